"""The live viewer: a viser server with the scene and its panel (:func:`open_viewer`). The static
page with the same panel is :func:`jaxstiff.view._static.write_html`.

The panel: a path selector (B > 1), the waypoint slider, play/pause and the speed, "all ellipsoids
along the path", and the numbers at the current waypoint (shape: alpha, rho, criterion, status,
CMS factor; csc: u, the Frobenius error, tracking error, status) and kj per joint ("rigid" for a
rigid locked joint), the robot, the solver or controller, the ellipsoid scale (per cm of the scene,
:meth:`Scene.scale_text`), what each colour is (:meth:`Scene.legend`), and, while "all ellipsoids"
is on and they are large beside the path, a hint at ``--scale`` (:meth:`Scene.all_hint`). Waypoints
are numbered from 0, as ``--waypoint``, the slider and the files.
"""

from __future__ import annotations

import os
import threading
import time
from typing import Any

from jaxstiff.view._data import ViewData
from jaxstiff.view._scene import Scene

__all__ = ["Viewer"]


def panel_markdown(data: ViewData, b: int, p: int) -> str:
    """The panel's numbers at path b, waypoint p (markdown)."""
    word = "waypoint" if data.kind == "shape" else "step"
    lines = [f"**{word} {p} (0-based) of {data.P}**, {data.labels[b]}", ""]
    lines += [f"- {k}: {v}" for k, v in data.info(b, p)]
    kind = "kj_scaled (after CMS)" if data.kind == "shape" else "realised kj"
    lines += ["", f"**{kind}**", ""] + [f"- {name}: {v}" for name, v in data.kj_lines(b, p)]
    return "\n".join(lines)


def header_markdown(data: ViewData, scene: Scene) -> str:
    m = data.meta
    if data.kind == "shape":
        what = f"shape, criterion {m.get('criterion')}, ratio {m.get('ratio')}, solver {m.get('solver')}"
    else:
        what = f"csc, task {m.get('task')}, {m.get('step')} step, beta {m.get('beta')}"
    return (
        f"**{os.path.basename(data.source)}**: {what}; robot {data.robot.name} ({data.robot.n} joints, "
        f"locked joints: {data.locked_joints}). {scene.scale_text()}.\n\n{scene.legend()}"
    )


class Viewer:
    """The live viewer: scene + GUI in ``server``; :meth:`step` advances when playing."""

    def __init__(self, server: Any, data: ViewData, n_per_m: float | None = None, every: int = 1) -> None:
        self.server, self.data = server, data
        self.scene = Scene(server, data, n_per_m, every)
        gui = server.gui
        gui.add_markdown(header_markdown(data, self.scene))
        self.path = None
        if data.B > 1:
            self.path = gui.add_dropdown("path", tuple(data.labels), initial_value=data.labels[0])
            self.path.on_update(lambda _: self.refresh())
        word = "waypoint" if data.kind == "shape" else "step"
        self.slider = gui.add_slider(word, min=0, max=max(data.P - 1, 1), step=1, initial_value=0)
        self.slider.on_update(lambda _: self.refresh())
        self.play = gui.add_checkbox("play", initial_value=False)
        self.fps = gui.add_slider("play speed (per s)", min=1, max=60, step=1, initial_value=10)
        self.all = gui.add_checkbox("all ellipsoids along the path", initial_value=False)
        self.all.on_update(lambda _: self._all_changed())
        hint = self.scene.all_hint()  # shown while "all ellipsoids" is on
        self.hint = gui.add_markdown(hint, visible=False) if hint else None
        tcp = self.scene.tcp_hint()  # shown while it is off
        self.tcp_hint = gui.add_markdown(tcp, visible=True) if tcp else None
        self.panel = gui.add_markdown(panel_markdown(data, 0, 0))
        self.lock = threading.Lock()

    def start_at(self, b: int = 0, p: int = 0, all_on: bool = False) -> None:
        """Show path b, waypoint p, and "all ellipsoids" when ``all_on`` (the panel follows)."""
        if self.path is not None:
            self.path.value = self.data.labels[b]
        self.slider.value = min(max(int(p), 0), self.data.P - 1)
        self.all.value = bool(all_on)
        self.refresh()
        self._all_changed()

    def _all_changed(self) -> None:
        on = bool(self.all.value)
        self.scene.show_all(on)
        if self.hint is not None:
            self.hint.visible = on
        if self.tcp_hint is not None:
            self.tcp_hint.visible = not on

    def _b(self) -> int:
        return 0 if self.path is None else self.data.labels.index(str(self.path.value))

    def refresh(self) -> None:
        with self.lock:
            b, p = self._b(), min(int(self.slider.value), self.data.P - 1)
            self.scene.show(b, p)
            self.panel.content = panel_markdown(self.data, b, p)

    def step(self) -> float:
        """Advance one waypoint when playing; returns the seconds to wait."""
        if self.play.value and self.data.P > 1:
            self.slider.value = (int(self.slider.value) + 1) % self.data.P
        return 1.0 / max(float(self.fps.value), 1.0)


def open_viewer(
    data: ViewData, port: int = 8080, host: str = "127.0.0.1", n_per_m: float | None = None, every: int = 1
) -> Viewer:
    """Start the server (in its own threads) with the scene; returns the :class:`Viewer`."""
    import viser

    server = viser.ViserServer(host=host, port=port, verbose=False)
    return Viewer(server, data, n_per_m, every)


def serve_forever(viewer: Viewer) -> None:
    """Play loop until Ctrl-C."""
    while True:
        time.sleep(viewer.step())
