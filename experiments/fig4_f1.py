"""Seed 000, Fig. 4: shaping along a curved path with f1 (ratio at least 5), KUKA LWR 4, 7th joint locked.

Setup (the seed gives neither the path nor the rate limits; jaxstiff's documented defaults):
``urdf/kuka_lwr4.urdf`` with ``lwr_a7`` locked at 0 (as in the seed) and rigid: it neither moves nor
gives, so K_C sums over the 6 free joints (jaxstiff's default for a locked joint, SPEC section 1); the shipped default path (:func:`jaxstiff.paths.default_path`:
a half-sine bump in the plane z = 0.30 m, 60 waypoints, 0.55 m, the tangent turning at most 1.9 deg
per waypoint); desired direction = the path tangent; criterion f1 (S0-9) with r = 5, c = 0.01; task
"full" (K_T = top-left 3x3 of the 6x6 K_C, S0-6/7); kj in [1, 100] Nm/rad; rate limits 2 deg and
5 Nm/rad per waypoint (S0-11 ... S0-14), not applied to the first waypoint; solver "slsqp" (SLSQP
per waypoint with JAX derivatives); CMS to a geometric-mean axis of 1000 N/m.

Panels, as in the seed: (a) joint stiffness, (b) joint positions, (c) criterion value, (d) orientation
error (with the axis ratio), (e) CMS factor, (f) the path with the CMS-scaled 3-D stiffness ellipsoids,
(g) their projection on the xy plane (ellipse scale in N/m stated). Writes ``fig4_f1.png``,
``summary.md`` (the table: share of waypoints with alpha < 1 deg and ratio >= 4.9, the path's largest
turn per waypoint against the rate limit, waypoints with a joint held by a rate limit, max position
error and max bound/rate violation checked with a numpy FK, time per waypoint), ``summary.csv`` and
the result file ``fig4_f1.npz``. ``fig4_f1_curved.py`` runs the same on a path whose tangent turns
more degrees per waypoint than the joint rate limit dq (a joint angle: not the same quantity).

Usage:
    python experiments/fig4_f1.py [--out DIR] [--quick]
"""

from __future__ import annotations

import os
import sys
import time


def limits_in_use(res, robot) -> dict:
    """The path's turning per waypoint against the joint rate limit, and how often the limits hold joints."""
    import numpy as np

    from jaxstiff.paths import Path, turning_deg
    from jaxstiff.plots import rate_limited_joints

    lim = rate_limited_joints(res, robot)
    return {
        "turning": turning_deg(Path(res.target[0], res.direction[0])),
        "dq_deg": float(np.degrees(np.max(res.meta["limits"]["dq"]))),
        "dk": float(np.max(res.meta["limits"]["dk"])),
        "wp_q_rate": int(np.count_nonzero(lim["q_rate"])),
        "wp_kj_rate": int(np.count_nonzero(lim["kj_rate"])),
        "per_wp": lim,
    }


def summary_rows(res, verification, limits):
    """The summary table of the experiment as (metric, value) rows (``limits``: :func:`limits_in_use`)."""
    import numpy as np

    from jaxstiff.results import _files as R

    s = R.summary(res)
    t = limits["turning"]
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
            "path tangent's turn per waypoint min / max (deg); joint rate limit dq (deg)",
            f"{float(t.min()):.2f} / {float(t.max()):.2f}; {limits['dq_deg']:g}",
        ),
        (
            f"waypoints with a joint at its rate limit dq / a stiffness at dk = {limits['dk']:g} Nm/rad",
            f"{limits['wp_q_rate']} / {limits['wp_kj_rate']}",
        ),
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


def default_setup(criterion: str) -> str:
    """The interpretations of the default-path run (this docstring's Setup paragraph) for ``criterion``."""
    setup = " ".join(__doc__.split("Setup")[1].split("Panels")[0].split())
    if criterion == "f2":  # fig5: the same setup with the other criterion
        setup = setup.replace("criterion f1 (S0-9) with r = 5, c = 0.01", "criterion f2 (S0-15) with r = 5")
        assert "f2 (S0-15)" in setup, "fig4_f1's setup text changed: update the f2 substitution"
    return setup


#: what one path says about f1 against f2 (issue 40 item 3): the comparison rests on a family of paths
ONE_PATH = (
    "One path does not rank the criteria: at the first waypoint the solver picks among equally good postures "
    "by rounding, so the same path moved by 1e-13 m can give another count; `fig5_f2_vs_f1_paths` compares f1 and "
    "f2 over 56 paths (the default path shifted, random reachable paths) and reports the distribution."
)


