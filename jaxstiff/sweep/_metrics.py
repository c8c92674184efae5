"""Summary metrics of one sweep row (one trajectory under one setting), computed in numpy.

Shape rows (from a :class:`~jaxstiff.results.ShapeResult`, one path ``b``): a waypoint *succeeds*
when it is usable (status 0-2, feasible), its orientation error is below ``alpha_tol_deg`` and its
axis ratio reaches the target: ``|rho - r| / r < ratio_rel_tol`` (f2 and other criteria) or
``rho >= (1 - ratio_rel_tol) r`` (f1 asks for *at least* r). Unlike
:func:`jaxstiff.results.summary`, unusable waypoints never count as successes.

CSC rows (from the arrays of a :class:`~jaxstiff.csc.CSCResult`, one rollout): the off-diagonal
norm u (S1-19) and the Frobenius error ``|K_xd - K_C|_F`` (S1-10) at the start posture and at the
end, their relative reductions, the tracking error and the shares of flagged steps.

Nothing here depends on timing: the results table holds no wall times (they go to the manifest).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np

__all__: list[str] = []

#: Metric name -> description, per sweep kind, in table order. The first two are the default
#: heat-map metrics.
METRICS: dict[str, dict[str, str]] = {
    "shape": {
        "share_both": "share of waypoints that are usable, aligned (alpha < tol) and reach the ratio",
        "share_ratio": "share of waypoints that are usable and reach the ratio (f1: rho >= (1 - tol) r; else |rho - r| / r < tol)",
        "share_alpha": "share of waypoints that are usable and have alpha < alpha_tol_deg",
        "share_usable": "share of waypoints with status 0-2 (feasible)",
        "share_solved": "share of waypoints with status 0",
        "share_unreachable": "share of waypoints with status 3 (unreachable)",
        "median_alpha_deg": "median orientation error over usable waypoints, deg",
        "max_alpha_deg": "largest orientation error over usable waypoints, deg",
        "mean_ratio": "mean axis ratio rho over usable waypoints",
        "min_ratio": "smallest axis ratio over usable waypoints",
        "mean_criterion": "mean criterion value over usable waypoints",
        "max_pos_error": "largest TCP position error over usable waypoints, m",
        "mean_cms": "mean common-mode factor over usable waypoints",
        "total_nfev": "objective evaluations of the solver, all waypoints",
    },
    "csc": {
        "u_reduction": "1 - u_end / u_start (off-diagonal norm, S1-19)",
        "frobenius_reduction": "1 - frobenius_end / frobenius_start (S1-10)",
        "u_start": "u at the start posture, Nm/rad",
        "u_end": "u after the last step, Nm/rad",
        "frobenius_start": "|K_xd - K_C|_F at the start posture, N/m",
        "frobenius_end": "|K_xd - K_C|_F after the last step, N/m",
        "frobenius_mean": "mean |K_xd - K_C|_F over the steps, N/m",
        "max_tracking_error": "largest TCP tracking error over the steps, m",
        "final_tracking_error": "TCP tracking error after the last step, m",
        "share_damped": "share of steps with the damped pseudo-inverse active",
        "share_joint_limit": "share of steps that hit a joint limit",
        "share_nan_guard": "share of steps dropped by the NaN guard",
    },
}


def _nanstat(fn: Callable[[np.ndarray], Any], a: np.ndarray) -> float:
    return float(fn(a)) if a.size else math.nan


def shape_row_metrics(  # noqa: PLR0913 - one per-waypoint array per metric, and the sweep's tolerances
    status: np.ndarray,
    alpha_deg: np.ndarray,
    ratio: np.ndarray,
    criterion_value: np.ndarray,
    pos_error: np.ndarray,
    cms: np.ndarray,
    nfev: np.ndarray,
    *,
    criterion: str,
    ratio_target: float,
    alpha_tol_deg: float,
    ratio_rel_tol: float,
) -> dict[str, float]:
    """Metrics of one shaped path from its per-waypoint arrays (each (P,)). See the module docstring."""
    from jaxstiff.results._files import SOLVED, UNREACHABLE, is_usable
    from jaxstiff.results._target import target_masks

    usable = is_usable(status)
    # the one "in target" rule (jaxstiff.results._target), with the sweep's configured tolerances
    a_ok, r_ok = target_masks(alpha_deg, ratio, ratio_target, criterion, alpha_tol_deg, ratio_rel_tol)
    u = usable
    return {
        "share_both": float(np.mean(u & a_ok & r_ok)),
        "share_ratio": float(np.mean(u & r_ok)),
        "share_alpha": float(np.mean(u & a_ok)),
        "share_usable": float(np.mean(u)),
        "share_solved": float(np.mean(status == SOLVED)),
        "share_unreachable": float(np.mean(status == UNREACHABLE)),
        "median_alpha_deg": _nanstat(np.median, alpha_deg[u]),
        "max_alpha_deg": _nanstat(np.max, alpha_deg[u]),
        "mean_ratio": _nanstat(np.mean, ratio[u]),
        "min_ratio": _nanstat(np.min, ratio[u]),
        "mean_criterion": _nanstat(np.mean, criterion_value[u]),
        "max_pos_error": _nanstat(np.max, pos_error[u]),
        "mean_cms": _nanstat(np.mean, cms[u]),
        "total_nfev": float(np.sum(nfev)),
    }


def csc_row_metrics(
    u: np.ndarray,
    frobenius: np.ndarray,
    tracking_error: np.ndarray,
    status: np.ndarray,
    u_start: float,
    frobenius_start: float,
) -> dict[str, float]:
    """Metrics of one CSC rollout from its per-step arrays (each (T,)) and start values."""
    from jaxstiff.csc._rollout import STATUS_DAMPED, STATUS_JOINT_LIMIT, STATUS_NAN

    st = np.asarray(status).astype(np.int64)
    u_start, frobenius_start = float(u_start), float(frobenius_start)
    return {
        "u_reduction": 1.0 - float(u[-1]) / u_start if u_start > 0 else 0.0,
        "frobenius_reduction": 1.0 - float(frobenius[-1]) / frobenius_start if frobenius_start > 0 else 0.0,
        "u_start": u_start,
        "u_end": float(u[-1]),
        "frobenius_start": frobenius_start,
        "frobenius_end": float(frobenius[-1]),
        "frobenius_mean": float(np.mean(frobenius)),
        "max_tracking_error": float(np.max(tracking_error)),
        "final_tracking_error": float(tracking_error[-1]),
        "share_damped": float(np.mean((st & STATUS_DAMPED) != 0)),
        "share_joint_limit": float(np.mean((st & STATUS_JOINT_LIMIT) != 0)),
        "share_nan_guard": float(np.mean((st & STATUS_NAN) != 0)),
    }
