"""TCP paths: waypoints and desired ellipsoid directions (SPEC section 5), CSV files, generators.

A :class:`Path` holds ``P >= 2`` waypoints ``x_p`` (metres, in the robot's base frame; one is
enough when its direction is given) and one desired direction ``d_p`` per waypoint (unit
vectors). Seed 000 aligns the stiffness ellipsoid with the direction of motion, so the default
direction is the unit tangent of the path:
``(x_{p+1} - x_{p-1}) / |...|`` inside, one-sided differences at the two ends. For equally spaced
points on a circle the central difference is exactly the tangent. The generators below pass their
analytic tangents instead.

A batch of ``B`` paths with the same number of waypoints is one Path with ``points`` (B, P, 3).

CSV format (DESIGN.md): a header ``x,y,z`` and optionally ``dx,dy,dz``, one waypoint a row,
metres in the base frame; ``#`` starts a comment line.

The shipped default, :func:`default_path`: a half-sine S-curve in the LWR's xy plane; see its
docstring for how it was chosen.

Example:
    >>> import numpy as np
    >>> from jaxstiff.paths import Path, arc
    >>> p = Path(np.array([[0.5, 0.0, 0.4], [0.5, 0.1, 0.4], [0.5, 0.2, 0.4]]))
    >>> p.directions[0].tolist()
    [0.0, 1.0, 0.0]
"""

from __future__ import annotations

import csv
import dataclasses
import io
import math
import os
import re
from collections.abc import Sequence

import numpy as np

from jaxstiff.runtime.io import atomic_write_text

__all__ = [
    "Path",
    "read_csv",
    "tangents",
    "line",
    "arc",
    "circle",
    "half_sine",
    "spline",
    "default_path",
    "DEFAULT_PATH_SPEC",
]

_ZERO_SEGMENT = 1e-12  # m: segments shorter than this have no direction


def tangents(points: np.ndarray, where: str = "path") -> np.ndarray:
    """Unit tangents of a polyline (P, 3) -> (P, 3) by central differences (one-sided at the ends;
    at a waypoint where the path turns straight back, the line of its two segments).

    Raises:
        ValueError: a waypoint whose neighbours coincide with it (zero-length segment), since then
            the direction of motion is undefined; give the directions explicitly.
    """
    pts = np.asarray(points, dtype=float)
    P = pts.shape[0]
    t = np.empty_like(pts)
    t[0] = pts[1] - pts[0]
    t[-1] = pts[-1] - pts[-2]
    if P > 2:
        t[1:-1] = pts[2:] - pts[:-2]
    norm = np.linalg.norm(t, axis=-1)
    seg = np.linalg.norm(np.diff(pts, axis=0), axis=-1)
    if P > 2:
        # an out-and-back turn (the path reverses at waypoint i): the central difference cancels,
        # but both segments lie on one line, which is the direction (alpha is sign-free)
        rev = np.flatnonzero((norm[1:-1] <= 1e-9 * (seg[:-1] + seg[1:])) & (seg[:-1] > _ZERO_SEGMENT) & (seg[1:] > _ZERO_SEGMENT)) + 1
        t[rev] = (pts[rev] - pts[rev - 1]) / seg[rev - 1, None] - (pts[rev + 1] - pts[rev]) / seg[rev, None]
        norm[rev] = np.linalg.norm(t[rev], axis=-1)
    bad = np.flatnonzero((norm <= _ZERO_SEGMENT) | np.r_[seg <= _ZERO_SEGMENT, False] | np.r_[False, seg <= _ZERO_SEGMENT])
    if bad.size:
        raise ValueError(
            f"{where}: zero-length segment at waypoint {int(bad[0])} (consecutive waypoints coincide) "
            f"and no direction given; remove the duplicate waypoint or give dx,dy,dz"
        )
    return t / norm[:, None]


