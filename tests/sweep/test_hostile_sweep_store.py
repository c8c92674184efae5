"""Generated hostile sweep stores through what a user runs on a sweep folder (issue 42).

Two small real sweeps are made once per session (a shape sweep of the planar 3R with one path out
of reach, and a csc sweep), through the command. A generator damages a copy of each: every field of
a chunk's rows file (the record's and each column of a row: deleted, retyped to text / list / null
/ bool, numbers to NaN / inf / -1 / 1e9, ids moved by one), the rows reordered, repeated, dropped
or added, the file truncated, garbled, emptied or deleted; every field of plan.json (and its
config's sections) and manifest.json the same way; the array files (an array's dtype, shape and
values, its meta's sweep record, truncated, garbled, deleted); and the derived files (the table,
timing, summary).

On each damaged folder run ``jaxstiff export DIR --row K --csv`` (the reader of a sweep row that
view and plot share) for a row of the damaged chunk, then ``jaxstiff sweep CONFIG --out DIR
--resume`` (with the report for the manifest's cases, which it reads). Each must end in a clean
refusal (exit 2, one line naming the damaged file) or the right answer (the export's CSV of the
untouched folder byte for byte; a resumed table equal to the untouched one, a deleted chunk
recomputed), never a traceback or another number. The fast lane runs every 16th case and every
4th harmless one; ``-m slow`` runs them all. The counts are printed (``-s``).
"""

from __future__ import annotations

import copy
import dataclasses
import json
import os
import shutil
from collections.abc import Callable
from typing import Any

import numpy as np
import pandas as pd
import pytest
from helpers import CSC_TOML

from jaxstiff.cli import main
from jaxstiff.sweep import read_table

SHAPE_TOML = """\
[sweep]
kind = "shape"
name = "hostile-shape"
chunk_size = 6

[robot]
name = "planar_3r"

[[paths]]
generator = "arc"
center = [0.0, 0.0, 0.0]
radius = [1.5, 2.0, 4.0]   # 4 m: out of the arm's reach, a row left unsolved
start_deg = 10.0
end_deg = 12.0
n = 3

[axes]
task = "xy"
criterion = "f2"
ratio = [2.0, 3.0]
dk = [5.0, 10.0]
first_starts = 2
"""

ROWS = "chunks/chunk-000000.json"
ARRAYS = "arrays/chunk-000000-0.npz"


@pytest.fixture(scope="module", autouse=True)
def _no_compile_cache():
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("JAXSTIFF_COMPILE_CACHE", "0")
        yield


def _sweep_argv(cfg: str, out: str, *more: str) -> list[str]:
    return ["sweep", cfg, "--out", out, "--no-progress", "--no-compile-cache", *more]


@pytest.fixture(scope="module")
def stores(tmp_path_factory) -> dict[str, dict[str, Any]]:
    """The untouched sweeps: config, folder, table, and the CSV export of rows 0 and 1."""
    base = tmp_path_factory.mktemp("hostile-sweep")
    out: dict[str, dict[str, Any]] = {}
    for kind, text in (("shape", SHAPE_TOML), ("csc", CSC_TOML)):
        cfg = str(base / f"{kind}.toml")
        with open(cfg, "w", encoding="utf-8") as fh:
            fh.write(text)
        folder = str(base / kind)
        assert main(_sweep_argv(cfg, folder, "--no-report")) == 0
        csv = {}
        for row in (0, 1):
            f = str(base / f"{kind}-{row}.csv")
            assert main(["export", folder, "--row", str(row), "--csv", f]) == 0
            csv[row] = open(f).read()
        out[kind] = {"cfg": cfg, "folder": folder, "table": read_table(folder), "csv": csv}
    # the shape sweep leaves a row unsolved (the 4 m arc), the csc sweep has two array files' rows
    rows = json.load(open(os.path.join(out["shape"]["folder"], ROWS)))["rows"]
    assert any(r["result_file"] == "" for r in rows) and any(r["result_file"] for r in rows)
    return out


# ---------------------------------------------------------------------- the generator
@dataclasses.dataclass(frozen=True)
class Case:
    kind: str
    file: str  # the damaged file, relative to the folder
    name: str
    damage: Callable[[str], None]  # damage(path of the file)
    expect: str = "either"  # "same" (harmless), "resume" (the resumed table the same) or "either"


def _json_edit(fn: Callable[[Any], Any]) -> Callable[[str], None]:
    def damage(path: str) -> None:
        with open(path, encoding="utf-8") as fh:
            rec = json.load(fh)
        rec = fn(copy.deepcopy(rec))
        with open(path, "w", encoding="utf-8") as fh:
            json.dump(rec, fh)  # (NaN and inf as JSON's NaN / Infinity tokens, as a tamperer's tool writes them)

    return damage


