"""``jaxstiff shape``: stiffness-ellipsoid shaping along TCP paths, result file ``.npz`` (seed 000).

With no arguments it runs the shipped default: the KUKA LWR 4 with its 7th joint locked at 0 (as
in seed 000), the shipped default path, criterion f2 with ratio 5, written to ``shape.npz``. The
flags' defaults, units and help come from :class:`~jaxstiff.settings.ShapeSettings` and the robot
flags from :func:`~jaxstiff.cli._common.add_robot_flags`, like every command's.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
from typing import TYPE_CHECKING, Any

from jaxstiff.cli._common import check_out_file, command, parse_floats, robot_spec_from_args
from jaxstiff.cli._setting_flags import read_setting_flags, setting_flags
from jaxstiff.cli._shape_flags import EPILOG as EPILOG
from jaxstiff.cli._shape_flags import add_shape_flags as add_shape_flags
from jaxstiff.cli._shape_flags import limit_kwargs
from jaxstiff.runtime._io import deferred_interrupts, interrupt_pending, raise_if_interrupted, save_or_rescue
from jaxstiff.runtime._progress import Progress, progress
from jaxstiff.settings._shape import SINGLE_START_SOLVERS, ShapeSettings

if TYPE_CHECKING:
    import numpy as np

    from jaxstiff.model._robot import Robot
    from jaxstiff.paths import Path
    from jaxstiff.results._files import ShapeResult

__all__ = ["summary_table", "rate_limits", "joint_rate_limits", "WaypointProgress", "add_shape_flags", "run_shape"]


def _num(text: Any, flag: str, cast: Any = float) -> Any:
    if text is None:
        return None
    try:
        return cast(text)
    except (TypeError, ValueError):
        what = "an integer" if cast is int else "a number"
        raise ValueError(f"{flag}: expected {what}, got {text!r}") from None


def _nums(text: str | None, flag: str) -> list[float] | None:
    if text is None:
        return None
    out = parse_floats(text, flag)
    if not out:
        raise ValueError(f"{flag}: no numbers given")
    return out


class WaypointProgress:
    """``shape(progress=...)``'s callback for the command: a checkpoint for interrupts (a Ctrl-C
    that JAX swallowed stops the run at the next waypoint) and a :class:`~jaxstiff.runtime._progress.Progress`
    tick (``done`` counts the waypoints finished)."""

    def __init__(self, bar: Progress):
        self.bar = bar
        self.done = 0

    def __call__(self, b: int, p: int) -> None:
        raise_if_interrupted()
        self.done += 1
        self.bar.update(1, note=f"path {b}")  # 0-based, as the result file and the warnings


def summary_table(res: ShapeResult) -> str:
    """Per path: waypoints, statuses, share with alpha < 1 deg, share with the ratio met, share in
    target (both; the one rule of :mod:`jaxstiff.results._target`), errors, time. The three shape
    shares count usable waypoints only (status 0-2, shares of all the path's waypoints): an
    unreachable waypoint's ellipsoid is that of a posture off the path (an independent check read
    "usable 17 %, in target 67 %")."""
    import numpy as np

    from jaxstiff.results._files import SOLVED, is_usable
    from jaxstiff.results._target import ALPHA_TOL_DEG, RATIO_REL_TOL, ratio_targets, target_masks

    r_b = ratio_targets(res.meta, res.B)
    crit = str(res.meta["criterion"])
    tol = f"{100 * RATIO_REL_TOL:g}%"
    rlabel = f"rho>={1 - RATIO_REL_TOL:g}r" if crit == "f1" else f"|rho-r|<{tol}"
    names = res.meta.get("path_files") or [res.meta.get("path", {}).get("name", "path")] * res.B
    lines = [
        f"{'path':<24} {'P':>4} {'solved':>7} {'usable':>7} {f'a<{ALPHA_TOL_DEG:g}deg':>7} {rlabel:>11} "
        f"{'in target':>9} {'max pos err (m)':>16} {'median ms/wp':>12}"
    ]
    for b in range(res.B):
        a_ok, r_ok = target_masks(res.alpha_deg[b], res.ratio[b], r_b[b], crit)
        usable = is_usable(res.status[b])
        a_ok, r_ok = a_ok & usable, r_ok & usable
        perr = f"{float(res.pos_error[b][usable].max()):.2e}" if usable.any() else "n/a"
        name = os.path.basename(str(names[b])) if b < len(names) else f"path {b}"
        lines.append(
            f"{name[:24]:<24} {res.P:>4} {np.mean(res.status[b] == SOLVED):>7.0%} {np.mean(usable):>7.0%} "
            f"{np.mean(a_ok):>7.0%} {np.mean(r_ok):>11.0%} {np.mean(a_ok & r_ok):>9.0%} {perr:>16} "
            f"{1e3 * np.median(res.time_s[b]):>12.1f}"
        )
    inside = float((res.meta.get("timing_s") or {}).get("compile_in_time_s") or 0.0)
    # worth a line when it is a visible share of the times and a visible time (a warm cache leaves
    # a few hundredths of a second, which read as "up to 0.0 s")
    if inside >= 0.1 and inside > 0.05 * float(np.sum(res.time_s)):
        lines.append(
            f"(the waypoints' times in the file, whose median the table shows, include up to {inside:.1f} s of "
            f"JAX compilation inside the timed calls of solver {res.meta.get('solver')!r}; a second run with "
            "the compilation cache shows the run time)"
        )
    return "\n".join(lines)


def rate_limits(robot: Robot, dq_deg: float, dq_m: float | None) -> float | np.ndarray:
    """Per-joint rate limit (n,): revolute joints from --dq-deg (rad), prismatic ones from --dq-m
    (m; default the same number as the revolute joints' radians), a scalar when all are revolute."""
    return joint_rate_limits(robot, math.radians(dq_deg), dq_m)


def joint_rate_limits(robot: Robot, dq: float, dq_m: float | None) -> float | np.ndarray:
    """:func:`rate_limits` from ``dq`` in rad (the field's unit, as :func:`read_setting_flags` gives it)."""
    import numpy as np

    prismatic = robot.prismatic
    if not prismatic.any():
        return dq
    return np.where(prismatic, dq if dq_m is None else dq_m, dq)


# ---------------------------------------------------------------------- run
def _read_numbers(args: argparse.Namespace) -> dict[str, Any]:
    """The settings flags (``{field: value}``, dq in rad) and the other numeric flags, checked
    (errors name the flag)."""
    v = read_setting_flags(args, ShapeSettings)
    v.update(
        cms_volume=_num(args.cms_volume, "--cms-volume"),
        cms_major=_num(args.cms_major, "--cms-major"),
        dq_m=_num(args.dq_m, "--dq-m"),
    )
    for key, flag, unit in (("dq", "--dq-deg", "degrees"), ("dq_m", "--dq-m", "m"), ("dk", "--dk", "Nm/rad")):
        x = v[key]
        if x is not None and (math.isnan(x) or x < 0):
            raise ValueError(
                f"{flag} must be >= 0 ({unit} per waypoint), got {getattr(args, flag[2:].replace('-', '_'))}"
            )
    return v


def _unused_flags(v: dict[str, Any], robot: Robot) -> list[str]:
    """Flags given that this run does not read (said before any work, as ``jaxstiff csc`` does)."""
    notes = []
    default = ShapeSettings()
    criterion = v.get("criterion") or default.criterion
    c = v.get("c")
    # the flags fill in the default; a value that is refused anyway (ShapeSettings) gets the
    # refusal alone, not a warning that it is unused first
    if c is not None and c != default.c and criterion != "f1" and math.isfinite(c) and c >= 0:
        notes.append(f"--c is the offset of criterion f1; unused with --criterion {criterion}")
    if v.get("dq_m") is not None and not robot.prismatic.any():
        notes.append(f"--dq-m is the rate limit of prismatic joints; {robot.name!r} has none, so it is unused")
    return notes


def _settings(args: argparse.Namespace, v: dict[str, Any], robot: Robot) -> dict[str, Any]:
    """The keywords of :func:`~jaxstiff.shaping.run_shape` for the settings flags: every field of
    :class:`jaxstiff.settings.ShapeSettings` as a keyword (checked there, with its messages), the
    rate limits as ``dq`` / ``dk`` per joint or as a ``settings`` object for the per-metre ones
    (:func:`limit_kwargs`), and a field that ``run_shape`` does not take (one of a settings class
    derived from it, the flags' ``ShapeSettings``) in ``settings``."""
    from jaxstiff import settings as real

    limits = limit_kwargs(args, joint_rate_limits(robot, v["dq"], v["dq_m"]), v["dk"])
    settings = limits.pop("settings", None)
    taken = set(real.ShapeSettings.field_names())
    fields = {k: v[k] for k in setting_flags(ShapeSettings) if k not in ("dq", "dk", "dq_per_m", "dk_per_m")}
    rest = {k: x for k, x in fields.items() if k not in taken and x is not None}
    if rest:
        settings = (settings or ShapeSettings()).replace(**rest)
    out = {k: x for k, x in fields.items() if k in taken and x is not None}
    return {**out, **limits, **({} if settings is None else {"settings": settings})}


def _read_paths(files: list[str] | None) -> tuple[Path, list[str]]:
    """The --path files as one batch (equal lengths), and their names for meta; default path."""
    from jaxstiff.paths import Path, default_path

    if not files:
        return default_path(), ["(shipped default path)"]
    paths = [Path.from_csv(f) for f in files]
    Ps = sorted({pp.P for pp in paths})
    if len(Ps) > 1:
        raise ValueError(
            f"--path: all paths of one run need the same number of waypoints, got {Ps}; run them separately"
        )
    return (paths[0] if len(paths) == 1 else Path.stack(paths)), [os.path.abspath(f) for f in files]


def _read_start_states(args: argparse.Namespace, robot: Robot) -> tuple[list[float] | None, Any]:
    """--q0 (n values) and --kj0 (1, n or, with rigid locked joints, n_free values)."""
    q0 = _nums(args.q0, "--q0")
    if q0 is not None and len(q0) != robot.n:
        raise ValueError(
            f"--q0 needs {robot.n} values (one per joint of {robot.name!r}: {', '.join(robot.joint_names)}), got {len(q0)}"
        )
    kj0 = _nums(args.kj0, "--kj0")
    rigid = getattr(args, "locked_joints", "rigid") == "rigid" and robot.n_free < robot.n
    if kj0 is not None and len(kj0) not in (1, robot.n) and not (rigid and len(kj0) == robot.n_free):
        also = f" or {robot.n_free} (one per free joint: the locked ones are rigid)" if rigid else ""
        raise ValueError(f"--kj0 needs 1 or {robot.n} values{also}, got {len(kj0)}")
    return q0, (kj0[0] if kj0 is not None and len(kj0) == 1 else kj0)


def _none_choice_options() -> frozenset[str]:
    """The solver options whose choices include the text "none" but not None."""
    from jaxstiff.settings._solvers import OPTIONS_OF

    return frozenset(
        f.name
        for cls in {c for classes in OPTIONS_OF.values() for c in classes}
        for f in cls.fields_info()
        if f.choices is not None and "none" in f.choices and None not in f.choices
    )


_NONE_CHOICES = _none_choice_options()


def read_options(items: list[str] | None) -> dict[str, Any]:
    """--option KEY=VALUE (repeatable) as the solver's options dict: a value is read as an integer,
    a number, true/false or none where it is one, else kept as text (the solver checks each
    option's name and value, :func:`jaxstiff.solvers._configs.solver_from_name`)."""
    out: dict[str, Any] = {}
    for item in items or ():
        key, eq, text = item.partition("=")
        key, text = key.strip(), text.strip()
        if not eq or not key or not text:
            raise ValueError(f"--option {item!r}: expected KEY=VALUE, e.g. --option iters=60")
        if key in out:
            raise ValueError(f"--option {key!r} is given twice ({out[key]!r} and {text!r})")
        low = text.lower()
        value: Any
        if low in ("true", "false"):
            value = low == "true"
        elif low in ("none", "null"):
            # the word none: None, except for an option whose choices name "none" and not None
            # (pgd's first_exact, slsqp's target_step): that choice
            value = "none" if key in _NONE_CHOICES else None
        else:
            try:
                value = int(text)
            except ValueError:
                try:
                    value = float(text)
                except ValueError:
                    value = text
        out[key] = value
    return out


def _solve_and_save(args: argparse.Namespace, out: str, kw: dict[str, Any], total: int) -> tuple[ShapeResult, str]:
    """Run :func:`jaxstiff.shape` with a progress bar; an interrupt keeps what was finished (SLSQP)."""
    import numpy as np

    from jaxstiff.results import _files as R
    from jaxstiff.shaping import ShapeInterrupted
    from jaxstiff.shaping import run_shape as shape_all_inputs

    if args.solver in ("pgd", "trajectory", "hybrid") and not args.quiet:
        print(
            f"shape: solver {args.solver} solves all {kw['path'].B} path(s) x {kw['path'].P} waypoints as one batch "
            "(compiling, then solving; no per-waypoint progress until then, and Ctrl-C takes effect when it ends) ...",
            file=sys.stderr,
            flush=True,
        )
    try:
        with progress(total, "shape", "waypoints", enabled=not args.quiet) as bar:
            res = shape_all_inputs(progress=WaypointProgress(bar), **kw)
            # the batch solvers tick no waypoint: the line says what was done ("60/60", not "0/60")
            bar.update(int(np.sum(res.status != R.NOT_RUN)) - bar.n)
    except ShapeInterrupted as e:  # keep what was finished, then stop as interrupted
        st = e.result.status
        if np.all(st == R.NOT_RUN):
            print("\njaxstiff: nothing was written (no waypoint was finished)", file=sys.stderr)
            raise
        # an earlier result at --out is not replaced by a part of this run: it goes beside it
        kept = os.path.exists(out)
        target = _interrupted_name(out) if kept else out
        with deferred_interrupts():
            written = save_or_rescue(e.result.save, target)
        print(
            f"\njaxstiff: interrupted: wrote {written} with the {int((st != R.NOT_RUN).sum())} of {st.size} "
            f"waypoints finished before it; the others have status {R.NOT_RUN} (not run)"
            + (f"; the earlier {out} is kept as it was" if kept else ""),
            file=sys.stderr,
        )
        raise
    except KeyboardInterrupt:
        why = (
            "it solves all paths together"
            if args.solver not in SINGLE_START_SOLVERS
            else "the interrupt came before the first waypoint was finished"
        )
        print(f"\njaxstiff: nothing was written (solver {args.solver!r}: {why})", file=sys.stderr)
        raise
    with deferred_interrupts():  # the work is done: an interrupt now still gets the file
        written = save_or_rescue(res.save, out)
    if interrupt_pending() is not None:
        print(f"\njaxstiff: interrupted after the last waypoint: wrote the complete result {written}", file=sys.stderr)
        raise KeyboardInterrupt
    return res, written


def _interrupted_name(out: str) -> str:
    """Where an interrupted run's part goes when ``out`` already holds a file: ``x.npz`` ->
    ``x.interrupted.npz`` (an earlier part there is replaced)."""
    stem, ext = os.path.splitext(out)
    return f"{stem}.interrupted{ext or '.npz'}"


def _report(args: argparse.Namespace, res: ShapeResult, written: str) -> int:
    """The summary table; exit 3 when no waypoint is usable."""
    from jaxstiff.results import _files as R

    if not args.quiet:
        print(summary_table(res))
        print(f"wrote {written}  ({res.B} path(s) x {res.P} waypoints; status codes: see jaxstiff.results)")
    # waypoints without a usable solution were named by shape()'s warning (UnusableWaypointsWarning)
    usable = R.is_usable(res.status)
    return 0 if usable.any() else 3  # 3: the file is written, but holds no usable waypoint


def run_shape(args: argparse.Namespace) -> int:
    """``jaxstiff shape``: check everything before any work (bad input never leaves a file), solve,
    save, report. Returns the exit status (see the epilog)."""
    import numpy as np

    from jaxstiff.runtime._x64 import enable_x64
    from jaxstiff.shaping import prefer_sync_cpu_dispatch

    out = check_out_file(args.out)
    v = _read_numbers(args)
    spec = robot_spec_from_args(args)
    robot = spec.build()
    path, path_files = _read_paths(args.path)
    q0, kj0 = _read_start_states(args, robot)
    for note in _unused_flags(v, robot):
        print(f"jaxstiff: warning: {note}", file=sys.stderr)
    enable_x64()
    prefer_sync_cpu_dispatch()  # per-waypoint SLSQP is latency-bound: see its docstring
    kw = dict(
        robot=robot,
        path=path,
        q0=None if q0 is None else np.asarray(q0),
        kj0=kj0,
        **_settings(args, v, robot),
        cms_volume=v["cms_volume"],
        cms_major=v["cms_major"],
        meta_extra={"path_files": path_files, "robot_spec": spec.meta(), "cli": cli_record(args)},
    )
    options = read_options(args.option)
    if options:
        kw["options"] = options
    res, written = _solve_and_save(args, out, kw, path.B * path.P)
    return _report(args, res, written)


@command("shape", "shape the stiffness ellipsoid along TCP paths (seed 000): per-waypoint SLSQP -> .npz")
def _add_shape(p: argparse.ArgumentParser) -> Any:
    add_shape_flags(p)
    return run_shape


def cli_record(args: argparse.Namespace) -> dict:
    """``meta["cli"]``: the flags as the command line gave them. Numbers are text, as typed (a default
    as ``str(value)``, e.g. ``"2.0"``), so a file says what was asked, not what it was parsed into."""
    out = {}
    for k, val in vars(args).items():
        if k.startswith("_"):
            continue
        out[k] = str(val) if isinstance(val, (int, float)) and not isinstance(val, bool) else val
    return out
