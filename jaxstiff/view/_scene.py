"""The 3-D scene of a result in viser: arm, TCP path, desired directions, stiffness ellipsoids.

:class:`Scene` adds the nodes once and moves them per waypoint (:meth:`Scene.show`): the arm as
its link meshes when the URDF names meshes that resolve, else as capsules between the joint origins
(joint axes as red strokes); the waypoints as a green line; the desired direction at each waypoint
as a purple stroke; the stiffness ellipsoid at the TCP (orange; csc: the realised ``K_C`` orange,
the desired ``K_xd`` teal, beside it to the right on screen, both labelled); the TCP as a black ball
with a black stick along the tool's z axis (not an RGB axis triad: its red, green and blue would read
as a joint axis, the path and a link); a floor grid. :meth:`Scene.legend` names each of them for the
panel. Semi-axes are drawn at a fixed scale for the whole file, ``n_per_m`` N/m per metre of the
scene (the arm's own metres: the view is perspective and zooms, so no length on screen is fixed;
1 cm in the scene = ``n_per_m / 100`` N/m), stated in the panel (:meth:`Scene.scale_text`). Colours
(RGB) are fixed so that tests can find them in a screenshot.
"""

from __future__ import annotations

import math
import warnings
from typing import Any

import numpy as np

from jaxstiff.view._data import ViewData, check_drawable
from jaxstiff.view._framing import arm_sizes, choose_view, drawn_semi_axis, nice_scale
from jaxstiff.view._geometry import capsule, cylinder, icosphere
from jaxstiff.view._kinematics import chain_frames, ellipsoid_axes, link_frames
from jaxstiff.view._meshes import urdf_meshes

__all__ = ["COLORS", "nice_scale", "rotation_wxyz", "ellipsoid_pose", "ellipsoid_vertices"]

COLORS = {
    "arm": (40, 80, 220),
    "joint": (20, 40, 120),
    "axis": (230, 20, 20),
    "path": (0, 170, 60),
    "direction": (150, 40, 200),
    "ellipsoid": (255, 140, 0),
    "desired": (0, 170, 170),
    "all": (255, 190, 90),
    "tcp": (25, 25, 25),
}
_LOOK: dict[str, dict[str, Any]] = {"ellipsoid": {}, "desired": {"opacity": 0.9}}
NEAR_OPACITY = 0.35  #: links and joints that can come between the camera and the ellipsoid are see-through
FOV_DEG, ASPECT = 75.0, 1.1  #: viser's vertical field of view; width / height of the page left of the panel
CAMERA_MARGIN = 1.25  #: the camera this much further than the closest distance that shows everything
CAMERA_SHIFT = 0.08  #: look this far (diagonals) right of the centre: the panel covers the page's right side
#: where the label over the TCP goes: a page of ``--png``'s default 1200 x 800 px whose panel covers the right
#: from 0.71 of its width (0.70: a margin), viser's label font about 6.5 px a character
PAGE_PX, PAGE_ASPECT, PANEL_FROM, LABEL_CHAR_PX = 1200.0, 1.5, 0.70, 6.5
ALL_HINT_RATIO = 0.5  #: "all ellipsoids" hints at --scale when a drawn semi-axis exceeds this x the path's extent
TCP_HINT_RATIO = 1.0  #: the TCP's ellipsoid hints at --scale when its drawn semi-axis exceeds this x the path's extent


def rotation_wxyz(R: np.ndarray) -> np.ndarray:
    """Unit quaternion (w, x, y, z) of a rotation matrix (Shepperd's method)."""
    t = np.trace(R)
    if t > 0:
        s = 2.0 * math.sqrt(1.0 + t)
        return np.array([0.25 * s, (R[2, 1] - R[1, 2]) / s, (R[0, 2] - R[2, 0]) / s, (R[1, 0] - R[0, 1]) / s])
    i = int(np.argmax(np.diag(R)))
    j, k = (i + 1) % 3, (i + 2) % 3
    s = 2.0 * math.sqrt(max(1.0 + R[i, i] - R[j, j] - R[k, k], 1e-300))
    q = np.empty(4)
    q[0] = (R[k, j] - R[j, k]) / s
    q[1 + i] = 0.25 * s
    q[1 + j] = (R[j, i] + R[i, j]) / s
    q[1 + k] = (R[k, i] + R[i, k]) / s
    return q


