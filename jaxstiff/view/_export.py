"""A result's joint trajectory as CSV, for a controller: :func:`export_csv`, :func:`read_csv`.

One row per waypoint (shape) or step (csc) of every path; columns, in this order:

* ``path`` (0-based index of the path / rollout in the file), ``index`` (waypoint or step);
* ``q_<joint>_<unit>`` per actuated joint, chain order, locked joints included: rad (``m`` for a
  prismatic joint);
* ``kj_<joint>_<unit>``: shape files the joint stiffness before CMS, csc files the realised kj;
  ``Nm_per_rad`` (``N_per_m`` for a prismatic joint); ``inf`` for a rigid locked joint;
* ``kj_scaled_<joint>_<unit>`` (shape only): after CMS, what the controller should command;
* ``tcp_x_m``, ``tcp_y_m``, ``tcp_z_m``: the stored TCP position, m, in the robot's base frame
  (the URDF's base link), the TCP being the tip link plus the result's tcp offset;
* ``status``: the waypoint's or step's status code (:mod:`jaxstiff.results._status`; csc: its
  flags). A shape row with status 3-5 is not a solution (unreachable: the solver's closest point
  inside its box, the TCP off the path; not run and, mostly, non-finite: the reference state): a
  controller must not command it (:func:`unusable_rows` names them; ``jaxstiff export`` warns).

Values are written with 17 significant digits, so a round trip is exact.
"""

from __future__ import annotations

import csv
import io
import os

import numpy as np

from jaxstiff.view._data import ViewData, load_view_data

__all__ = ["export_csv", "csv_text", "read_csv", "csv_columns", "unusable_rows"]


def _units(data: ViewData) -> tuple[list[str], list[str]]:
    pris = data.robot.prismatic
    return [("m" if p else "rad") for p in pris], [("N_per_m" if p else "Nm_per_rad") for p in pris]


def csv_columns(data: ViewData) -> list[str]:
    """The CSV header of ``data`` (module docstring)."""
    qu, ku = _units(data)
    names = data.robot.joint_names
    cols = ["path", "index"] + [f"q_{j}_{u}" for j, u in zip(names, qu, strict=True)]
    cols += [f"kj_{j}_{u}" for j, u in zip(names, ku, strict=True)]
    if data.kind == "shape":
        cols += [f"kj_scaled_{j}_{u}" for j, u in zip(names, ku, strict=True)]
    return cols + ["tcp_x_m", "tcp_y_m", "tcp_z_m", "status"]


def unusable_rows(data: ViewData, path: int | None = None) -> dict[int, np.ndarray]:
    """Shape results: per path (only those with any), the waypoints whose status is 3-5 (not a
    usable solution); {} for csc results."""
    if data.kind != "shape":
        return {}
    from jaxstiff.results._status import is_usable
    from jaxstiff.results._target import waypoints_by_path

    bad = waypoints_by_path(~is_usable(np.asarray(data.arrays["status"])))
    return bad if path is None else {b: v for b, v in bad.items() if b == path}


def export_csv(result: ViewData | str | os.PathLike, out: str | os.PathLike, path: int | None = None) -> str:
    """Write the joint trajectory of a result (a file, a :class:`ViewData`) as CSV; returns the file.

    Args:
        result: a shape or csc result file, or its :class:`ViewData`.
        out: the CSV to write (atomically).
        path: only this path of a batch (default: all, told apart by the ``path`` column).
    """
    from jaxstiff.runtime._io import atomic_write_text

    return atomic_write_text(out, csv_text(result, path))


def csv_text(result: ViewData | str | os.PathLike, path: int | None = None) -> str:
    """The text :func:`export_csv` writes (for standard output: ``jaxstiff export --csv -``)."""
    data = result if isinstance(result, ViewData) else load_view_data(result)
    paths = range(data.B) if path is None else [path]
    if path is not None and not 0 <= path < data.B:
        raise ValueError(f"path {path}: the result has {data.B} path(s), 0..{data.B - 1}")
    kj_raw = data.arrays["kj_raw"] if data.kind == "shape" else data.kj
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(csv_columns(data))
    for b in paths:
        for p in range(data.P):
            vals = [*data.q[b, p], *kj_raw[b, p]] + ([*data.kj[b, p]] if data.kind == "shape" else [])
            st = int(data.arrays["status"][b, p])
            w.writerow([b, p, *(f"{v:.17g}" for v in [*vals, *data.position[b, p]]), st])
    return buf.getvalue()


def read_csv(file: str | os.PathLike) -> dict[str, np.ndarray]:
    """Read a CSV written by :func:`export_csv`: ``{column: array}`` (``path``, ``index`` as int)."""
    with open(file, newline="") as fh:
        rows = list(csv.reader(fh))
    if not rows:
        raise ValueError(f"{file}: empty CSV")
    head, body = rows[0], np.asarray(rows[1:], dtype=float).reshape(-1, len(rows[0]))
    ints = ("path", "index", "status")
    return {c: (body[:, i].astype(int) if c in ints else body[:, i]) for i, c in enumerate(head)}
