"""``jaxstiff csc``: a Configuration-based Stiffness Control rollout (seed 001) from the command line.

Examples::

    # the project's planar hold case (seed 001 has no simulation example): hold a point, K_xd = R(30 deg) diag(3000, 1000) R^T N/m
    # (--hold takes --step constant --beta 2e-3 unless they are given: HOLD_STEP, HOLD_BETA)
    jaxstiff csc --robot planar_3r --hold 1.50005,0 --kxd 3000,1000@30 --q0-deg 75,-74.74,-76.30 \\
                 --steps 1000 --out hold.npz

    # the LWR (its 7th joint locked at 0 by default, as in `jaxstiff shape`) along a CSV path, task xyz;
    # q0 puts the TCP on the first point of jaxstiff.paths.line((0.5, -0.1, 0.4), (0.5, 0.1, 0.4), 20)
    jaxstiff csc --robot kuka_lwr4 --path path.csv --kxd 3000,1000,2000@30 \\
                 --q0 0.003,0.41,-0.233,-1.721,-0.026,0.74,0 --beta 1 --out lwr.npz

``--hold`` without ``--step`` runs the constant step rule (a null step of ``--beta`` rad per step,
default 2e-3 there): the adaptive rule's null step is beta times the primary step (S1-22), zero
while the target stands still, so a held arm would not move. ``--step adaptive`` with ``--hold``
still runs as asked, with a warning.

``--kxd`` (N/m; for m = 6 the blocks [[N/m, N/rad], [Nm/m, Nm/rad]]): either the diagonal ``K1,...,Km`` optionally followed by ``@DEG``, meaning
``R_z(DEG) diag(K1..Km) R_z(DEG)^T`` (a rotation about the base z axis; m = 2 or 3), or the full
symmetric matrix as m*m comma-separated numbers, row by row (m = 2, 3 or 6). The task follows from
m (2 -> xy, 3 -> xyz, 6 -> full) unless ``--task`` is given.

The result file (``.npz``, ``numpy.load(..., allow_pickle=False)``) has a leading axis B over the
paths (B = 1 for ``--hold`` or one ``--path``), T steps, n joints: the arrays of
:class:`jaxstiff.CSCResult` (``q (B,T,n)``, ``u (B,T)``, ``frobenius``, ``tracking_error``,
``orientation_error``, ``kj (B,T,n)``, ``K_C (B,T,m,m)``, ``position (B,T,3)``, ``target (B,T,d)``,
``isotropy``, ``null_step``, ``status`` (bit mask, documented in meta), ``u_start (B,)``,
``frobenius_start (B,)``), plus ``joint_names (n,)``, ``q0 (n,)``, ``K_xd (m,m)`` and ``meta`` (JSON:
every input and default, ``settings`` (the CSCSettings values with their units), ``robot_spec``
(the robot flags as RobotSpec), the robot's URDF path and sha256, units per array, versions). Written atomically.

A run of more than :data:`SEGMENT_WORK` rollout-steps (paths x steps) runs as
:func:`jaxstiff.csc.csc_rollout_segments`: segments of equal length (one compilation), a progress
line after each, and Ctrl-C or SIGTERM writes the finished steps (``meta["interrupted"]`` true,
``meta["steps"]`` the rows written) and exits 130 / 143. A shorter run is one compiled call.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time
from typing import Any

import numpy as np

from jaxstiff.cli._common import (
    add_robot_flags,
    check_out_file,
    check_rollout_size,
    command,
    reads,
    robot_spec_from_args,
    writes,
)
from jaxstiff.cli._csc_flags import M_TASK, parse_numbers
from jaxstiff.cli._csc_flags import SETTING_FLAGS as SETTING_FLAGS
from jaxstiff.cli._csc_flags import add_setting_flags as add_setting_flags
from jaxstiff.cli._csc_flags import parse_kxd as parse_kxd
from jaxstiff.cli._csc_flags import settings_from_args as settings_from_args
from jaxstiff.csc._inputs import check_planar_task
from jaxstiff.csc._segments import StepProgress
from jaxstiff.runtime._io import check_regular_file, deferred_interrupts, interrupt_pending, save_or_rescue
from jaxstiff.settings._csc import DEFAULT_JL_GAIN as DEFAULT_JL_GAIN  # (re-exported: the former --jl-gain default)
from jaxstiff.settings._csc import CSCSettings
from jaxstiff.settings._shape import task_dim

TRACKING_WARN_M = 1e-3  #: a path ending further than this (m) from its last waypoint gets a warning on stderr
#: rollout-steps per segment of a long run: a progress line after each, an interrupt keeps the
#: finished ones, and a signal is acted on when the segment in flight ends (Python's handler waits
#: for the compiled loop), so a segment is kept short: one rollout of the 7-joint LWR takes about
#: 17 us per step on a CPU core, 50,000 steps under 1 s (500,000 made SIGTERM wait up to 14 s)
SEGMENT_WORK = 50_000
MIN_SEGMENT = 10


def segment_steps(B: int, T: int) -> int:
    """Steps per segment for B rollouts of T steps (T itself for a short run: one compiled call)."""
    return int(min(T, max(MIN_SEGMENT, math.ceil(SEGMENT_WORK / max(B, 1)))))


def _warn_ignored_z(robot: Any, q0: np.ndarray, z: np.ndarray, flag: str) -> None:
    """Task "xy" tracks x and y only: say so when the targets' z is not the TCP's (> 1 mm apart)."""
    z_tcp = float(np.asarray(robot.fk(q0))[2, 3])
    dz = float(np.max(np.abs(z - z_tcp)))
    if not dz <= TRACKING_WARN_M:
        print(
            f"jaxstiff: warning: task 'xy' tracks x and y only: the z of {flag} (up to {dz:.3g} m from the "
            f"start TCP's z = {z_tcp:.3g} m) is ignored",
            file=sys.stderr,
        )


def power_of_ten_text(n: int) -> str:
    """``50_000`` -> ``"5 x 10^4"`` (``"10^4"``, ``"1.5 x 10^4"``; below 1000, or not a few digits
    times a power of ten, the plain number: ``"300"``, ``"12,345"``): how the help and the README
    write :data:`SEGMENT_WORK`."""
    n = int(n)
    k = len(str(abs(n))) - 1
    mantissa = n / 10**k
    if abs(n) < 1000 or len(f"{mantissa:g}") > 4:  # (more than 3 digits: the plain number reads better)
        return f"{n:,}"
    return f"10^{k}" if mantissa == 1 else f"{mantissa:g} x 10^{k}"


#: the epilog of ``jaxstiff csc --help``; ``{segment_work}`` is :data:`SEGMENT_WORK`, filled in when
#: the parser is built (so the help cannot drift from the code)
_EPILOG = (
    "Result file (--out, .npz, numpy.load(..., allow_pickle=False)); B paths (1 for --hold), T steps, n joints, "
    "m task rows, d target coordinates: q (B,T,n), u (B,T), frobenius (B,T), tracking_error (B,T), "
    "orientation_error (B,T, rad), kj (B,T,n), K_C (B,T,m,m), position (B,T,3), target (B,T,d), isotropy (B,T), "
    "null_step (B,T), status (B,T) bit mask, u_start (B,), frobenius_start (B,), joint_names (n,), q0 (n,), "
    "K_xd (m,m), and meta (JSON: every input and default, settings with units (objective, locked_joints too), "
    "units per array, status bits, versions). A rigid locked joint (--locked-joints rigid, the default) has no "
    "spring: its kj is +inf (infinite stiffness) and K_C sums over the free joints. Row k is the posture after step k, measured against waypoint k. Units: rad and Nm/rad (m and N/m "
    "for prismatic joints), N/m, m. A long run (paths x steps over {segment_work}) runs in segments with a progress line "
    "after each; Ctrl-C or SIGTERM then writes the steps finished so far (meta 'interrupted' true, 'steps' = rows "
    "written, 'steps_requested'). Exit status: 0 written; 2 bad input (nothing written); 1 the system refused the file (a "
    "full disk, a read-only folder): the result was written elsewhere, and the message says where; 130 / 143 interrupted by "
    "Ctrl-C / SIGTERM."
)


#: steps of ``--hold`` when ``--steps`` is not given
HOLD_STEPS = 1000
#: ``--hold`` without ``--step``: the constant step rule (the adaptive null step is beta |dq_P|, zero
#: while the target stands still: the arm would not move), with this null-step length (rad per step)
#: unless ``--beta`` is given: small enough that one Newton correction keeps the TCP on the point
HOLD_STEP = "constant"
HOLD_BETA = 2e-3


@command("csc", "Configuration-based Stiffness Control (seed 001): follow a path or hold a point, lower u(q)")
def _add_csc(p: argparse.ArgumentParser):
    p.epilog = _EPILOG.replace("{segment_work}", power_of_ten_text(SEGMENT_WORK))
    add_robot_flags(p)
    src = p.add_mutually_exclusive_group(required=True)
    path = src.add_argument(
        "--path",
        action="append",
        metavar="CSV",
        help="path CSV (header x,y,z[,dx,dy,dz]; m, base frame; directions unused), one step per row (a repeated row holds still); repeat for a batch",
    )
    reads(path)
    src.add_argument("--hold", metavar="X,Y[,Z]", help="hold the TCP at this point (m) for --steps steps")
    p.add_argument(
        "--steps",
        type=int,
        default=None,
        help=f"steps with --hold (default {HOLD_STEPS}; a --path has one step per row)",
    )
    p.add_argument(
        "--kxd",
        required=True,
        help="desired Cartesian stiffness: 'K1,...,Km[@DEG]' (R_z(DEG) diag(K) R_z^T) or m*m entries; N/m for "
        "m = 2 (task xy) and 3 (xyz); for m = 6 (task full) the blocks [[N/m, N/rad], [Nm/m, Nm/rad]] "
        "(translation x, y, z, then rotation rx, ry, rz). Two values select task xy, which only planar arms "
        "take (z would drift); give three for a spatial arm",
    )
    q0 = p.add_mutually_exclusive_group(required=True)
    q0.add_argument(
        "--q0",
        metavar="RAD,...",
        help="start posture, rad; m for prismatic joints (locked joints: their locked values); 'ik': position IK "
        "from the nominal posture onto the first target (--hold's point, or the one --path's first row), so the "
        "run starts on the path",
    )
    q0.add_argument("--q0-deg", metavar="DEG,...", help="start posture, degrees (prismatic joints: m)")
    add_setting_flags(
        p, later={"step": f"; with --hold: {HOLD_STEP}", "beta": f"; with --hold: {HOLD_BETA:g} rad per step"}
    )
    writes(
        p.add_argument("--out", required=True, metavar="FILE.npz", help="result file (written atomically)"),
        suffix=".npz",
    )
    return run_csc


def _ik_start(args: argparse.Namespace) -> bool:
    """``--q0 ik``: the start posture by IK onto the first target."""
    return args.q0 is not None and args.q0.strip().lower() == "ik"


def _ik_posture(robot: Any, points: np.ndarray, task: str) -> np.ndarray:
    """``--q0 ik``: damped least-squares IK from the nominal posture onto ``points[0, 0]`` (x, y only
    for task xy); refused where there are several paths (one q0 serves them all) or IK misses."""
    from jaxstiff.ik import ik_position, nominal_posture

    if points.shape[0] != 1:
        raise ValueError(f"--q0 ik takes one --path (or --hold), got {points.shape[0]} paths: give --q0 / --q0-deg")
    first = np.asarray(points[0, 0], float)
    target = np.r_[first, 0.0] if first.shape[0] == 2 else first
    q, err = ik_position(robot, target, nominal_posture(robot), planar=task == "xy")
    if not err <= 1e-6:
        raise ValueError(
            f"--q0 ik: IK from the nominal posture ends {err:.3g} m from the first target {first.tolist()} m; "
            "give a start posture near it with --q0 / --q0-deg"
        )
    return np.asarray(q, float)


def _start_posture(args: argparse.Namespace, robot: Any) -> tuple[np.ndarray, str]:
    """q0 (n,) in rad (m for prismatic joints) from --q0 or --q0-deg, locked joints checked; and the flag."""
    flag = "--q0" if args.q0 is not None else "--q0-deg"
    typed = np.asarray(parse_numbers(args.q0 if args.q0 is not None else args.q0_deg, flag), dtype=float)
    q0 = typed
    if args.q0 is None and typed.shape == (robot.n,):
        q0 = np.where(robot.prismatic, typed, np.deg2rad(typed))  # degrees for revolute joints; prismatic: m
    if q0.shape != (robot.n,):
        raise ValueError(
            f"{flag} needs {robot.n} values for {robot.name!r} ({', '.join(robot.joint_names)}), got {q0.size}"
        )
    lv = robot.locked_values
    for i in np.flatnonzero(~robot.free):  # the help: locked joints take their locked values
        given = q0[i] if args.q0 is not None or robot.prismatic[i] else np.rad2deg(q0[i])
        want = lv[i] if args.q0 is not None or robot.prismatic[i] else np.rad2deg(lv[i])
        if not abs(given - want) <= (1e-9 if args.q0 is not None else 1e-3):
            unit = "m" if robot.prismatic[i] else ("rad" if args.q0 is not None else "deg")
            raise ValueError(
                f"{flag} gives joint {robot.joint_names[i]!r} {given:.10g} {unit}, but it is locked at "
                f"{want:.10g} {unit}: give the locked value there (or change --lock)"
            )
    check_q0_limits(robot, q0, flag, typed)
    return np.where(robot.free, q0, np.nan_to_num(lv)), flag


def check_q0_limits(robot: Any, q0: np.ndarray, flag: str, typed: np.ndarray) -> None:
    """Refuse a free joint of ``q0`` (rad; m for prismatic joints) outside its limits, in the unit of
    ``flag`` (``typed``: the values as given, degrees for ``--q0-deg``), before any work; the
    library's own check of ``q0`` says rad."""
    from jaxstiff.csc._inputs import joints_outside_limits

    bad = joints_outside_limits(robot, q0)  # the library's rule; here reported in the flag's unit
    if not bad.any():
        return
    i = int(np.argmax(bad))
    deg = flag == "--q0-deg" and not robot.prismatic[i]
    unit = "m" if robot.prismatic[i] else ("deg" if deg else "rad")
    lo, hi = (np.rad2deg(robot.lower[i]), np.rad2deg(robot.upper[i])) if deg else (robot.lower[i], robot.upper[i])
    value = float(typed[i])
    edge = float(lo if value < lo else hi)
    digits = 6  # as `jaxstiff shape`'s q0 message; more where the value and the limit would read alike
    while digits < 15 and f"{value:.{digits}g}" == f"{edge:.{digits}g}":
        digits += 1
    raise ValueError(
        f"{flag}: joint {robot.joint_names[i]!r} (q0[{i}]) = {value:.{digits}g} {unit} is outside its limits "
        f"[{lo:.{digits}g}, {hi:.{digits}g}] {unit}"
    )


