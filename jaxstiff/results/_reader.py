"""The one reader of result files: every consumer (view, plot, export, check-sim,
:func:`jaxstiff.results.verify`, sweep rows, :meth:`ShapeResult.load`, :meth:`CSCResult.load`)
goes through it, so they accept and refuse the same files.

Two levels:

* :func:`read_arrays` (the schema; what ``ShapeResult.load`` / ``CSCResult.load`` use): the file
  is a regular ``.npz`` (no pickles), its meta a JSON record, every array present with the shape
  the meta and ``q`` give (B >= 1, P >= 1, n the meta's joint count), the dtypes of the format
  (q, kj, positions float32 or float64 only: int, bool, complex, float16 refused; codes integers;
  names text), the values that must be finite finite (q and positions at usable waypoints, the
  paths), stiffness > 0 and finite except ``+inf`` at a rigid locked joint, status codes known, the
  meta fields the readers use of the right type.
* :func:`read_result` (what the commands use): the schema, then the robot: the URDF opened only as
  a regular file of bounded size (:func:`jaxstiff.runtime._io.check_urdf_file`), its sha256 checked,
  the chain rebuilt and compared with the record (name, joint names in order, limits, tip
  transform), locked joints at their values, q inside the limits at usable waypoints, each usable
  waypoint's step in q and kj within the recorded rate limits (``limits.dq`` / ``dk``, from q0 / kj0
  at the first one when ``first_rate_limit``), the stored
  TCP positions recomputed by numpy FK of the stored q (within :data:`POSITION_TOL`), and the task
  checked against the stored stiffness (shape: the axis ratio; csc: ``K_C``). A file that claims
  another robot, TCP or task is refused, naming what disagrees.

Every refusal is a :class:`ResultFileError` (a ValueError; the commands' exit 2) with one line
``FILE: FIELD: expected ..., found ...``. Numpy only: nothing here imports JAX.
"""

from __future__ import annotations

import dataclasses
import json
import math
import os
from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

import numpy as np

from jaxstiff.results._status import USABLE
from jaxstiff.runtime._io import check_regular_file, file_sha256, meta_loads

if TYPE_CHECKING:
    from jaxstiff.model._chain import Chain

__all__ = ["SHAPE_KEYS", "CSC_KEYS", "POSITION_TOL", "TASKS"]

POSITION_TOL = 1e-6  #: m: stored TCP positions against the numpy FK of the stored q
RATIO_REL_TOL = 1e-4  #: stored axis ratio against the one of the recorded task (well-conditioned waypoints)
K_REL_TOL = 1e-6  #: csc: stored K_C against the one of q, kj and the task (relative, Frobenius)
COND_MAX = 1e10  #: compliances worse conditioned than this are not compared (round-off)
TASKS = {"xy": 2, "xyz": 3, "full": 6}  #: task -> rows of its Jacobian (and size of csc's K_C)

_SHAPE_BPN = ("q", "kj", "kj_scaled")
_SHAPE_BP3 = ("target", "direction", "position")
_SHAPE_BP_FLOAT = ("cms", "pos_error", "alpha_deg", "ratio", "criterion", "time_s")
_SHAPE_BP_INT = ("status", "solver_code", "nit", "nfev")
_SHAPE_BN = ("q0", "kj0")
#: the arrays of a shape result file (jaxstiff.results._files)
SHAPE_KEYS = ("joint_names", *_SHAPE_BPN, *_SHAPE_BP3, *_SHAPE_BP_FLOAT, *_SHAPE_BP_INT, *_SHAPE_BN)
_CSC_BT_FLOAT = ("u", "frobenius", "tracking_error", "orientation_error", "isotropy", "null_step")
#: the arrays of a csc result file (jaxstiff.csc._result.CSCResult's fields)
CSC_KEYS = ("q", *_CSC_BT_FLOAT[:4], "kj", "K_C", "position", "target", *_CSC_BT_FLOAT[4:], "status")
CSC_KEYS = (*CSC_KEYS, "u_start", "frobenius_start")


class ResultFileError(ValueError):
    """A result file the readers refuse: one line ``FILE: FIELD: expected ..., found ...``."""

    def __init__(self, file: str, field: str, expected: str, found: Any = None, *, text: str | None = None):
        self.file, self.field = file, field
        msg = text if text is not None else f"expected {expected}, found {_short(found)}"
        self.text = msg  #: the message without the file and field
        where = f"{file}: " if field == "file" else f"{file}: {field}: "  # (the whole file: no field)
        super().__init__(" ".join(f"{where}{msg}".split()))


def _short(x: Any, limit: int = 80) -> str:
    s = x if isinstance(x, str) and x.startswith("<") else repr(x)
    s = " ".join(str(s).split())
    return s if len(s) <= limit else s[: limit - 3] + "..."


@dataclasses.dataclass(frozen=True, eq=False)
class ResultFile:
    """A result file that passed :func:`read_result`.

    Attributes:
        file: the file read.
        kind: ``"shape"`` or ``"csc"``.
        arrays: its arrays by key (shape: the ``ShapeResult`` fields; csc: every array, q and
            the per-step arrays with a batch axis even where the file has none), float64 for
            the float arrays, int64 for the codes.
        meta: its meta record.
        chain: the robot rebuilt from the meta (numpy chain, no JAX).
    """

    file: str
    kind: str
    arrays: dict[str, np.ndarray]
    meta: dict[str, Any]
    chain: Chain

    @property
    def task(self) -> str:
        return str(self.meta["task"])


