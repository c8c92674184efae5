"""What the viewer, the plot and the export commands read from a result: :class:`ViewData`.

One loader for the three kinds of result a user holds: a ``jaxstiff shape`` file, a ``jaxstiff
csc`` file, and one row of a sweep folder (its ``chunks/*.json`` name the array file and the index
of the row). Every file is read by the results layer's one reader
(:func:`jaxstiff.results._reader.read_result`), which checks it against its meta and its robot and
names what is wrong with a file it refuses. Everything is numpy: the chain is rebuilt from the
file's ``meta`` (URDF path, links, locks, tcp; :func:`chain_from_meta`) and the stiffness
ellipsoids come from :mod:`jaxstiff.view._kinematics`; JAX is not imported.

Units: q in rad (m for prismatic joints), kj in Nm/rad (N/m for prismatic joints), positions in m,
stiffness matrices in N/m, base frame throughout. A rigid locked joint (newer shape files,
``meta["settings"]["locked_joints"] == "rigid"``) has ``kj = +inf``; it is shown as "rigid".
"""

from __future__ import annotations

import dataclasses
import os
from typing import TYPE_CHECKING, Any

import numpy as np

from jaxstiff.results._grid import PathGrid
from jaxstiff.results._reader import ResultFile, chain_from_meta, read_result
from jaxstiff.view._kinematics import stiffness_T, tcp_position

if TYPE_CHECKING:
    from jaxstiff.model._chain import Chain

__all__ = ["sweep_row_file", "format_kj", "chain_from_meta"]


@dataclasses.dataclass(frozen=True, eq=False)
class ViewData(PathGrid):
    """A result as the viewer draws it. B paths (or rollouts), P waypoints (or steps), n joints.

    Attributes:
        kind: ``"shape"`` or ``"csc"``.
        source: the file read (and ``#row=N`` for a sweep row).
        robot: the chain rebuilt from the file's meta.
        q: (B, P, n) joint values, rad (m for prismatic joints).
        kj: (B, P, n) joint stiffness drawn: shape ``kj_scaled`` (after CMS), csc the realised kj;
            Nm/rad (N/m prismatic); ``+inf`` for a rigid locked joint.
        target: (B, P, 3) waypoints, m (csc "xy" targets get the TCP's z).
        position: (B, P, 3) TCP positions, m, as stored in the file.
        direction: (B, P, 3) desired directions (unit) of a shape result, else None.
        K: (B, P, 3, 3) realised translational stiffness, N/m (shape: K_T of kj_scaled; csc: K_C).
        K_desired: (B, P, 3, 3) csc's desired K_xd (translational block), else None.
        arrays: the file's per-step arrays (B, P) by key, for the panel and the plots.
        meta: the file's meta record.
        labels: B names of the paths.
        result: a shape file's :class:`~jaxstiff.results.ShapeResult` (every path of the file), else None.
        index: the path of ``result`` shown (a sweep row's index in its array file), else None (all).
    """

    kind: str
    source: str
    robot: Chain
    q: np.ndarray
    kj: np.ndarray
    target: np.ndarray
    position: np.ndarray
    direction: np.ndarray | None
    K: np.ndarray
    K_desired: np.ndarray | None
    arrays: dict[str, np.ndarray]
    meta: dict[str, Any]
    labels: list[str]
    result: Any = None
    index: int | None = None

    @property
    def locked_joints(self) -> str:
        """``"rigid"`` or ``"spring"`` (older files say nothing: spring)."""
        settings = self.meta.get("settings") or {}
        return str(settings.get("locked_joints", "spring")) if isinstance(settings, dict) else "spring"

    def info(self, b: int, p: int) -> list[tuple[str, str]]:
        """The panel's lines at path b, waypoint p: (label, value with unit)."""
        a = {k: v[b, p] for k, v in self.arrays.items()}
        if self.kind == "shape":
            from jaxstiff.results._status import STATUS_NAMES

            lines = [
                ("alpha", f"{a['alpha_deg']:.3g} deg"),
                ("rho", f"{a['ratio']:.4g} (target {self.meta.get('ratio')})"),
                (f"criterion {self.meta.get('criterion', '')}", f"{a['criterion']:.5g}"),
                ("status", STATUS_NAMES.get(int(a["status"]), str(int(a["status"])))),
                ("CMS factor", f"{a['cms']:.4g}"),
                ("|TCP - waypoint|", f"{a['pos_error']:.2e} m"),
            ]
        else:
            bits = self.meta.get("status_bits") or {}
            code = int(a["status"])
            status = "ok" if code == 0 else ", ".join(t for k, t in bits.items() if code & int(k)) or str(code)
            lines = [
                ("u", f"{a['u']:.5g} Nm/rad"),
                ("|K_xd - K_C|_F", f"{a['frobenius']:.5g} N/m"),
                ("tracking error", f"{a['tracking_error']:.2e} m"),
                ("status", status),
            ]
        return lines

    def kj_lines(self, b: int, p: int) -> list[tuple[str, str]]:
        """Per joint: (name, kj with unit, or "rigid" / "locked")."""
        unit = np.where(self.robot.prismatic, "N/m", "Nm/rad")
        return [
            (name, format_kj(float(k), str(u), locked=not free))
            for name, k, u, free in zip(self.robot.joint_names, self.kj[b, p], unit, self.robot.free, strict=True)
        ]