def _targets(args: argparse.Namespace, robot: Any, q0: np.ndarray | None, task: str) -> tuple[np.ndarray, list[str]]:
    """The (B, T, d) targets of --hold or --path, and their sources for meta (``q0`` None: not known
    yet, ``--q0 ik``; the warning about an ignored z is then left out)."""
    d = task_dim(task)
    if args.hold is not None:
        x = parse_numbers(args.hold, "--hold")
        if len(x) not in (d, 3):
            raise ValueError(f"--hold needs {d} coordinates (m) for task {task!r}, got {len(x)}")
        steps = HOLD_STEPS if args.steps is None else args.steps
        check_rollout_size(1, steps, robot.n, task, "--steps")
        points = np.tile(np.asarray(x), (1, steps, 1))
        sources = [f"hold {x}"]
    else:
        from jaxstiff.paths import read_csv

        pts = []
        for f in args.path:
            check_regular_file(f, "--path")
            # the points only: one step per row, repeated rows hold still, directions unused
            pts.append(read_csv(f)[0])
        lengths = {len(a) for a in pts}
        if len(lengths) != 1:
            raise ValueError(f"--path: all paths of one run need the same number of waypoints, got {sorted(lengths)}")
        check_rollout_size(len(pts), len(pts[0]), robot.n, task, "--path (fewer rows or paths)")
        points = np.stack(pts)
        sources = [os.path.abspath(f) for f in args.path]
    if task == "xy" and points.shape[-1] == 3:
        if q0 is not None:
            _warn_ignored_z(robot, q0, points[..., 2], "--hold" if args.hold is not None else "--path")
        points = points[..., :2]
    return points, sources


