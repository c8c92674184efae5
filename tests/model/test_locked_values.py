"""A value for a locked joint that is not its locked value is refused, with one message, by every
entry point that takes q (jaxstiff.model._chain.check_locked_values; SPEC section 1, issue 21)."""

import re

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxstiff
from jaxstiff.ik import ik_position
from jaxstiff.model._chain import LOCKED_TOL, check_locked_values

MSG = re.escape("= 0.3 for joint 'lwr_a7' of robot 'kuka_lwr4', which is locked at 0; pass the locked value (0)")


@pytest.fixture(scope="module")
def lwr():
    return jaxstiff.Robot.from_urdf("kuka_lwr4", locked={"lwr_a7": 0.0})


def test_check_locked_values_message(lwr):
    q = np.zeros(7)
    check_locked_values(lwr, q)  # at the locked value: fine
    check_locked_values(lwr, q + np.r_[np.zeros(6), 0.5 * LOCKED_TOL])  # within the tolerance
    q[6] = 0.3
    with pytest.raises(ValueError, match=re.escape("q[6] = 0.3 for joint 'lwr_a7'")):
        check_locked_values(lwr, q)
    qb = np.zeros((4, 2, 7))
    qb[3, 1, 6] = 0.3
    with pytest.raises(ValueError, match=re.escape("q[3, 1, 6] = 0.3") + ".*" + "locked=... / --lock"):
        check_locked_values(lwr, qb)
    free = jaxstiff.Robot.from_urdf("kuka_lwr4", locked={})
    check_locked_values(free, q)  # nothing locked: nothing to refuse


@pytest.mark.parametrize("method", ["fk", "jacobian", "fk_and_jacobian"])
def test_robot_methods_refuse(lwr, method):
    q = jnp.zeros((10, 7)) + 0.3  # the README's old quick start: 0.3 for the locked joint too
    with pytest.raises(ValueError, match=MSG):
        getattr(lwr, method)(q)
    if method == "fk_and_jacobian":
        with pytest.raises(ValueError, match=MSG):
            jaxstiff.fk_and_jacobian(lwr, q)
    ok = q.at[:, 6].set(0.0)
    assert np.all(np.isfinite(np.asarray(getattr(lwr, method)(ok)[0])))


def test_traced_values_are_not_checked(lwr):
    """Inside jit the values are unknown: no check (documented), the kernel runs."""
    T = jax.jit(lwr.fk)(jnp.full(7, 0.3))
    assert T.shape == (4, 4)


def test_shape_q0_and_ik_give_the_same_message(lwr):
    q0 = np.full(7, 0.3)
    with pytest.raises(ValueError, match=MSG):
        jaxstiff.shape(lwr, jaxstiff.default_path(n=3), "f2", 5.0, q0=q0)
    with pytest.raises(ValueError, match=MSG):
        ik_position(lwr, np.array([0.45, -0.25, 0.35]), q_start=q0)


def test_csc_rollout_gives_the_same_message(lwr):
    """csc_rollout's q0 (it held the locked joint at its value without a word)."""
    q0 = np.full(7, 0.3)
    hold = np.asarray(lwr.fk(q0 * np.r_[np.ones(6), 0.0]))[:3, 3]
    K_xd = np.diag([3000.0, 1000.0, 2000.0])
    with pytest.raises(ValueError, match=MSG):
        jaxstiff.csc_rollout(lwr, np.tile(hold, (3, 1)), K_xd, q0, task="xyz")
    res = jaxstiff.csc_rollout(lwr, np.tile(hold, (3, 1)), K_xd, q0 * np.r_[np.ones(6), 0.0], task="xyz")
    assert np.all(np.asarray(res.q)[..., 6] == 0.0)


def test_a_float32_q_at_the_locked_value_passes():
    """0.2 rounded to float32 is 0.2 + 3e-9, beyond the 1e-9 tolerance: a float32 q holding the
    locked value must pass (csc_rollout casts q0 to JAX's default float32 and then refused it),
    while a float32 q one float32 step per 1e-6 off is still refused."""
    r = jaxstiff.Robot.from_urdf("planar_4r", locked={"joint_4": 0.2})
    q = np.array([0.1, 0.2, 0.3, 0.2], dtype=np.float32)
    assert abs(float(q[3]) - 0.2) > LOCKED_TOL  # the case: the rounding alone exceeds the tolerance
    check_locked_values(r, q)
    check_locked_values(r, jnp.asarray(q))
    with pytest.raises(ValueError, match="locked at 0.2"):
        check_locked_values(r, q + np.float32(1e-6) * np.array([0, 0, 0, 1], dtype=np.float32))
    with pytest.raises(ValueError, match="locked at 0.2"):
        check_locked_values(r, q.astype(np.float64) + np.array([0, 0, 0, 3e-9]))
