"""Figures that read at a glance (issue 40, item 4): each fixed defect has a check that can fail,
judged by matplotlib's renderer extents (bounding boxes in display pixels), never by pixel hashes.

* the seven-panel path figure (``figure_shape_path``, also what ``jaxstiff plot`` draws) on the LWR
  and on third-party arms (tests/data/robots): (f)'s 3-D tick and axis labels do not overlap each
  other or (g)'s, the scale bar lies inside (g), the panels start right under the title, (f) and
  (g) state one scale and (g)'s major axes are drawn at it (checked against a numpy stiffness from
  a finite-difference Jacobian), and the ellipses are neither needles nor piled on each other;
* seed 000 Fig. 6 (``figure_criteria``): contour labels apart and inside their maps, and no part of
  the surface in front of f1's red minimum line in the 3-D view;
* the CSC propositions' figures: the legend of Proposition 1 off the data, the ``beta = b`` labels
  of Proposition 2 apart and off the other points (``label_points``);
* the planar 4R self-motion figure: both panels one size and one range, the colour bar beside them.

Hand-made results (fixed smooth joint motions), no solver run, except the 4R script (slow).
"""

from __future__ import annotations

import os
import re
import sys
import types

import numpy as np
import pytest
from helpers import load_script, numpy_fk
from matplotlib.colors import same_color

import jaxstiff
from jaxstiff import plots
from jaxstiff.plots import _planar as planar
from jaxstiff.plots import _shape_path as shape_path
from jaxstiff.plots._base import label_points

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
ROBOTS = os.path.join(ROOT, "tests", "data", "robots")


# ------------------------------------------------------------------ helpers


def _boxes(texts, renderer):
    """``[(text, bbox)]`` of the visible, non-empty Text artists ``texts`` (display pixels)."""
    out = []
    for t in texts:
        if t.get_visible() and t.get_text().strip():
            out.append((t.get_text(), t.get_window_extent(renderer)))
    return out


def _overlapping(boxes_a, boxes_b=None, shrink=1.0):
    """Pairs ``(text_a, text_b)`` whose boxes overlap by more than ``shrink`` pixels on each side
    (one list: every pair in it; two lists: pairs across them)."""
    pairs = []
    if boxes_b is None:
        items = [(a, b) for i, a in enumerate(boxes_a) for b in boxes_a[i + 1 :]]
    else:
        items = [(a, b) for a in boxes_a for b in boxes_b]
    for (ta, ba), (tb, bb) in items:
        if ba.x0 + shrink < bb.x1 and bb.x0 + shrink < ba.x1 and ba.y0 + shrink < bb.y1 and bb.y0 + shrink < ba.y1:
            pairs.append((ta, tb))
    return pairs


def _axis3d_texts(ax):
    """The tick labels and axis labels of a 3-D axes."""
    texts = []
    for axis in (ax.xaxis, ax.yaxis, ax.zaxis):
        texts += [t.label1 for t in axis.get_major_ticks()] + [axis.label]
    return texts


def _axis2d_texts(ax):
    return (
        [t.label1 for t in ax.xaxis.get_major_ticks()]
        + [t.label1 for t in ax.yaxis.get_major_ticks()]
        + [
            ax.xaxis.label,
            ax.yaxis.label,
            ax.title,
        ]
    )


def _capture(monkeypatch, module):
    """Replace ``module.save_figure`` by one that keeps the figure (drawn), then saves it."""
    seen = {}
    original = module.save_figure

    def keep(fig, file, **kw):
        fig.canvas.draw()
        seen["fig"] = fig
        seen["renderer"] = fig.canvas.get_renderer()
        return original(fig, file, **kw)

    monkeypatch.setattr(module, "save_figure", keep)
    return seen


