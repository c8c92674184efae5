"""The seven panels of seed 000 Fig. 4/5 (a)-(g) of one path of a shaping result; alpha and rho along
the path against the turning rate of its tangent (:func:`figure_turning`)."""

from __future__ import annotations

import os
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from jaxstiff.plots._base import draw_scale_bar, nice_value, pyplot, save_figure
from jaxstiff.results._status import is_usable

if TYPE_CHECKING:
    from jaxstiff.model._chain import Chain
    from jaxstiff.results._files import ShapeResult

__all__ = ["stiffness_axes", "figure_shape_path", "rate_limited_joints", "figure_turning", "usable_only"]


def stiffness_axes(
    robot: Chain, q: np.ndarray, kj_scaled: np.ndarray, task: str = "full"
) -> tuple[np.ndarray, np.ndarray]:
    """Axes of the translational stiffness ellipsoid ``K_T`` (SPEC section 2) at each waypoint.

    Args:
        robot: the chain.
        q: (P, n) joint values, rad (m for prismatic joints).
        kj_scaled: (P, n) joint stiffnesses (after CMS), Nm/rad (N/m for prismatic joints).
        task: ``"full"`` or ``"xyz"`` (a 3x3 ``K_T``).

    Returns:
        Eigenvalues (P, 3) in N/m, descending, and eigenvectors (P, 3, 3) as columns, base frame.
    """
    from jaxstiff.model._kinematics import jacobian
    from jaxstiff.stiffness._core import translational_stiffness

    J = jacobian(robot, np.asarray(q))
    K = np.asarray(translational_stiffness(J, np.asarray(kj_scaled), task=task))
    w, V = np.linalg.eigh(K)
    return w[:, ::-1], V[:, :, ::-1]


def _prismatic(robot: Any, n: int) -> np.ndarray:
    """(n,) bool: which actuated joints are prismatic (values in m, stiffness in N/m); from the
    robot (:attr:`jaxstiff.model._chain.Chain.prismatic`), all revolute for a look-alike without it."""
    pris = getattr(robot, "prismatic", None)
    if pris is None:
        return np.zeros(n, bool)
    pris = np.asarray(pris, dtype=bool)
    if pris.shape != (n,):
        raise ValueError(
            f"the robot has {pris.size} actuated joints, the result {n}: not the robot it was computed for"
        )
    return pris


def _panel_joints(
    ax: Any,
    wp: np.ndarray,
    values: np.ndarray,
    res: ShapeResult,
    colors: Any,
    ylabel: str,
    title: str,
    suffix: Sequence[str] | None = None,
    right: tuple[np.ndarray, str] | None = None,
) -> tuple[list[Any], list[str]]:
    """(a)/(b): one curve a joint over the waypoints, legend below. A joint whose values are all
    ``+inf`` (a rigid locked joint's kj, SPEC section 1) has no curve; its legend entry says "rigid".
    A value with no finite neighbour (a usable waypoint between unusable ones, left out as NaN) is
    drawn as a marker: a line through one point draws nothing.

    ``suffix``: per joint, text added to its legend entry (a unit); ``right``: ``(mask, ylabel)``,
    the joints in ``mask`` drawn on a twin axis on the right with that label (another unit).

    Returns:
        The legend's handles and labels, in chain order (:func:`_fit_joint_legends` places it for good).
    """
    ax_r = ax.twinx() if right is not None and right[0].any() else None
    handles = []
    for i in range(res.n):
        rigid = bool(np.all(np.isposinf(values[:, i])))
        label = f"{res.joint_names[i]} (rigid)" if rigid else str(res.joint_names[i])  # kj = inf: no curve
        if suffix is not None and suffix[i]:
            label = f"{label} {suffix[i]}"
        target = ax_r if ax_r is not None and right[0][i] else ax  # type: ignore[index]
        y = np.where(np.isfinite(values[:, i]), values[:, i], np.nan)
        handles += target.plot(wp, y, color=colors[i], label=label)
        alone = _isolated(y)
        if alone.any():  # no line segment reaches these points: a marker each, not in the legend
            target.plot(wp[alone], y[alone], "o", color=colors[i], ms=4, label="_nolegend_")
    ax.set(xlabel="waypoint p", ylabel=ylabel, title=title)
    if ax_r is not None:
        ax_r.set_ylabel(right[1])  # type: ignore[index]
    labels = [str(h.get_label()) for h in handles]  # both axes' curves, in chain order
    ax.legend(handles, labels, fontsize=7, ncol=_legend_columns(labels), loc="upper center", bbox_to_anchor=(0.5, -0.2))
    ax.grid(alpha=0.3)
    return handles, labels


def _isolated(y: np.ndarray) -> np.ndarray:
    """(P,) bool: the finite entries of ``y`` whose neighbours (before and after) are both NaN or
    missing, which a line alone does not show."""
    fin = np.isfinite(y)
    before = np.r_[False, fin[:-1]]
    after = np.r_[fin[1:], False]
    return fin & ~before & ~after


def _waypoint_limits(P: int) -> tuple[float, float]:
    """x limits of a panel over the waypoints: the whole path 0..P-1 with matplotlib's 5 % margins
    (what the autoscale gives a path without gaps), also where only some waypoints are usable (one
    usable waypoint was drawn on an axis of -0.04..0.04)."""
    if P < 2:
        return -0.5, 0.5
    pad = 0.05 * (P - 1)
    return -pad, P - 1 + pad


