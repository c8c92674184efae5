"""Shaping quality on the shipped LWR and the third-party arms: slsqp, pgd and hybrid on the same
random reachable paths (issue 37, item 2).

Arms (``tests/data/robots``; how each is configured):

* ``lwr``: the shipped KUKA LWR 4, joint lwr_a7 locked at 0 (6 free joints);
* ``ur10``: tip link tool0 (6 joints);
* ``kinova``: j2s6s200, tip link j2s6s200_end_effector (6 joints, three of them continuous);
* ``z1``: Unitree Z1, tip link gripperStator (the link before the gripper joint: 6 joints);
* ``talos``: TALOS left arm, tip link gripper_left_base_link (the link before the gripper joint:
  arm_left_2 ... arm_left_7, 6 joints).

Paths: ``scripts/bench_batch.py``'s :func:`random_reachable_paths` (fixed seed, B paths x P
waypoints, the TCP trace of a smooth joint-space motion; its start posture is q0), directions the
tangents. Settings: the ``shape()`` defaults (f2, r = 5, task full, dq 2 deg, dk 5 Nm/rad per
waypoint, kj in [1, 100] Nm/rad, first waypoint without rate limit, 8 first-waypoint starts) and
each solver's default options (``--pgd-options`` JSON adds pgd/hybrid options, e.g.
``'{"first_exact": "none"}'`` for pgd before issue 37).

Printed per arm and solver: the in-target share of the usable waypoints and of all waypoints
(:mod:`jaxstiff.results._target`: alpha < 1 deg and |rho - r| / r < 2 %), the in-target share of
waypoint 0, mean and minimum rho at waypoint 0, and, at the waypoints 0 where slsqp is in target,
how many of pgd's/hybrid's rho lie within 2 % of slsqp's; and the wall time of each solve.

With ``--attainable``, every waypoint is also solved alone (a one-waypoint path: no rate limit;
pgd's first-waypoint starts, and, where those end off target, greedy SLSQP's first-waypoint search
from q0 and 7 IK postures with as many rescue starts over the whole ranges: pgd's retry). A waypoint
is counted attainable when that search, or any of the solvers on the whole path, puts it in target;
the others are taken as targets out of the arm's reach with this spring model and task (a lower
bound on the attainable set, not a proof), and each solver's in-target share is printed again over
the attainable waypoints only. On a random path of a third-party arm many
targets are not attainable at all (the share of all waypoints is then bounded by that, whatever the
solver); the share over attainable waypoints is the one to compare between arms.

Usage:
    python scripts/quality_arms.py                      # 16 paths x 30 waypoints, every arm
    python scripts/quality_arms.py --B 4 --P 10 --arms lwr ur10
    python scripts/quality_arms.py --B 8 --P 30 --attainable
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
import warnings

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROBOTS = os.path.join(HERE, "..", "tests", "data", "robots")

#: name -> (URDF or shipped name, Robot.from_urdf keyword arguments)
ARMS = {
    "lwr": ("kuka_lwr4", {"locked": {"lwr_a7": 0.0}}),
    "ur10": (os.path.join(ROBOTS, "ur10.urdf"), {"tip_link": "tool0"}),
    "kinova": (os.path.join(ROBOTS, "kinova_j2s6s200.urdf"), {"tip_link": "j2s6s200_end_effector"}),
    "z1": (os.path.join(ROBOTS, "z1.urdf"), {"tip_link": "gripperStator"}),
    "talos": (os.path.join(ROBOTS, "talos_left_arm.urdf"), {"tip_link": "gripper_left_base_link"}),
}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--B", type=int, default=16, help="paths per arm")
    ap.add_argument("--P", type=int, default=30, help="waypoints per path")
    ap.add_argument("--seed", type=int, default=0, help="seed of the random paths")
    ap.add_argument("--arms", nargs="+", default=list(ARMS), choices=list(ARMS))
    ap.add_argument("--solvers", nargs="+", default=["slsqp", "pgd", "hybrid"])
    ap.add_argument("--pgd-options", default="{}", help="JSON options for pgd and hybrid")
    ap.add_argument("--attainable", action="store_true", help="also solve every waypoint alone (module docstring)")
    args = ap.parse_args(argv)

    import jax

    jax.config.update("jax_enable_x64", True)
    import jaxstiff
    from jaxstiff.shaping import prefer_sync_cpu_dispatch
    from jaxstiff.solvers._configs import solver_from_name

    prefer_sync_cpu_dispatch()
    sys.path.insert(0, HERE)
    from bench_batch import random_reachable_paths

    extra = json.loads(args.pgd_options)
    print(f"B = {args.B} paths x P = {args.P} waypoints per arm, seed {args.seed}, f2, r = 5; options {extra}")
    for arm in args.arms:
        src, kw = ARMS[arm]
        robot = jaxstiff.Robot.from_urdf(src, **kw)
        pts, dirs, q0 = random_reachable_paths(robot, args.B, args.P, seed=args.seed)
        path = jaxstiff.Path(pts, dirs)
        res = {}
        for solver in args.solvers:
            t0 = time.perf_counter()
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                res[solver] = jaxstiff.shape(
                    robot, path, "f2", 5.0, solver=solver_from_name(solver, extra if solver != "slsqp" else None), q0=q0
                )
            res[solver].meta["_wall_s"] = time.perf_counter() - t0
        print(f"\n{arm}: {robot.n} joints {list(robot.joint_names)}, tip {kw.get('tip_link', 'default')}")
        attainable = None
        if args.attainable:
            t0 = time.perf_counter()
            alone = jaxstiff.Path(pts.reshape(-1, 1, 3), dirs.reshape(-1, 1, 3))
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                one = jaxstiff.shape(robot, alone, "f2", 5.0, solver="pgd", q0=np.repeat(q0, args.P, axis=0))
            attainable = one.in_target.reshape(args.B, args.P).copy()
            for r in res.values():
                attainable |= r.in_target
            print(
                f"  attainable (in target alone, or on the path by any solver): {attainable.mean():6.1%} of all "
                f"waypoints (alone: {one.in_target.mean():6.1%}; {time.perf_counter() - t0:.1f} s)",
                flush=True,
            )
        ref = res.get("slsqp")
        ref_ok = None if ref is None else ref.in_target[:, 0]
        for solver, r in res.items():
            usable = np.isin(r.status, (0, 1, 2))
            it = r.in_target
            rho0 = r.ratio[:, 0]
            line = (
                f"  {solver:7s} in target {it[usable].mean():6.1%} of usable, {it.mean():6.1%} of all "
                f"({int(usable.sum())}/{usable.size} usable); wp0 in target {it[:, 0].mean():6.1%}, "
                f"rho0 mean {np.nanmean(rho0):.3f} min {np.nanmin(rho0):.3f}"
            )
            if ref_ok is not None and solver != "slsqp" and ref_ok.any():
                close = np.abs(rho0[ref_ok] - ref.ratio[ref_ok, 0]) <= 0.02 * ref.ratio[ref_ok, 0]
                line += f"; rho0 within 2 % of slsqp's where slsqp is in target: {int(close.sum())}/{int(ref_ok.sum())}"
            if attainable is not None and attainable.any():
                line += f"; in target {it[attainable].mean():6.1%} of the attainable"
            print(line + f"; {r.meta['_wall_s']:.1f} s", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