@dataclasses.dataclass(frozen=True, eq=False)
class Path:
    """Waypoints and desired directions of one TCP path, or of a batch of paths.

    Args:
        points: (P, 3) or (B, P, 3) waypoints, metres, robot base frame; P >= 2, or P = 1 with
            ``directions`` (one point has no tangent).
        directions: same shape, desired direction of the ellipsoid's major axis per waypoint
            (any non-zero length; stored normalised). Default: the unit path tangent.
        name: a label (file name or generator), kept in result metadata.

    Attributes:
        points: (P, 3) or (B, P, 3) float64.
        directions: same shape, unit vectors.

    Raises:
        ValueError: wrong shape, fewer than 2 waypoints (1 without directions), NaN/Inf, a zero direction, or a
            zero-length segment where no direction was given.
    """

    points: np.ndarray
    directions: np.ndarray
    name: str = ""

    def __init__(self, points, directions=None, name: str = ""):
        pts = np.array(points, dtype=float, copy=True)
        where = name or "path"
        if pts.ndim not in (2, 3) or pts.shape[-1] != 3:
            raise ValueError(f"{where}: points must have shape (P, 3) or (B, P, 3), got {pts.shape}")
        if pts.shape[-2] < 1 or (pts.shape[-2] < 2 and directions is None):
            raise ValueError(f"{where}: a path needs at least 2 waypoints, or 1 with its direction given (columns "
                             f"dx,dy,dz): one point has no tangent; got {pts.shape[-2]}")
        if pts.ndim == 3 and pts.shape[0] < 1:
            raise ValueError(f"{where}: empty batch of paths")
        if not np.all(np.isfinite(pts)):
            raise ValueError(f"{where}: points contain NaN or Inf")
        if directions is None:
            if pts.ndim == 2:
                d = tangents(pts, where)
            else:
                d = np.stack([tangents(p, f"{where}[{b}]") for b, p in enumerate(pts)])
        else:
            d = np.array(directions, dtype=float, copy=True)
            if d.shape != pts.shape:
                raise ValueError(f"{where}: directions must have the shape of points {pts.shape}, got {d.shape}")
            if not np.all(np.isfinite(d)):
                raise ValueError(f"{where}: directions contain NaN or Inf")
            norm = np.linalg.norm(d, axis=-1)
            if np.any(norm <= 1e-12):
                idx = np.argwhere(norm <= 1e-12)[0].tolist()
                raise ValueError(f"{where}: zero-length direction at waypoint {idx[-1]}")
            d = d / norm[..., None]
        pts.setflags(write=False)
        d.setflags(write=False)
        object.__setattr__(self, "points", pts)
        object.__setattr__(self, "directions", d)
        object.__setattr__(self, "name", str(name))

    # ------------------------------------------------------------------ shape
    @property
    def batched(self) -> bool:
        """True if this Path holds a batch (B, P, 3)."""
        return self.points.ndim == 3

    @property
    def P(self) -> int:
        """Number of waypoints."""
        return int(self.points.shape[-2])

    @property
    def B(self) -> int:
        """Number of paths (1 for an unbatched Path)."""
        return int(self.points.shape[0]) if self.batched else 1

    def as_batch(self) -> Path:
        """This path with a leading batch axis (B, P, 3) (a batched Path is returned as is)."""
        if self.batched:
            return self
        return Path(self.points[None], self.directions[None], name=self.name)

    def __getitem__(self, b: int) -> Path:
        """Path ``b`` of a batch."""
        if not self.batched:
            raise IndexError("an unbatched Path has no batch index")
        return Path(self.points[b], self.directions[b], name=f"{self.name}[{b}]" if self.name else "")

    def __len__(self) -> int:
        return self.B

    @staticmethod
    def stack(paths: Sequence[Path]) -> Path:
        """Stack unbatched paths with the same P into one batch (B, P, 3)."""
        if not paths:
            raise ValueError("no paths to stack")
        Ps = {p.P for p in paths}
        if len(Ps) != 1 or any(p.batched for p in paths):
            raise ValueError(f"can only stack unbatched paths with the same number of waypoints, got P = {sorted(Ps)}")
        return Path(
            np.stack([p.points for p in paths]),
            np.stack([p.directions for p in paths]),
            name=";".join(p.name for p in paths),
        )

    @property
    def length(self) -> np.ndarray:
        """Arc length of the polyline (m): a float, or (B,) for a batch."""
        seg = np.linalg.norm(np.diff(self.points, axis=-2), axis=-1).sum(axis=-1)
        return seg

    # ------------------------------------------------------------------ CSV
    @staticmethod
    def from_csv(file: str | os.PathLike) -> Path:
        """Read a path from a CSV file with header ``x,y,z[,dx,dy,dz]`` (metres, base frame).

        Raises:
            FileNotFoundError: the file does not exist.
            ValueError: empty file, missing/unknown columns, a non-numeric or missing cell (the
                message names file, line and column), NaN/Inf, fewer than 2 waypoints, a
                zero-length segment without directions (named by waypoint and line).
        """
        file = os.fspath(file)
        points, directions, lines = read_csv(file)
        name = os.path.basename(file)
        try:
            return Path(points, directions, name=name)
        except ValueError as exc:  # geometry (zero-length segment or direction): say which line
            msg = re.sub(r"waypoint (\d+)", lambda m: f"waypoint {m[1]} (line {lines[int(m[1])]})", str(exc))
            if msg.startswith(name + ":"):
                msg = file + msg[len(name):]
            raise ValueError(msg) from None

    def to_csv(self, file: str | os.PathLike, directions: bool = True) -> None:
        """Write an unbatched path as CSV (``x,y,z,dx,dy,dz``), atomically (temp file + rename)."""
        if self.batched:
            raise ValueError("to_csv writes one path; index the batch first (path[b])")
        buf = io.StringIO()
        w = csv.writer(buf, lineterminator="\n")
        w.writerow(["x", "y", "z", "dx", "dy", "dz"] if directions else ["x", "y", "z"])
        for p, d in zip(self.points, self.directions, strict=True):
            vals = list(p) + (list(d) if directions else [])
            w.writerow([repr(float(v)) for v in vals])
        atomic_write_text(os.fspath(file), buf.getvalue())

    def __repr__(self) -> str:
        shape = "x".join(str(s) for s in self.points.shape)
        return f"Path({self.name or 'unnamed'}, points {shape})"


