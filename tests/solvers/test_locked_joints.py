"""Locked joints (SPEC section 1, issue 21): rigid by default (no spring: no compliance term, no
stiffness variable, kj = +inf in results), a spring on request (``locked_joints="spring"``, the
behaviour before issue 21); the same choice through the API, the CLI and the sweep.

Independent references: K_T from a numpy FK/Jacobian (tests/helpers.numpy_fk, central
differences) and a numpy sum over the sprung joints; the numpy-only result check
(``jaxstiff.results.verify``)."""

import json
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from helpers import assert_close, numpy_fk

import jaxstiff
from jaxstiff.results import _files as R
from jaxstiff.solvers._problem import Limits, WaypointProblem, box

LOCK = {"lwr_a7": 0.0}
Q = np.array([0.3, 0.5, -0.2, -1.0, 0.4, 0.6, 0.0])  # a generic LWR posture, lwr_a7 at its lock


@pytest.fixture(scope="module")
def lwr():
    return jaxstiff.Robot.from_urdf("kuka_lwr4", locked=LOCK)


def numpy_jacobian(robot, q, h=1e-6):
    """6 x n geometric Jacobian by central differences of the numpy FK (independent of the library)."""
    J = np.zeros((6, robot.n))
    for i in range(robot.n):
        e = np.zeros(robot.n)
        e[i] = h
        Tp, Tm = numpy_fk(robot, q + e), numpy_fk(robot, q - e)
        J[:3, i] = (Tp[:3, 3] - Tm[:3, 3]) / (2 * h)
        W = (Tp[:3, :3] - Tm[:3, :3]) / (2 * h) @ numpy_fk(robot, q)[:3, :3].T
        J[3:, i] = [W[2, 1], W[0, 2], W[1, 0]]
    return J


def numpy_KT(J, kj, joints):
    """Top-left 3x3 of (sum over ``joints`` of J_i J_i^T / kj_i)^-1 (task "full", S0-4, S0-6)."""
    C = sum(np.outer(J[:, i], J[:, i]) / kj[i] for i in joints)
    return np.linalg.inv(C)[:3, :3]


# ----------------------------------------------------------------------------- the problem
def test_rigid_is_the_default_and_has_no_stiffness_variable(lwr):
    rigid = WaypointProblem(lwr, "full", jaxstiff.f2)
    spring = WaypointProblem(lwr, "full", jaxstiff.f2, locked_joints="spring")
    assert rigid.locked_joints == "rigid"
    assert (rigid.n_free, rigid.n_spring, rigid.nx) == (6, 6, 12)
    assert (spring.n_spring, spring.nx) == (7, 13)
    x = rigid.x_of(Q, np.arange(1.0, 8.0))
    assert x.shape == (12,) and np.array_equal(x[6:], np.arange(1.0, 7.0))  # lwr_a7's kj is not in x
    kj = np.asarray(rigid.kj_of(jnp.asarray(x)))
    assert np.array_equal(kj[:6], np.arange(1.0, 7.0)) and kj[6] == np.inf
    # the box has no entry for lwr_a7's stiffness: no kmin/kmax, no rate limit
    lb, ub = box(rigid, Q, np.r_[np.full(6, 50.0), np.inf], np.full(7, 0.1), np.full(7, 5.0), 1.0, 100.0)
    assert lb.shape == (12,) and np.all(np.isfinite(lb)) and np.all(np.isfinite(ub))
    with pytest.raises(ValueError, match="locked_joints"):
        WaypointProblem(lwr, "full", jaxstiff.f2, locked_joints="stiff")


def test_planar_robot_is_the_same_in_both_modes():
    robot = jaxstiff.Robot.from_urdf("planar_3r")
    a = WaypointProblem(robot, "xy", jaxstiff.f2)
    b = WaypointProblem(robot, "xy", jaxstiff.f2, locked_joints="spring")
    assert a.nx == b.nx == 6 and a.all_springs and b.all_springs


def test_K_sums_over_free_joints_only(lwr):
    """rigid: K_T = (sum over the 6 free joints)^-1; spring: over all 7 (numpy, independent FK)."""
    kj = np.array([50.0, 30.0, 20.0, 10.0, 5.0, 8.0, 1.0])
    J = numpy_jacobian(lwr, Q)
    K_rigid = numpy_KT(J, kj, range(6))
    K_spring = numpy_KT(J, kj, range(7))
    for mode, K_ref in (("rigid", K_rigid), ("spring", K_spring)):
        prob = WaypointProblem(lwr, "full", jaxstiff.f2, locked_joints=mode)
        K = np.asarray(prob.stiffness(jnp.asarray(Q), jnp.asarray(kj)))
        assert_close(K, K_ref, rtol=1e-7, atol=1e-6, what=mode)
    assert np.abs(K_rigid - K_spring).max() > 1.0  # a 1 Nm/rad spring at A7 matters: the test can fail


