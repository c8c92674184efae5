"""TCP paths: waypoints and desired ellipsoid directions (SPEC section 5), CSV files, generators.

A :class:`Path` holds ``P >= 2`` waypoints ``x_p`` (metres, in the robot's base frame; one is
enough when its direction is given) and one desired direction ``d_p`` per waypoint (unit
vectors). Seed 000 aligns the stiffness ellipsoid with the direction of motion, so the default
direction is the unit tangent of the path:
``(x_{p+1} - x_{p-1}) / |...|`` inside, one-sided differences at the two ends. For equally spaced
points on a circle the central difference is exactly the tangent. The generators pass their
analytic tangents instead.

A batch of ``B`` paths with the same number of waypoints is one Path with ``points`` (B, P, 3).

CSV format (DESIGN.md): a header ``x,y,z`` and optionally ``dx,dy,dz``, one waypoint a row,
metres in the base frame; ``#`` starts a comment line.

The shipped default, :func:`default_path`: a half-sine bump in the LWR's xy plane; see its
docstring for its geometry.

Modules: :mod:`._core` (:class:`Path`, :func:`tangents`), :mod:`._csv_io` (reading and writing the
CSV text), :mod:`._generators` (line, arc, circle, half_sine, spline, ellipse_arc; turning_deg), :mod:`._default` (the shipped
default path). Every public name is importable from ``jaxstiff.paths``.

Example:
    >>> import numpy as np
    >>> from jaxstiff.paths import Path, arc
    >>> p = Path(np.array([[0.5, 0.0, 0.4], [0.5, 0.1, 0.4], [0.5, 0.2, 0.4]]))
    >>> p.directions[0].tolist()
    [0.0, 1.0, 0.0]
"""

from __future__ import annotations

from jaxstiff.runtime._moved import former_names

from ._core import ZERO_SEGMENT_M, Path, tangents
from ._csv_io import format_csv, read_csv
from ._default import DEFAULT_PATH_SPEC, default_path
from ._generators import (
    WAYPOINT_BYTES,
    arc,
    check_waypoints,
    circle,
    ellipse_arc,
    ellipse_curvature,
    half_sine,
    line,
    spline,
    turning_deg,
)

__all__ = [
    "DEFAULT_PATH_SPEC",
    "Path",
    "WAYPOINT_BYTES",
    "ZERO_SEGMENT_M",
    "arc",
    "check_waypoints",
    "circle",
    "default_path",
    "ellipse_arc",
    "ellipse_curvature",
    "format_csv",
    "half_sine",
    "line",
    "read_csv",
    "spline",
    "tangents",
    "turning_deg",
]


__getattr__ = former_names(__name__, {})  # the former modules (jaxstiff.paths.X read as an attribute)
