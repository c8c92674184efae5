"""Generated hostile result files through the one reader and the commands (issue 42, item 3).

One small valid shape file (the shipped LWR, 3 waypoints, slsqp) and one small csc file (the
command, 4 steps) are made once per session. A generator mutates them: every array in shape (drop
a column, add a row, transpose), dtype (int, bool, complex, float16, str; float for the codes) and
value (NaN, inf, negative, zero; -1 and 99 for the codes), and every meta field (top level and one
level down) deleted and retyped (number / text / list), plus the lies a tampered file tells (another
robot with its correct hash, the TCP moved 0.5 m, another task, joint names permuted, a locked
joint moved or its recorded value changed) and harmless changes (an extra field, an extra array).

Each case goes through :func:`jaxstiff.results._reader.read_result`, the schema loaders
(``ShapeResult.load`` / ``CSCResult.load``), ``jaxstiff export`` in-process, and (shape)
``jaxstiff.results.verify``. Each must end in a clean refusal (a ResultFileError / exit 2 with one
line on stderr) or the right answer (the CSV of the unmutated file, byte for byte), never a
traceback or another number; the reader and the commands must agree; a lie must be refused. The fast
lane runs every lie and every 4th other case; ``-m slow`` runs them all. The counts are printed
(``-s``) and written to ``hostile-counts.json`` in the session's temporary folder.
"""

from __future__ import annotations

import copy
import dataclasses
import json
import os
import time
from collections.abc import Callable
from typing import Any

import numpy as np
import pytest

import jaxstiff
from jaxstiff.cli import main
from jaxstiff.model import robot_path
from jaxstiff.results._reader import ResultFileError, read_result
from jaxstiff.runtime._io import file_sha256

Q_START = [0.3, 0.5, -0.2, -1.2, 0.4, 0.6, 0.0]  # the LWR, lwr_a7 locked at 0 (its default)

Arrays = dict[str, np.ndarray]


@dataclasses.dataclass(frozen=True)
class Case:
    kind: str  # "shape" or "csc"
    name: str
    mutate: Callable[[Arrays, dict], tuple[Arrays, dict]]
    expect: str = "either"  # "refuse", "same" (the right answer: the CSV of the valid file) or "either"


# ---------------------------------------------------------------------- the valid files
@pytest.fixture(scope="session")
def valid_files(tmp_path_factory) -> dict[str, str]:
    folder = tmp_path_factory.mktemp("hostile-valid")
    robot = jaxstiff.Robot.from_urdf("kuka_lwr4", locked={"lwr_a7": 0.0})  # as the commands lock it
    q = np.asarray(Q_START)
    p = np.asarray(jaxstiff.fk(robot, q))[:3, 3]
    pts = p + np.c_[np.linspace(0.0, 0.002, 3), np.zeros(3), np.zeros(3)]
    res = jaxstiff.shape(robot, jaxstiff.Path(pts), "f2", 3.0, task="xyz", solver="slsqp", q0=q)
    assert (res.status == 0).all()
    shape = res.save(str(folder / "shape.npz"))
    csc = str(folder / "csc.npz")
    hold = ",".join(f"{x:.6f}" for x in p)
    argv = ["csc", "--hold", hold, "--steps", "4", "--kxd", "3000,1000,2000", "--q0", ",".join(map(str, Q_START))]
    assert main([*argv, "--out", csc]) == 0
    return {"shape": shape, "csc": csc, "folder": str(folder)}


def _read(file: str) -> tuple[Arrays, dict]:
    with np.load(file, allow_pickle=False) as z:
        arrays = {k: z[k] for k in z.files}
    return {k: v for k, v in arrays.items() if k != "meta"}, json.loads(str(arrays["meta"]))


_NO_META = object()  # a mutation's meta: write no meta array


def _write(file: str, arrays: Arrays, meta: Any) -> str:
    extra = {} if meta is _NO_META else {"meta": np.asarray(json.dumps(meta))}
    np.savez(file, **extra, **arrays)  # pyright: ignore[reportArgumentType]
    return file


# ---------------------------------------------------------------------- the generator
def _set(a: np.ndarray, flat: int, value: Any) -> np.ndarray:
    b = a.copy()
    b.reshape(-1)[flat] = value
    return b