def _hand_made(robot, P=30, seed=0, task="full"):
    """A one-path result that the plots read: a smooth joint motion inside the limits, its TCP trace
    as the path (numpy FK), joint stiffnesses from a fixed random draw; no solve."""
    rng = np.random.default_rng(seed)
    n = robot.n
    lo = np.where(np.isfinite(robot.lower), robot.lower, -np.pi) + 0.3
    hi = np.where(np.isfinite(robot.upper), robot.upper, np.pi) - 0.3
    qa = rng.uniform(lo, hi)
    qb = np.clip(qa + rng.uniform(-0.4, 0.4, n), lo, hi)
    s = 0.5 - 0.5 * np.cos(np.linspace(0, np.pi, P))
    q = qa + s[:, None] * (qb - qa)
    locked = ~np.isnan(robot.locked_values)
    q[:, locked] = robot.locked_values[locked]  # locked joints at their values, rigid (kj = inf)
    pts = np.stack([numpy_fk(robot, qi)[:3, 3] for qi in q])
    tang = np.gradient(pts, axis=0)
    dirs = tang / np.linalg.norm(tang, axis=1, keepdims=True)
    kj = np.clip(rng.uniform(5, 95, (1, n)) + np.linspace(0, 5, P)[:, None], 1, 100)
    kj[:, locked] = np.inf
    return types.SimpleNamespace(
        P=P, n=n, B=1, joint_names=np.array(robot.joint_names),
        meta={"ratio": 5.0, "criterion": "f2", "task": task},
        q=q[None], kj=kj[None], kj_scaled=3 * kj[None], cms=np.full((1, P), 3.0),
        target=pts[None], direction=dirs[None], position=pts[None],
        criterion=np.full((1, P), 1.5), alpha_deg=np.linspace(0, 3, P)[None], ratio=np.linspace(3, 6, P)[None],
        status=np.zeros((1, P), int),
    )  # fmt: skip


ARMS = {
    "kuka_lwr4": lambda: jaxstiff.Robot.from_urdf("kuka_lwr4"),
    "ur10": lambda: jaxstiff.Robot.from_urdf(os.path.join(ROBOTS, "ur10.urdf")),
    "z1": lambda: jaxstiff.Robot.from_urdf(os.path.join(ROBOTS, "z1.urdf")),
    "kinova_j2s6s200": lambda: jaxstiff.Robot.from_urdf(os.path.join(ROBOTS, "kinova_j2s6s200.urdf")),
}


def _draw_path_figure(robot_name, tmp_path, monkeypatch, **kw):
    robot = ARMS[robot_name]()
    res = _hand_made(robot, **kw)
    seen = _capture(monkeypatch, shape_path)
    shape_path.figure_shape_path(res, robot, tmp_path / "fig.png", "t", dpi=40)
    fig = seen["fig"]
    ax_f = next(a for a in fig.axes if a.name == "3d")
    ax_g = next(a for a in fig.axes if a.get_title().startswith("(g)"))
    return robot, res, fig, seen["renderer"], ax_f, ax_g


# ------------------------------------------------------------------ the path figure


@pytest.mark.parametrize("robot_name", list(ARMS))
def test_path_figure_3d_labels_do_not_collide(robot_name, tmp_path, monkeypatch):
    """(f)'s tick labels and axis names do not overlap each other, nor (g)'s labels (the LWR's
    "0.75" ran into "-0.30"; a zoomed box put "z (m)" on (g)'s "y (m)")."""
    _, _, fig, rnd, ax_f, ax_g = _draw_path_figure(robot_name, tmp_path, monkeypatch)
    f_boxes = _boxes(_axis3d_texts(ax_f), rnd)
    assert len(f_boxes) >= 9  # three axes with ticks and names
    assert _overlapping(f_boxes) == []
    assert _overlapping(f_boxes, _boxes(_axis2d_texts(ax_g), rnd)) == []


LOCKED = {
    "kuka_lwr4": ("kuka_lwr4", {"lwr_a7": 0.0}),
    "ur10": (os.path.join(ROBOTS, "ur10.urdf"), {"wrist_3_joint": 0.0}),
    "z1": (os.path.join(ROBOTS, "z1.urdf"), {"joint6": 0.0}),
}