# ---------------------------------------------------------------------- the file
def _load_npz(file: str) -> dict[str, np.ndarray]:
    if not os.path.exists(file):
        raise FileNotFoundError(f"result file not found: {file}")
    try:
        check_regular_file(file, "result file")
    except ValueError as exc:  # a FIFO, a device, a folder: never opened
        raise ResultFileError(file, "file", "", text=str(exc).split(": ", 1)[-1]) from None
    with open(file, "rb") as fh:
        head = fh.read(4)
    if head != b"PK\x03\x04":  # every .npz is a zip archive; anything else numpy would try to unpickle
        text = all(32 <= b < 127 or b in (9, 10, 13) for b in head)
        kind = "the file is empty" if not head else "it is text, e.g. a CSV" if text else "it is not a zip archive"
        raise ResultFileError(
            file,
            "file",
            "",
            text=f"not a readable .npz result file ({kind}); results are written by `jaxstiff shape --out r.npz` "
            "or `jaxstiff csc --out r.npz`",
        )
    try:
        with np.load(file, allow_pickle=False) as z:
            return {k: z[k] for k in z.files}
    except Exception as exc:  # zip/format errors, an object array (a pickle)
        raise ResultFileError(
            file, "file", "", text=f"not a readable .npz result file ({type(exc).__name__}: {exc})"
        ) from None


def file_kind(arrays: dict[str, np.ndarray]) -> str:
    """``"csc"`` for a csc result's arrays (``K_C`` and ``u``), else ``"shape"``."""
    return "csc" if {"K_C", "u"} <= set(arrays) else "shape"


def _meta(file: str, arrays: dict[str, np.ndarray]) -> dict[str, Any]:
    raw = arrays.get("meta")
    if raw is None:
        raise ResultFileError(file, "meta", "a JSON record (the file's meta array)", "no meta array")
    if raw.shape != () or raw.dtype.kind != "U":
        raise ResultFileError(
            file, "meta", "a 0-d text array holding JSON", f"<{raw.dtype} array of shape {raw.shape}>"
        )
    try:
        meta = meta_loads(str(raw))
    except (json.JSONDecodeError, ValueError, RecursionError) as exc:
        raise ResultFileError(file, "meta", "", text=f"not valid JSON ({exc})") from None
    if not isinstance(meta, dict):
        raise ResultFileError(file, "meta", "a JSON record {...}", f"<{type(meta).__name__}> {meta!r:.40}")
    return meta


# ---------------------------------------------------------------------- small checks
def _float_array(file: str, key: str, a: np.ndarray) -> np.ndarray:
    if a.dtype.kind != "f" or a.dtype.itemsize not in (4, 8):
        raise ResultFileError(file, key, "float32 or float64 values", f"<dtype {a.dtype}>")
    return a.astype(np.float64)


def _int_array(file: str, key: str, a: np.ndarray) -> np.ndarray:
    if a.dtype.kind not in "iu":
        raise ResultFileError(file, key, "integer codes", f"<dtype {a.dtype}>")
    return a.astype(np.int64)


def _shape(file: str, key: str, a: np.ndarray, want: tuple[int, ...], how: str) -> None:
    if a.shape != want:
        raise ResultFileError(file, key, f"shape {want} ({how})", f"<shape {a.shape}>")


def _where(mask: np.ndarray) -> str:
    idx = tuple(int(i) for i in np.argwhere(mask)[0])
    return f"at index {idx}" + (f" and {int(mask.sum()) - 1} more" if mask.sum() > 1 else "")


def _number(x: Any) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool)


def _text(x: Any) -> bool:
    return isinstance(x, str)


def _meta_field(file: str, meta: dict, key: str, ok: Any, expected: str, *, required: bool = False) -> Any:
    """meta[key] (dotted for nested records) if ``ok(value)``, else a ResultFileError."""
    rec: Any = meta
    parts = key.split(".")
    for part in parts[:-1]:
        rec = rec.get(part) if isinstance(rec, dict) else None
    if not isinstance(rec, dict) or parts[-1] not in rec:
        if required:
            raise ResultFileError(file, f"meta {key}", expected, "nothing (the field is missing)")
        return None
    value = rec[parts[-1]]
    if not ok(value):
        raise ResultFileError(file, f"meta {key}", expected, value)
    return value


def _numbers(x: Any, n: int | None = None, finite: bool = True) -> bool:
    if not isinstance(x, (list, tuple)) or (n is not None and len(x) != n):
        return False
    return all(_number(v) and (not finite or math.isfinite(v)) for v in x)


def _matrix4(x: Any) -> bool:
    return isinstance(x, (list, tuple)) and len(x) == 4 and all(_numbers(r, 4) for r in x)


