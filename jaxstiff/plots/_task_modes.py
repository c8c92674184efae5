"""Which stiffness is shaped? Along a path, the ellipsoid of the stiffness with the tool's orientation
held (task ``full``'s, seed 000 S0-6/7) against the one a pure force at the TCP meets when the tool is
free to turn (task ``xyz``'s, the inverse of the translational compliance), docs/concepts.md."""

from __future__ import annotations

import os
from typing import TYPE_CHECKING

import numpy as np

from jaxstiff.plots._base import pyplot, save_figure

if TYPE_CHECKING:
    from jaxstiff.model._chain import Chain
    from jaxstiff.results._files import ShapeResult

__all__ = ["held_and_free", "figure_task_modes"]


def _alpha_ratio_major(K: np.ndarray, d: np.ndarray) -> dict[str, np.ndarray]:
    """alpha (deg, major axis against ``d``), rho = lambda1 / lambda2 and lambda1 (N/m) per waypoint."""
    w, V = np.linalg.eigh(K)  # ascending
    v1 = V[:, :, -1]
    dn = d / np.linalg.norm(d, axis=-1, keepdims=True)
    cos = np.clip(np.abs(np.sum(v1 * dn, axis=-1)), 0.0, 1.0)
    return {"alpha_deg": np.degrees(np.arccos(cos)), "ratio": w[:, -1] / w[:, -2], "major": w[:, -1]}


def held_and_free(
    robot: Chain, q: np.ndarray, kj: np.ndarray, directions: np.ndarray
) -> dict[str, dict[str, np.ndarray]]:
    """The two translational stiffnesses of the same postures and joint springs, per waypoint.

    ``"held"``: the top-left 3x3 block of the 6x6 ``K_C`` (task ``full``: tool orientation held);
    ``"free"``: ``C_TT^-1`` (task ``xyz``: a pure force, the tool free to turn). Each maps to
    ``alpha_deg`` (the major axis against ``directions``, deg), ``ratio`` (lambda1 / lambda2) and
    ``major`` (lambda1, N/m), each (P,).

    Args:
        robot: the chain.
        q: (P, n) joint values, rad.
        kj: (P, n) joint stiffnesses, Nm/rad (``inf``: a rigid locked joint).
        directions: (P, 3) wanted directions (the path tangent).
    """
    from jaxstiff.model._kinematics import jacobian
    from jaxstiff.stiffness._core import translational_stiffness

    J = jacobian(robot, np.asarray(q))
    out = {}
    for name, task in (("held", "full"), ("free", "xyz")):
        K = np.asarray(translational_stiffness(J, np.asarray(kj), task=task), dtype=float)
        out[name] = _alpha_ratio_major(K, np.asarray(directions, dtype=float))
    return out


def figure_task_modes(
    res_full: ShapeResult, res_xyz: ShapeResult, robot: Chain, file: str | os.PathLike, title: str, dpi: int = 110
) -> str:
    """Three ellipsoids per waypoint of path 0: (i) what task ``full`` shapes (orientation held),
    (ii) the free-orientation stiffness of the same solution, (iii) that of a solution shaped with
    task ``xyz``. Panels: (a) the major axis's angle to the path tangent (deg), (b) the axis ratio
    against the wanted r, (c) the major axis, N/m (CMS-scaled, log scale).

    Args:
        res_full: a result shaped with task ``"full"``.
        res_xyz: a result on the same path shaped with task ``"xyz"``.
        robot: the robot both were computed for.
        file: the figure to write (cropped to the drawing).
        title: figure title.
        dpi: resolution, dots per inch.
    """
    for res, task in ((res_full, "full"), (res_xyz, "xyz")):
        if res.meta["task"] != task:
            raise ValueError(f"expected a result shaped with task {task!r}, got task {res.meta['task']!r}")
    if res_full.P != res_xyz.P:
        raise ValueError(f"the results have {res_full.P} and {res_xyz.P} waypoints: not the same path")
    d = res_full.direction[0]
    both = held_and_free(robot, res_full.q[0], res_full.kj_scaled[0], d)
    own = held_and_free(robot, res_xyz.q[0], res_xyz.kj_scaled[0], d)["free"]
    r = float(res_full.meta["ratio"])
    crit = res_full.meta["criterion"]
    curves = [
        (both["held"], "C0", "-", f"(i) shaped with task full, orientation held (what {crit} shapes)"),
        (both["free"], "C3", "-", "(ii) the same solution, tool free to turn"),
        (own, "C2", "--", "(iii) shaped with task xyz, tool free to turn"),
    ]
    plt = pyplot()
    wp = np.arange(res_full.P)
    fig, axes = plt.subplots(3, 1, figsize=(10, 10), sharex=True, gridspec_kw={"height_ratios": [1, 1, 0.8]})
    for vals, color, ls, label in curves:
        axes[0].plot(wp, vals["alpha_deg"], color=color, ls=ls, marker=".", label=label)
        axes[1].plot(wp, vals["ratio"], color=color, ls=ls, marker=".")
        axes[2].semilogy(wp, vals["major"], color=color, ls=ls, marker=".")
    axes[0].axhline(1.0, color="0.3", ls=":", lw=1, label="alpha = 1 deg (in target below)")
    axes[0].set(
        ylabel="major axis to path tangent (deg)", title="(a) angle between the major axis and the path tangent"
    )
    axes[0].set_ylim(-2, 92)
    axes[0].set_yticks([0, 15, 30, 45, 60, 75, 90])
    axes[1].axhline(r, color="0.3", ls=":", lw=1, label=f"wanted ratio r = {r:g}")
    axes[1].set(ylabel="axis ratio lambda1 / lambda2 (-)", title="(b) axis ratio")
    axes[1].set_ylim(0, max(2 * r, 1.1 * max(float(np.max(c[0]["ratio"])) for c in curves)))
    axes[2].set(
        xlabel="waypoint p",
        ylabel="major axis lambda1 (N/m, log)",
        title="(c) stiffness along the major axis (CMS-scaled joint springs)",
    )
    from matplotlib.ticker import LogLocator, NullFormatter, ScalarFormatter

    axes[2].yaxis.set_major_locator(LogLocator(subs=(1.0, 2.0, 5.0)))  # 100, 200, 500, 1000 ... written out
    axes[2].yaxis.set_major_formatter(ScalarFormatter())
    axes[2].yaxis.set_minor_formatter(NullFormatter())
    for ax in axes:
        ax.grid(alpha=0.3, which="major")
    h0, l0 = axes[0].get_legend_handles_labels()
    h1, l1 = axes[1].get_legend_handles_labels()
    fig.legend(h0 + h1, l0 + l1, loc="upper center", bbox_to_anchor=(0.5, 0.965), ncol=2, fontsize=8, frameon=False)
    fig.suptitle(title, fontsize=12, y=0.995)
    fig.tight_layout(rect=(0, 0, 1, 0.925))  # the legend above (a), no band between
    return save_figure(fig, file, dpi=dpi)
