"""`jaxstiff view RESULT --png OUT` on the LWR and three arms nobody here wrote (tests/data/robots):
a small shape result solved with pgd (4 waypoints), the screenshot through headless Chromium,
and the ellipsoid's orange counted in the picture - against the area the ellipsoid covers on
screen, computed here from the camera the page states, viser's 75 degree field of view, and the
stiffness from the numpy check's own Jacobian (not the viewer's). A link in front of the ellipsoid
(opaque, or its see-through blue over the orange) takes those pixels away.

Skipped, saying why, where Chromium is missing (apt-get install chromium) or viser is."""

from __future__ import annotations

import json
import math
import os
import re
import shutil

import numpy as np
import pytest

import jaxstiff

CHROMIUM = os.environ.get("JAXSTIFF_CHROMIUM") or shutil.which("chromium") or shutil.which("chromium-browser")
pytestmark = [
    pytest.mark.slow,
    pytest.mark.skipif(CHROMIUM is None, reason="no Chromium (apt-get install chromium) for the --png test"),
]
ROBOTS = os.path.join(os.path.dirname(__file__), "..", "data", "robots")
ARMS = {  # name: (URDF, tip link, locks)
    "kuka_lwr4": ("kuka_lwr4", None, {"lwr_a7": 0.0}),
    "ur10": (os.path.join(ROBOTS, "ur10.urdf"), "tool0", None),
    "kinova_j2s6s200": (os.path.join(ROBOTS, "kinova_j2s6s200.urdf"), "j2s6s200_end_effector", None),
    "z1": (os.path.join(ROBOTS, "z1.urdf"), "gripperStator", None),  # the tip before the gripper joint
}
W, H, FOV_DEG = 1200, 800, 75.0
PANEL_LEFT = 850  # the page's panel covers x >= 858 (330 px wide, 12 px from the right)


def _result(name: str, out: str) -> jaxstiff.ShapeResult:
    import jax

    jax.config.update("jax_enable_x64", True)
    urdf, tip, locked = ARMS[name]
    robot = jaxstiff.Robot.from_urdf(urdf, tip_link=tip, locked=locked)
    lo, hi = np.maximum(robot.lower, -2.0), np.minimum(robot.upper, 2.0)
    q = np.clip(0.5 * (lo + hi) + 0.7 * (-1.0) ** np.arange(robot.n), lo, hi)  # bent at every joint: not singular
    q[~robot.free] = robot.locked_values[~robot.free]
    p0 = np.asarray(jaxstiff.fk(robot, q))[:3, 3]
    path = p0 + np.linspace(-0.5, 0.5, 4)[:, None] * np.array([0.0, 0.04, 0.02])
    res = jaxstiff.shape(robot, path, "f2", 5.0, solver="pgd", dq=np.radians(5.0))
    res.save(out)
    return res


def _orange(img: np.ndarray) -> np.ndarray:
    """Pixels of the ellipsoid's orange (255, 140, 0), lit and shaded (scene.COLORS["ellipsoid"])."""
    r, g, b = img[..., 0], img[..., 1], img[..., 2]
    return (r > 150) & (g > 0.35 * r) & (g < 0.8 * r) & (b < 0.45 * r) & (r - b > 90)


def _expected_area(name: str, res: jaxstiff.ShapeResult, page: dict, p: int) -> float:
    """Pixels the ellipsoid at waypoint p covers on screen (perspective at the TCP's depth), from
    an independent K_T and the page's camera and scale."""
    from jaxstiff.results._numpy_check import np_translational_stiffness

    urdf, tip, locked = ARMS[name]
    robot = jaxstiff.Robot.from_urdf(urdf, tip_link=tip, locked=locked)
    K = np_translational_stiffness(robot, res.q[0, p], res.kj_scaled[0, p], str(res.meta.get("task", "full")))
    w, E = np.linalg.eigh(K)
    s = w[::-1] / page["n_per_m"]
    s = np.maximum(s, 0.02 * s[0])  # the drawing's floor for a flat ellipsoid
    E = E[:, ::-1]
    cam, look = np.asarray(page["camera"]["position"]), np.asarray(page["camera"]["look_at"])
    fwd = (look - cam) / np.linalg.norm(look - cam)
    v = E.T @ fwd
    area = math.pi * math.sqrt((s[1] * s[2] * v[0]) ** 2 + (s[0] * s[2] * v[1]) ** 2 + (s[0] * s[1] * v[2]) ** 2)
    depth = float((res.position[0, p] - cam) @ fwd)
    f = (H / 2) / math.tan(math.radians(FOV_DEG) / 2)
    return area * (f / depth) ** 2


@pytest.mark.parametrize("name", list(ARMS))
def test_png_shows_the_ellipsoid(name: str, tmp_path, capsys) -> None:
    pytest.importorskip("viser")
    from PIL import Image

    from jaxstiff.cli import main

    res = _result(name, str(tmp_path / "shape.npz"))
    png, html = str(tmp_path / "view.png"), str(tmp_path / "view.html")
    rc = main(
        ["view", str(tmp_path / "shape.npz"), "--png", png, "--html", html, "--waypoint", "1", "--timeout", "500"]
    )
    assert rc == 0, capsys.readouterr().err
    assert not [f for f in os.listdir(tmp_path) if f.startswith(".") or f.endswith(".tmp")]  # no temporaries left
    img = np.asarray(Image.open(png).convert("RGB")).astype(int)
    assert img.shape == (H, W, 3)
    text = open(html, encoding="utf-8").read()
    m = re.search(r'<script type="application/json" id="jaxstiff-view-data">(.*?)</script>', text)
    assert m is not None
    page = json.loads(m.group(1))
    seen = int(_orange(img[:, :PANEL_LEFT]).sum())
    expected = _expected_area(name, res, page, 1)
    print(f"{name}: orange pixels {seen}, ellipsoid's area on screen {expected:.0f}")
    assert seen > 1500, (seen, expected)
    assert seen > 0.35 * expected, (seen, expected)  # most of it is in sight: not behind links or off the picture
    assert seen < 1.6 * expected, (seen, expected)  # and it is the ellipsoid drawn at the stated scale
    # the arm's blue and the panel are there too (not an orange page)
    blue = (img[..., 2] > 140) & (img[..., 0] < 120) & (img[..., 2] - img[..., 0] > 60)
    assert int(blue[:, :PANEL_LEFT].sum()) > 800
    assert "<b>waypoint 1 (0-based) of 4</b>" in page["panel"][0][1]  # 4 waypoints, 0..3


def test_png_timeout_writes_nothing(shape_file, tmp_path) -> None:
    """A deadline too short for Chromium to start and draw: a TimeoutError naming the step, no file."""
    pytest.importorskip("viser")
    from jaxstiff.view._data import load_view_data
    from jaxstiff.view._png import screenshot
    from jaxstiff.view._static import write_html

    html = write_html(load_view_data(shape_file), str(tmp_path / "p.html"))
    out = str(tmp_path / "p.png")
    with pytest.raises(TimeoutError, match=r"did not finish .* within 1 s; nothing written"):
        screenshot(html, out, timeout=1.0)
    assert not os.path.exists(out) and sorted(os.listdir(tmp_path)) == ["p.html", "shape.npz"]