# ---------------------------------------------------------------------- meta
def _check_robot_meta(file: str, meta: dict, n: int, required: bool) -> dict | None:
    """meta["robot"] checked (full mode), or as it is for the locked-joint mask (schema mode)."""
    if not required:
        rmeta = meta.get("robot")
        return rmeta if isinstance(rmeta, dict) else None
    rmeta = _meta_field(
        file, meta, "robot", lambda v: isinstance(v, dict), "a record (URDF, links, locks)", required=required
    )
    if rmeta is None:
        return None
    _meta_field(file, meta, "robot.urdf", lambda v: _text(v) and bool(v.strip()), "a URDF file name", required=required)
    _meta_field(
        file, meta, "robot.sha256", lambda v: _text(v) and (v == "" or len(v) == 64), "a sha256 (64 hex digits)"
    )
    _meta_field(file, meta, "robot.name", _text, "the robot's name (text)")
    for key in ("base_link", "tip_link"):
        _meta_field(file, meta, f"robot.{key}", lambda v: v is None or _text(v), "a link name (text) or null")
    _meta_field(
        file,
        meta,
        "robot.locked",
        lambda v: v is None or (isinstance(v, dict) and all(_number(x) and math.isfinite(x) for x in v.values())),
        "a record {joint: finite value}",
    )
    _meta_field(
        file,
        meta,
        "robot.joint_names",
        lambda v: isinstance(v, list) and len(v) == n and all(_text(x) for x in v),
        f"a list of {n} joint names (the file's q has {n} columns)",
    )
    for key in ("lower", "upper"):
        _meta_field(file, meta, f"robot.{key}", lambda v: _numbers(v, n, finite=False), f"a list of {n} numbers")
    for key in ("tip_transform", "tcp"):
        _meta_field(file, meta, f"robot.{key}", lambda v: v is None or _matrix4(v), "a 4x4 matrix of finite numbers")
    return rmeta


def _check_shape_meta(file: str, meta: dict, B: int, n: int, full: bool) -> None:
    task = _meta_field(
        file, meta, "task", lambda v: isinstance(v, str) and v in TASKS, f"one of {', '.join(TASKS)}", required=full
    )
    _meta_field(file, meta, "settings", lambda v: isinstance(v, dict), "a record")
    _meta_field(file, meta, "settings.task", lambda v: v == task or task is None, f"the task of the file ({task!r})")
    _meta_field(file, meta, "settings.locked_joints", lambda v: v in ("rigid", "spring"), "'rigid' or 'spring'")
    crit = _meta_field(file, meta, "criterion", _text, "the criterion's name (text)", required=full)
    pos = lambda v: _number(v) and math.isfinite(v) and v > 0  # noqa: E731
    _meta_field(
        file,
        meta,
        "ratio",
        lambda v: pos(v) or (_numbers(v, B) and all(x > 0 for x in v)),
        f"a positive number or {B} of them",
        required=full,
    )
    _meta_field(
        file, meta, "c", lambda v: _number(v) and math.isfinite(v), "a finite number", required=full and crit == "f1"
    )
    _meta_field(file, meta, "pos_tol", pos, "a positive number")
    cms = _meta_field(
        file, meta, "cms", lambda v: isinstance(v, dict), "a record (target_volume or target_major)", required=full
    )
    if cms is not None:
        for key in ("target_volume", "target_major"):
            _meta_field(file, meta, f"cms.{key}", lambda v: v is None or pos(v), "a positive number or null")
        if cms.get("target_volume") is None and cms.get("target_major") is None:
            raise ResultFileError(file, "meta cms", "target_volume or target_major (the CMS rule)", cms)
    if _meta_field(file, meta, "limits", lambda v: isinstance(v, dict), "a record (kmin, kmax, dq, dk)", required=full):
        kmin = _meta_field(file, meta, "limits.kmin", pos, "a positive number", required=full)
        _meta_field(
            file,
            meta,
            "limits.kmax",
            lambda v: _number(v) and (kmin is None or v >= kmin),
            f"a number >= kmin ({kmin})",
            required=full,
        )
        _meta_field(
            file, meta, "limits.first_rate_limit", lambda v: isinstance(v, bool), "true or false", required=full
        )
        for key in ("dq", "dk"):
            lim = meta["limits"]
            v = lim.get(key)
            if v is None and not full:
                continue
            ok = (
                _number(v)
                or _numbers(v, n, finite=False)
                or (isinstance(v, list) and len(v) == B and all(_numbers(r, n, finite=False) for r in v))
            )
            if not ok or np.any(np.asarray(v, dtype=float) < 0) or np.any(np.isnan(np.asarray(v, dtype=float))):
                raise ResultFileError(file, f"meta limits.{key}", f"a number >= 0, {n} of them, or {B} lists of {n}", v)


def _locked_mask(rmeta: dict | None, names: list[str]) -> np.ndarray:
    locked = (rmeta or {}).get("locked") or {}
    locked = locked if isinstance(locked, dict) else {}
    return np.asarray([nm in locked for nm in names], dtype=bool)


def _check_stiffness(file: str, key: str, kj: np.ndarray, rows: np.ndarray, locked: np.ndarray, rigid_ok: bool) -> None:
    """kj (..., n) at the rows selected by ``rows`` (...): > 0 and finite; +inf only at a rigid locked joint."""
    k = kj[rows]
    inf_ok = locked[None, :] & rigid_ok
    bad = np.isnan(k) | (k <= 0) | (np.isinf(k) & ~inf_ok)
    if bad.any():
        v = k[bad][0]
        rule = "> 0 and finite (+inf only at a rigid locked joint)"
        idx = tuple(int(i) for i in np.argwhere(rows)[np.argwhere(bad)[0][0]]) + (int(np.argwhere(bad)[0][-1]),)
        raise ResultFileError(file, key, f"stiffness {rule}", f"{v} at index {idx}")


def _check_finite(file: str, key: str, a: np.ndarray, rows: np.ndarray | None = None, what: str = "") -> None:
    sel = a if rows is None else a[rows]
    bad = ~np.isfinite(sel)
    if bad.any():
        raise ResultFileError(file, key, f"finite values{what}", f"{sel[bad][0]} ({int(bad.sum())} non-finite)")


