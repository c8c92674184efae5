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

from ._common import check_out_path, command, writes
from ._view import add_result_flags

FORMATS = (".png", ".svg", ".pdf")  #: by the suffix of --out (jaxstiff.plots.save_figure)


def parse_waypoints(text: str, P: int) -> list[int]:
    """``--waypoints``: a spacing ``N`` (every N-th waypoint from 0) or a pick list ``I,J,...`` of
    0-based waypoint indices (sorted, repeats dropped); a ValueError for other text or an index
    outside 0..P-1."""
    parts = [t.strip() for t in str(text).split(",")]
    if "," in str(text) and not all(parts):
        raise ValueError(f"--waypoints {text!r}: an index is empty; give indices like 0,10,20")
    parts = [t for t in parts if t]
    try:
        values = [int(t) for t in parts]
    except ValueError:
        raise ValueError(f"--waypoints {text!r}: give a spacing N or indices like 0,10,20") from None
    if not values:
        raise ValueError("--waypoints: give a spacing N or indices like 0,10,20")
    if len(parts) == 1 and "," not in str(text):
        if values[0] < 1:
            raise ValueError(f"--waypoints {text}: a spacing must be a positive number of waypoints")
        return list(range(0, P, values[0]))
    bad = [v for v in values if not 0 <= v < P]
    if bad:
        raise ValueError(f"--waypoints {text}: index {bad[0]} is out of range; the path has {P} waypoints, 0..{P - 1}")
    return sorted(set(values))


@command("plot", "draw a result's figure (shape: seed 000's panels; csc: u and Frobenius error)")
def _add_plot(p: argparse.ArgumentParser) -> Any:
    add_result_flags(p)
    writes(p.add_argument("--out", required=True, metavar="FIG.png", help="the figure to write (.png, .svg or .pdf)"))
    p.add_argument("--path", type=int, default=0, help="shape: which path of a batch (0-based)")
    p.add_argument(
        "--waypoints",
        default=None,
        metavar="N|I,J,...",
        help="shape: which waypoints' ellipses to draw, in the 3-D panel and the xy projection alike: a spacing N "
        "(every N-th waypoint from 0) or a pick list of 0-based indices, e.g. 0,10,20 (default: about six, "
        "every P//6-th)",
    )

    def run(args: argparse.Namespace) -> int:
        import numpy as np

        from jaxstiff.view._data import check_drawable, load_view_data

        ext = os.path.splitext(args.out)[1].lower()
        if ext not in FORMATS:
            raise ValueError(f"--out {args.out}: write a .png, .svg or .pdf figure (got {ext or 'no suffix'!r})")
        check_out_path(args.out, "--out")  # an existing, writable folder, as every command's output
        data = load_view_data(args.result, row=args.row, urdf=args.urdf)
        check_drawable(data)  # (a non-finite waypoint is named, not met by an eigen-decomposition)
        if data.kind == "shape":
            from jaxstiff.plots import figure_shape_path
            from jaxstiff.runtime._x64 import enable_x64

            enable_x64()  # the ellipsoids from the file's float64 joints (it warned and drew them in float32)

            if not 0 <= args.path < data.B:
                raise ValueError(f"--path {args.path}: the result has {data.B} path(s), 0..{data.B - 1}")
            # the file as the reader checked it (every path; a sweep row: its index in the array file)
            res = data.result
            b = data.index if data.index is not None else args.path
            title = f"{os.path.basename(data.source)}: {data.labels[0 if args.row is not None else b]}"
            if args.waypoints is None:  # about six ellipses along the path
                written = figure_shape_path(res, data.robot, args.out, title, b=b)
            elif "," in str(args.waypoints):  # a pick list: those waypoints in (f) and (g)
                picks = parse_waypoints(args.waypoints, data.P)
                written = figure_shape_path(res, data.robot, args.out, title, b=b, waypoints=picks)
            else:  # a spacing N: every N-th waypoint in (f) and (g)
                parse_waypoints(args.waypoints, data.P)  # its checks
                written = figure_shape_path(res, data.robot, args.out, title, every=int(args.waypoints), b=b)
        else:
            from jaxstiff.csc import STATUS_JOINT_LIMIT
            from jaxstiff.plots import figure_u_frobenius

            status = data.arrays.get("status")
            limits = None if status is None else (np.asarray(status).astype(np.int64) & int(STATUS_JOINT_LIMIT)) != 0
            written = figure_u_frobenius(
                np.arange(data.P),
                data.arrays["u"],
                data.arrays["frobenius"],
                data.labels,
                args.out,
                suptitle=f"CSC {os.path.basename(data.source)}: robot {data.robot.name}",
                limit_steps=limits,
            )
        print(f"wrote {written}")
        return 0

    return run