# ---------------------------------------------------------------------- generators
def _vec3(v, what: str) -> np.ndarray:
    a = np.asarray(v, dtype=float)
    if a.shape != (3,) or not np.all(np.isfinite(a)):
        raise ValueError(f"{what} must be 3 finite numbers (m), got {v!r}")
    return a


def _check_n(n: int) -> int:
    n = int(n)
    if n < 2:
        raise ValueError(f"a path needs at least 2 waypoints, got n = {n}")
    return n


def line(start, end, n: int = 20) -> Path:
    """``n`` equally spaced waypoints on the segment ``start -> end`` (m); direction = the segment."""
    a, b = _vec3(start, "start"), _vec3(end, "end")
    n = _check_n(n)
    if np.linalg.norm(b - a) <= _ZERO_SEGMENT:
        raise ValueError("line: start and end coincide")
    s = np.linspace(0.0, 1.0, n)[:, None]
    pts = a + s * (b - a)
    d = np.broadcast_to((b - a) / np.linalg.norm(b - a), pts.shape)
    return Path(pts, d, name="line")


def arc(center, radius: float, start_deg: float, end_deg: float, n: int = 30, normal=(0.0, 0.0, 1.0)) -> Path:
    """``n`` waypoints on a circular arc, equally spaced in angle; direction = analytic tangent.

    Args:
        center: (3,) m.
        radius: m, > 0.
        start_deg, end_deg: angles (degrees) measured in the plane normal to ``normal``, from its
            first in-plane axis (the base x axis for the default normal +z); the arc runs from
            start to end (either sense).
        n: waypoints.
        normal: plane normal (default +z: an arc in a horizontal xy plane).
    """
    c = _vec3(center, "center")
    if not radius > 0:
        raise ValueError(f"arc radius must be > 0 (m), got {radius}")
    n = _check_n(n)
    if start_deg == end_deg:
        raise ValueError("arc: start and end angles coincide")
    e1, e2, _ = _plane_basis(normal)
    th = np.deg2rad(np.linspace(start_deg, end_deg, n))
    pts = c + radius * (np.cos(th)[:, None] * e1 + np.sin(th)[:, None] * e2)
    sense = 1.0 if end_deg > start_deg else -1.0
    d = sense * (-np.sin(th)[:, None] * e1 + np.cos(th)[:, None] * e2)
    return Path(pts, d, name="arc")