# ---------------------------------------------------------------------- shape schema
def _shape_schema(file: str, data: dict[str, np.ndarray], meta: dict, full: bool) -> dict[str, np.ndarray]:
    missing = [k for k in SHAPE_KEYS if k not in data]
    if missing:
        if {"frobenius", "tracking_error"} <= set(data):
            raise ResultFileError(
                file, "file", "", text="a CSC result (jaxstiff csc); this needs a shape result (jaxstiff shape)"
            )
        raise ResultFileError(file, "file", "", text=f"not a jaxstiff result file, missing keys: {', '.join(missing)}")
    q = data["q"]
    if q.ndim != 3 or min(q.shape) < 1:
        raise ResultFileError(file, "q", "shape (B, P, n) with B, P, n >= 1", f"<shape {q.shape}>")
    B, P, n = q.shape
    out: dict[str, np.ndarray] = {}
    names = data["joint_names"]
    if names.dtype.kind != "U":
        raise ResultFileError(file, "joint_names", "joint names (text)", f"<dtype {names.dtype}>")
    _shape(file, "joint_names", names, (n,), "n, from q")
    out["joint_names"] = names
    how = "B, P from q; n the joint count"
    for keys, tail in ((_SHAPE_BPN, (n,)), (_SHAPE_BP3, (3,)), (_SHAPE_BP_FLOAT, ()), (_SHAPE_BP_INT, ())):
        for k in keys:
            _shape(file, k, data[k], (B, P, *tail), how)
            out[k] = _int_array(file, k, data[k]) if k in _SHAPE_BP_INT else _float_array(file, k, data[k])
    for k in _SHAPE_BN:
        _shape(file, k, data[k], (B, n), "B, n from q")
        out[k] = _float_array(file, k, data[k])
    rmeta = _check_robot_meta(file, meta, n, required=full)
    _check_shape_meta(file, meta, B, n, full)
    _check_shape_values(file, out, meta, rmeta)
    if full:
        _check_shape_consistency(file, out, meta)
    return out


def _check_shape_values(file: str, out: dict[str, np.ndarray], meta: dict, rmeta: dict | None) -> None:
    """The values of a shape file's arrays that need no robot (module docstring)."""
    B, names = out["q"].shape[0], out["joint_names"]
    status = out["status"]
    bad = ~np.isin(status, np.arange(6))
    if bad.any():
        raise ResultFileError(file, "status", "codes 0-5 (jaxstiff.results._status)", f"{status[bad][0]} {_where(bad)}")
    for k in ("time_s", "nit", "nfev"):  # seconds and counts: a negative one is not what a solver wrote
        neg = out[k] < 0
        if neg.any():
            raise ResultFileError(file, k, "values >= 0", f"{out[k][neg][0]} {_where(neg)}")
    usable = np.isin(status, np.asarray(USABLE))
    _check_finite(file, "q", out["q"], usable, " at usable waypoints (status 0-2)")
    _check_finite(file, "q0", out["q0"])
    _check_finite(file, "position", out["position"], usable, " at usable waypoints (status 0-2)")
    _check_finite(file, "target", out["target"])
    _check_finite(file, "direction", out["direction"])
    settings: dict = meta["settings"] if isinstance(meta.get("settings"), dict) else {}
    rigid_ok = settings.get("locked_joints", "rigid") != "spring"
    locked = _locked_mask(rmeta, [str(x) for x in names])
    for k in ("kj", "kj_scaled"):
        _check_stiffness(file, k, out[k], usable, locked, rigid_ok)
    _check_stiffness(file, "kj0", out["kj0"], np.ones(B, bool), locked, rigid_ok)


def _check_shape_consistency(file: str, out: dict[str, np.ndarray], meta: dict) -> None:
    """What the arrays of a shape file say about each other (full mode; hand-made results that
    :meth:`ShapeResult.load` reads need not agree): unit directions, ``kj_scaled = cms * kj``,
    ``pos_error = |position - target|``, kj inside the recorded range, at usable waypoints."""
    usable = np.isin(out["status"], np.asarray(USABLE))
    norm = np.linalg.norm(out["direction"], axis=-1)
    off = ~(np.abs(norm - 1.0) <= 1e-6)
    if off.any():
        raise ResultFileError(
            file, "direction", "unit vectors", f"a vector of length {norm[off][0]:.6g} ({_where(off)})"
        )
    cms = out["cms"][usable]
    if np.any(~np.isfinite(cms) | (cms <= 0)):
        raise ResultFileError(
            file, "cms", "finite factors > 0 at usable waypoints", cms[~np.isfinite(cms) | (cms <= 0)][0]
        )
    want = out["cms"][..., None] * out["kj"]
    got = out["kj_scaled"]
    with np.errstate(invalid="ignore"):
        off = ~((want == got) | (np.abs(got - want) <= 1e-9 * np.abs(want)))
    off &= usable[..., None]
    if off.any():
        raise ResultFileError(
            file,
            "kj_scaled",
            "cms * kj (what a controller is commanded with)",
            f"{got[off][0]} where cms * kj = {want[off][0]} ({_where(off)})",
        )
    err = np.linalg.norm(out["position"] - out["target"], axis=-1)
    off = usable & ~(np.abs(err - out["pos_error"]) <= POSITION_TOL)
    if off.any():
        raise ResultFileError(
            file,
            "pos_error",
            "|position - target|",
            f"{out['pos_error'][off][0]} where |position - target| = {err[off][0]} ({_where(off)})",
        )
    lim = meta.get("limits")
    if isinstance(lim, dict) and lim.get("kmin") is not None and lim.get("kmax") is not None:
        kmin, kmax = float(lim["kmin"]), float(lim["kmax"])
        kj = out["kj"]
        spring = usable[..., None] & ~np.isinf(kj)
        off = spring & ((kj < kmin * (1 - 1e-9)) | (kj > kmax * (1 + 1e-9)))
        if off.any():
            raise ResultFileError(
                file,
                "kj",
                f"stiffness in the recorded range [{kmin:g}, {kmax:g}] at usable waypoints",
                f"{kj[off][0]} ({_where(off)})",
            )