def format_kj(k: float, unit: str, locked: bool = False) -> str:
    """``"42.1 Nm/rad"``; ``"rigid"`` for +inf; ``"(locked)"`` appended for a locked joint."""
    text = "rigid" if np.isinf(k) else f"{k:.4g} {unit}"
    return text + (" (locked)" if locked and not np.isinf(k) else "")


def sweep_row_file(folder: str, row: int) -> tuple[str, int]:
    """The array file and the index in it of sweep row ``row``, after the checks of
    :func:`jaxstiff.sweep._stored.read_sweep_row` (plan, rows file, array file)."""
    from jaxstiff.sweep._stored import read_sweep_row

    rf, index = read_sweep_row(folder, row)
    return rf.file, index


def _block3(K: np.ndarray) -> np.ndarray:
    """The translational 3x3 block of (..., m, m) stiffness matrices (m = 2 padded with zeros)."""
    if K.shape[-1] == 2:
        out = np.zeros(K.shape[:-2] + (3, 3))
        out[..., :2, :2] = K
        return out
    return K[..., :3, :3]


def _shape_data(rf: ResultFile, index: int | None, source: str) -> ViewData:
    from jaxstiff.results._files import ShapeResult

    res = ShapeResult.from_file(rf)
    sel = slice(None) if index is None else slice(index, index + 1)
    robot = rf.chain
    q, kj = res.q[sel], res.kj_scaled[sel]
    K = stiffness_T(robot, q, kj, rf.task)
    keys = ("alpha_deg", "ratio", "criterion", "status", "cms", "pos_error")
    arrays = {k: np.asarray(getattr(res, k))[sel] for k in keys}
    arrays["kj_raw"] = res.kj[sel]
    labels = _labels(_path_names(res.meta.get("path")), q.shape[0], index)
    return ViewData(
        "shape",
        source,
        robot,
        q,
        kj,
        res.target[sel],
        res.position[sel],
        res.direction[sel],
        K,
        None,
        arrays,
        res.meta,
        labels,
        result=res,
        index=index,
    )


def _csc_data(rf: ResultFile, index: int | None, source: str) -> ViewData:
    data, meta, robot = rf.arrays, rf.meta, rf.chain  # (per-step arrays with the batch axis)
    sel = slice(None) if index is None else slice(index, index + 1)
    q = data["q"][sel]
    B, T = q.shape[:2]
    position = data["position"][sel]
    target = data["target"][sel]
    if target.shape[-1] == 2:
        target = np.concatenate([target, position[..., 2:3]], axis=-1)
    Kxd = data["K_xd"] if "K_xd" in data else _meta_kxd(meta, rf.file)
    if Kxd.ndim == 3 and Kxd.shape[0] != 1 and index is not None:
        Kxd = Kxd[sel]
    Kxd = np.broadcast_to(_block3(Kxd).reshape((-1, 1, 3, 3) if Kxd.ndim == 3 else (1, 1, 3, 3)), (B, T, 3, 3))
    arrays = {k: np.asarray(data[k])[sel] for k in ("u", "frobenius", "tracking_error", "status", "isotropy")}
    labels = _labels(_path_names(meta.get("paths")), B, index)
    return ViewData(
        "csc",
        source,
        robot,
        q,
        data["kj"][sel],
        target,
        position,
        None,
        _block3(data["K_C"][sel]),
        Kxd.copy(),
        arrays,
        meta,
        labels,
        index=index,
    )


