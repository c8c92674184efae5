"""``jaxstiff shape``: stiffness-ellipsoid shaping along TCP paths, result file ``.npz`` (seed 000).

With no arguments it runs the shipped default: the KUKA LWR 4 with its 7th joint locked at 0 (as
in seed 000), the shipped default path, criterion f2 with ratio 5, written to ``shape.npz``.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time

from jaxstiff.runtime.io import deferred_interrupts, interrupt_pending, raise_if_interrupted
from jaxstiff.cli.common import TIP_LINK_HELP, check_out_file, command, parse_locks

_DEFAULT_LOCK = {"kuka_lwr4": {"lwr_a7": 0.0}}


def _num(text, flag: str, cast=float):
    if text is None:
        return None
    try:
        v = cast(text)
    except (TypeError, ValueError):
        raise ValueError(f"{flag}: expected a number, got {text!r}") from None
    return v


def _nums(text, flag: str) -> list[float] | None:
    if text is None:
        return None
    out = []
    for part in str(text).split(","):
        part = part.strip()
        if not part:
            continue
        try:
            out.append(float(part))
        except ValueError:
            raise ValueError(f"{flag}: expected comma-separated numbers, got {text!r}") from None
    if not out:
        raise ValueError(f"{flag}: no numbers given")
    return out


class _Progress:
    """A progress bar with ETA on stderr (redrawn in place on a terminal, a line every 5 s otherwise)."""

    def __init__(self, total: int, enabled: bool):
        self.total, self.enabled = total, enabled
        self.done = 0
        self.t0 = time.perf_counter()
        self.t1 = self.t0
        self.last = 0.0
        self.tty = sys.stderr.isatty()

    def __call__(self, b: int, p: int) -> None:
        raise_if_interrupted()  # a Ctrl-C that JAX swallowed stops the run at the next waypoint
        self.done += 1
        now = time.perf_counter()
        if self.done == 1:
            self.t1 = now  # the rate leaves out the first waypoint: compilation and its start postures
        if not self.enabled:
            return
        if self.done < self.total and now - self.last < (0.2 if self.tty else 5.0):
            return
        self.last = now
        el = now - self.t0
        rate = (self.done - 1) / (now - self.t1) if self.done > 1 and now > self.t1 else 0.0
        eta = f"{(self.total - self.done) / rate:6.1f} s" if rate > 0 else "   ..."
        width = 30
        fill = int(width * self.done / max(self.total, 1))
        msg = (f"shape [{'#' * fill}{'.' * (width - fill)}] {self.done}/{self.total} waypoints "
               f"(path {b})  {el:6.1f} s  ETA {eta}")  # 0-based, as the result file and the warnings
        if self.tty:
            sys.stderr.write("\r" + msg + ("\n" if self.done >= self.total else ""))
        else:
            sys.stderr.write(msg + "\n")
        sys.stderr.flush()


def summary_table(res) -> str:
    """Per path: waypoints, statuses, share with alpha < 1 deg, share with the ratio met, errors, time."""
    import numpy as np

    from jaxstiff.results.files import SOLVED, is_usable

    r = float(res.meta["ratio"])
    crit = res.meta["criterion"]
    rlabel = f"rho>={0.98 * r:g}" if crit == "f1" else "|rho-r|<2%"
    names = res.meta.get("path_files") or [res.meta.get("path", {}).get("name", "path")] * res.B
    lines = [
        f"{'path':<24} {'P':>4} {'solved':>7} {'usable':>7} {'a<1deg':>7} {rlabel:>11} {'both':>6} "
        f"{'max pos err (m)':>16} {'ms/waypoint':>12}"
    ]
    for b in range(res.B):
        a_ok = res.alpha_deg[b] < 1.0
        r_ok = res.ratio[b] >= 0.98 * r if crit == "f1" else np.abs(res.ratio[b] - r) / r < 0.02
        usable = is_usable(res.status[b])
        perr = f"{float(res.pos_error[b][usable].max()):.2e}" if usable.any() else "n/a"
        name = os.path.basename(str(names[b])) if b < len(names) else f"path {b}"
        lines.append(
            f"{name[:24]:<24} {res.P:>4} {np.mean(res.status[b] == SOLVED):>7.0%} {np.mean(usable):>7.0%} "
            f"{np.mean(a_ok):>7.0%} {np.mean(r_ok):>11.0%} {np.mean(a_ok & r_ok):>6.0%} {perr:>16} "
            f"{1e3 * np.median(res.time_s[b]):>12.1f}"
        )
    return "\n".join(lines)


def _rate_limits(robot, dq_deg: float, dq_m: float | None):
    """Per-joint rate limit (n,): revolute joints from --dq-deg (rad), prismatic ones from --dq-m
    (m; default the same number as the revolute joints' radians), a scalar when all are revolute."""
    import numpy as np

    dq = math.radians(dq_deg)
    prismatic = robot.prismatic
    if not prismatic.any():
        return dq
    return np.where(prismatic, dq if dq_m is None else dq_m, dq)


@command("shape", "shape the stiffness ellipsoid along TCP paths (seed 000): per-waypoint SLSQP -> .npz")
def _add_shape(p: argparse.ArgumentParser):
    from jaxstiff.shaping import DEFAULTS

    p.epilog = ("Exit status: 0 the result file was written (each waypoint's status is in it; a warning names "
                "waypoints without a usable solution); 3 written, but no waypoint has a usable solution; 2 bad "
                "input (nothing written); 130 / 143 interrupted by Ctrl-C / SIGTERM: with the SLSQP solvers the "
                "file is written with the waypoints finished so far (the others have status 5, not run; meta "
                "'interrupted' is true), with the batch solvers (pgd, hybrid, trajectory) nothing is written; after the "
                "last waypoint the complete file is still written.")
    p.add_argument("--robot", default="kuka_lwr4", help="URDF file or shipped robot name")
    p.add_argument("--base-link", default=None, help="first link of the chain (default: the URDF root)")
    p.add_argument("--tip-link", default=None, help=TIP_LINK_HELP)
    p.add_argument("--lock", action="append", metavar="JOINT=RAD",
                   help="lock a joint at a value, rad (repeatable). Default for the shipped kuka_lwr4: "
                        "lwr_a7=0 (seed 000); '--lock none' frees every joint")
    p.add_argument("--tcp", default=None, metavar="X,Y,Z", help="tool offset after the tip link, m, in the tip frame (default: none)")
    p.add_argument("--path", action="append", metavar="CSV",
                   help="path file with header x,y,z[,dx,dy,dz], metres in the base frame (repeatable: several "
                        "paths with the same number of waypoints, one result file; messages number them from "
                        "0, in the order given, as the file's first axis). Default: the shipped "
                        "default path (jaxstiff.paths.default_path)")
    p.add_argument("--criterion", default="f2", help="f1 (S0-9: ratio >= R) or f2 (S0-15: ratio = R)")
    p.add_argument("--ratio", default="5", metavar="R", help="wanted axis ratio lambda1/lambda2, > 1")
    p.add_argument("--out", default="shape.npz", metavar="FILE.npz", help="result file (written atomically)")
    p.add_argument("--task", default="full", choices=["full", "xyz", "xy"],
                   help="full: K_T = top-left 3x3 of the 6x6 K_C (seed); xyz: 3x3 K_C; xy: planar 2x2")
    p.add_argument("--q0", default=None, metavar="RAD,...",
                   help="start posture, one value per joint (rad; m for prismatic joints; locked joints at their values); "
                        "default: damped-least-squares IK from the nominal posture to the first waypoint")
    p.add_argument("--kj0", default=None, metavar="V|V,...",
                   help="start joint stiffness, Nm/rad: one value for all joints or one per joint "
                        "(default: mid-range (kmin+kmax)/2)")
    p.add_argument("--dq-deg", default=str(DEFAULTS["dq_deg"]), metavar="D",
                   help="joint rate limit, degrees per waypoint (inf = none)")
    p.add_argument("--dq-m", default=None, metavar="M",
                   help="rate limit of prismatic joints, m per waypoint (inf = none; default: the value of "
                        "--dq-deg in radians read as metres, 2 -> 0.0349 m)")
    p.add_argument("--dk", default=str(DEFAULTS["dk"]), metavar="K",
                   help="joint-stiffness rate limit, Nm/rad per waypoint (inf = none)")
    p.add_argument("--kmin", default=str(DEFAULTS["kmin"]), metavar="A", help="lowest joint stiffness, Nm/rad, > 0")
    p.add_argument("--kmax", default=str(DEFAULTS["kmax"]), metavar="B", help="highest joint stiffness, Nm/rad, > kmin")
    p.add_argument("--c", default=str(DEFAULTS["c"]), metavar="C", help="f1's offset c (S0-9), deg")
    p.add_argument("--solver", default="slsqp",
                   help="slsqp (JAX derivatives), slsqp-fd (the seed's numpy + finite differences), "
                        "pgd (batched projected gradient), hybrid (pgd + SLSQP polish), trajectory (whole "
                        "trajectory after a greedy warm start), or another registered solver")
    p.add_argument("--starts", default=None, metavar="S", help="starts per waypoint, multi-start solvers only (default: the solver's own)")
    p.add_argument("--first-rate-limit", dest="first_rate_limit", action="store_true",
                   help="apply the rate limits between (q0, kj0) and the first waypoint too (default: the "
                        "first waypoint may use the full joint and stiffness ranges)")
    p.add_argument("--no-first-rate-limit", dest="first_rate_limit", action="store_false",
                   help="the default: do not rate-limit the first waypoint")
    p.set_defaults(first_rate_limit=DEFAULTS["first_rate_limit"])
    p.add_argument("--first-starts", default=str(DEFAULTS["first_starts"]), metavar="N",
                   help="start postures for the first (not rate-limited) waypoint")
    p.add_argument("--cms-volume", default=None, metavar="V",
                   help="CMS target: product of the ellipsoid axes, (N/m)^3 (default: 1000^3, "
                        "i.e. a geometric-mean axis of 1000 N/m)")
    p.add_argument("--cms-major", default=None, metavar="N_PER_M", help="CMS target: major axis lambda1, N/m, instead of the volume")
    p.add_argument("--quiet", action="store_true", help="no progress bar and no summary table")

    def run(args) -> int:
        import numpy as np

        from jaxstiff.results import files as R
        from jaxstiff.runtime.x64 import enable_x64
        from jaxstiff.paths import Path, default_path
        from jaxstiff.model.robot import Robot, robot_path
        from jaxstiff.shaping import ShapeInterrupted, prefer_sync_cpu_dispatch, shape

        # ---- validate everything before any work, so bad input never leaves a file
        out = check_out_file(args.out)
        ratio = _num(args.ratio, "--ratio")
        dq_deg = _num(args.dq_deg, "--dq-deg")
        dk = _num(args.dk, "--dk")
        kmin, kmax = _num(args.kmin, "--kmin"), _num(args.kmax, "--kmax")
        c = _num(args.c, "--c")
        starts = _num(args.starts, "--starts", int)
        first_starts = _num(args.first_starts, "--first-starts", int)
        cms_volume, cms_major = _num(args.cms_volume, "--cms-volume"), _num(args.cms_major, "--cms-major")
        if dq_deg is not None and (math.isnan(dq_deg) or dq_deg < 0):
            raise ValueError(f"--dq-deg must be >= 0 (degrees per waypoint), got {args.dq_deg}")
        dq_m = None if args.dq_m is None else _num(args.dq_m, "--dq-m")
        if dq_m is not None and (math.isnan(dq_m) or dq_m < 0):
            raise ValueError(f"--dq-m must be >= 0 (m per waypoint), got {args.dq_m}")
        if dk is not None and (math.isnan(dk) or dk < 0):
            raise ValueError(f"--dk must be >= 0 (Nm/rad per waypoint), got {args.dk}")

        if args.lock:  # ("--lock none": {}, which also drops the default lock below)
            locks: dict[str, float] = parse_locks(args.lock)
        else:  # the seed's lock for the shipped LWR, nothing for other robots
            locks = {}
            try:
                src = args.robot if os.path.isfile(args.robot) else robot_path(args.robot)
            except FileNotFoundError:  # neither a file nor a shipped name: Robot.from_urdf says which
                src = None
            for name, lock in _DEFAULT_LOCK.items():
                if src is not None and os.path.samefile(src, robot_path(name)):
                    locks = dict(lock)
        tcp = _nums(args.tcp, "--tcp")
        robot = Robot.from_urdf(args.robot, base_link=args.base_link, tip_link=args.tip_link, locked=locks or None, tcp=tcp)

        if args.path:
            paths = [Path.from_csv(f) for f in args.path]
            Ps = sorted({pp.P for pp in paths})
            if len(Ps) > 1:
                raise ValueError(
                    f"--path: all paths of one run need the same number of waypoints, got {Ps}; run them separately"
                )
            path = paths[0] if len(paths) == 1 else Path.stack(paths)
            path_files = [os.path.abspath(f) for f in args.path]
        else:
            path = default_path()
            path_files = ["(shipped default path)"]

        q0 = _nums(args.q0, "--q0")
        if q0 is not None and len(q0) != robot.n:
            raise ValueError(f"--q0 needs {robot.n} values (one per joint of {robot.name!r}: {', '.join(robot.joint_names)}), got {len(q0)}")
        kj0 = _nums(args.kj0, "--kj0")
        if kj0 is not None and len(kj0) not in (1, robot.n):
            raise ValueError(f"--kj0 needs 1 or {robot.n} values, got {len(kj0)}")
        if kj0 is not None and len(kj0) == 1:
            kj0 = kj0[0]

        enable_x64()
        prefer_sync_cpu_dispatch()  # per-waypoint SLSQP is latency-bound: see its docstring
        B = path.B
        progress = _Progress(B * path.P, enabled=not args.quiet)
        if args.solver in ("pgd", "trajectory", "hybrid") and not args.quiet:
            print(f"shape: solver {args.solver} solves all {B} path(s) x {path.P} waypoints as one batch (compiling, "
                  "then solving; no per-waypoint progress until then, and Ctrl-C takes effect when it ends) ...",
                  file=sys.stderr, flush=True)
        try:
            res = shape(
                robot, path, args.criterion, ratio, task=args.task, solver=args.solver, starts=starts,
                q0=None if q0 is None else np.asarray(q0), kj0=kj0,
                dq=_rate_limits(robot, dq_deg, dq_m), dk=dk, kmin=kmin, kmax=kmax, c=c,
                first_rate_limit=args.first_rate_limit, first_starts=first_starts,
                cms_volume=cms_volume, cms_major=cms_major, progress=progress,
                meta_extra={"path_files": path_files, "cli": {k: v for k, v in vars(args).items() if not k.startswith("_")}},
            )
        except ShapeInterrupted as e:  # keep what was finished, then stop as interrupted
            st = e.result.status
            if np.all(st == R.NOT_RUN):
                print("\njaxstiff: nothing was written (no waypoint was finished)", file=sys.stderr)
                raise
            with deferred_interrupts():
                written = e.result.save(out)
            print(f"\njaxstiff: interrupted: wrote {written} with the {int((st != R.NOT_RUN).sum())} of {st.size} "
                  f"waypoints finished before it; the others have status {R.NOT_RUN} (not run)", file=sys.stderr)
            raise
        except KeyboardInterrupt:
            why = ("it solves all paths together" if args.solver not in ("slsqp", "slsqp-fd")
                   else "the interrupt came before the first waypoint was finished, or after the last, while the "
                        "result was assembled")
            print(f"\njaxstiff: nothing was written (solver {args.solver!r}: {why})", file=sys.stderr)
            raise
        with deferred_interrupts():  # the work is done: an interrupt now still gets the file
            written = res.save(out)
        if interrupt_pending() is not None:
            print(f"\njaxstiff: interrupted after the last waypoint: wrote the complete result {written}", file=sys.stderr)
            raise KeyboardInterrupt
        if not args.quiet:
            print(summary_table(res))
            print(f"wrote {written}  ({B} path(s) x {res.P} waypoints; status codes: see jaxstiff.results)")
        usable = R.is_usable(res.status)
        if not usable.all():  # the file is still complete: every waypoint has its status
            worst = int(np.argmin(usable.sum(axis=1)))
            far = float(np.max(res.pos_error[~usable]))
            # the first waypoint has no rate limit (unless --first-rate-limit): if it was reached
            # and later ones were not, the limits per waypoint are the likelier cause
            after_first = bool(np.all(usable[:, 0])) and not args.first_rate_limit
            hint = ("the joint and stiffness rate limits (--dq-deg, --dk: change allowed per waypoint) may be too "
                    "tight for the waypoint spacing, or the path leaves the robot's reach" if after_first
                    else "check the path's units and the robot's reach")
            print(f"jaxstiff: warning: {int((~usable).sum())} of {usable.size} waypoints have no usable solution "
                  f"(path {worst}: {int((~usable[worst]).sum())} of {res.P}; largest position error {far:.3g} m); "
                  f"{hint} (status codes: see jaxstiff.results)", file=sys.stderr)
            if not usable.any():
                return 3  # the file is written, but holds no usable waypoint
        return 0

    return run