# ---------------------------------------------------------------------- csc schema
def _csc_schema(file: str, data: dict[str, np.ndarray], meta: dict, full: bool) -> dict[str, np.ndarray]:
    missing = [k for k in CSC_KEYS if k not in data]
    if missing:
        what = "a shape result (jaxstiff shape)" if "criterion" in data else "not a CSC result file"
        raise ResultFileError(file, "file", "", text=f"{what}; missing CSC fields: {', '.join(missing)}")
    q = data["q"]
    if q.ndim not in ((2, 3) if full else range(2, 33)) or min(q.shape) < 1:
        raise ResultFileError(file, "q", "shape (B, T, n) or (T, n) with B, T, n >= 1", f"<shape {q.shape}>")
    batch = q.shape[:-2]
    T, n = q.shape[-2:]
    task = _meta_field(
        file, meta, "task", lambda v: isinstance(v, str) and v in TASKS, f"one of {', '.join(TASKS)}", required=full
    )
    _meta_field(file, meta, "settings", lambda v: isinstance(v, dict), "a record")
    _meta_field(file, meta, "settings.task", lambda v: v == task or task is None, f"the task of the file ({task!r})")
    _meta_field(file, meta, "settings.locked_joints", lambda v: v in ("rigid", "spring"), "'rigid' or 'spring'")
    _meta_field(file, meta, "paths", lambda v: isinstance(v, list) and all(_text(x) for x in v), "a list of path names")
    if task is None:  # a file saved without meta (CSCResult.save(meta=None)): the task from K_C's size
        m = data["K_C"].shape[-1] if data["K_C"].ndim >= 2 else 0
        task = {v: k for k, v in TASKS.items()}.get(m, "xyz")
    m, d = TASKS[task], (2 if task == "xy" else 3)
    want = {"q": (n,), "kj": (n,), "K_C": (m, m), "position": (3,), "target": (d,)}
    out: dict[str, np.ndarray] = {}
    for k in CSC_KEYS:
        if k in ("u_start", "frobenius_start"):
            shp, how = batch, "the batch axes of q"
        else:
            shp, how = (*batch, T, *want.get(k, ())), f"batch, T from q{', ' + str(want[k]) if k in want else ''}"
            if k == "K_C":
                how = f"batch, T from q; {m} x {m} for task {task}"
        _shape(file, k, data[k], shp, how)
        out[k] = _int_array(file, k, data[k]) if k == "status" else _float_array(file, k, data[k])
    if "joint_names" in data:
        names = data["joint_names"]
        if names.dtype.kind != "U":
            raise ResultFileError(file, "joint_names", "joint names (text)", f"<dtype {names.dtype}>")
        _shape(file, "joint_names", names, (n,), "n, from q")
        out["joint_names"] = names
    if "q0" in data:
        if data["q0"].shape not in ((n,), (*batch, n)):
            raise ResultFileError(file, "q0", f"shape ({n},) or {(*batch, n)}", f"<shape {data['q0'].shape}>")
        out["q0"] = _float_array(file, "q0", data["q0"])
        _check_finite(file, "q0", out["q0"])
    if "K_xd" in data:
        kxd = data["K_xd"]
        if kxd.shape not in ((m, m), (1, m, m), (*batch, m, m)):
            raise ResultFileError(
                file, "K_xd", f"shape ({m}, {m}) for task {task} (or one per rollout)", f"<shape {kxd.shape}>"
            )
        out["K_xd"] = _float_array(file, "K_xd", kxd)
        _check_finite(file, "K_xd", out["K_xd"])
    for k in ("q", "position", "target", "K_C"):
        _check_finite(file, k, out[k])
    bad = (out["status"] < 0) | (out["status"] > 15)
    if bad.any():
        raise ResultFileError(
            file, "status", "bit masks 0-15 (jaxstiff.csc.CSCStatus)", f"{out['status'][bad][0]} {_where(bad)}"
        )
    rmeta = _check_robot_meta(file, meta, n, required=full)
    names = [
        str(x) for x in (out["joint_names"] if "joint_names" in out else (rmeta or {}).get("joint_names") or [""] * n)
    ]
    settings: dict = meta["settings"] if isinstance(meta.get("settings"), dict) else {}
    locked = _locked_mask(rmeta, names)
    _check_stiffness(
        file,
        "kj",
        out["kj"],
        np.ones(out["kj"].shape[:-1], bool),
        locked,
        settings.get("locked_joints", "rigid") != "spring",
    )
    return out


def _read(file: str, kind: str | None, full: bool) -> tuple[str, dict[str, np.ndarray], dict[str, Any], bool]:
    """:func:`read_arrays`, and whether the file's q is float32 (float32 tolerances for it)."""
    data = _load_npz(file)
    found = file_kind(data)
    if kind == "csc" and found != "csc":
        what = "a shape result (jaxstiff shape)" if "criterion" in data else "not a CSC result file"
        missing = [k for k in CSC_KEYS if k not in data]
        raise ResultFileError(file, "file", "", text=f"{what}; missing CSC fields: {', '.join(missing)}")
    kind = kind or found
    keys = SHAPE_KEYS if kind == "shape" else CSC_KEYS
    # a file without meta and without the arrays: the schema names the missing arrays first
    meta = {} if "meta" not in data and not all(k in data for k in keys) else _meta(file, data)
    static = meta.get("static")
    if (
        kind == "csc"
        and "task" not in meta
        and isinstance(static, dict)
        and meta.get("format") == "jaxstiff.sweep.csc/1"
    ):
        meta["task"] = static.get("task")  # (a csc sweep's array file written before it recorded its task)
    arrays = _shape_schema(file, data, meta, full) if kind == "shape" else _csc_schema(file, data, meta, full)
    return kind, arrays, meta, data["q"].dtype == np.float32