def _bytes_edit(fn: Callable[[bytes], bytes]) -> Callable[[str], None]:
    def damage(path: str) -> None:
        with open(path, "rb") as fh:
            data = fh.read()
        with open(path, "wb") as fh:
            fh.write(fn(data))

    return damage


def _garble(b: bytes) -> bytes:
    i = len(b) // 2
    return b[:i] + bytes([b[i] ^ 0xFF]) + b[i + 1 :]


def _file_cases(kind: str, file: str, deleted: str = "either") -> list[Case]:
    return [
        Case(kind, file, "truncated to half", _bytes_edit(lambda b: b[: len(b) // 2])),
        Case(kind, file, "one byte garbled", _bytes_edit(_garble)),
        Case(kind, file, "emptied", _bytes_edit(lambda b: b"")),
        Case(kind, file, "deleted", os.remove, deleted),
    ]


def _retypes(v: Any) -> list[tuple[str, Any]]:
    out: list[tuple[str, Any]] = []
    if not isinstance(v, str):
        out.append(("text", str(v)))  # "5" for 5: the raw traceback
    if not isinstance(v, list):
        out.append(("a list", [v]))
    if v is not None:
        out.append(("null", None))
    if not isinstance(v, bool):
        out.append(("a bool", True))
    if isinstance(v, (int, float)) and not isinstance(v, bool):
        out += [("NaN", float("nan")), ("inf", float("inf")), ("-1", -1), ("1e9", 1e9)]
        if isinstance(v, int):
            out.append(("one more", v + 1))
    if isinstance(v, (str, list, dict)) and v not in ("", [], {}):
        out.append(("a number", 5))
    return out


def _field_cases(kind: str, file: str, rec: dict, prefix: tuple = (), depth: int = 1) -> list[Case]:
    """Every field of ``rec`` (and one level down into records) deleted and retyped."""
    cases = []
    for key, v in rec.items():
        path = (*prefix, key)
        label = ".".join(map(str, path))

        def at(r: Any, path=path) -> tuple[Any, Any]:
            for p in path[:-1]:
                r = r[p]
            return r, path[-1]

        def delete(r, at=at):
            d, k = at(r)
            del d[k]
            return r

        cases.append(Case(kind, file, f"{label}: deleted", _json_edit(delete)))
        for what, new in _retypes(v):

            def put(r, at=at, new=new):
                d, k = at(r)
                d[k] = new
                return r

            cases.append(Case(kind, file, f"{label}: {what}", _json_edit(put)))
        if isinstance(v, dict) and depth > 0:
            cases += _field_cases(kind, file, v, path, depth - 1)
    return cases


def _rows_cases(kind: str, rec: dict) -> list[Case]:
    top = {k: v for k, v in rec.items() if k != "rows"}
    cases = _field_cases(kind, ROWS, top)
    cases += _field_cases(kind, ROWS, {"rows": {0: rec["rows"][0]}}, depth=2)  # the rows, row 0, each column of it
    last = len(rec["rows"]) - 1
    metrics = ("share_both", "mean_cms") if kind == "shape" else ("share_damped", "u_end")
    for key in ("row_id", "result_index", "result_file", *metrics):
        v = rec["rows"][last][key]
        for what, new in _retypes(v)[:3]:

            def put(r, key=key, new=new):
                r["rows"][-1][key] = new
                return r

            cases.append(Case(kind, ROWS, f"rows[{last}].{key}: {what}", _json_edit(put)))

    def rows_edit(fn):
        return _json_edit(lambda r: {**r, "rows": fn(r["rows"])})

    cases += [
        Case(kind, ROWS, "rows: first two swapped", rows_edit(lambda rs: [rs[1], rs[0], *rs[2:]])),
        Case(kind, ROWS, "rows: first repeated", rows_edit(lambda rs: [rs[0], *rs])),
        Case(kind, ROWS, "rows: last dropped", rows_edit(lambda rs: rs[:-1])),
        Case(kind, ROWS, "rows: an extra row", rows_edit(lambda rs: [*rs, {**rs[-1], "row_id": rs[-1]["row_id"] + 1}])),
        Case(kind, ROWS, "rows: empty", rows_edit(lambda rs: [])),
        Case(
            kind,
            ROWS,
            "rows: row ids shifted by one",
            rows_edit(lambda rs: [{**r, "row_id": r["row_id"] + 1} for r in rs]),
        ),
        Case(kind, ROWS, "rows: metrics of rows 0 and 1 swapped", rows_edit(lambda rs: _swap_metrics(rs))),
        Case(kind, ROWS, "a whole JSON list", _json_edit(lambda r: r["rows"])),
        Case(kind, ROWS, "an extra field", _json_edit(lambda r: {**r, "x_extra": 1}), "same"),
        Case(kind, ROWS, "an extra column in a row", rows_edit(lambda rs: [{**rs[0], "x_extra": 1}, *rs[1:]]), "same"),
    ]
    cases += _file_cases(kind, ROWS, deleted="resume")  # a chunk without its rows file: not done, computed again
    return cases


def _swap_metrics(rows: list[dict]) -> list[dict]:
    a, b = dict(rows[0]), dict(rows[1])
    keys = [k for k in a if k.startswith(("share_", "mean_", "max_", "min_", "u_", "frobenius_"))]
    for k in keys:
        a[k], b[k] = rows[1][k], rows[0][k]
    return [a, b, *rows[2:]]


def _arrays_cases(kind: str, folder: str) -> list[Case]:
    with np.load(os.path.join(folder, ARRAYS), allow_pickle=False) as z:
        arrays = {k: z[k] for k in z.files}
    meta = json.loads(str(arrays["meta"]))

    def npz_edit(fn):
        def damage(path: str) -> None:
            a = {k: v.copy() for k, v in arrays.items()}
            m = copy.deepcopy(meta)
            a, m = fn(a, m)
            if m is not None:
                a["meta"] = np.asarray(json.dumps(m))
            np.savez(path, **a)

        return damage

    def set_first(key, value):
        def fn(a, m):
            b = a[key].copy()
            b.reshape(-1)[0] = value
            return {**a, key: b}, m

        return fn

    cases = []
    for key, v in arrays.items():
        if key == "meta":
            continue
        if v.dtype.kind == "f":
            for what, val in (("NaN", np.nan), ("-1", -1.0), ("x1.5", v.reshape(-1)[0] * 1.5 + 0.1)):
                cases.append(Case(kind, ARRAYS, f"{key}: {what} at the first entry", npz_edit(set_first(key, val))))
        if v.dtype.kind in "iu":
            cases.append(Case(kind, ARRAYS, f"{key}: 99 at the first entry", npz_edit(set_first(key, 99))))
        if v.ndim >= 1 and v.shape[0] > 1:
            cases.append(
                Case(
                    kind, ARRAYS, f"{key}: its paths reversed", npz_edit(lambda a, m, k=key: ({**a, k: a[k][::-1]}, m))
                )
            )
        cases.append(
            Case(
                kind,
                ARRAYS,
                f"{key}: deleted",
                npz_edit(lambda a, m, k=key: ({x: y for x, y in a.items() if x != k}, m)),
            )
        )
    cases += _sweep_meta_cases(kind, meta, npz_edit)
    cases.append(
        Case(kind, ARRAYS, "meta: deleted", npz_edit(lambda a, m: ({k: v for k, v in a.items() if k != "meta"}, None)))
    )
    return cases + _file_cases(kind, ARRAYS)


def _sweep_meta_cases(kind: str, meta: dict, npz_edit: Callable) -> list[Case]:
    """The array file's record of its sweep rows (plan hash, chunk, row ids, paths, ...) lied about."""
    cases = []
    paths = [("sweep", k) for k in meta["sweep"]] + ([("rows",)] if kind == "csc" else [])
    for path in paths:

        def edit(new, path=path):
            def fn(a, m):
                d = m
                for p in path[:-1]:
                    d = d[p]
                d[path[-1]] = new(d[path[-1]])
                return a, m

            return fn

        label = "meta " + ".".join(path)
        cases.append(Case(kind, ARRAYS, f"{label}: text", npz_edit(edit(lambda v: str(v)))))
        flip = edit(lambda v: v[::-1] if isinstance(v, (list, str)) else v + 1)
        cases.append(Case(kind, ARRAYS, f"{label}: reversed", npz_edit(flip)))
    return cases


def generate(stores: dict[str, dict[str, Any]]) -> list[Case]:
    cases: list[Case] = []
    for kind, s in stores.items():
        folder = s["folder"]
        cases += _rows_cases(kind, json.load(open(os.path.join(folder, ROWS))))
        plan = json.load(open(os.path.join(folder, "plan.json")))
        cases += _field_cases(kind, "plan.json", plan) + _file_cases(kind, "plan.json")
        man = json.load(open(os.path.join(folder, "manifest.json")))
        man_cases = _field_cases(kind, "manifest.json", man) + _file_cases(kind, "manifest.json")
        cases += [dataclasses.replace(c, expect="same") for c in man_cases]  # a log: made again
        cases += _arrays_cases(kind, folder)
        for derived in ("results.parquet", "timing.csv"):
            cases += [dataclasses.replace(c, expect="same") for c in _file_cases(kind, derived)]
    return cases


# ---------------------------------------------------------------------- one case
def _refusal(rc: int, err: str, file: str) -> bool:
    """Exit 2 with one line naming the damaged file (a warning line before it allowed)."""
    lines = [ln for ln in err.strip().splitlines() if ln.startswith("jaxstiff: error: ")]
    return rc == 2 and len(lines) == 1 and "Traceback" not in err and os.path.basename(file) in lines[0]


def _run(argv: list[str], capsys) -> tuple[int, str]:
    capsys.readouterr()
    try:
        rc = main(argv)
    except BaseException as exc:  # noqa: BLE001 - anything escaping the command is a defect
        return -1, f"{type(exc).__name__}: {exc}"
    return rc, capsys.readouterr().err


def run_case(case: Case, store: dict[str, Any], tmp: str, capsys) -> tuple[str, str, list[str]]:
    folder = os.path.join(tmp, "case")
    if os.path.exists(folder):
        shutil.rmtree(folder)
    shutil.copytree(store["folder"], folder)
    case.damage(os.path.join(folder, case.file))
    problems: list[str] = []
    outcomes = []
    # the reader of a sweep row (view, export, plot): a row pointing into the damaged chunk's first array file
    for row in (0, 1):
        csv = os.path.join(tmp, "case.csv")
        if os.path.exists(csv):
            os.remove(csv)
        rc, err = _run(["export", folder, "--row", str(row), "--csv", csv], capsys)
        if rc == 0 and os.path.exists(csv) and open(csv).read() == store["csv"][row]:
            outcomes.append("same")
        elif _refusal(rc, err, case.file) and not os.path.exists(csv):
            outcomes.append("refused")
        else:
            problems.append(f"export --row {row}: exit {rc}, {err.strip()[-300:]!r}")
            outcomes.append("failed")
    export = "same" if outcomes == ["same", "same"] else "refused" if "failed" not in outcomes else "failed"
    # resume (the report reads the manifest)
    more = ("--resume",) if case.file == "manifest.json" else ("--resume", "--no-report")
    rc, err = _run(_sweep_argv(store["cfg"], folder, *more), capsys)
    if rc == 0:
        try:
            pd.testing.assert_frame_equal(read_table(folder), store["table"], check_exact=True)
            same = True
        except (AssertionError, ValueError, OSError) as exc:
            same = False
            problems.append(f"resume: exit 0 with another table: {str(exc)[:200]}")
        resume = "same" if same else "failed"
    elif _refusal(rc, err, case.file):
        resume = "refused"
    else:
        resume = "failed"
        problems.append(f"resume: exit {rc}, {err.strip()[-300:]!r}")
    if case.expect == "resume" and resume != "same":
        problems.append(f"resume did not give the untouched table ({resume})")
    if case.expect == "same" and (export, resume) != ("same", "same"):
        problems.append(f"a harmless change was not read as the untouched folder (export {export}, resume {resume})")
    return export, resume, problems


def _run_all(stores, tmp_path, capsys, pick: Callable[[int, Case], bool]) -> dict[str, int]:
    cases = generate(stores)
    chosen = [c for i, c in enumerate(cases) if pick(i, c)]
    results = [(c, *run_case(c, stores[c.kind], str(tmp_path), capsys)) for c in chosen]
    counts = {
        "generated": len(cases),
        "run": len(results),
        "export_refused": sum(e == "refused" for _, e, _, _ in results),
        "export_right": sum(e == "same" for _, e, _, _ in results),
        "resume_refused": sum(r == "refused" for _, _, r, _ in results),
        "resume_right": sum(r == "same" for _, _, r, _ in results),
        "failures": sum(bool(p) for *_, p in results),
    }
    with capsys.disabled():
        print(f"\nhostile sweep stores: {json.dumps(counts)}")
    bad = [f"{c.kind} {c.file} / {c.name}: {'; '.join(p)}" for c, _, _, p in results if p]
    assert not bad, f"{len(bad)} of {len(results)} cases failed:\n" + "\n".join(bad[:40])
    return counts


def test_hostile_sweep_stores_sample(stores, tmp_path, capsys) -> None:
    """Every 16th generated case and every 4th harmless one (the fast lane)."""
    counts = _run_all(stores, tmp_path, capsys, lambda i, c: i % 16 == 0 or (c.expect == "same" and i % 4 == 0))
    assert counts["resume_refused"] > 0 and counts["resume_right"] > 0 and counts["export_refused"] > 0


@pytest.mark.slow
def test_hostile_sweep_stores_all(stores, tmp_path, capsys) -> None:
    counts = _run_all(stores, tmp_path, capsys, lambda i, c: True)
    assert counts["run"] == counts["generated"]
