"""A joint axis a hair off a coordinate axis, such as (0, 1, 6e-8) (float32 noise in a URDF): in
float64 it is a unit vector whose largest entry is exactly 1, and the framed kernel once took it for
the coordinate axis and built a frame that was not a rotation (FK off by 4e-8). Found by the
random-chain property test; checked here against Rodrigues' formula in numpy, for every coordinate
axis, both signs and offsets in each other entry."""

from __future__ import annotations

import itertools
import math
import os
import tempfile

import jax.numpy as jnp
import numpy as np
import pytest

import jaxstiff
from jaxstiff.model._kinematics_scan import kernel_for


def _robot(axis) -> jaxstiff.Robot:
    urdf = (
        '<?xml version="1.0"?><robot name="r"><link name="l0"/><link name="l1"/><link name="l2"/>'
        '<joint name="j0" type="revolute"><parent link="l0"/><child link="l1"/>'
        f'<origin xyz="0.1 0 0.2" rpy="0.3 0 0"/><axis xyz="{" ".join(map(repr, axis))}"/>'
        '<limit lower="-3" upper="3" effort="1" velocity="1"/></joint>'
        '<joint name="j1" type="fixed"><parent link="l1"/><child link="l2"/><origin xyz="0 0.3 0.1"/></joint></robot>'
    )
    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "r.urdf")
        with open(path, "w") as fh:
            fh.write(urdf)
        return jaxstiff.Robot.from_urdf(path, tip_link="l2")


def _rodrigues_fk(axis, q) -> np.ndarray:
    a = np.asarray(axis, float) / np.linalg.norm(axis)
    K = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    cx, sx = math.cos(0.3), math.sin(0.3)
    O = np.eye(4)
    O[:3, :3] = [[1, 0, 0], [0, cx, -sx], [0, sx, cx]]
    O[:3, 3] = (0.1, 0.0, 0.2)
    M = np.eye(4)
    M[:3, :3] = np.eye(3) + math.sin(q) * K + (1 - math.cos(q)) * K @ K
    T = np.eye(4)
    T[:3, 3] = (0.0, 0.3, 0.1)
    return O @ M @ T


CASES = [
    tuple(sign * (1.0 if i == k else (6e-8 if i == j else 0.0)) for i in range(3))
    for k, j, sign in itertools.product(range(3), range(3), (1.0, -1.0))
    if j != k
]


@pytest.mark.parametrize("axis", CASES)
def test_axis_a_hair_off_a_coordinate_axis(axis):
    robot = _robot(axis)
    assert kernel_for(robot) != "scan"  # the unrolled kernels are what this is about
    for q in (0.8, -2.1):
        T = np.asarray(jaxstiff.fk(robot, jnp.asarray([q])))
        np.testing.assert_allclose(T, _rodrigues_fk(axis, q), rtol=0, atol=1e-13)
