"""Benchmark: a new arm's first batch call, as a user meets it (issue 37, item 7).

For each arm, in a fresh Python process with an empty compilation cache (``JAXSTIFF_CACHE_DIR`` a new
temporary folder): ``import jaxstiff`` (timed apart), B random reachable paths x P waypoints of the
arm (``bench_batch.random_reachable_paths``, seed 0), then ``jaxstiff.shape(robot, path, "f2", 5,
solver=...)`` twice: the first call (compilation included: nothing is cached) and a second, warm
one. Printed per arm: import, first call, the compilation inside it (``meta["timing_s"]["compile"]``),
the warm call and the in-target share.

The arms are ``scripts/quality_arms.py``'s: the shipped LWR and the third-party arms of
``tests/data/robots`` (copies of ``../shared/robots``). A first call on a CPU is mostly XLA
compiling the solver's programs; beyond that, a third-party arm's first call is its warm call, of
which pgd's first-waypoint retry is most (docs/notes/speed.md, twentieth session).

Usage:
    python scripts/bench_first_call.py                       # every arm, pgd, 64 x 50
    python scripts/bench_first_call.py --arms lwr ur10 --B 8 --P 10 --solver hybrid
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))

_CHILD = r"""
import json, sys, time, warnings
t0 = time.perf_counter()
import jaxstiff
from jaxstiff.shaping import prefer_sync_cpu_dispatch
t1 = time.perf_counter()
prefer_sync_cpu_dispatch()
sys.path.insert(0, HERE)
from bench_batch import random_reachable_paths
from quality_arms import ARMS
arm, solver, B, P = sys.argv[1], sys.argv[2], int(sys.argv[3]), int(sys.argv[4])
src, kw = ARMS[arm]
robot = jaxstiff.Robot.from_urdf(src, **kw)
pts, dirs, q0 = random_reachable_paths(robot, B, P, seed=0)
path = jaxstiff.Path(pts, dirs)
times, results = [], []
with warnings.catch_warnings():
    warnings.simplefilter("ignore")
    for _ in range(2):  # the first call, then a warm one
        t = time.perf_counter()
        results.append(jaxstiff.shape(robot, path, "f2", 5.0, solver=solver, q0=q0))
        times.append(time.perf_counter() - t)
first = results[0]
print(json.dumps({"arm": arm, "import_s": t1 - t0, "first_s": times[0],
                  "compile_s": float(first.meta["timing_s"].get("compile") or 0.0),
                  "warm_s": times[1], "in_target": float(first.in_target.mean())}))
""".replace("HERE", repr(HERE))


def run_arm(arm: str, solver: str, B: int, P: int) -> dict:
    """One arm in a fresh process with an empty cache folder: its measurements (or ``error``)."""
    with tempfile.TemporaryDirectory(prefix="jaxstiff-first-call-") as cache:
        env = dict(os.environ, JAXSTIFF_CACHE_DIR=cache)
        out = subprocess.run(
            [sys.executable, "-c", _CHILD, arm, solver, str(B), str(P)], env=env, capture_output=True, text=True
        )
    lines = [line for line in out.stdout.splitlines() if line.startswith("{")]
    if out.returncode != 0 or not lines:
        return {"arm": arm, "error": (out.stderr or out.stdout)[-2000:]}
    return json.loads(lines[-1])


def main(argv: list[str] | None = None) -> int:
    sys.path.insert(0, HERE)
    from quality_arms import ARMS

    ap = argparse.ArgumentParser(description=(__doc__ or "").split("\n\n")[0])
    ap.add_argument("--arms", nargs="+", default=list(ARMS), choices=list(ARMS))
    ap.add_argument("--solver", default="pgd", choices=["pgd", "hybrid", "slsqp", "trajectory"])
    ap.add_argument("--B", type=int, default=64, help="paths")
    ap.add_argument("--P", type=int, default=50, help="waypoints per path")
    ap.add_argument("--json", default=None, help="also write the rows to this file")
    args = ap.parse_args(argv)

    print(f"{args.solver}, {args.B} x {args.P} random reachable paths, a fresh process and an empty cache per arm")
    print("| arm | import | first call | of it compilation | warm call | in target |")
    print("| --- | --- | --- | --- | --- | --- |")
    rows = []
    for arm in args.arms:
        r = run_arm(arm, args.solver, args.B, args.P)
        rows.append(r)
        if "error" in r:
            print(f"| {arm} | failed: {r['error'].strip().splitlines()[-1] if r['error'].strip() else '?'} |")
            continue
        print(
            f"| {arm} | {r['import_s']:.1f} s | {r['first_s']:.1f} s | {r['compile_s']:.1f} s | "
            f"{r['warm_s']:.1f} s | {100 * r['in_target']:.1f} % |",
            flush=True,
        )
    if args.json:
        with open(args.json, "w") as f:
            json.dump(rows, f, indent=1)
    return 1 if any("error" in r for r in rows) else 0


if __name__ == "__main__":
    sys.exit(main())
