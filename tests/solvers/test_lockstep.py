"""Solves advanced in lockstep with batched evaluations (jaxstiff.solvers._lockstep, issue 23):
the same results as each solve run alone (toy Newton solves against numpy's closed form, and
SLSQP waypoint solves against the same solver called directly), bucketed batch sizes, exceptions;
and the hybrid on a batch: each path's result as when it is solved alone, and the polish skip
(``polish_skip_tol``) against polishing everything."""

from __future__ import annotations

import numpy as np
import pytest
from pgd_cases import OPTS

import jaxstiff
from jaxstiff.results import _files as R
from jaxstiff.solvers import _lockstep as lockstep
from jaxstiff.solvers._greedy import kernel_objective
from jaxstiff.solvers._problem import WaypointProblem, compiled_scaled_rows
from jaxstiff.solvers._slsqp import make_slsqp_solver


def newton_sqrt(a: float, iters: int):
    """sqrt(a) by Newton steps, each step's f(y) = y^2 - a and f'(y) asked for as a request."""
    y = np.array([max(a, 1.0)])
    for _ in range(iters):
        out = yield (y.copy(), np.array([a]))
        y = y - out[0] / out[1]
    return float(y[0])


def _evaluate(Y: np.ndarray, Pm: np.ndarray) -> np.ndarray:
    return np.stack([Y[:, 0] ** 2 - Pm[:, 0], 2 * Y[:, 0]], axis=1)


def test_lockstep_gives_each_solve_its_own_result():
    a = [2.0, 9.0, 0.25, 1e4, 7.0]
    iters = [3, 30, 12, 25, 1]  # different lengths: solves end in different rounds
    sizes: list[int] = []

    def evaluate(Y, Pm):
        sizes.append(Y.shape[0])
        return _evaluate(Y, Pm)

    got = lockstep.run_lockstep([newton_sqrt(x, n) for x, n in zip(a, iters, strict=True)], evaluate)
    alone = [
        lockstep.run_steps(newton_sqrt(x, n), lambda r: _evaluate(r[0][None], r[1][None])[0])
        for x, n in zip(a, iters, strict=True)
    ]
    assert got == alone
    np.testing.assert_allclose(got[1:4], np.sqrt(a[1:4]), rtol=1e-12)
    assert set(sizes) == {16} and len(sizes) == max(iters)  # 1-5 requests: the smallest bucket


def test_gathered_solves_share_rounds_and_keep_their_results():
    """``gather`` runs independent solves side by side inside one lockstep generator: each gets
    its closed-form answer, the generator gets them in its own order, and its rounds are as many
    as its longest solve's (5 and 8 Newton steps: 8 rounds, not 13); nested and empty gathers;
    ``run_steps`` answers gathered requests one by one with the same results."""
    calls: list[int] = []

    def counting(Y: np.ndarray, Pm: np.ndarray) -> np.ndarray:
        calls.append(len(Y))
        return _evaluate(Y, Pm)

    def two_then_one(a: float, b: float, c: float):
        first = yield from lockstep.gather([newton_sqrt(a, 5), newton_sqrt(b, 8)])
        nested = yield from lockstep.gather([lockstep.gather([newton_sqrt(c, 3)]), lockstep.gather([])])
        return first, nested

    (first, nested), alone = lockstep.run_lockstep([two_then_one(2.0, 9.0, 16.0), newton_sqrt(5.0, 4)], counting)
    assert len(calls) == 8 + 3
    np.testing.assert_allclose(first, [np.sqrt(2.0), 3.0], rtol=1e-6)
    assert nested[1] == [] and nested[0] == lockstep.run_lockstep([newton_sqrt(16.0, 3)], _evaluate)
    assert np.isclose(alone, np.sqrt(5.0), rtol=1e-6)
    # driven alone, one request at a time: the same numbers
    one_by_one = lockstep.run_steps(two_then_one(2.0, 9.0, 16.0), lambda req: _evaluate(req[0][None], req[1][None])[0])
    assert one_by_one == (first, nested)


