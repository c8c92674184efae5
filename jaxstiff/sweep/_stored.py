"""The checks of a sweep store's files: the one place that the store's scan (``--resume``) and the
readers of a sweep row (``jaxstiff view / export / plot DIR --row K``) go through, so they accept
and refuse the same folders.

* ``plan.json`` (:func:`load_plan`): a JSON record with the format, a plan hash, the kind, the
  chunks (id, first and last row, count) and the config's tolerances.
* ``chunks/chunk-N.json``, the rows of a finished chunk (:func:`check_rows_record`): the format,
  this plan's hash, the chunk's id and group, every row with every column of the table, each of
  its type (the axes' types and choices, integer ids, finite or NaN metrics, shares in [0, 1]), the
  row ids of the chunk in order and, where the plan is at hand (resume), each row's settings equal
  to the plan's.
* ``arrays/chunk-N-K.npz``, the per-waypoint arrays the rows point to (:func:`check_rows_arrays`):
  read by the one result-file reader at its full level (:func:`jaxstiff.results._reader.read_result`:
  schema, robot and its hash, FK of q, task, rate limits), its sweep record (plan hash, chunk, row
  ids) naming the rows that point to it, the rows' settings equal to the file's, and every metric of
  a row recomputed from the file (:mod:`jaxstiff.sweep._metrics`) and equal to the stored one.
* ``manifest.json`` (:func:`manifest_problem`): a log (wall times, runs), rebuilt from the rows
  files when it is not what the store writes.

Every refusal is a :class:`~jaxstiff.results._reader.ResultFileError` (a ValueError: the commands'
exit 2) with one line ``FILE: FIELD: expected ..., found ...``. Numpy only, no JAX.
"""

from __future__ import annotations

import math
import os
import re
from typing import Any

from jaxstiff.results._reader import ResultFile, ResultFileError, read_result
from jaxstiff.runtime._io import check_regular_file, meta_loads
from jaxstiff.sweep._axes import AXES
from jaxstiff.sweep._metrics import METRICS, csc_row_metrics, shape_row_metrics

__all__ = [
    "FORMAT",
    "RECORD_MAX_BYTES",
    "load_record",
    "load_plan",
    "check_rows_record",
    "check_rows_arrays",
    "manifest_problem",
    "read_sweep_row",
    "chunk_file",
]

FORMAT = "jaxstiff.sweep/1"
RECORD_MAX_BYTES = 256 * 2**20  #: a plan, manifest or rows file larger than this is not one the store wrote
METRIC_REL_TOL = 1e-12  #: a stored metric against the one recomputed from its array file
_HEX64 = re.compile(r"[0-9a-f]{64}")
_BASE_INT = ("row_id", "chunk", "group", "path_index", "P")


def chunk_file(folder: str, chunk_id: int) -> str:
    """``folder/chunks/chunk-000012.json``: the rows file of a chunk."""
    return os.path.join(folder, "chunks", f"chunk-{chunk_id:06d}.json")


def _int(x: Any) -> bool:
    return isinstance(x, int) and not isinstance(x, bool)


def _number(x: Any) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool)


def _same(a: Any, b: Any) -> bool:
    """Equal values of the same JSON type (1 is not True, "5" is not 5; an int equals its float)."""
    if isinstance(a, bool) or isinstance(b, bool):
        return type(a) is type(b) and a == b
    if _number(a) and _number(b):
        return a == b or (math.isnan(a) and math.isnan(b))
    if isinstance(a, list) and isinstance(b, list):
        return len(a) == len(b) and all(_same(x, y) for x, y in zip(a, b, strict=True))
    return type(a) is type(b) and a == b


def _close(a: float, b: float) -> bool:
    if not (math.isfinite(a) and math.isfinite(b)):
        return a == b or (math.isnan(a) and math.isnan(b))
    return a == b or abs(a - b) <= METRIC_REL_TOL * max(abs(a), abs(b))


