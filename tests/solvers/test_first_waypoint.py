"""Issue 37, item 2: the first waypoint (no rate limit) reaches the exact solver's optimum with pgd
and the hybrid, on a third-party arm with rotated joint frames (UR10, tip tool0) and on the
shipped LWR; and the missed-target warning names the first waypoint's own cause.

The reference is greedy SLSQP run in the same test (an independent solver: scipy's SLSQP on exact
JAX derivatives), never a stored number."""

import os
import warnings

import numpy as np
import pytest

import jaxstiff
from jaxstiff.model import fk
from jaxstiff.results._target import MissedTargetWarning, first_free_waypoints, missed_target_warning

UR10 = os.path.join(os.path.dirname(__file__), "..", "data", "robots", "ur10.urdf")


def _line(robot, q, direction, length=0.0167, P=2):
    """P waypoints from the TCP at q along ``direction`` (m), the tangent as desired direction."""
    p0 = np.asarray(fk(robot, np.asarray(q, float)))[:3, 3]
    return jaxstiff.Path(p0 + np.linspace(0.0, length, P)[:, None] * np.asarray(direction, float)[None])


def _ur10_stall_case():
    """The UR10 (tip tool0) along a 1.67 cm line in y from a posture 0.3 rad off mid-range: slsqp
    puts waypoint 0 in target, pgd's own stages leave it at rho 1.67. Which postures give such a
    case depends on the kinematics' last bits; the tests check the case's premise before using it."""
    robot = jaxstiff.Robot.from_urdf(UR10, tip_link="tool0")
    q = np.clip(0.5 * (robot.lower + robot.upper) + 0.3, robot.lower, robot.upper)
    return robot, _line(robot, q, [0.0, 1.0, 0.0])


def _shape(robot, path, solver):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", MissedTargetWarning)
        return jaxstiff.shape(robot, path, "f2", 5.0, solver=solver)


def _check_first_waypoint(robot, path, solvers):
    ref = _shape(robot, path, "slsqp")
    assert ref.status[0, 0] == 0
    assert ref.in_target[0, 0], "the case is meant to be one slsqp solves in target"
    for solver in solvers:
        res = _shape(robot, path, solver)
        assert res.status[0, 0] == 0
        rho, rho_ref = res.ratio[0, 0], ref.ratio[0, 0]
        assert abs(rho - rho_ref) <= 0.02 * rho_ref, (solver, rho, rho_ref)
        if solver == "hybrid":
            # the hybrid (SLSQP polish) reaches the optimum itself, not only the ratio: f2 within 2 %
            # of slsqp's. pgd's rollout keeps the start whose whole trajectory ranks best, which may
            # trade some alignment at waypoint 0 for the later waypoints (UR10 case: rho 5.000,
            # alpha 1.35 deg against slsqp's 0.88 deg), so pgd is held to the ratio (issue 37's line)
            assert res.criterion[0, 0] <= 1.02 * ref.criterion[0, 0], (solver, res.criterion[0, 0], ref.criterion[0, 0])


@pytest.mark.slow
def test_first_waypoint_ur10_tool0_matches_slsqp():
    """A straight line on the UR10 (tip tool0, rotated joint frames) where pgd's own first-waypoint
    stages stall (rho 1.67 with first_exact="none") and slsqp reaches rho 5.0 in target."""
    robot, path = _ur10_stall_case()
    _check_first_waypoint(robot, path, ("pgd", "hybrid"))


@pytest.mark.slow
def test_first_waypoint_lwr_matches_slsqp():
    robot = jaxstiff.Robot.from_urdf("kuka_lwr4", locked={"lwr_a7": 0.0})
    q = np.radians([20.0, 40.0, -10.0, -70.0, 15.0, 30.0, 0.0])
    _check_first_waypoint(robot, _line(robot, q, [1.0, 0.0, 0.0]), ("pgd",))


