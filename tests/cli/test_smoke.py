"""End-to-end smoke checks of the foundation: planar 3R closed form, Jacobian vs autodiff of FK."""

import jax
import jax.numpy as jnp
import numpy as np
from helpers import assert_close, numpy_fk

import jaxstiff


def planar_3r_closed_form(q):
    c = np.cumsum(q)
    x = np.cos(c).sum()
    y = np.sin(c).sum()
    J = np.zeros((6, 3))
    for i in range(3):
        J[0, i] = -np.sin(c[i:]).sum()
        J[1, i] = np.cos(c[i:]).sum()
        J[5, i] = 1.0
    return np.array([x, y, 0.0]), J, c[-1]


def test_planar_3r_closed_form():
    robot = jaxstiff.Robot.from_urdf("planar_3r")
    rng = np.random.default_rng(0)
    for q in rng.uniform(-3, 3, size=(20, 3)):
        T, J = robot.fk_and_jacobian(jnp.asarray(q))
        p, Jc, phi = planar_3r_closed_form(q)
        assert_close(T[:3, 3], p, atol=1e-12, what="position")
        assert_close(T[:2, :2], [[np.cos(phi), -np.sin(phi)], [np.sin(phi), np.cos(phi)]], atol=1e-12)
        assert_close(J, Jc, atol=1e-12, what="jacobian")


def test_lwr_matches_numpy_chain():
    robot = jaxstiff.Robot.from_urdf("kuka_lwr4")
    q = np.random.default_rng(1).uniform(-2, 2, size=robot.n)
    assert_close(robot.fk(jnp.asarray(q)), numpy_fk(robot, q), atol=1e-12)


def test_jacobian_is_derivative_of_fk():
    robot = jaxstiff.Robot.from_urdf("kuka_lwr4")
    q = jnp.asarray(np.random.default_rng(2).uniform(-2, 2, size=robot.n))
    J = robot.jacobian(q)
    Jp = jax.jacfwd(lambda x: jaxstiff.fk(robot, x)[:3, 3])(q)
    assert_close(J[:3], Jp, atol=1e-12)
