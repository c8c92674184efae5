"""A validated sweep config expanded into rows, groups and chunks: :class:`SweepPlan`.

:func:`load_config` reads a TOML file and :func:`parse_config` a dict; both check every table
(:mod:`._schema`, :mod:`._axes`, :mod:`._trajectories`) before any work starts and raise
:class:`~jaxstiff.sweep._schema.SweepConfigError` naming the key and the problem.

Rows are numbered setting-major: ``row_id = setting_index * n_paths + path_index``, with the
settings in ``itertools.product`` order of the axes in the order of :data:`~._axes.AXES`. Rows that
share the *static* axes and the number of waypoints form a *group*; each group is cut into chunks
of at most ``chunk_size`` consecutive rows (kind "shape": whole settings, i.e. all paths of a
setting, as long as they fit, so that every batched call of a group has the same batch size and
compiles once). The plan, and so every row's result, depends only on the config, never on timing.
"""

from __future__ import annotations

import dataclasses
import hashlib
import itertools
import json
import math
import os
from collections.abc import Mapping
from typing import Any

import numpy as np

from jaxstiff.runtime._io import check_regular_file, json_default
from jaxstiff.sweep._axes import AXES, axes_table, cross_checks, resolve_jl_gain
from jaxstiff.sweep._robot_table import build_robot as build_robot
from jaxstiff.sweep._schema import (
    DEFAULT_CHUNK,
    MAX_ROWS,
    TOP_KEYS,
    SweepConfigError,
    SweepTable,
    check_table,
    known_keys,
    validate,
)
from jaxstiff.sweep._sections import report_choices, solver_options
from jaxstiff.sweep._trajectories import Trajectory, format_value, read_paths

__all__ = ["load_config", "build_robot", "expand_rows", "cut_chunks"]


def hashed_config(normalised: dict) -> dict:
    """The part of a normalised config (``plan.config``) that the plan hash sees: not where the
    files lie (``robot.urdf_file``, the paths' ``file``; their sha256 and data count), not the
    report section (it does not change results)."""
    hashed = {k: v for k, v in normalised.items() if k != "report"}
    hashed["robot"] = {k: v for k, v in normalised.get("robot", {}).items() if k != "urdf_file"}
    hashed["paths"] = [{k: v for k, v in p.items() if k != "file"} for p in normalised.get("paths", [])]
    return hashed


@dataclasses.dataclass(frozen=True)
class Chunk:
    """Consecutive rows of one group: the unit that is computed, written and resumed."""

    id: int
    group: int
    rows: tuple[int, ...]


@dataclasses.dataclass(frozen=True, eq=False)
class SweepPlan:
    """A validated, expanded sweep. Everything a worker needs (picklable; no open files).

    Attributes:
        kind: ``"shape"`` or ``"csc"``.
        name: label.
        robot: the :class:`~jaxstiff.robot.Robot`.
        robot_spec: the ``[robot]`` table as given (plus the resolved URDF file and its sha256,
            and the default locks where they applied).
        trajectories: the expanded paths.
        axes: axis name -> list of values (every axis of the kind, defaults filled in).
        settings: one dict per setting (axis -> value), in product order.
        rows: ``(setting_index, path_index)`` per row id.
        groups: per group, its static key as a dict (static axes + ``P``).
        row_group: group index of each row.
        chunks: the chunks, ids ``0..C-1``.
        options: ``[solver_options]``.
        seed, alpha_tol_deg, ratio_rel_tol: ``[sweep]`` settings.
        heatmaps: axis pairs of the report's heat maps.
        metrics: metrics shown in the heat maps.
        config: the normalised config (JSON-serialisable).
        config_text: the TOML text (empty for a dict config).
        source: the config file ("" for a dict).
        plan_hash: sha256 of everything that determines the results.
    """

    kind: str
    name: str
    robot: Any
    robot_spec: dict
    trajectories: tuple[Trajectory, ...]
    axes: dict[str, list]
    settings: tuple[dict, ...]
    rows: tuple[tuple[int, int], ...]
    groups: tuple[dict, ...]
    row_group: tuple[int, ...]
    chunks: tuple[Chunk, ...]
    options: dict
    seed: int
    alpha_tol_deg: float
    ratio_rel_tol: float
    heatmaps: tuple[tuple[str, str], ...]
    metrics: tuple[str, ...]
    config: dict
    config_text: str
    source: str
    plan_hash: str

    @property
    def n_rows(self) -> int:
        """Number of rows (settings x paths)."""
        return len(self.rows)

    def row_settings(self, row_id: int) -> dict:
        """Axis values of a row (a fresh dict)."""
        return dict(self.settings[self.rows[row_id][0]])

    def row_trajectory(self, row_id: int) -> Trajectory:
        """The path of a row."""
        return self.trajectories[self.rows[row_id][1]]

    def varying_axes(self) -> list[str]:
        """Axes with more than one value."""
        return [k for k, v in self.axes.items() if len(v) > 1]

    def describe(self) -> str:
        """A few lines: robot, paths, axes, rows, groups, chunks."""
        lines = [
            f"sweep {self.name!r} (kind {self.kind}): {self.n_rows} rows = {len(self.settings)} settings x "
            f"{len(self.trajectories)} paths; {len(self.groups)} groups, {len(self.chunks)} chunks",
            f"robot: {self.robot.name} ({self.robot.n} joints, {self.robot.n_free} free)",
            "paths: "
            + ", ".join(f"{t.name} (P={t.P})" for t in self.trajectories[:8])
            + (f", ... ({len(self.trajectories)} in all)" if len(self.trajectories) > 8 else ""),
        ]
        for k, v in self.axes.items():
            shown = "auto (0.3 with joint_limits on, else 0)" if v == [None] else _fmt_values(v)
            lines.append(f"  {k:16s} {shown}")
        return "\n".join(lines)


