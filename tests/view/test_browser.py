"""`jaxstiff view` and its `--html` page in a real headless Chromium (the Debian package, driven by
playwright with ``executable_path``): the screenshot shows the arm, the path and the ellipsoid in
their colours, and moving the waypoint slider (the live panel's, or the static page's own panel)
changes the picture. `--png` on several arms: tests/view/test_png_arms.py.

Skipped, saying why, where Chromium or playwright is missing; ``.ci/run`` installs both."""

from __future__ import annotations

import io
import os
import shutil
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

CHROMIUM = os.environ.get("JAXSTIFF_CHROMIUM") or shutil.which("chromium") or shutil.which("chromium-browser")
pytestmark = [
    pytest.mark.slow,
    pytest.mark.skipif(CHROMIUM is None, reason="no Chromium (apt-get install chromium) for the browser test"),
]
ARGS = ["--no-sandbox", "--use-angle=swiftshader", "--enable-unsafe-swiftshader", "--ignore-gpu-blocklist"]


def _pixels(png: bytes) -> np.ndarray:
    from PIL import Image

    return np.asarray(Image.open(io.BytesIO(png)).convert("RGB")).astype(int)


def _counts(img: np.ndarray) -> dict[str, int]:
    """Pixels of the scene's colours (jaxstiff.view._scene.COLORS, shaded by the lights)."""
    r, g, b = img[..., 0], img[..., 1], img[..., 2]
    return {
        "arm": int(np.sum((b > 140) & (r < 110) & (g < 140) & (b - r > 60))),
        "path": int(np.sum((g > 110) & (r < 110) & (b < 140) & (g - r > 40) & (g - b > 20))),
        "ellipsoid": int(np.sum((r > 190) & (g > 90) & (g < 215) & (b < 150) & (r - b > 90))),
        "desired": int(np.sum((r < 90) & (g > 100) & (b > 100) & (np.abs(g - b) < 40) & (g - r > 60))),
    }


def _check_scene(img: np.ndarray, path: bool = True) -> None:
    c = _counts(img[150:, :])  # below the browser's notice in the top left
    assert c["arm"] > 1500 and (c["path"] > 40 or not path) and c["ellipsoid"] > 40, c


def _settled(page, check=_check_scene, seconds: float = 60.0) -> np.ndarray:
    """A screenshot once ``check`` passes on it (software WebGL on a loaded machine can take many
    seconds to draw the first frames); the last one, failing ``check``, after ``seconds``."""
    t_end = time.time() + seconds
    while True:
        img = _pixels(page.screenshot())
        try:
            check(img)
            return img
        except AssertionError:
            if time.time() > t_end:
                raise
            page.wait_for_timeout(2000)


@pytest.fixture(scope="module")
def readme_result(tmp_path_factory) -> str:
    """The README main job: `jaxstiff shape` on the shipped default (LWR, 7th joint locked, f2, ratio 5)."""
    out = str(tmp_path_factory.mktemp("readme") / "shape.npz")
    subprocess.run([sys.executable, "-m", "jaxstiff", "shape", "--out", out], check=True, capture_output=True)
    return out


@pytest.fixture(scope="module")
def browser():
    sync = pytest.importorskip("playwright.sync_api", reason="playwright (pip install playwright) drives Chromium")
    with sync.sync_playwright() as pw:
        br = pw.chromium.launch(executable_path=CHROMIUM, args=ARGS)
        yield br
        br.close()


@pytest.fixture(autouse=True)
def _close_pages(request):
    """Each test's pages closed after it: the module's one browser otherwise keeps every earlier
    test's page and its software-WebGL context drawing, and later tests' scenes came late or not
    at all (a 90 s timeout waiting for the canvas in the full suite)."""
    yield
    if "browser" in request.fixturenames:
        for ctx in list(request.getfixturevalue("browser").contexts):
            ctx.close()


@pytest.fixture(scope="module")
def csc_result(tmp_path_factory) -> str:
    """A `jaxstiff csc` run on the LWR: hold the TCP where the start posture puts it, 60 steps (the
    project's own case; seed 001 has no simulation example)."""
    out = str(tmp_path_factory.mktemp("csc") / "csc.npz")
    cmd = ["csc", "--hold", "0.6404,0.1129,0.4102", "--steps", "60", "--kxd", "3000,1000,2000@30", "--task", "xyz"]
    cmd += ["--q0-deg", "10,40,0,-70,0,50,0", "--out", out]
    subprocess.run([sys.executable, "-m", "jaxstiff", *cmd], check=True, capture_output=True)
    return out


def _start_viewer(file: str, port: int) -> subprocess.Popen:
    proc = subprocess.Popen(
        [sys.executable, "-m", "jaxstiff", "view", file, "--port", str(port)],
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )
    assert proc.stdout is not None
    for line in proc.stdout:
        if line.startswith("jaxstiff view: http"):
            return proc
    raise AssertionError(f"jaxstiff view did not start (exit {proc.wait()})")


def test_live_viewer(readme_result, browser) -> None:
    proc = _start_viewer(readme_result, 8097)
    try:
        page = browser.new_page(viewport={"width": 1200, "height": 800})
        page.goto("http://127.0.0.1:8097")
        page.wait_for_selector("canvas")
        first = _settled(page)
        box = page.locator("input:visible").first  # the waypoint slider's number field
        box.fill("45")
        box.press("Enter")
        page.wait_for_timeout(3000)
        second = _settled(page)
        assert np.mean(np.any(first != second, axis=-1)) > 0.002  # the arm moved
    finally:
        proc.send_signal(signal.SIGINT)
        proc.wait(20)


