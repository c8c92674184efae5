"""Quality study of the batch engine (issue 5): pgd (1 and S starts, both modes), hybrid and the
trajectory-level mode against greedy SLSQP, f2 and f1 with r = 5, KUKA LWR 4 (7th joint locked).

Paths: the shipped default path (60 waypoints) plus ``--paths`` random reachable paths of 60
waypoints (:func:`scripts.bench_batch.random_reachable_paths`, seed 0), all in one batch (one
compilation per solver setting). Every result goes through :func:`jaxstiff.results.verify` (numpy
only: position, bounds, rates, reported values).

Numbers (per criterion, on the default path and on the random paths):
* total criterion per solver; usable fraction; f1: fraction with alpha < 1 deg and ratio >= 4.9;
* hybrid <= SLSQP + 1e-6 per waypoint (fraction of waypoints usable in both);
* multi-start (S) vs single start total; trajectory-level vs its greedy warm start (SLSQP and pgd).

Usage:
    python experiments/quality_study.py --quick          # default path + 2 random paths
    python experiments/quality_study.py --paths 100      # the issue's full study (slow: SLSQP)
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "scripts"))


def main(argv: list[str] | None = None) -> int:  # noqa: PLR0915 - the experiment's procedure, read top to bottom
    """Run the study and write its tables and figure. One function (~110 lines) on purpose: an
    experiment is a short script read top to bottom, parse -> paths -> solvers -> table."""
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true", help="2 random paths (unless --paths), fewer settings")
    ap.add_argument("--paths", type=int, default=None, help="random paths besides the default path")
    ap.add_argument("--criteria", default="f1,f2")
    ap.add_argument("--starts", type=int, default=8)
    ap.add_argument("--only", default=None, help="comma list of setting names to run (e.g. slsqp,hybrid)")
    ap.add_argument("--out", default=os.path.join(HERE, "out", "quality_study.json"))
    args = ap.parse_args(argv)
    N = args.paths if args.paths is not None else (2 if args.quick else 100)

    from bench_batch import random_reachable_paths

    import jaxstiff
    from jaxstiff.ik import ik_position
    from jaxstiff.results import _files as R
    from jaxstiff.shaping import SOLVERS, register_solver
    from jaxstiff.solvers import _trajectory as trajectory
    from jaxstiff.solvers._configs import solver_from_name

    robot = jaxstiff.Robot.from_urdf("kuka_lwr4", locked={"lwr_a7": 0.0})
    dp = jaxstiff.default_path()
    P = dp.P
    q_dp, _ = ik_position(robot, dp.points[0])
    q_dp = np.clip(q_dp, robot.lower, robot.upper)  # IK may land a rounding step outside a limit
    pts, dirs, q_r = (
        random_reachable_paths(robot, N, P, seed=0) if N else (np.zeros((0, P, 3)),) * 2 + (np.zeros((0, robot.n)),)
    )
    path = jaxstiff.Path(np.concatenate([dp.points[None], pts]), np.concatenate([dp.directions[None], dirs]))
    q0 = np.concatenate([q_dp[None], q_r])
    B = 1 + N
    cached: dict[str, dict] = {}

    def to_arrays(res):
        return {
            k: np.array(getattr(res, k))
            for k in ("q", "kj", "status", "pos_error", "solver_code", "nit", "nfev", "time_s")
        }

    def traj_from(name):
        def run(req):
            return trajectory.refine_batch(
                req,
                cached[name],
                options=req.options,
                pos_tol=req.pos_tol,
            )

        return run

    out: dict = {"B": B, "P": P, "random_paths": N, "starts": args.starts, "results": {}}
    S = args.starts
    settings = [
        ("slsqp", "slsqp", None, {}),
        ("pgd_S1", "pgd", 1, {"starts_first": 1}),
        (f"pgd_S{S}", "pgd", S, {}),
        (f"pgd_S{S}_best", "pgd", S, {"mode": "best"}),
        ("hybrid", "hybrid", S, {}),
        ("traj_from_slsqp", "_traj_slsqp", None, {}),
        ("traj_from_pgd", "_traj_pgd", None, {}),
    ]
    if args.quick:  # the "best" mode and the pgd-warm trajectory only in the full study
        settings = [s_ for s_ in settings if s_[0] not in (f"pgd_S{S}_best", "traj_from_pgd")]
    if args.only:
        settings = [s_ for s_ in settings if s_[0] in args.only.split(",")]
    register_solver("_traj_slsqp", traj_from("slsqp"))
    register_solver("_traj_pgd", traj_from(f"pgd_S{S}"))
    for crit in args.criteria.split(","):
        rows = {}
        for name, solver, starts, opts in settings:
            t0 = time.perf_counter()
            res = jaxstiff.shape(
                robot,
                path,
                crit,
                5.0,
                solver=solver_from_name(solver, {**opts, "chunk": B} if solver != "slsqp" else opts),
                starts=starts,
                q0=q0,
            )
            dt = time.perf_counter() - t0
            cached[name] = to_arrays(res)
            v = R.verify(res, robot=robot)
            u = R.is_usable(res.status)
            good = (res.alpha_deg < 1.0) & (res.ratio >= 4.9) & u
            rows[name] = {
                "time_s": round(dt, 1),
                "total_default": float(res.criterion[0][u[0]].sum()),
                "usable_default": float(u[0].mean()),
                "total_random": float(res.criterion[1:][u[1:]].sum()) if N else None,
                "usable_random": float(u[1:].mean()) if N else None,
                "alpha<1&ratio>=4.9_default": float(good[0].mean()),
                "alpha<1&ratio>=4.9_random": float(good[1:].mean()) if N else None,
                "verify": {k: float(f"{x:.3g}") for k, x in v.items()},
                "criterion": res.criterion,
                "usable": u,
            }
            print(
                f"{crit} {name:<18} {dt:7.1f} s  total default {rows[name]['total_default']:.4f}  "
                f"random {rows[name]['total_random']}  usable {u.mean():.3f}  "
                f"a<1&r>=4.9 default {good[0].mean():.3f}  max pos err {v['max_pos_error']:.1e} "
                f"rate viol {v['max_rate_violation']:.1e}",
                flush=True,
            )
        summ = {}
        if "slsqp" in rows and "hybrid" in rows:
            ref, hyb = rows["slsqp"], rows["hybrid"]
            both = ref["usable"] & hyb["usable"]
            le = hyb["criterion"] <= ref["criterion"] + 1e-6
            summ["hybrid_le_slsqp_default"] = float(le[0][both[0]].mean())
            summ["hybrid_le_slsqp_random"] = float(le[1:][both[1:]].mean()) if N else None
        if f"pgd_S{S}" in rows and "pgd_S1" in rows:
            summ["multi_vs_single_total_all"] = [
                float(rows[f"pgd_S{S}"]["criterion"][rows[f"pgd_S{S}"]["usable"]].sum()),
                float(rows["pgd_S1"]["criterion"][rows["pgd_S1"]["usable"]].sum()),
            ]
        print(crit, json.dumps(summ), flush=True)
        for r in rows.values():
            r.pop("criterion")
            r.pop("usable")
        out["results"][crit] = {"solvers": rows, "summary": summ}
    SOLVERS.pop("_traj_slsqp", None)
    SOLVERS.pop("_traj_pgd", None)
    os.makedirs(os.path.dirname(args.out), exist_ok=True)
    tmp = args.out + ".tmp"
    with open(tmp, "w") as fh:
        json.dump(out, fh, indent=1)
    os.replace(tmp, args.out)
    print("wrote", args.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
