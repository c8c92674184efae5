"""ShapeSettings: the settings of stiffness-ellipsoid shaping (seed 000), defaults written once.

``shape()``, ``jaxstiff shape`` and a sweep's ``[shape]`` axes read their defaults here. Units
are those of the API: joint rate limits in rad per waypoint (``dq``; m for prismatic joints);
the command line's ``--dq-deg`` and the sweep's ``dq_deg`` are degrees (the field's ``Flag`` and
``Axis`` convert: :func:`dq_to_deg`, :meth:`ShapeSettings.dq_from_deg`). The flags of
``jaxstiff shape`` and the sweep's ``[axes]`` are made from these fields (:mod:`jaxstiff.settings._base`). Every result file records the settings it ran with, with
their units (``meta["settings"]``).

``ratio``, ``dq`` and ``dk`` may also be given per path (and per joint) to :func:`jaxstiff.shape`;
:func:`ratio_per_path` and :func:`limit_per_joint` check those arrays, naming the path and joint
of a bad value.

Rate limits per metre of path (``dq_per_m``, ``dk_per_m``; default None: the per-waypoint ``dq``
and ``dk`` apply) make a result independent of how densely the path is sampled. Each path's
per-waypoint limit is the per-metre limit times that path's segment length, its *shortest* one
when the waypoints are not evenly spaced (so the per-metre limit holds on every segment; on longer
segments the limit is then tighter than asked, and :func:`jaxstiff.shape` warns when they differ
by more than :data:`SEGMENT_SPREAD_WARN`): :func:`per_metre_limit`. The same segment length
serves the first waypoint when ``first_rate_limit`` is on. A per-metre limit and an explicit
per-waypoint one for the same quantity are refused together.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any, Literal

import numpy as np

from jaxstiff.model._chain import LOCKED_JOINT_MODES
from jaxstiff.settings._base import Axis, Flag, Settings, at_least, non_negative, positive_finite, setting

__all__ = [
    "ShapeSettings",
    "LOCKED_JOINT_MODES",
    "CRITERIA",
    "TASKS",
    "SOLVER_NAMES",
    "SINGLE_START_SOLVERS",
    "DEFAULT_DQ_DEG",
    "dq_to_deg",
]

CRITERIA = ("f1", "f2")  #: the shipped criteria (S0-9, S0-15); more can be registered
TASKS = ("full", "xyz", "xy")  #: task rows of the stiffness (SPEC section 2)


def task_dim(task: str) -> int:
    """The Cartesian dimension of a task's translational part: 2 for ``"xy"`` (the plane), else 3;
    the size of its translational stiffness ``K_T`` and of its position targets."""
    return 2 if task == "xy" else 3


SOLVER_NAMES = ("slsqp", "slsqp-fd", "pgd", "hybrid", "trajectory")  #: the shipped solvers
#: the shipped solvers that take one start state per path (greedy SLSQP: its own starts at the
#: first waypoint, then each waypoint from the previous one)
SINGLE_START_SOLVERS = ("slsqp", "slsqp-fd")
DEFAULT_DQ_DEG = 2.0  #: joint rate limit, degrees per waypoint (the seed leaves it open)
#: per-metre limits: warn when a path's longest segment exceeds its shortest by this factor
SEGMENT_SPREAD_WARN = 1.1


def dq_to_deg(dq: float) -> float:
    """A joint rate limit in rad as the degrees of ``--dq-deg`` and the sweep's ``dq_deg``, to 12
    significant digits (the default shows as 2.0, not 2.0000000000000004)."""
    return float(f"{math.degrees(dq):.12g}")


def _starts_axis_check(v: object) -> str | None:
    return None if isinstance(v, int) and v >= 0 else "must be an integer >= 0 (0: the solver's default)"


def _optional_non_negative(v: object) -> str | None:
    return None if v is None else non_negative(v)


#: the largest wanted axis ratio taken: an ellipsoid whose minor axis is a millionth of its major one
#: is a degenerate target, not a shape (a tester's 1e300 ran to non-finite criteria that a warning
#: blamed on the path's units)
MAX_RATIO = 1e6


def _ratio(v: object) -> str | None:
    ok = isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) and 1 < v <= MAX_RATIO
    return None if ok else f"must be > 1 and at most {MAX_RATIO:g} (lambda1 / lambda2)"


#: the joint stiffnesses a shaping run takes, Nm/rad (N/m for a prismatic joint): the compliance
#: and the stiffness square them, and the CMS factor multiplies their m-th roots; far beyond this
#: float64 loses them (a range of [1e-300, 1e-290] gave status 1-2 waypoints whose stored ratio
#: no reader could reproduce)
STIFFNESS_BOUNDS = (1e-100, 1e100)


def stiffness_bound(v: Any) -> str | None:
    """Check: a joint stiffness bound, a finite number inside :data:`STIFFNESS_BOUNDS`."""
    msg = positive_finite(v)
    if msg is not None:
        return msg
    lo, hi = STIFFNESS_BOUNDS
    return None if lo <= v <= hi else f"must lie within [{lo:g}, {hi:g}] (float64 squares it)"


@dataclasses.dataclass(frozen=True)
class ShapeSettings(Settings):
    """Settings of :func:`jaxstiff.shape` that the seed leaves open (every field, default and unit below).

    The scalar form is validated here; ``ratio``, ``dq`` and ``dk`` may also be given per path or
    per joint to :func:`jaxstiff.shape`, which checks those arrays itself.
    """

    section = "shape"

    criterion: str = setting(
        "f2",
        doc="shaping criterion: f1 (ratio at least r) or f2 (ratio exactly r)",
        flag=Flag(type=str.lower, choices=CRITERIA, help="f1 (S0-9: ratio >= R) or f2 (S0-15: ratio = R)"),
        axis=Axis(static=True, registry="jaxstiff.stiffness._criteria:CRITERIA"),
    )
    ratio: float = setting(
        5.0,
        doc="wanted axis ratio r = lambda1 / lambda2",
        check=_ratio,
        flag=Flag(metavar="R", extra=", > 1 and at most 1e6"),
    )
    task: str = setting(
        "full",
        choices=TASKS,
        doc="task rows of K_T: full = top-left 3x3 of the 6x6 K_C",
        flag=Flag(
            help="which stiffness is shaped. full (seed 000): the top-left 3x3 of the 6x6 K_C, what a force "
            "meets with the tool's orientation HELD (clamp, peg in a hole); xyz: the inverse of the translational "
            "compliance, what a pure force at the TCP meets with the tool FREE TO TURN: shaping contact with a "
            "tool that may turn wants xyz (a full result's ellipsoid can be far off there: docs/concepts.md, "
            "'Which stiffness is shaped?'); xy: planar arms, 2x2 (default: %(default)s)"
        ),
        axis=Axis(static=True),
    )
    locked_joints: Literal["rigid", "spring"] = setting(
        "rigid",
        choices=LOCKED_JOINT_MODES,
        doc="a locked joint is rigid (no spring, no stiffness variable, kj = +inf) or keeps its spring (SPEC 1)",
        flag=Flag(
            help="rigid: a locked joint (--lock) has no spring, adds no compliance and has no stiffness "
            "variable (its kj in the file is inf); spring: it keeps its spring, whose stiffness is "
            "optimised like a free joint's (SPEC section 1) (default: %(default)s)"
        ),
        axis=Axis(static=True),
    )
    solver: str = setting(
        "slsqp",
        doc="solver (slsqp, slsqp-fd, pgd, hybrid, trajectory, or a registered one)",
        flag=Flag(
            help="slsqp (JAX derivatives), slsqp-fd (the seed's numpy + finite differences), "
            "pgd (batched projected gradient), hybrid (pgd + SLSQP polish), trajectory (whole "
            "trajectory after a greedy warm start), or another registered solver"
        ),
        axis=Axis(static=True, registry="jaxstiff.solvers._base:SOLVERS"),
    )
    starts: int | None = setting(
        None,
        doc="starts per waypoint (None: the solver's default; SLSQP: 1)",
        flag=Flag(metavar="S", help="starts per waypoint, multi-start solvers only (default: the solver's own)"),
        # the table's column is an integer: 0 is the solver's default (None here)
        axis=Axis(
            static=True,
            from_field=lambda v: v or 0,
            to_field=lambda v: v or None,
            check=_starts_axis_check,
            extra="; a sweep writes None as 0",
        ),
    )
    dq: float = setting(
        math.radians(DEFAULT_DQ_DEG),
        unit="rad per waypoint (m for prismatic joints)",
        doc="joint rate limit (S0-11, S0-12)",
        check=non_negative,
        flag=Flag(
            name="--dq-deg",
            metavar="D",
            unit="degrees per waypoint",
            from_field=dq_to_deg,
            to_field=math.radians,
            extra=" (inf = none)",
            group="dq",
        ),
        axis=Axis(
            name="dq_deg",
            unit="deg per waypoint",
            from_field=dq_to_deg,
            to_field=math.radians,
            extra="; a prismatic joint gets the same number in m (3 deg -> 0.0524 m)",
        ),
    )
    dk: float = setting(
        5.0,
        unit="Nm/rad per waypoint (N/m for prismatic joints)",
        doc="joint stiffness rate limit (S0-13, S0-14)",
        check=non_negative,
        flag=Flag(metavar="K", extra=" (inf = none)", group="dk"),
        axis=Axis(unit="Nm/rad per waypoint"),
    )
    dq_per_m: float | None = setting(
        None,
        unit="rad per metre of path (m per m for prismatic joints)",
        doc="joint rate limit per metre of path instead of dq (None: dq per waypoint applies)",
        check=_optional_non_negative,
        flag=Flag(
            metavar="RAD_PER_M",
            extra="; instead of --dq-deg and --dq-m: each path's limit per waypoint is this times its (shortest) "
            "segment length, so the result does not depend on how densely the path is sampled",
            group="dq",
        ),
        axis=None,
    )
    dk_per_m: float | None = setting(
        None,
        unit="Nm/rad per metre of path",
        doc="joint stiffness rate limit per metre of path instead of dk (None: dk per waypoint applies)",
        check=_optional_non_negative,
        flag=Flag(
            metavar="K_PER_M",
            extra="; instead of --dk: each path's limit per waypoint is this times its (shortest) segment length",
            group="dk",
        ),
        axis=None,
    )
    kmin: float = setting(
        1.0, unit="Nm/rad", doc="lowest joint stiffness", check=stiffness_bound, flag=Flag(metavar="A", extra=", > 0")
    )
    kmax: float = setting(
        100.0,
        unit="Nm/rad",
        doc="highest joint stiffness",
        check=stiffness_bound,
        flag=Flag(metavar="B", extra=", > kmin"),
    )
    c: float = setting(
        0.01,
        unit="deg",
        doc="offset c of f1 (S0-9)",
        check=non_negative,
        flag=Flag(metavar="C"),
        axis=Axis(unit="", before="dq_deg"),
    )
    first_rate_limit: bool = setting(
        False,
        doc="apply the rate limits between (q0, kj0) and waypoint 0",
        flag=Flag(
            help="apply the rate limits between (q0, kj0) and the first waypoint too (default: the "
            "first waypoint may use the full joint and stiffness ranges)",
            off_help="the default: do not rate-limit the first waypoint",
        ),
    )
    first_starts: int = setting(
        8, doc="IK start postures tried at the first waypoint", check=at_least(1), flag=Flag(metavar="N")
    )
    cms_mean_axis: float = setting(
        1000.0,
        unit="N/m",
        doc="CMS: the common geometric-mean axis of every waypoint",
        check=positive_finite,
        flag=None,  # the command line's --cms-volume / --cms-major say the target instead
        axis=None,
    )

    def __post_init__(self) -> None:
        super().__post_init__()
        if self.kmin >= self.kmax:
            raise ValueError(f"shape.kmin ({self.kmin:g}) must be below shape.kmax ({self.kmax:g}) (Nm/rad)")

    @staticmethod
    def dq_from_deg(dq_deg: float) -> float:
        """``--dq-deg`` / the sweep's ``dq_deg`` (degrees per waypoint) as the API's ``dq`` (rad)."""
        return math.radians(dq_deg)


def limit_per_joint(value: Any, n: int, what: str, unit: str, B: int = 1) -> np.ndarray:
    """A rate limit: a number or (n,) -> (n,), the same for every path; (B, n) -> one row per path
    ((n,) again if all rows are equal). Errors name the path (row) and joint of a bad value."""
    try:
        a = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"{what} must be a number, {n} numbers or ({B}, {n}) numbers ({unit})") from None
    if a.ndim == 0:
        a = np.full(n, float(a))
    if a.shape != (n,) and a.shape != (B, n):
        raise ValueError(
            f"{what} must be a number, {n} numbers (one per joint) or shape ({B}, {n}) "
            f"(one row per path) ({unit}), got shape {a.shape}"
        )
    bad_nan = np.argwhere(np.isnan(a))
    bad_neg = np.argwhere(a < 0)
    for bad, why in ((bad_nan, "is NaN"), (bad_neg, f"must be >= 0 ({unit}; inf = no limit)")):
        if bad.size:
            idx = tuple(int(i) for i in bad[0])
            where = f"path {idx[0]}, joint {idx[1]}" if a.ndim == 2 else f"joint {idx[0]}"
            raise ValueError(f"{what} {why}: {where} has {a[idx]}")
    if a.ndim == 2 and np.all(a == a[:1]):
        a = a[0].copy()
    return a


def shortest_segments(points: Any) -> tuple[np.ndarray, np.ndarray]:
    """Per path of ``points`` (B, P, 3) (m): the shortest and the longest distance between
    consecutive waypoints, each (B,) in m. Needs P >= 2 and no repeated waypoint (ValueError)."""
    pts = np.asarray(points, dtype=float)
    if pts.ndim != 3 or pts.shape[1] < 2:
        raise ValueError("rate limits per metre of path need paths of at least 2 waypoints")
    seg = np.linalg.norm(np.diff(pts, axis=1), axis=-1)  # (B, P-1)
    lo = seg.min(axis=1)
    if np.any(~(lo > 0)):
        b = int(np.flatnonzero(~(lo > 0))[0])
        p = int(np.argmin(seg[b]))
        raise ValueError(
            f"rate limits per metre of path: path {b} repeats a waypoint ({p} and {p + 1} coincide), "
            "so its per-waypoint limit would be 0"
        )
    return lo, seg.max(axis=1)


def per_metre_limit(value: Any, segment_m: Any, n: int, what: str, unit: str) -> np.ndarray:
    """A per-metre rate limit (a number, (n,) or (B, n); ``unit`` per metre) times each path's
    segment length ``segment_m`` (B,) (m): the per-waypoint limit, (n,) when every path gets the
    same row, else (B, n) (as :func:`limit_per_joint`). ``inf`` stays ``inf`` (no limit)."""
    seg = np.asarray(segment_m, dtype=float).reshape(-1)
    B = seg.shape[0]
    per_m = limit_per_joint(value, n, what, unit, B)
    return limit_per_joint(np.broadcast_to(per_m, (B, n)) * seg[:, None], n, what, unit, B)


def ratio_per_path(value: Any, B: int) -> float | np.ndarray:
    """The wanted axis ratio: a number (every path) or (B,) (one per path; a number again if all
    are equal). Each must be > 1 and at most :data:`MAX_RATIO`; errors name the path of a bad value."""
    try:
        a = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"ratio must be a number or {B} numbers (one per path), got {value!r}") from None
    if a.ndim == 0:
        r = float(a)
        if not (math.isfinite(r) and 1.0 < r <= MAX_RATIO):
            raise ValueError(f"ratio must be > 1 and at most {MAX_RATIO:g} (lambda1 / lambda2), got {r}")
        return r
    if a.shape != (B,):
        raise ValueError(
            f"ratio must be a number or {B} numbers (one per path of the batch of {B}), got shape {a.shape}"
        )
    bad = np.flatnonzero(~(np.isfinite(a) & (a > 1.0) & (a <= MAX_RATIO)))
    if bad.size:
        b = int(bad[0])
        raise ValueError(
            f"ratio must be > 1 and at most {MAX_RATIO:g} (lambda1 / lambda2) for every path, got {a[b]} for path {b}"
        )
    if np.all(a == a[0]):
        return float(a[0])
    return a.copy()