def default_path_note(res, limits) -> list[str]:
    """What the default path's gentle turning means for the result (Markdown lines)."""
    import numpy as np

    t, dq = limits["turning"], limits["dq_deg"]
    nq, nk = limits["wp_q_rate"], limits["wp_kj_rate"]
    below = "below" if float(t.max()) < dq else "not below"
    if nq == 0 and nk == 0:
        held = "no joint and no joint stiffness reaches its rate limit at any waypoint"
        verdict = "the rate limits never hold the ellipsoid back"
    else:
        held = f"a joint reaches its rate limit at {nq} and a joint stiffness at {nk} of {res.P} waypoints"
        verdict = "the rate limits rarely hold the ellipsoid back"
    from fig4_f1_curved import hold_mask, where_it_holds  # the same rule and table as the curved run

    crit = res.meta["criterion"]
    curved = {"f1": "fig4_f1_curved", "f2": "fig5_f2_curved"}.get(crit, "the `_curved` run")
    head = (
        f"The default path's tangent turns at most {float(t.max()):.2f} deg per waypoint ({below} the joint rate "
        f"limit of {dq:g} deg per waypoint; stiffness rate limit {limits['dk']:g} Nm/rad per waypoint), and {held}. "
    )
    ok = hold_mask(res)
    if ok.all():
        return [
            head + f"On this path {verdict}, so an even alpha and ratio along the whole path is the expected result: "
            f"it does not show where the criterion gives way. `{curved}` repeats this figure on a path whose "
            "tangent turns more degrees per waypoint than the joint rate limit dq (a joint angle: not the same "
            f"quantity). {ONE_PATH}",
        ]
    bound = int(np.count_nonzero(limits["per_wp"]["kj_bound"][~ok]))
    return [
        head + f"Even so, {crit} gives way at {int((~ok).sum())} of {res.P} waypoints: the turning alone does not "
        f"explain it (the joint stiffness sits at kmin or kmax at {bound} of them, and {crit} "
        + (
            "asks for a ratio of at least r, so the ratio is free to grow and the stiffness rate limit must then bring it "
            "back)"
            if crit == "f1"
            else "asks for the ratio r exactly)"
        )
        + f". `{curved}` repeats this figure on a path whose tangent turns more degrees per waypoint than the joint "
        f"rate limit dq (a joint angle: not the same quantity). {ONE_PATH}",
        "",
        *where_it_holds(res, limits),
    ]


def run(criterion: str, tag: str, title: str, argv=None, path_fn=None, setup=None, extra=None) -> int:
    """Shape along a path with ``criterion`` (r = 5), draw the seven panels, write the summary.

    Args:
        path_fn: ``path_fn(quick) -> Path``; default: the shipped default path (its first 20 waypoints
            with ``--quick``).
        setup: the interpretations paragraph (default: :func:`default_setup`).
        extra: ``extra(res, robot, limits, out) -> list of Markdown lines`` put after the table
            (default: :func:`default_path_note`).
    """
    from jaxstiff.plots import experiment_parser

    ap = experiment_parser(tag, getattr(sys.modules.get("__main__"), "__doc__", None) or __doc__)  # the script's
    ap.add_argument("--quick", action="store_true", help="a shorter path (see above)")
    args = ap.parse_args(argv)

    from jaxstiff.runtime._x64 import enable_x64
    from jaxstiff.shaping import prefer_sync_cpu_dispatch

    enable_x64()
    prefer_sync_cpu_dispatch()  # per-waypoint SLSQP is latency-bound (see its docstring)

    import jaxstiff
    from jaxstiff import plots
    from jaxstiff.results import _files as R
    from jaxstiff.runtime._io import atomic_write_text

    os.makedirs(args.out, exist_ok=True)
    robot = jaxstiff.Robot.from_urdf("kuka_lwr4", locked={"lwr_a7": 0.0})
    if path_fn is None:
        path = jaxstiff.default_path()
        if args.quick:
            path = jaxstiff.Path(path.points[:20], path.directions[:20], name="default (first 20)")
    else:
        path = path_fn(args.quick)
    t0 = time.perf_counter()
    res = jaxstiff.shape(robot, path, criterion, 5.0)
    wall = time.perf_counter() - t0
    res.save(os.path.join(args.out, f"{tag}.npz"))
    ver = R.verify(res)
    plots.figure_shape_path(res, robot, os.path.join(args.out, f"{tag}.png"), title)

    limits = limits_in_use(res, robot)
    rows = summary_rows(res, ver, limits) + [("wall time of the run incl. compilation (s)", f"{wall:.1f}")]
    atomic_write_text(
        os.path.join(args.out, "summary.csv"), "metric,value\n" + "".join(f'"{k}","{v}"\n' for k, v in rows)
    )
    setup = default_setup(criterion) if setup is None else setup
    lines = [f"## {title}", "", "Setup: " + setup, "", f"![{tag}]({tag}.png)", ""]
    lines += ["| metric | value |", "| --- | --- |"] + [f"| {k} | {v} |" for k, v in rows] + [""]
    lines += default_path_note(res, limits) if extra is None else extra(res, robot, limits, args.out)
    atomic_write_text(os.path.join(args.out, "summary.md"), "\n".join(lines) + "\n")
    for k, v in rows:
        print(f"{k:<90} {v}")
    print(f"wrote {args.out}/{tag}.png, summary.md, summary.csv, {tag}.npz")
    return 0


def main(argv=None) -> int:
    return run(
        "f1",
        "fig4_f1",
        "After seed 000 Fig. 4, on jaxstiff's own default path: f1, ratio at least 5 - KUKA LWR 4 (A7 locked)",
        argv,
    )


if __name__ == "__main__":
    sys.exit(main())
