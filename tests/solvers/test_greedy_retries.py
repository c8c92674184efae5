"""Greedy SLSQP's retries where a rate-limited waypoint ends off target (option ``path_retries``):
the walk again from the first waypoint's other optima.

The trap (found beside CasADi + IPOPT's greedy, which stays in target there): the LWR along a
90 deg arc of 60 waypoints. From the first posture greedy SLSQP picks, waypoints 13-18 end off
target (f2 up to 1.33), while other postures of f2's optimal set at the first waypoint lead the
whole path in target. Every result is re-checked by ``results.verify`` (numpy: FK, bounds, rate
limits, criterion), independent of the solver."""

from __future__ import annotations

import numpy as np
import pytest

import jaxstiff
from jaxstiff.paths import arc
from jaxstiff.results import verify
from jaxstiff.results._target import MissedTargetWarning
from jaxstiff.solvers import SLSQP


@pytest.fixture(scope="module")
def trap():
    robot = jaxstiff.Robot.from_urdf("kuka_lwr4", locked={"lwr_a7": 0.0})
    R = 0.1 * min(robot.length_scale, 1.3)
    return robot, arc(np.array([0.6 - R, 0.0, 0.3]), R, -45.0, 45.0, n=60)


def _checked(res):
    v = verify(res)
    assert v["max_pos_error"] < 1e-9 and v["max_rate_violation"] <= 1e-9 and v["max_bound_violation"] <= 1e-9, v
    assert v["max_criterion_mismatch"] < 1e-6, v
    return res


@pytest.mark.slow
def test_the_walk_leaves_the_trap_from_another_first_optimum(trap):
    robot, path = trap
    with pytest.warns(MissedTargetWarning):
        seed_scheme = _checked(jaxstiff.shape(robot, path, "f2", 5.0, solver=SLSQP(path_retries=0)))
    retried = _checked(jaxstiff.shape(robot, path, "f2", 5.0, solver=SLSQP()))
    assert not seed_scheme.in_target.all()  # the trap is there without the retries (else this test proves nothing)
    assert retried.in_target.all()
    assert np.max(retried.criterion) < 1.1 <= np.max(seed_scheme.criterion)
    # the first waypoint is still at f2's minimum: another of its optimal postures, not a worse one
    assert abs(retried.criterion[0, 0] - seed_scheme.criterion[0, 0]) < 1e-6
    assert not np.allclose(retried.q[0, 0], seed_scheme.q[0, 0], atol=1e-2)


@pytest.mark.slow
@pytest.mark.parametrize("n", [60, 20])
def test_a_retry_walk_stops_once_it_cannot_rank_better_with_the_same_result(trap, monkeypatch, n):
    """The retry walks first look for one in target everywhere, each stopped at its first miss;
    where none is (n = 20: the rate limits bind, no walk is in target throughout), the stopped
    walks go on, each while it can still rank better than the best walk so far. The same walk
    wins as when every retry walks the whole path, for fewer waypoints."""
    from jaxstiff.results import _files as F
    from jaxstiff.solvers import _greedy as G

    robot, arc60 = trap
    R = 0.1 * min(robot.length_scale, 1.3)
    path = arc60 if n == 60 else arc(np.array([0.6 - R, 0.0, 0.3]), R, -45.0, 45.0, n=n)
    solved, resumed = [], []
    real_waypoint, real_run = G._GreedyWalk._waypoint, G._GreedyWalk.run

    def counting(self, p, *a):
        solved.append(p)
        return real_waypoint(self, p, *a)

    def noting(self, first, progress, stop=None, resume=None):
        resumed.append(resume is not None)
        return real_run(self, first, progress, stop, resume)

    monkeypatch.setattr(G._GreedyWalk, "_waypoint", counting)
    monkeypatch.setattr(G._GreedyWalk, "run", noting)
    reported = []
    early = jaxstiff.shape(robot, path, "f2", 5.0, solver=SLSQP(), progress=lambda b, p: reported.append(p))
    n_early = len(solved)
    assert reported == list(range(n))  # each waypoint once, in order, whichever walk is kept
    solved.clear()

    def every_walk_whole(batch, b, solver, pos_tol, progress, first_starts, first_maxiter, path_retries, target_step):
        """The rule written plainly: every walk to its end, the best by (unsolved, off target,
        sum of the criterion) kept, the first walk in target throughout ending the search."""
        walk = G._GreedyWalk(batch, b, solver, None, None, pos_tol, first_starts, first_maxiter, target_step)
        out, fs, alternatives = real_run(walk, None, None)
        bound = float(walk.bound)
        rank = G._walk_rank(out, fs, bound)
        if rank[1] == 0 or not (out[0].status in F.USABLE and fs[0] < bound):
            return out
        for alt in alternatives[:path_retries]:
            o2, f2s, _ = real_run(walk, alt, None)
            if G._walk_rank(o2, f2s, bound) < rank:
                out, rank = o2, G._walk_rank(o2, f2s, bound)
            if rank[1] == 0:
                break
        return out

    monkeypatch.setattr(G, "greedy_path", every_walk_whole)
    full = jaxstiff.shape(robot, path, "f2", 5.0, solver=SLSQP())
    n_full = len(solved)
    for k in ("q", "kj", "criterion", "status"):
        np.testing.assert_array_equal(getattr(early, k), getattr(full, k))
    assert n_full > 2 * n  # retries ran (else this test proves nothing)
    assert n_early < n_full
    if n == 60:
        assert n_early < n_full - n // 2
        assert early.in_target.all()
        assert not any(resumed)  # found in the first round
    else:
        assert not early.in_target.all()
        assert any(resumed)  # the stopped walks went on (else the second round is untested)


