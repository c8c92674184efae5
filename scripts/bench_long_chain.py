"""Compile and run time of FK + Jacobian for long generated chains: the unrolled kernel against the
scan over joints (issue 24, finding 2), and the compile time of shaping and a CSC rollout.

Every case runs in a fresh Python process (no compilation cache, a hard timeout, its own peak
memory), repeated ``--repeat`` times; the table shows medians. Compile time is ``jit(...).lower(q)
.compile()``; run time is the median of ``--calls`` calls of the compiled function after one warm-up
call. Chains come from :func:`jaxstiff.model._generate.serial_chain` (``generic``: random axes and
rotated origins, nothing axis-aligned; ``aligned``: coordinate axes and right-angle origins, like
most real arms); a shipped robot's name as a kind measures that robot (``--kinds kuka_lwr4 --n 7``).

Usage:
    python scripts/bench_long_chain.py                      # the table (several minutes)
    python scripts/bench_long_chain.py --n 7 25 --batch 1   # a part of it
    python scripts/bench_long_chain.py --pipeline 100       # shape + csc_rollout compile, 100 joints
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))


def one_kernel(kind: str, n: int, kernel: str, batch: int, calls: int) -> dict:
    """Child process: compile and time one FK + Jacobian kernel."""
    import resource

    import jax

    jax.config.update("jax_enable_x64", True)
    import jax.numpy as jnp
    import numpy as np

    from jaxstiff.model._generate import serial_chain
    from jaxstiff.model._kinematics import fk_and_jacobian_raw
    from jaxstiff.runtime import kernel_compiler_options

    if kind == "generic" or kind == "aligned":
        robot = serial_chain(n, seed=0, aligned=kind == "aligned")
    else:  # a shipped robot by name (n is ignored)
        from jaxstiff.model import Robot

        robot = Robot.from_urdf(kind)
        n = robot.n
    shape = (n,) if batch == 1 else (batch, n)
    q = jnp.asarray(np.random.default_rng(1).uniform(-1.0, 1.0, shape))
    f = jax.jit(lambda x: fk_and_jacobian_raw(robot, x, kernel=kernel), compiler_options=kernel_compiler_options())
    t0 = time.perf_counter()
    compiled = f.lower(q).compile()
    compile_s = time.perf_counter() - t0
    jax.block_until_ready(compiled(q))
    runs = []
    for _ in range(calls):
        t0 = time.perf_counter()
        jax.block_until_ready(compiled(q))
        runs.append(time.perf_counter() - t0)
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1e6  # GB (Linux: KB)
    return {"compile_s": compile_s, "run_ms": 1e3 * statistics.median(runs), "peak_gb": rss}


def one_pipeline(n: int) -> dict:
    """Child process: compile + run time of ``jaxstiff.shape`` (task xyz, 3 waypoints) and of a
    10-step ``csc_rollout`` on an n-joint generic chain."""
    import jax

    jax.config.update("jax_enable_x64", True)
    import numpy as np

    import jaxstiff
    from jaxstiff.csc import csc_rollout
    from jaxstiff.model._generate import serial_chain

    robot = serial_chain(n, seed=0)
    q0 = np.zeros(n)
    p0 = np.asarray(robot.fk(q0))[:3, 3]
    path = p0 + np.array([[0.0, 0.0, 0.0], [0.002, 0.0, 0.0], [0.004, 0.001, 0.0]])
    out = {}
    t0 = time.perf_counter()
    res = jaxstiff.shape(robot, path, task="xyz", q0=q0)
    out["shape_total_s"] = time.perf_counter() - t0
    out["shape_timing_s"] = {k: v for k, v in dict(res.meta.get("timing_s", {})).items() if isinstance(v, float)}
    K_xd = np.diag([1000.0, 2000.0, 3000.0])
    steps = np.linspace(p0, p0 + np.array([0.005, 0.0, 0.0]), 10)
    t0 = time.perf_counter()
    csc_rollout(robot, steps, K_xd, q0, task="xyz")
    out["csc_first_s"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    csc_rollout(robot, steps, K_xd, q0, task="xyz")
    out["csc_second_s"] = time.perf_counter() - t0
    return out


def run_child(args: list[str], timeout: float) -> dict:
    cmd = [sys.executable, os.path.join(HERE, "bench_long_chain.py"), "--child", *args]
    t0 = time.perf_counter()
    try:
        done = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, check=False)
    except subprocess.TimeoutExpired:
        return {"timeout": timeout}
    if done.returncode != 0:
        return {"error": done.stderr.strip().splitlines()[-1] if done.stderr.strip() else f"rc {done.returncode}"}
    out = json.loads(done.stdout.strip().splitlines()[-1])
    out["wall_s"] = time.perf_counter() - t0
    return out


def median_of(results: list[dict], key: str) -> float | None:
    vals = [r[key] for r in results if key in r]
    return statistics.median(vals) if vals else None


def table(ns: list[int], kinds: list[str], batches: list[int], repeat: int, timeout: float, calls: int) -> None:
    print(f"| chain | n | batch | kernel | compile s (median of {repeat}) | run ms | peak GB |")
    print("|---|---:|---:|---|---:|---:|---:|")
    for kind in kinds:
        for batch in batches:
            gave_up: set[str] = set()  # a kernel that timed out is not tried on longer chains
            for n in ns:
                for kernel in ("unrolled", "scan"):
                    if kernel in gave_up:
                        print(
                            f"| {kind} | {n} | {batch} | {kernel} | (skipped: > {timeout:g} at a shorter chain) | | |"
                        )
                        continue
                    args = ["kernel", kind, str(n), kernel, str(batch), str(calls)]
                    res = [run_child(args, timeout)]
                    if "compile_s" in res[0]:  # a killed case is not repeated
                        res += [run_child(args, timeout) for _ in range(repeat - 1)]
                    c, r, m = (median_of(res, k) for k in ("compile_s", "run_ms", "peak_gb"))
                    if c is None:
                        gave_up.add(kernel)
                        why = f"> {timeout:g} s (killed)" if "timeout" in res[0] else res[0].get("error", "?")
                        print(f"| {kind} | {n} | {batch} | {kernel} | {why} | | |", flush=True)
                        continue
                    spread = (
                        f" ({min(x['compile_s'] for x in res):.2f}-{max(x['compile_s'] for x in res):.2f})"
                        if len(res) > 1
                        else ""
                    )
                    print(f"| {kind} | {n} | {batch} | {kernel} | {c:.2f}{spread} | {r:.3f} | {m:.2f} |", flush=True)


def main() -> None:
    if len(sys.argv) > 2 and sys.argv[1] == "--child":
        what, rest = sys.argv[2], sys.argv[3:]
        if what == "kernel":
            out = one_kernel(rest[0], int(rest[1]), rest[2], int(rest[3]), int(rest[4]))
        else:
            out = one_pipeline(int(rest[0]))
        print(json.dumps(out))
        return
    ap = argparse.ArgumentParser(description="FK + Jacobian compile/run time of long chains, unrolled vs scan")
    ap.add_argument("--n", type=int, nargs="+", default=[7, 25, 50, 100, 500], help="chain lengths")
    ap.add_argument("--kinds", nargs="+", default=["generic", "aligned"], help="generic, aligned or a shipped robot")
    ap.add_argument("--batch", type=int, nargs="+", default=[1, 256], help="configurations per call (1: shape (n,))")
    ap.add_argument("--repeat", type=int, default=3, help="processes per case (median reported)")
    ap.add_argument("--calls", type=int, default=20, help="timed calls per process")
    ap.add_argument("--timeout", type=float, default=90.0, help="seconds per process before it is killed")
    ap.add_argument("--pipeline", type=int, nargs="*", help="instead: shape + csc_rollout compile at these lengths")
    a = ap.parse_args()
    if a.pipeline:
        for n in a.pipeline:
            print(n, json.dumps(run_child(["pipeline", str(n)], max(a.timeout, 600.0))), flush=True)
        return
    table(a.n, a.kinds, a.batch, a.repeat, a.timeout, a.calls)


if __name__ == "__main__":
    main()