@pytest.mark.parametrize("robot_name", list(LOCKED))
def test_path_figure_legends_cover_no_title_and_no_other_panel(robot_name, tmp_path, monkeypatch):
    """Each legend under a panel stays off the next row's titles and off the other panels, with a
    rigid locked joint's longer entry too (the UR10's six names in one column of "(rigid, kj =
    inf)" ran over (d)'s title in the gallery's second example)."""
    source, locked = LOCKED[robot_name]
    robot = jaxstiff.Robot.from_urdf(source, locked=locked)
    res = _hand_made(robot)
    seen = _capture(monkeypatch, shape_path)
    shape_path.figure_shape_path(res, robot, tmp_path / "fig.png", "t", dpi=40)
    fig, rnd = seen["fig"], seen["renderer"]
    legends = [(a, a.get_legend()) for a in fig.axes if a.get_legend() is not None]
    assert len(legends) >= 2  # (a) and (b) at least
    titles = [(a.get_title(), a.title.get_window_extent(rnd)) for a in fig.axes if a.get_title()]
    for owner, leg in legends:
        box = leg.get_window_extent(rnd)
        hits = _overlapping([("legend of " + owner.get_title(), box)], titles)
        assert hits == [], hits
        for other in fig.axes:
            if other is owner or other.name == "3d" or not other.get_visible() or other.bbox.width < 2:
                continue
            frame = other.bbox
            inside = box.x0 + 1 < frame.x1 and frame.x0 + 1 < box.x1 and box.y0 + 1 < frame.y1 and frame.y0 + 1 < box.y1
            assert not inside, (owner.get_title(), other.get_title())


@pytest.mark.parametrize("robot_name", list(ARMS))
def test_path_figure_scale_bar_inside_g_and_no_band_under_the_title(robot_name, tmp_path, monkeypatch):
    _, _, fig, rnd, ax_f, ax_g = _draw_path_figure(robot_name, tmp_path, monkeypatch)
    bars = [a for a in ax_g.artists if type(a).__name__ == "AnchoredSizeBar"]
    assert len(bars) == 1
    box, frame = bars[0].get_window_extent(rnd), ax_g.bbox
    assert frame.x0 <= box.x0 and box.x1 <= frame.x1 and frame.y0 <= box.y0 and box.y1 <= frame.y1
    # the highest panel title sits right under the figure title: the band between them is less
    # than 4 % of the figure's height (the default layout left about 8 %)
    sup = next(t for t in fig.texts if t.get_text() == "t").get_window_extent(rnd)  # the figure title
    highest = max(a.title.get_window_extent(rnd).y1 for a in fig.axes if a.get_title())
    assert 0 < (sup.y0 - highest) / fig.bbox.height < 0.04


@pytest.mark.parametrize("robot_name", ["kuka_lwr4", "ur10"])
def test_path_figure_one_scale_that_the_drawing_keeps(robot_name, tmp_path, monkeypatch):
    """(f) and (g) state the same N/m per cm, and (g)'s major-axis lines have the length that scale
    gives the major axis of a numpy stiffness (FK differences), projected on xy."""
    robot, res, fig, rnd, ax_f, ax_g = _draw_path_figure(robot_name, tmp_path, monkeypatch)
    scales = [float(re.search(r"= ([0-9.e+]+) N/m", a.get_title()).group(1)) for a in (ax_f, ax_g)]
    assert scales[0] == scales[1]
    n_per_m = 100.0 * scales[1]
    majors = [ln for ln in ax_g.get_lines() if same_color(ln.get_color(), "C3")]
    assert len(majors) >= 3
    kj = res.kj_scaled[0]
    for ln in majors:
        x, y = ln.get_xdata(), ln.get_ydata()
        centre = np.array([x.mean(), y.mean()])
        k = int(np.argmin(np.linalg.norm(res.target[0][:, :2] - centre, axis=1)))
        keep = np.isfinite(kj[k])
        q = res.q[0, k]
        K = _numpy_translational_stiffness_free(robot, q, kj[k], keep)
        w, V = np.linalg.eigh(K)
        half = 0.5 * np.hypot(x[1] - x[0], y[1] - y[0])
        expect = w[-1] / n_per_m * np.linalg.norm(V[:2, -1])
        assert half == pytest.approx(expect, rel=2e-3, abs=1e-9)


