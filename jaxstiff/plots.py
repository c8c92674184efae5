"""Figures of seed 000: stiffness ellipses of planar arms (Fig. 2 CMS, Fig. 3 CDS) and the criteria
landscape (Fig. 6). Matplotlib (Agg backend) is imported only inside these functions: the core
library never imports this module.

Every function takes numbers computed by the library (stiffness matrices, criterion grids), draws
them with labelled axes and units, and writes the PNG atomically (a temporary file in the same
folder, then ``os.replace``), so a failed run never leaves a partial figure.

Example:
    >>> import numpy as np, jaxstiff
    >>> from jaxstiff import plots
    >>> pts = plots.ellipse_points(np.diag([5.0, 1.0]))  # (201, 2) N/m, semi-axes 5 along x, 1 along y
    >>> float(pts[:, 0].max()), float(pts[:, 1].max())
    (5.0, 1.0)
"""

from __future__ import annotations

import os
from typing import Sequence

import numpy as np

from ._io import atomic_write

__all__ = [
    "ellipse_points",
    "chain_points",
    "save_figure",
    "figure_cms",
    "figure_cds",
    "figure_criteria",
]


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def save_figure(fig, file: str | os.PathLike, dpi: int = 130) -> str:
    """Write ``fig`` as PNG to ``file`` atomically (temp file in the same folder, then ``os.replace``)."""
    file = os.fspath(file)
    folder = os.path.dirname(os.path.abspath(file))
    os.makedirs(folder, exist_ok=True)
    try:
        return atomic_write(file, lambda fh: fig.savefig(fh, dpi=dpi, format="png", bbox_inches="tight"), binary=True)
    finally:
        _pyplot().close(fig)


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
    plt = _pyplot()
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
    ax1.set(xlabel="stiffness along x (N/m)", ylabel="stiffness along y (N/m)", title="stiffness ellipses: CMS scales size only")
    ax1.set_aspect("equal")
    ax1.grid(alpha=0.3)
    ax1.legend(fontsize=8, loc="center left", bbox_to_anchor=(1.01, 0.5))
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
    plt = _pyplot()
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
    ax1.set(xlabel="stiffness along x (N/m)", ylabel="stiffness along y (N/m)", title="stiffness ellipses: CDS turns and reshapes them")
    ax1.set_aspect("equal")
    ax1.grid(alpha=0.3)
    ax1.legend(fontsize=8, loc="center left", bbox_to_anchor=(1.01, 0.5))
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
    plt = _pyplot()
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
