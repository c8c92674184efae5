"""pgd's first waypoint as the scan's first step (one traced and compiled waypoint program,
issue 23) computes what the separate first-waypoint program computed: the same states, criteria,
position errors and statuses on the LWR with given first-waypoint starts, f2 and f1."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxstiff
from jaxstiff.ik import ik_position
from jaxstiff.settings import PGDOptions
from jaxstiff.solvers._pgd.kernel import PGDKernel
from jaxstiff.solvers._problem import WaypointProblem


def _run(kernel: PGDKernel, args: tuple) -> dict:
    return jax.jit(kernel.traj)(*args)


@pytest.mark.parametrize(
    "crit", ["f2", pytest.param("f1", marks=pytest.mark.slow)]
)  # f1 in the slow lane: same program shape
def test_one_program_equals_two_programs(crit):
    robot = jaxstiff.Robot.from_urdf("kuka_lwr4", locked={"lwr_a7": 0.0})
    problem = WaypointProblem(robot, "full", getattr(jaxstiff, crit))
    opts = {f: getattr(PGDOptions(), f) for f in PGDOptions.__dataclass_fields__}
    opts.update(starts=3, iters=6, iters_first=12, iters_lm=4, lm_iters=3, lm_iters_first=5, polish=2)
    p = jaxstiff.default_path()
    P = 5
    targets, dirs = jnp.asarray(p.points[:P]), jnp.asarray(p.directions[:P])
    q0, _ = ik_position(robot, np.asarray(p.points[0]), q_start=np.radians([0, 30, 0, -60, 0, 60, 0]))
    x0 = jnp.asarray(problem.x_of(q0, np.full(robot.n, 50.0)))
    rng = np.random.default_rng(0)
    extra = jnp.asarray(np.asarray(x0)[None, :] + rng.uniform(-0.05, 0.05, size=(1, x0.size)))
    args = (
        targets,
        dirs,
        x0,
        jax.random.PRNGKey(3),
        jnp.full((problem.n_free,), np.radians(2.0)),
        jnp.asarray(5.0),
        jnp.asarray(1.0),
        jnp.asarray(100.0),
        jnp.asarray(5.0),
        jnp.asarray(0.01),
        jnp.asarray(1e-9),
        extra,
    )
    one = PGDKernel(problem, opts, False)
    two = PGDKernel(problem, opts, False)
    assert one.one_program
    two.one_program = False  # the separate first-waypoint program, as before
    a, b = _run(one, args), _run(two, args)
    for k in ("x", "f", "err", "status", "start"):
        np.testing.assert_allclose(np.asarray(a[k]), np.asarray(b[k]), rtol=1e-12, atol=1e-13, err_msg=k)
    assert np.all(np.asarray(a["status"]) == 0)
