"""``jaxstiff reproduce --out DIR [--quick]``: run every experiment and write one report."""

from __future__ import annotations

import argparse
import importlib
import os
import sys
from types import ModuleType

from jaxstiff.cli._common import command, reads, writes

__all__ = ["load_runner"]

#: the folder of the package's source checkout (editable install or clone): experiments/ lies beside it
_CHECKOUT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def load_runner() -> ModuleType:
    """The runner of ``jaxstiff reproduce`` (``experiments/_reproduce/runner.py``), which lives in the
    source checkout with the experiments it runs, not in the installed package: looked for in
    ``$JAXSTIFF_EXPERIMENTS``, beside the package (an editable install or a clone), then in
    ``./experiments``.

    Raises:
        FileNotFoundError: no checkout found; the message says where it looked and what to do.
    """
    env = os.environ.get("JAXSTIFF_EXPERIMENTS")
    folders = ([env] if env else []) + [
        os.path.join(_CHECKOUT, "experiments"),
        os.path.join(os.getcwd(), "experiments"),
    ]
    for d in folders:
        if os.path.isfile(os.path.join(d, "_reproduce", "runner.py")):
            d = os.path.abspath(d)
            if d not in sys.path:
                sys.path.insert(0, d)
            return importlib.import_module("_reproduce.runner")
    raise FileNotFoundError(
        "jaxstiff reproduce runs the scripts in the experiments/ folder of a source checkout, which is not "
        "part of the installed package; looked in: " + "; ".join(folders) + ". Run it from the root of a clone "
        "of the repository (with any install of it), or give a checkout's experiments/ folder with --experiments DIR "
        "or JAXSTIFF_EXPERIMENTS"
    )


@command("reproduce", "run the experiments (seed figures 2-6, CSC, the quick sweep) and write one report")
def _add_reproduce(p: argparse.ArgumentParser):
    p.epilog = (
        "Needs a source checkout: the experiments are the scripts in its experiments/ folder, "
        "each run as its own process. Writes DIR/report.md, DIR/figures/ and DIR/runs/."
    )
    writes(
        p.add_argument("--out", required=True, metavar="DIR", help="report folder"),
        folder=True,
        names=("report.md", "figures", "runs"),
    )
    p.add_argument("--quick", action="store_true", help="pass --quick to the experiments that have a short variant")
    p.add_argument(
        "--only",
        nargs="+",
        metavar="NAME",
        default=None,
        help="run only the experiments whose names start with these (e.g. fig4 csc); no sweep",
    )
    reads(
        p.add_argument(
            "--experiments",
            metavar="DIR",
            default=None,
            help="the experiments folder (none: $JAXSTIFF_EXPERIMENTS, then the source checkout's)",
        )
    )
    p.add_argument("--timeout", type=float, default=900.0, metavar="S", help="seconds per experiment")
    p.add_argument("--no-sweep", action="store_true", help="skip experiments/sweeps/quick.toml")
    p.add_argument("--report-only", action="store_true", help="run nothing; rebuild DIR/report.md from DIR/runs")
    p.add_argument(
        "--all",
        action="store_true",
        help="run every experiment script, not only the default set (seed 000's figures fig*, the fidelity studies "
        "task_modes and f1_default_path, the CSC cases csc*, the physics check sim*)",
    )

    def run(args) -> int:
        import os

        run_reproduce = load_runner().run_reproduce

        if os.path.exists(args.out) and not os.path.isdir(args.out):
            raise ValueError(f"--out: {args.out} is a file; the report needs a folder (made if missing)")
        if not args.timeout > 0:
            raise ValueError(f"--timeout must be > 0 seconds, got {args.timeout}")
        res = run_reproduce(
            args.out,
            quick=args.quick,
            only=args.only,
            experiments_dir=args.experiments,
            timeout=args.timeout,
            sweep=not args.no_sweep,
            everything=args.all,
            report_only=args.report_only,
        )
        failed = [r.name for r in res.runs if not r.ok]
        print(f"{len(res.runs) - len(failed)} of {len(res.runs)} ok in {res.wall_s:.0f} s -> {res.report}")
        if failed:
            print("failed: " + ", ".join(failed))
            return 1
        return 0

    return run