def test_a_path_in_target_is_walked_once(trap):
    robot, path = trap
    short = jaxstiff.Path(path.points[:8], path.directions[:8])  # in target before the trap
    a = jaxstiff.shape(robot, short, "f2", 5.0, solver=SLSQP(path_retries=0))
    b = jaxstiff.shape(robot, short, "f2", 5.0, solver=SLSQP())
    assert a.in_target.all()
    for k in ("q", "kj", "criterion", "status"):
        np.testing.assert_array_equal(getattr(a, k), getattr(b, k))


def test_path_retries_option_is_checked():
    with pytest.raises(ValueError, match="path_retries"):
        SLSQP(path_retries=-1)
    with pytest.raises(TypeError, match="path_retry"):
        SLSQP(path_retry=2)


@pytest.mark.slow
def test_an_interrupt_during_the_retries_keeps_the_first_walks_finished_waypoints(trap, monkeypatch):
    """The first walk stops at its first off-target waypoint while the other optima are tried: a
    Ctrl-C then keeps the waypoints it finished (checked by ``verify``), the rest NOT_RUN."""
    from jaxstiff.results import _files as R
    from jaxstiff.shaping import ShapeInterrupted
    from jaxstiff.solvers import _greedy as G

    robot, path = trap
    real_run, real_waypoint = G._GreedyWalk.run, G._GreedyWalk._waypoint
    walks = []

    def run(self, first, progress, stop=None, resume=None):
        walks.append(first is not None)
        return real_run(self, first, progress, stop, resume)

    def waypoint(self, p, *a):
        if any(walks):  # inside a retry walk
            raise KeyboardInterrupt
        return real_waypoint(self, p, *a)

    monkeypatch.setattr(G._GreedyWalk, "run", run)
    monkeypatch.setattr(G._GreedyWalk, "_waypoint", waypoint)
    with pytest.raises(ShapeInterrupted) as e:
        jaxstiff.shape(robot, path, "f2", 5.0, solver=SLSQP())
    res = e.value.result
    status = res.status[0]
    done = int(np.sum(status != R.NOT_RUN))
    assert 0 < done < path.points.shape[0]  # the first walk's finished part, up to its first miss
    assert np.all(status[done:] == R.NOT_RUN)
    assert np.all(np.isin(status[:done], list(R.USABLE)))
    assert not res.in_target[0, done - 1] and res.in_target[0, : done - 1].all()
    _checked(res)


def test_a_first_waypoint_above_its_least_value_is_polished_by_the_target_step(monkeypatch):
    """The LWR along the default path's first two waypoints with task xyz: greedy SLSQP's
    first-waypoint starts end 2 % and more above f2's least value (1); the target step from its
    answers reaches it. With the polish switched off the same call ends above it (else this test
    proves nothing); the result is re-checked by ``verify`` (numpy)."""
    from jaxstiff.solvers import _greedy as G

    robot = jaxstiff.Robot.from_urdf("kuka_lwr4", locked={"lwr_a7": 0.0})
    full = jaxstiff.default_path()
    two = jaxstiff.Path(full.points[:2], full.directions[:2])
    res = _checked(jaxstiff.shape(robot, two, "f2", 5.0, task="xyz", solver=SLSQP()))
    assert abs(res.criterion[0, 0] - 1.0) < 1e-9
    monkeypatch.setattr(G, "FIRST_POLISH_REL", float("inf"))
    bare = _checked(jaxstiff.shape(robot, two, "f2", 5.0, task="xyz", solver=SLSQP()))
    assert bare.criterion[0, 0] > 1.0 + 1e-3


def test_a_first_waypoint_at_its_least_value_is_left_as_slsqp_ends_it(monkeypatch):
    """Within FIRST_POLISH_REL of the least value the first waypoint is not polished (the README
    job's first waypoint, 1e-7 above it, keeps its bits): no target step runs there."""
    from jaxstiff.solvers import _greedy as G

    robot = jaxstiff.Robot.from_urdf("kuka_lwr4", locked={"lwr_a7": 0.0})
    full = jaxstiff.default_path()
    two = jaxstiff.Path(full.points[:2], full.directions[:2])
    calls = []
    real = G._GreedyWalk._target_step

    def counting(self, x, lb, ub, *a):
        calls.append(bool(np.all(ub - lb > 0.5)))  # the first waypoint's box is the whole range
        return real(self, x, lb, ub, *a)

    monkeypatch.setattr(G._GreedyWalk, "_target_step", counting)
    res = jaxstiff.shape(robot, two, "f2", 5.0, solver=SLSQP())
    assert 0 < res.criterion[0, 0] - 1.0 < G.FIRST_POLISH_REL
    assert calls and not any(calls)  # the rate-limited waypoint's step ran, the first waypoint had none
