"""Kill a sweep with SIGKILL midway, resume it, and compare with an uninterrupted run.

Measures the acceptance check of the sweep issue on this machine:

1. run the sweep uninterrupted (``jaxstiff sweep CONFIG --out A``) and time it;
2. run it again into ``B`` and SIGKILL the process once ``--kill-at`` of its chunks are committed;
3. resume (``jaxstiff sweep CONFIG --out B --resume``) and time it;
4. check: the two Parquet tables are identical (every column, exact), every chunk finished before
   the kill is byte-identical afterwards and was not computed again (the manifest's runs), and the
   resumed run computed exactly the missing chunks.

Usage::

    python scripts/sweep_kill_resume.py [experiments/sweeps/resume1000.toml] [--kill-at 0.5] [--work DIR] [--json FILE]

Prints a small table and writes the numbers as JSON (``--json``). Exit code 1 if a check fails.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import platform
import shutil
import signal
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(HERE)
CLI = "import sys; from jaxstiff.cli import main; sys.exit(main())"


def _cmd(config: str, out: str, *extra: str) -> list[str]:
    return [sys.executable, "-c", CLI, "sweep", config, "--out", out, "--no-progress", "--no-report", *extra]


def _rows_files(out: str) -> dict[str, str]:
    d = os.path.join(out, "chunks")
    res = {}
    if os.path.isdir(d):
        for f in sorted(os.listdir(d)):
            if f.startswith("chunk-") and f.endswith(".json"):
                with open(os.path.join(d, f), "rb") as fh:
                    res[f] = hashlib.sha256(fh.read()).hexdigest()
    return res


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=(__doc__ or "").split("\n\n")[0])
    ap.add_argument("config", nargs="?", default=os.path.join(REPO, "experiments", "sweeps", "resume1000.toml"))
    ap.add_argument("--kill-at", type=float, default=0.5, help="fraction of chunks committed before the SIGKILL")
    ap.add_argument("--work", default=None, help="work folder (default: a temporary one, removed)")
    ap.add_argument("--json", default=None, help="write the numbers here")
    args = ap.parse_args(argv)

    import pandas as pd

    from jaxstiff.sweep import load_config

    plan = load_config(args.config)
    n_chunks = len(plan.chunks)
    work = args.work or tempfile.mkdtemp(prefix="sweep-kill-")
    os.makedirs(work, exist_ok=True)
    a, b = os.path.join(work, "uninterrupted"), os.path.join(work, "killed")
    for d in (a, b):
        shutil.rmtree(d, ignore_errors=True)
    env = dict(os.environ, PYTHONPATH=REPO + os.pathsep + os.environ.get("PYTHONPATH", ""))
    print(f"{plan.n_rows} rows, {n_chunks} chunks ({plan.kind}, robot {plan.robot.name}); work folder {work}")

    t0 = time.perf_counter()
    subprocess.run(_cmd(args.config, a), env=env, check=True, stdout=subprocess.DEVNULL)
    t_full = time.perf_counter() - t0
    print(f"uninterrupted: {t_full:.1f} s")

    target = max(1, min(n_chunks - 1, int(round(args.kill_at * n_chunks))))
    t0 = time.perf_counter()
    proc = subprocess.Popen(_cmd(args.config, b), env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    while proc.poll() is None and len(_rows_files(b)) < target:
        time.sleep(0.02)
    if proc.poll() is not None:
        print("the run finished before it could be killed; use a larger sweep or a smaller --kill-at")
        return 1
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    t_killed = time.perf_counter() - t0
    before = _rows_files(b)
    leftovers = [f for sub in ("arrays", "chunks") for f in os.listdir(os.path.join(b, sub)) if f.startswith(".tmp-")]
    print(
        f"killed after {t_killed:.1f} s with {len(before)}/{n_chunks} chunks committed "
        f"({len(leftovers)} temporary files left by the kill)"
    )

    t0 = time.perf_counter()
    subprocess.run(_cmd(args.config, b, "--resume"), env=env, check=True, stdout=subprocess.DEVNULL)
    t_resume = time.perf_counter() - t0
    after = _rows_files(b)
    with open(os.path.join(b, "manifest.json"), encoding="utf-8") as fh:
        man = json.load(fh)
    resumed = man["runs"][-1]
    done_before = {int(f[6:12]) for f in before}
    recomputed = sorted(done_before & set(resumed["computed"]))
    missing = sorted(set(range(n_chunks)) - done_before)

    ta, tb = pd.read_parquet(os.path.join(a, "results.parquet")), pd.read_parquet(os.path.join(b, "results.parquet"))
    try:
        pd.testing.assert_frame_equal(ta, tb, check_exact=True)
        same = True
    except AssertionError as exc:
        same = False
        print(exc)
    checks = {
        "tables_identical": same,
        "finished_chunks_unchanged": all(after.get(f) == h for f, h in before.items()),
        "no_finished_chunk_recomputed": not recomputed,
        "resume_computed_exactly_the_missing": sorted(resumed["computed"]) == missing,
        "no_temporary_files_after_resume": not any(
            f.startswith(".tmp-") for sub in ("arrays", "chunks") for f in os.listdir(os.path.join(b, sub))
        ),
    }
    numbers = {
        "config": os.path.relpath(args.config, REPO),
        "rows": plan.n_rows,
        "chunks": n_chunks,
        "uninterrupted_s": round(t_full, 2),
        "killed_after_s": round(t_killed, 2),
        "chunks_committed_at_kill": len(before),
        "temporary_files_left_by_kill": len(leftovers),
        "resume_s": round(t_resume, 2),
        "resume_computed_chunks": len(resumed["computed"]),
        "checks": checks,
        "machine": f"{platform.platform()}, {os.cpu_count()} CPUs",
    }
    print(f"resume: {t_resume:.1f} s, computed {len(resumed['computed'])} chunks (missing were {len(missing)})")
    for k, v in checks.items():
        print(f"  {k:40s} {'ok' if v else 'FAILED'}")
    if args.json:
        with open(args.json, "w", encoding="utf-8") as fh:
            json.dump(numbers, fh, indent=1)
    if not args.work:
        shutil.rmtree(work, ignore_errors=True)
    return 0 if all(checks.values()) else 1


if __name__ == "__main__":
    sys.exit(main())