def _array_cases(kind: str, arrays: Arrays) -> list[Case]:
    cases = []
    for key, a in arrays.items():

        def put(fn, key=key):
            return lambda arr, meta: ({**arr, key: fn(arr[key])}, meta)

        if a.ndim >= 1 and a.shape[-1] > 1:
            cases.append(Case(kind, f"{key}: drop a column", put(lambda x: x[..., :-1])))
        if a.ndim >= 1:
            cases.append(Case(kind, f"{key}: add a row", put(lambda x: np.concatenate([x, x[:1]], axis=0))))
        if a.ndim >= 2 and a.T.shape != a.shape:
            cases.append(Case(kind, f"{key}: transposed", put(lambda x: x.T)))
        cases.append(Case(kind, f"{key}: a scalar", put(lambda x: np.asarray(x.reshape(-1)[0]))))
        for dt in (np.int64, np.bool_, np.complex128, np.float16, np.str_, np.float64):
            if np.dtype(dt) == a.dtype or (dt is np.float64 and a.dtype.kind == "f"):
                continue

            def cast(x, dt=dt):
                try:
                    return x.astype(dt)
                except (ValueError, TypeError):
                    return np.zeros(x.shape, dt)

            cases.append(Case(kind, f"{key}: dtype {np.dtype(dt).name}", put(cast)))
        if a.size and a.dtype.kind == "f":
            for label, v in (("NaN", np.nan), ("inf", np.inf), ("negative", -1.0), ("zero", 0.0)):
                for where, flat in (("first", 0), ("last", a.size - 1)):
                    cases.append(
                        Case(kind, f"{key}: {label} at the {where} entry", put(lambda x, f=flat, v=v: _set(x, f, v)))
                    )
        if a.size and a.dtype.kind in "iu":
            for v in (-1, 99):
                cases.append(Case(kind, f"{key}: {v} at the first entry", put(lambda x, v=v: _set(x, 0, v))))
    return cases


def _meta_paths(meta: dict) -> list[tuple[str, ...]]:
    out = []
    for k, v in meta.items():
        out.append((k,))
        if isinstance(v, dict):
            out += [(k, k2) for k2 in v]
    return out


def _edit(meta: dict, path: tuple[str, ...], fn: Callable[[dict, str], None]) -> dict:
    m = copy.deepcopy(meta)
    rec = m
    for p in path[:-1]:
        rec = rec[p]
    fn(rec, path[-1])
    return m


def _retypes(v: Any) -> list[tuple[str, Any]]:
    out = []
    if not (isinstance(v, (int, float)) and not isinstance(v, bool)):
        out.append(("a number", 7))
    if not isinstance(v, str):
        out.append(("text", "7"))
    if not isinstance(v, list):
        out.append(("a list", [7]))
    if isinstance(v, (list, dict)) or v is None:
        out.append(("text 'kuka'", "kuka"))
    return out


def _meta_cases(kind: str, meta: dict) -> list[Case]:
    cases = []
    for path in _meta_paths(meta):
        dotted = ".".join(path)

        def deleted(arr, m, path=path):
            return arr, _edit(m, path, lambda r, k: r.pop(k))

        cases.append(Case(kind, f"meta {dotted}: deleted", deleted))
        rec: Any = meta
        for p in path:
            rec = rec[p]
        for label, new in _retypes(rec):

            def retyped(arr, m, path=path, new=new):
                return arr, _edit(m, path, lambda r, k: r.__setitem__(k, new))

            cases.append(Case(kind, f"meta {dotted}: retyped to {label}", retyped))
    for label, whole in (("null", None), ("a list", []), ("text", "kuka"), ("empty", {})):
        cases.append(Case(kind, f"meta: {label}", lambda arr, m, w=whole: (arr, w), "refuse"))
    cases.append(Case(kind, "meta: an extra field", lambda arr, m: (arr, {**m, "x_extra": [1, 2]}), "same"))
    cases.append(Case(kind, "an extra array", lambda arr, m: ({**arr, "x_extra": np.zeros(3)}, m), "same"))
    cases.append(Case(kind, "meta array: deleted", lambda arr, m: (arr, _NO_META), "refuse"))
    return cases