# ---------------------------------------------------------------------- the warning's cause
META = {"criterion": "f2", "solver": "pgd", "limits": {"kmin": 1.0, "kmax": 100.0, "first_rate_limit": False}}
NAMES = ["a1", "a2", "a3"]


def test_first_waypoint_miss_names_its_own_cause_not_look_ahead():
    status = np.zeros((1, 3), int)
    flag = np.array([[False, True, True]])  # only waypoint 0 misses
    kj = np.full((1, 3, 3), 50.0)
    kj[0, 0] = [1.0, 100.0, 37.0]  # the stiffness range is used end to end
    text = missed_target_warning(status, flag, META, kj, NAMES)
    assert text is not None and "path 0: waypoints 0" in text
    assert "look ahead" not in text
    assert "no rate limit" in text and "range binds" in text and "a1 at kmin" in text and "a2 at kmax" in text
    kj[0, 0] = [1.0, 60.0, 37.0]  # only kmin reached: the ratios are free, no bound holds the shape
    text = missed_target_warning(status, flag, META, kj, NAMES)
    assert text is not None and "local optimum" in text and "range binds" not in text and "look ahead" not in text


@pytest.mark.parametrize(
    ("solver", "named", "not_named"),
    [
        ("pgd", ("'slsqp'", "'hybrid'"), ()),
        ("slsqp", ("'hybrid'",), ("'slsqp'",)),
        ("hybrid", (), ("'slsqp'", "'hybrid'")),
    ],
)
def test_the_first_waypoint_advice_never_names_the_solver_that_ran(solver, named, not_named):
    """A user of slsqp was told that solver 'slsqp' may reach the target, and a hybrid's user 'hybrid';
    and a first waypoint whose shape the arm cannot give (an arm whose parallel joint axes fix one
    axis of the ellipsoid) was called a local optimum outright."""
    status, flag = np.zeros((1, 2), int), np.array([[False, True]])
    kj = np.full((1, 2, 3), 50.0)
    text = missed_target_warning(status, flag, {**META, "solver": solver}, kj, NAMES)
    assert text is not None and "local optimum" in text and "no posture gives" in text
    cause = text.split("has no rate limit", 1)[1]
    for s in named:
        assert f"solver {s}" in cause
    for s in not_named:
        assert f"solver {s}" not in cause


def test_the_look_ahead_advice_starts_trajectory_from_the_hybrid():
    """'try trajectory' alone sent an slsqp user to a trajectory warm-started from pgd, worse there
    (xArm6 10 % in target against slsqp's 33 %); the advice names the hybrid and trajectory from it."""
    status, flag = np.zeros((1, 3), int), np.array([[True, True, False]])
    text = missed_target_warning(status, flag, {**META, "solver": "slsqp"}, np.full((1, 3, 3), 50.0), NAMES)
    assert text is not None and "cannot look ahead" in text and "Trajectory(warm=Hybrid())" in text
    assert "try solver='trajectory'" not in text


def test_later_waypoints_keep_the_look_ahead_advice_and_first_gets_its_own():
    status = np.array([[3, 0, 0, 0]])  # waypoint 0 unusable: waypoint 1 is the first solved without rate limit
    flag = np.array([[False, False, True, False]])
    kj = np.full((1, 4, 3), 50.0)
    assert first_free_waypoints(status, META).tolist() == [1]
    text = missed_target_warning(status, flag, META, kj, NAMES)
    assert text is not None and "path 0: waypoints 1, 3" in text
    assert "path 0: waypoint 1 has no rate limit" in text and "local optimum" in text
    assert "cannot look ahead" in text  # waypoint 3 follows a rate-limited chain
    # a rate-limited first waypoint is one of the chain: the usual advice only
    limited = {**META, "limits": {**META["limits"], "first_rate_limit": True}}
    assert first_free_waypoints(status, limited).tolist() == [-1]
    text = missed_target_warning(status, flag, limited, kj, NAMES)
    assert text is not None and "no rate limit" not in text and "cannot look ahead" in text


