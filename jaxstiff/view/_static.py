"""The static page of ``jaxstiff view --html``: one self-contained HTML file that opens from disk
(no server) with the scene and the same panel as the live viewer.

viser's standalone export (``get_scene_serializer().as_html()``) holds scene messages on a
timeline and plays them back; it records no GUI (its panel needs the Python server to act). So
the page is built in two parts:

- the recording: every (path, "all ellipsoids" off/on, waypoint) is one slot of :data:`SLOT_S`
  seconds on viser's timeline, recorded in that order (slot ``k = (2 * path + all) * P +
  waypoint``); the messages of a slot put the whole scene in that state, so the scene at any time
  ``t`` of the timeline is the one of slot ``floor(t / SLOT_S)``;
- our panel (:data:`PANEL_JS`, :data:`PANEL_CSS`, the per-waypoint numbers as JSON in the page):
  path selector (B > 1), waypoint slider, play and its speed, "all ellipsoids along the path"
  (with, while it is on, the hint at ``--scale`` of :meth:`Scene.all_hint`, if any; while it is
  off, :meth:`Scene.tcp_hint`'s), the numbers
  and kj per joint at the waypoint. It moves the scene by setting viser's playback time
  to the middle of the slot through viser's own time field (then hidden with the rest of viser's
  playback bar), which also pauses viser's player; Space plays / pauses our player instead.

The page reads its starting state from the URL fragment: ``page.html#path=1&waypoint=30&all=1``
(0-based; also what ``--png`` uses). When it has applied a state it sets
``window.__jaxstiffView.ready = true`` (and ``.slot``, ``.state``): the screenshot waits for it.
"""

from __future__ import annotations

import contextlib
import html as html_lib
import io
import json
import re
import socket
from typing import Any

from jaxstiff.view._app import header_markdown, panel_markdown
from jaxstiff.view._data import ViewData
from jaxstiff.view._scene import Scene

__all__ = ["page_html", "markdown_html", "SLOT_S", "MAX_WAYPOINTS", "slot_index"]

SLOT_S = 1.0  #: seconds of viser's timeline per slot (the page sets the time to a slot's middle)
MAX_WAYPOINTS = 3000  #: a batch with more waypoints in all (B x P) puts only the chosen path in the page


def slot_index(path: int, all_on: bool, waypoint: int, P: int) -> int:
    """The slot of (path index in the page, "all ellipsoids", waypoint) on the page's timeline."""
    return (2 * path + int(bool(all_on))) * P + waypoint


def markdown_html(text: str) -> str:
    """The panel's markdown (``**bold**``, ``- item`` lines, blank lines) as HTML, text escaped."""
    out: list[str] = []
    in_list = False
    for line in text.splitlines():
        body = re.sub(
            r"\*\*(.+?)\*\*", r"<b>\1</b>", html_lib.escape(line.strip()[2:] if line.startswith("- ") else line)
        )
        if line.startswith("- "):
            if not in_list:
                out.append("<ul>")
                in_list = True
            out.append(f"<li>{body}</li>")
            continue
        if in_list:
            out.append("</ul>")
            in_list = False
        if line.strip():
            out.append(f"<p>{body}</p>")
    if in_list:
        out.append("</ul>")
    return "".join(out)


PANEL_CSS = """
#jx-panel{position:fixed;top:12px;right:12px;width:330px;max-height:calc(100% - 24px);overflow:auto;z-index:1000;
 background:rgba(255,255,255,.96);color:#222;border-radius:8px;box-shadow:0 2px 14px rgba(0,0,0,.18);
 font:13px/1.35 system-ui,-apple-system,'Segoe UI',Roboto,sans-serif;padding:10px 12px}
#jx-panel p{margin:.35em 0}#jx-panel ul{margin:.2em 0;padding-left:1.2em}#jx-panel li{margin:0}
#jx-panel .jx-row{display:flex;align-items:center;gap:6px;margin:6px 0}
#jx-panel .jx-row label{flex:0 0 auto}#jx-panel input[type=range]{flex:1 1 auto;min-width:60px}
#jx-panel input[type=number]{width:4.5em}#jx-panel select{flex:1 1 auto;max-width:100%}
#jx-panel .jx-head{font-size:12px;color:#444;border-bottom:1px solid #ddd;padding-bottom:6px;margin-bottom:4px}
#jx-panel .jx-note{font-size:11px;color:#666}
#jx-panel .jx-hint{font-size:12px;color:#7a4a00;background:#fff4e0;border-radius:4px;padding:4px 6px;margin:4px 0}
#jx-toggle{position:fixed;top:12px;right:12px;z-index:1001;font:12px system-ui,sans-serif;display:none}
.jx-png .mantine-Notifications-root{display:none!important}
"""