def _numpy_translational_stiffness_free(robot, q, kj, keep):
    """K_T (3x3, task full) from a central-difference Jacobian of the numpy FK: the top-left block
    of (J C J^T)^-1 with C = diag(1/kj) over the joints with a spring (``keep``; a rigid locked
    joint, kj = inf, has none: SPEC section 1), independent of jaxstiff's kinematics."""
    T0 = numpy_fk(robot, q)
    h = 1e-6
    cols = []
    for i in np.flatnonzero(keep):
        dq = np.zeros(len(q))
        dq[i] = h
        Tp, Tm = numpy_fk(robot, q + dq), numpy_fk(robot, q - dq)
        dR = (Tp[:3, :3] - Tm[:3, :3]) / (2 * h) @ T0[:3, :3].T
        cols.append(np.r_[(Tp[:3, 3] - Tm[:3, 3]) / (2 * h), dR[2, 1], dR[0, 2], dR[1, 0]])
    J = np.array(cols).T
    C = J @ np.diag(1.0 / np.asarray(kj)[keep]) @ J.T
    return np.linalg.inv(C)[:3, :3]


@pytest.mark.parametrize("robot_name", ["kuka_lwr4", "ur10", "z1"])
def test_path_figure_ellipses_neither_needles_nor_piled(robot_name, tmp_path, monkeypatch):
    """The median drawn major axis (3-D, from (g)'s line and the numpy eigenvector's xy share) is
    between 0.5 and 2 times the median gap between the drawn waypoints: at the old largest-axis
    scale the ellipsoids were needles far apart, with (g) drawn twice as often they piled up."""
    robot, res, fig, rnd, ax_f, ax_g = _draw_path_figure(robot_name, tmp_path, monkeypatch)
    majors = [ln for ln in ax_g.get_lines() if same_color(ln.get_color(), "C3")]
    pts = res.target[0]
    full, drawn = [], []
    for ln in majors:
        x, y = ln.get_xdata(), ln.get_ydata()
        k = int(np.argmin(np.linalg.norm(pts[:, :2] - [x.mean(), y.mean()], axis=1)))
        keep = np.isfinite(res.kj_scaled[0, k])
        w, V = np.linalg.eigh(_numpy_translational_stiffness_free(robot, res.q[0, k], res.kj_scaled[0, k], keep))
        drawn.append(k)
        share = np.linalg.norm(V[:2, -1])
        if share > 0.3:  # the major axis not nearly vertical: its xy line tells its length
            full.append(np.hypot(x[1] - x[0], y[1] - y[0]) / share)
    gaps = np.linalg.norm(np.diff(pts[sorted(drawn)], axis=0), axis=1)
    assert full, "no major axis lies near the xy plane"
    assert 0.5 < np.median(full) / np.median(gaps) < 2.0, (full, gaps)


def test_fig_f_waypoints_equal_g_waypoints(tmp_path, monkeypatch):
    """(f) and (g) draw the same waypoints (every P//6-th by default): six surfaces, six outlines."""
    _, res, fig, rnd, ax_f, ax_g = _draw_path_figure("kuka_lwr4", tmp_path, monkeypatch, P=36)
    surfaces = [c for c in ax_f.collections if type(c).__name__ == "Poly3DCollection"]
    outlines = [ln for ln in ax_g.get_lines() if same_color(ln.get_color(), "C1")]
    assert len(surfaces) == len(outlines) == 6


# ------------------------------------------------------------------ seed 000 Fig. 6


