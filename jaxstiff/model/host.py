"""Kinematics in plain numpy, for checks that run once on the host.

A handful of postures evaluated once (the task rank check of
:func:`jaxstiff.stiffness.tasks.check_task_feasible`) cost less in numpy than a JAX trace of the
unrolled chain (about 0.2 s on a 7-joint arm, paid on every command's start). Same convention as
:func:`jaxstiff.model.kinematics.jacobian` (SPEC section 1: rows vx vy vz wx wy wz of the TCP point,
base frame); the test suite compares the two.
"""

from __future__ import annotations

import numpy as np

from jaxstiff.model.chain import JOINT_PRISMATIC, Chain


def _axis_rotations(axis: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """Rodrigues for a constant unit axis and angles (B,): (B, 3, 3)."""
    ax, ay, az = axis
    K = np.array([[0.0, -az, ay], [az, 0.0, -ax], [-ay, ax, 0.0]])
    c, s = np.cos(angle)[:, None, None], np.sin(angle)[:, None, None]
    return c * np.eye(3) + s * K + (1.0 - c) * np.outer(axis, axis)


def host_jacobian(robot: Chain, q: np.ndarray) -> np.ndarray:
    """Geometric Jacobian (B, 6, n) of the TCP point in the base frame at postures ``q`` (B, n),
    float64 numpy (joint values are not checked: the caller's own)."""
    q = np.asarray(q, dtype=np.float64)
    B = q.shape[0]
    R = np.broadcast_to(np.eye(3), (B, 3, 3))
    p = np.zeros((B, 3))
    z_axes, points, prismatic = [], [], []
    for i in range(robot.n):
        org = robot.origin_matrix(i)
        p = p + R @ org[:3, 3]
        M = R @ org[:3, :3]
        axis = np.asarray(robot.axes[i], dtype=np.float64)
        z = M @ axis
        z_axes.append(z)
        points.append(p)
        if robot.joint_types[i] == JOINT_PRISMATIC:
            prismatic.append(True)
            p = p + z * q[:, i : i + 1]
            R = M
        else:
            prismatic.append(False)
            R = M @ _axis_rotations(axis, q[:, i])
    p_tcp = p + R @ robot.tip_matrix[:3, 3]
    J = np.zeros((B, 6, robot.n))
    for i, (z, p_i, slide) in enumerate(zip(z_axes, points, prismatic, strict=True)):
        if slide:
            J[:, :3, i] = z
        else:
            J[:, :3, i] = np.cross(z, p_tcp - p_i)
            J[:, 3:, i] = z
    return J