def read_arrays(
    file: str | os.PathLike, kind: str | None = None, *, full: bool = False
) -> tuple[str, dict[str, np.ndarray], dict[str, Any]]:
    """The schema level (module docstring): ``(kind, arrays, meta)`` of a result file.

    Args:
        kind: ``"shape"`` or ``"csc"`` to require that kind (the other is refused by name);
            None: whichever the file is.
        full: also require the meta fields :func:`read_result` needs (robot, task).

    Raises:
        FileNotFoundError: no such file.
        ResultFileError: anything else.
    """
    return _read(os.fspath(file), kind, full)[:3]


# ---------------------------------------------------------------------- the robot
def chain_from_meta(meta: dict[str, Any], urdf: str | os.PathLike | None = None, file: str = "") -> Chain:
    """The result's chain rebuilt from ``meta["robot"]`` (URDF path, links, locked joints, tcp) as a
    numpy :class:`~jaxstiff.model._chain.Chain` (no JAX).

    The URDF is opened only if it is a regular file of bounded size
    (:func:`jaxstiff.results._numpy_check.result_urdf`); its sha256 is checked against the recorded
    one; a ``urdf`` given instead (a moved file) must be the result's robot
    (:func:`jaxstiff.results._numpy_check.check_same_robot`).
    """
    from jaxstiff.model._chain import Chain
    from jaxstiff.model._urdf import parse_urdf_chain
    from jaxstiff.results._numpy_check import check_same_robot, result_urdf

    try:
        path, rmeta = result_urdf(meta, urdf)
        if urdf is None and rmeta.get("sha256") and file_sha256(path) != rmeta["sha256"]:
            raise ValueError(
                f"{path}: sha256 differs from the one recorded in the result ({rmeta['sha256'][:12]}...): the URDF was "
                "edited after the run, so it may not be the result's robot. Restore the file the result was computed "
                "with (or give it with --urdf FILE; urdf= in Python); --urdf with this edited file reads it, with a "
                "warning, where its chain still matches the result's joints and limits"
            )
        tcp = np.asarray(rmeta["tcp"]) if rmeta.get("tcp") is not None else None
        locked = rmeta.get("locked") or None
        try:
            fields = parse_urdf_chain(path, rmeta.get("base_link") or None, rmeta.get("tip_link") or None, locked, tcp)
        except ValueError as exc:
            raise ValueError(f"the recorded chain cannot be built: {exc}") from None
    except FileNotFoundError as exc:
        raise FileNotFoundError(f"{exc}; the result's URDF moved? give it with --urdf FILE") from None
    except ResultFileError:
        raise
    except ValueError as exc:
        if file:
            raise ResultFileError(file, "meta robot", "", text=str(exc)) from None
        raise
    chain = Chain(**fields)
    if urdf is not None:
        check_same_robot(rmeta, path, chain)
    return chain


def _same(a: Any, b: np.ndarray) -> bool:
    try:
        return bool(np.allclose(np.asarray(a, dtype=float), b, rtol=1e-12, atol=1e-12, equal_nan=False)) or bool(
            np.array_equal(np.asarray(a, dtype=float), b)
        )
    except (TypeError, ValueError):
        return False


def _check_robot(file: str, meta: dict, chain: Chain, names: list[str] | None, q: np.ndarray, q32: bool) -> None:
    rmeta = meta["robot"]
    if rmeta.get("name") not in (None, chain.name):
        raise ResultFileError(
            file, "meta robot.name", f"{chain.name!r} (the robot of the URDF {chain.source})", rmeta["name"]
        )
    want = list(chain.joint_names)
    for where, got in (("joint_names", names), ("meta robot.joint_names", rmeta.get("joint_names"))):
        if got is not None and list(got) != want:
            raise ResultFileError(file, where, f"the robot's joints in chain order {want}", list(got))
    for key, have in (("lower", chain.lower), ("upper", chain.upper), ("tip_transform", chain.tip_matrix)):
        if rmeta.get(key) is not None and not _same(rmeta[key], have):
            what = (
                "the TCP's transform (the URDF's tip and the recorded tcp)"
                if key == "tip_transform"
                else f"the URDF's {key} limits"
            )
            raise ResultFileError(file, f"meta robot.{key}", f"{what} {np.round(have, 6).tolist()}", rmeta[key])
    tol = 1e-6 if q32 else 1e-9
    lmask = ~chain.free
    if lmask.any():
        vals = chain.locked_values[lmask]
        moved = np.isfinite(q[..., lmask]) & (np.abs(q[..., lmask] - vals) > tol)
        if moved.any():
            j = int(np.argwhere(moved)[0][-1])
            name = [nm for nm, f in zip(chain.joint_names, chain.free, strict=True) if not f][j]
            raise ResultFileError(
                file,
                "q",
                f"locked joint {name} at its recorded value {vals[j]}",
                f"{q[..., lmask][moved][0]} ({_where(moved)})",
            )