PANEL_JS = r"""
(function () {
  var D = JSON.parse(document.getElementById("jaxstiff-view-data").textContent);
  var S = {path: D.initial.path, waypoint: D.initial.waypoint, all: D.initial.all, playing: false, fps: 10};
  var API = window.__jaxstiffView = {ready: false, slot: -1, state: S, data: D};
  (location.hash || "").replace(/^#/, "").split("&").forEach(function (kv) {
    var p = kv.split("="), v = parseInt(p[1], 10);
    if (p[0] === "path" && v >= 0) S.path = Math.min(v, D.paths.length - 1);
    if (p[0] === "waypoint" && v >= 0) S.waypoint = Math.min(v, D.P - 1);
    if (p[0] === "all") S.all = p[1] === "1" || p[1] === "true";
    if (p[0] === "png" && p[1] === "1") document.documentElement.classList.add("jx-png");
    if (p[0] === "panel" && p[1] === "0") S.hidePanel = true;
  });
  function el(tag, attrs, html) {
    var e = document.createElement(tag);
    for (var k in attrs || {}) e.setAttribute(k, attrs[k]);
    if (html !== undefined) e.innerHTML = html;
    return e;
  }
  function timeField() {  // viser's playback time (a Mantine NumberInput in its playback bar)
    var all = document.querySelectorAll("input");
    for (var i = 0; i < all.length; i++) {
      var e = all[i];
      if (e.closest("#jx-panel")) continue;
      if (e.classList.contains("mantine-NumberInput-input") || e.closest(".mantine-NumberInput-root")) return e;
    }
    return null;
  }
  function setTime(t) {
    var f = timeField();
    if (!f) return false;
    var bar = f.closest(".mantine-Paper-root");
    if (bar && bar.style.display !== "none") bar.style.display = "none";
    var set = Object.getOwnPropertyDescriptor(HTMLInputElement.prototype, "value").set;
    set.call(f, t.toFixed(3));
    f.dispatchEvent(new Event("input", {bubbles: true}));
    return true;
  }
  var ui = {};
  function slot() { return (2 * S.path + (S.all ? 1 : 0)) * D.P + S.waypoint; }
  function apply() {
    var k = slot();
    if (!setTime((k + 0.5) * D.slot_s)) return false;
    API.slot = k;
    ui.wp.value = S.waypoint; ui.wpn.value = S.waypoint;
    ui.all.checked = S.all; if (ui.path) ui.path.value = S.path;
    ui.numbers.innerHTML = D.panel[S.path][S.waypoint];
    var hint = S.all ? D.all_hint : D.tcp_hint;  // the --scale hint of what is drawn, if any
    ui.hint.innerHTML = hint; ui.hint.style.display = hint ? "" : "none";
    return true;
  }
  function build() {
    var P = el("div", {id: "jx-panel"});
    P.appendChild(el("div", {"class": "jx-head"}, D.header));
    if (D.paths.length > 1) {
      var r = el("div", {"class": "jx-row"}); r.appendChild(el("label", {}, "path"));
      ui.path = el("select", {id: "jx-path"});
      D.labels.forEach(function (lab, i) { var o = el("option", {value: i}); o.textContent = lab; ui.path.appendChild(o); });
      ui.path.onchange = function () { S.path = parseInt(ui.path.value, 10); apply(); };
      r.appendChild(ui.path); P.appendChild(r);
    }
    var w = el("div", {"class": "jx-row"}); w.appendChild(el("label", {}, D.word));
    ui.wp = el("input", {id: "jx-waypoint", type: "range", min: 0, max: Math.max(D.P - 1, 0), step: 1, value: S.waypoint});
    ui.wpn = el("input", {id: "jx-waypoint-number", type: "number", min: 0, max: Math.max(D.P - 1, 0), step: 1, value: S.waypoint});
    ui.wp.oninput = function () { S.waypoint = parseInt(ui.wp.value, 10); apply(); };
    ui.wpn.onchange = function () {
      var v = parseInt(ui.wpn.value, 10); if (isNaN(v)) return;
      S.waypoint = Math.max(0, Math.min(D.P - 1, v)); apply();
    };
    w.appendChild(ui.wp); w.appendChild(ui.wpn); P.appendChild(w);
    var pl = el("div", {"class": "jx-row"});
    ui.play = el("input", {id: "jx-play", type: "checkbox"});
    ui.play.onchange = function () { S.playing = ui.play.checked; };
    pl.appendChild(ui.play); pl.appendChild(el("label", {"for": "jx-play"}, "play"));
    pl.appendChild(el("label", {"for": "jx-fps", style: "margin-left:12px"}, "play speed (per s)"));
    ui.fps = el("input", {id: "jx-fps", type: "range", min: 1, max: 60, step: 1, value: S.fps});
    var fpsOut = el("span", {}, String(S.fps));
    ui.fps.oninput = function () { S.fps = parseInt(ui.fps.value, 10); fpsOut.textContent = S.fps; };
    pl.appendChild(ui.fps); pl.appendChild(fpsOut); P.appendChild(pl);
    var a = el("div", {"class": "jx-row"});
    ui.all = el("input", {id: "jx-all", type: "checkbox"});
    ui.all.onchange = function () { S.all = ui.all.checked; apply(); };
    a.appendChild(ui.all); a.appendChild(el("label", {"for": "jx-all"}, "all ellipsoids along the path"));
    P.appendChild(a);
    ui.hint = el("div", {id: "jx-all-hint", "class": "jx-hint"}, D.all_hint);
    ui.hint.style.display = "none";
    P.appendChild(ui.hint);
    ui.numbers = el("div", {id: "jx-numbers"});
    P.appendChild(ui.numbers);
    P.appendChild(el("div", {"class": "jx-note"}, D.note));
    if (S.hidePanel) P.style.display = "none";
    document.body.appendChild(P);
  }
  function tick() {
    if (S.playing && D.P > 1) { S.waypoint = (S.waypoint + 1) % D.P; apply(); }
    setTimeout(tick, 1000 / Math.max(S.fps, 1));
  }
  window.addEventListener("keydown", function (ev) {  // Space: our player, not viser's (it would run across slots)
    if (ev.code !== "Space") return;
    var t = ev.target;
    if (t && /^(INPUT|SELECT|TEXTAREA|BUTTON)$/.test(t.tagName)) return;
    ev.preventDefault(); ev.stopImmediatePropagation();
    S.playing = !S.playing; ui.play.checked = S.playing;
  }, true);
  function start() {
    build();
    (function wait() {  // viser decodes the recording, then mounts its playback bar
      if (apply()) { API.ready = true; setTimeout(tick, 200); } else setTimeout(wait, 100);
    })();
  }
  if (document.readyState === "loading") document.addEventListener("DOMContentLoaded", start); else start();
})();
"""