# ---------------------------------------------------------------------- JSON records
def load_record(file: str, what: str) -> dict[str, Any]:
    """The JSON record in ``file`` (a regular file of bounded size), or a one-line refusal."""
    try:
        check_regular_file(file, what)
    except ValueError as exc:
        raise ResultFileError(file, "file", "", text=str(exc).split(": ", 1)[-1]) from None
    if os.path.getsize(file) > RECORD_MAX_BYTES:
        raise ResultFileError(file, "file", "", text=f"{os.path.getsize(file)} bytes: larger than any {what}")
    try:
        with open(file, encoding="utf-8") as fh:
            rec = meta_loads(fh.read())
    except (UnicodeDecodeError, ValueError, RecursionError) as exc:  # (JSONDecodeError is a ValueError)
        raise ResultFileError(file, "file", "", text=f"not a readable {what}: {exc}") from None
    if not isinstance(rec, dict):
        raise ResultFileError(
            file, "file", "", text=f"not a readable {what}: a JSON {type(rec).__name__}, not a record"
        )
    return rec


def _field(file: str, rec: dict, key: str, ok: Any, expected: str, where: str = "") -> Any:
    if key not in rec:
        raise ResultFileError(file, f"{where}{key}", expected, "nothing (the field is missing)")
    if not ok(rec[key]):
        raise ResultFileError(file, f"{where}{key}", expected, rec[key])
    return rec[key]


def load_plan(folder: str) -> dict[str, Any]:
    """``folder/plan.json`` checked: format, plan hash, kind, chunks and the config's tolerances."""
    file = os.path.join(folder, "plan.json")
    if not os.path.isfile(file) and os.path.isdir(os.path.join(folder, "chunks")):
        raise FileNotFoundError(f"{folder}: no plan.json; not a usable jaxstiff sweep folder")
    if not os.path.exists(file):
        raise FileNotFoundError(f"{folder}: no plan.json or chunks/chunk-*.json; not a jaxstiff sweep folder")
    rec = load_record(file, "sweep plan (plan.json)")
    _field(file, rec, "format", lambda v: v == FORMAT, repr(FORMAT))
    _field(
        file, rec, "plan_hash", lambda v: isinstance(v, str) and bool(_HEX64.fullmatch(v)), "a sha256 (64 hex digits)"
    )
    _field(file, rec, "kind", lambda v: isinstance(v, str) and v in AXES, f"one of {', '.join(AXES)}")

    def chunk_ok(c: Any) -> bool:
        return (
            isinstance(c, dict)
            and _int(c.get("id"))
            and _int(c.get("n"))
            and c["n"] >= 1
            and isinstance(c.get("rows"), list)
            and len(c["rows"]) == 2
            and all(_int(x) and x >= 0 for x in c["rows"])
            and c["rows"][1] - c["rows"][0] + 1 >= c["n"]
        )

    chunks = _field(
        file,
        rec,
        "chunks",
        lambda v: isinstance(v, list) and all(chunk_ok(c) for c in v) and [c["id"] for c in v] == list(range(len(v))),
        "a list of chunk records {id, rows: [first, last], n}, ids 0, 1, ...",
    )
    cfg = _field(file, rec, "config", lambda v: isinstance(v, dict) and isinstance(v.get("sweep"), dict), "a record")
    for key in ("alpha_tol_deg", "ratio_rel_tol"):
        _field(
            file,
            cfg["sweep"],
            key,
            lambda v: _number(v) and math.isfinite(v) and v > 0,
            "a positive number",
            "config.sweep.",
        )
    rec["n_rows_in_chunks"] = sum(c["n"] for c in chunks)
    return rec


# ---------------------------------------------------------------------- the rows file
def _check_axis(file: str, where: str, kind: str, name: str, v: Any) -> None:
    spec = AXES[kind][name]
    ok = {
        "float": lambda x: _number(x) and not math.isnan(x),  # (kmax may be inf)
        "int": _int,
        "bool": lambda x: isinstance(x, bool),
    }.get(spec.type, lambda x: isinstance(x, str))
    if not ok(v):
        raise ResultFileError(file, where + name, f"a {spec.type} (axis {name})", v)
    choices = spec.choices  # (a registry's function is not called: the plan's values are compared on resume)
    if isinstance(choices, (tuple, list)) and choices and v not in choices:
        raise ResultFileError(file, where + name, f"one of {', '.join(map(str, choices))}", v)


