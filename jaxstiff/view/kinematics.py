"""Numpy forward kinematics and stiffness for the viewer: no JAX, nothing compiled.

The viewer draws an arm at hundreds of postures once, so plain vectorised numpy over the postures
is all it needs; it reads the chain of :class:`jaxstiff.model.chain.Chain` (joint origins, axes,
types, the TCP transform) exactly as the JAX kernel does (SPEC section 1): ``T = prod_i O_i M_i(q_i)
then the tip``, ``M_i`` a rotation about (revolute) or a translation along (prismatic) the joint
axis. ``tests/view/test_kinematics.py`` checks it against :func:`jaxstiff.fk` to 1e-12.

Rigid locked joints have ``kj = +inf``: their compliance ``1/kj`` is 0 here (never ``inf * 0``).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from jaxstiff.model.chain import Chain

__all__ = [
    "chain_frames",
    "link_frames",
    "tcp_transform",
    "tcp_position",
    "position_jacobian",
    "stiffness_T",
    "ellipsoid_axes",
]

_PRISMATIC = 1  # JointType.PRISMATIC (jaxstiff.model.chain), kept as a literal: no import at run time


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
        T = T @ _joint_motion(axis, chain.joint_types[i] == _PRISMATIC, qf[:, i])
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
        chain: the chain (a :class:`~jaxstiff.model.chain.Chain` or Robot).
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
    pris = np.asarray(chain.joint_types) == _PRISMATIC
    v = np.where(pris[:, None], z, np.cross(z, lever))
    w = np.where(pris[:, None], 0.0, z)
    J = np.concatenate([v, w], axis=-1)  # (..., n, 6)
    return np.swapaxes(J, -1, -2)[..., :rows, :]


def stiffness_T(chain: Chain, q: np.ndarray, kj: np.ndarray, task: str = "full") -> np.ndarray:
    """Translational stiffness ``K_T`` (..., 3, 3), N/m (S0-4, S0-6), from q and joint stiffness kj.

    ``task`` "full": ``K_T`` is the translational block of ``(J diag(1/kj) J^T)^-1`` with the 6-row
    Jacobian; "xyz": ``(J_v diag(1/kj) J_v^T)^-1``; "xy": the 2x2 of the xy rows, returned padded to
    3x3 (zero row and column z). A joint with ``kj = +inf`` (rigid) has compliance 0.
    """
    kj = np.asarray(kj, dtype=float)
    comp = np.where(np.isinf(kj), 0.0, 1.0 / np.where(np.isinf(kj), 1.0, kj))
    rows = {"full": [0, 1, 2, 3, 4, 5], "xyz": [0, 1, 2], "xy": [0, 1]}[task]
    J = position_jacobian(chain, q)[..., rows, :]
    C = np.einsum("...in,...n,...jn->...ij", J, comp, J)
    try:
        Kf = np.linalg.inv(C)
    except np.linalg.LinAlgError:  # fewer compliant joints than task rows: stiff without bound somewhere
        Kf = np.linalg.pinv(C)
    K = Kf[..., :3, :3] if task == "full" else Kf
    K = 0.5 * (K + np.swapaxes(K, -1, -2))
    if task == "xy":
        out = np.zeros(K.shape[:-2] + (3, 3))
        out[..., :2, :2] = K
        return out
    return K


def ellipsoid_axes(K: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Semi-axes (..., 3), N/m, descending, and unit directions (..., 3, 3) as columns, of ``K`` (..., m, m)
    (m = 2 is padded with a zero z axis)."""
    K = np.asarray(K, dtype=float)
    if K.shape[-1] == 2:
        P = np.zeros(K.shape[:-2] + (3, 3))
        P[..., :2, :2] = K
        K = P
    w, V = np.linalg.eigh(0.5 * (K + np.swapaxes(K, -1, -2)))
    return np.maximum(w[..., ::-1], 0.0), V[..., :, ::-1]