def test_bucket_sizes():
    assert [lockstep.bucket_size(r) for r in (1, 2, 3, 16, 17, 128, 129, 1000)] == [
        16,
        16,
        16,
        16,
        128,
        128,
        256,
        1024,
    ]


@pytest.mark.parametrize("n, R", [(1, 16), (5, 16), (16, 16), (44, 128), (130, 256)])
def test_a_round_fills_its_rows_as_stacking_its_requests_would(n, R):
    """A round's arguments written into one buffer: the same arrays as stacking the requests and
    repeating the last one (the construction run_lockstep used before), dtype included."""
    rng = np.random.default_rng(n)
    reqs = [(rng.normal(size=7), rng.normal(size=8)) for _ in range(n)]
    Y, Pm = lockstep._fill(reqs, R)
    rows = reqs + [reqs[-1]] * (R - n)
    Y_ref, P_ref = np.stack([r[0] for r in rows]), np.stack([r[1] for r in rows])
    assert Y.dtype == Y_ref.dtype and Pm.dtype == P_ref.dtype
    assert np.array_equal(Y, Y_ref) and np.array_equal(Pm, P_ref)


@pytest.mark.parametrize("name", ["kuka_lwr4", "planar_3r"])
def test_a_row_has_the_same_bits_at_every_bucket_size(name):
    """The lockstep answers a round with whichever compiled row count is ready (RowsProgram), so a
    row's values must not depend on the row count: checked at 16, 128 and 1024 rows on random
    postures, stiffnesses and targets, and through a RowsProgram: a round of 300 rows (pieces of
    128 on threads) and a few points alone (``at_points``, the first-waypoint search's criterion). (At 2 rows XLA:CPU gave other last bits on 6 % of a hybrid
    run's evaluations, and a path's result then depended on the order its programs compiled in.)"""
    robot = jaxstiff.Robot.from_urdf(name)
    task = "xy" if name == "planar_3r" else "full"
    problem = WaypointProblem(robot, task, jaxstiff.f2)
    rng = np.random.default_rng(3)
    k = 16
    q = rng.uniform(robot.lower, robot.upper, (k, robot.n))
    kj = rng.uniform(5.0, 100.0, (k, robot.n))
    Y = np.stack([problem.x_of(qi, ki) for qi, ki in zip(q, kj, strict=True)])
    d = rng.normal(size=(k, 3))
    d[:, 2] *= task != "xy"
    Pm = np.stack(
        [
            WaypointProblem.params(rng.normal(size=3), di / np.linalg.norm(di), float(r), 0.0)
            for di, r in zip(d, rng.uniform(2.0, 8.0, k), strict=True)
        ]
    )
    rows = compiled_scaled_rows(problem)
    scale = np.abs(rng.normal(size=Y.shape[1] + 1)) + 0.5
    out = {
        R: np.asarray(rows(np.r_[Y, np.repeat(Y[-1:], R - k, 0)], np.r_[Pm, np.repeat(Pm[-1:], R - k, 0)], scale))[:k]
        for R in (16, 128, 1024)
    }
    assert np.all(np.isfinite(out[16]))
    np.testing.assert_array_equal(out[16], out[128])
    np.testing.assert_array_equal(out[16], out[1024])
    prog = lockstep.RowsProgram(rows, scale)
    n = prog.rows_for(lockstep.bucket_size(300), Y.shape[1], Pm.shape[1])
    assert n == 384
    big = np.asarray(prog(np.r_[Y, np.repeat(Y[-1:], n - k, 0)], np.r_[Pm, np.repeat(Pm[-1:], n - k, 0)]))
    assert big.shape[0] == n
    np.testing.assert_array_equal(big[:k], out[16])
    np.testing.assert_array_equal(big[k:], np.repeat(out[16][-1:], n - k, 0))
    np.testing.assert_array_equal(prog.at_points(Y[3:6], Pm[3:6], scale), out[16][3:6])


