"""Benchmark: shaping per waypoint with SLSQP + JAX derivatives ("slsqp") vs the seed's own method,
SLSQP with finite differences in plain numpy ("slsqp-fd"), on the shipped default path, one process.

Two measurements:

1. **Same waypoint problems** (the speed-up): the greedy "slsqp" run defines, for every waypoint, its
   problem (target, direction, rate-limited box around the previous state, start point). Each
   problem is then solved again by both solvers, interleaved (slsqp, fd, slsqp, fd, ...) so that
   machine load hits both alike (plus "slsqp" through ``scipy.optimize.minimize`` instead of the
   lean driver: the same iterates, to show what the driver contributes); time per waypoint, objective evaluations per waypoint (the FD
   solver's count includes its difference quotients), and the criterion reached on the identical
   problem (quality: FD's criterion minus slsqp's).
2. **Whole runs**: ``jaxstiff.shape`` along the path with each solver (each follows its own
   trajectory; run one after the other, so load changes between them show up here and not in 1):
   median time per waypoint, and the quality summary (share of waypoints with
   alpha < 1 deg and |rho - 5|/5 < 2%, max position error).

Compilation is timed apart (the JAX kernels are compiled before any waypoint is timed). Times are
wall-clock, ``time.perf_counter``; the first (multi-start, not rate-limited) waypoint is excluded
from per-waypoint medians. Options are the library defaults for both solvers (same scaling,
``ftol``, ``maxiter``), so they differ only in where derivatives come from.

Usage:
    python scripts/bench_shape.py [--waypoints 60] [--criterion f2] [--skip-runs] [--json FILE]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import time


def main(argv=None) -> int:  # noqa: PLR0915 - the benchmark's procedure, read top to bottom
    argv = sys.argv[1:] if argv is None else list(argv)
    if "--batch" in argv:  # batch engine benchmark (issue 5): delegate to scripts/bench_batch.py
        sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
        import bench_batch

        return bench_batch.main([a for a in argv if a != "--batch"])
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--waypoints", type=int, default=60, help="first N waypoints of the default path (max 60)")
    ap.add_argument("--criterion", default="f2", choices=["f1", "f2"])
    ap.add_argument("--ratio", type=float, default=5.0)
    ap.add_argument("--skip-runs", action="store_true", help="only measurement 1 (same waypoint problems)")
    ap.add_argument("--json", default=None, help="also write the numbers to this JSON file")
    ap.add_argument(
        "--async-dispatch",
        action="store_true",
        help="keep JAX's asynchronous CPU dispatch (default: inline, see prefer_sync_cpu_dispatch)",
    )
    args = ap.parse_args(argv)

    if args.async_dispatch:  # shape() would otherwise switch to inline dispatch at its first call
        os.environ["JAXSTIFF_CPU_ASYNC_DISPATCH"] = "1"
    from jaxstiff.runtime._x64 import enable_x64
    from jaxstiff.shaping import prefer_sync_cpu_dispatch

    enable_x64()
    sync = prefer_sync_cpu_dispatch()
    import jax
    import numpy as np
    import scipy

    import jaxstiff
    from jaxstiff.results import _files as R
    from jaxstiff.shaping import DEFAULTS
    from jaxstiff.solvers._problem import Limits, WaypointProblem, clip_to_box, compiled
    from jaxstiff.solvers._slsqp import make_slsqp_solver
    from jaxstiff.solvers._slsqp_fd import make_fd_solver, numpy_objective

    robot = jaxstiff.Robot.from_urdf("kuka_lwr4", locked={"lwr_a7": 0.0})
    full = jaxstiff.default_path()
    P = min(args.waypoints, full.P)
    path = jaxstiff.Path(full.points[:P], full.directions[:P], name="default")
    crit = {"f1": jaxstiff.f1, "f2": jaxstiff.f2}[args.criterion]
    r, c = args.ratio, DEFAULTS["c"]
    load0 = os.getloadavg()

    # ---- reference greedy run with slsqp: defines the waypoint problems
    ref = jaxstiff.shape(robot, path, args.criterion, r)
    compile_s = ref.meta["timing_s"]["compile"]
    prob = WaypointProblem(robot, "full", crit)
    limits = Limits(np.asarray(ref.meta["limits"]["dq"]), np.asarray(ref.meta["limits"]["dk"]), 1.0, 100.0, True)
    t0 = time.perf_counter()
    jx = make_slsqp_solver(prob)
    jxm = make_slsqp_solver(prob, {"driver": "scipy"})  # same SLSQP through scipy.optimize.minimize
    fd = make_fd_solver(prob)
    fused = compiled(prob)
    obj_np = numpy_objective(prob)

    # ---- 1. the same waypoint problems, interleaved
    rows = []
    for p in range(1, P):
        q_prev, k_prev = ref.q[0, p - 1], ref.kj[0, p - 1]
        lb, ub = limits.box(prob, q_prev, k_prev, True)
        x0 = clip_to_box(prob.x_of(q_prev, k_prev), lb, ub)
        prm = WaypointProblem.params(path.points[p], path.directions[p], r, c)
        t = time.perf_counter()
        sj = jx(x0.copy(), lb, ub, prm)
        tj = time.perf_counter() - t
        t = time.perf_counter()
        sf = fd(x0.copy(), lb, ub, prm)
        tf = time.perf_counter() - t
        t = time.perf_counter()
        jxm(x0.copy(), lb, ub, prm)
        tm = time.perf_counter() - t
        fj = float(np.asarray(fused(clip_to_box(sj.x, lb, ub), prm))[0])
        ff = obj_np(clip_to_box(sf.x, lb, ub), prm)
        rows.append((tj, tf, sj.nfev, sf.nfev, sj.nit, sf.nit, fj, ff, sj.code, sf.code, tm))
    a = np.asarray(rows, dtype=float)
    med = lambda k: float(np.median(a[:, k]))  # noqa: E731
    speedup_each = a[:, 1] / a[:, 0]
    same = {
        "waypoints": int(len(rows)),
        "slsqp_ms_per_waypoint": 1e3 * med(0),
        "slsqp_via_minimize_ms_per_waypoint": 1e3 * med(10),
        "speedup_via_minimize": med(1) / med(10),
        "fd_ms_per_waypoint": 1e3 * med(1),
        "speedup_of_medians": med(1) / med(0),
        "speedup_median_per_waypoint": float(np.median(speedup_each)),
        "speedup_total_time": float(a[:, 1].sum() / a[:, 0].sum()),
        "slsqp_evals_per_waypoint": med(2),
        "fd_evals_per_waypoint": med(3),
        "slsqp_iterations": med(4),
        "fd_iterations": med(5),
        "slsqp_median_criterion": med(6),
        "fd_median_criterion": med(7),
        "share_fd_criterion_not_better": float(np.mean(a[:, 7] >= a[:, 6] - 1e-9)),
        "max_criterion_gap_slsqp_minus_fd": float(np.max(a[:, 6] - a[:, 7])),
        "slsqp_converged": float(np.mean(a[:, 8] == 0)),
        "fd_converged": float(np.mean(a[:, 9] == 0)),
    }

    # ---- 2. whole runs
    runs = {}
    if not args.skip_runs:
        # order: fd, then slsqp again (warm; the first slsqp run above also served as warm-up)
        for solver in ("slsqp-fd", "slsqp"):
            t0 = time.perf_counter()
            res = jaxstiff.shape(robot, path, args.criterion, r, solver=solver)
            wall = time.perf_counter() - t0
            s = R.summary(res)
            v = R.verify(res)
            runs[solver] = {
                "median_ms_per_waypoint": 1e3 * float(np.median(res.time_s[0, 1:])),
                "first_waypoint_s": float(res.time_s[0, 0]),
                "median_evals_per_waypoint": float(np.median(res.nfev[0, 1:])),
                "share_alpha_lt_1deg": s["share_alpha"],
                "share_ratio_within_2pct": s["share_ratio"],
                "share_both": s["share_both"],
                "median_criterion": float(np.median(res.criterion)),
                "max_pos_error_m": v["max_pos_error"],
                "max_rate_violation": v["max_rate_violation"],
                "status_counts": np.bincount(res.status.ravel(), minlength=5).tolist(),
                "wall_s": wall,
            }

    env = {
        "cpu": platform.processor() or platform.machine(),
        "cores": os.cpu_count(),
        "loadavg_start": load0,
        "loadavg_end": os.getloadavg(),
        "python": sys.version.split()[0],
        "jax": jax.__version__,
        "numpy": np.__version__,
        "scipy": scipy.__version__,
        "device": str(jax.devices()[0]),
        "compile_s": compile_s,
        "jax_cpu_sync_dispatch": sync,
        "criterion": args.criterion,
        "ratio": r,
        "P": P,
    }
    print(
        f"bench_shape: default path, {P} waypoints, {args.criterion}, r = {r:g}; {env['device']}, "
        f"{env['cores']} cores, load {load0[0]:.1f} -> {env['loadavg_end'][0]:.1f}; compile {compile_s:.1f} s (apart); "
        f"JAX CPU dispatch {'inline' if sync else 'async'}"
    )
    print("\n1. same waypoint problems (waypoints 2..P, interleaved)")
    print(f"{'':34}{'slsqp (JAX)':>14}{'slsqp-fd (seed)':>18}")
    print(
        f"{'median time per waypoint (ms)':34}{same['slsqp_ms_per_waypoint']:>14.2f}{same['fd_ms_per_waypoint']:>18.1f}"
    )
    print(
        f"{'  slsqp via scipy minimize (ms)':34}{same['slsqp_via_minimize_ms_per_waypoint']:>14.2f}"
        f"{'':>18}  ({same['speedup_via_minimize']:.1f}x; same iterates, scipy's wrappers)"
    )
    print(
        f"{'median objective evals/waypoint':34}{same['slsqp_evals_per_waypoint']:>14.0f}{same['fd_evals_per_waypoint']:>18.0f}"
    )
    print(f"{'median SLSQP iterations':34}{same['slsqp_iterations']:>14.0f}{same['fd_iterations']:>18.0f}")
    print(f"{'median criterion reached':34}{same['slsqp_median_criterion']:>14.8f}{same['fd_median_criterion']:>18.8f}")
    print(f"{'share converged (SLSQP mode 0)':34}{same['slsqp_converged']:>14.0%}{same['fd_converged']:>18.0%}")
    print(
        f"speed-up: {same['speedup_of_medians']:.1f}x (ratio of medians), {same['speedup_median_per_waypoint']:.1f}x "
        f"(median of per-waypoint ratios), {same['speedup_total_time']:.1f}x (total time)"
    )
    print(
        f"quality: FD's criterion >= slsqp's (-1e-9) on {same['share_fd_criterion_not_better']:.0%} of the problems; "
        f"largest slsqp - FD gap {same['max_criterion_gap_slsqp_minus_fd']:.2e}"
    )
    if runs:
        print("\n2. whole runs along the path (each solver its own trajectory; sequential, not interleaved)")
        print(f"{'':34}{'slsqp (JAX)':>14}{'slsqp-fd (seed)':>18}")
        for key, fmt, label in [
            ("median_ms_per_waypoint", "{:.1f}", "median time per waypoint (ms)"),
            ("first_waypoint_s", "{:.2f}", "first waypoint, 8 starts (s)"),
            ("median_evals_per_waypoint", "{:.0f}", "median objective evals/waypoint"),
            ("share_alpha_lt_1deg", "{:.0%}", "share alpha < 1 deg"),
            ("share_ratio_within_2pct", "{:.0%}", "share |rho - r|/r < 2% (f1: >=)"),
            ("median_criterion", "{:.6f}", "median criterion"),
            ("max_pos_error_m", "{:.1e}", "max position error (m)"),
            ("max_rate_violation", "{:.1e}", "max rate violation"),
            ("wall_s", "{:.1f}", "wall time incl. setup (s)"),
        ]:
            print(f"{label:34}{fmt.format(runs['slsqp'][key]):>14}{fmt.format(runs['slsqp-fd'][key]):>18}")
        print(
            f"whole-run speed-up (medians): {runs['slsqp-fd']['median_ms_per_waypoint'] / runs['slsqp']['median_ms_per_waypoint']:.1f}x"
        )
    if args.json:
        with open(args.json, "w") as fh:
            json.dump({"env": env, "same_problems": same, "runs": runs}, fh, indent=2)
    return 0


if __name__ == "__main__":
    sys.exit(main())
