"""Sizes and camera of the 3-D scene, from the arm and the result (plain numpy, no viser).

Every size is a fraction of the arm's length ``L`` (:func:`arm_length`: the chain's joint origins
from the base to the TCP, segment by segment, the longest over the shown postures), so that a
0.5 m hobby arm and a 1.9 m UR10 look alike: links ``0.025 L`` thick (3 cm on the 1.18 m LWR),
joint balls at most ``1.4`` link radii and less than half the distance to the next joint origin or
the TCP (the wrist balls of a compact wrist shrink instead of swallowing the TCP), the largest
stiffness semi-axis along the path drawn ``0.21 L`` long (about 25 cm on the LWR; :func:`nice_scale`).

The camera (:func:`choose_view`) looks at the box around the arm's postures, the path and the
ellipsoids from the direction (out of about 400 with an elevation of 5 to 70 degrees) that best
shows, in this order of weight: the ellipsoid unhidden by the links (no link sample outside the
ellipsoid in the corridor from the TCP towards the camera), a large cross-section of the ellipsoid
(half of its largest is enough), the path's plane seen from at least 33 degrees off edge-on and its
longest extent broadside, an elevation near 30 degrees, and the arm from the side of the work away
from its base.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["ArmSizes", "arm_length", "MANTISSAS"]

#: the round mantissas a scale can take: 1, 1.2, 1.5, 2, 2.5, 3, 4, 5, 6, 8 x 10^k (neighbours at most 4/3 apart)
MANTISSAS = (1.0, 1.2, 1.5, 2.0, 2.5, 3.0, 4.0, 5.0, 6.0, 8.0)
#: largest drawn semi-axis / arm length, both in the scene's metres (0.25 m on the 1.18 m LWR)
SEMI_AXIS_PER_LENGTH = 0.21
RADIUS_PER_LENGTH = 0.025  #: link radius / arm length (0.03 m on the LWR)
#: a view that shows the ellipsoid's cross-section at half its largest (pi a b), or the path's plane
#: at 0.3 of face on (33 degrees above a horizontal plane), scores full marks: looking straight along
#: the shortest axis of a flat ellipsoid or at a horizontal path from overhead loses the arm's depth
ELLIPSOID_ENOUGH, PLANE_ENOUGH = 0.5, 0.3


def nice_scale(largest: float, drawn: float) -> float:
    """N/m of stiffness per metre of the scene (the arm's own metres, not of the screen: the view is
    perspective and zooms) that draws a semi-axis of ``largest`` N/m about ``drawn`` m long:
    ``largest / drawn`` rounded to the nearest (in ratio) of :data:`MANTISSAS` x 10^k, so the drawn
    length is within a factor 1.16 of ``drawn`` (the former rounding *up* to 1, 2 or 5 x 10^k drew
    it anywhere from 0.4 to 1 times ``drawn``: 11 cm instead of 25 for ``largest / drawn`` = 2.2)."""
    if not np.isfinite(largest) or largest <= 0 or not drawn > 0:
        return 1.0
    raw = largest / drawn
    e = math.floor(math.log10(raw))
    choices = [m * 10.0**k for k in (e - 1, e, e + 1) for m in MANTISSAS]
    return float(min(choices, key=lambda c: abs(math.log(c / raw))))


def drawn_semi_axis(length: float) -> float:
    """The length (m, in the scene) the largest semi-axis is drawn at, for an arm ``length`` m long."""
    return SEMI_AXIS_PER_LENGTH * length


screen_semi_axis = drawn_semi_axis  #: its former name (the former module jaxstiff.view.framing exported it)


def _chain_points(joints: np.ndarray, tcp: np.ndarray) -> np.ndarray:
    """(..., n + 2, 3): base origin, joint origins, TCP."""
    base = np.zeros(joints.shape[:-3] + (1, 3))
    return np.concatenate([base, joints[..., :3, 3], tcp[..., None, :3, 3]], axis=-2)


def arm_length(joints: np.ndarray, tcp: np.ndarray) -> float:
    """The arm's length, m: the polyline base -> joint origins -> TCP, longest over the postures
    (joints (..., n, 4, 4), tcp (..., 4, 4) of :func:`jaxstiff.view._kinematics.chain_frames`);
    at least 5 cm (a chain whose joints all sit at the base)."""
    pts = _chain_points(joints, tcp)
    seg = np.linalg.norm(np.diff(pts, axis=-2), axis=-1).sum(-1)
    return max(float(np.max(seg)) if seg.size else 0.0, 0.05)


@dataclass(frozen=True)
class ArmSizes:
    """The scene's sizes, m. ``ball`` (n,): joint ball radii; ``link`` (n + 1,): radius of the
    capsule from point i to point i + 1 of base, joints, TCP."""

    length: float
    radius: float
    ball: np.ndarray
    link: np.ndarray
    axis_length: float
    path_thickness: float
    stroke: float
    tcp_axes: float
    label_lift: float
    grid_cell: float


def arm_sizes(joints: np.ndarray, tcp: np.ndarray) -> ArmSizes:
    """Sizes from the arm's postures (see the module text)."""
    L = arm_length(joints, tcp)
    r = float(np.clip(RADIUS_PER_LENGTH * L, 0.002, 0.06))
    pts = _chain_points(joints, tcp).reshape(-1, joints.shape[-3] + 2, 3)
    n = joints.shape[-3]
    ball = np.full(n, 1.4 * r)
    for i in range(n):  # joint i is point i + 1: the nearest other point that is not at the same place
        d = np.linalg.norm(pts - pts[:, i + 1 : i + 2], axis=-1)
        d = d[d > 1e-6]
        if d.size:
            ball[i] = min(ball[i], 0.45 * float(d.min()))
    ball = np.maximum(ball, 0.3 * r)  # still visible where joint origins nearly meet
    link = np.full(n + 1, r)
    link[-1] = 0.6 * r  # the hand: from the last joint to the TCP, where the ellipsoid sits
    return ArmSizes(
        length=L,
        radius=r,
        ball=ball,
        link=link,
        axis_length=0.13 * L,
        path_thickness=max(0.0015, 0.004 * L),
        stroke=0.035 * L,
        tcp_axes=0.05 * L,
        label_lift=0.04 * L,
        grid_cell=0.1 if L > 0.6 else 0.05,
    )


