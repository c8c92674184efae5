"""Seed 000, Fig. 4: shaping along a curved path with f1 (ratio at least 5), KUKA LWR 4, 7th joint locked.

Setup (the seed gives neither the path nor the rate limits; jaxstiff's documented defaults):
``urdf/kuka_lwr4.urdf`` with ``lwr_a7`` locked at 0; the shipped default path
(:func:`jaxstiff.paths.default_path`: a half-sine bump in the plane z = 0.30 m, 60 waypoints,
0.55 m); desired direction = the path tangent; criterion f1 (S0-9) with r = 5, c = 0.01; task
"full" (K_T = top-left 3x3 of the 6x6 K_C, S0-6/7); kj in [1, 100] Nm/rad; rate limits 2 deg and
5 Nm/rad per waypoint (S0-11 ... S0-14), not applied to the first waypoint; solver "slsqp" (SLSQP
per waypoint with JAX derivatives); CMS to a geometric-mean axis of 1000 N/m.

Panels, as in the seed: (a) joint stiffness, (b) joint positions, (c) criterion value, (d) orientation
error (with the axis ratio), (e) CMS factor, (f) the path with the CMS-scaled 3-D stiffness ellipsoids,
(g) their projection on the xy plane. Writes ``fig4_f1.png``, ``summary.md`` (the table: share of
waypoints with alpha < 1 deg and ratio >= 4.9, max position error and max bound/rate violation checked
with a numpy FK, time per waypoint), ``summary.csv`` and the result file ``fig4_f1.npz``.

Usage:
    python experiments/fig4_f1.py [--out DIR] [--quick]
"""

from __future__ import annotations

import os
import sys
import time


def summary_rows(res, verification):
    """The summary table of the experiment as (metric, value) rows."""
    import numpy as np

    from jaxstiff.results import files as R

    s = R.summary(res)
    r = float(res.meta["ratio"])
    rlabel = (
        f"share of waypoints with ratio >= {0.98 * r:g} (f1 asks for at least {r:g})"
        if res.meta["criterion"] == "f1"
        else f"share of waypoints with |ratio - {r:g}| / {r:g} < 2%"
    )
    st = np.bincount(res.status.ravel(), minlength=5)
    return [
        ("waypoints", f"{res.P}"),
        ("share of waypoints with alpha < 1 deg", f"{s['share_alpha']:.1%}"),
        (rlabel, f"{s['share_ratio']:.1%}"),
        ("share with both", f"{s['share_both']:.1%}"),
        ("median alpha (deg)", f"{s['median_alpha_deg']:.2e}"),
        ("max alpha (deg)", f"{float(res.alpha_deg.max()):.3g}"),
        ("ratio min / max", f"{float(res.ratio.min()):.3f} / {float(res.ratio.max()):.3f}"),
        (
            "status counts (0 solved, 1 not converged, 2 clipped, 3 unreachable, 4 non-finite)",
            " ".join(str(int(x)) for x in st),
        ),
        ("max position error (m), numpy FK", f"{verification['max_pos_error']:.2e}"),
        ("max bound violation (joint limits, kmin/kmax)", f"{verification['max_bound_violation']:.2e}"),
        ("max rate violation (rad or Nm/rad beyond dq, dk)", f"{verification['max_rate_violation']:.2e}"),
        ("median time per waypoint (ms), first waypoint excluded", f"{1e3 * float(np.median(res.time_s[:, 1:])):.1f}"),
        ("first waypoint (8 starts) time (s)", f"{float(res.time_s[0, 0]):.2f}"),
        ("median SLSQP iterations per waypoint", f"{float(np.median(res.nit[:, 1:])):.0f}"),
        ("compile time (s)", f"{res.meta['timing_s'].get('compile') or 0:.1f}"),
    ]


def run(criterion: str, tag: str, title: str, argv=None) -> int:
    from jaxstiff.plots import experiment_parser

    ap = experiment_parser(tag, __doc__)
    ap.add_argument("--quick", action="store_true", help="only the first 20 waypoints of the default path")
    args = ap.parse_args(argv)

    from jaxstiff.runtime.x64 import enable_x64
    from jaxstiff.shaping import prefer_sync_cpu_dispatch

    enable_x64()
    prefer_sync_cpu_dispatch()  # per-waypoint SLSQP is latency-bound (see its docstring)

    import jaxstiff
    from jaxstiff import plots
    from jaxstiff.results import files as R
    from jaxstiff.runtime.io import atomic_write_text

    os.makedirs(args.out, exist_ok=True)
    robot = jaxstiff.Robot.from_urdf("kuka_lwr4", locked={"lwr_a7": 0.0})
    path = jaxstiff.default_path()
    if args.quick:
        path = jaxstiff.Path(path.points[:20], path.directions[:20], name="default (first 20)")
    t0 = time.perf_counter()
    res = jaxstiff.shape(robot, path, criterion, 5.0)
    wall = time.perf_counter() - t0
    res.save(os.path.join(args.out, f"{tag}.npz"))
    ver = R.verify(res)
    plots.figure_shape_path(res, robot, os.path.join(args.out, f"{tag}.png"), title)

    rows = summary_rows(res, ver) + [("wall time of the run incl. compilation (s)", f"{wall:.1f}")]
    atomic_write_text(
        os.path.join(args.out, "summary.csv"), "metric,value\n" + "".join(f'"{k}","{v}"\n' for k, v in rows)
    )
    lines = [f"## {title}", "", f"![{tag}]({tag}.png)", "", "| metric | value |", "| --- | --- |"]
    lines += [f"| {k} | {v} |" for k, v in rows]
    setup = " ".join(__doc__.split("Setup")[1].split("Panels")[0].split())
    if criterion == "f2":  # fig5: the same setup with the other criterion
        setup = setup.replace("criterion f1 (S0-9) with r = 5, c = 0.01", "criterion f2 (S0-15) with r = 5")
        assert "f2 (S0-15)" in setup, "fig4_f1's setup text changed: update the f2 substitution"
    lines += ["", "Setup: " + setup]
    atomic_write_text(os.path.join(args.out, "summary.md"), "\n".join(lines) + "\n")
    for k, v in rows:
        print(f"{k:<90} {v}")
    print(f"wrote {args.out}/{tag}.png, summary.md, summary.csv, {tag}.npz")
    return 0


def main(argv=None) -> int:
    return run("f1", "fig4_f1", "Seed 000 Fig. 4: f1, ratio at least 5 - KUKA LWR 4 (A7 locked), default path", argv)


if __name__ == "__main__":
    sys.exit(main())
