"""Greedy SLSQP's target step (SLSQP option ``target_step="lm"``, the default): at a rate-limited
waypoint, Levenberg-Marquardt onto the zero set of the f1/f2 residuals first, kept only where the
answer is usable with the criterion at its least value; SLSQP elsewhere.

Checked against independent things: numpy's re-check of every reported value and limit
(``jaxstiff.results.verify``), the least value of f2 (1, a closed form: alpha = 0 and rho = r), a
per-waypoint numpy recomputation of alpha and rho from the stored posture and stiffness, and
SLSQP alone (``target_step="none"``) on the same inputs."""

from __future__ import annotations

import numpy as np
import pytest

import jaxstiff
from jaxstiff.results import verify
from jaxstiff.solvers import SLSQP
from jaxstiff.solvers import _slsqp as slsqp_module
from jaxstiff.solvers._problem import WaypointProblem
from jaxstiff.solvers._problem.target_step import target_step

LWR = jaxstiff.Robot.from_urdf("kuka_lwr4", locked={"lwr_a7": 0.0})


def _path(P: int = 16):
    p = jaxstiff.default_path()
    return jaxstiff.Path(p.points[:P], p.directions[:P])


def _shape(step: str, path=None, **kw):
    return jaxstiff.shape(LWR, _path() if path is None else path, "f2", 5.0, solver=SLSQP(target_step=step), **kw)


def _alpha_rho(robot, q, kj, d):
    """Numpy: the translational stiffness of the stored state, its major axis' angle to d (deg)
    and its axis ratio (largest over middle eigenvalue)."""
    J = np.asarray(jaxstiff.jacobian(robot, q))
    C = J @ np.diag(1.0 / kj) @ J.T
    K = np.linalg.inv(C[:3, :3] - C[:3, 3:] @ np.linalg.solve(C[3:, 3:], C[3:, :3]))
    w, V = np.linalg.eigh(K)
    cosang = abs(V[:, -1] @ d) / np.linalg.norm(d)
    return np.degrees(np.arccos(min(cosang, 1.0))), w[-1] / w[-2]


def test_reaches_the_least_value_where_slsqp_alone_stops_short():
    lm, sl = _shape("lm"), _shape("none")
    for res in (lm, sl):
        assert np.all(res.status == 0) and np.all(res.in_target)
        report = verify(res)
        assert report["max_pos_error"] <= 1e-9 and report["max_bound_violation"] <= 1e-12
        assert report["max_rate_violation"] <= 1e-12 and report["max_criterion_mismatch"] <= 1e-9
    gap_lm, gap_sl = lm.criterion[0, 1:] - 1.0, sl.criterion[0, 1:] - 1.0
    # f2's least value is 1; the target step reaches it to 1e-9 at most rate-limited waypoints
    assert np.all(gap_lm >= -1e-12)
    assert np.mean(gap_lm <= 1e-9) >= 0.8
    assert np.mean(gap_lm) < 0.1 * np.mean(gap_sl)
    # the waypoint 0 search (no rate limit) is SLSQP's in both runs
    np.testing.assert_array_equal(lm.q[0, 0], sl.q[0, 0])
    # the reported alpha and rho are what the stored states give (numpy, from the URDF's chain)
    d = np.asarray(_path().directions)
    for p in range(1, lm.q.shape[1]):
        alpha, rho = _alpha_rho(LWR, lm.q[0, p], lm.kj[0, p], d[p])
        assert alpha <= 1e-3 and rho == pytest.approx(5.0, rel=1e-6)


@pytest.mark.parametrize("bad", ["nan", "start", "raises"])
def test_an_answer_off_the_least_value_is_not_kept(monkeypatch, bad):
    """A target step whose answer is not finite, is only the start (on the previous waypoint's
    target, off the least value here), or raises: SLSQP solves the waypoint as without it, so the
    result is bit for bit SLSQP's alone."""

    def fake_factory(problem, kspan):
        def step(x, lb, ub, target, d, r):
            if bad == "raises":
                raise FloatingPointError("no")
            return np.full_like(x, np.nan) if bad == "nan" else np.asarray(x, float)

        return step

    monkeypatch.setattr(slsqp_module, "target_step", fake_factory)
    path = _path(6)
    faked, sl = _shape("lm", path), _shape("none", path)
    for name in ("q", "kj", "status", "criterion", "nit", "nfev"):
        np.testing.assert_array_equal(getattr(faked, name), getattr(sl, name), err_msg=name)


def test_no_target_step_for_a_criterion_of_ones_own():
    """A registered criterion has no residuals whose zeros are its minimum set: no target step."""

    def mine(K, d, r, c=0.01):
        return 2.0 * jaxstiff.f2(K, d, r, c)  # the same minimum set, but not f2 itself

    name = "target_step_test_criterion"
    jaxstiff.register_criterion(name, mine, overwrite=True)
    prob = WaypointProblem(LWR, "full", jaxstiff.get_criterion(name))
    assert target_step(prob, 99.0) is None
    assert target_step(WaypointProblem(LWR, "full", jaxstiff.f2), 99.0) is not None


def test_solvers_without_a_target_step_refuse_to_be_given_one():
    """slsqp-fd (the seed's method) and the hybrid's SLSQP polish have no target step: asked for
    one, they say so instead of recording an option they do not use; unset (None) they run."""
    from jaxstiff.solvers import SLSQPFD, Hybrid

    path = _path(3)
    for solver in (SLSQPFD(target_step="lm"), Hybrid(slsqp=SLSQP(target_step="lm"))):
        with pytest.raises(ValueError, match=r"target_step='lm' is slsqp's: .* has no target step"):
            jaxstiff.shape(LWR, path, "f2", 5.0, solver=solver)
    res = jaxstiff.shape(LWR, path, "f2", 5.0, solver=SLSQPFD())
    assert res.meta["options"]["target_step"] == "auto" and np.all(res.status == 0)


_EXIT_SCRIPT = """
import atexit, os, threading
os.environ["JAXSTIFF_COMPILE_CACHE"] = "0"
import jax
jax.config.update("jax_enable_x64", True)
import jaxstiff
from jaxstiff.solvers._problem import WaypointProblem
from jaxstiff.solvers._problem.target_step import target_step
robot = jaxstiff.Robot.from_urdf("kuka_lwr4", locked={"lwr_a7": 0.0})
target_step(WaypointProblem(robot, "full", jaxstiff.f2), 99.0)
names = lambda: sorted(t.name for t in threading.enumerate() if t.name.startswith("jaxstiff-target"))
print("started", names(), flush=True)
atexit.register(lambda: print("at exit", names(), flush=True))
"""


def test_a_process_that_ends_while_the_program_compiles_waits_for_it():
    """The target step's program compiles on a thread; a script that ends first (a one-waypoint
    solve, an exception) waits for it: a daemon thread stopped inside XLA's compiler by the
    interpreter's finalisation can abort the process. By the exit handlers the thread has ended."""
    import subprocess
    import sys

    r = subprocess.run([sys.executable, "-c", _EXIT_SCRIPT], capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, (r.returncode, r.stderr[-3000:])
    assert "started ['jaxstiff-target-step']" in r.stdout and "at exit []" in r.stdout, r.stdout


def test_no_program_where_no_waypoint_is_rate_limited(monkeypatch):
    """One waypoint whose box has no rate limit: nothing for the step to do, so nothing is compiled."""
    built = []
    monkeypatch.setattr(slsqp_module, "target_step", lambda *a: built.append(a))
    res = _shape("lm", _path(1))
    assert built == [] and res.status[0, 0] == 0
    _shape("lm", _path(2))
    assert len(built) == 1