def _check_metric(file: str, where: str, name: str, v: Any) -> None:
    if not _number(v):
        raise ResultFileError(file, where + name, "a number (NaN where the row has no value)", v)
    if name.startswith("share_") and not 0 <= v <= 1:
        raise ResultFileError(file, where + name, "a share in [0, 1]", v)
    if (name.endswith(("_error", "_alpha_deg", "_nfev", "_cms")) or name.startswith("u_") or "frobenius_" in name) and (
        v < 0 and not name.endswith("_reduction")
    ):
        raise ResultFileError(file, where + name, "a number >= 0", v)


def _check_row(file: str, i: int, row: Any, kind: str, rec: dict, expected: dict | None) -> dict:
    where = f"rows[{i}]."
    if not isinstance(row, dict):
        raise ResultFileError(file, f"rows[{i}]", "a record (one table row)", row)
    for key in _BASE_INT:
        _field(file, row, key, lambda v, key=key: _int(v) and v >= (1 if key == "P" else 0), "an integer >= 0", where)
    for key in ("chunk", "group"):
        if row[key] != rec[key]:
            raise ResultFileError(file, where + key, f"{rec[key]} (the file's {key})", row[key])
    _field(file, row, "path", lambda v: isinstance(v, str), "the path's name (text)", where)
    for name in AXES[kind]:
        _field(file, row, name, lambda v: True, "", where)
        _check_axis(file, where, kind, name, row[name])
    _field(
        file, row, "q0_ik_error_m", lambda v: _number(v) and (math.isnan(v) or v >= 0), "a number >= 0 or NaN", where
    )
    for name in METRICS[kind]:
        _field(file, row, name, lambda v: True, "", where)
        _check_metric(file, where, name, row[name])
    pattern = rf"arrays/chunk-{rec['chunk']:06d}-\d+\.npz"
    rf = _field(
        file,
        row,
        "result_file",
        lambda v: isinstance(v, str) and (v == "" or re.fullmatch(pattern, v) is not None),
        f'"" or an array file of this chunk ({pattern})',
        where,
    )
    _field(
        file,
        row,
        "result_index",
        lambda v: _int(v) and (v == -1 if rf == "" else v >= 0),
        "-1 (no array file)" if rf == "" else "an index >= 0 into the array file",
        where,
    )
    if expected is not None:
        for key, want in expected.items():
            if not _same(row.get(key), want):
                raise ResultFileError(
                    file, where + key, f"{want!r} (the plan's value for row {expected['row_id']})", row.get(key)
                )
    return row