@pytest.fixture(scope="module")
def criteria_figure(tmp_path_factory):
    """figure_criteria on closed-form f1, f2 (S0-9, S0-15) over the experiment's grid."""
    import matplotlib.pyplot as plt

    r, c = 5.0, 0.01
    alpha = np.linspace(-90.0, 90.0, 181)
    rho = np.linspace(1.05, 10.0, 180)
    A, P = np.meshgrid(alpha, rho, indexing="ij")
    F1 = (np.abs(A) + c) / (np.minimum(P, r) / r)
    F2 = (1 + np.abs(A)) * (1 + np.abs(r - P))
    seen = {}
    original = planar.save_figure

    def keep(fig, file, **kw):
        fig.canvas.draw()
        seen["fig"], seen["renderer"] = fig, fig.canvas.get_renderer()
        return original(fig, file, **kw)

    planar.save_figure = keep
    try:
        plots.figure_criteria(alpha, rho, F1, F2, r, c, tmp_path_factory.mktemp("fig6") / "fig6.png")
    finally:
        planar.save_figure = original
    yield seen, (A, P, F1, F2, r, c)
    plt.close(seen["fig"])


def test_fig6_contour_labels_apart_and_inside(criteria_figure):
    seen, _ = criteria_figure
    fig, rnd = seen["fig"], seen["renderer"]
    maps = [a for a in fig.axes if a.name != "3d" and a.get_label() != "<colorbar>" and a.collections]
    assert len(maps) == 2
    for ax in maps:
        labels = [t for t in ax.texts if t.get_text().strip()]
        assert len(labels) >= 4
        boxes = _boxes(labels, rnd)
        assert _overlapping(boxes) == []
        for _, b in boxes:
            assert ax.bbox.x0 <= b.x0 and b.x1 <= ax.bbox.x1 and ax.bbox.y0 <= b.y0 and b.y1 <= ax.bbox.y1
        legend = ax.get_legend().get_window_extent(rnd)
        assert _overlapping([("legend", legend)], boxes) == []


def _hidden_points_of_f1_line(ax, r, c, alpha_range=(-90.0, 90.0), rho_range=(1.05, 10.0), f=None, points=None):
    """How many of 101 points of f1's minimum line (alpha = 0, rho >= r, f1 = c) have f1's closed-form
    surface between them and the viewer: a ray from each point toward the eye (the view's elevation
    and azimuth, in the box's normalised coordinates, orthographic), marched until it leaves the
    grid, is hidden where the surface rises above it. ``f(alpha, rho)`` and ``points`` [(alpha,
    rho, value)]: another surface and its marked points (f2's minimum)."""
    f = f or (lambda a, p: (abs(a) + c) / (min(p, r) / r))
    points = points if points is not None else [(0.0, rho, c) for rho in np.linspace(r, rho_range[1], 101)]
    box = np.asarray(ax.get_box_aspect(), float)
    lims = np.array([ax.get_xlim3d(), ax.get_ylim3d(), ax.get_zlim3d()])
    el, az = np.radians(ax.elev), np.radians(ax.azim)
    eye = np.array([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)])
    tol = 1e-3 * (lims[2, 1] - lims[2, 0])
    hidden = 0
    for point in points:
        start = (np.array(point) - lims[:, 0]) / (lims[:, 1] - lims[:, 0]) * box
        for t in np.linspace(1e-3, 3.0, 3000):
            a, p, z = (start + t * eye) / box * (lims[:, 1] - lims[:, 0]) + lims[:, 0]
            if not (alpha_range[0] <= a <= alpha_range[1] and rho_range[0] <= p <= rho_range[1]):
                break
            if f(a, p) > z + tol:
                hidden += 1
                break
    return hidden


def test_fig6_f1_minimum_line_not_behind_the_surface(criteria_figure):
    """No part of f1's surface lies between its red minimum line and the viewer (at the former view,
    azim -60, 85 of the 101 points were behind the valley's near wall, the line drawn over it)."""
    seen, (_, _, _, _, r, c) = criteria_figure
    ax = next(a for a in seen["fig"].axes if a.name == "3d" and "f1" in a.get_title())
    assert _hidden_points_of_f1_line(ax, r, c) == 0
    elev, azim = ax.elev, ax.azim
    try:
        ax.view_init(elev=30, azim=-60)  # the check fails at the former view
        assert _hidden_points_of_f1_line(ax, r, c) > 50
    finally:
        ax.view_init(elev=elev, azim=azim)


