"""``jaxstiff export``: a result's q / kj trajectory as CSV for a controller (columns and units:
:mod:`jaxstiff.view.export`)."""

from __future__ import annotations

import argparse
import sys
from typing import Any

from .common import command
from .view import add_result_flags


@command("export", "write a result's joint trajectory (q, kj, TCP) as CSV for a controller")
def _add_export(p: argparse.ArgumentParser) -> Any:
    add_result_flags(p)
    p.add_argument("--csv", required=True, metavar="OUT.csv", help="the CSV to write (written atomically)")
    p.add_argument("--path", type=int, default=None, help="only this path of a batch (default: all, column 'path')")

    def run(args: argparse.Namespace) -> int:
        from jaxstiff.view.data import load_view_data
        from jaxstiff.view.export import export_csv, unusable_rows

        data = load_view_data(args.result, row=args.row, urdf=args.urdf)
        print(
            f"wrote {export_csv(data, args.csv, path=args.path)} ({data.B if args.path is None else 1} x {data.P} rows)"
        )
        bad = unusable_rows(data, args.path)
        if bad:
            from jaxstiff.results.target import waypoints_text

            where = waypoints_text(bad)
            print(
                f"jaxstiff: warning: {sum(len(v) for v in bad.values())} rows are not usable solutions (status "
                f"3-5: unreachable, non-finite or not run; they hold the reference state): {where}; filter on "
                "the status column before commanding a robot",
                file=sys.stderr,
            )
        return 0

    return run
