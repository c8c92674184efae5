"""How long a path out of reach takes to be refused (issue 37: a Panda path at x = 2 m once ran
397 s before exit 3): on the shipped LWR and every arm of tests/data/robots, a 20-waypoint line at
x = 2 m (and the same line written in millimetres) through ``jaxstiff.shape`` in this process and
through the ``jaxstiff shape`` command in a fresh one (Python start and JAX import included).
``--unattainable`` adds a waypoint inside the LWR's reach shell that no posture attains (status 3
after IK, without SLSQP runs) per solver, second call (compiled programs warm).

    python scripts/bench_reach.py [--unattainable] [--json OUT.json]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import tempfile
import time
import warnings

import numpy as np

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
ROBOTS = os.path.join(REPO, "tests", "data", "robots")
ARMS = [("kuka_lwr4", "kuka_lwr4")] + [
    (f[: -len(".urdf")], os.path.join(ROBOTS, f)) for f in sorted(os.listdir(ROBOTS)) if f.endswith(".urdf")
]


def line(x: float, P: int = 20) -> np.ndarray:
    """P waypoints at x (m), y from -0.1 to 0.1 m, z = 0.3 m."""
    return np.stack([np.full(P, x), np.linspace(-0.1, 0.1, P), np.full(P, 0.3)], axis=1)


def task_for(robot) -> str:
    """The default task "full" needs 6 free joints; a 5-joint arm (SO-101) shapes with "xyz"."""
    return "full" if robot.n_free >= 6 else "xyz"


def refuse_in_process(robot, pts: np.ndarray) -> tuple[float, str]:
    import jaxstiff
    from jaxstiff.model import UnreachableError

    t = time.perf_counter()
    try:
        jaxstiff.shape(robot, pts, task=task_for(robot))
    except UnreachableError as e:
        return time.perf_counter() - t, str(e)
    raise SystemExit(f"{robot.name}: the path was not refused")


def refuse_cli(urdf: str, task: str, pts: np.ndarray, folder: str) -> tuple[float, int]:
    import jaxstiff

    csv = os.path.join(folder, "path.csv")
    jaxstiff.Path(pts).to_csv(csv)
    out = os.path.join(folder, "o")
    cmd = [sys.executable, "-m", "jaxstiff", "shape", "--robot", urdf, "--task", task, "--path", csv, "--out", out]
    t = time.perf_counter()
    rc = subprocess.run(cmd, capture_output=True, text=True).returncode
    return time.perf_counter() - t, rc


def unattainable(solvers: list[str]) -> list[dict]:
    """The LWR 0.4 m below its base (inside the shell, no posture gets there): per solver, the
    second call's wall time per waypoint (P = 5)."""
    import jaxstiff

    robot = jaxstiff.Robot.from_urdf("kuka_lwr4", locked={"lwr_a7": 0.0})
    pts = np.stack([np.linspace(-0.02, 0.02, 5), np.zeros(5), np.full(5, -0.4)], axis=1)
    out = []
    for solver in solvers:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            jaxstiff.shape(robot, pts, solver=solver)  # compile
            t = time.perf_counter()
            res = jaxstiff.shape(robot, pts, solver=solver)
        dt = time.perf_counter() - t
        out.append({"solver": solver, "s_per_waypoint": dt / 5, "status": res.status[0].tolist()})
        print(f"unattainable LWR waypoint, {solver:>10}: {dt / 5:.3f} s per waypoint, status {res.status[0].tolist()}")
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--unattainable", action="store_true", help="also time status 3 inside the shell per solver")
    ap.add_argument("--json", default=None, help="write the numbers here")
    args = ap.parse_args()
    import jax

    jax.config.update("jax_enable_x64", True)
    import jaxstiff

    rows = []
    print(f"{'arm':<18} {'tip':<24} {'reach m':>14} {'shape 2 m':>10} {'2000 mm':>9} {'CLI 2 m':>9} {'CLI mm':>8}")
    with tempfile.TemporaryDirectory() as folder:
        for name, urdf in ARMS:
            kw = {"locked": {"lwr_a7": 0.0}} if name == "kuka_lwr4" else {}
            robot = jaxstiff.Robot.from_urdf(urdf, **kw)
            r = robot.reach()
            t_m, msg = refuse_in_process(robot, line(2.0))
            t_mm, msg_mm = refuse_in_process(robot, line(2.0) * 1000.0)
            c_m, rc_m = refuse_cli(urdf, task_for(robot), line(2.0), folder)
            c_mm, rc_mm = refuse_cli(urdf, task_for(robot), line(2.0) * 1000.0, folder)
            assert rc_m == rc_mm == 2 and "millimetres" in msg_mm and "millimetres" not in msg
            rows.append(
                {
                    "arm": name,
                    "tip": robot.tip_link,
                    "reach_inner_m": r.inner,
                    "reach_outer_m": r.outer,
                    "shape_refuse_s": t_m,
                    "shape_refuse_mm_s": t_mm,
                    "cli_refuse_s": c_m,
                    "cli_refuse_mm_s": c_mm,
                    "cli_rc": rc_m,
                }
            )
            print(
                f"{name:<18} {robot.tip_link:<24} {r.inner:>6.3f}-{r.outer:<6.3f} {t_m:>9.3f}s {t_mm:>8.3f}s "
                f"{c_m:>8.2f}s {c_mm:>7.2f}s"
            )
    extra = unattainable(["slsqp", "pgd", "hybrid"]) if args.unattainable else []
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(
                {
                    "refuse": rows,
                    "unattainable": extra,
                    "machine": {"cpu": platform.processor() or platform.machine(), "cores": os.cpu_count()},
                    "versions": {"jax": jax.__version__, "python": platform.python_version()},
                    "device": str(jax.devices()[0]),
                },
                fh,
                indent=1,
            )


if __name__ == "__main__":
    main()