def check_rows_record(
    file: str,
    rec: dict[str, Any],
    kind: str,
    *,
    plan_hash: str,
    chunk_id: int | None = None,
    row_ids: list[int] | None = None,
    expected: dict[int, dict] | None = None,
) -> list[dict]:
    """The rows of a chunk's rows file, checked (module docstring); ``expected``: the plan's
    columns of each row (row id -> record), compared exactly."""
    _field(file, rec, "format", lambda v: v == FORMAT, repr(FORMAT))
    if rec.get("plan_hash") != plan_hash:
        raise ResultFileError(
            file, "plan_hash", f"{plan_hash[:16]}... (this sweep's plan)", rec.get("plan_hash"),
            text=f"belongs to another sweep (plan_hash {str(rec.get('plan_hash'))[:16]}..., this sweep's is "
            f"{plan_hash[:16]}...); delete it to recompute that chunk, or use a new --out",
        )  # fmt: skip
    _field(
        file,
        rec,
        "chunk",
        lambda v: _int(v) and (v == chunk_id if chunk_id is not None else v >= 0),
        f"{chunk_id} (the chunk of the file's name)" if chunk_id is not None else "a chunk id",
    )
    _field(file, rec, "group", lambda v: _int(v) and v >= 0, "a group id >= 0")
    _field(file, rec, "wall_s", lambda v: _number(v) and math.isfinite(v) and v >= 0, "seconds >= 0")
    _field(file, rec, "devices", lambda v: _int(v) and v >= 1, "an integer >= 1")
    for key in ("finished", "worker"):
        _field(file, rec, key, lambda v: isinstance(v, str), "text")
    rows = _field(file, rec, "rows", lambda v: isinstance(v, list) and len(v) >= 1, "a list of table rows")
    out = [
        _check_row(
            file,
            i,
            r,
            kind,
            rec,
            None
            if expected is None or not isinstance(r, dict) or not _int(r.get("row_id"))
            else expected.get(r["row_id"]),
        )
        for i, r in enumerate(rows)
    ]
    # (in the order they were computed: a shape chunk writes its rows out of reach first)
    ids = [r["row_id"] for r in out]
    if row_ids is not None and sorted(ids) != sorted(row_ids):
        raise ResultFileError(file, "rows", f"the rows of chunk {rec['chunk']}, each once: {_ids(row_ids)}", _ids(ids))
    if row_ids is None and len(ids) != len(set(ids)):
        raise ResultFileError(file, "rows", "row ids, each once", _ids(ids))
    return out


def _ids(ids: list[int]) -> str:
    return str(ids) if len(ids) <= 12 else f"[{ids[0]}, {ids[1]}, ..., {ids[-1]}] ({len(ids)} rows)"


# ---------------------------------------------------------------------- the rows' array files
def check_rows_arrays(
    folder: str,
    file: str,
    rows: list[dict],
    kind: str,
    *,
    plan_hash: str,
    alpha_tol_deg: float,
    ratio_rel_tol: float,
    urdf: str | None = None,
    only: str | None = None,
) -> dict[str, ResultFile]:
    """Read the array files the ``rows`` (of rows file ``file``) point to through the one
    result-file reader and check the rows against them (module docstring). ``only``: just that
    array file (a viewer reading one row). Returns the files read by their names."""
    by_file: dict[str, list[dict]] = {}
    for r in rows:
        if r["result_file"]:
            by_file.setdefault(r["result_file"], []).append(r)
        else:
            _check_unsolved(file, r, kind)
    read: dict[str, ResultFile] = {}
    for name, members in by_file.items():
        if only is not None and name != only:
            continue
        path = os.path.join(folder, name)
        if not os.path.exists(path):
            raise ResultFileError(
                path,
                "file",
                "",
                text=f"missing: the array file of rows {_ids([r['row_id'] for r in members])} of {file}",
            )
        rf = read_result(path, urdf, kind=kind)
        _check_sweep_record(file, path, rf, members, kind, plan_hash, rows[0]["chunk"])
        for r in members:
            _check_row_values(file, name, rf, r, kind, alpha_tol_deg, ratio_rel_tol)
        read[name] = rf
    return read


def _check_unsolved(file: str, r: dict, kind: str) -> None:
    """A row without an array file: a shape path out of reach, solved nowhere."""
    where = f"row {r['row_id']}: "
    if not math.isnan(r["q0_ik_error_m"]):
        raise ResultFileError(
            file, where + "q0_ik_error_m", "NaN (a path out of reach has no start posture)", r["q0_ik_error_m"]
        )
    if kind != "shape":
        raise ResultFileError(file, where + "result_file", "an array file (every csc row has one)", "")
    for name in METRICS["shape"]:
        v = r[name]
        want = (
            (0 < v <= 1)
            if name == "share_unreachable"
            else v == 0
            if name.startswith("share_") or name == "total_nfev"
            else math.isnan(v)
        )
        if not want:
            raise ResultFileError(
                file, where + name, "the value of a path out of reach (no usable waypoint, nothing solved)", v
            )


