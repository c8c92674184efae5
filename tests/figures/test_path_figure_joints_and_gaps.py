"""The seven-panel path figure (``figure_shape_path``, what ``jaxstiff plot`` draws) for any number
of joints and with waypoints left out:

* the legends under (a) joint stiffness and (b) joint positions overlap no other panel, no title
  and each other, for 1 to 12 joints with long names (a Fetch's eight joints, one of them
  prismatic, were listed in one column over (d)'s title and into (e));
* a usable waypoint between unusable ones (NaN in the panels) is still drawn: a marker in (a)
  and (b), where a line through one point drew nothing (an xArm6 result with 19 of its 20
  waypoints unreachable showed empty joint panels on an axis of -0.04..0.04); the waypoint axes
  span the whole path; (d)'s limits come from the usable values; the title says how many
  waypoints are unusable and left out.

Hand-made results on generated serial URDFs (no solver run); judged by the renderer's extents and
the drawn Line2D data, never by pixels.
"""

from __future__ import annotations

import types

import numpy as np
import pytest
from helpers import numpy_fk
from matplotlib.colors import to_rgba

import jaxstiff
from jaxstiff.plots import _shape_path as shape_path
from jaxstiff.plots import pyplot

FETCH = [
    "torso_lift_joint", "shoulder_pan_joint", "shoulder_lift_joint", "upperarm_roll_joint",
    "elbow_flex_joint", "forearm_roll_joint", "wrist_flex_joint", "wrist_roll_joint",
]  # fmt: skip


def _serial_urdf(folder, names, prismatic=()):
    """A serial URDF with joints ``names`` (revolute, except those in ``prismatic``), axes z, y, x
    in turn, links 0.12 m apart; returns the Robot."""
    axes = ("0 0 1", "0 1 0", "1 0 0")
    links = "".join(f'<link name="l{i}"/>' for i in range(len(names) + 1))
    joints = []
    for i, name in enumerate(names):
        kind = "prismatic" if name in prismatic else "revolute"
        lim = 'lower="0" upper="0.4"' if kind == "prismatic" else 'lower="-2.9" upper="2.9"'
        joints.append(
            f'<joint name="{name}" type="{kind}"><parent link="l{i}"/><child link="l{i + 1}"/>'
            f'<origin xyz="0 0 0.12"/><axis xyz="{axes[i % 3]}"/>'
            f'<limit {lim} effort="1" velocity="1"/></joint>'
        )
    file = folder / "serial.urdf"
    file.write_text(f'<?xml version="1.0"?><robot name="serial">{links}{"".join(joints)}</robot>')
    return jaxstiff.Robot.from_urdf(str(file))


def _result(robot, P=30, seed=0, status=None):
    """A one-path result that the figure reads: a smooth joint motion inside the limits, its TCP
    trace as the path (numpy FK), fixed random joint stiffnesses; no solve."""
    rng = np.random.default_rng(seed)
    n = robot.n
    lo, hi = robot.lower + 0.1 * (robot.upper - robot.lower), robot.upper - 0.1 * (robot.upper - robot.lower)
    qa = rng.uniform(lo, hi)
    qb = np.clip(qa + rng.uniform(-0.3, 0.3, n), lo, hi)
    s = 0.5 - 0.5 * np.cos(np.linspace(0, np.pi, P))
    q = qa + s[:, None] * (qb - qa)
    pts = np.stack([numpy_fk(robot, qi)[:3, 3] for qi in q])
    # a path of a few cm at least (a joint motion that hardly moves the TCP gives no tangent)
    pts = pts + np.c_[np.linspace(0, 0.1, P), np.zeros(P), np.zeros(P)]
    tang = np.gradient(pts, axis=0)
    kj = np.clip(rng.uniform(5, 95, (1, n)) + np.linspace(0, 5, P)[:, None], 1, 100)
    return types.SimpleNamespace(
        P=P, n=n, B=1, joint_names=np.array(robot.joint_names),
        meta={"ratio": 5.0, "criterion": "f2", "task": "full"},
        q=q[None], kj=kj[None], kj_scaled=3 * kj[None], cms=np.linspace(2.0, 4.0, P)[None],
        target=pts[None], direction=(tang / np.linalg.norm(tang, axis=1, keepdims=True))[None], position=pts[None],
        criterion=np.linspace(1.5, 1.2, P)[None], alpha_deg=np.linspace(0, 3, P)[None],
        ratio=np.linspace(3, 6, P)[None],
        status=np.zeros((1, P), int) if status is None else np.asarray(status)[None],
    )  # fmt: skip


