"""Figures of the experiments: stiffness ellipses of planar arms (seed 000 Fig. 2 CMS, Fig. 3 CDS),
the criteria landscape (Fig. 6), the seven-panel path figure (Fig. 4/5) and CSC's u / Frobenius
curves; plus the small pieces every experiment script shares (its ``--out`` parser, summary tables).
Matplotlib (Agg backend) is imported only inside these functions: the core library never imports
this module, and importing it pulls in numpy only.

Every figure function takes numbers computed by the library (stiffness matrices, criterion grids,
results), draws them with labelled axes and units, and writes the PNG atomically (a temporary file
in the same folder, then ``os.replace``), so a failed run never leaves a partial figure.

Example:
    >>> import numpy as np, jaxstiff
    >>> from jaxstiff import plots
    >>> pts = plots.ellipse_points(np.diag([5.0, 1.0]))  # (201, 2) N/m, semi-axes 5 along x, 1 along y
    >>> float(pts[:, 0].max()), float(pts[:, 1].max())
    (5.0, 1.0)
"""

from __future__ import annotations

import argparse
import csv
import os
from typing import Sequence

import numpy as np

from jaxstiff.runtime.io import atomic_write

__all__ = [
    "pyplot",
    "save_figure",
    "ellipse_points",
    "chain_points",
    "figure_cms",
    "figure_cds",
    "figure_criteria",
    "figure_u_frobenius",
    "figure_shape_path",
    "experiment_parser",
    "markdown_table",
    "text_table",
    "save_table_csv",
]