def circle(center, radius: float, n: int = 60, normal=(0.0, 0.0, 1.0)) -> Path:
    """A full circle, ``n`` waypoints, the first point not repeated at the end."""
    n = _check_n(n)
    p = arc(center, radius, 0.0, 360.0 * (n - 1) / n if n > 1 else 0.0, n, normal)
    return Path(p.points, p.directions, name="circle")


def half_sine(start, end, amplitude: float, n: int = 60, periods: float = 1.0, normal=(0.0, 0.0, 1.0)) -> Path:
    """A sine bump along ``start -> end``: lateral offset ``amplitude * sin(pi * periods * s)``.

    The offset is in the plane normal to ``normal`` (default +z: in the horizontal plane),
    perpendicular to the chord; ``s`` runs 0..1 in ``n`` equal steps. ``periods = 1`` is a half
    sine (one bump), ``2`` an S-curve. Direction = analytic tangent.
    """
    a, b = _vec3(start, "start"), _vec3(end, "end")
    n = _check_n(n)
    chord = b - a
    L = np.linalg.norm(chord)
    if L <= _ZERO_SEGMENT:
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


def spline(points, n: int = 60) -> Path:
    """A cubic spline through the given points (K, 3), K >= 2, resampled at ``n`` waypoints.

    Chord-length parametrisation, natural end conditions (scipy ``CubicSpline``); waypoints
    equally spaced in the parameter; direction = the spline's analytic tangent.
    """
    from scipy.interpolate import CubicSpline

    pts = np.asarray(points, dtype=float)
    if pts.ndim != 2 or pts.shape[1] != 3 or pts.shape[0] < 2:
        raise ValueError(f"spline needs control points of shape (K >= 2, 3), got {pts.shape}")
    if not np.all(np.isfinite(pts)):
        raise ValueError("spline control points contain NaN or Inf")
    seg = np.linalg.norm(np.diff(pts, axis=0), axis=1)
    if np.any(seg <= _ZERO_SEGMENT):
        raise ValueError("spline: two consecutive control points coincide")
    n = _check_n(n)
    u = np.r_[0.0, np.cumsum(seg)]
    cs = CubicSpline(u, pts, axis=0, bc_type="natural" if pts.shape[0] > 2 else "not-a-knot")
    s = np.linspace(0.0, u[-1], n)
    return Path(cs(s), cs(s, 1), name="spline")


