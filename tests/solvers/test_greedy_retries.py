"""Greedy SLSQP's retries where a rate-limited waypoint ends off target (option ``path_retries``):
starts inside the waypoint's box, and the walk again from the first waypoint's other optima.

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
from jaxstiff.solvers._greedy import BOX_STARTS, box_starts


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
def test_a_retry_walk_stops_once_it_cannot_rank_better_with_the_same_result(trap, monkeypatch):
    """A retry walk whose unsolved and off-target counts already exceed the best walk's stops
    there: the same walk wins as when every retry walks the whole path, for fewer waypoints."""
    from jaxstiff.solvers import _greedy as G

    robot, path = trap
    solved = []
    real_waypoint, real_run = G._GreedyWalk._waypoint, G._GreedyWalk.run

    def counting(self, p, *a):
        solved.append(p)
        return real_waypoint(self, p, *a)

    monkeypatch.setattr(G._GreedyWalk, "_waypoint", counting)
    early = jaxstiff.shape(robot, path, "f2", 5.0, solver=SLSQP())
    n_early = len(solved)
    solved.clear()
    monkeypatch.setattr(
        G._GreedyWalk, "run", lambda self, first, progress, stop_above=None: real_run(self, first, progress)
    )
    full = jaxstiff.shape(robot, path, "f2", 5.0, solver=SLSQP())
    n_full = len(solved)
    for k in ("q", "kj", "criterion", "status"):
        np.testing.assert_array_equal(getattr(early, k), getattr(full, k))
    assert early.in_target.all()
    assert n_full > 2 * path.points.shape[0]  # retries ran (else this test proves nothing)
    assert n_early < n_full - path.points.shape[0] // 2


def test_a_path_in_target_is_walked_once(trap):
    robot, path = trap
    short = jaxstiff.Path(path.points[:8], path.directions[:8])  # in target before the trap
    a = jaxstiff.shape(robot, short, "f2", 5.0, solver=SLSQP(path_retries=0))
    b = jaxstiff.shape(robot, short, "f2", 5.0, solver=SLSQP())
    assert a.in_target.all()
    for k in ("q", "kj", "criterion", "status"):
        np.testing.assert_array_equal(getattr(a, k), getattr(b, k))


def test_box_starts_lie_in_the_box_and_depend_only_on_the_waypoint():
    rng = np.random.default_rng(3)
    lb = rng.uniform(-1, 0, 9)
    ub = lb + rng.uniform(0, 0.1, 9)
    ub[2] = lb[2]  # a side of zero width (a stiffness pinned at its bound)
    ref, target, direction = (lb + ub) / 2, np.array([0.5, 0.1, 0.3]), np.array([0.0, 1.0, 0.0])
    xs = box_starts(lb, ub, ref, target, direction)
    assert len(xs) == BOX_STARTS
    np.testing.assert_allclose(xs[0], (lb + ub) / 2)
    for x in xs:
        assert np.all(lb <= x) and np.all(x <= ub)
    assert len({x.tobytes() for x in xs}) == BOX_STARTS  # distinct
    again = box_starts(lb, ub, ref, target, direction)
    assert all(np.array_equal(a, b) for a, b in zip(xs, again, strict=True))
    other = box_starts(lb, ub, ref, target + 1e-3, direction)
    assert not np.array_equal(xs[1], other[1])


def test_path_retries_option_is_checked():
    with pytest.raises(ValueError, match="path_retries"):
        SLSQP(path_retries=-1)
    with pytest.raises(TypeError, match="path_retry"):
        SLSQP(path_retry=2)
