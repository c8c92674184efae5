"""Figures of planar arms and of the criteria: seed 000 Fig. 2 (CMS), Fig. 3 (CDS), Fig. 6 (criteria
landscape), and CSC's u / Frobenius curves over time."""

from __future__ import annotations

import os
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike

from jaxstiff.plots._base import draw_arm, ellipse_points, pyplot, save_figure, style_ellipse_panel

if TYPE_CHECKING:
    from jaxstiff.model._chain import Chain

__all__ = ["figure_cms", "figure_cds", "figure_criteria", "figure_u_frobenius"]


def figure_cms(
    robot: Chain,
    q: Sequence[float] | np.ndarray,
    kj0: Sequence[float] | np.ndarray,
    ks: Sequence[float],
    K_list: Sequence[ArrayLike],
    file: str | os.PathLike,
    title: str | None = None,
) -> str:
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
    draw_arm(ax0, robot, q, "black", annotate=True, kj=kj0)
    ax0.set(xlabel="x (m)", ylabel="y (m)", title="planar 3R arm, fixed posture; k_j = k · k_j0")
    ax0.set_aspect("equal")
    ax0.margins(0.18)
    ax0.grid(alpha=0.3)
    cmap = plt.get_cmap("viridis")
    kmin, kmax = min(ks), max(ks)
    for k, K in zip(ks, K_list, strict=False):
        pts = ellipse_points(K)
        col = cmap((k - kmin) / max(kmax - kmin, 1e-12))
        ax1.plot(pts[:, 0], pts[:, 1], color=col, lw=1.8, label=f"k = {k:g}")
    # the common major axis
    w, V = np.linalg.eigh(np.asarray(K_list[-1]))
    v1 = V[:, -1] * w[-1] * 1.08
    ax1.plot([-v1[0], v1[0]], [-v1[1], v1[1]], "--", color="tab:red", lw=1, label="major axis (all k)")
    style_ellipse_panel(ax1, "stiffness ellipses: CMS scales size only")
    fig.suptitle(title or "Seed 000 Fig. 2: common-mode stiffness (CMS)", fontsize=12)
    return save_figure(fig, file)


def figure_cds(
    robot: Chain,
    postures: Sequence[Sequence[float] | np.ndarray],
    kj: Sequence[float] | np.ndarray,
    K_list: Sequence[ArrayLike],
    file: str | os.PathLike,
    labels: Sequence[str] | None = None,
    title: str | None = None,
) -> str:
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
    for q, col, lab, K in zip(postures, colors, labels, K_list, strict=False):
        pts = draw_arm(ax0, robot, q, col, label=lab, lw=2.4)
        e = ellipse_points(K)
        ax1.plot(e[:, 0], e[:, 1], color=col, lw=2.0, label=lab)
    ax0.plot(pts[-1, 0], pts[-1, 1], "*", color="tab:blue", ms=14, label="common TCP point", zorder=5)
    ax0.set(xlabel="x (m)", ylabel="y (m)", title=f"same TCP position, k_j = {', '.join(f'{v:g}' for v in kj)} Nm/rad")
    ax0.set_aspect("equal")
    ax0.margins(0.08)
    ax0.grid(alpha=0.3)
    ax0.legend(fontsize=8, loc="best")
    style_ellipse_panel(ax1, "stiffness ellipses: CDS turns and reshapes them")
    fig.suptitle(title or "Seed 000 Fig. 3: configuration-dependent stiffness (CDS)", fontsize=12)
    return save_figure(fig, file)


def _criterion_surface(
    ax: Any,
    A: np.ndarray,
    P: np.ndarray,
    F: np.ndarray,
    name: str,
    label: str,
    rho_line: np.ndarray,
    r: float,
    c: float,
) -> None:
    """Top panel of :func:`figure_criteria`: the criterion as a 3-D surface (log colour), minimum set in red."""
    from matplotlib.colors import LogNorm

    # drawn in call order, the minimum on top: sorted by depth, matplotlib put the semi-transparent
    # surface over f2's dot and f1's line although no part of the surface is in front of them (the
    # views below are chosen so; tests/figures/test_figure_layout.py checks f1's line)
    ax.computed_zorder = False
    ax.plot_surface(
        A,
        P,
        F,
        cmap="viridis",
        norm=LogNorm(vmin=F.min(), vmax=F.max()),
        linewidth=0,
        antialiased=True,
        alpha=0.85,
        rcount=A.shape[0],
        ccount=A.shape[1],
    )
    if name == "f1":
        ax.plot(
            np.zeros_like(rho_line),
            rho_line,
            np.full_like(rho_line, c),
            color="red",
            lw=3,
            zorder=10,
            label="minimum set: α = 0, ρ ≥ r",
        )
    else:
        ax.scatter(
            [0.0],
            [r],
            [1.0],
            color="red",
            s=70,
            depthshade=False,
            zorder=10,  # pyright: ignore[reportArgumentType]
            label="minimum: α = 0, ρ = r",
        )  # (Axes3D.scatter takes zs; the 2-D stubs do not)
    ax.set_xticks([-90, -45, 0, 45, 90])
    ax.set_xlabel("orientation error α (deg)")
    ax.set_ylabel("axis ratio ρ = λ1/λ2")
    ax.set_zlabel(name)
    ax.set_title(label, fontsize=10)
    # f1's minimum set lies along the floor of a valley, f2's at the bottom of a funnel: seen from
    # azim -60, the near wall hid f1's red line (85 of 101 points) and f2's dot, drawn over it anyway;
    # seen along the valley (azim -105), nothing is in front of either, and both panels share the view
    ax.view_init(elev=30, azim=-105)
    ax.legend(fontsize=8, loc="upper left")