def _plane_basis(normal):
    nz = _vec3(normal, "normal")
    if np.linalg.norm(nz) <= 1e-12:
        raise ValueError("normal must be non-zero")
    nz = nz / np.linalg.norm(nz)
    ref = np.array([1.0, 0.0, 0.0]) if abs(nz[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    e1 = ref - nz * (ref @ nz)
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(nz, e1)
    return e1, e2, nz


#: The parameters of :func:`default_path` (also written into result metadata).
DEFAULT_PATH_SPEC = {
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
    64 degrees in all, at most 1.9 degrees between waypoints (fastest at the apex).

    How it was chosen: seed 000 moves the LWR's TCP along a curved path in the xy plane (Fig. 4/5)
    without giving it. This one keeps the TCP 0.65-0.70 m from the shoulder, so the elbow is
    bent by about 70-85 degrees: far from full stretch (0.87 m, singular) and from the A4 limit
    (120 degrees, reached when the TCP comes closer than about 0.45 m). Every waypoint is then
    reachable with room left in the 3-dimensional null space of the 6 free joints (7th locked) to
    turn the ellipsoid with the tangent; a first choice at 0.45-0.55 m from the base axis needed
    the elbow at 107-111 degrees and left SLSQP no room. Checked by the tests (IK reaches the
    waypoints; elbow bend in 40-100 degrees).

    Args:
        n: number of waypoints (default 60).
    """
    spec = dict(DEFAULT_PATH_SPEC)
    if n is not None:
        spec["n"] = int(n)
    p = half_sine(spec["start"], spec["end"], spec["amplitude"], n=spec["n"], periods=spec["periods"])
    return Path(p.points, p.directions, name="default")


_NUMBER = re.compile(r"[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?|[+-]?(?:inf|infinity|nan)", re.IGNORECASE | re.ASCII)


def read_csv(file: str | os.PathLike) -> tuple[np.ndarray, np.ndarray | None, list[int]]:
    """The rows of a path CSV (header ``x,y,z[,dx,dy,dz]``), without :class:`Path`'s geometry
    checks: ``(points (P, 3), directions (P, 3) or None, line number of each row)``, P >= 1.

    For users of the points alone (a CSC rollout takes one step per row and holds still where
    rows repeat). Blank lines and lines starting with ``#`` are skipped; a UTF-8 BOM is dropped;
    a cell must be a plain decimal number (``1_0`` or full-width digits, which Python's ``float``
    takes, are refused).

    Raises:
        FileNotFoundError: the file does not exist.
        ValueError: not UTF-8 text, no header or rows, a bad header, a row of the wrong length, a
            cell that is not a finite number (the message names file, line and column).
    """
    file = os.fspath(file)
    if os.path.isdir(file):
        raise ValueError(f"path file {file} is a folder; give a CSV file")
    if not os.path.isfile(file):
        raise FileNotFoundError(f"path file not found: {file}")
    try:
        with open(file, newline="", encoding="utf-8-sig") as fh:  # -sig: a BOM (spreadsheet export) is dropped
            text = fh.read()
    except UnicodeDecodeError:
        raise ValueError(f"{file}: not a text CSV file (cannot decode as UTF-8)") from None
    # CSV line ends only (str.splitlines also splits at form feeds, vertical tabs, U+2028, ...)
    lines = [(i + 1, ln) for i, ln in enumerate(re.split(r"\r\n|\r|\n", text)) if ln.strip() and not ln.lstrip().startswith("#")]
    if not lines:
        raise ValueError(f"{file}: empty file; expected a header x,y,z[,dx,dy,dz] and waypoint rows")
    header_no, header_line = lines[0]
    header = [h.strip().lower() for h in next(csv.reader([header_line]))]
    trailing = 0  # empty trailing columns (a spreadsheet's 'x,y,z,'): dropped where every row leaves them empty
    while len(header) > 3 and header[-1] == "":
        header.pop()
        trailing += 1
    if header[:3] != ["x", "y", "z"] or header not in (["x", "y", "z"], ["x", "y", "z", "dx", "dy", "dz"]):
        raise ValueError(
            f"{file}:{header_no}: header must be 'x,y,z' or 'x,y,z,dx,dy,dz', got {header_line.strip()!r}"
        )
    ncol = len(header)
    rows, numbers = [], []
    for line_no, ln in lines[1:]:
        cells = next(csv.reader([ln]))
        if trailing and len(cells) == ncol + trailing and not any(c.strip() for c in cells[ncol:]):
            cells = cells[:ncol]
        if len(cells) != ncol:
            raise ValueError(f"{file}:{line_no}: expected {ncol} values ({','.join(header)}), got {len(cells)}")
        row = []
        for col, cell in zip(header, cells, strict=True):
            if not _NUMBER.fullmatch(cell.strip()):
                raise ValueError(f"{file}:{line_no}: column {col}: {cell.strip()!r} is not a number")
            v = float(cell)
            if not math.isfinite(v):
                raise ValueError(f"{file}:{line_no}: column {col}: value {cell.strip()!r} is not finite")
            row.append(v)
        rows.append(row)
        numbers.append(line_no)
    if not rows:
        raise ValueError(f"{file}: no waypoint rows after the header")
    data = np.asarray(rows, dtype=float)
    return data[:, :3], (data[:, 3:6] if ncol == 6 else None), numbers
