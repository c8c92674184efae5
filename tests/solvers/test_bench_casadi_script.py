"""scripts/bench_casadi.py's CasADi formulation is jaxstiff's waypoint problem: on one rate-limited
waypoint of the LWR, IPOPT on the script's own symbolic model and jaxstiff's SLSQP reach the same
optimum, each answer feasible for the other's constraints, the criterion of each side equal at the
other's point; and the script's numpy check (its own FK and Jacobian) agrees with jaxstiff's.

Skipped without casadi (the ``bench`` extra)."""

from __future__ import annotations

import importlib.util
import math
import sys

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from helpers import REPO_ROOT

pytest.importorskip("casadi")


def _load_bench():
    """The script as a module, registered in ``sys.modules`` (its dataclasses look themselves up there)."""
    spec = importlib.util.spec_from_file_location("bench_casadi", REPO_ROOT / "scripts" / "bench_casadi.py")
    assert spec is not None and spec.loader is not None
    mod = importlib.util.module_from_spec(spec)
    sys.modules["bench_casadi"] = mod
    spec.loader.exec_module(mod)
    return mod


bench = _load_bench()


@pytest.mark.parametrize("key", list(bench.ROBOTS))
def test_numpy_check_kinematics_match_jaxstiff(key):
    """The checker's FK/Jacobian (this script's URDF reading) against jaxstiff's, random postures:
    a wrong fixed-joint fold, axis or rpy order would show here."""
    robot = bench.make_robot(key)
    urdf, kw = bench.ROBOTS[key]
    ch = bench.read_chain(urdf, robot.base_link, robot.tip_link, kw.get("locked"))
    assert ch.names == robot.joint_names
    rng = np.random.default_rng(1)
    lo = np.where(np.isfinite(robot.lower), robot.lower, -np.pi)
    hi = np.where(np.isfinite(robot.upper), robot.upper, np.pi)
    for _ in range(3):
        q = np.where(robot.free, rng.uniform(lo, hi), np.nan_to_num(robot.locked_values))
        p, J = bench.np_fk_jac(ch, q)
        np.testing.assert_allclose(p, np.asarray(robot.fk(q))[:3, 3], rtol=0, atol=1e-12)
        np.testing.assert_allclose(J, np.asarray(robot.jacobian(q)), rtol=0, atol=1e-12)


@pytest.mark.slow
@pytest.mark.parametrize("crit", ["f2", "f1"])
def test_casadi_waypoint_matches_jaxstiff_slsqp(crit):
    from jaxstiff.solvers._problem import WaypointProblem, box
    from jaxstiff.solvers._slsqp import make_slsqp_solver
    from jaxstiff.stiffness import get_criterion

    robot = bench.make_robot("lwr")
    urdf, kw = bench.ROBOTS["lwr"]
    ch = bench.read_chain(urdf, robot.base_link, robot.tip_link, kw.get("locked"))
    q_prev = np.radians([20.0, 40.0, -10.0, -70.0, 15.0, 35.0, 0.0])
    kj_prev = np.array([60.0, 40.0, 70.0, 30.0, 55.0, 45.0, np.inf])
    q_move = q_prev + np.radians([0.8, -0.5, 0.6, 0.7, -0.4, 0.5, 0.0])  # a reachable target inside the box
    target = np.asarray(robot.fk(q_move))[:3, 3]
    d = np.array([0.3, 0.8, -0.2])
    d /= np.linalg.norm(d)
    dq, dk, r, c = math.radians(2.0), 5.0, 4.0, 0.01
    case = bench.Case("lwr", "one", ch, target[None], d[None], q_prev, kj_prev, dq, dk, 1.0, 100.0, crit, r, c, "full")
    cp = bench.CasadiProblem(case, "smooth")
    solver = cp.waypoint_solver(jit=False)
    fr = cp.free
    q_cas, k_cas, st = cp.solve_waypoint(solver, q_prev[fr], kj_prev[fr], target, d, rate=True)
    assert st["return_status"] == "Solve_Succeeded", st["return_status"]

    with jax.enable_x64(True):
        prob = WaypointProblem(robot, "full", get_criterion(crit))
        lb, ub = box(prob, q_prev, kj_prev, np.full(7, dq), np.full(7, dk), 1.0, 100.0)
        params = WaypointProblem.params(target, d, r, c)
        sl = make_slsqp_solver(prob, {"ftol": 1e-12, "maxiter": 500}, (1.0, 100.0))
        out = sl(prob.x_of(q_prev, kj_prev), lb, ub, params)
        x_jax = out.x
        x_cas = np.r_[q_cas, k_cas]

        def f_jax(x):
            return float(prob.objective_x(jnp.asarray(x), jnp.asarray(params)))

        def err_jax(x):
            return float(np.linalg.norm(np.asarray(prob.residual_x(jnp.asarray(x), jnp.asarray(params)))))

        # CasADi's point is feasible in jaxstiff's terms (its box and its position constraint) ...
        assert np.all(x_cas >= lb - 1e-12) and np.all(x_cas <= ub + 1e-12)
        assert err_jax(x_cas) < 1e-9
        # ... and the two criteria agree at both points (the CasADi model evaluated at jaxstiff's)
        for x in (x_cas, x_jax):
            a, rho = (float(v) for v in cp.ar_fn(x[:6], x[6:] / cp.kunit, d))
            assert bench.np_criterion(a, rho, crit, r, c) == pytest.approx(f_jax(x), rel=1e-8)
        # the same optimum: the binding box makes it a proper one (criterion above its minimum)
        f_c, f_j = f_jax(x_cas), f_jax(x_jax)
        assert f_j > (1.0 if crit == "f2" else c) * 1.01, "the box should keep the optimum off the criterion's floor"
        assert f_c == pytest.approx(f_j, rel=1e-4)
        np.testing.assert_allclose(x_cas[:6], x_jax[:6], atol=1e-3)
        np.testing.assert_allclose(x_cas[6:], x_jax[6:], atol=0.1)