def _fmt_values(v: list) -> str:
    s = ", ".join(format_value(x) for x in v[:8])
    return s + (f", ... ({len(v)} values)" if len(v) > 8 else "")


# ---------------------------------------------------------------------------- expansion
def expand_rows(
    kind: str, axes: Mapping[str, list], trajectories: list[Trajectory]
) -> tuple[tuple[dict, ...], list[tuple[int, int]], list[int], tuple[dict, ...]]:
    """``(settings, rows, row_group, groups)``: the product of the axes (csc ``jl_gain`` None
    resolved per setting) times the paths, and the groups of rows sharing the static key."""
    names = list(AXES[kind])
    settings = tuple(dict(zip(names, combo, strict=True)) for combo in itertools.product(*(axes[k] for k in names)))
    if kind == "csc":
        for st in settings:
            if st["jl_gain"] is None:
                st["jl_gain"] = resolve_jl_gain(st["joint_limits"], None)
    static = [k for k in names if AXES[kind][k].static]
    rows, row_group, group_keys = [], [], {}
    for s_idx, st in enumerate(settings):
        for t in trajectories:
            key = json.dumps([[k, st[k]] for k in static] + [["P", t.P]], default=str)
            rows.append((s_idx, t.index))
            row_group.append(group_keys.setdefault(key, len(group_keys)))
    groups = tuple({**dict(json.loads(k)), "id": g} for k, g in group_keys.items())
    return settings, rows, row_group, groups


def _whole_setting_chunks(
    ids: list[int], rows: list[tuple[int, int]], g: int, chunk_size: int, chunks: list[Chunk]
) -> None:
    blocks: list[list[int]] = []  # runs of rows of one setting
    for r in ids:
        if blocks and rows[blocks[-1][0]][0] == rows[r][0]:
            blocks[-1].append(r)
        else:
            blocks.append([r])
    cur: list[int] = []
    for blk in blocks:
        if len(blk) > chunk_size:
            if cur:
                chunks.append(Chunk(id=len(chunks), group=g, rows=tuple(cur)))
                cur = []
            for i in range(0, len(blk), chunk_size):
                chunks.append(Chunk(id=len(chunks), group=g, rows=tuple(blk[i : i + chunk_size])))
            continue
        if cur and len(cur) + len(blk) > chunk_size:
            chunks.append(Chunk(id=len(chunks), group=g, rows=tuple(cur)))
            cur = []
        cur += blk
    if cur:
        chunks.append(Chunk(id=len(chunks), group=g, rows=tuple(cur)))