@pytest.fixture
def drawn(monkeypatch):
    """``draw(res, robot, tmp_path)``: the figure ``figure_shape_path`` would save, drawn and kept
    open (not written), with its renderer; closed afterwards."""
    figs = []

    def keep(fig, file, **kw):
        fig.canvas.draw()
        figs.append(fig)
        return str(file)

    monkeypatch.setattr(shape_path, "save_figure", keep)

    def draw(res, robot, tmp_path, title="t"):
        shape_path.figure_shape_path(res, robot, tmp_path / "fig.png", title, dpi=80)
        fig = figs[-1]
        return fig, fig.canvas.get_renderer()

    yield draw
    for fig in figs:
        pyplot().close(fig)


def _panel(fig, prefix):
    """The axes whose title starts with ``prefix``, and the twin axes that share its place."""
    (ax,) = [a for a in fig.axes if a.get_title().startswith(prefix)]
    return ax, [a for a in fig.axes if a is not ax and a.bbox.bounds == ax.bbox.bounds]


def _overlap(p, q, tol=0.5):
    """Do the display boxes ``p`` and ``q`` overlap by more than ``tol`` pixels each way."""
    return p.x0 + tol < q.x1 and q.x0 + tol < p.x1 and p.y0 + tol < q.y1 and q.y0 + tol < p.y1


def _legend_clashes(fig, renderer):
    """What the legends of (a) and (b) overlap: another axes (any panel, twin or 3-D, the own one
    too: the legend lies below it), a title (a panel's or the figure's), the own panel's x tick
    labels and name, the other joint legend, or the figure's edge."""
    found = []
    titles = [(a.get_title(), a.title.get_window_extent(renderer)) for a in fig.axes if a.get_title()]
    titles += [("figure title", t.get_window_extent(renderer)) for t in fig.texts if t.get_text()]
    legends = {}
    for prefix in ("(a)", "(b)"):
        ax, _ = _panel(fig, prefix)
        leg = ax.get_legend()
        assert leg is not None, prefix
        legends[prefix] = (ax, leg.get_window_extent(renderer))
    for prefix, (ax, box) in legends.items():
        if box.x0 < fig.bbox.x0 - 0.5 or box.x1 > fig.bbox.x1 + 0.5 or box.y0 < fig.bbox.y0 - 0.5:
            found.append((prefix, "off the figure"))
        for other in fig.axes:
            if other.get_visible() and _overlap(box, other.bbox):
                found.append((prefix, "axes " + (other.get_title() or "twin of " + _owner_title(fig, other))))
        found += [(prefix, "title " + name) for name, t in titles if _overlap(box, t)]
        x_axis = ax.xaxis.get_tightbbox(renderer)
        if _overlap(box, x_axis):
            found.append((prefix, "its own x tick labels or name"))
    if _overlap(legends["(a)"][1], legends["(b)"][1]):
        found.append(("(a)", "legend of (b)"))
    return found


def _owner_title(fig, twin):
    return next((a.get_title() for a in fig.axes if a.get_title() and a.bbox.bounds == twin.bbox.bounds), "?")


NAMES = {
    "kinova": lambda n: [f"j2s6s200_joint_{i + 1}" for i in range(n)],
    "talos": lambda n: [f"arm_left_{i + 1}_joint" for i in range(n)],
}


@pytest.mark.parametrize(
    ("style", "n", "prismatic"),
    [
        ("fetch", 8, ("torso_lift_joint",)),  # the reported case: 8 joints, the first prismatic
        ("kinova", 1, ()),
        ("talos", 5, ()),
        ("kinova", 12, ()),
        ("talos", 12, ("arm_left_1_joint",)),  # 12 long names, one with "(prismatic, mm, right axis)"
    ],
)
def test_joint_legends_overlap_no_panel_and_no_title(drawn, tmp_path, style, n, prismatic):
    """The legends of (a) and (b) lie clear of every axes, title, x axis and each other, in a font
    of 6 pt at least, for 1 to 12 joints with long names and prismatic joints' longer entries; each
    joint has a colour of its own (tab10 drew joints 10 to 12 in one)."""
    names = FETCH if style == "fetch" else NAMES[style](n)
    robot = _serial_urdf(tmp_path, names, prismatic)
    fig, rnd = drawn(_result(robot), robot, tmp_path)
    assert _legend_clashes(fig, rnd) == []
    for prefix in ("(a)", "(b)"):
        leg = _panel(fig, prefix)[0].get_legend()
        assert [t.get_text().split(" ")[0] for t in leg.get_texts()] == names  # every joint, in chain order
        assert min(t.get_fontsize() for t in leg.get_texts()) >= 6.0, prefix  # still readable
        colours = {tuple(np.round(to_rgba(h.get_color()), 6)) for h in leg.legend_handles}
        assert len(colours) == len(names), prefix