@pytest.mark.slow
def test_inf_kj_is_a_rigid_joint_with_finite_gradients(lwr):
    """The public stiffness functions read kj = +inf as a rigid joint: values as without the joint,
    finite values and gradients (w.r.t. kj and q)."""
    kj = jnp.array([50.0, 30.0, 20.0, 10.0, 5.0, 8.0, jnp.inf])
    J = lwr.jacobian(jnp.asarray(Q))
    d = jnp.array([1.0, 0.0, 0.0])
    for task in ("full", "xyz"):
        K = jaxstiff.translational_stiffness(J, kj, task=task)
        assert_close(K, jaxstiff.translational_stiffness(J[:, :6], kj[:6], task=task), rtol=1e-14, atol=1e-9)
        KC = jaxstiff.cartesian_stiffness(J, kj, task=task)
        assert_close(KC, jaxstiff.cartesian_stiffness(J[:, :6], kj[:6], task=task), rtol=1e-14, atol=1e-9)
        for crit in (jaxstiff.f1, jaxstiff.f2):

            def f(k, q, crit=crit, task=task):
                return crit(jaxstiff.translational_stiffness(lwr.jacobian(q), k, task=task), d, 5.0)

            gk, gq = jax.grad(f, argnums=(0, 1))(kj, jnp.asarray(Q))
            assert np.all(np.isfinite(gk)) and np.all(np.isfinite(gq)) and gk[6] == 0.0
        k, kjs = jaxstiff.cms_scale(K, kj, target_major=1000.0)  # CMS: inf stays inf
        assert kjs[6] == np.inf and np.isfinite(k)
        K2 = jaxstiff.translational_stiffness(J, kjs, task=task)
        assert_close(K2, k * K, rtol=1e-12, atol=1e-9)
        assert np.all(np.isfinite(jaxstiff.ellipsoid(K2).axes))


# ----------------------------------------------------------------------------- shape()
def _short(k=4):
    p = jaxstiff.default_path()
    return jaxstiff.Path(p.points[:k], p.directions[:k], name="head")


@pytest.mark.slow
@pytest.mark.parametrize("solver", ["slsqp", "pgd"])
def test_shape_rigid_default_and_spring_on_request(lwr, solver):
    kw: dict[str, Any] = {"starts": 2} if solver == "pgd" else {}
    res = jaxstiff.shape(lwr, _short(), "f2", 5.0, solver=solver, **kw)
    assert res.meta["settings"]["locked_joints"] == "rigid"
    assert np.all(res.kj[..., 6] == np.inf) and np.all(np.isfinite(res.kj[..., :6]))
    assert np.all(res.kj0[:, 6] == np.inf) and np.all(res.kj_scaled[..., 6] == np.inf)
    # the file verifies itself: K from J diag(1/kj) J^T (1/inf = 0), bounds and rate limits on the free joints
    v = R.verify(res)
    assert v["max_bound_violation"] == 0.0 and v["max_rate_violation"] == 0.0
    assert v["max_ratio_mismatch"] < 1e-9 and v["max_alpha_mismatch"] < 1e-9
    for p in range(res.P):  # reported ratio = numpy K over the free joints (independent FK)
        K = numpy_KT(numpy_jacobian(lwr, res.q[0, p]), res.kj[0, p], range(6))
        w = np.linalg.eigvalsh(K)
        assert abs(w[-1] / w[-2] - res.ratio[0, p]) < 1e-6 * res.ratio[0, p]
    sp = jaxstiff.shape(lwr, _short(), "f2", 5.0, solver=solver, locked_joints="spring", **kw)
    assert sp.meta["settings"]["locked_joints"] == "spring"
    assert np.all(np.isfinite(sp.kj)) and np.all((sp.kj >= 1.0) & (sp.kj <= 100.0))
    for p in range(sp.P):  # spring: the sum runs over all 7 joints
        K = numpy_KT(numpy_jacobian(lwr, sp.q[0, p]), sp.kj[0, p], range(7))
        w = np.linalg.eigvalsh(K)
        assert abs(w[-1] / w[-2] - sp.ratio[0, p]) < 1e-6 * sp.ratio[0, p]


def test_shape_result_file_round_trip_keeps_inf(lwr, tmp_path):
    res = jaxstiff.shape(lwr, _short(3), "f2", 5.0)
    f = tmp_path / "r.npz"
    res.save(f)
    back = jaxstiff.ShapeResult.load(f)
    assert np.array_equal(back.kj, res.kj) and back.kj[0, 0, 6] == np.inf
    with np.load(f, allow_pickle=False) as z:
        assert json.loads(str(z["meta"]))["settings"]["locked_joints"] == "rigid"


def test_kj0_per_free_joint_and_rigid_entries_ignored(lwr):
    a = jaxstiff.shape(lwr, _short(2), "f2", 5.0, kj0=[40.0] * 6, first_rate_limit=True)
    b = jaxstiff.shape(lwr, _short(2), "f2", 5.0, kj0=[40.0] * 6 + [np.inf], first_rate_limit=True)
    c = jaxstiff.shape(lwr, _short(2), "f2", 5.0, kj0=[40.0] * 6 + [1e6], first_rate_limit=True)
    assert np.array_equal(a.kj, b.kj) and np.array_equal(a.kj, c.kj) and a.kj0[0, 6] == np.inf
    with pytest.raises(ValueError, match="kj0"):  # spring: the locked joint's kj0 is checked
        jaxstiff.shape(lwr, _short(2), "f2", 5.0, kj0=[40.0] * 6 + [1e6], locked_joints="spring")
    with pytest.raises(ValueError, match="locked_joints"):
        jaxstiff.shape(lwr, _short(2), "f2", 5.0, locked_joints="rigd")


def test_limits_box_via_settings(lwr):
    """Limits.box on the rigid problem: (nx,) bounds, lwr_a7's stiffness absent."""
    lim = Limits(dq=np.full(7, 0.05), dk=np.full(7, 5.0), kmin=1.0, kmax=100.0, first_rate_limit=True)
    prob = WaypointProblem(lwr, "full", jaxstiff.f2)
    lb, ub = lim.box(prob, Q, np.r_[np.full(6, 50.0), np.inf], True)
    assert lb.shape == ub.shape == (12,)
    assert_close(lb[6:], np.full(6, 45.0))
    assert_close(ub[6:], np.full(6, 55.0))