def _check_limits(file: str, chain: Chain, q: np.ndarray, rows: np.ndarray, q32: bool) -> None:
    tol = 1e-6 if q32 else 1e-9
    sel = q[rows]
    off = (sel < chain.lower - tol) | (sel > chain.upper + tol)
    if off.any():
        raise ResultFileError(
            file, "q", "joint values inside the robot's limits at usable waypoints", f"{sel[off][0]} ({_where(off)})"
        )


RATE_TOL = 1e-9  #: rad or Nm/rad: a step beyond the recorded rate limit by more than this is refused (float64 files)


def _check_rates(
    file: str, chain: Chain, arr: dict[str, np.ndarray], meta: dict, usable: np.ndarray, q32: bool
) -> None:
    """Each usable waypoint's step in q and kj from its reference state (the last usable waypoint
    before it, or q0 / kj0 at the start) within the recorded rate limits ``limits.dq`` / ``dk``
    (per waypoint; per-metre limits are recorded converted), at the first waypoint only when the
    file records ``first_rate_limit``; a rigid locked joint (kj = +inf) has no stiffness step."""
    from jaxstiff.results._npz import path_parameters

    B, _, n = arr["q"].shape
    prm = path_parameters(meta, B, n)
    first = bool(meta["limits"]["first_rate_limit"])
    for b in range(B):
        at = np.flatnonzero(usable[b])  # the usable waypoints, in order
        if at.size == 0:
            continue
        for key, start, lim, unit in (("q", "q0", prm["dq"][b], "rad"), ("kj", "kj0", prm["dk"][b], "Nm/rad")):
            x = arr[key][b, at]
            ref = np.concatenate([arr[start][b][None], x[:-1]])  # each one's reference state
            with np.errstate(invalid="ignore"):
                step = np.where(np.isinf(x) & np.isinf(ref), 0.0, np.abs(x - ref))
            size = np.abs(np.where(np.isfinite(ref), ref, 0.0))
            tol = 1e-6 * (1.0 + size) if q32 else RATE_TOL + 1e-12 * size
            over = ~(step <= lim + tol)
            if not first:
                over[0] = False
            if over.any():
                k, j = (int(i) for i in np.argwhere(over)[0])
                was = f"waypoint {at[k - 1]}" if k else f"the start state ({start})"
                raise ResultFileError(
                    file,
                    key,
                    "",
                    text=f"path {b}, waypoint {at[k]}, joint {chain.joint_names[j]}: {key} moves {step[k, j]:.6g} "
                    f"{unit} from {was}, more than the recorded rate limit d{key[0]} = {lim[j]:.6g} {unit} "
                    f"(meta limits.d{key[0]}, tolerance {tol[k, j]:.2g})",
                )


def _check_positions(file: str, chain: Chain, q: np.ndarray, position: np.ndarray, rows: np.ndarray) -> None:
    from jaxstiff.model._host import tcp_position

    if not rows.any():
        return
    dist = np.linalg.norm(tcp_position(chain, q[rows]) - position[rows], axis=-1)
    if not np.all(dist <= POSITION_TOL):
        worst = int(np.argmax(np.where(np.isnan(dist), np.inf, dist)))
        idx = tuple(int(i) for i in np.argwhere(rows)[worst])
        raise ResultFileError(
            file,
            "position",
            f"the TCP positions of the stored q (numpy FK of the recorded robot, TCP and tip; within {POSITION_TOL:g} m)",
            "",
            text=f"the stored TCP position is {dist[worst]:.3g} m from the FK of the stored q at index {idx} "
            f"(tolerance {POSITION_TOL:g} m): the file's robot, tcp or q is not what it claims",
        )


def _compliance(chain: Chain, q: np.ndarray, kj: np.ndarray, task: str) -> np.ndarray:
    from jaxstiff.model._host import position_jacobian

    comp = np.where(np.isinf(kj), 0.0, 1.0 / np.where(np.isinf(kj), 1.0, kj))
    J = position_jacobian(chain, q)[..., : TASKS[task], :]
    return np.einsum("...in,...n,...jn->...ij", J, comp, J)


def _well_conditioned(C: np.ndarray, length_scale: float) -> np.ndarray:
    """Where the compliance ``C`` is well enough conditioned to compare, judged in the arm's own
    units: with task "full" its translational rows are m/N and its rotational ones rad/(N m), so
    their ratio scales with the arm's size squared; the translational rows and columns are divided
    by ``length_scale`` first (which leaves K_T's axis ratio as it is). A millimetre-sized arm's
    well-posed compliance was otherwise taken for singular."""
    if C.shape[-1] == 6:
        d = np.r_[np.full(3, 1.0 / length_scale), np.ones(3)]
        C = C * d[:, None] * d[None, :]
    with np.errstate(all="ignore"):
        c = np.linalg.cond(C) if C.size else np.zeros(C.shape[:-2])
    return np.isfinite(c) & (c < COND_MAX)