def cut_chunks(
    kind: str, rows: list[tuple[int, int]], row_group: list[int], n_groups: int, chunk_size: int
) -> list[Chunk]:
    """Each group's rows in chunks of at most ``chunk_size`` (kind "shape": whole settings per
    chunk as long as they fit, so every batched call of a group has the same number of paths)."""
    members: dict[int, list[int]] = {}
    for r, g in enumerate(row_group):
        members.setdefault(g, []).append(r)
    chunks: list[Chunk] = []
    for g in range(n_groups):
        ids = members[g]
        if kind == "shape":
            _whole_setting_chunks(ids, rows, g, chunk_size, chunks)
        else:
            for i in range(0, len(ids), chunk_size):
                chunks.append(Chunk(id=len(chunks), group=g, rows=tuple(ids[i : i + chunk_size])))
    return chunks


def _plan_hash(normalised: dict, robot: Any, trajectories: list[Trajectory]) -> str:
    """sha256 of what determines the results: the hashed config (file contents by sha256, not
    where they lie: a moved or symlinked sweep folder resumes), the robot and the path data."""
    h = hashlib.sha256()
    h.update(json.dumps(hashed_config(normalised), sort_keys=True, default=json_default).encode())
    h.update(repr(dataclasses.astuple(dataclasses.replace(robot, source=""))).encode())
    for t in trajectories:
        h.update(np.ascontiguousarray(t.points, dtype="<f8").tobytes())
        h.update(np.ascontiguousarray(t.directions, dtype="<f8").tobytes())
    return h.hexdigest()


def _check_chunk_size(rows: int, P: int, n: int, source: str) -> None:
    """Refuse a chunk (rows x waypoints x joints, held at once; the sweep streams chunk by chunk)
    that cannot fit in memory, naming ``sweep.chunk_size``."""
    from jaxstiff.runtime._plan_size import PlanTooLargeError, check_plan_size

    try:  # per waypoint and row: q, kj, their starts and bounds (n each) and ~30 reported values, float64
        check_plan_size(
            f"a chunk of {rows} rows x {P} waypoints ({n} joints)", rows * P, 8 * (6 * n + 30), "sweep.chunk_size"
        )
    except PlanTooLargeError as exc:
        raise SweepConfigError("sweep.chunk_size", str(exc), source) from None


def _axis_size(raw: Any) -> int:
    """How many values an ``[axes]`` entry will have, read from the raw TOML without making them
    (a range's ``num``, or its step count; a list's length; 1 for a single value or anything
    malformed, which the full check refuses with its own message)."""
    if isinstance(raw, list):
        return max(1, len(raw))
    if not isinstance(raw, Mapping):
        return 1
    num, start, stop, step = (raw.get(k) for k in ("num", "start", "stop", "step"))
    if isinstance(num, int) and not isinstance(num, bool):
        return max(1, num)
    reals = [float(x) for x in (start, stop, step) if isinstance(x, (int, float)) and not isinstance(x, bool)]
    if len(reals) != 3 or not all(math.isfinite(x) for x in reals):
        return 1
    a, b, d = reals
    return int(math.floor((b - a) / d + 1e-9)) + 1 if d != 0 and (b - a) * d >= 0 else 1


def _count_rows_first(raw_axes: Any, n_paths: int, source: str) -> None:
    """Refuse a sweep of more than MAX_ROWS rows from the product of its axis sizes and paths,
    before any axis is expanded (a 6-million-value range took a minute and 1.4 GB to refuse)."""
    if not isinstance(raw_axes, Mapping):
        return
    sizes = {k: _axis_size(v) for k, v in raw_axes.items()}
    if any(n > MAX_ROWS for n in sizes.values()):
        return  # one axis alone: its own check names it (axes.KEY), before it makes any value
    n_rows = math.prod(sizes.values()) * n_paths
    if n_rows > MAX_ROWS:
        big = " x ".join(f"{k} {n}" for k, n in sizes.items() if n > 1)
        raise SweepConfigError(
            "axes",
            f"the sweep would expand to {n_rows} rows ({big} x {n_paths} paths); the limit is {MAX_ROWS}",
            source,
        )


