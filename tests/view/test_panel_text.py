"""What the viewer's panel and scene say (a new user's report): the legend names every drawn thing
and no TCP triad's green can pass for the path, the scale is per cm of the scene (not of the
screen), the waypoint number says it is 0-based and how many there are, the label over the TCP
stays clear of the panel, and "all ellipsoids" too large for the path hints at --scale."""

from __future__ import annotations

import json
import math
import re
import socket

import numpy as np
import pytest
from viewer_files import make_shape_result

from jaxstiff.view._data import load_view_data

viser = pytest.importorskip("viser")

PANEL_FROM = 850 / 1200  # the page's panel covers x >= 858 of a 1200 px page (--png's default)
CHAR_PX = 6.5  # width of a character of viser's label, px (measured: 34 characters, 211 px)


def _port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


@pytest.fixture
def scene_of():
    """``scene_of(file)``: the Scene of a result file in a viser server, stopped after the test."""
    from jaxstiff.view._scene import Scene

    servers = []

    def make(file: str, **kw):
        server = viser.ViserServer(host="127.0.0.1", port=_port(), verbose=False)
        servers.append(server)
        return Scene(server, load_view_data(file), **kw)

    yield make
    for s in servers:
        s.stop()


def test_legend_names_every_drawn_thing(shape_file, scene_of) -> None:
    from jaxstiff.view._app import header_markdown
    from jaxstiff.view._scene import COLORS

    scene = scene_of(shape_file)
    text = header_markdown(scene.data, scene)
    for words in (
        "Orange: K_T after CMS",
        "green line: path",
        "purple strokes: desired direction",
        "blue: links",
        "dark blue balls: joints",
        "red sticks: joint axes",
        "black ball and stick: the TCP and its z axis",
        "pale orange: all ellipsoids",
        "floor grid",
    ):
        assert words in text, (words, text)
    # the TCP is not viser's RGB frame (its red, green and blue axes read as a joint axis, the path, a link)
    assert not any(isinstance(h, viser.FrameHandle) for h in scene.handles.values())
    assert tuple(scene.handles["tcp"].color) == COLORS["tcp"] == tuple(scene.handles["tcp_z"].color)
    # the path is the only green thing drawn
    green = [k for k, (r, g, b) in COLORS.items() if g > r + 40 and g > b + 20]
    assert green == ["path"], green


def test_scale_is_per_cm_of_the_scene(shape_file, scene_of) -> None:
    from jaxstiff.view._app import header_markdown

    scene = scene_of(shape_file)
    text = header_markdown(scene.data, scene)
    assert "on screen =" not in text and "1 cm on screen" not in text
    assert f"1 cm in the scene (measured like the arm, not on screen) = {scene.n_per_m / 100:.4g} N/m" in text
    assert "floor grid cells 10 cm" in text  # the arm is 1.18 m long: cells of 10 cm


def test_waypoint_number_is_0_based_of_the_count(batch_file, tmp_path) -> None:
    from jaxstiff.view._app import panel_markdown
    from jaxstiff.view._static import write_html

    data = load_view_data(batch_file)  # 3 paths of 6 waypoints
    assert panel_markdown(data, 0, 5).startswith("**waypoint 5 (0-based) of 6**, path 0")
    assert panel_markdown(data, 2, 0).startswith("**waypoint 0 (0-based) of 6**, path 2")
    text = open(write_html(data, str(tmp_path / "p.html")), encoding="utf-8").read()
    m = re.search(r'<script type="application/json" id="jaxstiff-view-data">(.*?)</script>', text)
    assert m is not None
    page = json.loads(m.group(1))
    assert "<b>waypoint 5 (0-based) of 6</b>" in page["panel"][0][5]


def _page_x(scene, point: np.ndarray) -> float:
    """Where ``point`` is on the page from the scene's starting camera, as a fraction of the page's
    width (0 left, 1 right; viser's 75 degree vertical field of view, a 1200 x 800 page)."""
    fwd = scene.look_at - scene.position
    fwd = fwd / np.linalg.norm(fwd)
    right = np.cross(fwd, [0.0, 0.0, 1.0])
    right /= np.linalg.norm(right)
    rel = point - scene.position
    return 0.5 + 0.5 * float(rel @ right) / (float(rel @ fwd) * math.tan(math.radians(37.5)) * 1.5)


def _label_span(scene) -> tuple[float, float]:
    lab = scene.handles["label"]
    x = _page_x(scene, np.asarray(lab.position))
    width = CHAR_PX * len(lab.text) / 1200
    return (x - width, x) if lab.anchor.endswith("right") else (x, x + width)