def pyplot():
    """``matplotlib.pyplot`` on the non-interactive Agg backend (matplotlib is imported on the first call).

    Example:
        >>> plt = plots.pyplot()
        >>> fig, ax = plt.subplots()
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def save_figure(fig, file: str | os.PathLike, dpi: int = 130, crop: bool = True) -> str:
    """Write ``fig`` as PNG to ``file`` atomically, then close it.

    The PNG goes to a temporary file in the target folder (created if missing) and is renamed onto
    ``file`` only once complete (:func:`jaxstiff._io.atomic_write`): if drawing fails, no partial
    or temporary file is left and an earlier ``file`` stays as it was. The figure is closed either way.

    Args:
        fig: a matplotlib Figure.
        file: the PNG to write.
        dpi: resolution, dots per inch (the PNG is ``figsize * dpi`` pixels when ``crop`` is False).
        crop: crop to the drawn content (``bbox_inches="tight"``); False keeps the figure's size.

    Returns:
        ``file`` as a string.
    """
    file = os.fspath(file)
    folder = os.path.dirname(os.path.abspath(file))
    os.makedirs(folder, exist_ok=True)
    extra = {"bbox_inches": "tight"} if crop else {}
    try:
        return atomic_write(file, lambda fh: fig.savefig(fh, dpi=dpi, format="png", **extra), binary=True)
    finally:
        pyplot().close(fig)


def ellipse_points(K, n: int = 201) -> np.ndarray:
    """Boundary of the stiffness ellipse of a 2x2 K: semi-axes ``lambda_i`` along ``v_i`` (S0-8).

    Args:
        K: (2, 2) symmetric positive definite, N/m.
        n: number of points.

    Returns:
        (n, 2) points in N/m, centred at 0 (closed: the last point equals the first).
    """
    K = np.asarray(K, dtype=float)
    if K.shape != (2, 2):
        raise ValueError(f"ellipse_points needs a 2x2 matrix, got shape {K.shape}")
    w, V = np.linalg.eigh(0.5 * (K + K.T))
    t = np.linspace(0.0, 2.0 * np.pi, n)
    return ((V * w) @ np.stack([np.cos(t), np.sin(t)])).T  # sum_i lambda_i v_i (cos t | sin t)


def chain_points(robot, q) -> np.ndarray:
    """Positions (n + 1, 3) of every joint origin and of the TCP in the base frame (numpy; for drawing)."""
    q = np.asarray(q, dtype=float)
    T = np.eye(4)
    pts = []
    for i in range(robot.n):
        T = T @ robot.origin_matrix(i)
        pts.append(T[:3, 3].copy())
        M = np.eye(4)
        axis = np.asarray(robot.axes[i], dtype=float)
        if robot.joint_types[i] == 1:  # prismatic
            M[:3, 3] = axis * q[i]
        else:
            a = axis / np.linalg.norm(axis)
            S = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
            M[:3, :3] = np.eye(3) + np.sin(q[i]) * S + (1 - np.cos(q[i])) * S @ S
        T = T @ M
    pts.append((T @ robot.tip_matrix)[:3, 3])
    return np.asarray(pts)


def _draw_arm(ax, robot, q, color, label=None, lw=3.0, annotate=False, kj=None):
    pts = chain_points(robot, q)
    ax.plot(pts[:, 0], pts[:, 1], "-", color=color, lw=lw, label=label, solid_capstyle="round")
    ax.plot(pts[:-1, 0], pts[:-1, 1], "o", color="white", mec=color, ms=7, mew=1.8)
    ax.plot(pts[-1, 0], pts[-1, 1], "o", color="tab:blue", ms=7)
    if annotate:
        for i in range(robot.n):
            txt = f"q{i + 1} = {np.degrees(q[i]):.2f}°"
            if kj is not None:
                txt += f"\nk_j{i + 1} = {kj[i]:g} Nm/rad"
            ax.annotate(txt, pts[i, :2], xytext=(10, -30 if i else 6), textcoords="offset points", fontsize=8, color="tab:red")
        ax.annotate("EE (TCP)", pts[-1, :2], xytext=(8, 6), textcoords="offset points", fontsize=8, color="tab:blue")
    return pts


def _style_ellipse_panel(ax, title: str) -> None:
    """Axes in N/m at equal scale, grid, legend to the right: the ellipse panel of Fig. 2 and Fig. 3."""
    ax.set(xlabel="stiffness along x (N/m)", ylabel="stiffness along y (N/m)", title=title)
    ax.set_aspect("equal")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, loc="center left", bbox_to_anchor=(1.01, 0.5))


def figure_cms(robot, q, kj0, ks: Sequence[float], K_list: Sequence, file, title: str | None = None) -> str:
    """Seed 000 Fig. 2: one planar posture, joint stiffnesses ``k * kj0``, the ellipses of ``K(k)``.

    Args:
        robot: a planar chain (drawn in its xy plane).
        q: (n,) posture, rad.
        kj0: (n,) base joint stiffnesses, Nm/rad.
        ks: CMS factors k.
        K_list: the 2x2 translational stiffness (N/m) for each k, same order.
        file: PNG to write.
    """
    plt = pyplot()
    fig, (ax0, ax1) = plt.subplots(1, 2, figsize=(12, 5.4), gridspec_kw={"width_ratios": [1, 1.15]})
    _draw_arm(ax0, robot, q, "black", annotate=True, kj=kj0)
    ax0.set(xlabel="x (m)", ylabel="y (m)", title="planar 3R arm, fixed posture; k_j = k · k_j0")
    ax0.set_aspect("equal")
    ax0.margins(0.18)
    ax0.grid(alpha=0.3)
    cmap = plt.get_cmap("viridis")
    kmin, kmax = min(ks), max(ks)
    for k, K in zip(ks, K_list):
        pts = ellipse_points(K)
        col = cmap((k - kmin) / max(kmax - kmin, 1e-12))
        ax1.plot(pts[:, 0], pts[:, 1], color=col, lw=1.8, label=f"k = {k:g}")
    # the common major axis
    w, V = np.linalg.eigh(np.asarray(K_list[-1]))
    v1 = V[:, -1] * w[-1] * 1.08
    ax1.plot([-v1[0], v1[0]], [-v1[1], v1[1]], "--", color="tab:red", lw=1, label="major axis (all k)")
    _style_ellipse_panel(ax1, "stiffness ellipses: CMS scales size only")
    fig.suptitle(title or "Seed 000 Fig. 2: common-mode stiffness (CMS)", fontsize=12)
    return save_figure(fig, file)


def figure_cds(robot, postures: Sequence, kj, K_list: Sequence, file, labels: Sequence[str] | None = None, title: str | None = None) -> str:
    """Seed 000 Fig. 3: several postures with the same TCP position and their stiffness ellipses.

    Args:
        robot: a planar chain.
        postures: list of (n,) postures, rad.
        kj: (n,) joint stiffnesses, Nm/rad (the same for every posture).
        K_list: 2x2 translational stiffness (N/m) per posture.
        file: PNG to write.
        labels: legend label per posture.
    """
    plt = pyplot()
    fig, (ax0, ax1) = plt.subplots(1, 2, figsize=(12.5, 5.6), gridspec_kw={"width_ratios": [1, 1.15]})
    colors = plt.get_cmap("tab10")(np.arange(len(postures)) % 10)
    labels = labels or [f"posture {i + 1}" for i in range(len(postures))]
    for q, col, lab, K in zip(postures, colors, labels, K_list):
        pts = _draw_arm(ax0, robot, q, col, label=lab, lw=2.4)
        e = ellipse_points(K)
        ax1.plot(e[:, 0], e[:, 1], color=col, lw=2.0, label=lab)
    ax0.plot(pts[-1, 0], pts[-1, 1], "*", color="tab:blue", ms=14, label="common TCP point", zorder=5)
    ax0.set(xlabel="x (m)", ylabel="y (m)", title=f"same TCP position, k_j = {', '.join(f'{v:g}' for v in kj)} Nm/rad")
    ax0.set_aspect("equal")
    ax0.margins(0.08)
    ax0.grid(alpha=0.3)
    ax0.legend(fontsize=8, loc="best")
    _style_ellipse_panel(ax1, "stiffness ellipses: CDS turns and reshapes them")
    fig.suptitle(title or "Seed 000 Fig. 3: configuration-dependent stiffness (CDS)", fontsize=12)
    return save_figure(fig, file)


def figure_criteria(alpha_deg, rho, F1, F2, r: float, c: float, file, title: str | None = None) -> str:
    """Seed 000 Fig. 6: f1 and f2 over orientation error x axis ratio, minimum sets in red.

    Args:
        alpha_deg: (A,) orientation errors, degrees.
        rho: (R,) axis ratios.
        F1, F2: (A, R) criterion values on the grid.
        r, c: the criteria's parameters (minimum sets: f1 at alpha = 0, rho >= r; f2 at (0, r)).
        file: PNG to write.
    """
    plt = pyplot()
    from matplotlib.colors import LogNorm

    A, P = np.meshgrid(alpha_deg, rho, indexing="ij")
    fig = plt.figure(figsize=(13, 10))
    gs = fig.add_gridspec(2, 2, height_ratios=[1.15, 1], hspace=0.25, wspace=0.15)
    specs = [("f1", F1, f"f1 = (|α| + c) / (min(ρ, r)/r),  r = {r:g}, c = {c:g}"), ("f2", F2, f"f2 = (1 + |α|)(1 + |r − ρ|),  r = {r:g}")]
    rho_line = rho[rho >= r]
    for col, (name, F, label) in enumerate(specs):
        ax = fig.add_subplot(gs[0, col], projection="3d")
        ax.plot_surface(A, P, F, cmap="viridis", norm=LogNorm(vmin=F.min(), vmax=F.max()), linewidth=0,
                        antialiased=True, alpha=0.85, rcount=A.shape[0], ccount=A.shape[1])
        if name == "f1":
            ax.plot(np.zeros_like(rho_line), rho_line, np.full_like(rho_line, c), color="red", lw=3, zorder=10,
                    label="minimum set: α = 0, ρ ≥ r")
        else:
            ax.scatter([0.0], [r], [1.0], color="red", s=70, depthshade=False, zorder=10, label="minimum: α = 0, ρ = r")
        ax.set_xticks([-90, -45, 0, 45, 90])
        ax.set_xlabel("orientation error α (deg)")
        ax.set_ylabel("axis ratio ρ = λ1/λ2")
        ax.set_zlabel(name)
        ax.set_title(label, fontsize=10)
        ax.view_init(elev=30, azim=-60)
        ax.legend(fontsize=8, loc="upper left")
        ax2 = fig.add_subplot(gs[1, col])
        pcm = ax2.pcolormesh(A, P, F, norm=LogNorm(vmin=F.min(), vmax=F.max()), cmap="viridis", shading="auto")
        levels = [v for v in (0.1, 1.5, 3, 10, 30, 100, 300) if F.min() < v < F.max()]
        cs = ax2.contour(A, P, F, levels=levels, colors="white", linewidths=0.7)
        ax2.clabel(cs, fmt="%g", fontsize=7)
        if name == "f1":
            ax2.plot(np.zeros_like(rho_line), rho_line, color="red", lw=4, label=f"minimum set (f1 = c = {c:g})")
        else:
            ax2.plot([0.0], [r], "o", color="red", ms=9, label="minimum (f2 = 1)")
        ax2.set(xlabel="orientation error α (deg)", ylabel="axis ratio ρ = λ1/λ2", title=f"{name} (colour: log scale, white: contours)")
        ax2.set_xticks([-90, -45, 0, 45, 90])
        ax2.legend(fontsize=8, loc="upper right")
        fig.colorbar(pcm, ax=ax2, label=name)
    fig.suptitle(title or "Seed 000 Fig. 6: criteria over orientation error × axis ratio", fontsize=12)
    return save_figure(fig, file)


def figure_u_frobenius(steps, u, frobenius, labels: Sequence[str], file, *, xlabel: str = "time step k",
                       titles: Sequence[str] = ("off-diagonal joint stiffness u (S1-19)", "Frobenius error of the realised stiffness"),
                       suptitle: str | None = None, figsize=(12, 4.5), dpi: int = 120) -> str:
    """CSC over time: u(q) (left) and ``|K_xd - K_C|_F`` (right), one curve per rollout.

    Args:
        steps: (T,) time steps k (x axis).
        u: (B, T) off-diagonal joint stiffness u (S1-19), Nm/rad, one row per rollout.
        frobenius: (B, T) Frobenius error of the realised stiffness (S1-10), N/m.
        labels: B legend labels.
        file: PNG to write (``figsize * dpi`` pixels, not cropped).
        xlabel: label of both x axes.
        titles: titles of the two panels.
        suptitle: title above both panels (none if None).

    Raises:
        ValueError: u and frobenius are not (B, T) with T = len(steps) and B = len(labels).
    """
    steps = np.asarray(steps)
    u = np.atleast_2d(np.asarray(u, dtype=float))
    frobenius = np.atleast_2d(np.asarray(frobenius, dtype=float))
    want = (len(labels), steps.shape[0])
    if u.shape != want or frobenius.shape != want:
        raise ValueError(f"figure_u_frobenius: u {u.shape} and frobenius {frobenius.shape} must both be "
                         f"(len(labels), len(steps)) = {want}")
    plt = pyplot()
    fig, ax = plt.subplots(1, 2, figsize=figsize)
    for ub, fb, lab in zip(u, frobenius, labels):
        ax[0].plot(steps, ub, label=lab)
        ax[1].plot(steps, fb, label=lab)
    ax[0].set(xlabel=xlabel, ylabel="u(q) [Nm/rad]", title=titles[0])
    ax[1].set(xlabel=xlabel, ylabel=r"$\|K_{xd} - K_C\|_F$ [N/m]", title=titles[1])
    for a in ax:
        a.grid(alpha=0.3)
        a.legend(fontsize=8)
    if suptitle:
        fig.suptitle(suptitle)
    fig.tight_layout()
    return save_figure(fig, file, dpi=dpi, crop=False)


def _stiffness_axes(robot, q, kj_scaled, task="full"):
    """Eigenvalues (descending, N/m) and eigenvectors (columns) of K_T at each waypoint, (P, 3), (P, 3, 3)."""
    from jaxstiff.model.kinematics import jacobian
    from jaxstiff.stiffness.core import translational_stiffness

    J = jacobian(robot, np.asarray(q))
    K = np.asarray(translational_stiffness(J, np.asarray(kj_scaled), task=task))
    w, V = np.linalg.eigh(K)
    return w[:, ::-1], V[:, :, ::-1]


def figure_shape_path(res, robot, file, title: str, every: int = 5, b: int = 0, dpi: int = 110) -> str:
    """Seed 000 Fig. 4/5: the seven panels (a)-(g) of one path of a shaping result.

    (a) joint stiffness kj (Nm/rad), (b) joint positions (deg), (c) the criterion's distance to its
    minimum (log scale), (d) orientation error alpha (deg) and axis ratio, (e) CMS factor, (f) the
    path (m) with the CMS-scaled 3-D stiffness ellipsoids every ``2 * every`` waypoints, (g) their
    outlines projected on the xy plane every ``every`` waypoints.

    Args:
        res: a :class:`jaxstiff.results.ShapeResult` of a task with a 3x3 K_T ("full" or "xyz").
        robot: the robot it was computed for.
        file: PNG to write (cropped to the drawing).
        title: figure title.
        every: waypoint spacing of the drawn ellipses.
        b: which path of the batch.
    """
    plt = pyplot()
    from matplotlib.ticker import MaxNLocator

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

    lam, V = _stiffness_axes(robot, res.q[b], res.kj_scaled[b], res.meta["task"])
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
    return save_figure(fig, file, dpi=dpi)


def experiment_parser(name: str, description: str) -> argparse.ArgumentParser:
    """The command line of an experiment script ``experiments/NAME.py``, with its ``--out DIR`` option.

    ``--out`` defaults to ``out/NAME`` (the contract of ``jaxstiff reproduce``: every experiment takes
    ``--out DIR``). The description is shown as written (line breaks kept).

    Example:
        >>> ap = plots.experiment_parser("fig2_cms", "Seed 000 Fig. 2")
        >>> ap.parse_args([]).out
        'out/fig2_cms'
    """
    ap = argparse.ArgumentParser(description=description, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", default=os.path.join("out", name), help=f"output folder (default {os.path.join('out', name)})")
    return ap


def markdown_table(rows: Sequence[dict]) -> list[str]:
    """Lines of a Markdown table of ``rows`` (dicts of strings with the same keys; the header is the first row's keys).


    Example:
        >>> plots.markdown_table([{"k": "1", "ratio": "2.5"}])
        ['| k | ratio |', '|---|---|', '| 1 | 2.5 |']

    Raises:
        ValueError: no rows.
    """
    if not rows:
        raise ValueError("markdown_table: no rows")
    header = list(rows[0])
    return ["| " + " | ".join(header) + " |", "|" + "---|" * len(header),
            *("| " + " | ".join(row[h] for h in header) + " |" for row in rows)]


def text_table(rows: Sequence[dict], width: int, sep: str = " ") -> list[str]:
    """Lines of a plain-text table of ``rows`` (dicts of strings): the header, then one line a row,
    every cell right-aligned in ``width`` characters, cells joined by ``sep``.

    Example:
        >>> plots.text_table([{"k": "1", "ratio": "2.5"}], width=6)
        ['     k  ratio', '     1    2.5']

    Raises:
        ValueError: no rows.
    """
    if not rows:
        raise ValueError("text_table: no rows")
    header = list(rows[0])
    return [sep.join(f"{h:>{width}s}" for h in header), *(sep.join(f"{row[h]:>{width}s}" for h in header) for row in rows)]


def save_table_csv(rows: Sequence[dict], file: str | os.PathLike) -> str:
    """Write ``rows`` (dicts with the same keys) as CSV with a header line to ``file``, atomically.

    Raises:
        ValueError: no rows.
        FileNotFoundError: the target folder does not exist.
    """
    if not rows:
        raise ValueError(f"save_table_csv: no rows to write to {os.fspath(file)}")

    def write(fh):
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)

    return atomic_write(file, write)