def _notes(args: argparse.Namespace, settings: CSCSettings) -> list[str]:
    """Warnings about the settings, printed once the inputs are known to be valid."""
    # (--hold with --step adaptive, and an arm with no null space for the task, are warned about by
    # the library itself, once per rollout call: jaxstiff.csc._inputs.warn_settings)
    notes = []
    if settings.joint_limits != "off" and settings.resolved_jl_gain == 0:
        notes.append(
            f"--joint-limits {settings.joint_limits} with --jl-gain 0 does nothing (the avoidance is scaled by the gain)"
        )
    if settings.joint_limits == "off" and settings.jl_gain:
        notes.append("--jl-gain is unused with --joint-limits off")
    return notes


def _rollout(
    robot: Any, points: np.ndarray, K: np.ndarray, q0: np.ndarray, settings: CSCSettings, notes: list[str]
) -> tuple[Any, bool, float]:
    """The rollout in segments (a progress line each); an interrupt keeps the finished ones.
    Returns ``(result, interrupted, seconds)``."""
    from jaxstiff.csc import CSCInterrupted, csc_rollout_segments

    t0 = time.perf_counter()
    B, T = points.shape[:2]
    L = segment_steps(B, T)
    interrupted = False
    try:
        res = csc_rollout_segments(
            robot,
            points,
            K,
            q0,
            settings.beta,
            segment_steps=L,
            progress=StepProgress(B, T, L, notes),
            settings=settings,
        )
    except CSCInterrupted as e:
        res, interrupted = e.result, True
    except KeyboardInterrupt:
        print(
            "\njaxstiff: nothing was written (the interrupt came before the first "
            + ("segment" if L < T else "and only compiled run")
            + " was finished)",
            file=sys.stderr,
        )
        raise
    return res, interrupted, time.perf_counter() - t0