def _pale(img: np.ndarray) -> int:
    """Pixels of "all ellipsoids" (COLORS["all"] at opacity 0.5 over the white page)."""
    r, g, b = img[..., 0], img[..., 1], img[..., 2]
    return int(np.sum((r > 235) & (g > 195) & (g < 240) & (b > 120) & (b < 215) & (r - b > 35)))


def test_static_html_page(readme_result, browser, tmp_path) -> None:
    """The --html page opened from disk has the live viewer's panel: the waypoint field moves the
    arm and the numbers, "all ellipsoids" draws them, Space plays."""
    html = str(tmp_path / "shape.html")
    subprocess.run([sys.executable, "-m", "jaxstiff", "view", readme_result, "--html", html], check=True)
    page = browser.new_page(viewport={"width": 1200, "height": 800})
    page.set_default_timeout(90_000)
    page.goto("file://" + html)
    page.wait_for_function("window.__jaxstiffView && window.__jaxstiffView.ready")
    first = _settled(page)
    numbers = page.inner_text("#jx-numbers")
    assert "waypoint 0 (0-based) of 60" in numbers and "lwr_a7: rigid" in numbers
    page.fill("#jx-waypoint-number", "45")
    page.press("#jx-waypoint-number", "Enter")
    page.wait_for_timeout(2000)
    second = _settled(page)
    assert "waypoint 45 (0-based) of 60" in page.inner_text("#jx-numbers")
    assert page.evaluate("window.__jaxstiffView.slot") == 45
    assert np.mean(np.any(first[:, :850] != second[:, :850], axis=-1)) > 0.002  # the arm moved
    page.check("#jx-all")
    page.wait_for_timeout(2000)
    # the flat ellipsoids along the path lie in its plane and cover it: no path pixels asked (the
    # green these found before was the TCP's RGB triad's y axis, which a reader took for the path)
    third = _settled(page, lambda img: _check_scene(img, path=False))
    assert page.evaluate("window.__jaxstiffView.slot") == 60 + 45  # the slot of "all ellipsoids", same waypoint
    assert _pale(third[:, :850]) > _pale(second[:, :850]) + 2000, (_pale(second), _pale(third))
    page.evaluate("document.activeElement && document.activeElement.blur()")
    page.keyboard.press("Space")  # our player (viser's own would run on into the next slots)
    page.wait_for_timeout(3000)
    page.keyboard.press("Space")
    state = page.evaluate("window.__jaxstiffView.state")
    assert state["waypoint"] != 45 and state["all"] is True and not state["playing"]


def _open(browser, port: int):
    page = browser.new_page(viewport={"width": 1200, "height": 800})
    # playwright's 30 s default for each action: under the full suite (4 workers on 2 cores, software
    # WebGL) a click on the path selector once timed out; 90 s, as _settled's drawing allowance grows
    page.set_default_timeout(90_000)
    page.goto(f"http://127.0.0.1:{port}")
    page.wait_for_selector("canvas")
    return page


def _check_csc(img: np.ndarray) -> None:
    c = _counts(img[150:, :])
    assert c["arm"] > 1500 and c["ellipsoid"] > 400 and c["desired"] > 400, c


def test_live_viewer_csc(csc_result, browser) -> None:
    """Realised K_C (orange, at the TCP) and desired K_xd (teal) side by side; the step slider moves."""
    proc = _start_viewer(csc_result, 8098)
    try:
        page = _open(browser, 8098)
        first = _settled(page, _check_csc)
        text = page.inner_text("body")
        assert "|K_xd - K_C|_F" in text and "u: " in text and "desired K_xd" in text
        box = page.locator("input:visible").first  # the step slider's number field
        box.fill("59")
        box.press("Enter")
        page.wait_for_timeout(3000)
        second = _pixels(page.screenshot())
        assert "step 59 (0-based) of 60" in page.inner_text("body")
        assert np.mean(np.any(first != second, axis=-1)) > 0.002  # the arm and the ellipsoid moved
    finally:
        proc.send_signal(signal.SIGINT)
        proc.wait(20)


def _batch_of_thirds(file: str, out: str) -> str:
    """The README result cut into a B = 3 batch: waypoints 0-19, 20-39 and 40-59 as three paths
    (real postures and stiffnesses, so every path's ellipsoids are drawn at one sensible scale)."""
    import dataclasses

    import jaxstiff

    res = jaxstiff.ShapeResult.load(file)
    cut = {}
    for f in dataclasses.fields(res):
        a = getattr(res, f.name)
        if f.name in ("q0", "kj0"):
            cut[f.name] = np.stack([res.q[0, k * 20] if f.name == "q0" else res.kj[0, k * 20] for k in range(3)])
        elif f.name not in ("meta", "joint_names"):
            cut[f.name] = np.asarray(a)[0].reshape(3, 20, *np.shape(a)[2:])
    meta = dict(res.meta, path={"name": "first;middle;last"})
    return jaxstiff.ShapeResult(joint_names=res.joint_names, meta=meta, **cut).save(out)


def test_live_viewer_batch_path_selector(readme_result, tmp_path, browser) -> None:
    """A B = 3 result: choosing path 2 in the selector changes the picture (another posture and path)."""
    f = _batch_of_thirds(readme_result, str(tmp_path / "batch.npz"))
    proc = _start_viewer(f, 8099)
    try:
        page = _open(browser, 8099)
        first = _settled(page)
        page.locator("input[value^='path 0']").first.click()
        page.get_by_text("path 2: last").first.click()
        page.wait_for_timeout(3000)
        second = _settled(page)
        assert "path 2: last" in page.inner_text("body")
        assert np.mean(np.any(first[:, :850] != second[:, :850], axis=-1)) > 0.005  # the scene, not the panel
    finally:
        proc.send_signal(signal.SIGINT)
        proc.wait(20)
