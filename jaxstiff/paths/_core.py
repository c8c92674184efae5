"""The :class:`Path` of a TCP (waypoints + desired directions) and the default direction, the tangent.

Shapes and units: ``points`` (P, 3) or a batch (B, P, 3), metres in the robot's base frame;
``directions`` the same shape, unit vectors. The default direction is the unit tangent by central
differences, ``(x_{p+1} - x_{p-1}) / |...|``, one-sided at the two ends (:func:`tangents`).
"""

from __future__ import annotations

import dataclasses
import os
import re
from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike

from jaxstiff._numerics.batch import NotNumbersError, shown_value
from jaxstiff.runtime._dtypes import refuse_half_precision
from jaxstiff.runtime._io import atomic_write_text

from ._csv_io import MAX_ABS_VALUE, format_csv, read_csv

__all__ = ["Path", "tangents"]

#: m: segments shorter than this have no direction (shared with the generators).
ZERO_SEGMENT_M = 1e-12


def tangents(points: ArrayLike, where: str = "path") -> np.ndarray:
    """Unit tangents of a polyline (P, 3) -> (P, 3) by central differences (one-sided at the ends;
    at a waypoint where the path turns straight back, the line of its two segments).

    Args:
        points: (P, 3) waypoints, P >= 2 (any length unit; the result is unitless).
        where: the name used in error messages.

    Raises:
        ValueError: a waypoint whose neighbours coincide with it (zero-length segment), since then
            the direction of motion is undefined; give the directions explicitly.
    """
    pts = np.asarray(points, dtype=float)
    if pts.ndim != 2 or pts.shape[0] < 2:
        raise ValueError(
            f"{where}: tangents need at least 2 waypoints (P, 3), got shape {pts.shape}; give the directions "
            "explicitly for a single waypoint"
        )
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
        rev = (
            np.flatnonzero(
                (norm[1:-1] <= 1e-9 * (seg[:-1] + seg[1:])) & (seg[:-1] > ZERO_SEGMENT_M) & (seg[1:] > ZERO_SEGMENT_M)
            )
            + 1
        )
        t[rev] = (pts[rev] - pts[rev - 1]) / seg[rev - 1, None] - (pts[rev + 1] - pts[rev]) / seg[rev, None]
        norm[rev] = np.linalg.norm(t[rev], axis=-1)
    bad = np.flatnonzero(
        (norm <= ZERO_SEGMENT_M) | np.r_[seg <= ZERO_SEGMENT_M, False] | np.r_[False, seg <= ZERO_SEGMENT_M]
    )
    if bad.size:
        raise ValueError(
            f"{where}: zero-length segment at waypoint {int(bad[0])} (consecutive waypoints coincide) "
            f"and no direction given; remove the duplicate waypoint or give dx,dy,dz"
        )
    return t / norm[:, None]


def _checked_points(points: ArrayLike, has_directions: bool, where: str) -> np.ndarray:
    """``points`` as a fresh float64 (P, 3) or (B, P, 3) array of finite values, P >= 2 (>= 1 with directions)."""
    if isinstance(points, (str, bytes, os.PathLike)):
        raise NotNumbersError(
            f"{where}: points must be numbers of shape (P, 3) or (B, P, 3) (m), got {shown_value(points)}; "
            "a path file is read with jaxstiff.Path.from_csv(file)"
        )
    try:
        given = np.asarray(points)
    except (TypeError, ValueError):
        given = None
    if given is None or given.dtype.kind not in "biufc":  # ragged rows, text, objects
        raise NotNumbersError(
            f"{where}: points must be numbers of shape (P, 3) or (B, P, 3) (m): got rows of different lengths, "
            f"or not numbers ({shown_value(points)})"
        )
    refuse_half_precision(where, points=given)
    if np.iscomplexobj(given):  # float() would drop the imaginary part with only numpy's warning
        raise ValueError(f"{where}: points are complex numbers; give real coordinates (m)")
    pts = np.array(given, dtype=float, copy=True)
    if pts.ndim not in (2, 3) or pts.shape[-1] != 3:
        raise ValueError(f"{where}: points must have shape (P, 3) or (B, P, 3), got {pts.shape}")
    if pts.shape[-2] < 1 or (pts.shape[-2] < 2 and not has_directions):
        raise ValueError(
            f"{where}: a path needs at least 2 waypoints, or 1 with its direction given (columns "
            f"dx,dy,dz): one point has no tangent; got {pts.shape[-2]}"
        )
    if pts.ndim == 3 and pts.shape[0] < 1:
        raise ValueError(f"{where}: empty batch of paths")
    if not np.all(np.isfinite(pts)):
        raise ValueError(f"{where}: points contain NaN or Inf")
    _refuse_huge(pts, "points", where)
    return pts