def _meta(
    args: argparse.Namespace,
    spec: Any,
    robot: Any,
    settings: CSCSettings,
    K: np.ndarray,
    q0: np.ndarray,
    flag: str,
    sources: list[str],
    T_done: int,
    T: int,
) -> dict[str, Any]:
    """The result file's ``meta`` record (every input and default, units, versions)."""
    from jaxstiff.csc import STATUS_NAMES
    from jaxstiff.csc._result import array_units
    from jaxstiff.settings._robot import robot_meta, versions

    used = {
        k: settings.task if k == "task" else getattr(settings, k)
        for k in ("task", "step", "kmin", "kmax", "newton", "joint_limits")
    }
    used["jl_gain"] = settings.resolved_jl_gain
    return {
        "kind": "csc",
        "robot": robot_meta(robot),
        "robot_spec": spec.meta(),
        "settings": settings.replace(jl_gain=settings.resolved_jl_gain).meta(),
        "paths": sources,
        "hold": args.hold,
        "steps": int(T_done),
        "steps_requested": int(T),
        "interrupted": T_done < T,
        "kxd": args.kxd,
        "K_xd": K.tolist(),
        "q0": q0.tolist(),
        "q0_arg": {flag: args.q0 if args.q0 is not None else args.q0_deg},
        "beta": settings.beta,
        "nu0": settings.nu0,
        "damping": settings.damping,
        "null_eps": "1e-9 * |K_xd|_F + 1e-77 (tiny^(1/4), float64)" if settings.null_eps is None else settings.null_eps,
        **used,  # (a number that is not finite is spelt "Infinity" by the file's meta writer)
        "status_bits": {str(k): v for k, v in STATUS_NAMES.items()},
        "units": array_units(robot, settings.task or ""),
        "row_k": "posture after step k, measured against waypoint k",
        "versions": versions(),
    }


