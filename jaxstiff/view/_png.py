"""``jaxstiff view RESULT --png OUT``: a screenshot of the static page (:mod:`jaxstiff.view._static`)
in headless Chromium, in bounded time, without playwright or a browser download.

The browser is driven over the DevTools protocol (its websocket, with the ``websockets`` package
that viser already needs): open the page with the state in its URL fragment, wait until the page
says it has applied that state (``window.__jaxstiffView.ready``), then take screenshots until two in
a row, :data:`SETTLE_S` apart, are the same and not blank (viser fades the canvas in and software
WebGL draws slowly), and write the last one atomically. Everything runs under one deadline; on a
timeout nothing is written and the error says which step did not finish.

The flags (Chromium 156, Debian's ``chromium``; see docs/notes/viewer.md for what fails without them):

- ``--headless=new``: the real browser without a window (the old headless shell is gone);
- ``--use-angle=swiftshader --enable-unsafe-swiftshader --ignore-gpu-blocklist``: WebGL on the CPU
  (SwiftShader). Without a GPU and without these, Chromium 137+ gives no WebGL context: blank page;
- ``--window-size=W,H`` (and the same device metrics through the protocol), ``--hide-scrollbars``;
- ``--remote-debugging-port=0``: a free port, read from the "DevTools listening on" line;
- ``--user-data-dir`` (a fresh temporary profile, removed after), ``--no-first-run``,
  ``--no-default-browser-check``, ``--disable-extensions``, ``--disable-background-networking``,
  ``--mute-audio``;
- ``--no-sandbox`` only when running as root (Chromium refuses to start as root otherwise).

Not used: ``--screenshot`` (it shoots at the load event, before the recording is decoded and
drawn: blank) and ``--virtual-time-budget`` (the page's render loop never lets virtual time
settle: it hangs until killed).
"""

from __future__ import annotations

import base64
import io
import json
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
from typing import IO, Any

__all__ = ["BROWSER_NAMES", "chromium_flags", "SETTLE_S"]

#: executables tried in this order on PATH (after --browser and $JAXSTIFF_CHROMIUM)
BROWSER_NAMES = ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable", "chrome")
SETTLE_S = 1.5  #: seconds between the two equal screenshots that end the wait


def find_browser(explicit: str | None = None) -> str:
    """The Chromium (or Chrome) executable: ``explicit``, else ``$JAXSTIFF_CHROMIUM``, else the
    first of :data:`BROWSER_NAMES` on PATH. Raises FileNotFoundError saying how to get one."""
    for given, what in ((explicit, "--browser"), (os.environ.get("JAXSTIFF_CHROMIUM"), "JAXSTIFF_CHROMIUM")):
        if given:
            path = shutil.which(given)
            if path is None:
                raise FileNotFoundError(f"{what} {given}: no such executable")
            return path
    for name in BROWSER_NAMES:
        path = shutil.which(name)
        if path:
            return path
    raise FileNotFoundError(
        "--png needs Chromium or Chrome, and none is installed (looked for "
        + ", ".join(BROWSER_NAMES)
        + " on PATH): install one (Debian/Ubuntu: apt-get install chromium) or give its path with "
        "--browser PATH or JAXSTIFF_CHROMIUM; --html writes the page without a browser"
    )


def chromium_flags(width: int, height: int, profile: str) -> list[str]:
    """The command-line flags (see the module text)."""
    flags = [
        "--headless=new",
        "--use-angle=swiftshader",
        "--enable-unsafe-swiftshader",
        "--ignore-gpu-blocklist",
        f"--window-size={width},{height}",
        "--hide-scrollbars",
        "--remote-debugging-port=0",
        f"--user-data-dir={profile}",
        "--no-first-run",
        "--no-default-browser-check",
        "--disable-extensions",
        "--disable-background-networking",
        "--mute-audio",
    ]
    if hasattr(os, "geteuid") and os.geteuid() == 0:
        flags.append("--no-sandbox")
    return flags


class BrowserError(RuntimeError):
    """The browser did not start, or did not do what the screenshot asked of it."""


class _Deadline:
    def __init__(self, seconds: float) -> None:
        self.seconds, self.end = seconds, time.monotonic() + seconds

    def left(self, what: str) -> float:
        left = self.end - time.monotonic()
        if left <= 0:
            raise TimeoutError(what)
        return left


class _DevTools:
    """One websocket to the browser; commands to one attached page target (flattened protocol)."""

    def __init__(self, url: str, deadline: _Deadline) -> None:
        from websockets.sync.client import connect

        self.deadline = deadline
        self.ws = connect(url, max_size=None, open_timeout=deadline.left("connecting to Chromium"))
        self.next_id = 0
        self.session: str | None = None

    def call(self, method: str, params: dict[str, Any] | None = None, what: str = "") -> dict[str, Any]:
        self.next_id += 1
        msg: dict[str, Any] = {"id": self.next_id, "method": method, "params": params or {}}
        if self.session is not None and not method.startswith("Target."):
            msg["sessionId"] = self.session
        self.ws.send(json.dumps(msg))
        while True:
            reply = json.loads(self.ws.recv(timeout=self.deadline.left(what or method)))
            if reply.get("id") == self.next_id:
                if "error" in reply:
                    raise BrowserError(f"Chromium: {method}: {reply['error'].get('message', reply['error'])}")
                return reply.get("result", {})

    def close(self) -> None:
        try:
            self.ws.close()
        except Exception:  # the browser is going away anyway
            pass


