"""The seven-panel and turning figures of a robot with prismatic joints: a prismatic joint's value
is a length (drawn in mm, on its own axis), its stiffness N/m and its rate limit a length, never
converted as if they were radians; a robot without one keeps its labels; the x tick labels of the
xy projection stay apart on a path narrow in x.

References are independent of the code under test: the values the hand-made results hold,
converted here (``1000 * q``, ``q * 180 / pi``), the drawn curves read back from the figure's
Line2D objects (the figure is caught before it is saved, nothing is rendered but panel (g)), and the
tick labels' extents on the canvas."""

from __future__ import annotations

import math
import types

import numpy as np
import pytest
from hand_made_results import arc_result
from helpers import DATA_DIR

import jaxstiff
from jaxstiff.plots import _shape_path as shape_path
from jaxstiff.plots import pyplot

BRANCHED = str(DATA_DIR / "branched_tree.urdf")  # j1 revolute, j2 prismatic, j3 continuous, j4 revolute

GANTRY = """<?xml version="1.0"?>
<robot name="gantry">
  <link name="base"/><link name="a"/><link name="b"/><link name="tool"/>
  <joint name="jx" type="prismatic"><parent link="base"/><child link="a"/>
    <axis xyz="1 0 0"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
  <joint name="jy" type="prismatic"><parent link="a"/><child link="b"/>
    <axis xyz="0 1 0"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
  <joint name="jz" type="prismatic"><parent link="b"/><child link="tool"/>
    <axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
</robot>
"""


@pytest.fixture
def caught(monkeypatch):
    """The figures the plot functions would save, kept open (not rendered), closed afterwards."""
    figs = []

    def keep(fig, file, **kw):
        figs.append(fig)
        return str(file)

    monkeypatch.setattr(shape_path, "save_figure", keep)
    yield figs
    for fig in figs:
        pyplot().close(fig)


def _result(robot, q, kj):
    """A hand-made one-path result along a line in y (narrow in x): no solver run."""
    P, n = q.shape
    pts = np.c_[np.full(P, 0.58), np.linspace(-0.33, -0.27, P), np.full(P, 0.75)]
    d = np.tile([0.0, 1.0, 0.0], (P, 1))
    return types.SimpleNamespace(
        P=P,
        n=n,
        B=1,
        joint_names=np.array(robot.joint_names),
        meta={"ratio": 5.0, "criterion": "f2", "c": 0.01, "task": "full"},
        q=q[None],
        kj=kj[None],
        kj_scaled=2 * kj[None],
        cms=np.full((1, P), 2.0),
        target=pts[None],
        direction=d[None],
        criterion=np.linspace(12.0, 11.0, P)[None],
        alpha_deg=np.linspace(0, 3, P)[None],
        ratio=np.linspace(3, 6, P)[None],
    )


def _panel(fig, title):
    """The axes titled ``title`` and the twin axes that share its place (a right y axis)."""
    (ax,) = [a for a in fig.axes if a.get_title().startswith(title)]
    twins = [a for a in fig.axes if a is not ax and a.get_position().bounds == ax.get_position().bounds]
    return ax, twins


def _curves(axes):
    """{legend label: y data} of the lines drawn in ``axes``."""
    return {ln.get_label(): np.asarray(ln.get_ydata(), float) for a in axes for ln in a.get_lines()}


def _legend_texts(ax):
    return [t.get_text() for t in ax.get_legend().get_texts()]


def test_prismatic_joint_is_drawn_in_mm_on_its_own_axis_and_its_stiffness_in_n_per_m(caught, tmp_path):
    robot = jaxstiff.Robot.from_urdf(BRANCHED, tip_link="tool")
    assert robot.prismatic.tolist() == [False, True, False, False]
    P = 6
    q = np.c_[np.linspace(0.1, 0.3, P), np.linspace(0.05, 0.1, P), np.full(P, 0.4), np.linspace(-0.5, 0.2, P)]
    kj = np.c_[np.full(P, 50.0), np.linspace(20.0, 30.0, P), np.full(P, 60.0), np.full(P, 70.0)]
    shape_path.figure_shape_path(_result(robot, q, kj), robot, tmp_path / "fig.png", "t", every=2)
    (fig,) = caught

    ax, twins = _panel(fig, "(b) joint positions")
    assert len(twins) == 1, "the prismatic joint has an axis of its own"
    assert ax.get_ylabel() == "revolute joint position q (deg)"
    assert "mm" in twins[0].get_ylabel() and "prismatic" in twins[0].get_ylabel()
    left, right = _curves([ax]), _curves(twins)
    np.testing.assert_allclose(right["j2 (prismatic, mm, right axis)"], 1000.0 * q[:, 1], rtol=1e-12)
    for i in (0, 2, 3):  # the revolute (and continuous) joints in degrees, on the left
        np.testing.assert_allclose(left[f"j{i + 1}"], q[:, i] * 180.0 / math.pi, rtol=1e-12)
    assert _legend_texts(ax) == ["j1", "j2 (prismatic, mm, right axis)", "j3", "j4"]  # every joint, chain order

    ax, twins = _panel(fig, "(a) joint stiffness")
    assert twins == []
    assert "Nm/rad" in ax.get_ylabel() and "N/m for prismatic joints" in ax.get_ylabel()
    assert _legend_texts(ax) == ["j1", "j2 (prismatic, N/m)", "j3", "j4"]
    np.testing.assert_allclose(_curves([ax])["j2 (prismatic, N/m)"], kj[:, 1], rtol=1e-12)