def _write(out: str, res: Any, robot: Any, q0: np.ndarray, K: np.ndarray, meta: dict[str, Any]) -> str:
    """The result file, written atomically; an interrupt now still gets the file."""
    with deferred_interrupts():  # the rollout is finished (or cut at a segment)
        return save_or_rescue(lambda f: res.save(f, joint_names=robot.joint_names, meta=meta, q0=q0, K_xd=K), out)


def _report(res: Any, robot: Any, settings: CSCSettings, K: np.ndarray, written: str) -> None:
    """The summary on stdout: u, |K_xd - K_C|_F, tracking error, status counts, final posture per path."""
    from jaxstiff.csc import describe_status

    B, T = res.q.shape[0], res.q.shape[-2]
    np.set_printoptions(precision=4, suppress=True, linewidth=120)
    print(
        f"CSC {robot.name!r}, task {settings.task}, {settings.step} step, beta {settings.beta:g}, {T} steps x {B} path(s)"
    )
    locked = [name for name, free in zip(robot.joint_names, robot.free, strict=True) if not free]
    print(
        f"objective {settings.objective} (the null space lowers "
        + ("u, S1-19" if settings.objective == "offdiag" else "|K_xd - K_C|_F")
        + ")"
        + (f"; locked joints {', '.join(locked)}: {settings.locked_joints}" if locked else "")
    )
    print(f"K_xd ({kxd_units(K.shape[0])}):\n{K}")
    for b in range(B):
        u, fr, st = res.u[b], res.frobenius[b], res.status[b]
        change = 100 * (1 - u[-1] / res.u_start[b]) if res.u_start[b] > 0 else 0.0
        print(
            f"[{b}] u: {res.u_start[b]:.6g} -> {u[-1]:.6g} Nm/rad (min {u.min():.6g}, "
            f"{abs(change):.1f}% {'lower' if change >= 0 else 'higher'})"
        )
        print(f"[{b}] |K_xd - K_C|_F: {res.frobenius_start[b]:.6g} -> {fr[-1]:.6g} N/m")
        print(f"[{b}] tracking error: max {res.tracking_error[b].max():.3g} m, last {res.tracking_error[b, -1]:.3g} m")
        counts = {describe_status(c): int(n) for c, n in zip(*np.unique(st, return_counts=True), strict=True)}
        print(f"[{b}] status: {counts}")
        qf = np.where(robot.prismatic, res.q[b, -1], np.rad2deg(res.q[b, -1]))
        unit = "deg; m for prismatic joints" if robot.prismatic.any() else "deg"
        print(f"[{b}] final q ({unit}): {np.round(qf, 3).tolist()}")
    print(f"wrote {written}")


