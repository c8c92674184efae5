"""What the solvers' programs compute their kinematics and reports with (issue 23, cold compile):
the scan over joints for chains of more than SOLVER_UNROLL_MAX_JOINTS joints, and one batched
report program. Checked against independent computations: numpy forward kinematics with a
finite-difference Jacobian, and the single-point report program per waypoint."""

from __future__ import annotations

import jax
import numpy as np
import pytest
from helpers import numpy_fk

import jaxstiff
from jaxstiff.model._kinematics_scan import SOLVER_UNROLL_MAX_JOINTS, solver_uses_scan
from jaxstiff.solvers._problem import WaypointProblem, compiled_report, report_rows, warm_report
from jaxstiff.solvers._problem.compiled import REPORT_ROWS
from jaxstiff.stiffness import f2


@pytest.mark.parametrize("name", ["kuka_lwr4", "planar_3r"])
def test_solver_kinematics_match_numpy_fk_and_finite_differences(name):
    robot = jaxstiff.Robot.from_urdf(name)
    assert solver_uses_scan(robot) == (robot.n > SOLVER_UNROLL_MAX_JOINTS)
    prob = WaypointProblem(robot, "full", f2)
    rng = np.random.default_rng(3)
    q = rng.uniform(robot.lower * 0.8, robot.upper * 0.8, size=(5, robot.n))
    with jax.enable_x64(True):
        p, J = jax.jit(jax.vmap(prob.kinematics))(q)
    h = 1e-6
    for k in range(len(q)):
        T = numpy_fk(robot, q[k])
        np.testing.assert_allclose(np.asarray(p[k]), T[:3, 3], atol=1e-12)
        for i in range(robot.n):
            dq = np.zeros(robot.n)
            dq[i] = h
            dp = (numpy_fk(robot, q[k] + dq)[:3, 3] - numpy_fk(robot, q[k] - dq)[:3, 3]) / (2 * h)
            np.testing.assert_allclose(np.asarray(J[k, :3, i]), dp, atol=1e-8)


def test_batched_report_equals_the_single_point_report_and_does_not_depend_on_the_batch():
    robot = jaxstiff.Robot.from_urdf("kuka_lwr4", locked={"lwr_a7": 0.0})
    prob = WaypointProblem(robot, "full", f2)
    rng = np.random.default_rng(7)
    N = REPORT_ROWS + 37  # two calls, the second padded
    q = rng.uniform(robot.lower * 0.8, robot.upper * 0.8, size=(N, robot.n))
    q[:, 6] = 0.0
    kj = rng.uniform(1.0, 100.0, size=(N, robot.n))
    X = prob.x_of(q, kj)
    d = rng.normal(size=(N, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    prm = np.stack([WaypointProblem.params(rng.normal(size=3), d[i], 5.0, 0.01) for i in range(N)])
    with jax.enable_x64(True):
        out = report_rows(prob, X, prm)
        single = compiled_report(prob)
        ref = np.stack([np.asarray(single(X[i], prm[i])) for i in range(N)])
        alone = report_rows(prob, X[40:43], prm[40:43])
    assert out.shape == ref.shape and np.all(np.isfinite(out))
    np.testing.assert_allclose(out, ref, rtol=1e-11, atol=1e-9)
    np.testing.assert_array_equal(alone, out[40:43])  # a row's bits whatever else is reported with it
    assert report_rows(prob, X[:0], prm[:0]).shape == (0, out.shape[1])


def test_report_warm_up_gives_the_same_report_and_survives_any_robot():
    """warm_report compiles the report program on a thread while the solve runs: report_rows then
    waits for it and gives the bits it gives without a warm-up; a chain with continuous joints
    (infinite limits) and prismatic ones, and a criterion of the user's own, warm up without error."""
    import threading

    from jaxstiff.model._generate import serial_chain

    robot = serial_chain(5, seed=4)  # joint 3 continuous, joints 2 and 4 prismatic
    assert np.isinf(robot.lower[3]) and 1 in robot.joint_types

    def mine(K, d, r):
        return f2(K, d, r)

    for crit in (f2, mine):
        prob = WaypointProblem(robot, "full", crit)
        rng = np.random.default_rng(1)
        q = np.clip(rng.normal(size=(9, robot.n)), np.maximum(robot.lower, -2), np.minimum(robot.upper, 2))
        X = prob.x_of(q, rng.uniform(1.0, 50.0, size=(9, robot.n)))
        prm = np.stack([WaypointProblem.params(rng.normal(size=3), [0.0, 0.0, 1.0], 3.0, 0.01) for _ in range(9)])
        with jax.enable_x64(True):
            plain = report_rows(prob, X, prm)
            warm_report(prob)
            warmed = report_rows(prob, X, prm)
        # report_rows waited for the warm-up thread
        assert not [t for t in threading.enumerate() if t.name == "jaxstiff-report-warm-up" and t.is_alive()]
        np.testing.assert_array_equal(warmed, plain)
        assert np.all(np.isfinite(plain))


_WARM_EXIT_SCRIPT = """
import atexit
import threading

import jaxstiff
from jaxstiff.solvers._problem import WaypointProblem, warm_report
from jaxstiff.stiffness._criteria import f2

robot = jaxstiff.Robot.from_urdf("kuka_lwr4", locked={"lwr_a7": 0.0})
warm_report(WaypointProblem(robot, "full", f2))
names = lambda: sorted(t.name for t in threading.enumerate() if t.name.startswith("jaxstiff-report"))
print("started", names(), flush=True)
atexit.register(lambda: print("at exit", names(), flush=True))
"""


def test_the_report_warm_up_is_waited_for_at_exit():
    """A process that ends while the report's warm-up compiles waits for it (a daemon thread stopped
    by the interpreter's finalisation inside JAX can abort the process): by the time the exit
    handlers run, the warm-up thread has ended."""
    import subprocess
    import sys

    r = subprocess.run([sys.executable, "-c", _WARM_EXIT_SCRIPT], capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, (r.returncode, r.stderr[-3000:])
    assert "started ['jaxstiff-report-warm-up']" in r.stdout, r.stdout
    assert "at exit []" in r.stdout, r.stdout
