"""The shipped default path for the KUKA LWR 4 (:func:`default_path`) and its parameters."""

from __future__ import annotations

from typing import Any

from ._core import Path
from ._generators import half_sine

__all__ = ["DEFAULT_PATH_SPEC", "default_path"]

#: The parameters of :func:`default_path` (also written into result metadata): metres, base frame.
DEFAULT_PATH_SPEC: dict[str, Any] = {
    "generator": "half_sine",
    "start": [0.60, 0.25, 0.30],
    "end": [0.60, -0.25, 0.30],
    "amplitude": 0.10,
    "periods": 1.0,
    "n": 60,
}


def default_path(n: int | None = None) -> Path:
    """The shipped default path for the KUKA LWR 4 (base frame, metres): a curved path in an xy plane.

    A half-sine bump in the horizontal plane z = 0.30 m (1 cm below the shoulder axis A2 at
    0.3105 m): from (0.60, 0.25) to (0.60, -0.25) m, bulging 0.10 m towards +x at the middle
    (x = 0.70 m); 60 waypoints, 0.546 m long (9.3 mm between waypoints); the tangent turns by
    64 degrees in all, at most 1.9 degrees between waypoints (fastest at the apex). The TCP stays
    0.65-0.70 m from the shoulder: the elbow is bent (far from full stretch at 0.87 m and from the
    A4 limit), so every waypoint is reachable with room in the null space of the 6 free joints
    (7th locked) to turn the ellipsoid with the tangent. Seed 000 gives no path; why this one:
    docs/notes/shape.md. The tests check the reachability (IK reaches the waypoints; elbow bend in
    40-100 degrees).

    Args:
        n: number of waypoints (default 60).

    Returns:
        A :class:`Path` named ``"default"``: points (n, 3) m, directions the unit tangents.
    """
    spec = dict(DEFAULT_PATH_SPEC)
    if n is not None:
        spec["n"] = n  # checked by half_sine (a whole number >= 2)
    p = half_sine(spec["start"], spec["end"], spec["amplitude"], n=spec["n"], periods=spec["periods"])
    return Path(p.points, p.directions, name="default")