def _launch(browser: str, flags: list[str], deadline: _Deadline) -> tuple[subprocess.Popen, str, list[str]]:
    """Start the browser; returns it, its DevTools websocket URL and its stderr lines so far."""
    proc = subprocess.Popen(
        [browser, *flags, "about:blank"],
        stdin=subprocess.DEVNULL,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,  # its helper processes form one group, ended together
    )
    lines: list[str] = []
    found = threading.Event()
    url: list[str] = []

    def read() -> None:
        assert proc.stderr is not None
        for line in proc.stderr:
            lines.append(line.rstrip())
            m = re.search(r"DevTools listening on (ws://\S+)", line)
            if m and not url:
                url.append(m.group(1))
                found.set()
        found.set()  # the browser ended

    threading.Thread(target=read, daemon=True).start()
    ended = found.wait(deadline.left("starting Chromium"))  # False: the wait timed out
    if not url:
        _stop(proc)  # its output then ends, which sets `found`: decide on the wait's own answer
        if not ended:
            raise TimeoutError("starting Chromium")
        tail = " | ".join(lines[-3:]) or f"exit status {proc.poll()}"
        raise BrowserError(f"{browser} did not start: {tail}")
    return proc, url[0], lines


def _stop(proc: subprocess.Popen) -> None:
    """End the browser and its helpers (its own process group)."""
    if proc.poll() is None:
        try:
            os.killpg(proc.pid, signal.SIGTERM)
        except OSError:
            proc.terminate()
        try:
            proc.wait(5)
        except subprocess.TimeoutExpired:
            try:
                os.killpg(proc.pid, signal.SIGKILL)
            except OSError:
                proc.kill()
            proc.wait(5)


def _drawn(png: bytes, width: int) -> bool:
    """Whether the picture left of the panel holds more than a white page (1 % of its pixels)."""
    try:
        import numpy as np
        from PIL import Image
    except ImportError:  # no Pillow: equal screenshots alone end the wait
        return True
    img = np.asarray(Image.open(io.BytesIO(png)).convert("RGB")).astype(int)
    left = img[:, : max(1, int(0.65 * width))]
    return float(np.mean(left.min(axis=-1) < 200)) > 0.01


def screenshot(
    html: str,
    out: str,
    *,
    fragment: str = "",
    browser: str | None = None,
    width: int = 1200,
    height: int = 800,
    timeout: float = 180.0,
) -> str:
    """Screenshot of the page ``html`` (a file) opened at ``#fragment``, written to ``out`` (PNG,
    atomically). Raises FileNotFoundError (no browser), TimeoutError (naming the unfinished step:
    nothing is written) or :class:`BrowserError` (the browser failed)."""
    from jaxstiff.runtime._io import atomic_write

    exe = find_browser(browser)
    deadline = _Deadline(timeout)
    profile = tempfile.mkdtemp(prefix="jaxstiff-chromium-")
    proc = None
    tools = None
    step = "starting Chromium"
    try:
        proc, url, _ = _launch(exe, chromium_flags(width, height, profile), deadline)
        try:
            tools = _DevTools(url, deadline)
        except TimeoutError:
            raise
        except OSError as e:  # refused or reset: the address the browser printed does not answer
            raise BrowserError(f"{exe} printed the DevTools address {url}, which does not answer: {e}") from None
        step = "opening the page"
        target = tools.call("Target.createTarget", {"url": "about:blank"})["targetId"]
        tools.session = tools.call("Target.attachToTarget", {"targetId": target, "flatten": True})["sessionId"]
        tools.call(
            "Emulation.setDeviceMetricsOverride",
            {"width": width, "height": height, "deviceScaleFactor": 1, "mobile": False},
        )
        page = "file://" + os.path.abspath(html) + "#" + "&".join(filter(None, [fragment, "png=1"]))
        tools.call("Page.navigate", {"url": page}, what=step)
        step = "the page applying its state (viser decoding the recording)"
        while not _evaluate(tools, "!!(window.__jaxstiffView && window.__jaxstiffView.ready)", step):
            time.sleep(min(0.25, deadline.left(step)))
        step = "the scene settling (two equal screenshots in a row)"
        last = b""
        _log(f"ready after {timeout - deadline.left(step):.1f} s")
        while True:
            shot = base64.b64decode(
                tools.call("Page.captureScreenshot", {"format": "png", "optimizeForSpeed": True}, what=step)["data"]
            )
            _log(f"screenshot at {timeout - deadline.left(step):.1f} s, {len(shot)} bytes, same: {shot == last}")
            if shot == last and _drawn(shot, width):
                break
            last = shot
            time.sleep(min(SETTLE_S, deadline.left(step)))
        picture = shot

        def write(fh: IO) -> None:
            fh.write(picture)

        return atomic_write(out, write, binary=True)
    except TimeoutError:
        raise TimeoutError(
            f"--png: Chromium ({exe}) did not finish {step} within {timeout:g} s; nothing written. "
            "Software WebGL on a busy machine is slow: raise --timeout"
        ) from None
    finally:
        if tools is not None:
            tools.close()
        if proc is not None:
            _stop(proc)
        shutil.rmtree(profile, ignore_errors=True)


def _log(text: str) -> None:
    if os.environ.get("JAXSTIFF_PNG_DEBUG"):
        print(f"jaxstiff view --png: {text}", file=sys.stderr, flush=True)


def _evaluate(tools: _DevTools, expression: str, what: str) -> Any:
    res = tools.call("Runtime.evaluate", {"expression": expression, "returnByValue": True}, what=what)
    return res.get("result", {}).get("value")
