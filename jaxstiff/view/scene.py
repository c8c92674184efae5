"""The 3-D scene of a result in viser: arm, TCP path, desired directions, stiffness ellipsoids.

:class:`Scene` adds the nodes once and moves them per waypoint (:meth:`Scene.show`): the arm as
its link meshes when the URDF names meshes that resolve, else as capsules between the joint origins
(joint axes as red strokes); the waypoints as a green line; the desired direction at each waypoint
as a purple stroke; the stiffness ellipsoid at the TCP (orange; csc: the realised ``K_C`` orange,
the desired ``K_xd`` teal, beside it to the right on screen, both labelled). Semi-axes are drawn at a fixed scale
for the whole file, ``n_per_m`` N/m per metre on screen (1 cm = ``n_per_m / 100`` N/m), stated in the
panel and the page's label. Colours (RGB) are fixed so that tests can find them in a screenshot.
"""

from __future__ import annotations

import math
import warnings
from typing import Any

import numpy as np

from jaxstiff.view.data import ViewData
from jaxstiff.view.geometry import capsule, cylinder, icosphere
from jaxstiff.view.kinematics import chain_frames, ellipsoid_axes, link_frames
from jaxstiff.view.meshes import urdf_meshes

__all__ = ["Scene", "COLORS", "nice_scale", "rotation_wxyz", "ellipsoid_pose", "ellipsoid_vertices"]

COLORS = {
    "arm": (40, 80, 220),
    "joint": (20, 40, 120),
    "axis": (230, 20, 20),
    "path": (0, 170, 60),
    "direction": (150, 40, 200),
    "ellipsoid": (255, 140, 0),
    "desired": (0, 170, 170),
    "all": (255, 190, 90),
}
_LOOK: dict[str, dict[str, Any]] = {"ellipsoid": {}, "desired": {"opacity": 0.9}}
CAPSULE_RADIUS = 0.03  #: m
PATH_THICKNESS = 0.005  #: m, the path's line (thinner than an ellipsoid's short axes, which it would hide)
SCREEN_SEMI_AXIS = 0.25  #: m on screen of the largest semi-axis along the path (before rounding the scale)
VIEW = np.array([0.75, -0.95, 0.8]) / np.linalg.norm([0.75, -0.95, 0.8])  #: from the scene's centre to the camera
FOV_DEG, ASPECT = 75.0, 1.1  #: viser's vertical field of view; width / height of the page left of the panel
CAMERA_MARGIN = 1.25  #: the camera this much further than the closest distance that shows everything
CAMERA_SHIFT = 0.08  #: look this far (diagonals) right of the centre: the panel covers the page's right side