def _check_sweep_record(
    rows_file: str, path: str, rf: ResultFile, members: list[dict], kind: str, plan_hash: str, chunk: int
) -> None:
    meta = rf.meta
    rec = meta.get("sweep")
    B = rf.arrays["q"].shape[0]
    if not isinstance(rec, dict):
        raise ResultFileError(path, "meta sweep", "the record of the sweep chunk the file belongs to", rec)
    if rec.get("plan_hash") != plan_hash or rec.get("chunk") != chunk:
        raise ResultFileError(
            path,
            "meta sweep",
            f"plan {plan_hash[:16]}..., chunk {chunk} (the rows file pointing to it)",
            f"plan {str(rec.get('plan_hash'))[:16]}..., chunk {rec.get('chunk')!r}",
        )
    if kind == "shape":
        ids = rec.get("row_ids")
        field = "meta sweep.row_ids"
    else:
        mrows = meta.get("rows")
        ids = (
            [r.get("row_id") for r in mrows]
            if isinstance(mrows, list) and all(isinstance(r, dict) for r in mrows)
            else None
        )
        field = "meta rows"
    if not (isinstance(ids, list) and len(ids) == B and all(_int(x) for x in ids)):
        raise ResultFileError(path, field, f"the row ids of its {B} paths", ids)
    got = sorted((r["result_index"], r["row_id"]) for r in members)
    if got != [(i, x) for i, x in enumerate(ids)]:
        raise ResultFileError(
            rows_file,
            "rows",
            "",
            text=f"its rows pointing to {os.path.relpath(path, os.path.dirname(os.path.dirname(rows_file)))} "
            f"(as (result_index, row_id): {got}) are not the paths that file holds ({field}: row ids {ids})",
        )


def _check_row_values(  # noqa: PLR0913 - the row, its two files, and the sweep's two tolerances
    file: str, name: str, rf: ResultFile, r: dict, kind: str, alpha_tol_deg: float, ratio_rel_tol: float
) -> None:
    """The row's settings against the array file's record of them, its metrics against the array
    file's arrays (refused naming the rows file ``file`` and the array file ``name``)."""
    i, a, meta = r["result_index"], rf.arrays, rf.meta
    where = f"row {r['row_id']}"
    if kind == "shape":
        rec = meta["sweep"]
        ratio = meta.get("ratio")
        recorded = {
            "task": meta.get("task"),
            "criterion": meta.get("criterion"),
            "ratio": ratio[i] if isinstance(ratio, list) and len(ratio) > i else ratio,
            "path": _at(rec.get("paths"), i),
            "q0": _at(rec.get("q0"), i),
        }
        ik = _at(rec.get("q0_ik_error_m"), i)
        recorded["q0_ik_error_m"] = math.nan if ik is None else ik
        got = shape_row_metrics(
            a["status"][i],
            a["alpha_deg"][i],
            a["ratio"][i],
            a["criterion"][i],
            a["pos_error"][i],
            a["cms"][i],
            a["nfev"][i],
            criterion=r["criterion"],
            ratio_target=r["ratio"],
            alpha_tol_deg=alpha_tol_deg,
            ratio_rel_tol=ratio_rel_tol,
        )
    else:
        mrow = meta["rows"][i]
        recorded = {k: mrow.get(k, "<missing>") for k in (*AXES["csc"], "path")}
        if "q0_ik_error_m" in mrow:  # (files written before it was recorded do not hold it)
            ik = mrow["q0_ik_error_m"]
            recorded["q0_ik_error_m"] = math.nan if ik is None else ik
        got = csc_row_metrics(
            a["u"][i],
            a["frobenius"][i],
            a["tracking_error"][i],
            a["status"][i],
            float(a["u_start"][i]),
            float(a["frobenius_start"][i]),
        )
    for key, want in recorded.items():
        if not _same(r[key], want):
            raise ResultFileError(file, f"{where} {key}", f"{want!r} (recorded in {name}, index {i})", r[key])
    for metric, v in got.items():
        if not _close(float(r[metric]), v):
            raise ResultFileError(file, f"{where} {metric}", f"{v!r} (recomputed from {name}, index {i})", r[metric])


