"""Numpy forward kinematics and stiffness for the viewer: no JAX, nothing compiled.

The viewer draws an arm at hundreds of postures once, so plain vectorised numpy over the postures
is all it needs: the chain's frames and Jacobian from :mod:`jaxstiff.model._host` (re-exported
here), the stiffness and the ellipsoid axes below. ``tests/view/test_view_kinematics.py`` checks
them against :func:`jaxstiff.fk` to 1e-12.

Rigid locked joints have ``kj = +inf``: their compliance ``1/kj`` is 0 here (never ``inf * 0``).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

# the chain kinematics live in the model layer (the task rank check uses them too)
from jaxstiff.model._host import chain_frames, link_frames, position_jacobian, tcp_position, tcp_transform

if TYPE_CHECKING:
    from jaxstiff.model._chain import Chain

__all__ = ["chain_frames", "link_frames", "tcp_transform", "tcp_position", "position_jacobian"]


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
