"""Waypoints at a singular posture for the task: where a stiffness axis is the regularisation's.

At a posture where the task rows of the Jacobian lose rank (an arm stretched to the edge of its
workspace, a wrist alignment for task "full"), the compliance is singular and the Cartesian
stiffness along the lost direction is unbounded. The stiffness functions keep it finite by a
relative floor ``delta`` of the compliance's eigenvalues (1e-8 in float64,
:func:`jaxstiff.stiffness._schur.lost_axis_floor`), so ``K_T`` there has a condition number of
about ``1 / delta`` and the reported axis ratio (up to ~2e8) is the floor's, not the robot's.

A usable waypoint whose reported ``K_T`` (float64) has a condition number above
:data:`SINGULAR_COND` = ``0.1 / delta`` (1e7) is *singular*: ``jaxstiff.shape`` names them in
``meta["singular"]`` and in a :class:`SingularPostureWarning`. Such a waypoint can still count as
in target (f1 asks for a ratio of at least r); the flag says that its ratio is not a property of
the robot. A stiffness ellipsoid whose true axis ratio exceeds 1e7 is flagged too.
"""

from __future__ import annotations

import warnings
from typing import Any

import numpy as np

from jaxstiff.results._status import is_usable
from jaxstiff.results._target import compress_ranges, waypoints_by_path, waypoints_text

__all__ = ["SINGULAR_COND", "singular_waypoints", "singular_meta", "SingularPostureWarning", "warn_singular"]

#: condition number of K_T above which a waypoint counts as singular: 0.1 / the float64 floor 1e-8
SINGULAR_COND = 1e7


def singular_waypoints(K: np.ndarray, status: np.ndarray) -> np.ndarray:
    """(B, P) bool: usable waypoints whose ``K`` (B, P, m, m) has a condition number above
    :data:`SINGULAR_COND` (a non-finite K counts as singular)."""
    K = np.asarray(K, float)
    finite = np.all(np.isfinite(K), axis=(-2, -1))
    w = np.linalg.eigvalsh(np.where(finite[..., None, None], K, np.eye(K.shape[-1])))
    cond = w[..., -1] / np.maximum(w[..., 0], np.finfo(float).tiny)
    return is_usable(np.asarray(status)) & (~finite | (cond > SINGULAR_COND))


def singular_meta(mask: np.ndarray) -> dict[str, Any]:
    """meta's ``singular`` record: the threshold, the count and the waypoints per path (0-based
    ranges, only paths with any)."""
    return {
        "cond_threshold": SINGULAR_COND,
        "count": int(np.sum(mask)),
        "waypoints": {str(b): compress_ranges(v) for b, v in waypoints_by_path(mask).items()},
    }


class SingularPostureWarning(UserWarning):
    """Usable waypoints at a singular posture for the task (:func:`warn_singular`)."""


def warn_singular(mask: np.ndarray, task: str, stacklevel: int = 3) -> str | None:
    """Warn once when any waypoint of ``mask`` (B, P) is singular; returns the text (None: none)."""
    per_path = waypoints_by_path(mask)
    if not per_path:
        return None
    where = waypoints_text(per_path)
    text = (
        f"{int(np.sum(mask))} usable waypoints are at a singular posture for task {task!r} (stiffness condition "
        f"number above {SINGULAR_COND:g}): {where}; there the stiffness along the lost direction is set "
        "by the regularisation, not by the robot, so their ratio and criterion are not the robot's (the path "
        "touches the workspace's edge or a singularity: move it inside, or leave out those waypoints)"
    )
    warnings.warn(text, SingularPostureWarning, stacklevel=stacklevel)
    return text
