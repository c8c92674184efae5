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

import argparse
import os
import sys
import time


def ellipsoid_axes(robot, q, kj_scaled, task="full"):
    """Eigenvalues (descending, N/m) and eigenvectors (columns) of K_T at each waypoint, (P, 3), (P, 3, 3)."""
    import numpy as np

    import jaxstiff

    J = jaxstiff.jacobian(robot, np.asarray(q))
    K = np.asarray(jaxstiff.translational_stiffness(J, np.asarray(kj_scaled), task=task))
    w, V = np.linalg.eigh(K)
    return w[:, ::-1], V[:, :, ::-1]


def seven_panel_figure(res, robot, file, title, every=5, b=0):
    """The seed's Fig. 4/5 layout for path ``b`` of a ShapeResult: panels (a)-(g), saved as PNG."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    P, n = res.P, res.n
    wp = np.arange(P)
    r = float(res.meta["ratio"])
    fig = plt.figure(figsize=(17, 14))
    gs = fig.add_gridspec(3, 6, height_ratios=[1, 1, 1.7], hspace=0.45, wspace=0.9)
    colors = plt.cm.tab10(np.arange(n))

    ax = fig.add_subplot(gs[0, 0:2])
    for i in range(n):
        ax.plot(wp, res.kj[b, :, i], color=colors[i], label=str(res.joint_names[i]))
    ax.set(xlabel="waypoint p", ylabel="joint stiffness k_j (Nm/rad)", title="(a) joint stiffness (before CMS)")
    ax.legend(fontsize=7, ncol=4, loc="upper center", bbox_to_anchor=(0.5, -0.2))
    ax.grid(alpha=0.3)

    ax = fig.add_subplot(gs[0, 2:4])
    for i in range(n):
        ax.plot(wp, np.degrees(res.q[b, :, i]), color=colors[i], label=str(res.joint_names[i]))
    ax.set(xlabel="waypoint p", ylabel="joint position q (deg)", title="(b) joint positions")
    ax.legend(fontsize=7, ncol=4, loc="upper center", bbox_to_anchor=(0.5, -0.2))
    ax.grid(alpha=0.3)

    ax = fig.add_subplot(gs[0, 4:6])
    crit = res.meta["criterion"]
    fmin = {"f1": float(res.meta["c"]), "f2": 1.0}.get(crit)
    if fmin is not None:  # distance to the criterion's lowest possible value, log scale
        ax.plot(wp, np.maximum(res.criterion[b] - fmin, 1e-12), "k.-", label=f"{crit} - {fmin:g}")
        ax.set(ylabel=f"{crit} - min {crit} (-)")
    else:
        ax.plot(wp, res.criterion[b], "k.-", label=crit)
        ax.set(ylabel=f"{crit} (-)")
    ax.set(xlabel="waypoint p", title=f"(c) criterion {crit} (its minimum is {fmin:g})" if fmin else f"(c) criterion {crit}")
    ax.set_yscale("log")
    ax.legend(fontsize=8, loc="best")
    ax.grid(alpha=0.3, which="both")

    ax = fig.add_subplot(gs[1, 0:3])
    ax.plot(wp, res.alpha_deg[b], "C3.-", label="orientation error alpha")
    ax.axhline(1.0, color="C3", ls=":", lw=1, label="1 deg")
    ax.set(xlabel="waypoint p", ylabel="alpha (deg)", title="(d) orientation error and axis ratio")
    ax.set_ylim(bottom=0, top=max(1.5, 1.1 * float(res.alpha_deg[b].max())))
    ax2 = ax.twinx()
    ax2.plot(wp, res.ratio[b], "C0.-", label="axis ratio rho = lambda1/lambda2")
    ax2.axhline(r, color="C0", ls=":", lw=1, label=f"r = {r:g}")
    ax2.set_ylabel("axis ratio rho (-)")
    ax2.set_ylim(0, max(2 * r, 1.1 * float(res.ratio[b].max())))
    h1, l1 = ax.get_legend_handles_labels()
    h2, l2 = ax2.get_legend_handles_labels()
    ax.legend(h1 + h2, l1 + l2, fontsize=8, loc="upper right")
    ax.grid(alpha=0.3)

    ax = fig.add_subplot(gs[1, 3:6])
    ax.plot(wp, res.cms[b], "C2.-")
    ax.set(xlabel="waypoint p", ylabel="CMS factor k (-)",
           title="(e) common-mode stiffness: kj_scaled = k kj (equal ellipsoid volume)")
    ax.grid(alpha=0.3)

    lam, V = ellipsoid_axes(robot, res.q[b], res.kj_scaled[b], res.meta["task"])
    pts = res.target[b]
    idx = np.arange(0, P, every)
    spacing = float(np.median(np.linalg.norm(np.diff(pts, axis=0), axis=1)))
    unit = lam / lam[:, :1].max()  # axes relative to the largest major axis on the path

    ax = fig.add_subplot(gs[2, 0:4], projection="3d")
    ax.plot(*pts.T, "k-", lw=1.5, label="path")
    u, v = np.meshgrid(np.linspace(0, 2 * np.pi, 24), np.linspace(0, np.pi, 12))
    sphere = np.stack([np.cos(u) * np.sin(v), np.sin(u) * np.sin(v), np.cos(v)], axis=-1)
    idx3 = np.arange(0, P, 2 * every)
    size = 0.5 * 2 * every * spacing  # display semi-major axis (m) of the stiffest ellipsoid
    for k in idx3:
        E = sphere * (unit[k] * size) @ V[k].T + pts[k]
        ax.plot_surface(E[..., 0], E[..., 1], E[..., 2], color="C1", alpha=0.6, linewidth=0, shade=True)
        ax.quiver(*pts[k], *(0.6 * size * res.direction[b, k]), color="C0", lw=1)
    ax.set(xlabel="x (m)", ylabel="y (m)", zlabel="z (m)", title="(f) path and 3-D stiffness ellipsoids (CMS-scaled)")
    lo, hi = pts.min(0) - 1.1 * size, pts.max(0) + 1.1 * size
    lo[2], hi[2] = min(lo[2], pts[:, 2].mean() - 0.05), max(hi[2], pts[:, 2].mean() + 0.05)
    ax.set_xlim(lo[0], hi[0])
    ax.set_ylim(lo[1], hi[1])
    ax.set_zlim(lo[2], hi[2])
    ax.set_box_aspect(tuple(hi - lo))  # equal scale on all three axes
    ax.view_init(elev=45, azim=-30)
    from matplotlib.ticker import MaxNLocator

    for axis in (ax.xaxis, ax.yaxis, ax.zaxis):
        axis.set_major_locator(MaxNLocator(4))

    ax = fig.add_subplot(gs[2, 4:6])
    ax.plot(pts[:, 0], pts[:, 1], "k-", lw=1.5, label="path")
    t = np.linspace(0, 2 * np.pi, 100)
    size = 0.5 * every * spacing
    semi = unit * size
    for j, k in enumerate(idx):
        M = (V[k] * semi[k])[:2]  # xy rows of the ellipsoid's axis matrix
        w2, U = np.linalg.eigh(M @ M.T)  # outline of the projection: an ellipse
        ell = (U * np.sqrt(np.maximum(w2, 0))) @ np.stack([np.cos(t), np.sin(t)])
        ax.plot(pts[k, 0] + ell[0], pts[k, 1] + ell[1], color="C1", label="ellipsoid outline (xy)" if j == 0 else None)
        a = V[k][:2, 0] * semi[k, 0]
        ax.plot(pts[k, 0] + np.array([-a[0], a[0]]), pts[k, 1] + np.array([-a[1], a[1]]), "C3-", lw=1,
                label="major axis" if j == 0 else None)
        d = res.direction[b, k, :2] * semi[k, 0]
        ax.plot(pts[k, 0] + np.array([-d[0], d[0]]), pts[k, 1] + np.array([-d[1], d[1]]), "C0:", lw=1,
                label="path tangent" if j == 0 else None)
    ax.set(xlabel="x (m)", ylabel="y (m)", title="(g) projection on the xy plane")
    ax.set_aspect("equal")
    ax.legend(fontsize=8, loc="best")
    ax.grid(alpha=0.3)

    fig.suptitle(title, fontsize=13)
    fig.savefig(file, dpi=110, bbox_inches="tight")
    plt.close(fig)


def summary_rows(res, verification):
    """The summary table of the experiment as (metric, value) rows."""
    import numpy as np

    from jaxstiff import results as R

    s = R.summary(res)
    r = float(res.meta["ratio"])
    rlabel = f"share of waypoints with ratio >= {0.98 * r:g} (f1 asks for at least {r:g})" if res.meta["criterion"] == "f1" \
        else f"share of waypoints with |ratio - {r:g}| / {r:g} < 2%"
    st = np.bincount(res.status.ravel(), minlength=5)
    return [
        ("waypoints", f"{res.P}"),
        ("share of waypoints with alpha < 1 deg", f"{s['share_alpha']:.1%}"),
        (rlabel, f"{s['share_ratio']:.1%}"),
        ("share with both", f"{s['share_both']:.1%}"),
        ("median alpha (deg)", f"{s['median_alpha_deg']:.2e}"),
        ("max alpha (deg)", f"{float(res.alpha_deg.max()):.3g}"),
        ("ratio min / max", f"{float(res.ratio.min()):.3f} / {float(res.ratio.max()):.3f}"),
        ("status counts (0 solved, 1 not converged, 2 clipped, 3 unreachable, 4 non-finite)", " ".join(str(int(x)) for x in st)),
        ("max position error (m), numpy FK", f"{verification['max_pos_error']:.2e}"),
        ("max bound violation (joint limits, kmin/kmax)", f"{verification['max_bound_violation']:.2e}"),
        ("max rate violation (rad or Nm/rad beyond dq, dk)", f"{verification['max_rate_violation']:.2e}"),
        ("median time per waypoint (ms), first waypoint excluded", f"{1e3 * float(np.median(res.time_s[:, 1:])):.1f}"),
        ("first waypoint (8 starts) time (s)", f"{float(res.time_s[0, 0]):.2f}"),
        ("median SLSQP iterations per waypoint", f"{float(np.median(res.nit[:, 1:])):.0f}"),
        ("compile time (s)", f"{res.meta['timing_s'].get('compile') or 0:.1f}"),
    ]


def run(criterion: str, tag: str, title: str, argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", default=f"out/{tag}", help="output folder")
    ap.add_argument("--quick", action="store_true", help="only the first 20 waypoints of the default path")
    args = ap.parse_args(argv)

    from jaxstiff._x64 import enable_x64
    from jaxstiff.shaping import prefer_sync_cpu_dispatch

    enable_x64()
    prefer_sync_cpu_dispatch()  # per-waypoint SLSQP is latency-bound (see its docstring)
    import numpy as np

    import jaxstiff
    from jaxstiff import results as R

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
    seven_panel_figure(res, robot, os.path.join(args.out, f"{tag}.png"), title)

    rows = summary_rows(res, ver) + [("wall time of the run incl. compilation (s)", f"{wall:.1f}")]
    with open(os.path.join(args.out, "summary.csv"), "w") as fh:
        fh.write("metric,value\n")
        for k, v in rows:
            fh.write(f"\"{k}\",\"{v}\"\n")
    lines = [f"## {title}", "", f"![{tag}]({tag}.png)", "", "| metric | value |", "| --- | --- |"]
    lines += [f"| {k} | {v} |" for k, v in rows]
    lines += ["", "Setup: " + " ".join(__doc__.split("Setup")[1].split("Panels")[0].split())]
    with open(os.path.join(args.out, "summary.md"), "w") as fh:
        fh.write("\n".join(lines) + "\n")
    for k, v in rows:
        print(f"{k:<90} {v}")
    print(f"wrote {args.out}/{tag}.png, summary.md, summary.csv, {tag}.npz")
    return 0


def main(argv=None) -> int:
    return run("f1", "fig4_f1", "Seed 000 Fig. 4: f1, ratio at least 5 - KUKA LWR 4 (A7 locked), default path", argv)


if __name__ == "__main__":
    sys.exit(main())