def nice_scale(largest: float, screen: float = SCREEN_SEMI_AXIS) -> float:
    """N/m per metre on screen: ``largest / screen`` rounded up to 1, 2 or 5 x 10^k."""
    if not np.isfinite(largest) or largest <= 0:
        return 1.0
    raw = largest / screen
    e = 10 ** math.floor(math.log10(raw))
    return float(next(m * e for m in (1, 2, 5, 10) if m * e >= raw * (1 - 1e-12)))


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
        data: the result (:func:`jaxstiff.view.data.load_view_data`).
        n_per_m: ellipsoid scale, N/m per metre on screen (default: :func:`nice_scale` of the file).
        every: with "all ellipsoids", draw every ``every``-th waypoint's.
    """

    def __init__(self, server: Any, data: ViewData, n_per_m: float | None = None, every: int = 1) -> None:
        self.server, self.data, self.every = server, data, max(1, int(every))
        big = [data.K] + ([data.K_desired] if data.K_desired is not None else [])
        self.n_per_m = (
            float(n_per_m) if n_per_m else nice_scale(max(float(ellipsoid_axes(k)[0][..., 0].max()) for k in big))
        )
        self.frames = chain_frames(data.robot, data.q)  # (B, P, n, 4, 4), (B, P, 4, 4)
        self.links = link_frames(data.robot, data.q) if data.robot.n else None
        self.meshes, missing = urdf_meshes(data.robot)
        if missing:
            warnings.warn(
                f"{len(missing)} link mesh file(s) of {data.robot.source} do not resolve (first: {missing[0]}); "
                "the arm is drawn as capsules between the joint origins",
                stacklevel=2,
            )
            self.meshes = []
        self.sphere = icosphere(3)  # (vertices, faces) of the unit sphere
        self.beside = self._beside_offset()
        self.b, self.p = 0, 0
        self.capsules: dict[int, tuple[Any, float]] = {}
        self.all_handles: list[Any] = []
        sc = server.scene
        sc.set_up_direction("+z")
        sc.add_grid("/grid", width=1.6, height=1.6, cell_size=0.1, position=(0.0, 0.0, 0.0))
        self.handles: dict[str, Any] = {}
        self._add_path(0)
        self._add_static_arm()
        self.show(0, 0)
        self._camera()

    # ------------------------------------------------------------------ nodes
    def _add_path(self, b: int) -> None:
        sc, d = self.server.scene, self.data
        pts = d.target[b]
        seg = np.stack([pts[:-1], pts[1:]], axis=1) if d.P > 1 else np.stack([pts, pts], axis=1)
        self.handles["path"] = sc.add_line_segments("/path", seg, COLORS["path"], thickness=PATH_THICKNESS)
        if d.direction is not None:  # about 15 strokes along the path: denser ones would hide the ellipsoid
            k = max(1, d.P // 15)
            dd = d.direction[b, ::k] * 0.04
            seg = np.stack([pts[::k] - dd, pts[::k] + dd], axis=1)
            self.handles["directions"] = sc.add_line_segments(
                "/directions", seg, COLORS["direction"], thickness=0.5 * PATH_THICKNESS
            )

    def _add_static_arm(self) -> None:
        sc = self.server.scene
        for k, m in enumerate(self.meshes):
            self.handles[f"mesh{k}"] = sc.add_mesh_simple(f"/arm/mesh{k}", m.vertices, m.faces, color=COLORS["arm"])
        self.handles["tcp"] = sc.add_frame("/tcp", axes_length=0.06, axes_radius=0.004)
        for key in ("ellipsoid", "desired") if self.data.K_desired is not None else ("ellipsoid",):
            self.handles[key] = sc.add_mesh_simple(f"/{key}", *self.sphere, color=COLORS[key], scale=0.01, **_LOOK[key])
        if self.data.K_desired is not None:
            self.handles["desired_label"] = sc.add_label("/desired_label", "desired K_xd", position=(0.0, 0.0, 0.0))
            self.handles["realised_label"] = sc.add_label("/realised_label", "realised K_C", position=(0.0, 0.0, 0.0))
        n = self.data.robot.n
        ball = icosphere(2, radius=1.6 * CAPSULE_RADIUS)
        stick = cylinder(radius=0.2 * CAPSULE_RADIUS, height=0.16, sections=12)
        for i in range(n):
            if not self.meshes:
                self.handles[f"joint{i}"] = sc.add_mesh_simple(f"/arm/joint{i}", *ball, color=COLORS["joint"])
            self.handles[f"axis{i}"] = sc.add_mesh_simple(f"/arm/axis{i}", *stick, color=COLORS["axis"])
        self.handles["label"] = sc.add_label("/label", "", position=(0.0, 0.0, 0.0), anchor="bottom-left")

    def _pose_arm(self, b: int, p: int) -> None:
        d = self.data
        joints, tcp = self.frames[0][b, p], self.frames[1][b, p]
        for k, m in enumerate(self.meshes):
            T = (np.eye(4) if m.anchor < 0 or self.links is None else self.links[b, p, m.anchor]) @ m.offset
            h = self.handles[f"mesh{k}"]
            h.position, h.wxyz = T[:3, 3], rotation_wxyz(T[:3, :3])
        pts = np.vstack([np.zeros(3), joints[:, :3, 3], tcp[:3, 3]])
        if not self.meshes:
            for i in range(len(pts) - 1):
                self._pose_capsule(i, pts[i], pts[i + 1])
        z = np.einsum("nij,nj->ni", joints[:, :3, :3], np.asarray(d.robot.axes, dtype=float))
        for i in range(d.robot.n):
            if not self.meshes:
                self.handles[f"joint{i}"].position = pts[i + 1]
            h = self.handles[f"axis{i}"]
            h.position, h.wxyz = pts[i + 1], _segment_pose(pts[i + 1] - z[i], pts[i + 1] + z[i])[1]
        self.handles["tcp"].position, self.handles["tcp"].wxyz = tcp[:3, 3], rotation_wxyz(tcp[:3, :3])

    def _pose_capsule(self, i: int, p0: np.ndarray, p1: np.ndarray) -> None:
        if np.linalg.norm(p1 - p0) < 1e-6:
            if i in self.capsules:
                self.capsules[i][0].visible = False
            return
        centre, wxyz, L = _segment_pose(p0, p1)
        h, L0 = self.capsules.get(i, (None, -1.0))
        if h is None or abs(L - L0) > 1e-9:  # new, or a prismatic joint changed the length
            h = self.server.scene.add_mesh_simple(f"/arm/link{i}", *capsule(L, CAPSULE_RADIUS), color=COLORS["arm"])
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
        lab.position = tcp + np.array([0.0, 0.0, 0.05])
        lab.text = f"{'waypoint' if d.kind == 'shape' else 'step'} {p}: " + ", ".join(
            f"{k} {v}" for k, v in d.info(b, p)[:2]
        )

    def show_all(self, on: bool) -> None:
        """Draw (or remove) the ellipsoids of every ``every``-th waypoint of the current path."""
        for h in self.all_handles:
            h.remove()
        self.all_handles = []
        if not on:
            return
        d, b = self.data, self.b
        for p in range(0, d.P, self.every):
            verts = ellipsoid_vertices(self.sphere[0], d.K[b, p], self.n_per_m)
            h = self.server.scene.add_mesh_simple(
                f"/all/e{p}",
                verts,
                self.sphere[1],
                color=COLORS["all"],
                opacity=0.5,
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
        sc, sd = (float(ellipsoid_axes(K)[0][..., 0].max()) / self.n_per_m for K in (d.K, d.K_desired))
        self.beside_height = max(sc, sd) + 0.02
        right = np.cross(-VIEW, [0.0, 0.0, 1.0])
        return right / np.linalg.norm(right) * (sc + sd + 0.04)

    def _camera(self) -> None:
        """Frame the arm, the path and the ellipsoids (the largest semi-axis around every TCP): the
        camera looks along ``-VIEW`` from just far enough that every such point is in the picture
        (viser's vertical field of view, the width left of the panel), a little right of the centre."""
        d = self.data
        tcp = self.frames[1][..., :3, 3].reshape(-1, 3)
        big = float(ellipsoid_axes(d.K)[0][..., 0].max()) / self.n_per_m
        pts = np.vstack(
            [d.target.reshape(-1, 3), self.frames[0][..., :3, 3].reshape(-1, 3), np.zeros((1, 3))]
            + [tcp + big * e for e in np.vstack([np.eye(3), -np.eye(3)])]
            + [tcp + self.beside + s * self.beside_height * e for e in np.eye(3) for s in (-1, 1)]
        )
        lo, hi = pts.min(0), pts.max(0)
        right = np.cross(-VIEW, [0.0, 0.0, 1.0])
        right /= np.linalg.norm(right)
        up = np.cross(right, -VIEW)
        centre = 0.5 * (lo + hi) + CAMERA_SHIFT * float(np.linalg.norm(hi - lo)) * right
        rel = pts - centre
        tan_v = math.tan(math.radians(FOV_DEG) / 2)
        need = rel @ VIEW + np.maximum(np.abs(rel @ up) / tan_v, np.abs(rel @ right) / (ASPECT * tan_v))
        cam = self.server.initial_camera
        cam.look_at = tuple(centre)
        cam.position = tuple(centre + CAMERA_MARGIN * max(float(need.max()), 0.3) * VIEW)
        cam.up = (0.0, 0.0, 1.0)

    def scale_text(self) -> str:
        """The stated ellipsoid scale."""
        return f"ellipsoid semi-axes: 1 cm on screen = {self.n_per_m / 100:.4g} N/m ({self.n_per_m:.4g} N/m per m)"