def _staggered_label_points(
    A: np.ndarray, P: np.ndarray, F: np.ndarray, levels: Sequence[float], ok: Any = None
) -> list[tuple[float, tuple[float, float]]]:
    """``[(level, (alpha, rho))]``: a point on each contour level, at alpha >= 0, the levels from low
    to high at rho rising evenly from the bottom of the map to its top (``A``, ``P``, ``F``: the
    (alpha, rho) grids and values, alpha along axis 0); a level that does not cross alpha >= 0 at its
    height takes the nearest height where it does, one that crosses nowhere gets no label.
    ``ok(alpha, rho)``: False for a point where no label may go (default: anywhere)."""
    alpha, rho = A[:, 0], P[0, :]
    right = alpha >= 0
    lo, hi = rho[0] + 0.06 * (rho[-1] - rho[0]), rho[-1] - 0.06 * (rho[-1] - rho[0])
    targets = np.linspace(lo, hi, max(len(levels), 1))
    out = []
    for level, target in zip(sorted(levels), targets, strict=False):
        for j in np.argsort(np.abs(rho - target)):
            f = F[right, j]  # rises with |alpha| at a fixed rho (both criteria)
            if f.min() <= level <= f.max():
                x = float(np.interp(level, f, alpha[right]))
                if ok is None or ok(x, float(rho[j])):
                    out.append((float(level), (x, float(rho[j]))))
                    break
    return out


def _criterion_map(
    fig: Any, ax2: Any, A: np.ndarray, P: np.ndarray, F: np.ndarray, name: str, rho_line: np.ndarray, r: float, c: float
) -> None:
    """Bottom panel of :func:`figure_criteria`: the criterion as a colour map with contours and its colour bar."""
    from matplotlib.colors import LogNorm

    # gouraud: colours interpolated between the grid's nodes (flat cells showed the 1-deg grid as
    # bands on the logarithmic alpha axis below)
    pcm = ax2.pcolormesh(A, P, F, norm=LogNorm(vmin=F.min(), vmax=F.max()), cmap="viridis", shading="gouraud")
    levels = [v for v in (0.1, 1.5, 3, 10, 30, 100, 300) if F.min() < v < F.max()]
    cs = ax2.contour(A, P, F, levels=levels, colors="white", linewidths=0.7)
    # symlog: linear within 1 deg of 0, logarithmic beyond: the contours that crowd alpha = 0 on a
    # linear axis (0.1 to 10 within 10 deg of 180) spread across the map and their labels read
    ax2.set_xscale("symlog", linthresh=1.0, linscale=0.6)
    ax2.set_xlim(A.min(), A.max())
    ticks = [t for t in (-90, -30, -10, -3, -1, 0, 1, 3, 10, 30, 90) if A.min() <= t <= A.max()]
    ax2.set_xticks(ticks, [f"{t:g}" for t in ticks])

    dot = ax2.transData.transform((0.0, r))  # the minimum's marker (f2) or the red line's end (f1)

    def inside(x: float, y: float) -> bool:  # away from the edges (a label there was cut in half) and the dot
        px = ax2.transData.transform((x, y))
        fx, fy = ax2.transAxes.inverted().transform(px)
        return bool(fx < 0.88 and 0.05 < fy < 0.95 and np.hypot(*(px - dot)) > 0.06 * ax2.bbox.height)

    # one label a level, each at its own height: placed by matplotlib, the labels of the levels that
    # crowd alpha = 0 lay on top of each other
    for level, point in _staggered_label_points(A, P, F, levels, inside):
        ax2.clabel(cs, levels=[level], fmt="%g", fontsize=7, manual=[point])
    if name == "f1":
        ax2.plot(np.zeros_like(rho_line), rho_line, color="red", lw=4, label=f"minimum set (f1 = c = {c:g})")
    else:
        ax2.plot([0.0], [r], "o", color="red", ms=9, label="minimum (f2 = 1)")
    ax2.set(
        xlabel="orientation error α (deg)",
        ylabel="axis ratio ρ = λ1/λ2",
        title=f"{name} (colour: log scale, white: contours)",
    )
    ax2.set_xlabel("orientation error α (deg; linear within ±1, logarithmic beyond)")
    ax2.legend(fontsize=8, loc="upper left")  # upper right: it covered the top of f1's red line
    fig.colorbar(pcm, ax=ax2, label=name)


