"""``jaxstiff sweep CONFIG.toml --out DIR [--resume] [--backend local|ray]``: parameter sweeps."""

from __future__ import annotations

import argparse
import os
import sys
from collections.abc import Callable

from jaxstiff.cli._common import command, reads, writes
from jaxstiff.runtime._io import WriteError, interrupt_exit_code

#: what a sweep writes into its --out folder (jaxstiff.sweep._store)
SWEEP_WRITES = (
    "plan.json",
    "arrays",
    "chunks",
    "manifest.json",
    "results.parquet",
    "results.csv",
    "timing.csv",
    "summary.md",
    "plots",
)

_EPILOG = """\
The config names the robot, the paths and the parameter axes (see jaxstiff/sweep/_config.py, docs/notes/sweep.md or
experiments/sweeps/quick.toml). Every finished chunk is written atomically into DIR; after Ctrl-C
or a kill, run the same command with --resume to compute only what is missing. The results table
is DIR/results.parquet (one row per path x setting), with DIR/summary.md and DIR/plots/.
"""


@command("sweep", "run a parameter sweep from a TOML config (resumable; local or Ray)")
def _add_sweep(p: argparse.ArgumentParser) -> Callable[[argparse.Namespace], int]:
    p.epilog = _EPILOG
    reads(p.add_argument("config", metavar="CONFIG.toml", help="sweep config (TOML)"))
    writes(
        p.add_argument(
            "--out", required=True, metavar="DIR", help="result folder (new/empty, or this sweep's with --resume)"
        ),
        folder=True,
        # (config.toml too, but --resume may read the copy kept there: rewriting it with itself loses nothing)
        names=SWEEP_WRITES,
    )
    p.add_argument("--resume", action="store_true", help="continue the sweep in DIR, skipping its finished chunks")
    p.add_argument(
        "--backend",
        choices=("local", "ray"),
        default="local",
        help="local: this process (batches sharded over its JAX devices); ray: one Ray task per chunk",
    )
    p.add_argument(
        "--address",
        default=None,
        help="Ray cluster address ('auto', 'ray://HOST:10001'); none: start a local Ray instance",
    )
    p.add_argument(
        "--ray-num-cpus", type=int, default=None, metavar="N", help="CPUs of a local Ray instance (none: all)"
    )
    p.add_argument("--dry-run", action="store_true", help="validate the config, print the plan, run nothing")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.add_argument("--no-report", action="store_true", help="skip summary.md and the heat maps")
    p.add_argument(
        "--no-compile-cache",
        action="store_true",
        help="do not use the persistent XLA compilation cache ($JAXSTIFF_CACHE_DIR, ~/.cache/jaxstiff/xla)",
    )

    def run(args: argparse.Namespace) -> int:
        # (looked up on the package at call time: tests replace jaxstiff.sweep.run_sweep)
        from jaxstiff.sweep import load_config, run_sweep
        from jaxstiff.sweep._backends import ChunkLostError

        plan = load_config(args.config)
        if args.dry_run:
            print(plan.describe())
            print(f"plan hash {plan.plan_hash}")
            return 0
        if args.ray_num_cpus is not None and args.ray_num_cpus < 1:
            raise ValueError(f"--ray-num-cpus must be >= 1, got {args.ray_num_cpus}")
        ray_init = {"num_cpus": args.ray_num_cpus} if args.ray_num_cpus else None
        try:
            outcome = run_sweep(
                plan,
                args.out,
                resume=args.resume,
                backend=args.backend,
                address=args.address,
                ray_init=ray_init,
                progress=not args.no_progress,
                report=not args.no_report,
                compile_cache=not args.no_compile_cache,
            )
        except ChunkLostError as e:
            print(f"jaxstiff: error: {e}", file=sys.stderr)
            return 1
        except WriteError as e:  # a full disk or a read-only folder: the finished chunks are kept
            if not os.path.isfile(os.path.join(args.out, "plan.json")):  # the store was never set up
                print(
                    f"jaxstiff: error: {e}; the sweep did not start and left nothing in {args.out}: make room, "
                    f"then run it again: jaxstiff sweep {args.config} --out {args.out}",
                    file=sys.stderr,
                )
                return 1
            print(
                f"jaxstiff: error: {e}; the chunks finished before it are kept in {args.out}: make room, then "
                f"continue with: jaxstiff sweep {args.config} --out {args.out} --resume",
                file=sys.stderr,
            )
            return 1
        except KeyboardInterrupt:
            print(
                f"jaxstiff: interrupted; finished chunks are saved in {args.out}; "
                f"continue with: jaxstiff sweep {args.config} --out {args.out} --resume",
                file=sys.stderr,
            )
            return interrupt_exit_code()  # 130 Ctrl-C, 143 SIGTERM
        print(
            f"{outcome.n_rows} rows ({len(outcome.computed)} chunks computed, {len(outcome.skipped)} resumed) "
            f"in {outcome.wall_s:.1f} s -> {outcome.table_file}"
        )
        return 0

    return run
