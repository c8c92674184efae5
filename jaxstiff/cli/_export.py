"""``jaxstiff export``: a result's q / kj trajectory as CSV for a controller (columns and units:
:mod:`jaxstiff.view._export`)."""

from __future__ import annotations

import argparse
import sys
from typing import Any

from ._common import command, writes
from ._view import add_result_flags


def csc_status_note(meta: dict[str, Any]) -> str:
    """What the ``status`` column of a csc file's CSV means: a bit mask per step, each bit named as
    the file's ``meta["status_bits"]`` names it (:class:`jaxstiff.csc.CSCStatus`; the library's
    names for a file without them), not the shape codes 0-5."""
    bits = meta.get("status_bits")
    if not isinstance(bits, dict) or not bits:
        from jaxstiff.csc._result import STATUS_NAMES

        bits = STATUS_NAMES
    try:
        pairs = sorted((int(k), str(v)) for k, v in bits.items())
    except (TypeError, ValueError):
        raise ValueError(f"result meta field status_bits must map bit values to names, got {bits!r:.80}") from None
    named = ", ".join(f"{k} {v}" for k, v in pairs)
    return (
        f"status column (csc file): a bit mask per step, not the shape codes 0-5: 0 a plain step; {named}; "
        "a step with several flags has their sum (test a flag with status & bit)"
    )


@command("export", "write a result's joint trajectory (q, kj, TCP) as CSV for a controller")
def _add_export(p: argparse.ArgumentParser) -> Any:
    add_result_flags(p)
    writes(
        p.add_argument(
            "--csv",
            "--out",
            dest="csv",
            required=True,
            metavar="OUT.csv",
            help="the CSV to write (written atomically), or - for standard output; --out is the same flag, as in "
            "the other commands",
        ),
        stdout=True,
    )
    p.add_argument("--path", type=int, default=None, help="only this path of a batch (default: all, column 'path')")

    def run(args: argparse.Namespace) -> int:
        from jaxstiff.results._target import waypoints_text
        from jaxstiff.view._data import load_view_data
        from jaxstiff.view._export import csv_text, export_csv, unusable_rows

        data = load_view_data(args.result, row=args.row, urdf=args.urdf)
        if args.path is not None and not 0 <= args.path < data.B:
            raise ValueError(f"--path {args.path}: the result has {data.B} path(s), 0..{data.B - 1}")
        # everything that reads the file (and can refuse it) before the CSV is written: an exit 2
        # never leaves a CSV behind (a csc file's malformed status_bits used to fail after it)
        note = csc_status_note(data.meta) if data.kind == "csc" else None
        bad = unusable_rows(data, args.path)
        where = waypoints_text(bad) if bad else ""
        rows = f"({data.B if args.path is None else 1} x {data.P} rows)"
        if args.csv == "-":  # the CSV alone on standard output; what the command says goes to stderr
            sys.stdout.write(csv_text(data, path=args.path))
            sys.stdout.flush()
            print(f"wrote the CSV to standard output {rows}", file=sys.stderr)
        else:
            print(f"wrote {export_csv(data, args.csv, path=args.path)} {rows}")
        if note:
            print(note, file=sys.stderr if args.csv == "-" else sys.stdout)
        if bad:
            print(
                f"jaxstiff: warning: {sum(len(v) for v in bad.values())} rows are not usable solutions (status "
                f"3-5: an unreachable waypoint's row is the solver's closest point inside its box, the TCP off the "
                f"path; a not-run or non-finite one mostly the reference state): {where}; filter on "
                "the status column before commanding a robot",
                file=sys.stderr,
            )
        return 0

    return run
