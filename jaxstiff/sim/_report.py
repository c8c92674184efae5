"""Tables and JSON of a physics check (``jaxstiff check-sim``, ``experiments/sim_check.py``)."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from jaxstiff.sim._check import SimRow

__all__ = ["markdown_table", "worst"]


def _eig(K: np.ndarray) -> str:
    return " / ".join(f"{v:.6g}" for v in np.linalg.eigvalsh(K)[::-1])


def _e(x: float) -> str:
    return "-" if np.isnan(x) else f"{x:.1e}"


def _eig_or_dash(K: np.ndarray | None) -> str:
    return "-" if K is None else _eig(K)


def _listed(K: np.ndarray | None) -> list | None:
    return None if K is None else K.tolist()


#: what the two measured stiffnesses are (printed under the table)
HELD_FREE_NOTE = (
    "held: the stiffness a force at the TCP meets with the tool's orientation held (task full shapes it); "
    "free: with the tool free to turn (task xyz shapes it), never stiffer than held"
)


def markdown_table(rows: Sequence[SimRow], robot: str = "") -> str:
    """One line per posture: stiffness eigenvalues predicted vs measured (N/m), the errors, both
    stiffnesses a force can meet (held and free tool orientation, :data:`HELD_FREE_NOTE`), the CCT check."""
    head = (
        "| robot | waypoint | task | locked | K_T eig. predicted (N/m) | K_T eig. measured (N/m) | err_K | err_C "
        "| err_dir | held eig. measured (N/m) | err held | free eig. measured (N/m) | err free "
        "| CCT load (N) | CCT err (+) | err (-) | err (none) | pass |"
    )
    lines = [head, "|" + "---|" * (head.count("|") - 1)]
    for r in rows:
        lines.append(
            f"| {robot} | {r.label} | {r.task} | {r.mode} | {_eig(r.K_pred)} | {_eig(r.K_meas)} | {_e(r.err_K)} "
            f"| {_e(r.err_C)} | {_e(r.err_dir)} | {_eig_or_dash(r.K_held_meas)} | {_e(r.err_held)} "
            f"| {_eig_or_dash(r.K_free_meas)} | {_e(r.err_free)} | {'-' if np.isnan(r.cct_load) else f'{r.cct_load:.3g}'} "
            f"| {_e(r.cct_err)} | {_e(r.cct_err_wrong)} | {_e(r.cct_err_none)} | {'yes' if r.passed else 'NO'} |"
        )
    return "\n".join(lines)


def worst(rows: Sequence[SimRow]) -> dict[str, float]:
    """The largest errors over ``rows`` (NaN-free keys only) and the smallest wrong-sign CCT error."""
    out: dict[str, float] = {}
    for key in ("err_K", "err_C", "err_dir", "err_held", "err_free", "cct_err", "cct_eq_residual", "residual"):
        vals = [getattr(r, key) for r in rows if not np.isnan(getattr(r, key))]
        if vals:
            out[key] = float(max(vals))
    wrong = [r.cct_err_wrong for r in rows if not np.isnan(r.cct_err_wrong)]
    if wrong:
        out["cct_err_wrong_min"] = float(min(wrong))
    return out


def rows_json(rows: Sequence[SimRow], **extra: Any) -> dict[str, Any]:
    """A JSON-ready dict: every row's numbers (matrices as nested lists) and :func:`worst`."""
    items = []
    for r in rows:
        items.append(
            {
                "label": r.label, "task": r.task, "locked_joints": r.mode, "K_pred": r.K_pred.tolist(),
                "K_meas": r.K_meas.tolist(), "err_K": r.err_K, "err_C": r.err_C, "err_dir": r.err_dir,
                "probe_force": r.force, "settle_residual": r.residual, "steps": r.steps,
                "cct_load": None if np.isnan(r.cct_load) else r.cct_load,
                "cct_err": None if np.isnan(r.cct_err) else r.cct_err,
                "cct_err_wrong_sign": None if np.isnan(r.cct_err_wrong) else r.cct_err_wrong,
                "cct_err_none": None if np.isnan(r.cct_err_none) else r.cct_err_none,
                "cct_eq_residual": None if np.isnan(r.cct_eq_residual) else r.cct_eq_residual,
                "K_held_pred": _listed(r.K_held_pred), "K_held_meas": _listed(r.K_held_meas),
                "K_free_pred": _listed(r.K_free_pred), "K_free_meas": _listed(r.K_free_meas),
                "err_held": None if np.isnan(r.err_held) else r.err_held,
                "err_free": None if np.isnan(r.err_free) else r.err_free,
                "tol": r.tol, "passed": r.passed,
            }
        )  # fmt: skip
    return {**extra, "passed": all(r.passed for r in rows), "worst": worst(rows), "rows": items}