def test_an_exception_in_one_solve_propagates_and_closes_the_others():
    closed = []

    def ok():
        try:
            yield (np.zeros(1), np.zeros(1))
            yield (np.zeros(1), np.zeros(1))
        finally:
            closed.append("ok")
        return 1

    def bad():
        yield (np.zeros(1), np.zeros(1))
        raise FloatingPointError("from the solve")

    with pytest.raises(FloatingPointError, match="from the solve"):
        lockstep.run_lockstep([ok(), bad()], lambda Y, P: np.zeros((Y.shape[0], 1)))
    assert closed == ["ok"]


def test_slsqp_solves_in_lockstep_equal_the_solver_called_alone():
    robot = jaxstiff.Robot.from_urdf("kuka_lwr4", locked={"lwr_a7": 0.0})
    problem = WaypointProblem(robot, "full", jaxstiff.f2)
    solver = make_slsqp_solver(problem)
    q = np.radians([5.0, 35.0, -5.0, -70.0, 10.0, 50.0, 0.0])
    rng = np.random.default_rng(1)
    cases = []
    for i in range(5):
        qi = q + rng.uniform(-0.2, 0.2, 7) * [1, 1, 1, 1, 1, 1, 0]
        target = np.asarray(robot.fk(qi))[:3, 3]
        x0 = problem.x_of(qi + rng.uniform(-0.02, 0.02, 7) * [1, 1, 1, 1, 1, 1, 0], np.full(7, 30.0 + 5 * i))
        box = np.r_[np.full(6, 0.1), np.full(6, 10.0)]  # a rate-limit box, as at a later waypoint
        lb = np.maximum(x0 - box, np.r_[robot.lower[:6], np.full(6, 1.0)])
        ub = np.minimum(x0 + box, np.r_[robot.upper[:6], np.full(6, 100.0)])
        d = rng.normal(size=3)
        params = WaypointProblem.params(target, d / np.linalg.norm(d), 5.0, 0.0)
        cases.append((x0, lb, ub, params))
    alone = [solver(*c) for c in cases]
    rows = compiled_scaled_rows(problem)
    together = lockstep.run_lockstep([solver.steps(*c) for c in cases], lambda Y, Pm: rows(Y, Pm, solver.scale))
    objective = kernel_objective(problem)
    for a, t, c in zip(alone, together, cases, strict=True):
        # batched rows round differently in the last bits than the single-point kernel, and f2's
        # optima are sets of postures: compare the criterion reached and the exit codes
        assert t.code == a.code == 0
        assert objective(t.x, c[3]) == pytest.approx(objective(a.x, c[3]), rel=1e-7, abs=1e-9)
        assert objective(t.x, c[3]) < objective(c[0], c[3])
    assert sum(t.nfev for t in together) > 5 * 3  # the solves really iterated


@pytest.mark.slow  # two hybrid solves; the fast lane keeps the lockstep-equals-alone check
@pytest.mark.filterwarnings("ignore::jaxstiff.results._target.MissedTargetWarning")
def test_hybrid_path_result_does_not_depend_on_its_batch(planar_paths, run_planar):
    path, q0 = planar_paths(3, 5, seed=2)
    opts = {**OPTS, "polish_skip_tol": 0.0}
    both = run_planar(path, q0, solver="hybrid", options=opts)
    alone = run_planar(jaxstiff.Path(path.points[1:2], path.directions[1:2]), q0[1:2], solver="hybrid", options=opts)
    for k in ("q", "kj", "criterion", "status"):
        np.testing.assert_array_equal(getattr(both, k)[1], getattr(alone, k)[0], err_msg=k)


