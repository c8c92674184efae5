"""Chain kinematics in plain numpy: no JAX, nothing compiled.

For work that evaluates a few hundred postures once on the host, where a JAX trace of the
unrolled chain would cost more than the arithmetic: the viewer's arm and ellipsoids
(:mod:`jaxstiff.view._kinematics`) and the task rank check of
:func:`jaxstiff.stiffness._tasks.check_task_feasible` (six postures at every command's start; the
JAX trace it replaced took 0.2 s). Plain vectorised numpy over the postures, reading the chain of
:class:`jaxstiff.model._chain.Chain` (joint origins, axes, types, the TCP transform) exactly as the
JAX kernel does (SPEC section 1): ``T = prod_i O_i M_i(q_i) then the tip``, ``M_i`` a rotation
about (revolute) or a translation along (prismatic) the joint axis. Checked against
:func:`jaxstiff.fk` / :func:`jaxstiff.jacobian` and finite differences (tests/view/test_view_kinematics.py,
tests/model/test_kinematics.py).
"""

from __future__ import annotations

import numpy as np

from jaxstiff.model._chain import JOINT_PRISMATIC, Chain

__all__: list[str] = []


def _joint_motion(axis: np.ndarray, prismatic: bool, q: np.ndarray) -> np.ndarray:
    """(N, 4, 4) motion of one joint at the N values ``q``: Rodrigues' rotation or a translation."""
    M = np.zeros((q.shape[0], 4, 4))
    M[:, 3, 3] = 1.0
    if prismatic:
        M[:, :3, :3] = np.eye(3)
        M[:, :3, 3] = q[:, None] * axis
        return M
    K = np.array([[0.0, -axis[2], axis[1]], [axis[2], 0.0, -axis[0]], [-axis[1], axis[0], 0.0]])
    s, c = np.sin(q)[:, None, None], np.cos(q)[:, None, None]
    M[:, :3, :3] = np.eye(3) + s * K + (1.0 - c) * (K @ K)
    return M


def _frames(chain: Chain, q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(joints before their motion, joints after it, tcp), shapes (..., n, 4, 4) x 2 and (..., 4, 4)."""
    q = np.asarray(q, dtype=float)
    lead = q.shape[:-1]
    qf = q.reshape(-1, chain.n)
    N = qf.shape[0]
    T = np.broadcast_to(np.eye(4), (N, 4, 4)).copy()
    before = np.empty((N, chain.n, 4, 4))
    after = np.empty((N, chain.n, 4, 4))
    for i in range(chain.n):
        T = T @ chain.origin_matrix(i)
        before[:, i] = T
        axis = np.asarray(chain.axes[i], dtype=float)
        T = T @ _joint_motion(axis, chain.joint_types[i] == JOINT_PRISMATIC, qf[:, i])
        after[:, i] = T
    tcp = T @ chain.tip_matrix
    shape = (*lead, chain.n, 4, 4)
    return before.reshape(shape), after.reshape(shape), tcp.reshape(*lead, 4, 4)


def link_frames(chain: Chain, q: np.ndarray) -> np.ndarray:
    """(..., n, 4, 4): the frame of joint i's child link (after the joint's motion), base frame."""
    return _frames(chain, q)[1]


def chain_frames(chain: Chain, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Frames of every joint and the TCP at the postures ``q``.

    Args:
        chain: the chain (a :class:`~jaxstiff.model._chain.Chain` or Robot).
        q: (..., n) joint values, rad (m for prismatic joints).

    Returns:
        ``joints`` (..., n, 4, 4): joint i's frame (base frame, before its own motion: the joint
        axis ``joints[..., i, :3, :3] @ axis_i`` passes through ``joints[..., i, :3, 3]``), and
        ``tcp`` (..., 4, 4) the TCP transform, metres.
    """
    before, _, tcp = _frames(chain, q)
    return before, tcp


def tcp_transform(chain: Chain, q: np.ndarray) -> np.ndarray:
    """TCP transforms (..., 4, 4) at the postures ``q`` (..., n)."""
    return chain_frames(chain, q)[1]


def tcp_position(chain: Chain, q: np.ndarray) -> np.ndarray:
    """TCP positions (..., 3), m, at the postures ``q`` (..., n)."""
    return chain_frames(chain, q)[1][..., :3, 3]


def position_jacobian(chain: Chain, q: np.ndarray, rows: int = 6) -> np.ndarray:
    """Geometric Jacobian (..., rows, n) of the TCP point (rows ``[v; w]``, base frame), rows 3 or 6."""
    joints, tcp = chain_frames(chain, q)
    axes = np.asarray(chain.axes, dtype=float)  # (n, 3)
    z = np.einsum("...ij,...j->...i", joints[..., :3, :3], axes)  # (..., n, 3) world axes
    p = joints[..., :3, 3]
    lever = tcp[..., None, :3, 3] - p
    pris = np.asarray(chain.joint_types) == JOINT_PRISMATIC
    v = np.where(pris[:, None], z, np.cross(z, lever))
    w = np.where(pris[:, None], 0.0, z)
    J = np.concatenate([v, w], axis=-1)  # (..., n, 6)
    return np.swapaxes(J, -1, -2)[..., :rows, :]
