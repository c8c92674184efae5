""" "In target": the one rule for whether a waypoint's ellipsoid meets the wanted shape.

A waypoint is *in target* when its ellipsoid points along the desired direction and has the
wanted axis ratio, within the tolerances every report uses:

* alpha: ``alpha_deg < ALPHA_TOL_DEG`` (1 degree);
* rho: criterion f1 asks for *at least* r: ``rho >= (1 - RATIO_REL_TOL) r``; f2 and any other
  criterion ask for r itself: ``|rho - r| / r < RATIO_REL_TOL`` (2 %).

A NaN alpha or rho is never in target. :func:`in_target` is about the shape only;
:attr:`jaxstiff.ShapeResult.in_target`, :func:`jaxstiff.results.summary` and the command's table
count usable waypoints only (status 0-2, :mod:`jaxstiff.results._status`): an unreachable
waypoint's ellipsoid is that of a posture off the path, not the path's. Status 0 keeps its meaning
(feasible and, for SLSQP, the optimiser converged): a greedy solver can converge at every waypoint
while the rate limits hold the ellipsoid away from the target, so :func:`missed_target_warning`
names the usable waypoints that miss it.

The flag is derived from the file's ``alpha_deg``, ``ratio`` and ``meta`` (``criterion``,
``ratio``), not stored as an array: :attr:`jaxstiff.ShapeResult.in_target` computes it, so old
files get it too and it cannot disagree with the arrays it comes from. With numpy alone:
``(alpha_deg < 1) & (abs(ratio - r) / r < 0.02)`` (f2).

Used by :func:`jaxstiff.results.summary` (``share_alpha``, ``share_ratio``, ``share_both``), the
``jaxstiff shape`` summary table and the warning at the end of :func:`jaxstiff.shape`.
"""

from __future__ import annotations

import warnings
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from jaxstiff.results._status import NOT_RUN, is_usable

__all__ = [
    "ALPHA_TOL_DEG",
    "RATIO_REL_TOL",
    "GREEDY_SOLVERS",
    "target_masks",
    "ratio_targets",
    "in_target",
    "compress_ranges",
    "waypoints_by_path",
    "waypoints_text",
    "missed_target_waypoints",
    "first_free_waypoints",
    "first_waypoint_cause",
    "missed_target_warning",
    "MissedTargetWarning",
    "warn_missed_target",
]

ALPHA_TOL_DEG = 1.0  #: largest orientation error of a waypoint in target, degrees (exclusive)
RATIO_REL_TOL = 0.02  #: largest relative axis-ratio error of a waypoint in target (exclusive)
#: solvers that go waypoint by waypoint (each waypoint's best within its rate box, never looking ahead)
GREEDY_SOLVERS = ("slsqp", "slsqp-fd", "pgd")


def target_masks(
    alpha_deg: Any,
    ratio: Any,
    r: Any,
    criterion: str,
    alpha_tol_deg: float = ALPHA_TOL_DEG,
    ratio_rel_tol: float = RATIO_REL_TOL,
) -> tuple[np.ndarray, np.ndarray]:
    """``(alpha_ok, ratio_ok)``, boolean arrays of the broadcast shape of ``alpha_deg``,
    ``ratio`` and the wanted ratio ``r`` (the module docstring's rule)."""
    alpha = np.asarray(alpha_deg, float)
    rho = np.asarray(ratio, float)
    r = np.asarray(r, float)
    a_ok = alpha < alpha_tol_deg
    with np.errstate(invalid="ignore", divide="ignore"):
        if criterion == "f1":
            r_ok = rho >= (1.0 - ratio_rel_tol) * r
        else:
            r_ok = np.abs(rho - r) / r < ratio_rel_tol
    return a_ok, r_ok


def ratio_targets(meta: Mapping[str, Any], B: int) -> np.ndarray:
    """The wanted ratio of each path (B,) from a result's ``meta["ratio"]`` (a number or B
    numbers; missing: NaN, so nothing is in target)."""
    raw = meta.get("ratio")
    return np.broadcast_to(np.asarray(np.nan if raw is None else raw, float), (B,)).copy()


def in_target(
    alpha_deg: np.ndarray,
    ratio: np.ndarray,
    meta: Mapping[str, Any],
    alpha_tol_deg: float = ALPHA_TOL_DEG,
    ratio_rel_tol: float = RATIO_REL_TOL,
) -> np.ndarray:
    """Per waypoint (B, P) bool: alpha and rho both within the tolerances (module docstring), the
    wanted ratio and criterion taken from ``meta``."""
    B = np.shape(alpha_deg)[0]
    r = ratio_targets(meta, B)[:, None]
    a_ok, r_ok = target_masks(alpha_deg, ratio, r, str(meta.get("criterion", "")), alpha_tol_deg, ratio_rel_tol)
    return a_ok & r_ok


