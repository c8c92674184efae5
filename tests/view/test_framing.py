"""The scene's scale, sizes and camera (jaxstiff.view._framing), the static page's panel data, and
`view --png`'s refusals (no browser, bad size) - without a browser run."""

from __future__ import annotations

import json
import math
import os
import re

import numpy as np
import pytest

from jaxstiff.cli import main
from jaxstiff.view._framing import MANTISSAS, arm_sizes, choose_view, nice_scale


def test_nice_scale_draws_the_largest_semi_axis_near_its_intended_length() -> None:
    rng = np.random.default_rng(0)
    for largest, screen in zip(10 ** rng.uniform(-2, 6, 500), rng.uniform(0.05, 0.5, 500), strict=True):
        n_per_m = nice_scale(largest, screen)
        drawn = largest / n_per_m
        assert screen / 1.16 <= drawn <= screen * 1.16, (largest, screen, n_per_m)
        mantissa = n_per_m / 10 ** math.floor(math.log10(n_per_m) + 1e-12)
        assert any(abs(mantissa - m) < 1e-9 for m in MANTISSAS), n_per_m
    # the tester's case: largest / screen = 2.2 N/m per m was rounded up to 5 and drawn at 11 cm of 25
    assert 0.216 <= 0.25 * 2.2 / nice_scale(2.2 * 0.25, 0.25) <= 0.29
    assert nice_scale(float("nan"), 0.25) == 1.0 and nice_scale(0.0, 0.25) == 1.0


def _straight_arm(n: int, length: float) -> tuple[np.ndarray, np.ndarray]:
    """Joint frames of an arm with n joints spaced evenly along z up to the TCP at ``length``."""
    joints = np.tile(np.eye(4), (1, n, 1, 1))
    joints[0, :, 2, 3] = np.linspace(0.0, length, n + 2)[1:-1]
    tcp = np.eye(4)[None].copy()
    tcp[0, 2, 3] = length
    return joints, tcp


def test_sizes_follow_the_arm() -> None:
    small, big = arm_sizes(*_straight_arm(6, 0.5)), arm_sizes(*_straight_arm(6, 1.5))
    assert small.length == pytest.approx(0.5) and big.length == pytest.approx(1.5)
    assert big.radius == pytest.approx(3 * small.radius) and big.axis_length == pytest.approx(3 * small.axis_length)
    np.testing.assert_allclose(big.ball, 3 * small.ball)
    # a compact wrist: the last three joints 2 cm apart, the TCP 3 cm further; balls shrink below half the gaps
    joints, tcp = _straight_arm(7, 1.0)
    joints[0, 4:, 2, 3] = [0.90, 0.92, 0.94]
    tcp[0, 2, 3] = 0.97
    s = arm_sizes(joints, tcp)
    assert np.all(s.ball[4:] <= 0.5 * 0.02 + 1e-12) and s.ball[0] == pytest.approx(1.4 * s.radius)
    assert s.link[-1] < s.radius  # the hand's link is thinner


def _scene(angle: float) -> tuple[np.ndarray, ...]:
    """An arm reaching along +x (rotated by ``angle`` about z), its hand along -x from the TCP, a
    path in the vertical plane through the TCP across the reach, flat ellipsoids (largest axis along
    the path)."""
    c, s = math.cos(angle), math.sin(angle)
    R = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    tcp = np.array([[0.7, y, 0.5] for y in np.linspace(-0.2, 0.2, 7)])
    chain = np.stack([[[0, 0, 0], [0, 0, 0.3], [0.3, 0.5 * t[1], 0.6], [0.55, t[1], 0.5], t] for t in tcp])
    path = tcp + np.array([0.0, 0.0, 0.05]) * np.sin(np.linspace(0, 3, 7))[:, None]
    semi = np.tile([0.25, 0.05, 0.01], (7, 1))
    axes = np.tile(np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]), (7, 1, 1))  # columns y, z, x
    return path @ R.T, chain @ R.T, semi, np.einsum("ij,njk->nik", R, axes), R


def test_camera_shows_the_path_plane_from_the_free_side_and_turns_with_the_scene() -> None:
    path, chain, semi, axes, _ = _scene(0.0)
    v = choose_view(path, chain, semi, axes, radius=0.03)
    assert abs(v[0]) > 0.5  # the path's plane (normal x) seen from well in front, not edge on
    assert v[0] > 0  # from the side away from the base: the links are behind the TCP, not before it
    elev = math.degrees(math.asin(v[2]))
    assert 5.0 <= elev <= 70.0
    for angle in (
        0.7,
        2.0,
        -2.5,
    ):  # the same scene turned about z: the same view, turned (within the candidates' spacing)
        p, ch, se, ax, R = _scene(angle)
        w = choose_view(p, ch, se, ax, radius=0.03)
        assert float(np.dot(w, R @ v)) > math.cos(math.radians(25)), (angle, w, R @ v)


def test_no_browser_is_a_one_line_error_and_no_file(shape_file, tmp_path, monkeypatch, capsys) -> None:
    pytest.importorskip("viser")
    monkeypatch.setenv("PATH", str(tmp_path / "nothing-here"))
    monkeypatch.delenv("JAXSTIFF_CHROMIUM", raising=False)
    out = str(tmp_path / "v.png")
    assert main(["view", shape_file, "--png", out]) == 2
    err = capsys.readouterr().err
    assert "--png needs Chromium or Chrome" in err and "apt-get install chromium" in err and len(err.splitlines()) == 1
    assert not os.path.exists(out)
    assert main(["view", shape_file, "--png", out, "--browser", "/no/such/chromium"]) == 2
    assert "--browser /no/such/chromium: no such executable" in capsys.readouterr().err
    assert main(["view", shape_file, "--png", out, "--size", "12x"]) == 2
    assert "--size: expected WIDTHxHEIGHT" in capsys.readouterr().err
    assert main(["view", shape_file, "--html", str(tmp_path / "v.html"), "--waypoint", "8"]) == 2
    assert "--waypoint 8: the result has 8 waypoints, 0..7" in capsys.readouterr().err


def test_static_page_carries_the_panel(batch_file, tmp_path) -> None:
    """--html: the per-waypoint numbers of every path (the live panel's text), the start state,
    the panel's script; viser's recording holds 2 slots (all ellipsoids off / on) per waypoint."""
    pytest.importorskip("viser")
    from jaxstiff.view._app import panel_markdown
    from jaxstiff.view._data import load_view_data

    html = str(tmp_path / "b.html")
    assert main(["view", batch_file, "--html", html, "--path", "2", "--waypoint", "4", "--all"]) == 0
    text = open(html, encoding="utf-8").read()
    m = re.search(r'<script type="application/json" id="jaxstiff-view-data">(.*?)</script>', text)
    assert m is not None and '<script id="jaxstiff-view-panel">' in text and "__VISER_EMBED_DATA__" in text
    page = json.loads(m.group(1))
    data = load_view_data(batch_file)
    assert page["paths"] == [0, 1, 2] and page["P"] == data.P == 6 and page["labels"] == data.labels
    assert page["initial"] == {"path": 2, "waypoint": 4, "all": True}
    for b in range(3):
        for p in (0, 5):
            panel = panel_markdown(data, b, p)
            for line in panel.splitlines():  # every line of the live panel is in the page's HTML for (b, p)
                if line.startswith("- "):
                    assert (
                        line[2:].replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;") in page["panel"][b][p]
                    )
    assert "rigid" in page["panel"][0][0]