@pytest.mark.slow  # hybrid solves with and without the skip
@pytest.mark.filterwarnings("ignore::jaxstiff.results._target.MissedTargetWarning")
def test_polish_skip_keeps_the_criterion_and_saves_solves(monkeypatch, planar_paths, run_planar):
    from jaxstiff.solvers import _slsqp as slsqp

    # count the SLSQP solves the polish starts (a skipped waypoint's nfev is pgd's either way, and
    # the other paths' nfev may differ at rounding level between batch compositions)
    solves: list[int] = []
    make = slsqp.make_slsqp_solver

    def counting_solver(*args, **kwargs):
        solver = make(*args, **kwargs)
        steps = solver.steps

        def counted(*a, **k):
            solves.append(1)
            return (yield from steps(*a, **k))

        solver.steps = counted
        return solver

    monkeypatch.setattr(slsqp, "make_slsqp_solver", counting_solver)  # the polish imports it per call
    path, q0 = planar_paths(3, 6, seed=3)
    pg = run_planar(path, q0, options={**OPTS, "iters": 200, "iters_first": 400})
    full = run_planar(
        path, q0, solver="hybrid", options={**OPTS, "iters": 200, "iters_first": 400, "polish_skip_tol": 0.0}
    )
    n_full = len(solves)
    skip = run_planar(path, q0, solver="hybrid", options={**OPTS, "iters": 200, "iters_first": 400})
    n_skip = len(solves) - n_full
    from jaxstiff.settings._solvers import HybridOptions

    near = pg.criterion - 1.0 <= HybridOptions.defaults()["polish_skip_tol"]  # f2: least value 1
    assert near.any() and not near.all()  # the case exercises the skip and the polish
    # a path that pgd solved optimally everywhere is kept as it is, without a SLSQP solve
    for b in np.flatnonzero(near.all(axis=1)):
        np.testing.assert_array_equal(skip.criterion[b], pg.criterion[b])
        np.testing.assert_array_equal(skip.nfev[b], pg.nfev[b])
    # never worse than pgd per path (the greedy chain's guarantee), and fewer SLSQP solves: at
    # least one fewer per waypoint where pgd's point was already optimal
    usable = R.is_usable(pg.status).all(axis=1)
    assert np.all(skip.criterion.sum(axis=1)[usable] <= pg.criterion.sum(axis=1)[usable] * (1 + 1e-9) + 1e-12)
    assert np.all(full.criterion.sum(axis=1)[usable] <= pg.criterion.sum(axis=1)[usable] * (1 + 1e-9) + 1e-12)
    assert 0 < n_skip <= n_full - int(near.sum())


def test_rows_program_builds_smaller_row_counts_without_holding_the_run_up():
    """RowsProgram (the hybrid's rows kernel): the first row count is compiled at once; a smaller
    one is built on a background thread while the calls go, padded, to the larger program; once
    built it answers. Every program gives the same values; the solves' results equal numpy's
    closed form as with a plain evaluate."""
    import time

    import jax
    import jax.numpy as jnp

    @jax.jit
    def rows(Y, Pm, two):
        return jnp.stack([Y[:, 0] ** 2 - Pm[:, 0], two * Y[:, 0]], axis=1)

    prog = lockstep.RowsProgram(rows, jnp.asarray(2.0))
    with jax.enable_x64(True):
        assert prog.rows_for(128, 1, 1) == 128  # nothing built yet: compiled now
        assert prog.rows_for(16, 1, 1) == 128  # built on a thread meanwhile
        deadline = time.monotonic() + 120
        while prog.rows_for(16, 1, 1) != 16 and time.monotonic() < deadline:
            time.sleep(0.05)
        assert prog.rows_for(16, 1, 1) == 16
        assert prog.rows_for(1024, 1, 1) == 1024  # larger than every built one: compiled now
        Y, Pm = np.arange(16.0)[:, None], np.full((16, 1), 3.0)
        small = np.asarray(prog(Y, Pm))
        big = np.asarray(prog(np.r_[Y, np.repeat(Y[-1:], 112, 0)], np.r_[Pm, np.repeat(Pm[-1:], 112, 0)]))[:16]
        np.testing.assert_array_equal(small, big)
        np.testing.assert_array_equal(small, _evaluate(Y, Pm))
        a = [2.0, 9.0, 0.25, 1e4, 7.0] * 5
        gens = [newton_sqrt(v, 30) for v in a]
        got = lockstep.run_lockstep(gens, lockstep.RowsProgram(rows, jnp.asarray(2.0)))
    np.testing.assert_allclose(got, np.sqrt(a), rtol=1e-12)


class _CountingJit:
    """A jitted function whose ``lower`` counts its calls (one per compiled row count) and can be
    made to fail."""

    def __init__(self, fn, fail=False):
        import jax

        self.fn, self.fail, self.lowered = jax.jit(fn), fail, []

    def lower(self, *args):
        self.lowered.append(args[0].shape[0])
        if self.fail:
            raise RuntimeError("no compiler today")
        return self.fn.lower(*args)


