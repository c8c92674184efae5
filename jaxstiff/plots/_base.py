"""Shared pieces of the figures: matplotlib on the Agg backend, the atomic PNG writer, ellipse and
arm geometry (numpy) and the drawing of a planar arm and of an ellipse panel."""

from __future__ import annotations

import os
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike

from jaxstiff.runtime._io import atomic_write

if TYPE_CHECKING:
    from jaxstiff.model._chain import Chain

__all__ = [
    "pyplot",
    "save_figure",
    "FIGURE_FORMATS",
    "ellipse_points",
    "chain_points",
    "draw_arm",
    "style_ellipse_panel",
    "nice_value",
    "draw_scale_bar",
    "label_points",
]


def pyplot() -> Any:
    """``matplotlib.pyplot`` on the non-interactive Agg backend (matplotlib is imported on the first call).

    Example:
        >>> plt = plots.pyplot()
        >>> fig, ax = plt.subplots()
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


#: the file formats :func:`save_figure` writes (by the file's suffix)
FIGURE_FORMATS = ("png", "svg", "pdf")


def save_figure(fig: Any, file: str | os.PathLike, dpi: int = 130, crop: bool = True) -> str:
    """Write ``fig`` to ``file`` atomically, then close it; the format from the suffix (png, svg, pdf; none: png).

    The file goes to a temporary file in the target folder (created if missing) and is renamed onto
    ``file`` only once complete (:func:`jaxstiff.runtime._io.atomic_write`): if drawing fails, no partial
    or temporary file is left and an earlier ``file`` stays as it was. The figure is closed either way.

    Args:
        fig: a matplotlib Figure.
        file: the figure to write (``.png``, ``.svg`` or ``.pdf``).
        dpi: resolution, dots per inch (the PNG is ``figsize * dpi`` pixels when ``crop`` is False).
        crop: crop to the drawn content (``bbox_inches="tight"``); False keeps the figure's size.

    Returns:
        ``file`` as a string.
    """
    file = os.fspath(file)
    fmt = os.path.splitext(file)[1].lstrip(".").lower() or "png"
    if fmt not in FIGURE_FORMATS:
        pyplot().close(fig)
        raise ValueError(f"{file}: figure format {fmt!r} is not supported; use one of {', '.join(FIGURE_FORMATS)}")
    folder = os.path.dirname(os.path.abspath(file))
    os.makedirs(folder, exist_ok=True)
    extra = {"bbox_inches": "tight"} if crop else {}
    try:
        return atomic_write(file, lambda fh: fig.savefig(fh, dpi=dpi, format=fmt, **extra), binary=True)
    finally:
        pyplot().close(fig)


def ellipse_points(K: ArrayLike, n: int = 201) -> np.ndarray:
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


def chain_points(robot: Chain, q: ArrayLike) -> np.ndarray:
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


def draw_arm(
    ax: Any,
    robot: Chain,
    q: Sequence[float] | np.ndarray,
    color: Any,
    label: str | None = None,
    lw: float = 3.0,
    annotate: bool = False,
    kj: Sequence[float] | np.ndarray | None = None,
) -> np.ndarray:
    """Draw a planar arm at posture ``q`` (rad) on ``ax`` in its xy plane (m); optionally label each
    joint's angle and stiffness ``kj`` (Nm/rad). Returns the points of :func:`chain_points`."""
    pts = chain_points(robot, q)
    ax.plot(pts[:, 0], pts[:, 1], "-", color=color, lw=lw, label=label, solid_capstyle="round")
    ax.plot(pts[:-1, 0], pts[:-1, 1], "o", color="white", mec=color, ms=7, mew=1.8)
    ax.plot(pts[-1, 0], pts[-1, 1], "o", color="tab:blue", ms=7)
    if annotate:
        for i in range(robot.n):
            txt = f"q{i + 1} = {np.degrees(q[i]):.2f}°"
            if kj is not None:
                txt += f"\nk_j{i + 1} = {kj[i]:g} Nm/rad"
            ax.annotate(
                txt, pts[i, :2], xytext=(10, -30 if i else 6), textcoords="offset points", fontsize=8, color="tab:red"
            )
        ax.annotate("EE (TCP)", pts[-1, :2], xytext=(8, 6), textcoords="offset points", fontsize=8, color="tab:blue")
    return pts


def style_ellipse_panel(ax: Any, title: str) -> None:
    """Axes in N/m at equal scale, grid, legend to the right: the ellipse panel of Fig. 2 and Fig. 3."""
    ax.set(xlabel="stiffness along x (N/m)", ylabel="stiffness along y (N/m)", title=title)
    ax.set_aspect("equal")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, loc="center left", bbox_to_anchor=(1.01, 0.5))


