"""The ``[[paths]]`` of a sweep: CSV files and path generators whose parameters may be lists or
ranges (one path per value; several lists: every combination, or pairwise with ``zip = true``).

Each generator's table is a pydantic model built from :data:`GENERATORS` and the generator's
signature (unknown and missing parameters are named with the generator); the parameter values
(a value, a list, a range, a vector or a list of vectors) are expanded by :func:`generator_values`.
"""

from __future__ import annotations

import dataclasses
import inspect
import itertools
import os
from collections.abc import Callable, Mapping
from typing import Any, ClassVar

import numpy as np
from pydantic import create_model

from jaxstiff.sweep._schema import (
    PathFileTable,
    SweepConfigError,
    Table,
    number,
    range_values,
    suggest,
    typename,
    validate,
    vec3,
)

__all__ = ["Trajectory", "generator_values"]

#: Parameter types of each path generator: ``"float"``, ``"int"``, ``"vec3"``, ``"points"``.
#: Scalar parameters accept a list or a range (one path per value), vec3 ones a list of vectors.
GENERATORS: dict[str, dict[str, str]] = {
    "default": {"n": "int"},
    "line": {"start": "vec3", "end": "vec3", "n": "int"},
    "arc": {
        "center": "vec3",
        "radius": "float",
        "start_deg": "float",
        "end_deg": "float",
        "n": "int",
        "normal": "vec3",
    },
    "circle": {"center": "vec3", "radius": "float", "n": "int", "normal": "vec3"},
    "half_sine": {
        "start": "vec3",
        "end": "vec3",
        "amplitude": "float",
        "n": "int",
        "periods": "float",
        "normal": "vec3",
    },
    "spline": {"points": "points", "n": "int"},
    "point": {"point": "vec3", "n": "int", "direction": "vec3"},
}


@dataclasses.dataclass(frozen=True, eq=False)
class Trajectory:
    """One path of the sweep: ``points``, ``directions`` (P, 3); ``spec`` says where it came from."""

    index: int
    name: str
    points: np.ndarray
    directions: np.ndarray
    spec: dict

    @property
    def P(self) -> int:
        """Number of waypoints."""
        return int(self.points.shape[0])


def format_value(x: Any) -> str:
    """A value as shown in a path name or the plan (``2``, ``[0, 0, 0.2]``)."""
    if isinstance(x, float):
        return f"{x:g}"
    if isinstance(x, (list, tuple)):
        return "[" + ", ".join(f"{float(e):g}" for e in x) + "]"
    return str(x)


def _point_path(point: Any, n: int = 20, direction: Any = (1.0, 0.0, 0.0)) -> Any:
    """A path that holds one point for ``n`` waypoints (CSC "hold" studies); directions constant."""
    from jaxstiff.paths import Path, check_waypoints

    p = np.asarray(point, dtype=float)
    d = np.asarray(direction, dtype=float)
    n = check_waypoints(n, "point")
    return Path(np.tile(p, (n, 1)), np.tile(d, (n, 1)), name="point")


def _generator_fns() -> dict[str, Callable[..., Any]]:
    from jaxstiff import paths as P

    return {
        "default": P.default_path,
        "line": P.line,
        "arc": P.arc,
        "circle": P.circle,
        "half_sine": P.half_sine,
        "spline": P.spline,
        "point": _point_path,
    }


class _GeneratorBase(Table):
    generator_name: ClassVar[str] = ""

    @classmethod
    def unknown_key(cls, key: str) -> str:
        return super().unknown_key(key) + f" for generator {cls.generator_name!r}"

    @classmethod
    def missing_key(cls, key: str) -> str:
        need = [k for k, f in cls.model_fields.items() if f.is_required() and k != "generator"]
        return f"missing: generator {cls.generator_name!r} needs {key!r} (its required keys: {', '.join(need)})"


def _generator_model(gen: str) -> type[_GeneratorBase]:
    sig = inspect.signature(_generator_fns()[gen])
    fields: dict[str, Any] = {"generator": (str, ...), "name": (Any, None), "zip": (bool, False)}
    for p in GENERATORS[gen]:
        required = sig.parameters[p].default is inspect.Parameter.empty
        fields[p] = (Any, ... if required else None)
    model = create_model(f"{gen}Generator", __base__=_GeneratorBase, **fields)
    model.generator_name = gen
    return model