def compress_ranges(indices: Sequence[int] | np.ndarray) -> str:
    """``[0, 1, 2, 5, 7, 8]`` -> ``"0-2, 5, 7-8"`` (sorted, duplicates dropped; ``""`` if empty)."""
    idx = sorted({int(i) for i in np.asarray(indices).ravel()})
    parts: list[str] = []
    i = 0
    while i < len(idx):
        j = i
        while j + 1 < len(idx) and idx[j + 1] == idx[j] + 1:
            j += 1
        parts.append(str(idx[i]) if i == j else f"{idx[i]}-{idx[j]}")
        i = j + 1
    return ", ".join(parts)


def waypoints_by_path(mask: np.ndarray) -> dict[int, np.ndarray]:
    """Per path b (only those with any), the waypoints where ``mask`` (B, P) is true."""
    mask = np.asarray(mask, bool)
    return {int(b): np.flatnonzero(mask[b]) for b in range(mask.shape[0]) if mask[b].any()}


def waypoints_text(per_path: Mapping[int, Sequence[int] | np.ndarray]) -> str:
    """``{0: [1, 2, 3], 2: [5]}`` -> ``"path 0: waypoints 1-3; path 2: waypoints 5"`` (the way every
    warning names waypoints)."""
    return "; ".join(f"path {b}: waypoints {compress_ranges(v)}" for b, v in per_path.items())


def missed_target_waypoints(status: np.ndarray, flag: np.ndarray) -> dict[int, np.ndarray]:
    """Per path b (only those with any): the usable waypoints (status 0-2) that are not in target."""
    return waypoints_by_path(is_usable(np.asarray(status)) & ~np.asarray(flag, bool))


def first_free_waypoints(status: np.ndarray, meta: Mapping[str, Any]) -> np.ndarray:
    """(B,) per path the first usable waypoint when it was solved without rate limit (the whole
    joint and stiffness ranges: ``meta["limits"]["first_rate_limit"]`` false, the default), else
    -1 (a path with no usable waypoint, or a rate-limited first waypoint)."""
    usable = is_usable(np.asarray(status))
    limits = meta.get("limits") or {}
    first = np.where(usable.any(axis=1), np.argmax(usable, axis=1), -1)
    return np.full(usable.shape[0], -1) if limits.get("first_rate_limit", False) else first


#: what a first waypoint solved without rate limit is, in the warning's words
_NO_RATE_LIMIT = "has no rate limit (nothing before it binds it)"
#: the advice where an unconstrained first waypoint's stiffnesses span the whole range
_RANGE_BINDS = "the range binds, a wider one (kmin/kmax, --kmin/--kmax) may reach the target"
#: solvers that search a first waypoint harder than the one named (the warning suggests those only)
_FIRST_SEARCHERS = {
    "pgd": ("slsqp", "hybrid"),
    "slsqp-fd": ("slsqp", "hybrid"),
    "slsqp": ("hybrid",),
    "trajectory": ("hybrid",),
}


def _local_optimum(solver: str = "") -> str:
    """The cause where an unconstrained first waypoint misses the target with no stiffness bound
    holding it: a local optimum of the search, or a shape that no posture there gives (the arm's
    geometry: parallel joint axes, say, fix an axis of the ellipsoid); the advice names other
    solvers than ``solver`` only."""
    others = _FIRST_SEARCHERS.get(solver, ("slsqp", "hybrid") if not solver else ())
    alt = "".join(f" or solver {o!r}" for o in others)
    return (
        f"a local optimum (more first-waypoint starts (first_starts, --first-starts){alt} may reach "
        "the target) or a shape no posture gives there (parallel joint axes can fix an ellipsoid axis)"
    )


def _range_bound_joints(
    kj: np.ndarray | None, meta: Mapping[str, Any], rtol: float = 1e-6
) -> tuple[np.ndarray, np.ndarray] | None:
    """The joints at kmin and at kmax (indices) of a first waypoint's stiffnesses ``kj`` (n,),
    where both kinds exist (the stiffness range binds); None otherwise or without ``kj``/limits."""
    limits = meta.get("limits") or {}
    kmin, kmax = limits.get("kmin"), limits.get("kmax")
    if kj is None or kmin is None or kmax is None:
        return None
    k = np.asarray(kj, float)
    finite = np.isfinite(k)
    lo = np.flatnonzero(finite & (k <= float(kmin) * (1 + rtol)))
    hi = np.flatnonzero(finite & (k >= float(kmax) * (1 - rtol)))
    return (lo, hi) if lo.size and hi.size else None