def figure_criteria(
    alpha_deg: np.ndarray,
    rho: np.ndarray,
    F1: np.ndarray,
    F2: np.ndarray,
    r: float,
    c: float,
    file: str | os.PathLike,
    title: str | None = None,
) -> str:
    """Seed 000 Fig. 6: f1 and f2 over orientation error x axis ratio, minimum sets in red.

    Args:
        alpha_deg: (A,) orientation errors, degrees.
        rho: (R,) axis ratios.
        F1, F2: (A, R) criterion values on the grid.
        r, c: the criteria's parameters (minimum sets: f1 at alpha = 0, rho >= r; f2 at (0, r)).
        file: PNG to write.
    """
    plt = pyplot()
    A, P = np.meshgrid(alpha_deg, rho, indexing="ij")
    fig = plt.figure(figsize=(13, 10))
    # top: the panels right under the title (the default left an empty band)
    gs = fig.add_gridspec(2, 2, height_ratios=[1.15, 1], hspace=0.2, wspace=0.15, top=0.93, bottom=0.06)
    specs = [
        ("f1", F1, f"f1 = (|α| + c) / (min(ρ, r)/r),  r = {r:g}, c = {c:g}"),
        ("f2", F2, f"f2 = (1 + |α|)(1 + |r − ρ|),  r = {r:g}"),
    ]
    rho_line = rho[rho >= r]
    for col, (name, F, label) in enumerate(specs):
        _criterion_surface(fig.add_subplot(gs[0, col], projection="3d"), A, P, F, name, label, rho_line, r, c)
        _criterion_map(fig, fig.add_subplot(gs[1, col]), A, P, F, name, rho_line, r, c)
    fig.suptitle(title or "Seed 000 Fig. 6: criteria over orientation error × axis ratio", fontsize=12, y=0.985)
    return save_figure(fig, file)


def figure_u_frobenius(  # noqa: PLR0913 - the data, then keyword-only figure options
    steps: ArrayLike,
    u: ArrayLike,
    frobenius: ArrayLike,
    labels: Sequence[str],
    file: str | os.PathLike,
    *,
    xlabel: str = "time step k",
    titles: Sequence[str] = ("off-diagonal joint stiffness u (S1-19)", "Frobenius error of the realised stiffness"),
    suptitle: str | None = None,
    figsize: tuple[float, float] = (12, 4.5),
    dpi: int = 120,
    limit_steps: ArrayLike | None = None,
) -> str:
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
        limit_steps: (B, T) bool, the steps where a joint was clamped at its limit (a csc file's
            ``status`` bit 2): marked on both curves, so that a kink there is explained.

    Raises:
        ValueError: u, frobenius (and limit_steps) are not (B, T) with T = len(steps) and B = len(labels).
    """
    steps = np.asarray(steps)
    u = np.atleast_2d(np.asarray(u, dtype=float))
    frobenius = np.atleast_2d(np.asarray(frobenius, dtype=float))
    want = (len(labels), steps.shape[0])
    if u.shape != want or frobenius.shape != want:
        raise ValueError(
            f"figure_u_frobenius: u {u.shape} and frobenius {frobenius.shape} must both be "
            f"(len(labels), len(steps)) = {want}"
        )
    marks = np.zeros(want, bool) if limit_steps is None else np.atleast_2d(np.asarray(limit_steps, dtype=bool))
    if marks.shape != want:
        raise ValueError(f"figure_u_frobenius: limit_steps {marks.shape} must be (len(labels), len(steps)) = {want}")
    plt = pyplot()
    fig, ax = plt.subplots(1, 2, figsize=figsize)
    for i, (ub, fb, lab) in enumerate(zip(u, frobenius, labels, strict=False)):
        for a, y in ((ax[0], ub), (ax[1], fb)):
            (line,) = a.plot(steps, y, label=lab)
            if marks[i].any():
                a.plot(
                    steps[marks[i]],
                    y[marks[i]],
                    "x",
                    color=line.get_color(),
                    markersize=6,
                    label=f"{lab}: joint at its limit ({int(marks[i].sum())} steps)",
                )
    ax[0].set(xlabel=xlabel, ylabel="u(q) [Nm/rad]", title=titles[0])
    ax[1].set(xlabel=xlabel, ylabel=r"$\|K_{xd} - K_C\|_F$ [N/m]", title=titles[1])
    for a in ax:
        a.grid(alpha=0.3)
        a.legend(fontsize=8)
    if suptitle:
        fig.suptitle(suptitle)
    fig.tight_layout()
    return save_figure(fig, file, dpi=dpi, crop=False)
