"""``jaxstiff check-sim RESULT.npz`` (or ``DIR --row K``, a shape sweep's row, read as view/plot/export
read it): predicted vs MuJoCo-measured stiffness of a shape result.

Needs MuJoCo (``pip install "jaxstiff[sim]"``). For each selected waypoint of every path the robot
is rebuilt in MuJoCo with springs kj at the waypoint's posture, small forces (and, for task
``full``, moments) are applied at the TCP, and the settled deflections are compared with jaxstiff's
compliance; then a finite load checks the CCT term and its sign (:mod:`jaxstiff.sim._check`). Whatever
the task, it prints both stiffnesses a force meets: with the tool's orientation held and with the tool
free to turn.
Exit code 0 when every waypoint agrees within ``--tol``, 1 otherwise, 2 for bad input.
"""

from __future__ import annotations

import argparse
import json
import math
import os
from typing import Any

import numpy as np

from ._common import check_out_path, command, parse_floats, writes
from ._view import add_result_flags


def _waypoints(text: str) -> int | list[int]:
    """``N`` (a sample of N) or ``i,j,k`` (these indices)."""
    values = parse_floats(text, "--waypoints")
    if not values or any(v != int(v) for v in values):
        raise ValueError(f"--waypoints: expected a count N or indices i,j,k, got {text!r}")
    if "," in text:
        return [int(v) for v in values]
    return int(values[0])


def _say_unusable(result: Any) -> None:
    """Say how many waypoints of ``result`` (a file or a loaded shape result) have no usable
    solution, which no --waypoints choice checks ("7/7 agree" on a path of 20 said nothing of the 13)."""
    from ..results import ShapeResult, is_usable

    res = ShapeResult.load(result) if isinstance(result, (str, os.PathLike)) else result
    status = np.asarray(res.status)
    bad = int(np.sum(~is_usable(status)))
    if bad:
        print(
            f"jaxstiff: check-sim: {bad} of {status.size} waypoints have no usable solution (status 3-5) and are not "
            "checked (--waypoints picks among the usable ones)"
        )


@command("check-sim", "check a shape result's stiffness against a MuJoCo simulation (needs jaxstiff[sim])")
def _add_check_sim(p: argparse.ArgumentParser) -> Any:
    # RESULT (a file, or a sweep folder with --row), --row, --urdf: as view/plot/export, shape results only
    add_result_flags(p, "a shape result file (.npz), or a shape sweep's folder with --row")
    p.add_argument(
        "--waypoints",
        default="5",
        help="N: check N evenly spaced waypoints per path among its usable ones (status 0-2; the usable ends "
        "included); i,j,k: these indices (unusable ones left out); 'all'. A waypoint without a usable solution "
        "holds none to check: the command says how many it leaves out",
    )
    p.add_argument(
        "--force",
        type=float,
        default=None,
        help="probe force, N (moment probes: Nm); default: sized for a deflection of 1e-5 m (1e-5 rad). The check "
        "compares the linear (small-deflection) stiffness: a probe that moves the TCP much further measures the "
        "arm's nonlinear response and misses",
    )
    p.add_argument("--tol", type=float, default=1e-3, help="relative agreement required")
    p.add_argument("--no-cct", action="store_true", help="skip the finite-load (CCT) check")
    p.add_argument("--scaled", action="store_true", help="use kj_scaled (after CMS) instead of kj")
    writes(p.add_argument("--json", default=None, metavar="OUT", help="also write the table and errors as JSON"))

    def run(args: argparse.Namespace) -> int:
        from ..sim._build import MUJOCO_MISSING

        try:
            import mujoco  # noqa: F401
        except ImportError:
            raise ValueError(MUJOCO_MISSING) from None
        from ..runtime._io import atomic_write_text, json_default
        from ..runtime._x64 import enable_x64
        from ..sim import SettleError, cases_from_result, check_cases, markdown_table, rows_json
        from ..sim._report import HELD_FREE_NOTE
        from ..sim._setup import sweep_row_result

        if args.force is not None and not (math.isfinite(args.force) and args.force > 0):
            raise ValueError(f"--force must be a positive finite number of newtons, got {args.force}")
        if not 0 < args.tol < 1:
            raise ValueError(f"--tol must be in (0, 1), got {args.tol}")
        if args.json:  # the output's folder before the simulation, not after it
            check_out_path(args.json, "--json")
        enable_x64()
        waypoints = None if args.waypoints.strip().lower() == "all" else _waypoints(args.waypoints)
        result: Any = args.result
        if os.path.isdir(args.result):
            if args.row is None:
                raise ValueError(f"{args.result} is a sweep folder: pick one of its rows with --row ROW_ID")
            result = sweep_row_result(args.result, args.row, args.urdf)
        elif args.row is not None:
            raise ValueError(f"--row {args.row} is for a sweep folder; {args.result} is a result file")
        cases = cases_from_result(result, waypoints, scaled=args.scaled, urdf=args.urdf)
        _say_unusable(result)
        try:
            rows = check_cases(cases, force=args.force, tol=args.tol, cct=not args.no_cct)
        except SettleError as exc:
            print(f"jaxstiff: check-sim: {exc}")
            return 1
        print(markdown_table(rows, cases[0].robot.name if cases else ""))
        print(f"\n{HELD_FREE_NOTE}")
        data = rows_json(rows, result=args.result, robot=cases[0].robot.name if cases else None)
        bad = [r.label for r in rows if not r.passed]
        print(
            f"\n{len(rows) - len(bad)}/{len(rows)} waypoints agree within {args.tol:g} "
            f"(worst: {', '.join(f'{k} {v:.1e}' for k, v in data['worst'].items())})"
        )
        if args.json:
            atomic_write_text(args.json, json.dumps(data, indent=1, default=json_default) + "\n")
        if bad:
            print(f"jaxstiff: check-sim: waypoints {', '.join(bad)} miss the tolerance {args.tol:g}")
            return 1
        return 0

    return run