def _candidates(count: int = 900) -> np.ndarray:
    """Unit directions (Fibonacci sphere) with an elevation of 5 to 70 degrees."""
    i = np.arange(count) + 0.5
    z = 1.0 - 2.0 * i / count
    phi = math.pi * (3.0 - math.sqrt(5.0)) * i
    s = np.sqrt(1.0 - z * z)
    v = np.stack([s * np.cos(phi), s * np.sin(phi), z], axis=-1)
    elev = np.degrees(np.arcsin(z))
    return v[(elev >= 5.0) & (elev <= 70.0)]


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def choose_view(
    path: np.ndarray,
    chain: np.ndarray,
    semi: np.ndarray,
    axes: np.ndarray,
    radius: float,
    samples: int = 24,
) -> np.ndarray:
    """The unit direction from the scene's centre to the camera.

    Args:
        path: (M, 3) waypoints, m.
        chain: (N, n + 2, 3) base, joint origins and TCP at N postures, m.
        semi: (N, 3) drawn semi-axes (m, descending) of the ellipsoid at the TCP of each posture.
        axes: (N, 3, 3) their unit directions as columns.
        radius: the links' radius, m.
        samples: at most this many postures (evenly spaced) are weighed.
    """
    v = _candidates()
    N = chain.shape[0]
    pick = np.unique(np.linspace(0, N - 1, min(samples, N)).round().astype(int))
    chain, semi, axes = chain[pick], semi[pick], axes[pick]
    tcp = chain[:, -1]

    # the ellipsoid's cross-section seen along v, / its largest (pi a b): 1 looking along the shortest axis
    a, b, c = (np.maximum(semi[:, k], 1e-9) for k in range(3))
    ve = np.einsum("kd,nde->kne", v, axes)  # (K, N, 3) v in each ellipsoid's axes
    area = np.sqrt((c / a) ** 2 * ve[..., 0] ** 2 + (c / b) ** 2 * ve[..., 1] ** 2 + ve[..., 2] ** 2)
    s_ell = np.minimum(area / ELLIPSOID_ENOUGH, 1.0).mean(-1)

    # links between the TCP and the camera: samples along every link, outside the ellipsoid's smallest semi-axis
    t = np.linspace(0.0, 1.0, 9)
    seg = chain[:, :-1, None, :] * (1 - t)[:, None] + chain[:, 1:, None, :] * t[:, None]  # (N, n+1, 9, 3)
    u = (seg - tcp[:, None, None, :]).reshape(len(pick), -1, 3)  # (N, S, 3)
    dist = np.linalg.norm(u, axis=-1)
    along = np.einsum("kd,nsd->kns", v, u)
    perp = np.sqrt(np.maximum(dist[None] ** 2 - along**2, 0.0))
    corridor = (np.maximum(semi[:, 1], 2.0 * radius) + 2.0 * radius)[None, :, None]
    outside = (dist > c[:, None] + radius)[None]
    clear = np.where((along > 0) & outside, np.clip(perp / corridor, 0.0, 1.0) ** 2, 1.0)
    s_vis = clear.min(-1).mean(-1)

    # the path: its plane face on (adjugate of the covariance) and its longest extent broadside
    s_path = np.full(len(v), 0.5)
    if len(path) > 1 and float(np.ptp(path, axis=0).max()) > 1e-3:
        w, E = np.linalg.eigh(np.cov(path.T))
        w = np.maximum(w, 0.0)
        broad = 1.0 - (v @ E[:, 2]) ** 2
        adj = E @ np.diag([w[1] * w[2], w[0] * w[2], w[0] * w[1]]) @ E.T
        top = float(np.linalg.eigvalsh(adj)[-1])
        face = np.einsum("kd,de,ke->k", v, adj, v) / top if top > 1e-18 * w[2] ** 2 else broad
        s_path = 0.5 * broad + 0.5 * np.minimum(face / PLANE_ENOUGH, 1.0)

    elev = np.degrees(np.arcsin(np.clip(v[:, 2], -1, 1)))
    s_elev = 1.0 - np.abs(elev - 30.0) / 60.0
    out = np.mean(path, axis=0)[:2] if len(path) else np.zeros(2)
    s_front = np.full(len(v), 0.5)
    if np.linalg.norm(out) > 1e-3:
        h = v[:, :2] / np.maximum(np.linalg.norm(v[:, :2], axis=-1, keepdims=True), 1e-9)
        s_front = 0.5 * (1.0 + h @ (out / np.linalg.norm(out)))
    score = 3.0 * s_vis + 2.0 * s_ell + 2.0 * s_path + 1.0 * s_elev + 0.5 * s_front
    return _unit(v[int(np.argmax(score))])
