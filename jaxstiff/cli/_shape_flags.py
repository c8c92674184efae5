"""The flags of ``jaxstiff shape``: one per :class:`~jaxstiff.settings.ShapeSettings` field (made from the
field's metadata), and the files, start states and CMS targets written here."""

from __future__ import annotations

import argparse
import math
from typing import Any

from jaxstiff.cli._common import add_robot_flags, reads, writes
from jaxstiff.cli._setting_flags import add_setting_flags
from jaxstiff.settings._shape import ShapeSettings

__all__: list[str] = []

_S = ShapeSettings()
EPILOG = (
    "Exit status: 0 the result file was written (each waypoint's status is in it; a warning names "
    "waypoints without a usable solution); 3 written, but no waypoint has a usable solution; 2 bad "
    "input (nothing written); 1 the system refused the file (a full disk, a read-only folder): the result "
    "was written elsewhere, and the message says where; 130 / 143 interrupted by Ctrl-C / SIGTERM: with the SLSQP solvers the "
    "file is written with the waypoints finished so far (the others have status 5, not run; meta "
    "'interrupted' is true), with the batch solvers (pgd, hybrid, trajectory) nothing is written; after the "
    "last waypoint the complete file is still written."
)


# ---------------------------------------------------------------------- flags
def _add_path_flags(p: argparse.ArgumentParser) -> None:
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
    writes(
        p.add_argument("--out", default="shape.npz", metavar="FILE.npz", help="result file (written atomically)"),
        suffix=".npz",
    )


def _add_start_and_target_flags(p: argparse.ArgumentParser) -> None:
    """The flags that are not settings: start states, the prismatic rate limit, CMS targets."""
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
    p.add_argument(
        "--dq-m",
        default=None,
        metavar="M",
        help="rate limit of prismatic joints, m per waypoint (inf = none; default: the value of "
        "--dq-deg in radians read as metres, 2 -> 0.0349 m; not with --dq-per-m)",
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
    p.add_argument(
        "--option",
        action="append",
        default=None,
        metavar="KEY=VALUE",
        help="one of the solver's options (repeatable), e.g. --solver pgd --option iters=60: the fields of "
        "the solver objects (jaxstiff.solvers: SLSQP, PGD, Hybrid, Trajectory; docs/api/solvers.md); a value "
        "is a number, true/false, none or a word (--solver trajectory --option warm=hybrid)",
    )
    p.add_argument("--quiet", action="store_true", help="no progress bar and no summary table")


def add_shape_flags(p: argparse.ArgumentParser) -> None:
    """Every flag of ``jaxstiff shape``: the robot flags (every command's), the path and result
    files, one flag per :class:`ShapeSettings` field (:func:`~jaxstiff.cli._setting_flags.add_setting_flags`;
    the command reads their text, :func:`~jaxstiff.cli._setting_flags.read_setting_flags`), then
    the start states and the CMS targets."""
    p.epilog = EPILOG
    add_robot_flags(p)
    _add_path_flags(p)
    add_setting_flags(p, ShapeSettings, typed=False)
    _add_start_and_target_flags(p)


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
