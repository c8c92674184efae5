"""Path CSV text: reading the rows (with line numbers for error messages) and writing them.

Format (DESIGN.md): a header ``x,y,z`` and optionally ``dx,dy,dz``, one waypoint a row, metres in
the robot's base frame (directions unitless); blank lines and lines starting with ``#`` are
skipped. This module checks the text only; the geometry checks (tangents, zero-length segments)
are :class:`jaxstiff.paths.Path`'s.
"""

from __future__ import annotations

import csv
import io
import math
import os
import re
from typing import Any

import numpy as np

from jaxstiff.runtime._io import check_regular_file

__all__ = ["read_csv"]

#: the largest magnitude a coordinate or direction component may have: beyond it the squared
#: length of a segment or direction (a sum of 3 squares of differences) overflows float64
MAX_ABS_VALUE = 1e150

_NUMBER = re.compile(r"[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?|[+-]?(?:inf|infinity|nan)", re.IGNORECASE | re.ASCII)
_HEADERS = (["x", "y", "z"], ["x", "y", "z", "dx", "dy", "dz"])


def _content_lines(file: str) -> list[tuple[int, str]]:
    """``(line number, text)`` of the non-blank, non-comment lines of ``file`` (UTF-8, a BOM dropped)."""
    if os.path.isdir(file):
        raise ValueError(f"path file {file} is not a regular file: it is a folder; give a CSV file")
    check_regular_file(file, "path file")
    try:
        with open(file, newline="", encoding="utf-8-sig") as fh:  # -sig: a BOM (spreadsheet export) is dropped
            text = fh.read()
    except UnicodeDecodeError:
        raise ValueError(f"{file}: not a text CSV file (cannot decode as UTF-8)") from None
    # CSV line ends only (str.splitlines also splits at form feeds, vertical tabs, U+2028, ...)
    lines = [
        (i + 1, ln)
        for i, ln in enumerate(re.split(r"\r\n|\r|\n", text))
        if ln.strip() and not ln.lstrip().startswith("#")
    ]
    if not lines:
        what = "only comment lines" if text.strip() else "empty file"
        raise ValueError(f"{file}: {what}; expected a header x,y,z[,dx,dy,dz] and waypoint rows")
    return lines


def _parse_header(file: str, line_no: int, line: str) -> tuple[list[str], int]:
    """The column names (``x,y,z`` or ``x,y,z,dx,dy,dz``) and the number of empty trailing
    columns (a spreadsheet's ``x,y,z,``), which the rows may leave empty."""
    header = [h.strip().lower() for h in next(csv.reader([line]))]
    trailing = 0
    while len(header) > 3 and header[-1] == "":
        header.pop()
        trailing += 1
    if header[:3] != ["x", "y", "z"] or header not in _HEADERS:
        raise ValueError(f"{file}:{line_no}: header must be 'x,y,z' or 'x,y,z,dx,dy,dz', got {line.strip()!r}")
    return header, trailing


def _parse_row(file: str, line_no: int, line: str, header: list[str], trailing: int) -> list[float]:
    """The finite numbers of one waypoint row, one per header column."""
    ncol = len(header)
    cells = next(csv.reader([line]))
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
        if abs(v) > MAX_ABS_VALUE:
            raise ValueError(
                f"{file}:{line_no}: column {col}: value {cell.strip()!r} is beyond +-{MAX_ABS_VALUE:g}, where "
                "lengths overflow float64 (coordinates are metres)"
            )
        row.append(v)
    return row


def read_csv(file: str | os.PathLike[str]) -> tuple[np.ndarray, np.ndarray | None, list[int]]:
    """The rows of a path CSV (header ``x,y,z[,dx,dy,dz]``), without :class:`Path`'s geometry
    checks: ``(points (P, 3) m, directions (P, 3) or None, line number of each row)``, P >= 1.

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
    lines = _content_lines(file)
    header, trailing = _parse_header(file, *lines[0])
    rows = [_parse_row(file, line_no, ln, header, trailing) for line_no, ln in lines[1:]]
    if not rows:
        raise ValueError(f"{file}: no waypoint rows after the header")
    data = np.asarray(rows, dtype=float)
    numbers = [line_no for line_no, _ in lines[1:]]
    return data[:, :3], (data[:, 3:6] if len(header) == 6 else None), numbers


def format_csv(points: Any, directions: np.ndarray | None = None) -> str:
    """The CSV text of one path: header ``x,y,z[,dx,dy,dz]`` and one row per waypoint.

    Args:
        points: (P, 3) m, base frame; or an unbatched :class:`~jaxstiff.paths.Path` (then its
            points and, unless ``directions`` is given, its directions).
        directions: (P, 3) or None (then the file has no direction columns).

    Values are written as ``repr(float(v))`` (shortest round-trip), so :func:`read_csv` gives back
    the same float64 numbers.

    Raises:
        ValueError: points not (P, 3) with P >= 1, directions not of the points' shape.
    """
    if hasattr(points, "points") and hasattr(points, "directions"):  # a Path (core imports this module)
        if directions is None:
            directions = np.asarray(points.directions)
        points = points.points
    pts = np.asarray(points, dtype=float)
    if pts.ndim != 2 or pts.shape[1] != 3 or pts.shape[0] < 1:
        raise ValueError(f"format_csv writes one path: points of shape (P, 3), got {pts.shape}")
    if directions is not None and np.shape(directions) != pts.shape:
        raise ValueError(
            f"format_csv: directions must have the shape of points {pts.shape}, got {np.shape(directions)}"
        )
    points = pts
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(_HEADERS[1] if directions is not None else _HEADERS[0])
    for i, p in enumerate(points):
        vals = list(p) + (list(directions[i]) if directions is not None else [])
        w.writerow([repr(float(v)) for v in vals])
    return buf.getvalue()