def page_data(data: ViewData, scene: Scene, paths: list[int], b: int, waypoint: int, all_on: bool) -> dict[str, Any]:
    """The JSON the page's panel reads."""
    note = "Static page of jaxstiff view (no server): drag the camera with the mouse; Space plays / pauses." + (
        "" if len(paths) == data.B else f" Only path {b} of {data.B} is in this page (B x P > {MAX_WAYPOINTS})."
    )
    return {
        "slot_s": SLOT_S,
        "P": data.P,
        "word": "waypoint" if data.kind == "shape" else "step",
        "paths": paths,
        "labels": [data.labels[i] for i in paths],
        "header": markdown_html(header_markdown(data, scene)),
        "panel": [[markdown_html(panel_markdown(data, i, p)) for p in range(data.P)] for i in paths],
        "initial": {"path": paths.index(b), "waypoint": int(waypoint), "all": bool(all_on)},
        "camera": {"position": [float(x) for x in scene.position], "look_at": [float(x) for x in scene.look_at]},
        "n_per_m": scene.n_per_m,
        "note": note,
        "all_hint": markdown_html(scene.all_hint()),
        "tcp_hint": markdown_html(scene.tcp_hint()),
    }


def page_html(viser_html: str, payload: dict[str, Any]) -> str:
    """viser's standalone page with our panel: its data (JSON), style and script added to the head."""
    text = json.dumps(payload, separators=(",", ":"), allow_nan=False).replace("</", "<\\/")
    extra = (
        f'<style id="jaxstiff-view-style">{PANEL_CSS}</style>'
        f'<script type="application/json" id="jaxstiff-view-data">{text}</script>'
        f'<script id="jaxstiff-view-panel">{PANEL_JS}</script>'
    )
    head_end = viser_html.index("</head>")
    return viser_html[:head_end] + extra + viser_html[head_end:]


def write_html(
    data: ViewData,
    out: str,
    b: int = 0,
    n_per_m: float | None = None,
    every: int = 1,
    waypoint: int = 0,
    all_ellipsoids: bool = False,
) -> str:
    """Write the static page of ``data`` (every path, or only path ``b`` past :data:`MAX_WAYPOINTS`
    waypoints in all), starting at path ``b``, ``waypoint``, "all ellipsoids" ``all_ellipsoids``.
    Written atomically; returns the path."""
    import viser

    from jaxstiff.runtime._io import atomic_write_text

    if not 0 <= b < data.B:
        raise ValueError(f"path {b}: the result has {data.B} path(s), 0..{data.B - 1}")
    if not 0 <= waypoint < data.P:
        raise ValueError(f"waypoint {waypoint}: the result has {data.P} waypoints, 0..{data.P - 1}")
    paths = list(range(data.B)) if data.B * data.P <= MAX_WAYPOINTS else [b]
    # viser prints its live server's address and "(viser) Server stopped" whatever verbose says: this
    # server only records the page, and a user writing a file was told of a server on a port nobody asked for
    with contextlib.redirect_stdout(io.StringIO()):
        server = viser.ViserServer(host="127.0.0.1", port=_free_port(), verbose=False)
    try:
        scene = Scene(server, data, n_per_m, every)
        scene.show(paths[0], 0)
        rec = server.get_scene_serializer()
        for path in paths:
            for all_on in (False, True):
                scene.show_all(False)
                scene.show(path, 0)
                scene.show_all(all_on)
                for p in range(data.P):
                    scene.show(path, p)
                    rec.insert_sleep(SLOT_S)
        viser_html = rec.as_html()
    finally:
        with contextlib.redirect_stdout(io.StringIO()):
            server.stop()  # (joins the server's thread, which prints as it ends)
    return atomic_write_text(out, page_html(viser_html, page_data(data, scene, paths, b, waypoint, all_ellipsoids)))


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])
