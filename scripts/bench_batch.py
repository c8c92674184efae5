"""Benchmark of the batch engine (solver "pgd"): B trajectories x P waypoints, f2, against slsqp-fd.

Robot: KUKA LWR 4, 7th joint locked at 0 (6 free joints), task "full", r = 5, the shape()
defaults (dq = 2 deg, dk = 5 Nm/rad per waypoint, kj in [1, 100] Nm/rad, kj0 = 50.5).
Paths: :func:`random_reachable_paths` (fixed seed): the TCP path of a smooth joint-space motion
between two random postures inside the joint limits (reachable by construction; the start
posture is q0), directions = the path tangents.

Timed apart: compilation (first chunk) and the run after compilation (all chunks). Peak memory:
``resource.getrusage(RUSAGE_SELF).ru_maxrss`` of this process (whole process, JAX included).
The seed method (``slsqp-fd``: SLSQP + numpy finite differences) runs on the first
``--seed-paths`` of the same trajectories in the same run, which gives the per-waypoint speed
ratio; quality is compared on those paths (mean criterion, fraction of waypoints where pgd is
<= slsqp-fd + 1e-6).

Usage:
    python scripts/bench_batch.py                        # B = 1000, P = 100 (full size)
    python scripts/bench_batch.py --B 16 --P 20 --seed-paths 1
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import resource
import sys
import time

import numpy as np


def random_reachable_paths(robot, B: int, P: int, seed: int = 0, span: float = 0.35, margin: float = 0.3):
    """B reachable TCP paths of P waypoints (points (B,P,3) m, directions (B,P,3), q_start (B,n)).

    Each path is the TCP trace of a smooth (cosine-eased) joint-space motion from a random posture
    (uniform inside the limits shrunk by ``margin`` rad) by a random offset of up to ``span`` rad
    per free joint; locked joints stay at their values. Waypoints closer than 1 mm apart in
    average are not rejected (the rate limits then have little to do). A joint without limits
    (continuous) draws from [-pi, pi].
    """
    import jax

    from jaxstiff.model import fk

    rng = np.random.default_rng(seed)
    n = robot.n
    lo = np.where(np.isfinite(robot.lower), robot.lower, -np.pi) + margin
    hi = np.where(np.isfinite(robot.upper), robot.upper, np.pi) - margin
    lv = robot.locked_values
    q_a = rng.uniform(lo, hi, size=(B, n))
    q_b = np.clip(q_a + rng.uniform(-span, span, size=(B, n)), lo, hi)
    locked = ~np.isnan(lv)
    q_a[:, locked] = lv[locked]
    q_b[:, locked] = lv[locked]
    s = 0.5 - 0.5 * np.cos(np.linspace(0.0, np.pi, P))
    Q = q_a[:, None, :] + s[None, :, None] * (q_b - q_a)[:, None, :]
    with jax.enable_x64(True):
        T = np.asarray(jax.jit(jax.vmap(lambda q: fk(robot, q)))(Q.reshape(B * P, n)))
    pts = T[:, :3, 3].reshape(B, P, 3)
    tang = np.gradient(pts, axis=1)
    nrm = np.linalg.norm(tang, axis=-1, keepdims=True)
    dirs = tang / np.where(nrm > 0, nrm, 1.0)
    dirs[nrm[..., 0] == 0] = [1.0, 0.0, 0.0]
    return pts, dirs, q_a


def bench_problem(B: int, P: int, criterion: str = "f2", seed: int = 0, robot_name: str | None = None):
    """The benchmark's robot and :class:`~jaxstiff.solvers._problem.WaypointBatch`: the LWR with its
    7th joint locked (or ``robot_name``, a shipped robot or a URDF file, no joint locked), B x P
    :func:`random_reachable_paths`, kj0 50.5 Nm/rad, dq 2 deg, dk 5 Nm/rad, stiffness 1-100 Nm/rad,
    ratio 5, c 0.01 (also :mod:`profile_pgd`, :mod:`profile_compile`)."""
    import jaxstiff
    from jaxstiff.solvers._problem import Limits, WaypointBatch, WaypointProblem
    from jaxstiff.stiffness import get_criterion

    if robot_name is None:
        robot = jaxstiff.Robot.from_urdf("kuka_lwr4", locked={"lwr_a7": 0.0})
    else:
        robot = jaxstiff.Robot.from_urdf(robot_name)
    n = robot.n
    pts, dirs, q0 = random_reachable_paths(robot, B, P, seed=seed)
    limits = Limits(dq=np.full(n, np.radians(2.0)), dk=np.full(n, 5.0), kmin=1.0, kmax=100.0, first_rate_limit=False)
    prob = WaypointProblem(robot, "full", get_criterion(criterion))
    return robot, WaypointBatch(prob, pts, dirs, q0, np.full((B, n), 50.5), limits, 5.0, 0.01)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--B", type=int, default=1000, help="trajectories")
    ap.add_argument("--P", type=int, default=100, help="waypoints per trajectory")
    ap.add_argument("--starts", type=int, default=4, help="pgd starts per waypoint")
    ap.add_argument("--iters", type=int, default=None, help="pgd iterations per start and waypoint (default: pgd's)")
    ap.add_argument(
        "--chunk",
        type=int,
        default=100,
        help="trajectories per compiled call (100 was faster than 250 on a 2-core CPU: 353 vs 307 wp/s, one run each, before the LM speed-up)",
    )
    ap.add_argument(
        "--threads",
        type=int,
        default=0,
        help="compiled chunks at once on a CPU (0: one per usable core; pgd option threads)",
    )
    ap.add_argument("--seed-paths", type=int, default=3, help="trajectories also solved with slsqp-fd")
    ap.add_argument("--criterion", default="f2")
    ap.add_argument("--json", default=None, help="also write the numbers to this JSON file")
    args = ap.parse_args(argv)

    import jax

    import jaxstiff
    from jaxstiff.solvers import _pgd as pgd

    robot, batch = bench_problem(args.B, args.P, args.criterion)
    pts, dirs, q0, kj0 = batch.targets, batch.directions, batch.q0, batch.kj0
    load0 = os.getloadavg()
    opts = {"chunk": args.chunk, "threads": args.threads}
    if args.iters is not None:
        opts.update(iters=args.iters, iters_lm=args.iters, iters_first=5 * args.iters)
    # the first waypoint's extra IK start postures, as jaxstiff.shape() passes them (host side, timed apart)
    from jaxstiff.shaping import DEFAULTS, first_start_postures

    t_ik = time.perf_counter()
    fs = [
        first_start_postures(robot, pts[b], dirs[b], q0[b], kj0[b], DEFAULTS["first_starts"] - 1) for b in range(args.B)
    ]
    t_ik = time.perf_counter() - t_ik
    res = pgd.solve_batch(
        batch,
        starts=args.starts,
        options=opts,
        return_timing=True,
        first_starts=fs,
    )
    nwp = args.B * args.P
    usable = np.isin(res["status"], (0, 1, 2))
    peak_mib = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0

    print(
        f"pgd: B={args.B} P={args.P} compile {res['compile_s']:.1f} s, run {res['run_s']:.1f} s, "
        f"{nwp / res['run_s']:.0f} waypoints/s, peak RSS {peak_mib:.0f} MiB, usable {usable.mean():.4f}",
        flush=True,
    )
    # seed method on the first few of the same trajectories (--seed-paths 0: pgd alone, no ratio)
    k = min(args.seed_paths, args.B)
    pgd_wps = nwp / res["run_s"]
    if k > 0:
        t0 = time.perf_counter()
        ref = jaxstiff.shape(
            robot, jaxstiff.Path(pts[:k], dirs[:k]), args.criterion, 5.0, solver="slsqp-fd", q0=q0[:k], kj0=kj0[:k]
        )
        t_fd = time.perf_counter() - t0
        fd_wps = k * args.P / ref.meta["timing_s"]["solve"]
        f_pgd, f_fd, fd_status = res["criterion"][:k], ref.criterion, ref.status
        fd_solve = ref.meta["timing_s"]["solve"]
        ok = np.isin(ref.status, (0, 1, 2)) & usable[:k]
    else:
        t_fd = fd_wps = fd_solve = float("nan")
        f_pgd = f_fd = fd_status = np.zeros((0, args.P))
        ok = np.zeros((0, args.P), bool)
    out = {
        "B": args.B,
        "P": args.P,
        "waypoints": nwp,
        "criterion": args.criterion,
        "starts": args.starts,
        "iters": args.iters or "default",
        "chunk": args.chunk,
        "threads": args.threads,
        "devices": str(jax.devices()),
        "compile_s": round(res["compile_s"], 2),
        "run_s": round(res["run_s"], 2),
        "first_start_ik_s": round(t_ik, 2),
        "pgd_waypoints_per_s": round(pgd_wps, 1),
        "peak_rss_mib": round(peak_mib, 1),
        "pgd_usable_fraction": float(usable.mean()),
        "pgd_mean_criterion_all": float(res["criterion"][usable].mean()),
        "pgd_median_criterion_all": float(np.median(res["criterion"][usable])),
        "slsqp_fd_paths": k,
        "slsqp_fd_solve_s": round(fd_solve, 2),
        "slsqp_fd_total_s": round(t_fd, 2),
        "slsqp_fd_waypoints_per_s": round(fd_wps, 2),
        "speedup_per_waypoint": round(pgd_wps / fd_wps, 1) if k > 0 else None,
        "same_paths_mean_criterion_pgd": float(f_pgd[ok].mean()) if ok.any() else None,
        "same_paths_mean_criterion_slsqp_fd": float(f_fd[ok].mean()) if ok.any() else None,
        "same_paths_frac_pgd_le_fd": float(np.mean(f_pgd[ok] <= f_fd[ok] + 1e-6)) if ok.any() else None,
        "slsqp_fd_usable_fraction": float(np.isin(fd_status, (0, 1, 2)).mean()) if k > 0 else None,
        "loadavg_before": [round(x, 2) for x in load0],
        "loadavg_after": [round(x, 2) for x in os.getloadavg()],
        "cpu_count": os.cpu_count(),
        "platform": platform.platform(),
    }
    w = max(len(k_) for k_ in out)
    for k_, v in out.items():
        print(f"{k_:<{w}}  {v}")
    if args.json:
        tmp = args.json + ".tmp"
        with open(tmp, "w") as fh:
            json.dump(out, fh, indent=1)
        os.replace(tmp, args.json)
    return 0


if __name__ == "__main__":
    sys.exit(main())