def _marked_points(axes):
    """``{(x, y)}`` of the points drawn with a visible marker on ``axes`` (lines of any style)."""
    out = set()
    for ax in axes:
        for ln in ax.get_lines():
            if ln.get_visible() and ln.get_marker() not in (None, "", " ", "None", "none") and ln.get_markersize() > 0:
                x, y = np.asarray(ln.get_xdata(), float), np.asarray(ln.get_ydata(), float)
                out |= {(float(a), round(float(b), 9)) for a, b in zip(x, y, strict=True) if np.isfinite(b)}
    return out


def test_one_usable_waypoint_is_drawn_and_the_title_counts_the_unusable(drawn, tmp_path):
    """An xArm6-like result: waypoint 0 usable, the other 19 unreachable (status 3). (a) and (b)
    draw a marker at waypoint 0 for every joint (kj in Nm/rad, q in deg), the waypoint axis of
    (a)-(e) spans 0..19, and the figure's title says 19 of 20 waypoints are unusable."""
    names = [f"joint{i + 1}" for i in range(6)]
    robot = _serial_urdf(tmp_path, names)
    P = 20
    res = _result(robot, P=P, status=np.r_[0, np.full(P - 1, 3)])
    fig, rnd = drawn(res, robot, tmp_path, title="xarm6_pgd.npz: path 0")
    ax_a, twins_a = _panel(fig, "(a)")
    ax_b, twins_b = _panel(fig, "(b)")
    marked_a, marked_b = _marked_points([ax_a, *twins_a]), _marked_points([ax_b, *twins_b])
    for i in range(robot.n):
        assert (0.0, round(float(res.kj[0, 0, i]), 9)) in marked_a, names[i]
        assert (0.0, round(float(np.degrees(res.q[0, 0, i])), 9)) in marked_b, names[i]
    for prefix in ("(a)", "(b)", "(c)", "(d)", "(e)"):
        ax, _ = _panel(fig, prefix)
        lo, hi = ax.get_xlim()
        assert lo < 0 and hi > P - 1, (prefix, lo, hi)  # the whole path, not -0.04..0.04 about waypoint 0
        y0, y1 = sorted(ax.get_ylim())
        for x, y in _marked_points([ax]):  # every drawn point inside its panel's limits
            assert lo <= x <= hi and y0 <= y <= y1, (prefix, x, y)
    sup = " ".join(t.get_text() for t in fig.texts)
    assert "xarm6_pgd.npz: path 0" in sup
    assert "19 of 20 waypoints unusable" in sup and "19 unreachable" in sup
    assert _legend_clashes(fig, rnd) == []


def test_isolated_usable_waypoints_get_markers_and_no_others(drawn, tmp_path):
    """Usable waypoints 0, 5-7 and 12 of 15: 0 and 12 have no usable neighbour and are marked in
    (a) and (b); 5-7 are joined by the line (no marker needed); a path without gaps has no
    markers in (a) and (b) at all, and its title no note."""
    robot = _serial_urdf(tmp_path, NAMES["talos"](4))
    P = 15
    ok = np.zeros(P, bool)
    ok[[0, 5, 6, 7, 12]] = True
    res = _result(robot, P=P, status=np.where(ok, 0, np.where(np.arange(P) < 10, 3, 5)))
    fig, _ = drawn(res, robot, tmp_path)
    ax_a, _ = _panel(fig, "(a)")
    xs = {x for x, _ in _marked_points([ax_a])}
    assert xs == {0.0, 12.0}
    sup = " ".join(t.get_text() for t in fig.texts)
    assert "10 of 15 waypoints unusable" in sup and "6 unreachable" in sup and "4 not run" in sup

    fig, _ = drawn(_result(robot, P=P), robot, tmp_path)
    assert _marked_points([_panel(fig, "(a)")[0]]) == set()
    assert _marked_points([_panel(fig, "(b)")[0]]) == set()
    assert [t.get_text() for t in fig.texts if t.get_text()] == ["t"]


def test_alpha_and_rho_limits_come_from_the_usable_waypoints(drawn, tmp_path):
    """(d): alpha of 5 deg and rho of 14 at the usable waypoints, the rest unusable (NaN in the
    panel): the axes reach past them (a NaN maximum kept alpha's axis at 1.5 deg and rho's at 2 r,
    the usable points above the plot)."""
    robot = _serial_urdf(tmp_path, NAMES["kinova"](6))
    P = 10
    res = _result(robot, P=P, status=np.r_[3, 0, 0, np.full(P - 3, 3)])
    res.alpha_deg = np.full((1, P), 5.0)
    res.ratio = np.full((1, P), 14.0)
    fig, _ = drawn(res, robot, tmp_path)
    ax_d, (twin,) = _panel(fig, "(d)")
    assert ax_d.get_ylim()[1] >= 5.0 and twin.get_ylim()[1] >= 14.0
