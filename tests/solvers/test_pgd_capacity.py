"""pgd's compiled program has a waypoint capacity (issue 23: speed a user feels): paths of any
length up to :func:`waypoint_capacity` run in one program, so a second run on a path of another
length loads it instead of compiling again; and the unused rows change nothing (bit for bit)."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
from pgd_cases import OPTS, STARTS

import jaxstiff
from jaxstiff.settings import PGDOptions
from jaxstiff.solvers._pgd import batch as pgd_batch
from jaxstiff.solvers._pgd.kernel import PGDKernel, waypoint_keys
from jaxstiff.solvers._problem import WaypointProblem


def test_waypoint_capacity_covers_the_path_with_few_sizes():
    caps = [pgd_batch.waypoint_capacity(P) for P in range(1, 300)]
    assert all(c >= P for c, P in zip(caps, range(1, 300), strict=True))
    assert all(c <= max(8, 2 * P - 1) for c, P in zip(caps, range(1, 300), strict=True))
    assert sorted(set(caps)) == [8, 16, 32, 64, 128, 256, 512]


def _kernel_args(problem, path, q0, P):
    """The kernel's arguments for the first P waypoints of path 0, the waypoint axis padded to P."""
    pts, dirs = np.asarray(path.points[0]), np.asarray(path.directions[0])
    n = pts.shape[0]
    pad = lambda a: np.concatenate([a, np.repeat(a[-1:], P - n, axis=0)])  # noqa: E731
    x0 = jnp.asarray(problem.x_of(q0[0], np.full(problem.robot.n, 50.0)))
    return (
        jnp.asarray(pad(pts)),
        jnp.asarray(pad(dirs)),
        x0,
        jnp.asarray(pad(np.asarray(waypoint_keys(jax.random.PRNGKey(7), n)))),  # the path's own keys, padded
        jnp.full((problem.n_free,), 0.1),
        jnp.asarray(5.0),
        jnp.asarray(1.0),
        jnp.asarray(100.0),
        jnp.asarray(3.0),
        jnp.asarray(0.01),
        jnp.asarray(1e-9),
        jnp.zeros((0, problem.nx)),
        jnp.int32(n),
    )


def test_rows_beyond_the_path_change_nothing(planar, planar_paths):
    # the same 5-waypoint path in programs of capacity 8 and 16: the same bits in its 5 rows (in
    # rollout mode the kept trajectory is chosen over the path's own waypoints only) and zeros after
    problem = WaypointProblem(planar, "xy", jaxstiff.f2)
    opts = {f: getattr(PGDOptions(), f) for f in PGDOptions.__dataclass_fields__}
    opts.update(OPTS, starts=STARTS)
    path, q0 = planar_paths(1, 5, seed=3)
    kern = jax.jit(PGDKernel(problem, opts, False).traj)
    a = kern(*_kernel_args(problem, path, q0, 8))
    b = kern(*_kernel_args(problem, path, q0, 16))
    for k in ("x", "f", "err", "status", "start"):
        np.testing.assert_array_equal(np.asarray(a[k])[:5], np.asarray(b[k])[:5], err_msg=k)
        if k != "start":  # rollout mode: start is the kept trajectory's index, in every row
            assert not np.any(np.asarray(b[k])[5:]), k  # never computed
    assert np.all(np.asarray(a["status"])[:5] == 0)


def test_paths_of_other_lengths_reuse_the_compiled_program(monkeypatch, planar_paths, run_planar):
    # pgd compiles (or loads) its chunk program for the arguments' shapes: a 5- and a 7-waypoint
    # batch must ask for the same shapes (capacity 8), so the second run reuses the program the
    # first compiled in this process (it does not even load it again)
    pgd_batch._PROGRAMS.clear()
    seen = []
    real = pgd_batch.compile_with_export_cache

    def spy(fn, args, key, options):
        seen.append(tuple(np.shape(a) for a in args))
        return real(fn, args, key, options)

    monkeypatch.setattr(pgd_batch, "compile_with_export_cache", spy)
    path5, q0 = planar_paths(2, 5, seed=1)
    path7, _ = planar_paths(2, 7, seed=1)
    r5, r7 = run_planar(path5, q0), run_planar(path7, q0)
    assert len(seen) == 1
    assert seen[0][0][1] == 8  # the waypoint axis at its capacity
    assert r5.P == 5 and r7.P == 7 and r5.q.shape[1] == 5 and r7.q.shape[1] == 7
    assert np.all(r5.status == 0) and np.all(r7.status == 0)


def test_chunk_keys_are_each_paths_own_split_padded_with_its_last_key():
    base = jax.random.PRNGKey(3)
    data = np.array([11, 12, 13], dtype=np.uint32)
    P, cap = 5, 8
    got = np.asarray(pgd_batch.chunk_keys(base, data, P, cap))
    assert got.shape == (3, cap, 2)
    for i, d in enumerate(data):
        # independent of waypoint_keys: split(fold_in(base, d), P + 1), the first waypoint the last key
        k = np.asarray(jax.random.split(jax.random.fold_in(base, d), P + 1))
        want = np.concatenate([k[P:], k[1:P], np.repeat(k[P - 1 : P], cap - P, axis=0)])
        np.testing.assert_array_equal(got[i], want)