def _lies(kind: str) -> list[Case]:  # noqa: C901 - one small mutation function per lie, in a row
    """What a tampered file claims: each must be refused."""
    planar = robot_path("planar_3r")

    def robot(**changes):
        def f(arr, m):
            m = copy.deepcopy(m)
            m["robot"].update(changes)
            return arr, m

        return f

    def tcp_moved(both: bool):
        def f(arr, m):
            m = copy.deepcopy(m)
            tcp = np.asarray(m["robot"]["tcp"] if m["robot"]["tcp"] is not None else np.eye(4), float)
            tcp[0, 3] += 0.5
            m["robot"]["tcp"] = tcp.tolist()
            if both:
                tip = np.asarray(m["robot"]["tip_transform"], float) @ _shift(0.5)
                m["robot"]["tip_transform"] = tip.tolist()
            return arr, m

        return f

    def task(new: str, settings_too: bool):
        def f(arr, m):
            m = copy.deepcopy(m)
            m["task"] = new
            if settings_too and isinstance(m.get("settings"), dict):
                m["settings"]["task"] = new
            return arr, m

        return f

    def permuted(meta_too: bool):
        def f(arr, m):
            arr = {**arr, "joint_names": arr["joint_names"][::-1].copy()}
            if meta_too:
                m = copy.deepcopy(m)
                m["robot"]["joint_names"] = m["robot"]["joint_names"][::-1]
            return arr, m

        return f

    def q_locked_moved(arr, m):
        q = arr["q"].copy()
        q[..., 6] += 0.1
        return {**arr, "q": q}, m

    def locked_value(arr, m):
        m = copy.deepcopy(m)
        m["robot"]["locked"] = {"lwr_a7": 0.3}
        return arr, m

    def positions_moved(arr, m):
        p = arr["position"].copy()
        p[..., 0] += 0.01
        out = {**arr, "position": p}
        if "target" in arr and kind == "shape":  # the claim kept consistent: only FK can tell
            out["target"] = arr["target"] + np.r_[0.01, 0, 0]
        return out, m

    def kj_scaled_doubled(arr, m):
        return {**arr, "kj_scaled": 2 * arr["kj_scaled"]}, m

    out = [
        Case(
            kind,
            "lie: another robot, its correct hash",
            robot(urdf=planar, sha256=file_sha256(planar), name="planar_3r"),
            "refuse",
        ),
        Case(kind, "lie: another robot name", robot(name="planar_3r"), "refuse"),
        Case(kind, "lie: another hash", robot(sha256="0" * 64), "refuse"),
        Case(kind, "lie: TCP moved 0.5 m", tcp_moved(False), "refuse"),
        Case(kind, "lie: TCP and tip transform moved 0.5 m", tcp_moved(True), "refuse"),
        Case(kind, "lie: joint names permuted", permuted(False), "refuse"),
        Case(kind, "lie: joint names permuted, meta too", permuted(True), "refuse"),
        Case(kind, "lie: a locked joint moved", q_locked_moved, "refuse"),
        Case(kind, "lie: locked value changed", locked_value, "refuse"),
        Case(kind, "lie: positions moved 1 cm", positions_moved, "refuse"),
    ]
    for new in ("xy", "full"):
        out.append(Case(kind, f"lie: task {new}", task(new, False), "refuse"))
        out.append(Case(kind, f"lie: task {new}, settings too", task(new, True), "refuse"))
    if kind == "shape":
        out.append(Case(kind, "lie: kj_scaled doubled", kj_scaled_doubled, "refuse"))
    return out


def _shift(x: float) -> np.ndarray:
    T = np.eye(4)
    T[0, 3] = x
    return T


def generate(valid: dict[str, str]) -> list[Case]:
    cases = []
    for kind in ("shape", "csc"):
        arrays, meta = _read(valid[kind])
        cases += _lies(kind) + _array_cases(kind, arrays) + _meta_cases(kind, meta)
    return cases


# ---------------------------------------------------------------------- one case
@dataclasses.dataclass
class Outcome:
    case: Case
    reader: str  # "refused" or "ok"
    export: str  # "refused", "same" or what went wrong
    problems: list[str]


def _one_line_refusal(err: str) -> bool:
    lines = [ln for ln in err.strip().splitlines() if ln]
    return len(lines) == 1 and lines[0].startswith("jaxstiff: error: ") and "Traceback" not in err


def _reader_outcome(f: str, kind: str, problems: list[str]) -> str:
    """read_result and the schema loader: "ok" / "refused" (a one-line ResultFileError) / "crashed"."""
    try:
        read_result(f)
        reader = "ok"
    except ResultFileError as exc:
        reader = "refused"
        if "\n" in str(exc) or not str(exc).startswith(f):
            problems.append(f"reader: not a one-line message naming the file: {exc!s:.200}")
    except Exception as exc:  # noqa: BLE001 - anything else is a defect
        reader = "crashed"
        problems.append(f"reader: {type(exc).__name__}: {exc!s:.200}")
    try:  # the schema loaders: a refusal or a result, never another exception
        if kind == "shape":
            jaxstiff.ShapeResult.load(f)
        else:
            from jaxstiff.csc import CSCResult

            CSCResult.load(f)
    except ValueError:
        pass
    except Exception as exc:  # noqa: BLE001
        problems.append(f"load: {type(exc).__name__}: {exc!s:.200}")
    return reader