def test_a_warning_about_many_paths_names_eight_and_groups_the_first_waypoint_causes():
    """On a third-party arm a 64-path pgd run missed the target on 34 paths, and the warning named
    each path's waypoints and each first waypoint's cause with its joints: one line of 10 kB.
    Beyond WARN_PATHS paths it names the first ones, counts the others, and gives the first
    waypoints' causes once per kind with the paths of each."""
    from jaxstiff.results._target import WARN_PATHS

    B, P = 20, 5
    status = np.zeros((B, P), int)
    flag = np.ones((B, P), bool)
    flag[:, 0] = False  # every path misses at its first waypoint ...
    flag[::2, 3] = False  # ... and the even paths at waypoint 3 too
    kj = np.full((B, P, 3), 50.0)
    kj[:12, 0] = [1.0, 100.0, 37.0]  # paths 0-11: the range binds; 12-19: a local optimum
    text = missed_target_warning(status, flag, META, kj, NAMES)
    assert text is not None
    assert text.startswith(f"{B + B // 2} of {B * P} usable waypoints miss the target")
    for b in range(WARN_PATHS):
        assert f"path {b}: waypoints {'0, 3' if b % 2 == 0 else '0'};" in text
    assert f"path {WARN_PATHS}: waypoints" not in text
    assert f"and {B - WARN_PATHS} more paths" in text
    assert "paths 0-11: the first waypoint has no rate limit" in text and "range binds" in text
    assert "paths 12-19: the first waypoint has no rate limit" in text and "local optimum" in text
    assert "a1 at kmin" not in text  # the joints are per path: not in the grouped form
    assert "the other waypoints: solver 'pgd' goes waypoint by waypoint and cannot look ahead" in text
    assert len(text) < 1200
    few = missed_target_warning(status[:WARN_PATHS], flag[:WARN_PATHS], META, kj[:WARN_PATHS], NAMES)
    assert few is not None and "more paths" not in few and "path 1: waypoint 0 has no rate limit" in few


# ---------------------------------------------------------------------- the retry's cost
@pytest.mark.slow
def test_retry_reruns_a_path_only_where_slsqp_found_a_lower_first_criterion(monkeypatch):
    """pgd's retry (option first_exact="retry") runs a path again only where greedy SLSQP's first
    waypoint has a lower criterion than pgd kept there: with SLSQP reporting nothing better (a
    target out of every solver's reach), no second run, and the result is pgd's own bit for bit;
    with its real answers, the path is run again (the UR10 case, where pgd's own stages stall)."""
    from jaxstiff.solvers import PGD
    from jaxstiff.solvers import _first_waypoint as fw
    from jaxstiff.solvers._pgd import batch as pgd_batch

    robot, path = _ur10_stall_case()
    runs = []
    real_run = pgd_batch._run_chunks
    monkeypatch.setattr(pgd_batch, "_run_chunks", lambda *a, **k: runs.append(1) or real_run(*a, **k))
    own = _shape(robot, path, PGD(first_exact="none"))
    assert len(runs) == 1
    assert abs(own.ratio[0, 0] - 5.0) > 0.1, "the case is meant to be one pgd's own stages leave off target"

    runs.clear()
    retried = _shape(robot, path, PGD())
    assert len(runs) == 2 and abs(retried.ratio[0, 0] - 5.0) <= 0.1  # the ratio reached (see _check_first_waypoint)

    real_answers = fw.exact_first_answers

    def nothing_better(*a, **k):
        out = real_answers(*a, **k)
        crit = a[4] if len(a) > 4 else k.get("criteria")
        if crit is not None:
            crit[:] = [np.inf] * len(crit)
        return out

    monkeypatch.setattr(fw, "exact_first_answers", nothing_better)
    runs.clear()
    skipped = _shape(robot, path, PGD())
    assert len(runs) == 1
    for k in ("q", "kj", "criterion", "status"):
        np.testing.assert_array_equal(getattr(skipped, k), getattr(own, k), err_msg=k)