def generator_values(v: Any, ptype: str, key: str, source: str = "") -> list:
    """The values of one generator parameter (one path per value)."""
    if ptype in ("float", "int"):
        integer = ptype == "int"
        if isinstance(v, Mapping):
            return range_values(dict(v), key, integer, source)
        if isinstance(v, list):
            if not v:
                raise SweepConfigError(key, "empty list: give at least one value", source)
            return [number(x, f"{key}[{i}]", integer, source) for i, x in enumerate(v)]
        return [number(v, key, integer, source)]
    if ptype == "vec3":
        if isinstance(v, list) and v and all(isinstance(x, list) for x in v):
            return [vec3(x, f"{key}[{i}]", source) for i, x in enumerate(v)]
        return [vec3(v, key, source)]
    if not isinstance(v, list) or len(v) < 2:  # points: a list of 3-vectors, no axis
        raise SweepConfigError(key, f"expected a list of >= 2 points [[x, y, z], ...], got {v!r}", source)
    return [[vec3(x, f"{key}[{i}]", source) for i, x in enumerate(v)]]


def _csc_directions(points: np.ndarray, given: np.ndarray | None) -> np.ndarray:
    """Directions of a CSC sweep's CSV path, kept for the plan and result files only (a CSC
    rollout never reads them): the given ones, else the tangents where the path has them, else
    (a path that holds still somewhere) the x axis."""
    from jaxstiff.paths import Path

    if given is not None:
        n = np.linalg.norm(given, axis=-1, keepdims=True)
        return np.where(n > 1e-12, given / np.where(n > 1e-12, n, 1.0), [1.0, 0.0, 0.0])
    try:
        return np.array(Path(points).directions)
    except ValueError:
        return np.tile([1.0, 0.0, 0.0], (len(points), 1))


def _file_path(tbl: Mapping[str, Any], key: str, kind: str, base_dir: str, source: str) -> Trajectory:
    from jaxstiff.paths import Path, read_csv
    from jaxstiff.runtime._io import check_regular_file, file_sha256

    entry = validate(PathFileTable, tbl, key, source)
    fp = entry.file if os.path.isabs(entry.file) else os.path.join(base_dir, entry.file)
    try:
        check_regular_file(fp, "path file")
        if kind == "csc":  # points only: a CSC rollout may hold still (repeated rows)
            pts, dirs, _ = read_csv(fp)
            dirs = _csc_directions(pts, dirs)
        else:
            p = Path.from_csv(fp)
            pts, dirs = p.points, p.directions
    except (ValueError, FileNotFoundError) as exc:
        raise SweepConfigError(f"{key}.file", str(exc), source) from None
    nm = entry.name or os.path.splitext(os.path.basename(fp))[0]
    return Trajectory(0, nm, np.array(pts), np.array(dirs), {"file": os.path.abspath(fp), "sha256": file_sha256(fp)})


def _generated_paths(tbl: Mapping[str, Any], key: str, source: str) -> list[Trajectory]:
    gen = tbl["generator"]
    if gen not in GENERATORS:
        raise SweepConfigError(
            f"{key}.generator",
            f"unknown generator {gen!r}{suggest(str(gen), list(GENERATORS))}; choose one of {', '.join(GENERATORS)}",
            source,
        )
    entry = validate(_GENERATOR_MODELS[gen], tbl, key, source)
    label = getattr(entry, "name", None)
    if label is not None and (not isinstance(label, str) or not label):
        raise SweepConfigError(f"{key}.name", f"expected a non-empty string, got {label!r}", source)
    options = {p: generator_values(tbl[p], t, f"{key}.{p}", source) for p, t in GENERATORS[gen].items() if p in tbl}
    varying = [k for k, v in options.items() if len(v) > 1]
    if getattr(entry, "zip", False):
        lengths = {k: len(options[k]) for k in varying}
        if len(set(lengths.values())) > 1:
            raise SweepConfigError(
                f"{key}.zip",
                f"zip = true pairs the list-valued parameters, which need equal lengths; got {lengths}",
                source,
            )
        n_paths = max(lengths.values(), default=1)
        combos = [tuple(v[i] if len(v) > 1 else v[0] for v in options.values()) for i in range(n_paths)]
    else:
        combos = list(itertools.product(*options.values()))
    _check_paths_size(options, len(combos), key, source)
    fn = _generator_fns()[gen]
    out = []
    for combo in combos:
        kw = dict(zip(options, combo, strict=True))
        try:
            p = fn(**kw)
        except (ValueError, TypeError) as exc:
            raise SweepConfigError(key, f"generator {gen!r} with {kw}: {exc}", source) from None
        nm = (label or gen) + ("(" + ", ".join(f"{k}={format_value(kw[k])}" for k in varying) + ")" if varying else "")
        out.append(Trajectory(0, nm, np.array(p.points), np.array(p.directions), {"generator": gen, **kw}))
    return out