def _meta_kxd(meta: dict[str, Any], file: str) -> np.ndarray:
    """A csc file without its K_xd array (a library save): the meta's ``K_xd``, else NaN (not drawn)."""
    try:
        K = np.asarray(meta.get("K_xd", np.full((3, 3), np.nan)), dtype=float)
    except (TypeError, ValueError):
        K = np.zeros((0, 0, 0))
    if K.ndim not in (2, 3) or K.shape[-1] != K.shape[-2] or K.shape[-1] not in (2, 3, 6):
        from jaxstiff.results._reader import ResultFileError

        raise ResultFileError(file, "meta K_xd", "a square 2x2, 3x3 or 6x6 matrix (no K_xd array)", meta.get("K_xd"))
    return K


def _path_names(rec: Any) -> list[str]:
    """Path names from a meta record: a dict with ``name`` (";"-joined for a batch), a list, or a string."""
    if isinstance(rec, dict):
        rec = rec.get("name") or rec.get("names") or ""
    if isinstance(rec, (list, tuple)):
        return [os.path.basename(str(p)) for p in rec]
    return [p for p in str(rec or "").split(";") if p]


def _labels(parts: list[str], B: int, index: int | None) -> list[str]:
    if index is not None:
        return [f"row index {index}" + (f": {parts[index]}" if index < len(parts) else "")]
    return [f"path {b}" + (f": {parts[b]}" if len(parts) == B else "") for b in range(B)]


def load_view_data(file: str | os.PathLike, row: int | None = None, urdf: str | None = None) -> ViewData:
    """Read a shape or csc result file, or row ``row`` of a sweep folder, for viewing.

    Args:
        file: a ``.npz`` result file, or a sweep output folder (then ``row`` is required).
        row: the sweep row (``row_id`` of ``results.parquet``).
        urdf: the robot's URDF when the recorded path moved (its sha256 is then not checked).

    Raises:
        FileNotFoundError: no such file or folder, or the URDF is missing.
        ValueError: not a jaxstiff result, or no such row.
    """
    file = os.fspath(file)
    index = None
    source = file
    if os.path.isdir(file):
        if row is None:
            raise ValueError(f"{file} is a sweep folder: pick one of its rows with --row ROW_ID")
        from jaxstiff.sweep._stored import read_sweep_row

        source = f"{file}#row={row}"
        # the sweep's checks (plan, rows file, the row against its array file), the array file
        # read by the one reader
        rf, index = read_sweep_row(file, row, urdf)
    elif row is not None:
        raise ValueError(f"--row {row} is for a sweep folder; {file} is a result file (use --path B to pick a path)")
    else:
        rf = read_result(file, urdf)  # the one reader: schema, robot, joints, locks, positions, task
    return _shape_data(rf, index, source) if rf.kind == "shape" else _csc_data(rf, index, source)


def check_positions(data: ViewData) -> float:
    """Largest distance (m) between the stored TCP positions and the numpy FK of the stored q (a file
    read by :func:`load_view_data` has passed the reader's check of it:
    :data:`jaxstiff.results._reader.POSITION_TOL`)."""
    return float(np.max(np.linalg.norm(tcp_position(data.robot, data.q) - data.position, axis=-1)))


def check_drawable(data: ViewData) -> None:
    """Refuse ``data`` unless every waypoint has a posture and a stiffness to draw: a non-finite one (a file may hold NaN
    q or kj where a waypoint is not usable, status 3-5) is refused by name, not met by the
    eigen-decomposition of its ellipsoid ("Eigenvalues did not converge")."""
    bad = ~np.isfinite(data.q).all(axis=-1) | ~np.isfinite(data.K).all(axis=(-2, -1))
    if bad.any():
        b, p = (int(i) for i in np.argwhere(bad)[0])
        status = data.arrays.get("status")
        st = f" (status {int(status[b, p])})" if status is not None else ""
        what = "joint values" if not np.isfinite(data.q[b, p]).all() else "stiffness"
        raise ValueError(
            f"{data.source}: path {b}, waypoint {p}{st}: non-finite {what}, which the viewer and plot cannot draw"
            + (f" ({int(bad.sum()) - 1} more such waypoints)" if bad.sum() > 1 else "")
            + "; `jaxstiff export` writes every waypoint to CSV"
        )
