"""The viewer's numpy FK, Jacobian and stiffness against the JAX kernels and an independent numpy
computation (jaxstiff.results._numpy_check)."""

from __future__ import annotations

import numpy as np
import pytest
from viewer_files import MISSING_MESHES_URDF

import jaxstiff
from jaxstiff.results._numpy_check import np_translational_stiffness
from jaxstiff.view._kinematics import chain_frames, ellipsoid_axes, position_jacobian, stiffness_T, tcp_transform


@pytest.mark.parametrize("name", ["kuka_lwr4", "planar_3r", MISSING_MESHES_URDF])
def test_fk_and_jacobian_match_jax(name: str) -> None:
    robot = jaxstiff.Robot.from_urdf(name, tcp=[0.01, -0.02, 0.05])
    q = np.random.default_rng(0).uniform(-2, 2, (4, 5, robot.n))
    T = tcp_transform(robot, q)
    np.testing.assert_allclose(T, np.asarray(jaxstiff.fk(robot, q)), rtol=0, atol=1e-12)
    np.testing.assert_allclose(position_jacobian(robot, q), np.asarray(jaxstiff.jacobian(robot, q)), rtol=0, atol=1e-12)
    joints, tcp = chain_frames(robot, q[0, 0])
    assert joints.shape == (robot.n, 4, 4) and np.allclose(tcp, T[0, 0], atol=1e-12)


def test_stiffness_matches_numpy_check_and_rigid_limit(lwr) -> None:
    rng = np.random.default_rng(1)
    q, kj = rng.uniform(-1, 1, (3, lwr.n)), rng.uniform(5, 90, (3, lwr.n))
    K = stiffness_T(lwr, q, kj, "full")
    for i in range(3):
        np.testing.assert_allclose(K[i], np_translational_stiffness(lwr, q[i], kj[i], "full"), rtol=1e-9)
    rigid = kj.copy()
    rigid[:, -1] = np.inf  # compliance 0, the limit of a very stiff joint
    stiff = kj.copy()
    stiff[:, -1] = 1e12
    Kr = stiffness_T(lwr, q, rigid, "xyz")
    assert np.all(np.isfinite(Kr))
    np.testing.assert_allclose(Kr, stiffness_T(lwr, q, stiff, "xyz"), rtol=1e-6)
    w, V = ellipsoid_axes(Kr)
    np.testing.assert_allclose(np.einsum("...ij,...j,...kj->...ik", V, w, V), Kr, rtol=1e-9, atol=1e-6)