def first_waypoint_cause(
    kj: np.ndarray | None, meta: Mapping[str, Any], joint_names: Sequence[str] | None = None, rtol: float = 1e-6
) -> str:
    """Why an unconstrained first waypoint (``kj`` (n,) its joint stiffnesses, rigid locked joints
    inf or NaN) misses the target, as far as its state tells: f1 and f2 depend only on the
    stiffnesses' ratios, so the stiffness range binds where some joint sits at kmin and another at
    kmax (within ``rtol``); otherwise no bound holds it: a local optimum of the search, or a shape
    the arm cannot give there (:func:`_local_optimum`)."""
    limits = meta.get("limits") or {}
    kmin, kmax = limits.get("kmin"), limits.get("kmax")
    local = _local_optimum(str(meta.get("solver", "")))
    if kj is None or kmin is None or kmax is None:
        return local
    bound = _range_bound_joints(kj, meta, rtol)
    if bound is not None:
        names = list(joint_names) if joint_names is not None else [str(i) for i in range(np.asarray(kj).size)]
        lo, hi = bound
        return (
            f"its joint stiffnesses span the whole range [{float(kmin):g}, {float(kmax):g}] Nm/rad "
            f"({', '.join(names[i] for i in lo)} at kmin; {', '.join(names[i] for i in hi)} at kmax): {_RANGE_BINDS}"
        )
    return f"its joint stiffnesses lie inside [{float(kmin):g}, {float(kmax):g}] Nm/rad (no bound holds them): {local}"


#: paths a missed-target warning names one by one (their waypoints, their first waypoint's
#: cause); beyond that many it names the first ones and counts the rest, and gives the first
#: waypoints' causes by kind with the paths of each (the result's ``in_target`` says the rest)
WARN_PATHS = 8


def _first_causes_grouped(firsts: Mapping[int, int], kj: np.ndarray | None, meta: Mapping[str, Any]) -> list[str]:
    """The first waypoints' causes of a warning about many paths, by kind: the paths whose
    stiffness range binds, then those that ended in a local optimum."""
    binds = [b for b, p in firsts.items() if kj is not None and _range_bound_joints(np.asarray(kj)[b, p], meta)]
    local = [b for b in firsts if b not in binds]
    limits = meta.get("limits") or {}
    out = []
    if binds:
        out.append(
            f"paths {compress_ranges(binds)}: the first waypoint {_NO_RATE_LIMIT} and its joint stiffnesses "
            f"span the whole range [{float(limits['kmin']):g}, {float(limits['kmax']):g}] Nm/rad: {_RANGE_BINDS}"
        )
    if local:
        cause = _local_optimum(str(meta.get("solver", "")))
        out.append(f"paths {compress_ranges(local)}: the first waypoint {_NO_RATE_LIMIT}, and {cause}")
    return out


def missed_target_warning(
    status: np.ndarray,
    flag: np.ndarray,
    meta: Mapping[str, Any],
    kj: np.ndarray | None = None,
    joint_names: Sequence[str] | None = None,
) -> str | None:
    """The text of the one warning at the end of :func:`jaxstiff.shape`: which usable waypoints
    miss the target (compressed ranges per path, 0-based) and what to try; None when none does.

    A path's first usable waypoint solved without rate limit (:func:`first_free_waypoints`) gets
    its own cause: nothing before it binds it, so "cannot look ahead" does not apply; from its
    stiffnesses ``kj`` (B, P, n) where given (:func:`first_waypoint_cause`)."""
    missed = missed_target_waypoints(status, flag)
    if not missed:
        return None
    count = sum(len(v) for v in missed.values())
    usable = int(is_usable(np.asarray(status)).sum())
    many = len(missed) > WARN_PATHS
    where = waypoints_text(dict(list(missed.items())[:WARN_PATHS]))
    if many:
        where += f"; and {len(missed) - WARN_PATHS} more paths (the result's in_target says which)"
    crit = str(meta.get("criterion", ""))
    rule = f"rho >= {1 - RATIO_REL_TOL:g} r" if crit == "f1" else f"|rho - r| / r < {RATIO_REL_TOL:g}"
    solver = str(meta.get("solver", ""))
    settings = meta.get("settings") or {}
    per_m = "" if settings.get("dq_per_m") is not None else ", or limits per metre of path (dq_per_m / dk_per_m)"
    first = first_free_waypoints(status, meta)
    firsts = {b: int(first[b]) for b, v in missed.items() if first[b] >= 0 and first[b] in v}
    causes = (
        _first_causes_grouped(firsts, kj, meta)
        if many
        else [
            f"path {b}: waypoint {p} {_NO_RATE_LIMIT}, and "
            + first_waypoint_cause(None if kj is None else np.asarray(kj)[b, p], meta, joint_names)
            for b, p in firsts.items()
        ]
    )
    head = f"{count} of {usable} usable waypoints miss the target (alpha < {ALPHA_TOL_DEG:g} deg and {rule}): {where}; "
    if len(firsts) == count:  # only first waypoints miss: their own causes, nothing about looking ahead
        return head + "; ".join(causes)
    lead = ("; ".join(causes) + "; the other waypoints: ") if causes else ""
    if solver in GREEDY_SOLVERS:
        advice = (
            f"solver {solver!r} goes waypoint by waypoint and cannot look ahead, so its status 0 (solved: "
            "feasible, optimiser converged) does not mean in target; try solver 'hybrid' (--solver hybrid), or "
            f"'trajectory' from it (Trajectory(warm=Hybrid())), or looser rate limits{per_m}"
        )
    else:
        advice = (
            "status 0 (solved) means feasible, not in target; the rate limits may be too tight for the "
            f"path's turns: try looser limits{per_m}"
            + (
                ""
                if solver == "trajectory"
                else ", or solver 'trajectory' from this solver's answer (Trajectory(warm=Hybrid()))"
                if solver == "hybrid"
                else ", or solver='trajectory' (--solver trajectory)"
            )
        )
    return head + lead + advice