def _check_shape_task(file: str, chain: Chain, arr: dict[str, np.ndarray], task: str, rows: np.ndarray) -> None:
    """The stored axis ratio against the one of (q, kj) with the recorded task, at usable waypoints."""
    if not rows.any():
        return
    C = _compliance(chain, arr["q"][rows], arr["kj"][rows], task)
    ok = _well_conditioned(C, chain.length_scale)
    stored = arr["ratio"][rows]
    if (~ok & np.isfinite(stored)).any():
        i = int(np.argwhere(~ok & np.isfinite(stored))[0][0])
        idx = tuple(int(x) for x in np.argwhere(rows)[i])
        raise ResultFileError(
            file,
            "meta task",
            "",
            text=f"task {task!r} leaves the compliance singular at index {idx}, where the file stores an axis ratio {stored[i]:.6g}: not the task the file was solved for",
        )
    K = np.linalg.inv(C[ok])
    if task == "full":
        K = K[..., :3, :3]
    w = np.linalg.eigvalsh(0.5 * (K + np.swapaxes(K, -1, -2)))
    rho = w[..., -1] / w[..., -2]
    off = ~(np.abs(rho - stored[ok]) <= RATIO_REL_TOL * np.abs(rho))
    if off.any():
        i = int(np.argwhere(off)[0][0])
        idx = tuple(int(x) for x in np.argwhere(rows)[np.flatnonzero(ok)[i]])
        raise ResultFileError(
            file,
            "meta task",
            "",
            text=f"the stored axis ratio {stored[ok][i]:.6g} at index {idx} is not the one of the stored q and kj "
            f"with task {task!r} ({rho[i]:.6g}): another task, or tampered q / kj / ratio",
        )


def _check_csc_task(file: str, chain: Chain, arr: dict[str, np.ndarray], task: str) -> None:
    """The stored K_C against the inverse compliance of (q, kj) with the recorded task."""
    C = _compliance(chain, arr["q"], arr["kj"], task)
    ok = _well_conditioned(C, chain.length_scale)
    K = np.linalg.inv(np.where(ok[..., None, None], C, np.eye(C.shape[-1])))
    stored = arr["K_C"]
    scale = np.linalg.norm(K, axis=(-2, -1))
    off = ok & ~(np.linalg.norm(stored - K, axis=(-2, -1)) <= K_REL_TOL * scale)
    if off.any():
        raise ResultFileError(
            file,
            "K_C",
            "",
            text=f"the stored K_C is not the stiffness of the stored q and kj with task {task!r} ({_where(off)}): "
            "another task, or tampered q / kj / K_C",
        )


def read_result(file: str | os.PathLike, urdf: str | os.PathLike | None = None, kind: str | None = None) -> ResultFile:
    """Read and check a shape or csc result file (module docstring: what is checked).

    Args:
        urdf: the robot's URDF when the recorded path moved (it must be the result's robot).
        kind: ``"shape"`` or ``"csc"`` to require that kind; None: either.

    Raises:
        FileNotFoundError: no such file, or the recorded URDF is missing.
        ResultFileError: the file is not what it claims (one line naming the field).
        ValueError: ``urdf`` is not the result's robot.
    """
    file = os.fspath(file)
    kind, arr, meta, q32 = _read(file, kind, True)
    try:
        return _checked(file, kind, arr, meta, q32, urdf)
    except ValueError as exc:  # (ResultFileError too) an edited URDF given: say that first, the file is likely fine
        note = urdf_differs(meta, urdf)
        if note is None:
            raise
        if isinstance(exc, ResultFileError):
            err = ResultFileError(file, "file", "", text=f"{note}; {exc.field}: {exc.text}")
            err.field = exc.field  # (the check that failed, as before)
            raise err from None
        raise ValueError(f"{note}; {exc}") from None


def urdf_differs(meta: Mapping[str, Any], urdf: str | os.PathLike | None) -> str | None:
    """A sentence saying that ``urdf`` is not the file a result (its ``meta``) was computed with:
    its sha256 differs from ``meta["robot"]["sha256"]``; None without ``urdf``, for the same file,
    without a recorded sha256, or for a URDF that cannot be read (the reader then says why)."""
    if urdf is None:
        return None
    rmeta = meta.get("robot")
    recorded = rmeta.get("sha256") if isinstance(rmeta, Mapping) else None
    try:
        given = file_sha256(urdf)
    except (OSError, ValueError):
        return None
    if not isinstance(recorded, str) or not recorded or given == recorded:
        return None
    return (
        f"the URDF given ({os.fspath(urdf)}) differs from the one the result was computed with "
        f"(sha256 {given[:12]}... here, {recorded[:12]}... recorded)"
    )


def _checked(file: str, kind: str, arr: dict, meta: dict, q32: bool, urdf: str | os.PathLike | None) -> ResultFile:
    """:func:`read_result`'s checks of a file read by :func:`_read`."""
    chain = chain_from_meta(meta, urdf, file=file)
    task = str(meta["task"])
    q = arr["q"] if arr["q"].ndim == 3 else arr["q"][None]
    n = q.shape[-1]
    if n != chain.n:
        raise ResultFileError(file, "q", f"{chain.n} joint columns (the robot {chain.name!r})", f"<{n} columns>")
    names = [str(x) for x in arr["joint_names"]] if "joint_names" in arr else None
    _check_robot(file, meta, chain, names, q, q32)
    if kind == "shape":
        usable = np.isin(arr["status"], np.asarray(USABLE))
        _check_robot(file, meta, chain, None, arr["q0"], q32)
        _check_limits(file, chain, q, usable, q32)
        _check_positions(file, chain, q, arr["position"], usable)
        _check_shape_task(file, chain, arr, task, usable)
        _check_rates(file, chain, arr, meta, usable, q32)
    else:
        if arr["q"].ndim == 2:  # a single rollout written without the batch axis
            arr = {k: (v if k in ("joint_names", "q0", "K_xd") else v[None]) for k, v in arr.items()}
        _check_positions(file, chain, arr["q"], arr["position"], np.ones(arr["q"].shape[:-1], bool))
        _check_csc_task(file, chain, arr, task)
    return ResultFile(file, kind, arr, meta, chain)
