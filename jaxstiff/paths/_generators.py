"""Path generators: line, arc, circle, half_sine, spline, ellipse_arc; the turning rate of a path.

Every generator returns a :class:`~jaxstiff.paths.Path` of ``n`` waypoints (metres, robot base
frame) with the curve's analytic unit tangent as the desired direction. :func:`turning_deg`
gives the angle the direction turns between consecutive waypoints (what the rate limits of a
shaping run have to follow).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike

from jaxstiff.runtime._plan_size import check_plan_size

from ._core import ZERO_SEGMENT_M, Path

__all__ = ["line", "arc", "circle", "half_sine", "spline", "ellipse_arc", "ellipse_curvature", "turning_deg"]
__all__ += ["WAYPOINT_BYTES", "check_waypoints"]

#: bytes held at once per generated waypoint (parameter, points, directions and the Path's
#: checked copies: about 20 float64 values), for :func:`check_waypoints`
WAYPOINT_BYTES = 160


def _vec3(v: ArrayLike, what: str) -> np.ndarray:
    a = np.asarray(v, dtype=float)
    if a.shape != (3,) or not np.all(np.isfinite(a)):
        raise ValueError(f"{what} must be 3 finite numbers (m), got {v!r}")
    return a


def check_waypoints(n: int, what: str = "path", bytes_per_waypoint: float = WAYPOINT_BYTES) -> int:
    """``n`` as an int, >= 2, and small enough that ``n`` waypoints fit in memory.

    Raises:
        ValueError: fewer than 2 waypoints, or (:class:`~jaxstiff.runtime._plan_size.PlanTooLargeError`)
            more than the available memory holds (the message gives the estimate and the limit).
    """
    if isinstance(n, np.ndarray) and n.ndim == 0:  # a numpy scalar array: its value
        n = n.item()
    if isinstance(n, (bool, np.bool_)) or not isinstance(n, (int, np.integer, float, np.floating)):
        raise TypeError(f"n (the number of waypoints) must be an integer, got {n!r}")
    if not (np.isfinite(n) and float(n).is_integer()):  # 2.5 cut to 2 would be another path
        raise ValueError(f"n (the number of waypoints) must be a whole number, got {n!r}")
    n = int(n)
    if n < 2:
        raise ValueError(f"a path needs at least 2 waypoints, got n = {n}")
    check_plan_size(f"{what}: n = {n} waypoints", n, bytes_per_waypoint, "n")
    return n


def _plane_basis(normal: ArrayLike) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """An orthonormal right-handed basis ``(e1, e2, n)`` with ``n`` the unit plane normal; ``e1`` is
    the base x axis projected into the plane (the y axis when the normal is near x)."""
    nz = _vec3(normal, "normal")
    if np.linalg.norm(nz) <= 1e-12:
        raise ValueError("normal must be non-zero")
    nz = nz / np.linalg.norm(nz)
    ref = np.array([1.0, 0.0, 0.0]) if abs(nz[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    e1 = ref - nz * (ref @ nz)
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(nz, e1)
    return e1, e2, nz


def line(start: ArrayLike, end: ArrayLike, n: int = 20) -> Path:
    """``n`` equally spaced waypoints on the segment ``start -> end`` ((3,) each, m); direction = the segment."""
    a, b = _vec3(start, "start"), _vec3(end, "end")
    n = check_waypoints(n, "line")
    if np.linalg.norm(b - a) <= ZERO_SEGMENT_M:
        raise ValueError("line: start and end coincide")
    s = np.linspace(0.0, 1.0, n)[:, None]
    pts = a + s * (b - a)
    d = np.broadcast_to((b - a) / np.linalg.norm(b - a), pts.shape)
    return Path(pts, d, name="line")


def arc(
    center: ArrayLike,
    radius: float,
    start_deg: float,
    end_deg: float,
    n: int = 30,
    normal: ArrayLike = (0.0, 0.0, 1.0),
) -> Path:
    """``n`` waypoints on a circular arc, equally spaced in angle; direction = analytic tangent.

    ``x(th) = center + radius (cos(th) e1 + sin(th) e2)`` with ``(e1, e2)`` an in-plane basis.

    Args:
        center: (3,) m.
        radius: m, > 0.
        start_deg, end_deg: angles (degrees) measured in the plane normal to ``normal``, from its
            first in-plane axis (the base x axis for the default normal +z); the arc runs from
            start to end (either sense).
        n: waypoints.
        normal: (3,) plane normal (default +z: an arc in a horizontal xy plane).
    """
    c = _vec3(center, "center")
    if not radius > 0:
        raise ValueError(f"arc radius must be > 0 (m), got {radius}")
    n = check_waypoints(n, "arc")
    if start_deg == end_deg:
        raise ValueError("arc: start and end angles coincide")
    e1, e2, _ = _plane_basis(normal)
    th = np.deg2rad(np.linspace(start_deg, end_deg, n))
    pts = c + radius * (np.cos(th)[:, None] * e1 + np.sin(th)[:, None] * e2)
    sense = 1.0 if end_deg > start_deg else -1.0
    d = sense * (-np.sin(th)[:, None] * e1 + np.cos(th)[:, None] * e2)
    return Path(pts, d, name="arc")


def circle(center: ArrayLike, radius: float, n: int = 60, normal: ArrayLike = (0.0, 0.0, 1.0)) -> Path:
    """A full circle (``center`` (3,) m, ``radius`` m), ``n`` waypoints, the first point not repeated at the end."""
    n = check_waypoints(n, "circle")
    p = arc(center, radius, 0.0, 360.0 * (n - 1) / n if n > 1 else 0.0, n, normal)
    return Path(p.points, p.directions, name="circle")


def half_sine(
    start: ArrayLike,
    end: ArrayLike,
    amplitude: float,
    n: int = 60,
    periods: float = 1.0,
    normal: ArrayLike = (0.0, 0.0, 1.0),
) -> Path:
    """A sine bump along ``start -> end`` ((3,) each, m): lateral offset ``amplitude * sin(pi * periods * s)`` (m).

    The offset is in the plane normal to ``normal`` (default +z: in the horizontal plane),
    perpendicular to the chord (towards ``normal x chord``); ``s`` runs 0..1 in ``n`` equal steps.
    ``periods = 1`` is a half sine (one bump), ``2`` an S-curve. Direction = analytic tangent.
    """
    a, b = _vec3(start, "start"), _vec3(end, "end")
    n = check_waypoints(n, "half_sine")
    chord = b - a
    L = np.linalg.norm(chord)
    if L <= ZERO_SEGMENT_M:
        raise ValueError("half_sine: start and end coincide")
    nrm = _vec3(normal, "normal")
    lateral = np.cross(nrm, chord)
    if np.linalg.norm(lateral) <= 1e-12:
        raise ValueError("half_sine: the chord is parallel to the plane normal")
    lateral /= np.linalg.norm(lateral)
    s = np.linspace(0.0, 1.0, n)
    w = math.pi * periods
    pts = a + s[:, None] * chord + (amplitude * np.sin(w * s))[:, None] * lateral
    d = chord[None, :] + (amplitude * w * np.cos(w * s))[:, None] * lateral
    return Path(pts, d, name="half_sine")


def spline(points: ArrayLike, n: int = 60) -> Path:
    """A cubic spline through the given points (K, 3) m, K >= 2, resampled at ``n`` waypoints.

    Chord-length parametrisation, natural end conditions (scipy ``CubicSpline``; not-a-knot for
    K = 2); waypoints equally spaced in the parameter; direction = the spline's analytic tangent.
    """
    from scipy.interpolate import CubicSpline

    pts = np.asarray(points, dtype=float)
    if pts.ndim != 2 or pts.shape[1] != 3 or pts.shape[0] < 2:
        raise ValueError(f"spline needs control points of shape (K >= 2, 3), got {pts.shape}")
    if not np.all(np.isfinite(pts)):
        raise ValueError("spline control points contain NaN or Inf")
    seg = np.linalg.norm(np.diff(pts, axis=0), axis=1)
    if np.any(seg <= ZERO_SEGMENT_M):
        raise ValueError("spline: two consecutive control points coincide")
    n = check_waypoints(n, "spline")
    u = np.r_[0.0, np.cumsum(seg)]
    cs = CubicSpline(u, pts, axis=0, bc_type="natural" if pts.shape[0] > 2 else "not-a-knot")
    s = np.linspace(0.0, u[-1], n)
    return Path(cs(s), cs(s, 1), name="spline")


_FINE_STEPS = 4096  #: parameter steps per waypoint of ellipse_arc's arc-length grid (6 float64 arrays)


def ellipse_curvature(semi_x: float, semi_y: float, t_deg: ArrayLike) -> np.ndarray:
    """Curvature (1/m) of the ellipse ``(semi_x cos t, semi_y sin t)`` at parameter angles ``t_deg`` (degrees).

    ``kappa(t) = a b / (a^2 sin^2 t + b^2 cos^2 t)^(3/2)`` with ``a = semi_x``, ``b = semi_y``: largest,
    ``a / b^2``, at the ends of the longer axis when ``a > b``.
    """
    t = np.deg2rad(np.asarray(t_deg, dtype=float))
    a, b = float(semi_x), float(semi_y)
    return a * b / (a**2 * np.sin(t) ** 2 + b**2 * np.cos(t) ** 2) ** 1.5


def ellipse_arc(
    center: ArrayLike,
    semi_x: float,
    semi_y: float,
    start_deg: float,
    end_deg: float,
    n: int = 60,
    normal: ArrayLike = (0.0, 0.0, 1.0),
) -> Path:
    """``n`` waypoints equally spaced in arc length on an elliptic arc; direction = analytic tangent.

    ``x(t) = center + semi_x cos(t) e1 + semi_y sin(t) e2`` for the parameter angle ``t`` from
    ``start_deg`` to ``end_deg`` (either sense), ``(e1, e2)`` the in-plane basis of :func:`arc`
    (the base x and y axes for the default normal +z). Unlike a circle, the curvature varies along
    the arc (:func:`ellipse_curvature`): with ``semi_x > semi_y`` it peaks at ``t = 0`` and
    ``180`` deg. With equal spacing ``ds`` the tangent turns by about ``kappa ds`` between
    waypoints, so the turning rate per waypoint follows the curvature (:func:`turning_deg`).

    Args:
        center: (3,) m.
        semi_x, semi_y: semi-axes along ``e1`` and ``e2``, m, > 0 (equal: a circular arc).
        start_deg, end_deg: parameter angles (degrees) of the first and last waypoint.
        n: waypoints (the arc length is found on a fine grid of 4096 parameter steps per
            waypoint, so the spacing is equal to about 1e-9 of the arc).
        normal: (3,) plane normal (default +z: an arc in a horizontal xy plane).
    """
    c = _vec3(center, "center")
    for what, v in (("semi_x", semi_x), ("semi_y", semi_y)):
        if not (math.isfinite(v) and v > 0):
            raise ValueError(f"ellipse_arc {what} must be a finite number > 0 (m), got {v}")
    n = check_waypoints(n, "ellipse_arc", WAYPOINT_BYTES + _FINE_STEPS * 48)
    if start_deg == end_deg:
        raise ValueError("ellipse_arc: start and end angles coincide")
    e1, e2, _ = _plane_basis(normal)
    fine = np.deg2rad(np.linspace(start_deg, end_deg, _FINE_STEPS * n + 1))
    speed = np.hypot(semi_x * np.sin(fine), semi_y * np.cos(fine))  # |dx/dt|
    s = np.r_[0.0, np.cumsum(0.5 * (speed[1:] + speed[:-1]) * np.abs(np.diff(fine)))]  # trapezoid rule
    th = np.interp(np.linspace(0.0, s[-1], n), s, fine)
    pts = c + semi_x * np.cos(th)[:, None] * e1 + semi_y * np.sin(th)[:, None] * e2
    sense = 1.0 if end_deg > start_deg else -1.0
    d = sense * (-semi_x * np.sin(th)[:, None] * e1 + semi_y * np.cos(th)[:, None] * e2)
    return Path(pts, d, name="ellipse_arc")


def turning_deg(path: Path) -> np.ndarray:
    """How far the desired direction turns between consecutive waypoints, degrees: (P - 1,) or (B, P - 1).

    The angle between ``d_p`` and ``d_{p+1}`` (``atan2(|d_p x d_{p+1}|, d_p . d_{p+1})``, accurate also
    for tiny angles). For a generator's tangents and equal spacing ``ds`` it is about
    ``kappa ds`` (rad): compare it with the joint rate limit ``dq`` per waypoint.
    """
    d = np.asarray(path.directions, dtype=float)
    a, b = d[..., :-1, :], d[..., 1:, :]
    return np.degrees(np.arctan2(np.linalg.norm(np.cross(a, b), axis=-1), np.sum(a * b, axis=-1)))