def unusable_warning(status: np.ndarray, pos_error: np.ndarray, meta: Mapping[str, Any]) -> str | None:
    """The text of the warning at the end of :func:`jaxstiff.shape` (and of ``jaxstiff shape``)
    where waypoints have no usable solution (status 3-4): how many, the worst path, the largest
    position error and the likelier cause; None when every waypoint is usable (or not run)."""
    st = np.asarray(status)
    usable = is_usable(st)
    bad = ~usable & (st != NOT_RUN)
    if not bad.any():
        return None
    worst = int(np.argmax(bad.sum(axis=1)))
    far = float(np.max(np.asarray(pos_error, float)[bad]))
    first_rate = bool((meta.get("limits") or {}).get("first_rate_limit", False))
    # the first waypoint has no rate limit (unless first_rate_limit): if it was reached and later
    # ones were not, the limits per waypoint are the likelier cause
    if bool(np.all(usable[:, 0])) and not first_rate:
        first = int(np.argmax(bad[worst]))
        hint = (
            f"the first waypoint was reached, so the joint rate limit (dq, --dq-deg: change allowed per "
            f"waypoint) is the likelier cause than the reach: from the last usable posture (path {worst}: before "
            f"waypoint {first}) no posture within it puts the TCP on the next waypoint, and the walk goes on from "
            "that same posture, so the waypoints after it usually fail too; loosen dq (--dq-deg), give it per "
            "metre of path (dq_per_m, --dq-per-m), or use more waypoints (the stiffness limits dk, kmin, kmax do "
            "not bound the TCP's motion)"
        )
    elif first_rate:
        # the first waypoint is held within one rate step of the start state as well
        hint = (
            "with first_rate_limit (--first-rate-limit) the first waypoint must be within one rate step of "
            "the start state (q0, or IK to the first waypoint): start on the path, or drop it; else check "
            "the path's units and the robot's reach"
        )
    else:
        hint = "check the path's units and the robot's reach"
    return (
        f"{int(bad.sum())} of {st.size} waypoints have no usable solution (path {worst}: "
        f"{int(bad[worst].sum())} of {st.shape[1]}; largest position error {far:.3g} m); {hint} "
        "(status codes: see jaxstiff.results)"
    )


class UnusableWaypointsWarning(UserWarning):
    """Waypoints without a usable solution (status 3-4; :func:`warn_unusable`)."""


def warn_unusable(res: Any, stacklevel: int = 3) -> str | None:
    """Warn once (:class:`UnusableWaypointsWarning`) when waypoints of ``res`` (a
    :class:`~jaxstiff.ShapeResult`) have no usable solution; returns the text (None: none)."""
    text = unusable_warning(res.status, res.pos_error, res.meta)
    if text is not None:
        warnings.warn(text, UnusableWaypointsWarning, stacklevel=stacklevel)
    return text


class MissedTargetWarning(UserWarning):
    """Usable waypoints whose ellipsoid misses the target (:func:`warn_missed_target`)."""


def warn_missed_target(res: Any, stacklevel: int = 3) -> str | None:
    """Warn once (:class:`MissedTargetWarning`) when usable waypoints of ``res`` (a
    :class:`~jaxstiff.ShapeResult`; typed loosely: this module sits below it) miss the target;
    returns the text (None: every usable waypoint is in target). Called at the end of
    :func:`jaxstiff.shape` (``stacklevel`` 3 points at shape's caller)."""
    text = missed_target_warning(res.status, res.in_target, res.meta, res.kj, res.joint_names)
    if text is not None:
        warnings.warn(text, MissedTargetWarning, stacklevel=stacklevel)
    return text