@pytest.mark.parametrize("kind", ["shape", "csc"])
def test_label_stays_left_of_the_panel(kind, shape_file, csc_file, scene_of) -> None:
    scene = scene_of(shape_file if kind == "shape" else csc_file)
    # short: the targets and the rest are in the panel ("... rho 5 (target 5" ran under it)
    right = np.cross(scene.look_at - scene.position, [0.0, 0.0, 1.0])
    right /= np.linalg.norm(right)
    depth = float(np.linalg.norm(scene.look_at - scene.position))
    for shift in (-0.45, -0.2, 0.0, 0.2, 0.4):  # the camera turned so that the TCP sits further right or left
        scene.look_at = scene.look_at - shift * depth * right
        scene.position = scene.position - shift * depth * right
        for p in range(scene.data.P):
            scene.show(0, p)
            tcp_x = _page_x(scene, scene.frames[1][0, p, :3, 3])
            if not 0.05 < tcp_x < PANEL_FROM - 0.02:
                continue  # a TCP under the panel or off the page: no label placement helps
            lo, hi = _label_span(scene)
            assert lo >= 0.0 and hi <= PANEL_FROM, (shift, p, tcp_x, lo, hi, scene.handles["label"].anchor)
        scene.look_at = scene.look_at + shift * depth * right
        scene.position = scene.position + shift * depth * right
    if kind == "csc":
        return
    # short: the targets and the rest are in the panel ("... rho 5 (target 5" ran under it)
    scene.show(0, 3)
    assert scene.handles["label"].text.startswith("waypoint 3: alpha ") and "(target" not in scene.handles["label"].text


def test_all_ellipsoids_hint_at_scale(tmp_path, lwr, scene_of) -> None:
    """A path of a few mm under ellipsoids drawn 25 cm long: the hint names --scale and a value that
    draws them small enough (with which it is gone); a path of a metre: no hint."""
    from jaxstiff.view._static import write_html

    short = make_shape_result(lwr, 1, 10, spread=(0.3, 0.302)).save(str(tmp_path / "short.npz"))
    scene = scene_of(short)
    extent = scene.path_extent()
    assert 0.001 < extent < 0.05, extent
    hint = scene.all_hint()
    m = re.search(r"--scale (\S+) draws it", hint)
    assert m is not None and "hide the path" in hint, hint
    better = float(m.group(1))
    assert better > scene.n_per_m
    assert scene_of(short, n_per_m=better).all_hint() == ""
    # the static page shows it while "all ellipsoids" is on
    text = open(write_html(scene.data, str(tmp_path / "p.html")), encoding="utf-8").read()
    m = re.search(r'<script type="application/json" id="jaxstiff-view-data">(.*?)</script>', text)
    assert m is not None
    page = json.loads(m.group(1))
    assert "--scale" in page["all_hint"] and "jx-all-hint" in text and "S.all ? D.all_hint : D.tcp_hint" in text
    # the ellipsoid at the TCP alone hides a path this short too: its own hint, while "all" is off
    tcp = scene.tcp_hint()
    m = re.search(r"--scale (\S+) draws it", tcp)
    assert m is not None and tcp.startswith("The ellipsoid at the TCP") and "hides the path" in tcp, tcp
    assert scene_of(short, n_per_m=float(m.group(1))).tcp_hint() == ""
    assert "--scale" in page["tcp_hint"]

    long = make_shape_result(lwr, 1, 10).save(str(tmp_path / "long.npz"))
    assert scene_of(long).all_hint() == "" and scene_of(long).tcp_hint() == ""


def test_live_viewer_shows_the_hint_only_with_all_ellipsoids(tmp_path, lwr) -> None:
    from jaxstiff.view._app import Viewer

    short = make_shape_result(lwr, 1, 10, spread=(0.3, 0.302)).save(str(tmp_path / "short.npz"))
    server = viser.ViserServer(host="127.0.0.1", port=_port(), verbose=False)
    try:
        viewer = Viewer(server, load_view_data(short))
        assert viewer.hint is not None and "--scale" in viewer.hint.content and not viewer.hint.visible
        assert viewer.tcp_hint is not None and "at the TCP" in viewer.tcp_hint.content
        viewer.start_at(0, 3, all_on=True)
        assert viewer.hint.visible and not viewer.tcp_hint.visible
        viewer.start_at(0, 3, all_on=False)
        assert not viewer.hint.visible and viewer.tcp_hint.visible
    finally:
        server.stop()
