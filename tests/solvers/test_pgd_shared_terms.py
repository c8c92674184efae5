"""pgd's evaluations that share one kinematics call (issue 23, cold compile): what a projected
gradient step needs (criterion or surrogate value and gradient, TCP position, position-row
Jacobian) and a final point's criterion and position error, each against the separate
evaluations they replace (``jax.value_and_grad`` of :meth:`WaypointOps.f` and of the surrogate,
:meth:`pos_err`, :meth:`pos_jac`), on chains with the scan kinematics and the unrolled ones, a
locked joint, a task whose rows are not the position rows, and a user's criterion."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from helpers import numpy_fk

import jaxstiff
from jaxstiff.solvers import _pgd as pgd
from jaxstiff.solvers._problem import WaypointProblem
from jaxstiff.stiffness import get_criterion


def _user_criterion(K, d, r):
    # depends on the whole matrix, not only its eigen-decomposition's summary
    return jnp.sum(K * K) / jnp.trace(K) ** 2 + 0.1 * (d @ K @ d) / jnp.trace(K)


CASES = [
    ("planar_3r", "xy", None, "f2"),
    pytest.param("kuka_lwr4", "full", {"lwr_a7": 0.0}, "f2", marks=pytest.mark.slow),  # the largest compile: slow lane
    ("kuka_lwr4", "xyz", None, "f1"),
    ("kuka_lwr4", "full", None, _user_criterion),
]


def _ops(robot_name: str, task: str, locked, crit):
    robot = jaxstiff.Robot.from_urdf(robot_name, locked=locked)
    criterion = get_criterion(crit) if isinstance(crit, str) else crit
    return robot, pgd.WaypointOps(WaypointProblem(robot, task, criterion))


def _points(ops: pgd.WaypointOps, robot, rng, k: int):
    for _ in range(k):
        q = rng.uniform(robot.lower * 0.8, robot.upper * 0.8)
        kj = np.exp(rng.uniform(0.0, np.log(100.0), ops.nk))
        x = jnp.asarray(np.r_[q[list(ops.pr.free_idx)], kj])
        tgt = jnp.asarray(numpy_fk(robot, q)[:3, 3] + rng.normal(size=3) * 0.01)
        d = rng.normal(size=3)
        yield x, tgt, jnp.asarray(d / np.linalg.norm(d))


@pytest.mark.parametrize("robot_name,task,locked,crit", CASES)
def test_descent_terms_equal_the_separate_evaluations(robot_name, task, locked, crit):
    robot, ops = _ops(robot_name, task, locked, crit)
    rng = np.random.default_rng(5)
    r, c = 4.0, 0.01
    with jax.enable_x64(True):
        # the flag as a Python bool and as a traced (unbatched) one, vmapped over points
        traced = jax.jit(jax.vmap(ops.descent_terms, in_axes=(0, 0, None, None, None)))
        pts = list(_points(ops, robot, rng, 3))
        X = jnp.stack([p[0] for p in pts])
        D = jnp.stack([p[2] for p in pts])
        for surrogate in (False, True):
            obj = ops.surrogate if surrogate else ops.f
            tv, tg, tp, tJ = traced(X, D, r, c, jnp.asarray(surrogate))
            for i, (x, tgt, d) in enumerate(pts):
                v, g, p, J = ops.descent_terms(x, d, r, c, surrogate)
                v_ref, g_ref = jax.value_and_grad(obj)(x, d, r, c)
                p_ref, J_ref = ops.pos_jac(x)
                assert np.all(np.isfinite(np.asarray(g)))
                np.testing.assert_allclose(v, v_ref, rtol=1e-12, atol=1e-14)
                np.testing.assert_allclose(g, g_ref, rtol=1e-10, atol=1e-12 * float(jnp.max(jnp.abs(g_ref))))
                np.testing.assert_allclose(p, p_ref, atol=1e-14)
                np.testing.assert_allclose(J, J_ref, atol=1e-14)
                assert J.shape == (len(ops.rows), ops.nf)
                np.testing.assert_allclose(jnp.linalg.norm(p - tgt), ops.pos_err(x, tgt), atol=1e-15)
                np.testing.assert_allclose(tv[i], v, rtol=1e-12, atol=1e-14)
                np.testing.assert_allclose(tg[i], g, rtol=1e-10, atol=1e-12 * float(jnp.max(jnp.abs(g))))


@pytest.mark.parametrize("robot_name,task,locked,crit", CASES)
def test_f_and_err_equal_the_separate_evaluations(robot_name, task, locked, crit):
    robot, ops = _ops(robot_name, task, locked, crit)
    rng = np.random.default_rng(9)
    with jax.enable_x64(True):
        for x, tgt, d in _points(ops, robot, rng, 3):
            fv, err = ops.f_and_err(x, d, 3.0, 0.01, tgt)
            np.testing.assert_allclose(fv, ops.f(x, d, 3.0, 0.01), rtol=1e-13, atol=1e-15)
            np.testing.assert_allclose(err, ops.pos_err(x, tgt), rtol=1e-13, atol=1e-16)
            # and the position error against numpy's forward kinematics
            q = np.asarray(ops.pr.q_of(x))
            np.testing.assert_allclose(err, np.linalg.norm(numpy_fk(robot, q)[:3, 3] - np.asarray(tgt)), atol=1e-12)