def _legend_columns(labels: Sequence[str], width_chars: int = 55) -> int:
    """Columns (1-4) of a legend under a joint panel that keep it within the panel's width, about
    ``width_chars`` characters of the 7-pt legend font: matplotlib fills the columns top to bottom,
    each as wide as its longest entry plus a handle (about 6). Four columns of a UR10's names
    ("shoulder_lift_joint") ran into the next panel's legend."""
    for ncol in (4, 3, 2):
        rows = -(-len(labels) // ncol)
        cols = [labels[c * rows : (c + 1) * rows] for c in range(ncol)]
        if sum(max((len(t) for t in col), default=0) + 6 for col in cols if col) <= width_chars:
            return ncol
    return 1


def _joint_panels(
    fig: Any, gs: Any, wp: np.ndarray, res: ShapeResult, b: int, colors: Any, pris: np.ndarray
) -> list[tuple[Any, list[Any], list[str]]]:
    """(a) joint stiffness, (b) joint positions: revolute joints in Nm/rad and deg, prismatic
    joints in N/m and mm ((b): on a right axis when the robot has both kinds). Returns each panel
    with its legend's handles and labels."""
    ax_a, ax_b = fig.add_subplot(gs[0, 0:2]), fig.add_subplot(gs[0, 2:4])
    title_a, title_b = "(a) joint stiffness (before CMS)", "(b) joint positions"
    if not pris.any():
        leg_a = _panel_joints(ax_a, wp, res.kj[b], res, colors, "joint stiffness k_j (Nm/rad)", title_a)
        leg_b = _panel_joints(ax_b, wp, np.degrees(res.q[b]), res, colors, "joint position q (deg)", title_b)
        return [(ax_a, *leg_a), (ax_b, *leg_b)]
    q_shown = np.where(pris, 1e3 * res.q[b], np.degrees(res.q[b]))  # mm for prismatic joints, deg otherwise
    if pris.all():
        leg_a = _panel_joints(ax_a, wp, res.kj[b], res, colors, "joint stiffness k_j (N/m)", title_a)
        leg_b = _panel_joints(ax_b, wp, q_shown, res, colors, "joint position q (mm)", title_b)
        return [(ax_a, *leg_a), (ax_b, *leg_b)]
    leg_a = _panel_joints(
        ax_a,
        wp,
        res.kj[b],
        res,
        colors,
        "joint stiffness k_j (Nm/rad)\n(N/m for prismatic joints)",
        title_a,
        suffix=["(prismatic, N/m)" if p else "" for p in pris],
    )
    leg_b = _panel_joints(
        ax_b,
        wp,
        q_shown,
        res,
        colors,
        "revolute joint position q (deg)",
        title_b,
        suffix=["(prismatic, mm, right axis)" if p else "" for p in pris],
        right=(pris, "prismatic joint q (mm)"),
    )
    return [(ax_a, *leg_a), (ax_b, *leg_b)]


def _panel_criterion(ax: Any, wp: np.ndarray, res: ShapeResult, b: int) -> None:
    """(c): the criterion's distance to its lowest possible value, log scale."""
    crit = res.meta["criterion"]
    fmin = float(res.meta["c"]) if crit == "f1" else 1.0 if crit == "f2" else None  # meta["c"]: f1's only
    if fmin is not None:  # distance to the criterion's lowest possible value, log scale
        ax.plot(wp, np.maximum(res.criterion[b] - fmin, 1e-12), "k.-", label=f"{crit} - {fmin:g}")
        ax.set(ylabel=f"{crit} - min {crit} (-)")
    else:
        ax.plot(wp, res.criterion[b], "k.-", label=crit)
        ax.set(ylabel=f"{crit} (-)")
    ax.set(
        xlabel="waypoint p",
        title=f"(c) criterion {crit} (its minimum is {fmin:g})" if fmin else f"(c) criterion {crit}",
    )
    ax.set_yscale("log")
    ax.legend(fontsize=8, loc="best")
    ax.grid(alpha=0.3, which="both")


def _panel_alpha_ratio(ax: Any, wp: np.ndarray, res: ShapeResult, b: int, r: float) -> None:
    """(d): orientation error alpha (deg, left axis) and axis ratio rho (right axis)."""
    ax.plot(wp, res.alpha_deg[b], "C3.-", label="orientation error alpha")
    ax.axhline(1.0, color="C3", ls=":", lw=1, label="1 deg")
    ax.set(xlabel="waypoint p", ylabel="alpha (deg)", title="(d) orientation error and axis ratio")
    # nanmax: an unusable waypoint is NaN, and max(1.5, nan) kept 1.5 over any usable alpha
    ax.set_ylim(bottom=0, top=max(1.5, 1.1 * float(np.nanmax(res.alpha_deg[b]))))
    ax2 = ax.twinx()
    ax2.plot(wp, res.ratio[b], "C0.-", label="axis ratio rho = lambda1/lambda2")
    ax2.axhline(r, color="C0", ls=":", lw=1, label=f"r = {r:g}")
    ax2.set_ylabel("axis ratio rho (-)")
    ax2.set_ylim(0, max(2 * r, 1.1 * float(np.nanmax(res.ratio[b]))))
    h1, l1 = ax.get_legend_handles_labels()
    h2, l2 = ax2.get_legend_handles_labels()
    ax.legend(h1 + h2, l1 + l2, fontsize=8, ncol=4, loc="upper center", bbox_to_anchor=(0.5, -0.2))
    ax.grid(alpha=0.3)


def _panel_cms(ax: Any, wp: np.ndarray, res: ShapeResult, b: int) -> None:
    """(e): the CMS factor k per waypoint."""
    ax.plot(wp, res.cms[b], "C2.-")
    ax.set(
        xlabel="waypoint p",
        ylabel="CMS factor k (-)",
        title="(e) common-mode stiffness: kj_scaled = k kj (equal ellipsoid volume)",
    )
    ax.grid(alpha=0.3)


def _scale_text(n_per_m: float) -> str:
    """'1 cm on the plot = X N/m' for ellipses drawn at ``n_per_m`` (N/m of stiffness per m of drawing)."""
    return f"ellipse semi-axes: 1 cm of the plot's axes = {0.01 * n_per_m:.4g} N/m"


def _widened_box(lo: np.ndarray, hi: np.ndarray, share: float = 0.35) -> tuple[np.ndarray, np.ndarray]:
    """The 3-D box ``lo``..``hi`` (m) widened about its centre so that no side is shorter than
    ``share`` of the longest: equal scale stays, and a flat box (the default path: 0.1 m in z
    against 0.55 m in y) no longer piles its tick labels on each other."""
    span = np.maximum(hi - lo, share * float(np.max(hi - lo)))
    mid = 0.5 * (lo + hi)
    return mid - 0.5 * span, mid + 0.5 * span


def _panel_ellipsoids_3d(
    ax: Any, res: ShapeResult, b: int, unit: np.ndarray, V: np.ndarray, idx3: np.ndarray, size: float, n_per_m: float
) -> None:
    """(f): the path (m) with the CMS-scaled 3-D ellipsoids at waypoints ``idx3``, equal axes; the
    stiffest semi-axis drawn ``size`` m long, i.e. ``n_per_m`` N/m per metre of the plot (in the
    title; the same scale as (g)). The box is widened where it is flat, with three to five ticks an
    axis, their labels and the axis names set off from the box."""
    from matplotlib.ticker import MaxNLocator

    pts = res.target[b]
    # drawn in call order (path, then ellipsoids, then tangents): sorted by depth, the path, which
    # runs along every major axis, was drawn over the ellipsoids and hid them
    ax.computed_zorder = False
    ax.plot(*pts.T, "-", color="0.35", lw=1, label="path")
    u, v = np.meshgrid(np.linspace(0, 2 * np.pi, 24), np.linspace(0, np.pi, 12))
    sphere = np.stack([np.cos(u) * np.sin(v), np.sin(u) * np.sin(v), np.cos(v)], axis=-1)
    for k in idx3:
        E = sphere * (unit[k] * size) @ V[k].T + pts[k]
        ax.plot_surface(E[..., 0], E[..., 1], E[..., 2], color="C1", alpha=0.85, linewidth=0, shade=True)
    for k in idx3:
        ax.quiver(*pts[k], *(0.6 * size * res.direction[b, k]), color="C0", lw=1)
    ax.set_title(f"(f) path and 3-D stiffness ellipsoids (CMS-scaled)\n{_scale_text(n_per_m)}")
    ax.set_xlabel("x (m)", labelpad=6)
    ax.set_ylabel("y (m)", labelpad=6)
    ax.zaxis.set_rotate_label(False)  # upright: seen from azimuths > 0 matplotlib turned it upside down
    ax.set_zlabel("z (m)", labelpad=4, rotation=90)
    reach = 1.05 * size * float(np.nanmax(unit[idx3, 0], initial=1.0))  # the longest drawn semi-axis, m
    lo, hi = _widened_box(np.nanmin(pts, 0) - reach, np.nanmax(pts, 0) + reach)
    ax.set_xlim(lo[0], hi[0])
    ax.set_ylim(lo[1], hi[1])
    ax.set_zlim(lo[2], hi[2])
    ax.set_box_aspect(tuple(hi - lo), zoom=1.1)  # equal scale on all three axes
    ax.view_init(elev=30, azim=_azimuth(pts))
    longest = float(np.max(hi - lo))
    for axis, side in zip((ax.xaxis, ax.yaxis, ax.zaxis), hi - lo, strict=True):
        axis.set_major_locator(MaxNLocator(int(np.clip(round(5 * side / longest), 3, 5))))
    ax.tick_params(axis="both", labelsize=8, pad=1)


def _azimuth(pts: np.ndarray) -> float:
    """A view azimuth (deg) that shows the path's longest horizontal extent across the panel, seen
    25 deg off broadside: -55 for a path along x (matplotlib's usual view), -25 along y (the
    default path, which -55 foreshortened into the box's corner)."""
    xy = pts[np.all(np.isfinite(pts), axis=1), :2]
    if len(xy) < 2:
        return -55.0
    w, U = np.linalg.eigh(np.cov((xy - xy.mean(0)).T))
    theta = float(np.degrees(np.arctan2(U[1, -1], U[0, -1]))) % 180.0  # the main direction, [0, 180)
    return theta - 55.0 if theta < 60.0 else theta - 115.0


def _panel_projection_xy(
    ax: Any, res: ShapeResult, b: int, unit: np.ndarray, V: np.ndarray, idx: np.ndarray, size: float, n_per_m: float
) -> None:
    """(g): outlines of the ellipsoids projected on the xy plane at waypoints ``idx`` (the stiffest
    semi-axis ``size`` m long), with their major axes and the path tangent; a scale bar in N/m
    (``n_per_m`` N/m per metre of the plot), the legend below the axes (it would hide the path's apex
    or the y label inside)."""
    pts = res.target[b]
    ax.plot(pts[:, 0], pts[:, 1], "k-", lw=1.5, label="path")
    t = np.linspace(0, 2 * np.pi, 100)
    semi = unit * size
    for j, k in enumerate(idx):
        M = (V[k] * semi[k])[:2]  # xy rows of the ellipsoid's axis matrix
        w2, U = np.linalg.eigh(M @ M.T)  # outline of the projection: an ellipse
        ell = (U * np.sqrt(np.maximum(w2, 0))) @ np.stack([np.cos(t), np.sin(t)])
        ax.plot(pts[k, 0] + ell[0], pts[k, 1] + ell[1], color="C1", label="ellipsoid outline (xy)" if j == 0 else None)
        a = V[k][:2, 0] * semi[k, 0]
        ax.plot(
            pts[k, 0] + np.array([-a[0], a[0]]),
            pts[k, 1] + np.array([-a[1], a[1]]),
            "C3-",
            lw=1,
            label="major axis" if j == 0 else None,
        )
        d = res.direction[b, k, :2] * semi[k, 0]
        ax.plot(
            pts[k, 0] + np.array([-d[0], d[0]]),
            pts[k, 1] + np.array([-d[1], d[1]]),
            "C0:",
            lw=1,
            label="path tangent" if j == 0 else None,
        )
    ax.set(xlabel="x (m)", ylabel="y (m)", title=f"(g) projection on the xy plane\n{_scale_text(n_per_m)}")
    # equal scale by widening the narrower data range, not by shrinking the box: a path narrow in x
    # (the default path: 0.1 m by 0.5 m) made an equal-aspect box a thin strip
    ax.set_aspect("equal", adjustable="datalim")
    ax.xaxis.set_major_locator(_FittingLocator())  # a narrow x range: fewer ticks, labels apart
    value = nice_value(size * n_per_m)  # a round stiffness near the largest drawn semi-axis
    # inside the axes, in the corner farthest from the path (outside it ran off the figure's grid)
    draw_scale_bar(ax, value / n_per_m, f"{value:g} N/m", loc=_emptiest_corner(ax, pts), anchor=None)
    ax.legend(fontsize=8, loc="upper center", bbox_to_anchor=(0.5, -0.12), ncol=2)
    ax.grid(alpha=0.3)


def _emptiest_corner(ax: Any, pts: np.ndarray) -> str:
    """The corner of ``ax`` ("upper left", ...) farthest from the points ``pts`` (xy columns), in
    axes fractions, after the equal aspect has set the limits."""
    ax.apply_aspect()
    (x0, x1), (y0, y1) = ax.get_xlim(), ax.get_ylim()
    fx, fy = (pts[:, 0] - x0) / (x1 - x0), (pts[:, 1] - y0) / (y1 - y0)
    corners = {"upper left": (0, 1), "upper right": (1, 1), "lower left": (0, 0), "lower right": (1, 0)}

    def room(c: str) -> float:
        return float(np.nanmin(np.hypot(fx - corners[c][0], fy - corners[c][1])))

    return max(corners, key=room)


def _fitting_locator_class() -> type:
    from matplotlib.ticker import MaxNLocator

    class FittingLocator(MaxNLocator):
        """Matplotlib's default x ticks (``AutoLocator``), with fewer of them where their labels
        would run into each other: an equal-aspect panel of a path that is narrow in x has room for
        few labels, and the default's estimate (three font sizes a label) wrote "0.490.500.51"."""

        def __init__(self) -> None:
            super().__init__(nbins="auto", steps=[1, 2, 2.5, 5, 10])

        def __call__(self) -> Any:
            axis: Any = self.axis  # (set by matplotlib when the locator is attached)
            vmin, vmax = sorted(axis.get_view_interval())
            width_pt = axis.axes.bbox.width * 72.0 / axis.axes.figure.dpi
            font = axis.get_major_ticks(1)[0].label1.get_fontsize()
            nbins = max(min(axis.get_tick_space(), 9), 1)  # what nbins="auto" gives
            while True:
                self.set_params(nbins=nbins, min_n_ticks=2 if nbins > 1 else 1)  # one tick if two do not fit
                locs = self.tick_values(vmin, vmax)
                shown = locs[(locs >= vmin - 1e-12 * abs(vmax - vmin)) & (locs <= vmax + 1e-12 * abs(vmax - vmin))]
                if nbins == 1 or shown.size < 2:
                    break
                labels = [str(t) for t in axis.major.formatter.format_ticks(shown)]
                gap_pt = width_pt * float(np.min(np.diff(shown))) / (vmax - vmin)
                need_pt = font * (0.65 * max(len(t) for t in labels) + 0.6)  # a label's width, and a space
                if gap_pt >= need_pt:
                    break
                nbins -= 1
            self.set_params(nbins="auto", min_n_ticks=2)
            return self.raise_if_exceeds(locs)

    return FittingLocator


def _FittingLocator() -> Any:
    """A :class:`FittingLocator` (matplotlib is imported only when a figure is drawn)."""
    return _fitting_locator_class()()


def _drawn_waypoints(
    P: int, every: int | None, waypoints: Sequence[int] | None
) -> tuple[np.ndarray, np.ndarray, float]:
    """Waypoints drawn in (g) and in (f) (the same), and their typical gap (waypoints) that sizes
    the ellipses. ``every`` None: about six ellipses along the path (every ``P // 6``-th)."""
    if waypoints is None:
        every = max(P // 6, 1) if every is None else every
        if every < 1:
            raise ValueError(f"every must be >= 1, got {every}")
        # the same waypoints in both panels, at one scale: (g) drawn twice as often as (f) piled its
        # outlines on each other at a scale that leaves (f)'s 3-D ellipsoids visible
        idx = np.arange(0, P, every)
        return idx, idx, float(every)
    idx = np.unique(np.asarray(list(waypoints), dtype=int))
    if idx.size == 0:
        raise ValueError("waypoints is empty: give at least one waypoint index")
    if idx[0] < 0 or idx[-1] >= P:
        bad = int(idx[0] if idx[0] < 0 else idx[-1])
        raise ValueError(f"waypoint {bad} is outside 0..{P - 1} (the path has {P} waypoints)")
    gap = float(np.median(np.diff(idx))) if idx.size > 1 else max(P / 10.0, 1.0)
    return idx, idx, max(gap, 1.0)


def usable_only(res: ShapeResult, b: int, ok: np.ndarray) -> ShapeResult:
    """``res`` with path ``b``'s values at unusable waypoints (status 3-5: unreachable, non-finite,
    not run) set to NaN, so the panels leave gaps there instead of drawing the reference state the
    file holds for them as if it were a solution."""
    out = {}
    for key in ("q", "kj", "kj_scaled", "cms", "criterion", "alpha_deg", "ratio"):
        a = np.array(getattr(res, key), dtype=float, copy=True)
        a[b, ~ok] = np.nan
        out[key] = a
    return _Overlay(res, out)  # type: ignore[return-value]


class _Overlay:
    """``base`` with some attributes replaced (works for a ShapeResult and any look-alike)."""

    def __init__(self, base: Any, values: dict[str, Any]):
        self._base = base
        self.__dict__.update(values)

    def __getattr__(self, key: str) -> Any:
        return getattr(self._base, key)


def figure_shape_path(
    res: ShapeResult,
    robot: Chain,
    file: str | os.PathLike,
    title: str,
    every: int | None = None,
    b: int = 0,
    dpi: int = 110,
    waypoints: Sequence[int] | None = None,
) -> str:
    """Seed 000 Fig. 4/5: the seven panels (a)-(g) of one path of a shaping result.

    (a) joint stiffness kj (Nm/rad; N/m for prismatic joints), (b) joint positions (deg; prismatic
    joints in mm, on a right axis when the robot has revolute joints too), (c) the criterion's distance to its
    minimum (log scale), (d) orientation error alpha (deg) and axis ratio, (e) CMS factor, (f) the
    path (m) with the CMS-scaled 3-D stiffness ellipsoids every ``every`` waypoints, (g) their
    outlines projected on the xy plane; (f) and (g) at one scale (N/m per cm, a scale bar in (g)).

    Args:
        res: a :class:`jaxstiff.results.ShapeResult` (task "xy": the ellipses lie in the path's
            plane, drawn flat in (f)). Unusable waypoints (status 3-5) are left out of every panel,
            the title says how many and of which status; a usable waypoint between unusable ones
            is a marker in (a) and (b), and the waypoint axes of (a)-(e) span the whole path.
        robot: the robot it was computed for.
        file: PNG to write (cropped to the drawing).
        title: figure title.
        every: waypoint spacing of the drawn ellipses, in (f) and (g) alike: every
            ``every``-th from 0; default ``P // 6`` (about six).
        b: which path of the batch.
        dpi: resolution, dots per inch.
        waypoints: the waypoints whose ellipses are drawn, in (f) and (g) alike (instead of
            ``every``); indices in ``0..P-1``.

    Raises:
        ValueError: if a waypoint index is outside ``0..P-1`` or the list is empty.
    """
    idx, idx3, gap = _drawn_waypoints(res.P, every, waypoints)
    status = getattr(res, "status", None)  # a hand-made look-alike may have none: all usable
    ok = np.ones(res.P, bool) if status is None else is_usable(np.asarray(status)[b])
    if not ok.any():
        raise ValueError(f"path {b} has no usable waypoint (status codes 3-5 only): nothing to plot")
    given, res = res, usable_only(res, b, ok)
    plt = pyplot()
    wp = np.arange(res.P)
    fig = plt.figure(figsize=(17, 14))
    # top: the panels start just under the title (the default left an empty band)
    gs = fig.add_gridspec(3, 6, height_ratios=[1, 1, 1.7], hspace=0.55, wspace=0.9, top=0.94)
    # one colour a joint: tab10 up to ten joints; beyond, tab20 (tab10 gave joints 10, 11, 12 one colour)
    colors = plt.cm.tab10(np.arange(res.n)) if res.n <= 10 else plt.cm.tab20(np.arange(res.n) % 20)
    pris = _prismatic(robot, res.n)
    joint_legends = _joint_panels(fig, gs, wp, res, b, colors, pris)
    spec_c = gs[0, 4:6]
    if pris.any() and not pris.all():  # (b) has a second y axis on its right: (c) moves right to make room
        spec_c = spec_c.subgridspec(1, 2, width_ratios=[0.3, 1], wspace=0)[0, 1]
    ax_c = fig.add_subplot(spec_c)
    _panel_criterion(ax_c, wp, res, b)
    row = gs[1, :].subgridspec(1, 2, wspace=0.3)  # room between (d)'s right axis label and (e)'s left one
    ax_d, ax_e = fig.add_subplot(row[0, 0]), fig.add_subplot(row[0, 1])
    _panel_alpha_ratio(ax_d, wp, res, b, float(res.meta["ratio"]))
    _panel_cms(ax_e, wp, res, b)
    from matplotlib.ticker import MaxNLocator

    for ax in (joint_legends[0][0], joint_legends[1][0], ax_c, ax_d, ax_e):  # (the twin axes share x)
        ax.set_xlim(*_waypoint_limits(res.P))
        ax.xaxis.set_major_locator(MaxNLocator("auto", steps=[1, 2, 5, 10], integer=True))  # indices: no "2.5"

    lam, V = stiffness_axes(robot, given.q[b], given.kj_scaled[b], res.meta["task"])
    if lam.shape[-1] == 2:
        # task "xy": K_T is 2 x 2, an ellipse in the path's plane; drawn as a flat ellipsoid (third
        # semi-axis 0, along z) so that (f) and (g) need no case of their own
        lam = np.concatenate([lam, np.zeros_like(lam[:, :1])], axis=1)
        V3 = np.zeros(V.shape[:-2] + (3, 3))
        V3[:, :2, :2], V3[:, 2, 2] = V, 1.0
        V = V3
    lam = np.where(ok[:, None], lam, np.nan)  # no ellipse where no usable solution was found
    spacing = float(np.median(np.linalg.norm(np.diff(res.target[b], axis=0), axis=1)))
    # one scale for (f) and (g): the median major semi-axis is half the gap between (f)'s ellipsoids
    # (they touch there); scaled by the largest instead, one stiff waypoint (f1 drives rho up to 19
    # on the default path) shrank every other ellipsoid to a needle
    typical = float(np.nanmedian(lam[:, 0]))
    unit = lam / typical  # axes relative to the median major axis on the path
    size = 0.5 * gap * spacing  # the median stiffest semi-axis, m
    n_per_m = typical / size  # N/m per metre of drawing, (f) and (g) alike
    idx, idx3 = idx[ok[idx]], idx3[ok[idx3]]
    ax_f = fig.add_subplot(gs[2, 0:3], projection="3d")
    _panel_ellipsoids_3d(ax_f, res, b, unit, V, idx3, size, n_per_m)
    _panel_projection_xy(fig.add_subplot(gs[2, 3:6]), res, b, unit, V, idx, size, n_per_m)

    sup = fig.suptitle(_title_with_note(title, _unusable_note(status, b, ok)), fontsize=13, y=0.985)
    if "\n" in sup.get_text():  # two lines or more: the panels may have to move down
        _title_above_panels(fig, gs, sup)
    _fit_joint_legends(fig, joint_legends, [ax_c])
    _declutter_3d(ax_f, fig)
    return save_figure(fig, file, dpi=dpi)


def _unusable_note(status: Any, b: int, ok: np.ndarray) -> str:
    """The title's note on the waypoints left out, "" when every one is usable: how many of the
    path's, and of which status ("19 of 20 waypoints unusable, left out: 19 unreachable")."""
    if ok.all():
        return ""
    from jaxstiff.results._status import STATUS_NAMES

    codes = np.asarray(status)[b][~ok].astype(int)
    kinds = ", ".join(
        f"{int(np.sum(codes == c))} {STATUS_NAMES.get(int(c), f'status {int(c)}')}" for c in np.unique(codes)
    )
    return f"{int((~ok).sum())} of {ok.size} waypoints unusable, left out: {kinds}"


def _title_with_note(title: str, note: str, width_chars: int = 140) -> str:
    """``title (note)`` on one line, or the note on a line of its own where both are longer than
    about ``width_chars`` characters of the 13-pt title (the figure's width)."""
    if not note:
        return title
    return f"{title}  ({note})" if len(title) + len(note) + 4 <= width_chars else f"{title}\n({note})"


#: legend font sizes (pt) of (a) and (b), tried in turn: the largest that fits the room under the panel
_JOINT_LEGEND_FONTS = (7.0, 6.5, 6.0, 5.5)
#: the last resort where even 5.5 pt does not fit in the tallest figure
_JOINT_LEGEND_SMALL_FONTS = (5.0, 4.5)
#: how often the figure grows taller (by 10 % each) to make room for the legends, before the small fonts
_TALLER_STEPS = 6


def _fit_joint_legends(
    fig: Any, panels: Sequence[tuple[Any, list[Any], list[str]]], others: Sequence[Any] = ()
) -> None:
    """Place the legends under (a) and (b) where they overlap nothing: each within its panel's
    share of the row (halfway to the neighbouring panels, ``others`` included), under its x axis
    labels and above the titles of the row below. Tried in turn: the font sizes of
    :data:`_JOINT_LEGEND_FONTS`, each with the columns of :func:`_legend_columns` first, then from
    the most columns to one; where none fits, the figure grows taller (every panel and gap with it,
    the text keeps its size) and all is tried again; in the tallest figure (1.77 times the height) smaller fonts too.
    Measured with the renderer's extents: the estimate from the names' lengths alone put a Fetch's
    eight joints (one of them "torso_lift_joint (prismatic, mm, right axis)") in one column, over
    (d)'s title and into (e). Where nothing fits (names too long for any font), each legend keeps
    the layout that sticks out least."""
    row = sorted([p[0] for p in panels] + list(others), key=lambda a: a.bbox.x0)
    pad = 3.0 * fig.dpi / 72.0  # 3 pt between a legend and what it must not touch, pixels
    height = float(fig.get_figheight())
    for step in range(_TALLER_STEPS + 1):
        if step:
            fig.set_figheight(height * 1.1**step)  # more room between the rows
        fig.canvas.draw()  # tick labels and the rows' positions final
        renderer = fig.canvas.get_renderer()
        last = step == _TALLER_STEPS
        fonts = _JOINT_LEGEND_FONTS + (_JOINT_LEGEND_SMALL_FONTS if last else ())
        outs = [_place_joint_legend(fig, renderer, ax, h, t, row, pad, fonts) for ax, h, t in panels]
        if all(o == 0.0 for o in outs):
            return


def _place_joint_legend(
    fig: Any,
    renderer: Any,
    ax: Any,
    handles: list[Any],
    labels: list[str],
    row: list[Any],
    pad: float,
    fonts: Sequence[float],
) -> float:
    """Put ``ax``'s legend in the first layout (font size, columns) that fits the room under it
    (see :func:`_fit_joint_legends`) and return 0.0; where none fits, the one that sticks out
    least, and by how much (pixels)."""
    i = row.index(ax)
    x_lo = 0.5 * (row[i - 1].bbox.x1 + ax.bbox.x0) + pad if i > 0 else fig.bbox.x0
    x_hi = 0.5 * (ax.bbox.x1 + row[i + 1].bbox.x0) - pad if i + 1 < len(row) else fig.bbox.x1
    below = [a for a in fig.axes if a.get_visible() and a.bbox.y1 < ax.bbox.y0 - 1]
    y_lo = max((a.get_tightbbox(renderer).y1 for a in below), default=fig.bbox.y0) + pad
    # the legend's top under the x axis' tick labels and name, 0.2 of the panel's height down at most
    x_axis = ax.xaxis.get_tightbbox(renderer)
    top = -0.2 if x_axis is None else min(-0.2, (x_axis.y0 - pad - ax.bbox.y0) / ax.bbox.height)
    first = _legend_columns(labels)
    columns = [first] + [c for c in range(min(len(labels), 6), 0, -1) if c != first]
    best = (np.inf, fonts[0], first)
    for font in fonts:
        for ncol in columns:
            leg = ax.legend(handles, labels, fontsize=font, ncol=ncol, loc="upper center", bbox_to_anchor=(0.5, top))
            box = leg.get_window_extent(renderer)
            out = max(0.0, x_lo - box.x0) + max(0.0, box.x1 - x_hi) + max(0.0, y_lo - box.y0)
            if out == 0.0:
                return 0.0
            if out < best[0]:
                best = (out, font, ncol)
    ax.legend(handles, labels, fontsize=best[1], ncol=best[2], loc="upper center", bbox_to_anchor=(0.5, top))
    return float(best[0])


def _title_above_panels(fig: Any, gs: Any, sup: Any) -> None:
    """Lower the panels' top (the gridspec's ``top``) where the figure title ``sup`` (a Text)
    reaches down to a panel's title: a title whose note is on a second line."""
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    pad = 3.0 * fig.dpi / 72.0
    bottom = sup.get_window_extent(renderer).y0
    highest = max((a.title.get_window_extent(renderer).y1 for a in fig.axes if a.get_title()), default=0.0)
    if highest + pad > bottom:
        gs.update(top=float(gs.top) - (highest + pad - bottom) / fig.bbox.height)


def _declutter_3d(ax: Any, fig: Any) -> None:
    """Hide the 3-D tick labels that overlap another label of the panel: where two axes meet at a
    corner of the box their end labels ran into each other ("0.75" into "-0.30" on the default
    path, "-0.04" into "-0.34" on a UR10 path), and an axis name may sit on a tick label. Of two
    overlapping tick labels the one of the axis with more labels shown goes; a tick label under an
    axis name goes. Needs a draw: the boxes are the renderer's."""
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    axes = (ax.xaxis, ax.yaxis, ax.zaxis)
    ticks = {
        id(a): [t.label1 for t in a.get_major_ticks() if t.label1.get_visible() and t.label1.get_text()] for a in axes
    }

    def shown(a: Any) -> int:
        return sum(t.get_visible() for t in ticks[id(a)])

    def overlap(p: Any, q: Any) -> bool:
        return bool(p.get_window_extent(renderer).overlaps(q.get_window_extent(renderer)))

    for i, a in enumerate(axes):
        for t in ticks[id(a)]:
            for b in axes:
                if t.get_visible() and b.label.get_text() and overlap(t, b.label):
                    t.set_visible(False)
            for b in axes[i:]:
                for u in ticks[id(b)]:
                    if u is t or not (t.get_visible() and u.get_visible()) or not overlap(t, u):
                        continue
                    (t if shown(a) >= shown(b) and a is not b else u).set_visible(False)


def rate_limited_joints(res: ShapeResult, robot: Chain, b: int = 0, rtol: float = 1e-6) -> dict[str, np.ndarray]:
    """Per waypoint of path ``b``: how many free joints sit at a limit (S0-11 ... S0-14), (P,) ints each.

    ``"q_rate"``: joints whose step from the waypoint's reference state is the joint rate limit
    ``dq`` (within ``rtol`` of it); ``"kj_rate"``: the same for the stiffness step and ``dk``;
    ``"q_bound"``: joints at a joint limit; ``"kj_bound"``: joint stiffnesses at ``kmin`` or
    ``kmax``. The reference state is the previous usable waypoint's (its start state before the
    first, where rate limits apply only with ``first_rate_limit``), as in
    :func:`jaxstiff.results._files.reference_states`; locked joints never count.
    """
    from jaxstiff.results._files import path_parameters, reference_states

    free = np.asarray(robot.free)
    prm = path_parameters(res.meta, res.B, res.n)
    lim = res.meta["limits"]
    q, kj = res.q[b], res.kj[b]
    q_ref, kj_ref, rate = reference_states(res, b)
    dq, dk = prm["dq"][b], prm["dk"][b]
    # a rigid locked joint's kj is +inf (inf - inf is nan): finite entries only, and locked joints never count
    kj = np.where(np.isfinite(kj), kj, np.nan)
    kj_ref = np.where(np.isfinite(kj_ref), kj_ref, np.nan)
    at_q = (np.abs(q - q_ref) >= dq * (1 - rtol)) & np.isfinite(dq) & rate[:, None]
    at_k = (np.abs(kj - kj_ref) >= dk * (1 - rtol)) & np.isfinite(dk) & np.isfinite(kj) & rate[:, None]
    span_q = np.where(np.isfinite(robot.upper - robot.lower), robot.upper - robot.lower, 1.0)
    q_bound = (q - robot.lower <= rtol * span_q) | (robot.upper - q <= rtol * span_q)
    kspan = float(lim["kmax"]) - float(lim["kmin"])
    kj_bound = (kj - float(lim["kmin"]) <= rtol * kspan) | (float(lim["kmax"]) - kj <= rtol * kspan)
    return {
        k: np.sum(v & free, axis=1)
        for k, v in (("q_rate", at_q), ("kj_rate", at_k), ("q_bound", q_bound), ("kj_bound", kj_bound))
    }


def _turning_overlay(ax: Any, wp: np.ndarray, turning: np.ndarray, dq_deg: float | None, which: str = "") -> Any:
    """A twin axis with the tangent's turning per waypoint (deg) and the joint rate limit line
    (none when ``dq_deg`` is None: no revolute joint, no rate limit in degrees); ``which`` names
    the joints the limit is of ("revolute " when the robot has prismatic joints too)."""
    ax2 = ax.twinx()
    ax2.plot(wp[1:], turning, color="0.45", lw=2, alpha=0.8, label="path tangent turns (deg per waypoint)")
    if dq_deg is not None:
        ax2.axhline(
            dq_deg,
            color="0.25",
            ls="--",
            lw=1,
            label=f"{which}joint rate limit dq = {dq_deg:g} deg per waypoint (a joint angle, for scale only:\nnot a limit on the tangent's turn)",
        )
    ax2.set_ylabel("turning of the path tangent (deg per waypoint)", color="0.3")
    ax2.set_ylim(0, 1.15 * max(float(turning.max()), dq_deg or 0.0) or 1.0)
    return ax2


def _limit_texts(dq: np.ndarray, dk: np.ndarray, pris: np.ndarray) -> tuple[float | None, str, str]:
    """The largest revolute rate limit dq in deg (None without revolute joints) and the legend
    texts of the joint and stiffness rate limits: deg and Nm/rad for revolute joints, mm and N/m
    for prismatic ones (the limits of a robot of both kinds are given for each kind)."""
    rev = ~pris
    dq_deg = float(np.degrees(dq[rev].max())) if rev.any() else None
    if not pris.any():
        return dq_deg, f"{dq_deg:g} deg", f"{float(dk.max()):g} Nm/rad"
    dq_mm, dk_n = f"{1e3 * float(dq[pris].max()):g} mm", f"{float(dk[pris].max()):g} N/m"
    if not rev.any():
        return None, dq_mm, dk_n
    return (
        dq_deg,
        f"{dq_deg:g} deg (revolute), {dq_mm} (prismatic)",
        f"{float(dk[rev].max()):g} Nm/rad (revolute), {dk_n} (prismatic)",
    )


def figure_turning(
    res: ShapeResult,
    robot: Chain,
    file: str | os.PathLike,
    title: str,
    b: int = 0,
    alpha_ok: float = 1.0,
    dpi: int = 110,
) -> str:
    """Where the shaping holds and where it gives way: alpha and rho along path ``b`` against the
    turning rate of the path's tangent, and the joints held at their rate limits.

    (a) orientation error alpha (deg, log scale) and (b) axis ratio rho, each with the angle the
    desired direction turns between consecutive waypoints (deg per waypoint, from ``res.direction``;
    :func:`jaxstiff.paths._generators.turning_deg`) on a twin axis with the joint rate limit ``dq``;
    (c) the number of free joints at the joint rate limit ``dq`` and at the stiffness rate limit
    ``dk`` (:func:`rate_limited_joints`). Waypoints where the tangent turns faster than ``dq`` are
    shaded in every panel. The turning is compared with the revolute joints' ``dq`` (deg) only: a
    prismatic joint's limit is a length (mm in the legend, its stiffness limit in N/m); a robot
    without revolute joints has no such line and no shading.

    Args:
        res: a :class:`jaxstiff.results.ShapeResult` (criterion f1 or f2: rho's target line is ``r``).
        robot: the robot it was computed for (its free joints and joint limits).
        file: PNG to write (cropped to the drawing).
        title: figure title.
        b: which path of the batch.
        alpha_ok: the alpha (deg) drawn as the "holds" line.
        dpi: resolution, dots per inch.
    """
    from jaxstiff.paths import Path
    from jaxstiff.paths._generators import turning_deg
    from jaxstiff.results._files import path_parameters

    plt = pyplot()
    wp = np.arange(res.P)
    turning = turning_deg(Path(res.target[b], res.direction[b]))
    prm = path_parameters(res.meta, res.B, res.n)
    pris = _prismatic(robot, res.n)
    dq_deg, dq_text, dk_text = _limit_texts(np.asarray(prm["dq"][b]), np.asarray(prm["dk"][b]), pris)
    which = "revolute " if pris.any() else ""
    r = float(prm["ratio"][b])
    # waypoint p is reached by a turn faster than dq (revolute joints: a prismatic one turns nothing)
    fast = np.r_[False, turning > dq_deg] if dq_deg is not None else np.zeros(res.P, bool)
    fig, axes = plt.subplots(3, 1, figsize=(11, 11), sharex=True, gridspec_kw={"height_ratios": [1.2, 1.2, 0.8]})
    for ax in axes:
        for k in np.flatnonzero(fast):
            ax.axvspan(k - 0.5, k + 0.5, color="C1", alpha=0.12, lw=0)
    ax = axes[0]
    ax.semilogy(wp, np.maximum(res.alpha_deg[b], 1e-9), "C3.-", label="orientation error alpha")
    ax.axhline(alpha_ok, color="C3", ls=":", lw=1, label=f"alpha = {alpha_ok:g} deg")
    ax.set(ylabel="alpha (deg, log scale)", title="(a) orientation error alpha and the turning of the path")
    ax.set_ylim(1e-9, 10 ** np.ceil(np.log10(max(90.0, float(res.alpha_deg[b].max())))))
    ax.grid(alpha=0.3, which="major")
    ax2 = _turning_overlay(ax, wp, turning, dq_deg, which)
    h1, l1 = ax.get_legend_handles_labels()
    h2, l2 = ax2.get_legend_handles_labels()
    ax.legend(h1 + h2, l1 + l2, fontsize=8, loc="upper left", bbox_to_anchor=(1.09, 1.0))
    ax = axes[1]
    ax.plot(wp, res.ratio[b], "C0.-", label="axis ratio rho = lambda1/lambda2")
    ax.axhline(r, color="C0", ls=":", lw=1, label=f"r = {r:g}")
    ax.set(ylabel="axis ratio rho (-)", title="(b) axis ratio rho and the turning of the path")
    ax.set_ylim(0, max(2 * r, 1.1 * float(res.ratio[b].max())))
    ax.grid(alpha=0.3)
    ax2 = _turning_overlay(ax, wp, turning, dq_deg, which)
    h1, l1 = ax.get_legend_handles_labels()
    h2, l2 = ax2.get_legend_handles_labels()
    ax.legend(h1 + h2, l1 + l2, fontsize=8, loc="upper left", bbox_to_anchor=(1.09, 1.0))
    ax = axes[2]
    lim = rate_limited_joints(res, robot, b)
    sep = "\n" if which else " "  # the limits of both kinds on a line of their own: the legend no wider
    ax.step(wp, lim["q_rate"], "C4", where="mid", label=f"joints at the rate limit dq ={sep}{dq_text}")
    ax.step(wp, lim["kj_rate"], "C2--", where="mid", label=f"joint stiffnesses at the rate limit dk ={sep}{dk_text}")
    ax.set(xlabel="waypoint p", ylabel="free joints (count)", title="(c) joints held by the rate limits")
    ax.set_ylim(-0.2, max(1, int(np.max([lim["q_rate"], lim["kj_rate"]]))) + 0.5)
    if dq_deg is not None:
        ax.fill_between(
            [], [], color="C1", alpha=0.12, label=f"waypoints the tangent reaches turning faster than {dq_deg:g} deg"
        )
    ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.09, 1.0))
    ax.grid(alpha=0.3)
    fig.suptitle(title, fontsize=12)
    fig.tight_layout()
    return save_figure(fig, file, dpi=dpi)