def kxd_units(m: int) -> str:
    """The units of an m x m K_xd as the summary prints them: N/m, or the blocks of the 6x6 (task full)."""
    return "N/m" if m != 6 else "blocks [[N/m, N/rad], [Nm/m, Nm/rad]]: rows/columns x, y, z, rx, ry, rz"


def _warn_tracking(res: Any, robot: Any, q0: np.ndarray, points: np.ndarray) -> None:
    """A warning on stderr per path that ends off its last waypoint, with the likely reason."""
    from jaxstiff.csc import STATUS_DAMPED

    last = res.tracking_error[:, -1]
    off = np.flatnonzero(~(last <= TRACKING_WARN_M))  # (NaN included)
    d = points.shape[-1]
    tcp0 = np.asarray(robot.fk(q0))[:d, 3] if off.size else None  # one start posture for every path
    for b in off:
        start = float(np.linalg.norm(tcp0 - points[b, 0]))
        hint = (
            f"the start posture's TCP is {start:.3g} m from the first waypoint, and a CSC step is a "
            "linearisation: start on the path"
            if start > 10 * TRACKING_WARN_M
            else "the path may leave the workspace or the joint limits, or the null-space step is too large "
            "(try a smaller --beta)"
        )
        if int(res.status[b, 0]) & STATUS_DAMPED and int(res.status[b, -1]) & STATUS_DAMPED:
            hint += (
                "; the arm started at and stayed in a (near) singular posture, where the damped step "
                "cannot move along the direction the Jacobian lost: start from a bent posture"
            )
        print(
            f"jaxstiff: warning: path {b} ends {last[b]:.3g} m from its last waypoint "
            f"(max {res.tracking_error[b].max():.3g} m): {hint}",
            file=sys.stderr,
        )


