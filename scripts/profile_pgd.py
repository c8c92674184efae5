"""Where pgd's run time goes: one execution of pgd's compiled chunk program under the JAX profiler,
every kernel launch attributed to the HLO loop body that holds it (the LM stage, the Adam loops,
the Newton corrections, the Jacobi sweeps, the per-waypoint scan body).

    python scripts/profile_pgd.py [--B 32] [--P 50] [--starts 8] [--json FILE]

Prints, per loop body (largest share of kernel time first): its trip count where XLA knows it, its
fusions, the kernel launches in the profiled execution, their summed time and share, and the op
name of the loop in the traced program. On a CPU the launch count matters as much as the
arithmetic: at small batches a kernel runs for about a microsecond (docs/notes/speed.md,
2026-12-03 fourth session).

The problem is ``scripts/bench_batch.py``'s (``bench_problem``: random reachable paths on the LWR
with its 7th joint locked, f2, ratio 5, dq 2 deg, dk 5 Nm/rad). The program is pgd's
own (captured where pgd compiles it), compiled once more with XLA's per-kernel trace events on;
one warm-up execution, then one profiled. Needs the CPU backend's profiler (jaxlib's, no extra
package).
"""

from __future__ import annotations

import argparse
import collections
import glob
import gzip
import json
import os
import re
import sys
import tempfile
import time

import jax

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from bench_batch import bench_problem  # noqa: E402

from jaxstiff.runtime import kernel_compiler_options  # noqa: E402
from jaxstiff.solvers._pgd import batch as pgd_batch  # noqa: E402


class _Captured(Exception):
    """Raised by the capture hook once pgd hands over its program and first chunk."""


def capture_program(B: int, P: int, starts: int, seed: int = 0, robot: str | None = None):
    """pgd's jitted chunk function and its first chunk's arguments for B x P random paths of the
    LWR (or ``robot``: :func:`bench_batch.bench_problem`)."""
    _, batch = bench_problem(B, P, seed=seed, robot_name=robot)
    got: dict = {}

    def hook(fn, args, key, options):
        got["fn"], got["args"] = fn, args
        raise _Captured

    real = pgd_batch.compile_with_export_cache
    pgd_batch.compile_with_export_cache = hook  # pgd's single compile point (solvers/_pgd/batch.py)
    try:
        pgd_batch.solve_batch(batch, starts=starts, options={"threads": 1, "chunk": B})
    except _Captured:
        pass
    finally:
        pgd_batch.compile_with_export_cache = real
    if "fn" not in got:
        raise RuntimeError("pgd did not reach its compile step (jaxstiff.solvers._pgd.batch changed?)")
    return got["fn"], got["args"]


def hlo_computations(hlo: str) -> dict[str, list[str]]:
    """The computations of a compiled program's HLO text, by name: their instruction lines."""
    comps: dict[str, list[str]] = {}
    cur = None
    for line in hlo.split("\n"):
        m = re.match(r"^(ENTRY )?%?([\w.\-]+) .*\{$", line)
        if m and not line.startswith(" "):
            cur = m.group(2)
            comps[cur] = []
        elif cur is not None and " = " in line:
            comps[cur].append(line)
    return comps


def profile(B: int, P: int, starts: int) -> dict:
    with jax.enable_x64(True):
        fn, args = capture_program(B, P, starts)
        t0 = time.perf_counter()
        comp = fn.lower(*args).compile({**kernel_compiler_options(), "xla_cpu_enable_xprof_traceme": True})
        compile_s = time.perf_counter() - t0
        jax.block_until_ready(comp(*args))
        with tempfile.TemporaryDirectory() as tmp:
            t0 = time.perf_counter()
            with jax.profiler.trace(tmp, create_perfetto_trace=True):
                jax.block_until_ready(comp(*args))
            run_s = time.perf_counter() - t0
            files = glob.glob(os.path.join(tmp, "**", "perfetto_trace.json.gz"), recursive=True)
            if not files:
                raise RuntimeError("the profiler wrote no perfetto trace")
            with gzip.open(files[0]) as fh:
                trace = json.load(fh)
    events = trace["traceEvents"] if isinstance(trace, dict) else trace
    comps = hlo_computations(comp.as_text())
    owner = {}
    loops = {}
    for name, lines in comps.items():
        for line in lines:
            m = re.search(r"%([\w.\-]+) = ", line)
            if m and not name.startswith("fused"):
                owner[m.group(1)] = name
            if " while(" in line:
                body = re.search(r"body=%?([\w.\-]+)", line)
                op = re.search(r'op_name="([^"]+)"', line)
                trip = re.search(r'known_trip_count":\{"n":"(\d+)"', line)
                if body:
                    loops[body.group(1)] = (int(trip.group(1)) if trip else None, op.group(1) if op else "")
    launches: collections.Counter = collections.Counter()
    micros: collections.Counter = collections.Counter()
    for e in events:
        if e.get("ph") == "X" and e.get("name") in owner:
            launches[owner[e["name"]]] += 1
            micros[owner[e["name"]]] += e.get("dur", 0)
    total = sum(micros.values()) or 1
    rows = [
        {
            "body": body,
            "trip_count": loops.get(body, (None, ""))[0],
            "op_name": loops.get(body, (None, "(entry or a fused region)"))[1],
            "fusions": sum(" fusion(" in line for line in comps.get(body, [])),
            "launches": launches[body],
            "kernel_ms": micros[body] / 1e3,
            "share": micros[body] / total,
        }
        for body in sorted(micros, key=lambda b: -micros[b])
    ]
    return {
        "B": B,
        "P": P,
        "starts": starts,
        "compile_s": compile_s,
        "profiled_run_s": run_s,
        "launches": sum(launches.values()),
        "kernel_ms": total / 1e3,
        "bodies": rows,
    }


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--B", type=int, default=32, help="paths (one chunk)")
    ap.add_argument("--P", type=int, default=50, help="waypoints per path")
    ap.add_argument("--starts", type=int, default=8, help="pgd starts (rollouts)")
    ap.add_argument("--top", type=int, default=12, help="loop bodies to print")
    ap.add_argument("--json", help="write the whole result here")
    a = ap.parse_args(argv)
    res = profile(a.B, a.P, a.starts)
    print(
        f"pgd B={a.B} P={a.P} starts={a.starts}: compile {res['compile_s']:.1f} s, profiled run "
        f"{res['profiled_run_s']:.2f} s, {res['launches']} kernel launches, {res['kernel_ms']:.0f} ms in kernels"
    )
    # the op names carry no Python function names; the fusion count and trip count tell the loops
    # apart (LWR, f2: the LM stage is the largest body with a traced trip count, ~200 fusions; the
    # Adam loops ~130; each Newton loop 27-36 with trip 8, 3, 2 or 6; the Jacobi sweeps trip 4)
    print(f"{'share':>6} {'ms':>8} {'launches':>9} {'fusions':>7} {'trip':>5}  loop (op name)")
    for r in res["bodies"][: a.top]:
        trip = "-" if r["trip_count"] is None else str(r["trip_count"])
        print(
            f"{r['share']:6.1%} {r['kernel_ms']:8.1f} {r['launches']:9d} {r['fusions']:7d} {trip:>5}  "
            f"{r['op_name'][-80:]}"
        )
    if a.json:
        with open(a.json, "w") as fh:
            json.dump(res, fh, indent=1)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