def _refuse_huge(a: np.ndarray, what: str, where: str) -> None:
    """Refuse values beyond :data:`MAX_ABS_VALUE` (their squared lengths overflow float64), by index."""
    big = np.argwhere(np.abs(a) > MAX_ABS_VALUE)
    if big.size:
        idx = big[0].tolist()
        raise ValueError(
            f"{where}: {what} value {a[tuple(idx)]:g} at waypoint {idx[-2]}, column {'xyz'[idx[-1]]} is beyond "
            f"+-{MAX_ABS_VALUE:g}, where lengths overflow float64"
        )


def _unit_directions(directions: ArrayLike | None, pts: np.ndarray, where: str) -> np.ndarray:
    """The given directions normalised to unit length, or the path tangents (shape of ``pts``)."""
    if directions is None:
        if pts.ndim == 2:
            return tangents(pts, where)
        return np.stack([tangents(p, f"{where}[{b}]") for b, p in enumerate(pts)])
    refuse_half_precision(where, directions=directions)
    if np.iscomplexobj(directions):
        raise ValueError(f"{where}: directions are complex numbers; give real vectors")
    d = np.array(directions, dtype=float, copy=True)
    if d.shape != pts.shape:
        raise ValueError(f"{where}: directions must have the shape of points {pts.shape}, got {d.shape}")
    if not np.all(np.isfinite(d)):
        raise ValueError(f"{where}: directions contain NaN or Inf")
    _refuse_huge(d, "directions", where)
    norm = np.linalg.norm(d, axis=-1)
    if np.any(norm <= 1e-12):
        idx = np.argwhere(norm <= 1e-12)[0].tolist()
        raise ValueError(f"{where}: zero-length direction at waypoint {idx[-1]}")
    return d / norm[..., None]


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
        points: (P, 3) or (B, P, 3) float64, read-only.
        directions: same shape, unit vectors, read-only.

    Raises:
        ValueError: wrong shape, fewer than 2 waypoints (1 without directions), NaN/Inf, a zero direction, or a
            zero-length segment where no direction was given.
    """

    points: np.ndarray
    directions: np.ndarray
    name: str = ""

    def __init__(self, points: ArrayLike, directions: ArrayLike | None = None, name: str = "") -> None:
        where = name or "path"
        pts = _checked_points(points, directions is not None, where)
        d = _unit_directions(directions, pts, where)
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
        for i, p in enumerate(paths):
            if not isinstance(p, Path):
                raise TypeError(
                    f"Path.stack takes Path objects; item {i} is a {type(p).__name__} (wrap points in jaxstiff.Path(...))"
                )
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
    def from_csv(file: str | os.PathLike[str]) -> Path:
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
                msg = file + msg[len(name) :]
            raise ValueError(msg) from None

    def to_csv(self, file: str | os.PathLike[str], directions: bool = True) -> None:
        """Write an unbatched path as CSV (``x,y,z,dx,dy,dz``, or ``x,y,z`` with ``directions=False``),
        atomically (temp file + rename); values as Python's shortest round-trip repr, so reading the
        file back gives the same float64 points."""
        if self.batched:
            raise ValueError("to_csv writes one path; index the batch first (path[b])")
        text = format_csv(self.points, self.directions if directions else None)
        atomic_write_text(os.fspath(file), text)

    def __repr__(self) -> str:
        shape = "x".join(str(s) for s in self.points.shape)
        return f"Path({self.name or 'unnamed'}, points {shape})"