def test_robot_without_prismatic_joints_keeps_its_labels(caught, tmp_path):
    robot = jaxstiff.Robot.from_urdf("planar_3r")
    P = 5
    q = np.c_[np.linspace(0.1, 0.3, P), np.full(P, 0.5), np.linspace(-0.5, 0.2, P)]
    kj = np.c_[np.full(P, 50.0), np.linspace(20.0, 30.0, P), np.full(P, 60.0)]
    shape_path.figure_shape_path(_result(robot, q, kj), robot, tmp_path / "fig.png", "t", every=2)
    (fig,) = caught
    ax, twins = _panel(fig, "(b) joint positions")
    assert twins == [] and ax.get_ylabel() == "joint position q (deg)"
    assert _legend_texts(ax) == list(robot.joint_names)
    for i, name in enumerate(robot.joint_names):
        np.testing.assert_allclose(_curves([ax])[name], q[:, i] * 180.0 / math.pi, rtol=1e-12)
    ax, _ = _panel(fig, "(a) joint stiffness")
    assert ax.get_ylabel() == "joint stiffness k_j (Nm/rad)"
    assert _legend_texts(ax) == list(robot.joint_names)


def test_all_prismatic_robot_is_drawn_in_mm_and_n_per_m(caught, tmp_path):
    urdf = tmp_path / "gantry.urdf"
    urdf.write_text(GANTRY)
    robot = jaxstiff.Robot.from_urdf(str(urdf))
    assert robot.prismatic.all()
    P = 5
    q = np.c_[np.full(P, 0.58), np.linspace(-0.33, -0.27, P), np.full(P, 0.75)]
    kj = np.c_[np.full(P, 50.0), np.linspace(20.0, 30.0, P), np.full(P, 10.0)]
    shape_path.figure_shape_path(_result(robot, q, kj), robot, tmp_path / "fig.png", "t", every=2)
    (fig,) = caught
    ax, twins = _panel(fig, "(b) joint positions")
    assert twins == [] and ax.get_ylabel() == "joint position q (mm)"
    np.testing.assert_allclose(_curves([ax])["jy"], 1000.0 * q[:, 1], rtol=1e-12)
    ax, _ = _panel(fig, "(a) joint stiffness")
    assert ax.get_ylabel() == "joint stiffness k_j (N/m)"


def test_xy_projection_x_tick_labels_do_not_overlap_on_a_narrow_path(caught, tmp_path):
    """A path along y: panel (g) is narrow at equal aspect; its x tick labels ran into each other
    ("0.490.500.51")."""
    robot = jaxstiff.Robot.from_urdf(BRANCHED, tip_link="tool")
    P = 6
    q = np.c_[np.linspace(0.1, 0.3, P), np.linspace(0.05, 0.1, P), np.full(P, 0.4), np.linspace(-0.5, 0.2, P)]
    kj = np.c_[np.full(P, 50.0), np.linspace(20.0, 30.0, P), np.full(P, 60.0), np.full(P, 70.0)]
    shape_path.figure_shape_path(_result(robot, q, kj), robot, tmp_path / "fig.png", "t", every=2)
    (fig,) = caught
    fig.set_dpi(110)
    fig.canvas.draw()
    ax, _ = _panel(fig, "(g) projection on the xy plane")
    lo, hi = sorted(ax.get_xlim())
    labels = [t for t in ax.get_xticklabels() if t.get_text() and lo <= t.get_position()[0] <= hi]
    assert len(labels) >= 1
    boxes = sorted((t.get_window_extent() for t in labels), key=lambda bb: bb.x0)
    for a, b in zip(boxes, boxes[1:], strict=False):
        assert a.x1 < b.x0, f"x tick labels overlap: {[t.get_text() for t in labels]}"


def test_turning_figure_compares_the_turning_with_the_revolute_rate_limit_only(caught, tmp_path):
    """The prismatic joint's rate limit 0.05 m is not 2.86 deg: the dq line sits at the revolute
    joints' 2 deg, and the legends give the prismatic limits in mm and N/m."""
    robot = jaxstiff.Robot.from_urdf(BRANCHED, tip_link="tool")
    P, n = 10, robot.n
    dq = [math.radians(2.0), 0.05, math.radians(2.0), math.radians(1.0)]
    dk = [5.0, 7.0, 5.0, 5.0]
    q = np.tile([0.1, 0.2, 0.3, 0.4], (P, 1)) + np.linspace(0, 0.01, P)[:, None]
    kj = np.full((P, n), 50.0)
    path = jaxstiff.paths.arc([0.0, 0.0, 0.3], 0.6, 0.0, 27.0, n=P)  # turns 3 deg per waypoint
    res = arc_result(q, kj, path, dq, dk, np.full(P, 1e-6))
    shape_path.figure_turning(res, robot, tmp_path / "turning.png", "t")
    (fig,) = caught
    ax, twins = _panel(fig, "(a) orientation error alpha")
    (limit,) = [ln for ln in twins[0].get_lines() if "rate limit dq" in ln.get_label()]
    np.testing.assert_allclose(limit.get_ydata(), 2.0, rtol=1e-12)
    assert limit.get_label().startswith("revolute joint rate limit dq = 2 deg per waypoint (a joint angle")
    ax, _ = _panel(fig, "(c) joints held by the rate limits")
    texts = _legend_texts(ax)
    assert "joints at the rate limit dq =\n2 deg (revolute), 50 mm (prismatic)" in texts
    assert "joint stiffnesses at the rate limit dk =\n5 Nm/rad (revolute), 7 N/m (prismatic)" in texts
    assert "waypoints the tangent reaches turning faster than 2 deg" in texts
    assert all("2.86" not in t for t in texts)