def _matrix(wxyz: np.ndarray) -> np.ndarray:
    """Rotation matrix of a unit quaternion (w, x, y, z)."""
    w, x, y, z = wxyz
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
    )


def _segment_pose(p0: np.ndarray, p1: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """Centre, quaternion turning +z onto p1 - p0, and length of a capsule from p0 to p1."""
    d = p1 - p0
    L = float(np.linalg.norm(d))
    z = d / L
    x = np.cross([0.0, 1.0, 0.0] if abs(z[1]) < 0.9 else [1.0, 0.0, 0.0], z)
    x /= np.linalg.norm(x)
    return 0.5 * (p0 + p1), rotation_wxyz(np.column_stack([x, np.cross(z, x), z])), L


def ellipsoid_pose(K: np.ndarray, n_per_m: float) -> tuple[np.ndarray, tuple[float, float, float]]:
    """Quaternion and per-axis scale (m) that turn the unit sphere into K's ellipsoid, semi-axes
    ``eig(K) / n_per_m`` m (a flat, "xy" one keeps a thin visible thickness)."""
    w, V = ellipsoid_axes(K)
    if np.linalg.det(V) < 0:
        V = V * np.array([1.0, 1.0, -1.0])
    semi = np.maximum(w / n_per_m, 0.02 * max(float(w[0]) / n_per_m, 1e-6))
    return rotation_wxyz(V), (float(semi[0]), float(semi[1]), float(semi[2]))


def ellipsoid_vertices(sphere: np.ndarray, K: np.ndarray, n_per_m: float) -> np.ndarray:
    """The unit-sphere vertices (V, 3) mapped onto K's ellipsoid, semi-axes ``eig(K) / n_per_m`` m,
    centred at 0 (a flat, "xy" ellipsoid keeps a thin visible thickness)."""
    wxyz, semi = ellipsoid_pose(K, n_per_m)
    return (sphere * np.asarray(semi)) @ _matrix(wxyz).T


class Scene:
    """The scene of ``data`` in a viser server; :meth:`show` (path b, waypoint p) moves it.

    Args:
        server: a ``viser.ViserServer``.
        data: the result (:func:`jaxstiff.view._data.load_view_data`).
        n_per_m: ellipsoid scale, N/m per metre of the scene (the arm's metres; default:
            :func:`nice_scale` of the file's largest semi-axis, drawn at
            :func:`~jaxstiff.view._framing.drawn_semi_axis` of the arm's length).
        every: with "all ellipsoids", draw every ``every``-th waypoint's.

    Sizes follow the arm (:func:`~jaxstiff.view._framing.arm_sizes`); the links and joints that can
    come between the camera and the ellipsoid (within the largest drawn semi-axis of a TCP along
    the file) are drawn see-through (opacity :data:`NEAR_OPACITY`): viser draws see-through meshes
    after the solid ones, so the solid ellipsoid shows through them, and it has no per-mesh "draw on
    top" (depth test) switch. The camera: :func:`~jaxstiff.view._framing.choose_view`.
    """

    def __init__(self, server: Any, data: ViewData, n_per_m: float | None = None, every: int = 1) -> None:
        self.server, self.data, self.every = server, data, max(1, int(every))
        check_drawable(data)
        self.frames = chain_frames(data.robot, data.q)  # (B, P, n, 4, 4), (B, P, 4, 4)
        self.links = link_frames(data.robot, data.q) if data.robot.n else None
        self.sizes = arm_sizes(*self.frames)
        #: the largest semi-axis (N/m) of K along the file, and of K_desired (csc; 0 without)
        self.largest = float(ellipsoid_axes(data.K)[0][..., 0].max())
        self.largest_desired = 0.0 if data.K_desired is None else float(ellipsoid_axes(data.K_desired)[0][..., 0].max())
        largest = max(self.largest, self.largest_desired) if data.K_desired is not None else self.largest
        self.n_per_m = float(n_per_m) if n_per_m else nice_scale(largest, drawn_semi_axis(self.sizes.length))
        self.meshes, missing = urdf_meshes(data.robot)
        if missing:
            warnings.warn(
                f"{len(missing)} link mesh file(s) of {data.robot.source} do not resolve or cannot be read "
                f"(first: {missing[0]}); "
                "the arm is drawn as capsules between the joint origins",
                stacklevel=2,
            )
            self.meshes = []
        self.sphere = icosphere(3)  # (vertices, faces) of the unit sphere
        self.points = self._chain_points()  # (B, P, n + 2, 3)
        self.near = self._near_tcp()
        self.view = self._choose_view()
        self.beside = self._beside_offset()
        self.b, self.p = 0, 0
        self.capsules: dict[int, tuple[Any, float]] = {}
        self.all_handles: list[Any] = []
        sc = server.scene
        sc.set_up_direction("+z")
        self._add_grid()
        self.handles: dict[str, Any] = {}
        self._add_path(0)
        self._add_static_arm()
        self._camera()
        self.show(0, 0)

    # ------------------------------------------------------------------ geometry
    def _chain_points(self) -> np.ndarray:
        joints, tcp = self.frames
        base = np.zeros(joints.shape[:-3] + (1, 3))
        return np.concatenate([base, joints[..., :3, 3], tcp[..., None, :3, 3]], axis=-2)

    def _semi(self, K: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Drawn semi-axes (m) and directions of stiffness matrices K."""
        w, V = ellipsoid_axes(K)
        return w / self.n_per_m, V

    def _near_tcp(self) -> np.ndarray:
        """(n + 2,) bool per point of the chain (base, joints, TCP): the link from it to the next
        point, or its joint ball, comes within the largest drawn semi-axis (+ a link radius) of
        the TCP at some waypoint."""
        pts = self.points.reshape(-1, self.points.shape[-2], 3)
        tcp = pts[:, -1:]
        reach = float(self._semi(self.data.K)[0][..., 0].max()) + 2.0 * self.sizes.radius
        t = np.linspace(0.0, 1.0, 9)[:, None, None, None]
        seg = pts[None, :, :-1] * (1 - t) + pts[None, :, 1:] * t  # (9, N, n + 1, 3)
        link_near = (np.linalg.norm(seg - tcp[None], axis=-1) < reach).any(axis=(0, 1))
        ball_near = (np.linalg.norm(pts - tcp, axis=-1) < reach + 1.5 * self.sizes.radius).any(axis=0)
        return np.append(link_near, True) | ball_near

    def _choose_view(self) -> np.ndarray:
        d = self.data
        semi, V = self._semi(d.K)
        N = d.B * d.P
        path = d.target.reshape(-1, 3)
        chain = self.points.reshape(N, -1, 3)
        return choose_view(path, chain, semi.reshape(N, 3), V.reshape(N, 3, 3), self.sizes.radius)

    # ------------------------------------------------------------------ nodes
    def _add_grid(self) -> None:
        """A floor grid at z = 0 under the whole scene, cells of 10 cm (5 cm for arms under 0.6 m)."""
        cell = self.sizes.grid_cell
        pts = np.vstack([self.points.reshape(-1, 3), self.data.target.reshape(-1, 3)])
        half = float(np.abs(pts[:, :2]).max()) + 2 * cell
        width = 2 * cell * math.ceil(half / cell)
        self.server.scene.add_grid("/grid", width=width, height=width, cell_size=cell, position=(0.0, 0.0, 0.0))

    def _add_path(self, b: int) -> None:
        sc, d, s = self.server.scene, self.data, self.sizes
        pts = d.target[b]
        seg = np.stack([pts[:-1], pts[1:]], axis=1) if d.P > 1 else np.stack([pts, pts], axis=1)
        self.handles["path"] = sc.add_line_segments("/path", seg, COLORS["path"], thickness=s.path_thickness)
        if d.direction is not None:  # about 15 strokes along the path: denser ones would hide the ellipsoid
            k = max(1, d.P // 15)
            dd = d.direction[b, ::k] * s.stroke
            seg = np.stack([pts[::k] - dd, pts[::k] + dd], axis=1)
            self.handles["directions"] = sc.add_line_segments(
                "/directions", seg, COLORS["direction"], thickness=0.5 * s.path_thickness
            )

    def _look(self, near: bool) -> dict[str, Any]:
        return {"opacity": NEAR_OPACITY, "cast_shadow": False} if near else {}

    def _add_static_arm(self) -> None:
        sc, s = self.server.scene, self.sizes
        for k, m in enumerate(self.meshes):
            near = bool(self.near[m.anchor + 1])
            self.handles[f"mesh{k}"] = sc.add_mesh_simple(
                f"/arm/mesh{k}", m.vertices, m.faces, color=COLORS["arm"], **self._look(near)
            )
        # the TCP: a black ball and a black stick along the tool's z axis (module text: not an RGB triad)
        self.handles["tcp"] = sc.add_mesh_simple("/tcp", *icosphere(2, radius=0.3 * s.radius), color=COLORS["tcp"])
        tool_z = cylinder(radius=0.12 * s.radius, height=s.tcp_axes, sections=12)
        self.handles["tcp_z"] = sc.add_mesh_simple("/tcp_z", *tool_z, color=COLORS["tcp"])
        for key in ("ellipsoid", "desired") if self.data.K_desired is not None else ("ellipsoid",):
            self.handles[key] = sc.add_mesh_simple(f"/{key}", *self.sphere, color=COLORS[key], scale=0.01, **_LOOK[key])
        if self.data.K_desired is not None:
            self.handles["desired_label"] = sc.add_label("/desired_label", "desired K_xd", position=(0.0, 0.0, 0.0))
            self.handles["realised_label"] = sc.add_label("/realised_label", "realised K_C", position=(0.0, 0.0, 0.0))
        stick = cylinder(radius=0.2 * s.radius, height=s.axis_length, sections=12)
        for i in range(self.data.robot.n):
            look = self._look(bool(self.near[i + 1]))
            if not self.meshes:
                ball = icosphere(2, radius=float(s.ball[i]))
                self.handles[f"joint{i}"] = sc.add_mesh_simple(f"/arm/joint{i}", *ball, color=COLORS["joint"], **look)
            self.handles[f"axis{i}"] = sc.add_mesh_simple(f"/arm/axis{i}", *stick, color=COLORS["axis"], **look)
        self.handles["label"] = sc.add_label("/label", "", position=(0.0, 0.0, 0.0), anchor="bottom-left")

    def _pose_arm(self, b: int, p: int) -> None:
        d = self.data
        joints, tcp = self.frames[0][b, p], self.frames[1][b, p]
        for k, m in enumerate(self.meshes):
            T = (np.eye(4) if m.anchor < 0 or self.links is None else self.links[b, p, m.anchor]) @ m.offset
            h = self.handles[f"mesh{k}"]
            h.position, h.wxyz = T[:3, 3], rotation_wxyz(T[:3, :3])
        pts = self.points[b, p]
        if not self.meshes:
            for i in range(len(pts) - 1):
                self._pose_capsule(i, pts[i], pts[i + 1])
        z = np.einsum("nij,nj->ni", joints[:, :3, :3], np.asarray(d.robot.axes, dtype=float))
        half = 0.5 * self.sizes.axis_length
        for i in range(d.robot.n):
            if not self.meshes:
                self.handles[f"joint{i}"].position = pts[i + 1]
            h = self.handles[f"axis{i}"]
            h.position, h.wxyz = pts[i + 1], _segment_pose(pts[i + 1] - half * z[i], pts[i + 1] + half * z[i])[1]
        self.handles["tcp"].position = tcp[:3, 3]
        h = self.handles["tcp_z"]  # the stick from the TCP along its z axis
        h.position, h.wxyz = tcp[:3, 3] + 0.5 * self.sizes.tcp_axes * tcp[:3, 2], rotation_wxyz(tcp[:3, :3])

    def _pose_capsule(self, i: int, p0: np.ndarray, p1: np.ndarray) -> None:
        if np.linalg.norm(p1 - p0) < 1e-6:
            if i in self.capsules:
                self.capsules[i][0].visible = False
            return
        centre, wxyz, L = _segment_pose(p0, p1)
        h, L0 = self.capsules.get(i, (None, -1.0))
        if h is None or abs(L - L0) > 1e-9:  # new, or a prismatic joint changed the length
            h = self.server.scene.add_mesh_simple(
                f"/arm/link{i}",
                *capsule(L, float(self.sizes.link[i])),
                color=COLORS["arm"],
                **self._look(bool(self.near[i])),
            )
            self.capsules[i] = (h, L)
        h.position, h.wxyz, h.visible = centre, wxyz, True

    def show(self, b: int, p: int) -> None:
        """Move everything to path b, waypoint p."""
        d = self.data
        if b != self.b:
            self.b = b
            self._add_path(b)
            if self.all_handles:
                self.show_all(True)
        self.p = p
        self._pose_arm(b, p)
        tcp = self.frames[1][b, p, :3, 3]
        for key, K in (("ellipsoid", d.K), ("desired", d.K_desired)):
            if K is None:
                continue
            h = self.handles[key]
            h.wxyz, h.scale = ellipsoid_pose(K[b, p], self.n_per_m)
            h.position = tcp if key == "ellipsoid" else tcp + self.beside
        if d.K_desired is not None:
            self.handles["desired_label"].position = tcp + self.beside + np.array([0.0, 0.0, self.beside_height])
            self.handles["realised_label"].position = tcp + np.array([0.0, 0.0, self.beside_height])
        lab = self.handles["label"]
        lab.position = tcp + np.array([0.0, 0.0, self.sizes.label_lift])
        lab.text = text = self.label_text(b, p)
        lab.anchor = self.label_anchor(tcp, text)

    def label_text(self, b: int, p: int) -> str:
        """The label above the TCP: the waypoint (0-based, as the slider) and its first two numbers,
        short (their targets and the rest are in the panel)."""
        d = self.data
        values = ", ".join(f"{k} {v.split(' (')[0]}" for k, v in d.info(b, p)[:2])
        return f"{'waypoint' if d.kind == 'shape' else 'step'} {p}: {values}"

    def label_anchor(self, tcp: np.ndarray, text: str) -> str:
        """Which corner of the label ``text`` sits at the TCP: the text runs to the right of the TCP
        where it ends left of the panel (which covers the page's right side from :data:`PANEL_FROM`
        of its width), else to its left; as seen from the starting camera on a page of
        :data:`PAGE_PX` x :data:`PAGE_ASPECT` (the user may turn the camera; the panel numbers are
        the same)."""
        view = self.position - self.look_at
        depth = float(np.linalg.norm(view))
        right = np.cross(-view, [0.0, 0.0, 1.0])
        right /= np.linalg.norm(right)
        rel = np.asarray(tcp, dtype=float) - self.position
        ahead = max(float(-(rel @ view)) / depth, 1e-9)
        x = 0.5 + 0.5 * float(rel @ right) / (ahead * math.tan(math.radians(FOV_DEG) / 2) * PAGE_ASPECT)
        return "bottom-left" if x + LABEL_CHAR_PX * len(text) / PAGE_PX <= PANEL_FROM else "bottom-right"

    def show_all(self, on: bool) -> None:
        """Draw (or remove) the ellipsoids of every ``every``-th waypoint of the current path."""
        for h in self.all_handles:
            h.remove()
        self.all_handles = []
        if not on:
            return
        d, b = self.data, self.b
        for p in range(0, d.P, self.every):
            wxyz, semi = ellipsoid_pose(d.K[b, p], self.n_per_m)
            h = self.server.scene.add_mesh_simple(
                f"/all/e{p}",
                *self.sphere,
                color=COLORS["all"],
                opacity=0.5,
                scale=semi,
                wxyz=wxyz,
                position=self.frames[1][b, p, :3, 3],
            )
            self.all_handles.append(h)

    def _beside_offset(self) -> np.ndarray:
        """csc: where the desired ``K_xd`` ellipsoid sits relative to the TCP (the realised ``K_C`` is at
        the TCP): to the right on screen, clear of both ellipsoids at their largest along the file."""
        d = self.data
        self.beside_height = 0.0
        if d.K_desired is None:
            return np.zeros(3)
        sc, sd = self.largest / self.n_per_m, self.largest_desired / self.n_per_m
        self.beside_height = max(sc, sd) + 0.02
        right = np.cross(-self.view, [0.0, 0.0, 1.0])
        return right / np.linalg.norm(right) * (sc + sd + 0.04)

    def _camera(self) -> None:
        """Frame the arm, the path and the ellipsoids (the largest semi-axis around every TCP): the
        camera looks along ``-self.view`` (:func:`~jaxstiff.view._framing.choose_view`) at the centre
        of their box, from just far enough that every such point is in the picture (viser's vertical
        field of view, the width left of the panel), a little right of the centre."""
        d = self.data
        tcp = self.frames[1][..., :3, 3].reshape(-1, 3)
        big = self.largest / self.n_per_m
        pts = np.vstack(
            [d.target.reshape(-1, 3), self.points.reshape(-1, 3)]
            + [tcp + big * e for e in np.vstack([np.eye(3), -np.eye(3)])]
            + [tcp + self.beside + s * self.beside_height * e for e in np.eye(3) for s in (-1, 1)]
        )
        view = self.view
        lo, hi = pts.min(0), pts.max(0)
        right = np.cross(-view, [0.0, 0.0, 1.0])
        right /= np.linalg.norm(right)
        up = np.cross(right, -view)
        centre = 0.5 * (lo + hi) + CAMERA_SHIFT * float(np.linalg.norm(hi - lo)) * right
        rel = pts - centre
        tan_v = math.tan(math.radians(FOV_DEG) / 2)
        need = rel @ view + np.maximum(np.abs(rel @ up) / tan_v, np.abs(rel @ right) / (ASPECT * tan_v))
        self.look_at = centre
        self.position = centre + CAMERA_MARGIN * max(float(need.max()), 0.25 * self.sizes.length) * view
        cam = self.server.initial_camera
        cam.look_at = tuple(self.look_at)
        cam.position = tuple(self.position)
        cam.up = (0.0, 0.0, 1.0)

    def scale_text(self) -> str:
        """The stated ellipsoid scale: per length in the scene (measured like the arm; the view is
        perspective and zooms, so no length on screen is fixed), with the floor grid's cell."""
        return (
            f"ellipsoid semi-axes: 1 cm in the scene (measured like the arm, not on screen) = "
            f"{self.n_per_m / 100:.4g} N/m ({self.n_per_m:.4g} N/m per m; floor grid cells "
            f"{100 * self.sizes.grid_cell:.0f} cm)"
        )

    def legend(self) -> str:
        """What each drawn thing is, by colour (every element of the scene)."""
        csc = self.data.K_desired is not None
        parts = [
            "Orange: " + ("realised K_C at the TCP; teal, beside it: desired K_xd" if csc else "K_T after CMS"),
            "green line: path (the waypoints)",
        ]
        if self.data.direction is not None:
            parts.append("purple strokes: desired direction")
        parts += [
            "blue: links" + ("" if self.meshes else "; dark blue balls: joints"),
            "red sticks: joint axes",
            "black ball and stick: the TCP and its z axis",
            "pale orange: all ellipsoids along the path"
            + (f" (one in {self.every} waypoints)" if self.every > 1 else ""),
            "grey: floor grid at z = 0",
        ]
        return "; ".join(parts) + "."

    def path_extent(self) -> float:
        """The largest extent (m) of a path of the file: the diagonal of its waypoints' box."""
        return float(np.linalg.norm(np.ptp(self.data.target, axis=1), axis=-1).max())

    def tcp_hint(self) -> str:
        """A hint at ``--scale`` when the ellipsoid at the TCP hides the path: its largest drawn
        semi-axis, at any waypoint, is longer than the path's extent (:data:`TCP_HINT_RATIO`); ""
        otherwise (or when the path is a point, or one waypoint). Short paths meet it: an arm's
        ellipsoid drawn about a quarter of its reach long covers a path of a few centimetres."""
        return self._scale_hint(
            TCP_HINT_RATIO,
            0.7,  # the ellipsoid and the path both seen (looked at on a 5 cm path: 0.3-0.5 left a sliver)
            "The ellipsoid at the TCP: its largest semi-axis is drawn {drawn} cm long, longer than the "
            "path ({extent} cm), so it hides the path; --scale {better} draws it {short} cm long.",
        )

    def all_hint(self) -> str:
        """A hint at ``--scale`` when "all ellipsoids" would hide the path: the largest drawn semi-axis
        is longer than :data:`ALL_HINT_RATIO` x the path's extent; "" otherwise (or when the path is a
        point, or one waypoint)."""
        return self._scale_hint(
            ALL_HINT_RATIO,
            0.3,
            "All ellipsoids: the largest semi-axis is drawn {drawn} cm long, more than half the path's "
            "extent ({extent} cm), so they hide the path and the arm; --scale {better} draws it {short} cm "
            "long (--every N draws every N-th waypoint's).",
        )

    def _scale_hint(self, ratio: float, fraction: float, text: str) -> str:
        """``text`` filled in where the largest drawn semi-axis exceeds ``ratio`` x the path's extent
        (``drawn``, ``extent``, the ``better`` --scale that draws it about ``fraction`` x the extent,
        and how long it then is: ``short``); "" otherwise, or for a path of one waypoint or under 1 mm."""
        extent = self.path_extent()
        largest = self.largest
        drawn = largest / self.n_per_m
        if self.data.P < 2 or extent < 1e-3 or drawn <= ratio * extent:
            return ""
        better = nice_scale(largest, fraction * extent)
        return text.format(
            drawn=f"{100 * drawn:.3g}",
            extent=f"{100 * extent:.3g}",
            better=f"{better:.4g}",
            short=f"{100 * largest / better:.2g}",
        )
