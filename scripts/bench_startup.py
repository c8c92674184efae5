"""Benchmark: what a user waits for before and around a short job, each in a fresh process.

Measures, in new Python processes (the way a command starts):

1. ``import ml_dtypes``, ``import numpy`` and ``import jax`` (plus one tiny computation), each the
   median of ``--repeats`` fresh processes (seconds, ``time.perf_counter`` inside the process);
2. the README main job, ``jaxstiff shape`` on the shipped default, ``--repeats`` times after one
   run that fills the compilation cache: wall time of the whole process, the command's own time
   and its compilation time (both from the command's last line), and the difference (interpreter
   start, imports, argument parsing, writing the file).

The import of ``ml_dtypes`` is reported on its own because version 0.7.0 takes about 1 s of it on
a 2-core CPU (numpy registers its new dtypes' ufunc loops one by one, with a linear search each);
pyproject.toml keeps ``ml_dtypes<0.7`` for that reason (0.6.0: 0.02 s).

Usage:
    python scripts/bench_startup.py [--repeats 3] [--out DIR] [--json FILE]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import re
import statistics
import subprocess
import sys
import tempfile
import time

_IMPORT = "import time; t = time.perf_counter(); {stmt}; print(time.perf_counter() - t)"
_STMTS = {
    "ml_dtypes": "import ml_dtypes",
    "numpy": "import numpy",
    "jax": "import jax, jax.numpy as jnp; jnp.zeros(3).sum().block_until_ready()",
}
#: the command's last line: "jaxstiff: shape: 2.8 s, of which JAX compilation 0.9 s (...)"
_LINE = re.compile(r"jaxstiff: shape: ([0-9.]+) s, of which JAX compilation ([0-9.]+) s")


def _import_time(stmt: str) -> float:
    out = subprocess.run([sys.executable, "-c", _IMPORT.format(stmt=stmt)], capture_output=True, text=True, check=True)
    return float(out.stdout.strip().splitlines()[-1])


def _shape_run(cwd: str) -> dict[str, float]:
    exe = os.path.join(os.path.dirname(sys.executable), "jaxstiff")
    cmd = [exe, "shape"] if os.path.exists(exe) else [sys.executable, "-m", "jaxstiff.cli", "shape"]
    t0 = time.perf_counter()
    out = subprocess.run(cmd, cwd=cwd, capture_output=True, text=True, check=True)
    wall = time.perf_counter() - t0
    m = _LINE.search(out.stderr + out.stdout)
    command = float(m.group(1)) if m else float("nan")
    compile_s = float(m.group(2)) if m else float("nan")
    return {"wall_s": wall, "command_s": command, "compile_s": compile_s, "outside_s": wall - command}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--repeats", type=int, default=3, help="fresh processes per measurement (default 3)")
    ap.add_argument("--out", default=None, help="folder for shape.npz (default: a temporary folder)")
    ap.add_argument("--json", default=None, help="also write the numbers to this JSON file")
    args = ap.parse_args(argv)
    if args.repeats < 1:
        ap.error(f"--repeats must be at least 1, got {args.repeats}")

    import importlib.metadata as md

    versions = {p: md.version(p) for p in ("ml_dtypes", "numpy", "jax", "jaxlib")}
    print(f"python {platform.python_version()}, " + ", ".join(f"{k} {v}" for k, v in versions.items()))
    report: dict = {"versions": versions, "machine": platform.processor() or platform.machine(), "imports_s": {}}
    for name, stmt in _STMTS.items():
        times = [_import_time(stmt) for _ in range(args.repeats)]
        report["imports_s"][name] = times
        print(
            f"import {name:<10} median {statistics.median(times):6.3f} s  (runs: {', '.join(f'{t:.3f}' for t in times)})"
        )

    with tempfile.TemporaryDirectory() as tmp:
        cwd = args.out or tmp
        os.makedirs(cwd, exist_ok=True)
        first = _shape_run(cwd)  # fills the compilation cache (or finds it filled)
        runs = [_shape_run(cwd) for _ in range(args.repeats)]
    report["shape_first"] = first
    report["shape_warm"] = runs
    print(
        f"jaxstiff shape, first run: wall {first['wall_s']:.2f} s (command {first['command_s']:.2f} s, "
        f"compilation {first['compile_s']:.2f} s)"
    )
    for key, label in (("wall_s", "wall"), ("command_s", "in the command"), ("compile_s", "of it compilation")):
        vals = [r[key] for r in runs]
        print(
            f"jaxstiff shape, warm: {label:<18} median {statistics.median(vals):5.2f} s  ({', '.join(f'{v:.2f}' for v in vals)})"
        )
    vals = [r["outside_s"] for r in runs]
    print(f"jaxstiff shape, warm: {'start and imports':<18} median {statistics.median(vals):5.2f} s")
    if args.json:
        with open(args.json, "w") as f:
            json.dump(report, f, indent=2)
    return 0


if __name__ == "__main__":
    sys.exit(main())
