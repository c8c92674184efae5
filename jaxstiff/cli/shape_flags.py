"""The flags of ``jaxstiff shape``: defaults, units and help from :class:`~jaxstiff.settings.ShapeSettings`."""

from __future__ import annotations

import argparse
import math
from typing import Any

from jaxstiff.cli.common import add_robot_flags, reads, setting_help, writes
from jaxstiff.settings.shape import LOCKED_JOINT_MODES, TASKS, ShapeSettings

__all__ = ["EPILOG", "add_shape_flags", "limit_kwargs"]

_S = ShapeSettings()
EPILOG = (
    "Exit status: 0 the result file was written (each waypoint's status is in it; a warning names "
    "waypoints without a usable solution); 3 written, but no waypoint has a usable solution; 2 bad "
    "input (nothing written); 130 / 143 interrupted by Ctrl-C / SIGTERM: with the SLSQP solvers the "
    "file is written with the waypoints finished so far (the others have status 5, not run; meta "
    "'interrupted' is true), with the batch solvers (pgd, hybrid, trajectory) nothing is written; after the "
    "last waypoint the complete file is still written."
)


# ---------------------------------------------------------------------- flags
def _add_problem_flags(p: argparse.ArgumentParser) -> None:
    path = p.add_argument(
        "--path",
        action="append",
        metavar="CSV",
        help="path file with header x,y,z[,dx,dy,dz], metres in the base frame (repeatable: several "
        "paths with the same number of waypoints, one result file; messages number them from "
        "0, in the order given, as the file's first axis). Default: the shipped "
        "default path (jaxstiff.paths.default_path)",
    )
    reads(path)
    p.add_argument(
        "--criterion",
        default=_S.criterion,
        type=str.lower,  # F2 is f2
        choices=("f1", "f2"),
        help="f1 (S0-9: ratio >= R) or f2 (S0-15: ratio = R)",
    )
    p.add_argument("--ratio", default=_S.ratio, metavar="R", help=setting_help(ShapeSettings, "ratio", extra=", > 1"))
    writes(
        p.add_argument("--out", default="shape.npz", metavar="FILE.npz", help="result file (written atomically)"),
        suffix=".npz",
    )
    p.add_argument(
        "--task",
        default=_S.task,
        choices=list(TASKS),
        help="which stiffness is shaped. full (seed 000): the top-left 3x3 of the 6x6 K_C, what a force "
        "meets with the tool's orientation HELD (clamp, peg in a hole); xyz: the inverse of the translational "
        "compliance, what a pure force at the TCP meets with the tool FREE TO TURN: shaping contact with a "
        "tool that may turn wants xyz (a full result's ellipsoid can be far off there: docs/concepts.md, "
        "'Which stiffness is shaped?'); xy: planar arms, 2x2 (default: %(default)s)",
    )
    p.add_argument(
        "--locked-joints",
        default=_S.locked_joints,
        choices=list(LOCKED_JOINT_MODES),
        help="rigid: a locked joint (--lock) has no spring, adds no compliance and has no stiffness "
        "variable (its kj in the file is inf); spring: it keeps its spring, whose stiffness is "
        "optimised like a free joint's (SPEC section 1) (default: %(default)s)",
    )
    p.add_argument(
        "--q0",
        default=None,
        metavar="RAD,...",
        help="start posture, one value per joint (rad; m for prismatic joints; locked joints at their values); "
        "default: damped-least-squares IK from the nominal posture to the first waypoint",
    )
    p.add_argument(
        "--kj0",
        default=None,
        metavar="V|V,...",
        help="start joint stiffness, Nm/rad: one value for all joints, one per joint (the values of "
        "rigid locked joints are ignored) or, with rigid locked joints, one per free joint "
        "(default: mid-range (kmin+kmax)/2)",
    )