def run_csc(args: argparse.Namespace) -> int:
    """``jaxstiff csc``: check every flag, run the rollout, write the file, report (module docstring)."""
    from jaxstiff.runtime._x64 import enable_x64

    enable_x64()
    if args.steps is not None and args.path:
        raise ValueError("--steps applies to --hold; a --path has one step per row (repeat a row to hold it still)")
    if args.steps is not None and args.steps < 1:
        raise ValueError(f"--steps must be >= 1, got {args.steps}")
    if args.hold is not None and args.step is None:  # a held point needs the step rule that moves
        args.step = HOLD_STEP
        args.beta = HOLD_BETA if args.beta is None else args.beta
    settings = settings_from_args(args)  # the numeric flags first (named as flags), before any work or warning
    out = check_out_file(args.out)
    spec = robot_spec_from_args(args)
    robot = spec.build()
    K = parse_kxd(args.kxd, settings.task)
    settings = settings.replace(task=settings.task or M_TASK[K.shape[0]])
    check_planar_task(robot, settings.task or "")  # task xy on an arm that moves z: refused before any work
    if _ik_start(args):
        points, sources = _targets(args, robot, None, settings.task or "")
        q0, flag = _ik_posture(robot, points, settings.task or ""), "--q0"
    else:
        q0, flag = _start_posture(args, robot)
        points, sources = _targets(args, robot, q0, settings.task or "")
    res, interrupted, seconds = _rollout(robot, points, K, q0, settings, _notes(args, settings))
    T, T_done = points.shape[1], res.q.shape[-2]
    partial = T_done < T  # (an interrupt while the last segment was joined still has every step)
    print(f"csc: {'interrupted' if partial else 'done'} in {seconds:.1f} s", file=sys.stderr)
    written = _write(out, res, robot, q0, K, _meta(args, spec, robot, settings, K, q0, flag, sources, T_done, T))
    if partial:
        print(
            f"\njaxstiff: interrupted: wrote {written} with the {T_done} of {T} steps finished before it "
            "(meta 'interrupted' is true, 'steps' says how many)",
            file=sys.stderr,
        )
        raise KeyboardInterrupt
    if interrupted or interrupt_pending() is not None:
        print(f"\njaxstiff: interrupted after the last step: wrote the complete result {written}", file=sys.stderr)
        raise KeyboardInterrupt
    _report(res, robot, settings, K, written)
    _warn_tracking(res, robot, q0, points)
    return 0
