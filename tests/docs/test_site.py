"""The documentation site: `mkdocs build --strict` (warnings are errors: a broken link, a missing
anchor or an API reference that does not resolve fails the build), then the built site in headless
Chromium, served over http on 127.0.0.1 (material's search runs in a web worker that fetches its
index, which file:// does not allow): the index and the API page of ``jaxstiff.shape`` render
(text, not blank, the function's signature visible) and the search box finds "ellipsoid".

Skipped, saying why, where mkdocs (the ``docs`` extra), playwright or Chromium is missing.
``JAXSTIFF_SITE_SCREENSHOTS=DIR`` keeps the screenshots there."""

from __future__ import annotations

import functools
import http.server
import importlib.util
import io
import os
import pathlib
import re
import shutil
import subprocess
import sys
import threading

import numpy as np
import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]


def _missing(modules: tuple[str, ...]) -> list[str]:
    """The modules of ``modules`` that cannot be imported (a dotted name whose parent is missing too)."""
    out = []
    for m in modules:
        try:
            found = importlib.util.find_spec(m) is not None
        except ModuleNotFoundError:
            found = False
        if not found:
            out.append(m)
    return out


MISSING = _missing(("mkdocs", "material", "mkdocstrings", "mkdocstrings_handlers.python"))
CHROMIUM = os.environ.get("JAXSTIFF_CHROMIUM") or shutil.which("chromium") or shutil.which("chromium-browser")
ARGS = ["--no-sandbox", "--use-angle=swiftshader", "--enable-unsafe-swiftshader", "--ignore-gpu-blocklist"]

pytestmark = pytest.mark.skipif(
    bool(MISSING), reason=f"mkdocs is not installed ({', '.join(MISSING)} missing): pip install '.[docs]'"
)
browser_deps = pytest.mark.skipif(
    CHROMIUM is None or importlib.util.find_spec("playwright") is None,
    reason="no Chromium (apt-get install chromium) or no playwright (the test extra) for the browser test",
)


def browser(fn):
    """A browser test: slow (Chromium starts, the site is served), like the viewer's browser tests."""
    return pytest.mark.slow(browser_deps(fn))


@pytest.fixture(scope="module")
def site(tmp_path_factory) -> pathlib.Path:
    """The site built from the checkout with --strict into a temporary folder."""
    out = tmp_path_factory.mktemp("site")
    proc = subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "-f", str(ROOT / "mkdocs.yml"), "-d", str(out)],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=600,
        env=dict(os.environ, NO_MKDOCS_2_WARNING="1"),
    )
    assert proc.returncode == 0, f"mkdocs build --strict failed:\n{proc.stdout[-4000:]}\n{proc.stderr[-6000:]}"
    return out


@pytest.fixture(scope="module")
def served(site):
    """The built site over http on 127.0.0.1 (a free port); its base URL."""
    handler = functools.partial(_QuietHandler, directory=str(site))
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    yield f"http://127.0.0.1:{server.server_address[1]}/"
    server.shutdown()
    server.server_close()


class _QuietHandler(http.server.SimpleHTTPRequestHandler):
    def log_message(self, format, *args):  # noqa: A002 (the base class's name)
        pass


@pytest.fixture(scope="module")
def page(served):
    sync = pytest.importorskip("playwright.sync_api")
    with sync.sync_playwright() as pw:
        br = pw.chromium.launch(executable_path=CHROMIUM, args=ARGS)
        pg = br.new_page(viewport={"width": 1280, "height": 900})
        yield pg
        br.close()


def _not_blank(png: bytes, name: str) -> None:
    """The screenshot has drawing in it (not one flat colour); kept where JAXSTIFF_SITE_SCREENSHOTS says."""
    from PIL import Image

    img = np.asarray(Image.open(io.BytesIO(png)).convert("L")).astype(float)
    dark = np.mean(img < 128)
    assert img.std() > 20 and dark > 0.005, f"{name}: the page looks blank (std {img.std():.1f}, dark share {dark:.4f})"
    keep = os.environ.get("JAXSTIFF_SITE_SCREENSHOTS")
    if keep:
        os.makedirs(keep, exist_ok=True)
        pathlib.Path(keep, name).write_bytes(png)


def test_site_builds_strict_with_every_page(site):
    for page in (
        "index.html",
        "getting-started/index.html",
        "concepts/index.html",
        "api/shape/index.html",
        "gallery/index.html",
        "benchmarks/index.html",
        "reproduce/report/index.html",
        "notes/speed/index.html",
    ):
        assert (site / page).is_file(), page
    api = (site / "api" / "shape" / "index.html").read_text(encoding="utf-8")
    assert 'id="jaxstiff.shape"' in api and "cms_volume" in api  # the docstring's parameters, from the source
    gallery = (site / "gallery" / "index.html").read_text(encoding="utf-8")
    assert (
        "from_urdf" in gallery and "--8&lt;--" not in gallery
    )  # the examples' code is included, no snippet marker left
    for png in sorted((ROOT / "docs" / "gallery").glob("*.png")):
        assert (site / "gallery" / png.name).is_file(), png.name


def test_no_docstring_role_markup_is_shown(site):
    # the docstrings' :class:`~x` roles reach the pages as text unless docs/_hooks/sphinx_roles.py
    # reduces them to their code (232 of them on the API pages without it)
    role = re.compile(r":(?:class|func|mod|meth|attr|data|exc|obj):(?:<code>|`)")
    shown = {}
    for html in site.rglob("*.html"):
        n = len(role.findall(html.read_text(encoding="utf-8")))
        if n:
            shown[str(html.relative_to(site))] = n
    assert not shown, shown
    api = (site / "api" / "shape" / "index.html").read_text(encoding="utf-8")
    assert "<code>ShapeSettings</code>" in api  # :class:`~jaxstiff.settings.ShapeSettings`, shortened


@browser
def test_index_renders(page, served):
    page.goto(served, wait_until="networkidle")
    assert page.locator("h1").first.inner_text().strip().rstrip("\u00b6").strip() == "jaxstiff"  # (the permalink sign)
    assert "stiffness ellipsoid" in page.locator("article").inner_text()
    assert page.locator("article img").first.evaluate(
        "img => img.complete && img.naturalWidth > 0"
    )  # the viewer picture
    _not_blank(page.screenshot(full_page=False), "site_index.png")


@browser
def test_shape_api_page_shows_the_signature(page, served):
    page.goto(served + "api/shape/", wait_until="networkidle")
    heading = page.locator('[id="jaxstiff.shape"]')
    assert heading.is_visible()
    signature = page.locator('[id="jaxstiff.shape"] + .doc-signature').first
    text = " ".join(signature.inner_text().split())
    assert text.startswith("shape(") and "robot: Robot" in text and "criterion" in text, text
    assert signature.is_visible()
    signature.scroll_into_view_if_needed()
    _not_blank(page.screenshot(full_page=False), "site_api_shape.png")


@browser
def test_search_finds_ellipsoid(page, served):
    page.goto(served, wait_until="networkidle")
    box = page.locator("input.md-search__input")
    box.click()  # the search field in the header (a desktop-wide window)
    box.press_sequentially("ellipsoid", delay=50)
    items = page.locator(".md-search-result__item")
    items.first.wait_for(state="visible", timeout=30_000)
    assert items.count() > 0
    assert "ellipsoid" in page.locator(".md-search-result").inner_text().lower()
    _not_blank(page.screenshot(full_page=False), "site_search.png")