def _add_limit_flags(p: argparse.ArgumentParser) -> None:
    dq_group, dk_group = p.add_mutually_exclusive_group(), p.add_mutually_exclusive_group()
    dq_group.add_argument(
        "--dq-deg",
        default=math.degrees(_S.dq),
        metavar="D",
        help=setting_help(ShapeSettings, "dq", unit="degrees per waypoint", extra=" (inf = none)"),
    )
    p.add_argument(
        "--dq-m",
        default=None,
        metavar="M",
        help="rate limit of prismatic joints, m per waypoint (inf = none; default: the value of "
        "--dq-deg in radians read as metres, 2 -> 0.0349 m)",
    )
    dq_group.add_argument(
        "--dq-per-m",
        default=None,
        metavar="RAD_PER_M",
        help=setting_help(ShapeSettings, "dq_per_m", extra="; instead of --dq-deg and --dq-m")
        + ": each path's limit per waypoint is this times its (shortest) segment length, so the result "
        "does not depend on how densely the path is sampled",
    )
    dk_group.add_argument(
        "--dk", default=_S.dk, metavar="K", help=setting_help(ShapeSettings, "dk", extra=" (inf = none)")
    )
    dk_group.add_argument(
        "--dk-per-m",
        default=None,
        metavar="K_PER_M",
        help=setting_help(ShapeSettings, "dk_per_m", extra="; instead of --dk")
        + ": each path's limit per waypoint is this times its (shortest) segment length",
    )
    p.add_argument("--kmin", default=_S.kmin, metavar="A", help=setting_help(ShapeSettings, "kmin", extra=", > 0"))
    p.add_argument("--kmax", default=_S.kmax, metavar="B", help=setting_help(ShapeSettings, "kmax", extra=", > kmin"))
    p.add_argument("--c", default=_S.c, metavar="C", help=setting_help(ShapeSettings, "c"))
    p.add_argument(
        "--first-rate-limit",
        dest="first_rate_limit",
        action="store_true",
        help="apply the rate limits between (q0, kj0) and the first waypoint too (default: the "
        "first waypoint may use the full joint and stiffness ranges)",
    )
    p.add_argument(
        "--no-first-rate-limit",
        dest="first_rate_limit",
        action="store_false",
        help="the default: do not rate-limit the first waypoint",
    )
    p.set_defaults(first_rate_limit=_S.first_rate_limit)
    p.add_argument(
        "--first-starts",
        default=_S.first_starts,
        metavar="N",
        help="start postures for the first (not rate-limited) waypoint",
    )
    p.add_argument(
        "--cms-volume",
        default=None,
        metavar="V",
        help=f"CMS target: product of the ellipsoid axes, (N/m)^3 (default: {_S.cms_mean_axis:g}^3, "
        f"i.e. a geometric-mean axis of {_S.cms_mean_axis:g} N/m)",
    )
    p.add_argument(
        "--cms-major",
        default=None,
        metavar="N_PER_M",
        help="CMS target: major axis lambda1, N/m, instead of the volume",
    )


def _add_solver_flags(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--solver",
        default=_S.solver,
        help="slsqp (JAX derivatives), slsqp-fd (the seed's numpy + finite differences), "
        "pgd (batched projected gradient), hybrid (pgd + SLSQP polish), trajectory (whole "
        "trajectory after a greedy warm start), or another registered solver",
    )
    p.add_argument(
        "--starts",
        default=_S.starts,
        metavar="S",
        help="starts per waypoint, multi-start solvers only (default: the solver's own)",
    )
    p.add_argument("--quiet", action="store_true", help="no progress bar and no summary table")


def add_shape_flags(p: argparse.ArgumentParser) -> None:
    """Every flag of ``jaxstiff shape`` (the robot flags are every command's)."""
    p.epilog = EPILOG
    add_robot_flags(p)
    _add_problem_flags(p)
    _add_limit_flags(p)
    _add_solver_flags(p)


def _per_metre(text: Any, flag: str) -> float | None:
    if text is None:
        return None
    try:
        x = float(text)
    except (TypeError, ValueError):
        raise ValueError(f"{flag}: expected a number, got {text!r}") from None
    if math.isnan(x) or x < 0:
        raise ValueError(f"{flag} must be >= 0 (per metre of path; inf = none), got {text}")
    return x


def limit_kwargs(args: argparse.Namespace, dq: Any, dk: Any) -> dict[str, Any]:
    """The rate-limit arguments of :func:`jaxstiff.shape` from the flags: ``dq``/``dk`` per
    waypoint (as read from --dq-deg/--dq-m and --dk), or, with --dq-per-m/--dk-per-m, the
    per-metre ones as :class:`ShapeSettings` fields (``settings``) and that quantity's
    per-waypoint argument left out. argparse refuses --dq-deg with --dq-per-m and --dk with
    --dk-per-m; --dq-m with --dq-per-m is refused here."""
    dq_pm = _per_metre(getattr(args, "dq_per_m", None), "--dq-per-m")
    dk_pm = _per_metre(getattr(args, "dk_per_m", None), "--dk-per-m")
    if dq_pm is not None and getattr(args, "dq_m", None) is not None:
        raise ValueError("--dq-m (m per waypoint) and --dq-per-m (per metre of path) exclude each other")
    out: dict[str, Any] = {"dq": None if dq_pm is not None else dq, "dk": None if dk_pm is not None else dk}
    if dq_pm is not None or dk_pm is not None:
        out["settings"] = ShapeSettings(dq_per_m=dq_pm, dk_per_m=dk_pm)
    return out