_GENERATOR_MODELS = {g: _generator_model(g) for g in GENERATORS}


def _check_paths_size(options: Mapping[str, list], n_paths: int, key: str, source: str) -> None:
    """Refuse a generator table whose paths cannot fit in memory (before any is generated), naming ``key.n``."""
    from jaxstiff.paths import WAYPOINT_BYTES
    from jaxstiff.runtime._plan_size import PlanTooLargeError, check_plan_size

    n_max = max((int(v) for v in options.get("n", [])), default=0)
    if n_max < 2:  # (the default n of the generator; a bad n is the generator's to name)
        return
    what = f"{n_paths} path(s) of up to n = {n_max} waypoints" if n_paths > 1 else f"n = {n_max} waypoints"
    try:
        check_plan_size(what, n_paths * n_max, WAYPOINT_BYTES, f"{key}.n")
    except PlanTooLargeError as exc:
        raise SweepConfigError(f"{key}.n", str(exc), source) from None


def _unique_names(paths: list[Trajectory]) -> list[Trajectory]:
    """Index the paths and give a repeated name the first free ``#k`` suffix (k = 2, 3, ...),
    never one that another path already has ("p", "p", "p#2" -> "p", "p#3", "p#2")."""
    taken = {t.name for t in paths}
    seen: set[str] = set()
    fixed = []
    for i, t in enumerate(paths):
        name = t.name
        if name in seen:
            k = 2
            while f"{t.name}#{k}" in taken:
                k += 1
            name = f"{t.name}#{k}"
            taken.add(name)
        seen.add(name)
        fixed.append(dataclasses.replace(t, index=i, name=name))
    return fixed


def read_paths(cfg: Mapping[str, Any], kind: str, base_dir: str, source: str = "") -> list[Trajectory]:
    """Every path of ``[[paths]]``, expanded and indexed (relative files resolve against ``base_dir``)."""
    if "paths" not in cfg:
        raise SweepConfigError(
            "paths", "missing: give at least one [[paths]] table (file = CSV, or generator = ...)", source
        )
    plist = cfg["paths"]
    if isinstance(plist, Mapping):
        plist = [plist]
    if not isinstance(plist, list) or not plist:
        raise SweepConfigError("paths", "expected one or more [[paths]] tables", source)
    out: list[Trajectory] = []
    for i, entry in enumerate(plist):
        key = f"paths[{i}]"
        if not isinstance(entry, Mapping):
            raise SweepConfigError(key, f"expected a table, got {typename(entry)} {entry!r}", source)
        if ("file" in entry) == ("generator" in entry):
            raise SweepConfigError(
                key,
                "give exactly one of 'file' (a CSV path) and 'generator' (one of " + ", ".join(GENERATORS) + ")",
                source,
            )
        if "file" in entry:
            out.append(_file_path(entry, key, kind, base_dir, source))
        else:
            out += _generated_paths(entry, key, source)
        _refuse_repeats(out, key, source)
    return _unique_names(out)


def _refuse_repeats(paths: list[Trajectory], key: str, source: str) -> None:
    """A path given twice (the same waypoints and directions: a file listed twice, or a generator
    that makes one path again) would run every setting twice; refused as a repeated axis value is."""
    seen: dict[bytes, int] = {}
    for i, t in enumerate(paths):
        sig = np.ascontiguousarray(t.points, float).tobytes() + np.ascontiguousarray(t.directions, float).tobytes()
        if sig in seen:
            j = seen[sig]
            raise SweepConfigError(
                key,
                f"path {t.name!r} is the same path as {paths[j].name!r} (the sweep's path {j}: the same waypoints "
                "and directions); give each path once",
                source,
            )
        seen[sig] = i