def nice_value(x: float) -> float:
    """The largest of 1, 2, 5 times a power of ten that is at most ``x`` (> 0): a round scale-bar value.

    Example:
        >>> from jaxstiff.plots._base import nice_value
        >>> nice_value(730.0), nice_value(0.031)
        (500.0, 0.02)
    """
    if not (np.isfinite(x) and x > 0):
        raise ValueError(f"nice_value needs a finite number > 0, got {x}")
    e = np.floor(np.log10(x))
    m = x / 10**e
    step = 5.0 if m >= 5 else 2.0 if m >= 2 else 1.0
    return float(round(step * 10**e, 12))


def draw_scale_bar(ax: Any, length: float, label: str, loc: str = "upper left", anchor: Any = (1.02, 1.0)) -> None:
    """A horizontal scale bar of ``length`` data units (an ellipse panel drawn in metres: the length
    a stated stiffness has on the plot) with ``label`` under it.

    Placed at ``loc`` of the point ``anchor`` in axes fractions (default: outside, right of the top
    right corner, where it hides no data); ``anchor=None`` puts it in the ``loc`` corner inside."""
    from matplotlib.font_manager import FontProperties
    from mpl_toolkits.axes_grid1.anchored_artists import AnchoredSizeBar

    bar = AnchoredSizeBar(
        ax.transData,
        length,
        label,
        loc,
        pad=0.4,
        sep=4,
        frameon=True,
        size_vertical=0.04 * length,  # pyright: ignore[reportArgumentType]  (matplotlib takes a float; its stub says int)
        fontproperties=FontProperties(size=8),
        bbox_to_anchor=anchor,
        bbox_transform=ax.transAxes if anchor is not None else None,
        borderpad=0.0 if anchor is not None else 0.5,
    )
    bar.patch.set_alpha(0.8)
    ax.add_artist(bar)


#: offsets (points) tried in turn for a point's label: right-up first, then the other sides
_LABEL_OFFSETS = ((6, 4), (6, -12), (-6, 4), (-6, -12), (0, 9), (0, -16), (14, 14), (14, -22), (-14, 14), (-14, -22))


def label_points(
    ax: Any,
    xs: ArrayLike,
    ys: ArrayLike,
    texts: Sequence[str],
    fontsize: float = 9,
    colors: Sequence[Any] | None = None,
) -> list[Any]:
    """Annotate the points ``(xs[i], ys[i])`` with ``texts[i]`` (in ``colors[i]``), each label at the
    first offset of a short list (right-up, right-down, left-up, ...) where its box lies inside the
    axes, overlaps no label placed before it and no other point's marker, and is nearer its own
    point than any other (so that it reads as that point's), judged by the renderer's extents (set
    the limits and the layout first). A label that fits nowhere keeps the first offset.

    Returns:
        The annotations, in the order of ``texts``.
    """
    fig = ax.figure
    fig.canvas.draw()  # limits and layout final: display coordinates hold from here on
    renderer = fig.canvas.get_renderer()
    x, y = np.asarray(xs, float), np.asarray(ys, float)
    pts = ax.transData.transform(np.column_stack([x, y]))
    r = 4.0 * fig.dpi / 72.0  # a 7-pt marker's half size, pixels
    placed: list[Any] = []
    out = []
    for i, text in enumerate(texts):
        others = np.delete(pts, i, axis=0)
        for dx, dy in (*_LABEL_OFFSETS, _LABEL_OFFSETS[0]):  # the last try: the first offset, kept
            ha = "left" if dx > 0 else "right" if dx < 0 else "center"
            ann = ax.annotate(
                text, (x[i], y[i]), textcoords="offset points", xytext=(dx, dy), fontsize=fontsize, ha=ha,
                color=None if colors is None else colors[i],
            )  # fmt: skip
            box = ann.get_window_extent(renderer)
            mid = np.array([(box.x0 + box.x1) / 2, (box.y0 + box.y1) / 2])
            own = bool(np.all(np.linalg.norm(others - mid, axis=1) > np.linalg.norm(pts[i] - mid)))
            inside = ax.bbox.x0 <= box.x0 and box.x1 <= ax.bbox.x1 and ax.bbox.y0 <= box.y0 and box.y1 <= ax.bbox.y1
            on_point = bool(np.any(
                (others[:, 0] > box.x0 - r) & (others[:, 0] < box.x1 + r)
                & (others[:, 1] > box.y0 - r) & (others[:, 1] < box.y1 + r)
            ))  # fmt: skip
            if inside and own and not on_point and not any(box.overlaps(b) for b in placed):
                break
            ann.remove()
        else:  # the loop's last try is kept as it is
            ann = ax.annotate(
                text, (x[i], y[i]), textcoords="offset points", xytext=_LABEL_OFFSETS[0], fontsize=fontsize,
                color=None if colors is None else colors[i],
            )  # fmt: skip
            box = ann.get_window_extent(renderer)
        placed.append(box)
        out.append(ann)
    return out