def test_a_prepared_row_count_is_built_once_and_waited_for():
    """RowsProgram.prepare builds a row count on a background thread; a round that needs it before
    it is ready waits for that build instead of compiling it a second time. A failed background
    build is not started again, and the round that needs it compiles it and sees the error."""
    import jax
    import jax.numpy as jnp

    def rows(Y, Pm, two):
        return jnp.stack([Y[:, 0] ** 2 - Pm[:, 0], two * Y[:, 0]], axis=1)

    with jax.enable_x64(True):
        fn = _CountingJit(rows)
        prog = lockstep.RowsProgram(fn, jnp.asarray(2.0))
        prog.prepare(5, 1, 1)  # a round of 5 requests: the 16-row program
        assert prog.rows_for(16, 1, 1) == 16
        prog.prepare(3, 1, 1)  # ready: nothing more to build
        assert prog.rows_for(lockstep.bucket_size(300), 1, 1) == 384  # pieces of 128: that program now
        assert sorted(fn.lowered) == [16, 128]
        Y = np.linspace(0.5, 3.0, 384)[:, None]
        Pm = np.full((384, 1), 3.0)
        got = np.asarray(prog(Y, Pm))  # three pieces of 128 rows, on threads
        np.testing.assert_allclose(got, _evaluate(Y, Pm), rtol=1e-14)
        one = fn.fn.lower(Y[:128], Pm[:128], jnp.asarray(2.0)).compile()
        for s in (0, 128, 256):  # each piece has the bits of a call of its own
            np.testing.assert_array_equal(got[s : s + 128], np.asarray(one(Y[s : s + 128], Pm[s : s + 128], 2.0)))

        bad = _CountingJit(rows, fail=True)
        prog = lockstep.RowsProgram(bad, jnp.asarray(2.0))
        prog.prepare(16, 1, 1)
        with pytest.raises(RuntimeError, match="no compiler today"):
            prog.rows_for(16, 1, 1)  # waits for the failed build, then compiles here: the error
        prog.prepare(16, 1, 1)  # failed once in the background: not started again
        assert bad.lowered == [16, 16]


_EXIT_SCRIPT = """
import atexit

import jax
import jax.numpy as jnp

from jaxstiff.solvers import _lockstep as lockstep


def rows(Y, params, k):
    out = Y
    for i in range(300):  # a program that takes seconds to compile
        out = jnp.sin(out * (1.0 + i * 1e-3)) + k * jnp.tanh(params[:, :1] * (i + 1.0))
    return out


prog = lockstep.RowsProgram(jax.jit(rows), jnp.asarray(2.0))
assert prog.rows_for(16, 3, 2) == 16  # the first row count: compiled at once
assert prog.rows_for(2, 3, 2) == 16  # 2 rows: compiled on a background thread, 16 answers meanwhile
# at exit (after the interpreter has waited for its non-daemon threads): which program answers now
atexit.register(lambda: print("at exit, 2 rows run on", prog.rows_for(2, 3, 2), flush=True))
"""


@pytest.mark.slow  # a subprocess that compiles from scratch
def test_a_process_that_ends_during_a_background_compile_waits_for_it():
    """The interpreter ends while a smaller row count is being compiled on the background thread
    (a script that returns right after a hybrid solve). The thread must be waited for: a daemon
    thread was stopped by the interpreter's finalisation, and where that happened inside JAX's
    lowering or XLA's compiler the process aborted ("FATAL: exception not rethrown", exit status
    134, after every cold 64 x 50 hybrid run of a script). Waited for, the 2-row program is ready
    when the exit handlers run; not waited for, the 16-row one still answers there."""
    import subprocess
    import sys

    r = subprocess.run([sys.executable, "-c", _EXIT_SCRIPT], capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, (r.returncode, r.stderr[-3000:])
    assert "at exit, 2 rows run on 2" in r.stdout, (r.stdout, r.stderr[-3000:])
