"""`jaxstiff view` and its `--html` page in a real headless Chromium (the Debian package, driven by
playwright with ``executable_path``): the screenshot shows the arm, the path and the ellipsoid in
their colours, and moving the waypoint slider (the page's timeline) changes the picture.

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
    """Pixels of the scene's colours (jaxstiff.view.scene.COLORS, shaded by the lights)."""
    r, g, b = img[..., 0], img[..., 1], img[..., 2]
    return {
        "arm": int(np.sum((b > 140) & (r < 110) & (g < 140) & (b - r > 60))),
        "path": int(np.sum((g > 110) & (r < 110) & (b < 140) & (g - r > 40) & (g - b > 20))),
        "ellipsoid": int(np.sum((r > 190) & (g > 90) & (g < 215) & (b < 150) & (r - b > 90))),
    }


def _check_scene(img: np.ndarray) -> None:
    c = _counts(img[150:, :])  # below the browser's notice in the top left
    assert c["arm"] > 1500 and c["path"] > 40 and c["ellipsoid"] > 40, c


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
        page.wait_for_timeout(6000)
        first = _pixels(page.screenshot())
        _check_scene(first)
        box = page.locator("input:visible").first  # the waypoint slider's number field
        box.fill("45")
        box.press("Enter")
        page.wait_for_timeout(3000)
        second = _pixels(page.screenshot())
        _check_scene(second)
        assert np.mean(np.any(first != second, axis=-1)) > 0.002  # the arm moved
    finally:
        proc.send_signal(signal.SIGINT)
        proc.wait(20)


def test_static_html_page(readme_result, browser, tmp_path) -> None:
    html = str(tmp_path / "shape.html")
    subprocess.run([sys.executable, "-m", "jaxstiff", "view", readme_result, "--html", html], check=True)
    page = browser.new_page(viewport={"width": 1200, "height": 800})
    page.goto("file://" + html)
    page.wait_for_selector("canvas")
    page.wait_for_timeout(5000)
    page.keyboard.press("Space")  # pause the animation where it is
    first = _pixels(page.screenshot())
    _check_scene(first)
    page.mouse.click(1000, 780)  # the timeline: jump towards the end of the path
    t0 = time.time()
    page.wait_for_timeout(2000)
    second = _pixels(page.screenshot())
    assert time.time() - t0 < 60
    _check_scene(second)
    assert np.mean(np.any(first[:740] != second[:740], axis=-1)) > 0.002