def test_fig6_f2_minimum_not_behind_the_surface(criteria_figure):
    """f2's minimum (0, r, 1) is drawn on top of the surface (computed_zorder off): right only if no
    part of the surface lies between it and the viewer."""
    seen, (_, _, _, _, r, c) = criteria_figure
    ax = next(a for a in seen["fig"].axes if a.name == "3d" and "f2" in a.get_title())
    assert ax.computed_zorder is False
    f2 = lambda a, p: (1 + abs(a)) * (1 + abs(r - p))  # noqa: E731
    assert _hidden_points_of_f1_line(ax, r, c, f=f2, points=[(0.0, r, 1.0)]) == 0
    elev, azim = ax.elev, ax.azim
    try:
        ax.view_init(elev=30, azim=-60)  # the former view: the funnel's near wall is in front of it
        assert _hidden_points_of_f1_line(ax, r, c, f=f2, points=[(0.0, r, 1.0)]) == 1
    finally:
        ax.view_init(elev=elev, azim=azim)


# ------------------------------------------------------------------ CSC propositions


@pytest.fixture(scope="module")
def props():
    sys.path.insert(0, os.path.join(ROOT, "experiments"))  # the script imports csc_cases from its own folder
    try:
        yield load_script("experiments/csc_propositions.py")
    finally:
        sys.path.remove(os.path.join(ROOT, "experiments"))


def _capture_module(monkeypatch):
    seen = {}
    original = plots.save_figure

    def keep(fig, file, **kw):
        fig.canvas.draw()
        seen["fig"], seen["renderer"] = fig, fig.canvas.get_renderer()
        return original(fig, file, **kw)

    monkeypatch.setattr(plots, "save_figure", keep)
    return seen


def test_prop1_legend_off_the_data(props, tmp_path, monkeypatch):
    """High bars (up to 0.95 of the axis): the legend lies outside the axes, so it covers none."""
    p1 = [
        {
            "case": name,
            "m": 2,
            "n_nonzero_columns": 3,
            "per_beta": {"0": {"share_min": 0.9, "share_mean": 0.95}, "8": {"share_min": 0.7, "share_mean": 0.8}},
            "direct_minimum_K_xd_of_first_step": {"polished_share": share},
            "aligned_floor_share": 0.9,
            **({"self_motion_scan": {"share_min": 0.85}} if i == 0 else {}),
        }
        for i, (name, share) in enumerate((("a", 0.0), ("b", 0.9), ("c", 0.6)))
    ]
    seen = _capture_module(monkeypatch)
    props.figure_prop1(p1, str(tmp_path / "p1.png"))
    fig, rnd = seen["fig"], seen["renderer"]
    ax = fig.axes[0]
    legend = (fig.legends or [ax.get_legend()])[0].get_window_extent(rnd)
    data = [("bar", p.get_window_extent(rnd)) for p in ax.patches] + [
        ("marker", c.get_window_extent(rnd)) for c in ax.collections
    ]
    assert _overlapping([("legend", legend)], data) == []
    assert legend.y1 <= ax.bbox.y0 or legend.x0 >= ax.bbox.x1  # outside the axes, below or right
    assert legend.y0 >= 0 and legend.x0 >= 0 and legend.x1 <= fig.bbox.x1  # and on the figure