# ---------------------------------------------------------------------------- entry points
def load_config(file: str | os.PathLike) -> SweepPlan:
    """Read, validate and expand a sweep TOML file.

    Raises:
        FileNotFoundError: the config file does not exist.
        SweepConfigError: anything wrong in it (the message names the key and the problem).
    """
    file = os.fspath(file)
    if not os.path.exists(file):
        raise FileNotFoundError(f"sweep config not found: {file}")
    check_regular_file(file, "sweep config")  # (a folder, FIFO or device: "is not a regular file")
    try:
        import tomllib
    except ModuleNotFoundError:  # Python 3.10
        try:
            import tomli as tomllib  # type: ignore[no-redef]
        except ModuleNotFoundError:
            raise SweepConfigError("", "reading TOML needs Python >= 3.11 or the package 'tomli'", file) from None
    with open(file, "rb") as fh:
        raw = fh.read()
    try:
        text = raw.decode("utf-8")
        cfg = tomllib.loads(text)
    except UnicodeDecodeError:
        raise SweepConfigError("", "not a UTF-8 text file", file) from None
    except tomllib.TOMLDecodeError as exc:
        raise SweepConfigError("", f"not valid TOML: {exc}", file) from None
    return parse_config(cfg, base_dir=os.path.dirname(os.path.abspath(file)), source=file, text=text)


def parse_config(
    cfg: Mapping[str, Any], base_dir: str | os.PathLike = ".", source: str = "", text: str = ""
) -> SweepPlan:
    """Validate and expand a config given as a dict (the parsed TOML).

    Args:
        cfg: the config tables.
        base_dir: folder that relative file names (URDF, CSV) are resolved against.
        source: name used in messages (the file).
        text: the TOML text (copied into the store).

    Raises:
        SweepConfigError: naming the key and the problem.
    """
    base_dir = os.fspath(base_dir)
    cfg = check_table(cfg, "config", source)
    known_keys(cfg, TOP_KEYS, "", source)
    sweep = validate(SweepTable, cfg.get("sweep", {}), "sweep", source)
    kind = sweep.kind
    name = (
        sweep.name if sweep.name is not None else (os.path.splitext(os.path.basename(source))[0] if source else "sweep")
    )
    chunk_size = sweep.chunk_size if sweep.chunk_size is not None else DEFAULT_CHUNK[kind]
    robot, robot_spec = build_robot(cfg, base_dir, source)
    trajectories = read_paths(cfg, kind, base_dir, source)
    _count_rows_first(cfg.get("axes", {}), len(trajectories), source)
    axes = axes_table(cfg.get("axes", {}), kind, robot, source)
    cross_checks(kind, axes, trajectories, robot, source)
    options = solver_options(cfg, axes, source)
    heatmaps, metrics = report_choices(cfg, kind, axes, len(trajectories), source)
    n_rows = math.prod(len(v) for v in axes.values()) * len(trajectories)
    if n_rows > MAX_ROWS:
        raise SweepConfigError("axes", f"the sweep expands to {n_rows} rows; the limit is {MAX_ROWS}", source)
    _check_chunk_size(min(chunk_size, n_rows), max(t.P for t in trajectories), robot.n, source)
    settings, rows, row_group, groups = expand_rows(kind, axes, trajectories)
    chunks = cut_chunks(kind, rows, row_group, len(groups), chunk_size)
    normalised = {
        "sweep": {
            "kind": kind,
            "name": name,
            "chunk_size": chunk_size,
            "seed": sweep.seed,
            "alpha_tol_deg": float(sweep.alpha_tol_deg),
            "ratio_rel_tol": float(sweep.ratio_rel_tol),
            "description": sweep.description,
        },
        "robot": robot_spec,
        "paths": [{"name": t.name, "P": t.P, **t.spec} for t in trajectories],
        "axes": axes,
        "solver_options": options,
        "report": {"heatmaps": [list(p) for p in heatmaps], "metrics": list(metrics)},
    }
    return SweepPlan(
        kind=kind,
        name=name,
        robot=robot,
        robot_spec=robot_spec,
        trajectories=tuple(trajectories),
        axes=axes,
        settings=settings,
        rows=tuple(rows),
        groups=groups,
        row_group=tuple(row_group),
        chunks=tuple(chunks),
        options=options,
        seed=sweep.seed,
        alpha_tol_deg=float(sweep.alpha_tol_deg),
        ratio_rel_tol=float(sweep.ratio_rel_tol),
        heatmaps=heatmaps,
        metrics=metrics,
        config=normalised,
        config_text=text,
        source=source,
        plan_hash=_plan_hash(normalised, robot, trajectories),
    )