def _export_outcome(f: str, out: str, baseline: str, capsys, problems: list[str]) -> str:
    """``jaxstiff export`` in-process: "refused" (exit 2, one line, no CSV) / "same" (the valid file's CSV)."""
    if os.path.exists(out):
        os.remove(out)
    capsys.readouterr()
    try:
        rc = main(["export", f, "--csv", out])
        err = capsys.readouterr().err
    except BaseException as exc:  # noqa: BLE001
        rc, err = -1, f"{type(exc).__name__}: {exc}"
    if rc == 2 and _one_line_refusal(err) and not os.path.exists(out):
        return "refused"
    if rc == 0 and open(out).read() == baseline:
        return "same"
    problems.append(f"export: exit {rc}, {'another CSV' if rc == 0 else repr(err.strip()[:200])}")
    return "different" if rc == 0 else f"exit {rc}"


#: verify's own re-checks of the reported values: on a file whose reported alpha, rho, criterion or
#: CMS factor was changed, verify reporting the mismatch is its right answer
_REPORTED = ("max_alpha_mismatch", "max_ratio_mismatch", "max_criterion_mismatch", "max_cms_mismatch")


def _verify_problems(f: str, reader: str, baseline: dict[str, float]) -> list[str]:
    try:
        v = jaxstiff.results.verify(f)
    except ResultFileError:
        return [] if reader == "refused" else ["verify refused a file the reader accepts"]
    except Exception as exc:  # noqa: BLE001
        return [f"verify: {type(exc).__name__}: {exc!s:.200}"]
    if reader == "refused":
        return ["verify accepted a file the reader refuses"]
    if any(x != x for x in v.values()):
        return [f"verify: a NaN (a check swallowed): {v}"]
    other = {k: x for k, x in v.items() if x != baseline[k]}
    if set(other) - set(_REPORTED):
        return [f"verify: other numbers {other}"]
    return []


def run_case(case: Case, valid: dict[str, str], tmp: str, baseline: dict[str, Any], capsys) -> Outcome:
    arrays, meta = _read(valid[case.kind])
    arrays, meta = case.mutate(arrays, meta)
    f = _write(os.path.join(tmp, "case.npz"), arrays, meta)
    problems: list[str] = []
    t0 = time.perf_counter()
    reader = _reader_outcome(f, case.kind, problems)
    export = _export_outcome(f, os.path.join(tmp, "case.csv"), baseline[case.kind], capsys, problems)
    if (reader == "refused") != (export == "refused") and reader != "crashed":
        problems.append(f"the reader ({reader}) and export ({export}) disagree")
    if case.kind == "shape":  # verify(path): the same reader
        problems += _verify_problems(f, reader, baseline["verify"])
    if case.expect == "refuse" and reader != "refused":
        problems.append("a lie was not refused")
    if case.expect == "same" and export != "same":
        problems.append("a harmless change was not read as the valid file")
    if time.perf_counter() - t0 > 30:
        problems.append(f"took {time.perf_counter() - t0:.0f} s")
    return Outcome(case, reader, export, problems)


def _run_all(valid, tmp_path, capsys, pick: Callable[[int, Case], bool]) -> dict[str, int]:
    baseline: dict[str, Any] = {"verify": jaxstiff.results.verify(valid["shape"])}
    for kind in ("shape", "csc"):
        out = str(tmp_path / f"{kind}.csv")
        assert main(["export", valid[kind], "--csv", out]) == 0
        baseline[kind] = open(out).read()
    cases = generate(valid)
    chosen = [c for i, c in enumerate(cases) if pick(i, c)]
    outcomes = [run_case(c, valid, str(tmp_path), baseline, capsys) for c in chosen]
    counts = {
        "generated": len(cases),
        "run": len(outcomes),
        "refused": sum(o.export == "refused" for o in outcomes),
        "right_answer": sum(o.export == "same" for o in outcomes),
        "failures": sum(bool(o.problems) for o in outcomes),
    }
    with capsys.disabled():
        print(f"\nhostile files: {json.dumps(counts)}")
    with open(os.path.join(valid["folder"], "hostile-counts.json"), "a") as fh:
        fh.write(json.dumps(counts) + "\n")
    bad = [f"{o.case.kind} / {o.case.name}: {'; '.join(o.problems)}" for o in outcomes if o.problems]
    assert not bad, f"{len(bad)} of {len(outcomes)} cases failed:\n" + "\n".join(bad[:40])
    return counts


def test_hostile_files_sample(valid_files, tmp_path, capsys) -> None:
    """Every lie and harmless change, and every 4th other generated case (the fast lane)."""
    counts = _run_all(valid_files, tmp_path, capsys, lambda i, c: c.expect != "either" or i % 4 == 0)
    assert counts["run"] >= 100 and counts["refused"] > 0 and counts["right_answer"] > 0


@pytest.mark.slow
def test_hostile_files_all(valid_files, tmp_path, capsys) -> None:
    counts = _run_all(valid_files, tmp_path, capsys, lambda i, c: True)
    assert counts["run"] == counts["generated"]