def test_prop2_labels_apart(props, tmp_path, monkeypatch):
    """beta = 10 and beta = 20 at nearly the same point (as on the LWR) get labels that overlap
    neither each other nor any other run's marker."""
    rankings = {
        "planar 4R line": {
            "mean_u": {"0": 11100, "1": 9800, "2": 8450, "4": 6350, "8": 4650},
            "mean_frobenius": {"0": 1927, "1": 1947, "2": 1922, "4": 1688, "8": 1335},
        },
        "LWR default path": {
            "mean_u": {"0": 799, "2": 764, "5": 682, "10": 625, "20": 607},
            "mean_frobenius": {"0": 3217, "2": 1927, "5": 2216, "10": 2181, "20": 2127},
        },
    }
    seen = _capture_module(monkeypatch)
    props.figure_prop2_rankings(rankings, str(tmp_path / "p2.png"))
    fig, rnd = seen["fig"], seen["renderer"]
    for ax, rk in zip(fig.axes, rankings.values(), strict=True):
        boxes = _boxes([t for t in ax.texts if t.get_text().startswith("beta")], rnd)
        assert len(boxes) == len(rk["mean_u"])
        assert _overlapping(boxes) == []
        pts = ax.transData.transform(
            np.column_stack([list(rk["mean_u"].values()), list(rk["mean_frobenius"].values())])
        )
        for (text, b), own in zip(boxes, pts, strict=True):
            for p in pts:
                if p is not own and not np.array_equal(p, own):
                    assert not (b.x0 < p[0] < b.x1 and b.y0 < p[1] < b.y1), (text, p)


def test_label_points_without_room_to_spare():
    """A tight cluster of five points: the labels end up pairwise apart and inside the axes."""
    plt = plots.pyplot()
    fig, ax = plt.subplots(figsize=(4, 3), dpi=80)
    xs, ys = [0.0, 0.1, 0.2, 0.05, 0.15], [0.0, 0.02, 0.0, 0.2, 0.2]
    ax.plot(xs, ys, "o")
    ax.set_xlim(-1, 1.2)
    ax.set_ylim(-1, 1.2)
    anns = label_points(ax, xs, ys, [f"beta = {i}" for i in range(5)])
    fig.canvas.draw()
    rnd = fig.canvas.get_renderer()
    boxes = _boxes(anns, rnd)
    assert len(boxes) == 5 and _overlapping(boxes) == []
    plt.close(fig)


# ------------------------------------------------------------------ planar 4R self-motion


@pytest.mark.slow
def test_planar4r_self_motion_panels_one_size_one_range_colorbar_beside(tmp_path, monkeypatch):
    sys.path.insert(0, os.path.join(ROOT, "experiments"))
    try:
        script = load_script("experiments/csc_planar4r_line.py")
        figs = {}
        original = plots.save_figure

        def keep(fig, file, **kw):
            fig.canvas.draw()
            figs[os.path.basename(str(file))] = fig
            return original(fig, file, **kw)

        monkeypatch.setattr(plots, "save_figure", keep)
        assert script.main(["--out", str(tmp_path)]) == 0
    finally:
        sys.path.remove(os.path.join(ROOT, "experiments"))
    fig = figs["self_motion.png"]
    panels = [a for a in fig.axes if a.get_label() != "<colorbar>" and a.get_xlabel()]
    cbar = [c for a in fig.axes for c in [a, *a.child_axes] if c.get_label() == "<colorbar>" or c not in fig.axes]
    assert len(panels) == 2 and len(cbar) == 1
    a, b = (p.get_window_extent() for p in panels)
    assert a.width == pytest.approx(b.width, rel=0.01) and a.height == pytest.approx(b.height, rel=0.01)
    assert panels[0].get_xlim() == panels[1].get_xlim() and panels[0].get_ylim() == panels[1].get_ylim()
    right = max(panels, key=lambda p: p.get_window_extent().x0).get_window_extent()
    c = cbar[0].get_window_extent()
    assert 0 <= c.x0 - right.x1 < 0.05 * fig.bbox.width  # beside the right panel
    assert c.height == pytest.approx(right.height, rel=0.02)


def test_fig6_no_band_under_the_title(criteria_figure):
    """The highest panel title sits right under the figure title (the default layout left an empty
    band of about 6 % of the figure's height)."""
    seen, _ = criteria_figure
    fig, rnd = seen["fig"], seen["renderer"]
    sup = next(t for t in fig.texts if t.get_text().startswith("Seed 000 Fig. 6")).get_window_extent(rnd)
    highest = max(a.title.get_window_extent(rnd).y1 for a in fig.axes if a.get_title())
    assert 0 < (sup.y0 - highest) / fig.bbox.height < 0.03
