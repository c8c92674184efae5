"""``jaxstiff plot``: the figure of a result as PNG, SVG or PDF (by the suffix of ``--out``).

A shape result: seed 000's seven panels (kj, q, criterion, alpha and rho, CMS factor, the path
with the 3-D ellipsoids, their xy projections; :func:`jaxstiff.plots.figure_shape_path`, ellipse
scale stated on the panels). A csc result: u (Nm/rad) and the Frobenius error (N/m) over the
steps, one curve per rollout (:func:`jaxstiff.plots.figure_u_frobenius`). A sweep row with --row;
a sweep's heat maps are written by ``jaxstiff sweep`` into ``DIR/plots/``.
"""

from __future__ import annotations

import argparse
import os
from typing import Any

from .common import command
from .view import add_result_flags

FORMATS = (".png", ".svg", ".pdf")  #: by the suffix of --out (jaxstiff.plots.save_figure)


@command("plot", "draw a result's figure (shape: seed 000's panels; csc: u and Frobenius error)")
def _add_plot(p: argparse.ArgumentParser) -> Any:
    add_result_flags(p)
    p.add_argument("--out", required=True, metavar="FIG.png", help="the figure to write (.png, .svg or .pdf)")
    p.add_argument("--path", type=int, default=0, help="shape: which path of a batch (0-based)")
    p.add_argument(
        "--waypoints",
        type=int,
        default=5,
        metavar="N",
        help="shape: draw the ellipses of every N-th waypoint (the 3-D panel every 2N-th)",
    )

    def run(args: argparse.Namespace) -> int:
        import numpy as np

        from jaxstiff.view.data import load_view_data

        ext = os.path.splitext(args.out)[1].lower()
        if ext not in FORMATS:
            raise ValueError(f"--out {args.out}: write a .png, .svg or .pdf figure (got {ext or 'no suffix'!r})")
        if args.waypoints < 1:
            raise ValueError(f"--waypoints must be a positive number of waypoints, got {args.waypoints}")
        data = load_view_data(args.result, row=args.row, urdf=args.urdf)
        if data.kind == "shape":
            from jaxstiff.plots import figure_shape_path
            from jaxstiff.results.files import ShapeResult

            if not 0 <= args.path < data.B:
                raise ValueError(f"--path {args.path}: the result has {data.B} path(s), 0..{data.B - 1}")
            file = data.source.split("#row=")[0]
            res = ShapeResult.load(file) if os.path.isfile(file) else None
            if res is None or args.row is not None:
                from jaxstiff.view.data import sweep_row_file

                f, i = sweep_row_file(file, int(args.row))
                res, b = ShapeResult.load(f), i
            else:
                b = args.path
            title = f"{os.path.basename(data.source)}: {data.labels[0 if args.row is not None else b]}"
            written = figure_shape_path(res, data.robot, args.out, title, every=args.waypoints, b=b)
        else:
            from jaxstiff.plots import figure_u_frobenius

            written = figure_u_frobenius(
                np.arange(data.P),
                data.arrays["u"],
                data.arrays["frobenius"],
                data.labels,
                args.out,
                suptitle=f"CSC {os.path.basename(data.source)}: robot {data.robot.name}",
            )
        print(f"wrote {written}")
        return 0

    return run