def _at(x: Any, i: int) -> Any:
    return x[i] if isinstance(x, list) and len(x) > i else "<missing>"


# ---------------------------------------------------------------------- the manifest
def manifest_problem(rec: Any, plan_hash: str) -> str | None:
    """Why a manifest record is not one the store wrote for this plan (None: it is)."""
    if not isinstance(rec, dict):
        return "not a JSON record"
    if rec.get("plan_hash") != plan_hash:
        return "another plan's hash"
    chunks, runs = rec.get("chunks"), rec.get("runs")
    if not isinstance(chunks, dict) or not isinstance(runs, list):
        return "chunks is not a record or runs is not a list"
    for k, v in chunks.items():
        if not (k.isdigit() and isinstance(v, dict)):
            return f"chunks[{k!r}] is not a chunk record"
        w = v.get("wall_s")
        if not (w is None or (_number(w) and math.isfinite(w) and w >= 0)):
            return f"chunks[{k!r}].wall_s is not seconds >= 0"
    if not all(isinstance(x, dict) for x in runs):
        return "a run is not a record"
    return None


# ---------------------------------------------------------------------- one row, for a viewer
def read_sweep_row(folder: str, row: int, urdf: str | None = None) -> tuple[ResultFile, int]:
    """Sweep row ``row`` of ``folder``: its array file as the one reader read it, and the index of
    the row's path in it, after the checks of the module docstring (plan, rows file, array file).

    Raises:
        FileNotFoundError: no sweep there.
        ResultFileError: a damaged or tampered file (one line naming it and the field).
        ValueError: no such row, its chunk not finished, or the row not solved (out of reach).
    """
    plan = load_plan(folder)
    n_rows = int(plan["n_rows_in_chunks"])
    cands = [c for c in plan["chunks"] if c["rows"][0] <= row <= c["rows"][1]]
    if not cands:
        raise ValueError(f"{folder}: no sweep row {row} (the folder has {n_rows} rows, row_id 0..{n_rows - 1})")
    kind, plan_hash = plan["kind"], plan["plan_hash"]
    for c in cands:
        file = chunk_file(folder, c["id"])
        if not os.path.exists(file):
            continue
        contiguous = c["rows"][1] - c["rows"][0] + 1 == c["n"]
        rows = check_rows_record(
            file,
            load_record(file, "sweep rows file"),
            kind,
            plan_hash=plan_hash,
            chunk_id=c["id"],
            row_ids=list(range(c["rows"][0], c["rows"][1] + 1)) if contiguous else None,
        )
        if not contiguous and len(rows) != c["n"]:
            raise ResultFileError(file, "rows", f"{c['n']} rows (plan.json's chunk {c['id']})", f"{len(rows)} rows")
        hit = [r for r in rows if r["row_id"] == row]
        if not hit:
            continue
        r = hit[0]
        if not r["result_file"]:  # a row whose path leaves the robot's reach is not solved
            check_rows_arrays(folder, file, [r], kind, plan_hash=plan_hash, alpha_tol_deg=1.0, ratio_rel_tol=1.0)
            raise ValueError(f"{folder}: sweep row {row} was not solved (its path leaves the robot's reach)")
        sweep = plan["config"]["sweep"]
        read = check_rows_arrays(
            folder,
            file,
            rows,
            kind,
            plan_hash=plan_hash,
            alpha_tol_deg=sweep["alpha_tol_deg"],
            ratio_rel_tol=sweep["ratio_rel_tol"],
            urdf=urdf,
            only=r["result_file"],
        )
        return read[r["result_file"]], r["result_index"]
    raise ValueError(
        f"{folder}: sweep row {row} is in a chunk that is not finished (no {os.path.relpath(chunk_file(folder, cands[0]['id']), folder)}); "
        "run the sweep again with --resume"
    )
