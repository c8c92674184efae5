"""Sweep configuration: parse and validate a TOML file, expand it into rows, groups and chunks.

A sweep is a grid of (trajectory x setting) *rows*. The TOML file names the robot, the paths
(CSV files or generators whose parameters may be lists or ranges) and the parameter *axes*; every
combination of axis values is one *setting*, and every setting is run on every trajectory.

Everything is checked here, before any work starts; every problem raises
:class:`SweepConfigError` whose message names the key (``axes.ratio``, ``paths[1].radius``,
``robot.name``) and the problem.

Layout of a config (every table but ``[robot]`` and ``[[paths]]`` is optional)::

    [sweep]
    kind = "shape"            # "shape" (jaxstiff.shape, seed 000) or "csc" (jaxstiff.csc_rollout, seed 001)
    name = "quick"            # label (default: the file name)
    chunk_size = 16           # rows per chunk: the unit that is computed, saved and resumed
    seed = 0                  # seed of every random choice (q0 = "random")
    alpha_tol_deg = 1.0       # summary metrics: a waypoint is aligned when alpha < this (degrees)
    ratio_rel_tol = 0.02      # ... and reaches the ratio when |rho - r| / r < this (f1: rho >= (1 - tol) r)

    [robot]                   # name = a shipped robot, or urdf = a file (relative to this TOML)
    name = "kuka_lwr4"
    locked = { lwr_a7 = 0.0 } # rad
    tcp = [0.0, 0.0, 0.0]     # m, in the tip frame (or a 4x4 transform)
    # base_link = "...", tip_link = "..."

    [[paths]]                 # a CSV file (x,y,z[,dx,dy,dz]), relative to this TOML
    file = "my_path.csv"

    [[paths]]                 # a generator of jaxstiff.paths; a list or range = one path per value
                              # (several lists: every combination, or pairwise with zip = true)
    generator = "arc"
    center = [0.5, 0.0, 0.35]
    radius = [0.08, 0.12]
    start_deg = 0.0
    end_deg = { start = 30.0, stop = 90.0, num = 3 }
    n = 8

    [axes]                    # a value, a list of values, or a range {start, stop, num | step}
    criterion = ["f1", "f2"]
    ratio = { start = 2.0, stop = 6.0, num = 5 }
    dq_deg = [1.0, 2.0]

    [solver_options]          # passed to the solver (SLSQP: maxiter, ftol, kj_scale, f_scale)

    [report]
    heatmaps = [["ratio", "dq_deg"]]   # axis pairs of the heat maps ("path" too; default: up to 6 pairs of varying axes)

Ranges: ``{start, stop, num}`` is ``numpy.linspace(start, stop, num)``; ``{start, stop, step}``
runs from start by step up to stop inclusive (within 1e-9 of a step). Values that differ from a
short decimal by a few units in the last place (the round-off of ``start + i * step``:
1.2000000000000002) are stored as that decimal (1.2); an integer axis refuses a range whose
values are not integers.

Axes of kind ``"shape"`` (see :data:`AXES`): criterion, task, solver, starts, ratio, c, dq_deg, dk,
kmin, kmax, first_rate_limit, first_starts, q0, q0_seed. Axes of kind ``"csc"``: task, step, kmin, kmax,
newton, joint_limits, jl_gain, beta, kxd_major, kxd_ratio, kxd_angle_deg, q0, q0_seed.

q0 family (both kinds): ``"ik"`` (damped least-squares IK from the nominal posture to the path's
first waypoint, shape's own default), ``"nominal"`` (the nominal posture itself), ``"random"``
(IK from a posture drawn uniformly inside the joint limits with seed ``(seed, q0_seed, path)``:
different self-motion postures), or an explicit posture ``[q_1, ..., q_n]`` in rad (write a list
of postures, ``q0 = [[...], [...]]``).

Rows are numbered setting-major: ``row_id = setting_index * n_paths + path_index``, with the
settings in ``itertools.product`` order of the axes in the order of :data:`AXES`. Rows that share
the *static* axes (those that change a compiled shape or a solver's structure: criterion, task,
solver, starts for "shape"; task, step, kmin, kmax, newton, joint_limits, jl_gain for "csc") and the
number of waypoints form a *group*; each group is cut into chunks of at most ``chunk_size``
consecutive rows (kind "shape": whole settings, i.e. all paths of a setting, as long as they fit, so
that every batched call of a group has the same batch size and compiles once).
The plan, and so every row's result, depends only on the config, never on timing.

Example:
    >>> from jaxstiff.sweep_config import load_config
    >>> plan = load_config("experiments/sweeps/quick.toml")     # doctest: +SKIP
    >>> len(plan.rows), len(plan.chunks)                        # doctest: +SKIP
    (312, 6)
"""

from __future__ import annotations

import dataclasses
import difflib
import hashlib
import inspect
import itertools
import json
import math
import os
import warnings
from typing import Any, Callable, Mapping, Sequence

import numpy as np

from jaxstiff.runtime.io import json_default as _json_default

__all__ = [
    "SweepConfigError",
    "AxisSpec",
    "AXES",
    "GENERATORS",
    "Trajectory",
    "Chunk",
    "SweepPlan",
    "load_config",
    "parse_config",
    "kxd_matrix",
]

KINDS = ("shape", "csc")
_TOP_KEYS = ("sweep", "robot", "paths", "axes", "solver_options", "report")
_SWEEP_KEYS = ("kind", "name", "description", "chunk_size", "seed", "alpha_tol_deg", "ratio_rel_tol")
_ROBOT_KEYS = ("name", "urdf", "locked", "tcp", "base_link", "tip_link")
_REPORT_KEYS = ("heatmaps", "metrics")
_DEFAULT_CHUNK = {"shape": 16, "csc": 64}
_MAX_ROWS = 10_000_000


def _short_float(x: float) -> float:
    """``x``, or the shortest decimal of at most 12 significant digits within 8 units in the last
    place of it (range round-off: 1.2000000000000002 -> 1.2; 1/3 stays 1/3)."""
    for digits in range(1, 13):
        y = float(f"{x:.{digits}g}")
        if abs(y - x) <= 8 * np.spacing(abs(x)):
            return y
    return x


def hashed_config(normalised: dict) -> dict:
    """The part of a normalised config (``plan.config``) that the plan hash sees: not where the
    files lie (``robot.urdf_file``, the paths' ``file``; their sha256 and data count), not the
    report section (it does not change results)."""
    hashed = {k: v for k, v in normalised.items() if k != "report"}
    hashed["robot"] = {k: v for k, v in normalised.get("robot", {}).items() if k != "urdf_file"}
    hashed["paths"] = [{k: v for k, v in p.items() if k != "file"} for p in normalised.get("paths", [])]
    return hashed


class SweepConfigError(ValueError):
    """A bad sweep config. ``key`` is the offending key (``"axes.ratio"``), ``str(err)`` says why."""

    def __init__(self, key: str, problem: str, source: str = ""):
        self.key = key
        self.problem = problem
        self.source = source
        where = f"{source}: " if source else ""
        super().__init__(f"{where}{key}: {problem}" if key else f"{where}{problem}")


# ---------------------------------------------------------------------------- axis specifications
@dataclasses.dataclass(frozen=True)
class AxisSpec:
    """One parameter axis of a sweep kind.

    Attributes:
        name: the key under ``[axes]`` and the column of the results table.
        type: ``"float"``, ``"int"``, ``"str"``, ``"bool"`` or ``"q0"``.
        default: the value when the axis is not given.
        static: part of the group key (changes a compiled shape or the solver structure).
        unit: unit of the values ("" if none).
        doc: one line for ``--help`` and the report.
        choices: allowed strings (``"str"`` axes), or a function returning them (registries).
        check: ``check(value) -> problem text or None`` for numbers.
    """

    name: str
    type: str
    default: Any
    static: bool = False
    unit: str = ""
    doc: str = ""
    choices: Sequence[str] | Callable[[], Sequence[str]] | None = None
    check: Callable[[Any], str | None] | None = None

    def allowed(self) -> list[str] | None:
        if self.choices is None:
            return None
        return list(self.choices() if callable(self.choices) else self.choices)


def _gt(x0: float, what: str = "") -> Callable[[Any], str | None]:
    return lambda v: None if v > x0 else f"must be > {x0:g}{what}, got {v!r}"


def _ge(x0: float, what: str = "") -> Callable[[Any], str | None]:
    return lambda v: None if v >= x0 else f"must be >= {x0:g}{what}, got {v!r}"


def _finite(v) -> str | None:
    return None if math.isfinite(v) else f"must be finite, got {v!r}"


def _criteria() -> list[str]:
    from jaxstiff.stiffness.criteria import CRITERIA

    return sorted(CRITERIA)


def _solvers() -> list[str]:
    from jaxstiff.shaping import SOLVERS

    return sorted(SOLVERS)


def _q0_spec() -> AxisSpec:
    return AxisSpec("q0", "q0", "ik", doc='start posture: "ik", "nominal", "random" or [q_1..q_n] rad')


def _q0_seed_spec() -> AxisSpec:
    return AxisSpec("q0_seed", "int", 0, check=_ge(0), doc='seed index of q0 = "random" postures')


#: The axes of each sweep kind, in the order rows are enumerated (:func:`itertools.product`).
AXES: dict[str, dict[str, AxisSpec]] = {
    "shape": {
        a.name: a
        for a in (
            AxisSpec("criterion", "str", "f2", static=True, choices=_criteria, doc="shaping criterion (S0-9 f1, S0-15 f2)"),
            AxisSpec("task", "str", "full", static=True, choices=("full", "xyz", "xy"), doc="task rows of K_T (SPEC 2)"),
            AxisSpec("solver", "str", "slsqp", static=True, choices=_solvers, doc="solver of jaxstiff.shape"),
            AxisSpec("starts", "int", 0, static=True, check=_ge(0), doc="starts per waypoint (0: the solver's default; SLSQP: 1)"),
            AxisSpec("ratio", "float", 5.0, check=_gt(1.0, " (lambda1 / lambda2)"), doc="wanted axis ratio r"),
            AxisSpec("c", "float", 0.01, check=_ge(0.0), doc="offset c of f1 (S0-9)"),
            AxisSpec("dq_deg", "float", 2.0, unit="deg per waypoint", check=_ge(0.0),
                     doc="joint rate limit (S0-11, S0-12); a prismatic joint gets the same number in m (3 deg -> 0.0524 m)"),
            AxisSpec("dk", "float", 5.0, unit="Nm/rad per waypoint", check=_ge(0.0), doc="stiffness rate limit (S0-13, S0-14)"),
            AxisSpec("kmin", "float", 1.0, unit="Nm/rad", check=_gt(0.0), doc="lower stiffness bound"),
            AxisSpec("kmax", "float", 100.0, unit="Nm/rad", check=_gt(0.0), doc="upper stiffness bound"),
            AxisSpec("first_rate_limit", "bool", False, doc="apply the rate limits between (q0, kj0) and waypoint 0"),
            AxisSpec("first_starts", "int", 8, check=_ge(1), doc="IK start postures tried at the first waypoint (no rate limit)"),
            _q0_spec(),
            _q0_seed_spec(),
        )
    },
    "csc": {
        a.name: a
        for a in (
            AxisSpec("task", "str", "xyz", static=True, choices=("xy", "xyz"), doc="task rows (K_xd is 2x2 or 3x3)"),
            AxisSpec("step", "str", "adaptive", static=True, choices=("adaptive", "constant"), doc="null-step rule (S1-22 or constant)"),
            AxisSpec("kmin", "float", 1.0, static=True, unit="Nm/rad", check=_gt(0.0), doc="actuator range, lower"),
            AxisSpec("kmax", "float", math.inf, static=True, unit="Nm/rad", check=_gt(0.0), doc="actuator range, upper (inf: open)"),
            AxisSpec("newton", "int", 0, static=True, check=_ge(0), doc="Newton corrections per step"),
            AxisSpec("joint_limits", "str", "off", static=True, choices=("off", "priority", "sum"), doc="joint-limit secondary task"),
            AxisSpec("jl_gain", "float", 0.0, static=True, check=_ge(0.0), doc="joint-limit gain"),
            AxisSpec("beta", "float", 0.5, check=lambda v: _ge(0.0)(v) or _finite(v), doc="null-step multiplier beta (S1-22)"),
            AxisSpec("kxd_major", "float", 3000.0, unit="N/m", check=lambda v: _gt(0.0)(v) or _finite(v), doc="K_xd major axis"),
            AxisSpec("kxd_ratio", "float", 3.0, check=lambda v: _ge(1.0)(v) or _finite(v), doc="K_xd major / minor axis"),
            AxisSpec("kxd_angle_deg", "float", 30.0, unit="deg", check=_finite, doc="K_xd major axis angle about base z"),
            _q0_spec(),
            _q0_seed_spec(),
        )
    },
}


def kxd_matrix(task: str, major: float, ratio: float, angle_deg: float) -> np.ndarray:
    """Desired Cartesian stiffness of a CSC sweep row, N/m.

    ``"xy"``: ``R(theta) diag(major, major / ratio) R(theta)^T`` (2x2), the form of seed 001's
    planar example (R(30 deg) diag(3000, 1000) R(30 deg)^T). ``"xyz"``: ``R_z(theta) diag(major,
    major / ratio, major / ratio) R_z(theta)^T`` (3x3): the major axis in the horizontal plane at
    angle theta from base x.
    """
    t = math.radians(angle_deg)
    c, s = math.cos(t), math.sin(t)
    if task == "xy":
        R = np.array([[c, -s], [s, c]])
        D = np.diag([major, major / ratio])
    else:
        R = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
        D = np.diag([major, major / ratio, major / ratio])
    K = R @ D @ R.T
    return 0.5 * (K + K.T)


def _csc_directions(points: np.ndarray, given) -> np.ndarray:
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


# ---------------------------------------------------------------------------- path generators
def _point_path(point, n: int = 20, direction=(1.0, 0.0, 0.0)):
    """A path that holds one point for ``n`` waypoints (CSC "hold" studies); directions constant."""
    from jaxstiff.paths import Path

    p = np.asarray(point, dtype=float)
    d = np.asarray(direction, dtype=float)
    if int(n) < 2:
        raise ValueError(f"a path needs at least 2 waypoints, got n = {n}")
    return Path(np.tile(p, (int(n), 1)), np.tile(d, (int(n), 1)), name="point")


def _generator_fns() -> dict[str, Callable]:
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


#: Parameter types of each path generator: ``"float"``, ``"int"``, ``"vec3"``, ``"points"``.
#: Scalar parameters accept a list or a range (one path per value), vec3 ones a list of vectors.
GENERATORS: dict[str, dict[str, str]] = {
    "default": {"n": "int"},
    "line": {"start": "vec3", "end": "vec3", "n": "int"},
    "arc": {"center": "vec3", "radius": "float", "start_deg": "float", "end_deg": "float", "n": "int", "normal": "vec3"},
    "circle": {"center": "vec3", "radius": "float", "n": "int", "normal": "vec3"},
    "half_sine": {"start": "vec3", "end": "vec3", "amplitude": "float", "n": "int", "periods": "float", "normal": "vec3"},
    "spline": {"points": "points", "n": "int"},
    "point": {"point": "vec3", "n": "int", "direction": "vec3"},
}


# ---------------------------------------------------------------------------- plan containers
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
        return int(self.points.shape[0])


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
        robot_spec: the ``[robot]`` table as given (plus the resolved URDF file and its sha256).
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
        return len(self.rows)

    def row_settings(self, row_id: int) -> dict:
        """Axis values of a row (a fresh dict)."""
        return dict(self.settings[self.rows[row_id][0]])

    def row_trajectory(self, row_id: int) -> Trajectory:
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
            "paths: " + ", ".join(f"{t.name} (P={t.P})" for t in self.trajectories[:8])
            + (f", ... ({len(self.trajectories)} in all)" if len(self.trajectories) > 8 else ""),
        ]
        for k, v in self.axes.items():
            lines.append(f"  {k:16s} {_fmt_values(v)}")
        return "\n".join(lines)


def _fmt_values(v: list) -> str:
    s = ", ".join(_fmt_value(x) for x in v[:8])
    return s + (f", ... ({len(v)} values)" if len(v) > 8 else "")


def _fmt_value(x) -> str:
    if isinstance(x, float):
        return f"{x:g}"
    if isinstance(x, (list, tuple)):
        return "[" + ", ".join(f"{float(e):g}" for e in x) + "]"
    return str(x)


# ---------------------------------------------------------------------------- entry points
def load_config(file: str | os.PathLike) -> SweepPlan:
    """Read, validate and expand a sweep TOML file.

    Raises:
        FileNotFoundError: the config file does not exist.
        SweepConfigError: anything wrong in it (the message names the key and the problem).
    """
    file = os.fspath(file)
    if not os.path.isfile(file):
        raise FileNotFoundError(f"sweep config not found: {file}")
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


def parse_config(cfg: Mapping[str, Any], base_dir: str | os.PathLike = ".", source: str = "", text: str = "") -> SweepPlan:
    """Validate and expand a config given as a dict (the parsed TOML).

    Args:
        cfg: the config tables.
        base_dir: folder that relative file names (URDF, CSV) are resolved against.
        source: name used in messages (the file).
        text: the TOML text (copied into the store).

    Raises:
        SweepConfigError: naming the key and the problem.
    """
    return _Parser(cfg, os.fspath(base_dir), source, text).plan()


# ---------------------------------------------------------------------------- the parser
def _typename(v) -> str:
    return {bool: "bool", int: "integer", float: "float", str: "string", list: "list", dict: "table"}.get(type(v), type(v).__name__)


def _suggest(word: str, options: Sequence[str]) -> str:
    close = difflib.get_close_matches(str(word), list(options), n=1, cutoff=0.6)
    return f"; did you mean {close[0]!r}?" if close else ""


class _Parser:
    def __init__(self, cfg, base_dir: str, source: str, text: str):
        self.cfg = cfg
        self.base_dir = base_dir
        self.source = source
        self.text = text

    def err(self, key: str, problem: str) -> SweepConfigError:
        return SweepConfigError(key, problem, self.source)

    # ------------------------------------------------------------------ helpers
    def table(self, value, key: str) -> dict:
        if not isinstance(value, Mapping):
            raise self.err(key, f"expected a table, got {_typename(value)} {value!r}")
        return dict(value)

    def known_keys(self, tbl: Mapping, allowed: Sequence[str], key: str, extra: str = "") -> None:
        for k in tbl:
            if k not in allowed:
                where = f"{key}.{k}" if key else k
                raise self.err(where, f"unknown key{_suggest(k, allowed)} (allowed: {', '.join(allowed)}){extra}")

    def number(self, v, key: str, integer: bool = False) -> float | int:
        if isinstance(v, bool) or not isinstance(v, (int, float)) or (integer and not isinstance(v, int)):
            want = "an integer" if integer else "a number"
            raise self.err(key, f"expected {want}, got {_typename(v)} {v!r}")
        if not integer and math.isnan(v):
            raise self.err(key, "NaN is not allowed")
        return int(v) if integer else float(v)

    def vec3(self, v, key: str) -> list[float]:
        if not isinstance(v, list) or len(v) != 3:
            raise self.err(key, f"expected 3 numbers [x, y, z] (m), got {v!r}")
        out = [self.number(x, f"{key}[{i}]") for i, x in enumerate(v)]
        if not all(math.isfinite(x) for x in out):
            raise self.err(key, f"values must be finite, got {v!r}")
        return out

    def range_values(self, v: dict, key: str, integer: bool) -> list:
        self.known_keys(v, ("start", "stop", "num", "step"), key, " (a range is {start, stop, num} or {start, stop, step})")
        for need in ("start", "stop"):
            if need not in v:
                raise self.err(key, f"a range needs '{need}' (write {{start = ..., stop = ..., num = ...}})")
        if ("num" in v) == ("step" in v):
            raise self.err(key, "a range needs exactly one of 'num' and 'step'")
        start = self.number(v["start"], f"{key}.start", integer)
        stop = self.number(v["stop"], f"{key}.stop", integer)
        if not (math.isfinite(start) and math.isfinite(stop)):
            raise self.err(key, "range start and stop must be finite")
        if "num" in v:
            num = self.number(v["num"], f"{key}.num", integer=True)
            if num < 1:
                raise self.err(key, f"empty axis: a range needs num >= 1, got num = {num}")
            if num > _MAX_ROWS:
                raise self.err(key, f"range has num = {num} values; the limit is {_MAX_ROWS}")
            vals = np.linspace(start, stop, num)
        else:
            step = self.number(v["step"], f"{key}.step", integer)
            if step == 0 or not math.isfinite(step) or (stop - start) * step < 0:
                raise self.err(key, f"range step {step!r} does not lead from {start!r} to {stop!r}")
            count = int(math.floor((stop - start) / step + 1e-9)) + 1
            if count > _MAX_ROWS:
                raise self.err(key, f"range has {count} values; that is too many")
            vals = start + step * np.arange(count)
        if integer:
            if not np.allclose(vals, np.round(vals), rtol=0, atol=1e-9):
                shown = ", ".join(f"{x:g}" for x in vals[:6]) + (", ..." if len(vals) > 6 else "")
                raise self.err(key, f"an integer axis: this range gives values that are not integers ({shown}); "
                                    "give {start, stop, step} or a list")
            return [int(round(x)) for x in vals]
        return [_short_float(float(x)) for x in vals]

    # ------------------------------------------------------------------ plan
    def plan(self) -> SweepPlan:
        cfg = self.table(self.cfg, "config")
        self.known_keys(cfg, _TOP_KEYS, "")
        sweep = self.table(cfg.get("sweep", {}), "sweep")
        self.known_keys(sweep, _SWEEP_KEYS, "sweep")

        kind = sweep.get("kind", "shape")
        if kind not in KINDS:
            raise self.err("sweep.kind", f"unknown kind {kind!r}{_suggest(str(kind), KINDS)}; choose one of {', '.join(KINDS)}")
        name = sweep.get("name", os.path.splitext(os.path.basename(self.source))[0] if self.source else "sweep")
        if not isinstance(name, str) or not name.strip():
            raise self.err("sweep.name", f"expected a non-empty string, got {name!r}")
        if "description" in sweep and not isinstance(sweep["description"], str):
            raise self.err("sweep.description", f"expected a string, got {_typename(sweep['description'])}")
        chunk_size = self.number(sweep.get("chunk_size", _DEFAULT_CHUNK[kind]), "sweep.chunk_size", integer=True)
        if chunk_size < 1:
            raise self.err("sweep.chunk_size", f"must be >= 1, got {chunk_size}")
        seed = self.number(sweep.get("seed", 0), "sweep.seed", integer=True)
        if seed < 0:
            raise self.err("sweep.seed", f"must be >= 0, got {seed}")
        alpha_tol = self.number(sweep.get("alpha_tol_deg", 1.0), "sweep.alpha_tol_deg")
        if not 0 < alpha_tol <= 90:
            raise self.err("sweep.alpha_tol_deg", f"must be in (0, 90] degrees, got {alpha_tol}")
        ratio_tol = self.number(sweep.get("ratio_rel_tol", 0.02), "sweep.ratio_rel_tol")
        if not 0 < ratio_tol < 1:
            raise self.err("sweep.ratio_rel_tol", f"must be in (0, 1), got {ratio_tol}")

        robot, robot_spec = self.robot(cfg)
        trajectories = self.paths(cfg, kind)
        axes = self.axes(cfg, kind, robot)
        self.cross_checks(kind, axes, trajectories, robot)
        options = self.options(cfg, axes)
        heatmaps, metrics = self.report(cfg, kind, axes, len(trajectories))

        # ---- expansion
        names = list(AXES[kind])
        n_settings = math.prod(len(axes[k]) for k in names)
        n_rows = n_settings * len(trajectories)
        if n_rows > _MAX_ROWS:
            raise self.err("axes", f"the sweep expands to {n_rows} rows; the limit is {_MAX_ROWS}")
        settings = tuple(dict(zip(names, combo)) for combo in itertools.product(*(axes[k] for k in names)))
        static = [k for k in names if AXES[kind][k].static]
        rows, row_group, group_keys = [], [], {}
        for s_idx, st in enumerate(settings):
            for t in trajectories:
                key = json.dumps([[k, st[k]] for k in static] + [["P", t.P]], default=str)
                g = group_keys.setdefault(key, len(group_keys))
                rows.append((s_idx, t.index))
                row_group.append(g)
        groups = tuple({**dict(json.loads(k)), "id": g} for k, g in group_keys.items())
        chunks: list[Chunk] = []
        members: dict[int, list[int]] = {}
        for r, g in enumerate(row_group):
            members.setdefault(g, []).append(r)
        for g in range(len(groups)):
            ids = members[g]
            if kind == "shape":
                # whole settings per chunk: every batched call then has the same number of paths
                # (one compilation per group for batched solvers)
                blocks: list[list[int]] = []
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
            else:
                for i in range(0, len(ids), chunk_size):
                    chunks.append(Chunk(id=len(chunks), group=g, rows=tuple(ids[i : i + chunk_size])))

        normalised = {
            "sweep": {"kind": kind, "name": name, "chunk_size": chunk_size, "seed": seed,
                      "alpha_tol_deg": alpha_tol, "ratio_rel_tol": ratio_tol,
                      "description": sweep.get("description", "")},
            "robot": robot_spec,
            "paths": [{"name": t.name, "P": t.P, **t.spec} for t in trajectories],
            "axes": axes,
            "solver_options": options,
            "report": {"heatmaps": [list(p) for p in heatmaps], "metrics": list(metrics)},
        }
        # the hash sees the files' contents (sha256), not where they lie: a moved or copied sweep
        # folder (or a symlinked one) resumes; the report section does not change results
        hashed = hashed_config(normalised)
        h = hashlib.sha256()
        h.update(json.dumps(hashed, sort_keys=True, default=_json_default).encode())
        h.update(repr(dataclasses.astuple(dataclasses.replace(robot, source=""))).encode())
        for t in trajectories:
            h.update(np.ascontiguousarray(t.points, dtype="<f8").tobytes())
            h.update(np.ascontiguousarray(t.directions, dtype="<f8").tobytes())
        return SweepPlan(
            kind=kind, name=name, robot=robot, robot_spec=robot_spec, trajectories=tuple(trajectories),
            axes=axes, settings=settings, rows=tuple(rows), groups=groups, row_group=tuple(row_group),
            chunks=tuple(chunks), options=options, seed=seed, alpha_tol_deg=alpha_tol, ratio_rel_tol=ratio_tol,
            heatmaps=heatmaps, metrics=metrics, config=normalised, config_text=self.text, source=self.source,
            plan_hash=h.hexdigest(),
        )

    # ------------------------------------------------------------------ [robot]
    def robot(self, cfg):
        from jaxstiff.results.files import file_sha256
        from jaxstiff.model.robot import Robot, robot_path, shipped_robots

        if "robot" not in cfg:
            raise self.err("robot", "missing table [robot] (give name = a shipped robot, or urdf = a file)")
        tbl = self.table(cfg["robot"], "robot")
        self.known_keys(tbl, _ROBOT_KEYS, "robot")
        if ("name" in tbl) == ("urdf" in tbl):
            raise self.err("robot", "give exactly one of 'name' (a shipped robot) and 'urdf' (a file)")
        if "name" in tbl:
            nm = tbl["name"]
            if not isinstance(nm, str):
                raise self.err("robot.name", f"expected a string, got {_typename(nm)} {nm!r}")
            shipped = shipped_robots()
            if nm.removesuffix(".urdf") not in shipped:
                raise self.err("robot.name", f"unknown robot {nm!r}{_suggest(nm, shipped)}; shipped robots: {', '.join(shipped)}")
            urdf = robot_path(nm)
        else:
            u = tbl["urdf"]
            if not isinstance(u, str):
                raise self.err("robot.urdf", f"expected a file name, got {_typename(u)} {u!r}")
            urdf = u if os.path.isabs(u) else os.path.join(self.base_dir, u)
            if not os.path.isfile(urdf):
                raise self.err("robot.urdf", f"file not found: {urdf}")
        locked = None
        if "locked" in tbl:
            lt = self.table(tbl["locked"], "robot.locked")
            locked = {str(k): self.number(v, f"robot.locked.{k}") for k, v in lt.items()}
        tcp = None
        if "tcp" in tbl:
            t = tbl["tcp"]
            if isinstance(t, list) and len(t) == 4 and all(isinstance(r, list) for r in t):
                tcp = [[self.number(x, f"robot.tcp[{i}][{j}]") for j, x in enumerate(r)] for i, r in enumerate(t)]
            else:
                tcp = self.vec3(t, "robot.tcp")
        links = {}
        for k in ("base_link", "tip_link"):
            if k in tbl:
                if not isinstance(tbl[k], str):
                    raise self.err(f"robot.{k}", f"expected a link name, got {_typename(tbl[k])}")
                links[k] = tbl[k]
        try:
            robot = Robot.from_urdf(urdf, locked=locked, tcp=None if tcp is None else np.asarray(tcp), **links)
        except (ValueError, FileNotFoundError) as exc:
            key = ("robot.locked" if locked and "lock" in str(exc).lower()
                   else "robot.tcp" if tcp is not None and str(exc).startswith("tcp") else "robot")
            raise self.err(key, str(exc)) from None
        spec = {k: tbl[k] for k in tbl}
        spec.update({"urdf_file": os.path.abspath(urdf), "urdf_sha256": file_sha256(urdf)})
        return robot, spec

    # ------------------------------------------------------------------ [[paths]]
    def paths(self, cfg, kind: str = "shape") -> list[Trajectory]:
        from jaxstiff.paths import Path, read_csv

        if "paths" not in cfg:
            raise self.err("paths", "missing: give at least one [[paths]] table (file = CSV, or generator = ...)")
        plist = cfg["paths"]
        if isinstance(plist, Mapping):
            plist = [plist]
        if not isinstance(plist, list) or not plist:
            raise self.err("paths", "expected one or more [[paths]] tables")
        out: list[Trajectory] = []
        for i, entry in enumerate(plist):
            key = f"paths[{i}]"
            tbl = self.table(entry, key)
            if ("file" in tbl) == ("generator" in tbl):
                raise self.err(key, "give exactly one of 'file' (a CSV path) and 'generator' (one of " + ", ".join(GENERATORS) + ")")
            label = tbl.get("name")
            if label is not None and (not isinstance(label, str) or not label):
                raise self.err(f"{key}.name", f"expected a non-empty string, got {label!r}")
            if "file" in tbl:
                self.known_keys(tbl, ("file", "name"), key)
                f = tbl["file"]
                if not isinstance(f, str):
                    raise self.err(f"{key}.file", f"expected a file name, got {_typename(f)} {f!r}")
                fp = f if os.path.isabs(f) else os.path.join(self.base_dir, f)
                if not os.path.isfile(fp):
                    raise self.err(f"{key}.file", f"path file not found: {fp}")
                try:
                    if kind == "csc":  # points only: a CSC rollout may hold still (repeated rows)
                        pts, dirs, _ = read_csv(fp)
                        dirs = _csc_directions(pts, dirs)
                    else:
                        p = Path.from_csv(fp)
                        pts, dirs = p.points, p.directions
                except (ValueError, FileNotFoundError) as exc:
                    raise self.err(f"{key}.file", str(exc)) from None
                from jaxstiff.results.files import file_sha256

                nm = label or os.path.splitext(os.path.basename(fp))[0]
                out.append(Trajectory(len(out), nm, np.array(pts), np.array(dirs),
                                      {"file": os.path.abspath(fp), "sha256": file_sha256(fp)}))
                continue
            gen = tbl["generator"]
            if gen not in GENERATORS:
                raise self.err(f"{key}.generator", f"unknown generator {gen!r}{_suggest(str(gen), GENERATORS)}; choose one of {', '.join(GENERATORS)}")
            ptypes = GENERATORS[gen]
            fn = _generator_fns()[gen]
            self.known_keys(tbl, ("generator", "name", "zip") + tuple(ptypes), key, f" for generator {gen!r}")
            zipped = tbl.get("zip", False)
            if not isinstance(zipped, bool):
                raise self.err(f"{key}.zip", f"expected true or false, got {_typename(zipped)} {zipped!r}")
            sig = inspect.signature(fn)
            for pname, par in sig.parameters.items():
                if par.default is inspect.Parameter.empty and pname not in tbl:
                    raise self.err(f"{key}.{pname}", f"missing: generator {gen!r} needs {', '.join(p for p, q in sig.parameters.items() if q.default is inspect.Parameter.empty)}")
            options: dict[str, list] = {}
            for pname, ptype in ptypes.items():
                if pname in tbl:
                    options[pname] = self.gen_values(tbl[pname], ptype, f"{key}.{pname}")
            varying = [k for k, v in options.items() if len(v) > 1]
            if zipped:
                lengths = {k: len(options[k]) for k in varying}
                if len(set(lengths.values())) > 1:
                    raise self.err(f"{key}.zip", f"zip = true pairs the list-valued parameters, which need equal lengths; got {lengths}")
                n_paths = max(lengths.values(), default=1)
                combos = [tuple(v[i] if len(v) > 1 else v[0] for v in options.values()) for i in range(n_paths)]
            else:
                combos = list(itertools.product(*options.values()))
            for combo in combos:
                kw = dict(zip(options, combo))
                try:
                    p = fn(**kw)
                except (ValueError, TypeError) as exc:
                    raise self.err(key, f"generator {gen!r} with {kw}: {exc}") from None
                base = label or gen
                nm = base + ("(" + ", ".join(f"{k}={_fmt_value(kw[k])}" for k in varying) + ")" if varying else "")
                out.append(Trajectory(len(out), nm, np.array(p.points), np.array(p.directions), {"generator": gen, **kw}))
        # unique names: a repeated name gets the first free "#k" suffix (k = 2, 3, ...), never one
        # that another path already has ("p", "p", "p#2" -> "p", "p#3", "p#2")
        taken = {t.name for t in out}
        seen: set[str] = set()
        fixed = []
        for t in out:
            name = t.name
            if name in seen:
                k = 2
                while f"{t.name}#{k}" in taken:
                    k += 1
                name = f"{t.name}#{k}"
                taken.add(name)
            seen.add(name)
            fixed.append(t if name == t.name else dataclasses.replace(t, name=name))
        return fixed

    def gen_values(self, v, ptype: str, key: str) -> list:
        if ptype in ("float", "int"):
            integer = ptype == "int"
            if isinstance(v, Mapping):
                vals = self.range_values(dict(v), key, integer)
            elif isinstance(v, list):
                if not v:
                    raise self.err(key, "empty list: give at least one value")
                vals = [self.number(x, f"{key}[{i}]", integer) for i, x in enumerate(v)]
            else:
                vals = [self.number(v, key, integer)]
            return vals
        if ptype == "vec3":
            if isinstance(v, list) and v and all(isinstance(x, list) for x in v):
                return [self.vec3(x, f"{key}[{i}]") for i, x in enumerate(v)]
            return [self.vec3(v, key)]
        # points: a list of 3-vectors, no axis
        if not isinstance(v, list) or len(v) < 2:
            raise self.err(key, f"expected a list of >= 2 points [[x, y, z], ...], got {v!r}")
        return [[self.vec3(x, f"{key}[{i}]") for i, x in enumerate(v)]]

    # ------------------------------------------------------------------ [axes]
    def axes(self, cfg, kind: str, robot) -> dict[str, list]:
        specs = AXES[kind]
        tbl = self.table(cfg.get("axes", {}), "axes")
        other = AXES["csc" if kind == "shape" else "shape"]
        for k in tbl:
            if k not in specs:
                hint = f" (it is an axis of kind {('csc' if kind == 'shape' else 'shape')!r}; set sweep.kind)" if k in other else ""
                raise self.err(f"axes.{k}", f"unknown axis for kind {kind!r}{_suggest(k, specs)}{hint}; axes: {', '.join(specs)}")
        out: dict[str, list] = {}
        for name, spec in specs.items():
            key = f"axes.{name}"
            raw = tbl.get(name, spec.default)
            vals = self.axis_values(raw, spec, key, robot)
            seen = set()
            for v in vals:
                h = json.dumps(v)
                if h in seen:
                    raise self.err(key, f"duplicate value {v!r} (each value once)")
                seen.add(h)
            out[name] = vals
        return out

    def axis_values(self, raw, spec: AxisSpec, key: str, robot) -> list:
        if spec.type == "q0":
            return self.q0_values(raw, key, robot)
        if isinstance(raw, Mapping):
            if spec.type not in ("float", "int"):
                raise self.err(key, f"a range table only works for numbers; {spec.name} takes {spec.type} values")
            vals = self.range_values(dict(raw), key, spec.type == "int")
        elif isinstance(raw, list):
            if not raw:
                raise self.err(key, "empty axis: give at least one value")
            vals = list(raw)
        else:
            vals = [raw]
        out = []
        for i, v in enumerate(vals):
            vk = key if len(vals) == 1 and not isinstance(raw, list) else f"{key}[{i}]"
            if spec.type in ("float", "int"):
                try:
                    x = self.number(v, vk, integer=spec.type == "int")
                except SweepConfigError:
                    want = "an integer" if spec.type == "int" else "a number"
                    raise self.err(key, f"expected {want} or a list/range of them, got {_typename(v)} {v!r}") from None
                problem = spec.check(x) if spec.check else None
                if not problem and not math.isfinite(x) and not (spec.name == "kmax" and math.isinf(spec.default)):
                    problem = f"must be finite, got {v!r}"  # (only the csc actuator range may be open: kmax = inf)
                if problem:
                    raise self.err(key, problem)
                out.append(x)
            elif spec.type == "bool":
                if not isinstance(v, bool):
                    raise self.err(key, f"expected true or false, got {_typename(v)} {v!r}")
                out.append(v)
            else:  # str
                if not isinstance(v, str):
                    raise self.err(key, f"expected a string or a list of strings, got {_typename(v)} {v!r}")
                allowed = spec.allowed()
                if allowed is not None and v not in allowed:
                    raise self.err(key, f"unknown value {v!r}{_suggest(v, allowed)}; choose one of {', '.join(allowed)}")
                out.append(v)
        return out

    def q0_values(self, raw, key: str, robot) -> list:
        if isinstance(raw, str):
            items = [raw]
        elif isinstance(raw, list):
            if not raw:
                raise self.err(key, "empty axis: give at least one value")
            if all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in raw):
                raise self.err(key, "a posture must be written inside a list: q0 = [[q_1, ..., q_n]] (rad)")
            items = raw
        else:
            raise self.err(key, f'expected "ik", "nominal", "random" or a list of postures, got {_typename(raw)} {raw!r}')
        out = []
        for i, v in enumerate(items):
            if isinstance(v, str):
                if v not in ("ik", "nominal", "random"):
                    raise self.err(key, f"unknown q0 family {v!r}{_suggest(v, ('ik', 'nominal', 'random'))}; choose ik, nominal, random or a posture")
                out.append(v)
            elif isinstance(v, list):
                q = [self.number(x, f"{key}[{i}][{j}]") for j, x in enumerate(v)]
                if len(q) != robot.n:
                    raise self.err(key, f"posture {i} has {len(q)} values; robot {robot.name!r} has {robot.n} joints ({', '.join(robot.joint_names)})")
                lo, hi = robot.lower, robot.upper
                for j, x in enumerate(q):
                    if not (lo[j] <= x <= hi[j]):
                        raise self.err(key, f"posture {i}: q[{j}] = {x:g} rad is outside the limits [{lo[j]:g}, {hi[j]:g}] of joint {robot.joint_names[j]!r}")
                    if robot.locked[j] is not None and abs(x - robot.locked[j]) > 1e-12:
                        raise self.err(key, f"posture {i}: joint {robot.joint_names[j]!r} is locked at {robot.locked[j]:g} rad, got {x:g}")
                out.append(q)
            else:
                raise self.err(key, f"item {i}: expected a string or a posture list, got {_typename(v)} {v!r}")
        return out

    def cross_checks(self, kind: str, axes: dict, trajectories: list[Trajectory], robot) -> None:
        # every combination needs kmin < kmax
        for lo in axes["kmin"]:
            for hi in axes["kmax"]:
                if not lo < hi:
                    raise self.err("axes.kmin", f"kmin = {lo:g} is not below kmax = {hi:g} (axes.kmax); every combination needs 0 < kmin < kmax")
        if kind == "shape":
            for s in axes["solver"]:
                if s in ("slsqp", "slsqp-fd") and any(k > 1 for k in axes["starts"]):
                    raise self.err("axes.starts", f"solver {s!r} is single-start; starts must be 0 or 1 (or sweep multi-start solvers separately)")
        from jaxstiff.stiffness.core import TASK_ROWS, check_task_feasible

        for task in axes["task"]:
            try:
                check_task_feasible(robot, task, motion=kind == "csc")
            except ValueError as e:
                raise self.err("axes.task", f"robot {robot.name!r}: {e}") from None
            m = len(TASK_ROWS[task])
            if kind == "csc" and robot.n_free <= m:  # allowed (tracking only), but the sweep's point is lost
                warnings.warn(f"{self.source or 'config'}: axes.task {task!r}: robot {robot.name!r} has {robot.n_free} free "
                              f"joints for {m} task rows: no null space, so the arm only tracks the path, and beta and the "
                              "step rule do not change its motion", stacklevel=2)
        if len(axes["q0_seed"]) > 1 and "random" not in axes["q0"]:
            raise self.err("axes.q0_seed", f"{len(axes['q0_seed'])} seeds, but axes.q0 has no \"random\" family: "
                                           "the seed only draws random postures, so every seed would repeat the same rows")
        if "xy" in axes["task"]:
            for t in trajectories:
                if kind == "shape" and np.any(np.abs(t.directions[:, 2]) > 1e-9):
                    raise self.err("axes.task", f"task 'xy' needs directions in the xy plane (dz = 0); path {t.name!r} has dz != 0")

    def options(self, cfg, axes) -> dict:
        tbl = self.table(cfg.get("solver_options", {}), "solver_options")
        out = {}
        known = None
        if "solver" in axes:  # each row's solver gets the options it knows (shaping.solver_option_names)
            from jaxstiff.shaping import solver_option_names

            from jaxstiff.solvers.trajectory import WARM_STARTS

            warm = tbl.get("warm", "pgd") if tbl.get("warm", "pgd") in WARM_STARTS else "pgd"
            names = [solver_option_names(s, warm) for s in axes["solver"]]
            if all(n is not None for n in names):
                known = tuple(sorted(set().union(*names)))
            which = "SLSQP" if set(axes["solver"]) <= {"slsqp", "slsqp-fd"} else "solver(s) " + ", ".join(axes["solver"])
        for k, v in tbl.items():
            if known is not None and k not in known:
                raise self.err(f"solver_options.{k}", f"unknown option{_suggest(k, known)} for {which}; options: {', '.join(known)}")
            if isinstance(v, bool) or not isinstance(v, (int, float, str)):
                raise self.err(f"solver_options.{k}", f"expected a number or a string, got {_typename(v)} {v!r}")
            if isinstance(v, (int, float)) and not (isinstance(v, int) or math.isfinite(v)) or (isinstance(v, (int, float)) and v < 0):
                raise self.err(f"solver_options.{k}", f"must be a finite number >= 0, got {v!r}")
            out[k] = v
        if known is not None:  # values, as each solver of the sweep will see them
            from jaxstiff.shaping import _check_options, options_for_solver

            for s in axes["solver"]:
                try:
                    _check_options(s, options_for_solver(s, out))
                except ValueError as e:
                    raise self.err("solver_options", str(e)) from None
        return out

    def report(self, cfg, kind, axes, n_paths: int) -> tuple[tuple[tuple[str, str], ...], tuple[str, ...]]:
        from jaxstiff.sweep.metrics import METRICS

        tbl = self.table(cfg.get("report", {}), "report")
        self.known_keys(tbl, _REPORT_KEYS, "report")
        numeric = [k for k, s in AXES[kind].items() if s.type in ("float", "int") and len(axes[k]) > 1]
        others = [k for k, s in AXES[kind].items() if s.type not in ("float", "int") and len(axes[k]) > 1]
        if "heatmaps" in tbl:
            hm = tbl["heatmaps"]
            if not isinstance(hm, list) or not all(isinstance(p, list) and len(p) == 2 for p in hm):
                raise self.err("report.heatmaps", f'expected a list of axis pairs, e.g. [["ratio", "dq_deg"]], got {hm!r}')
            pairs = []
            for i, (a, b) in enumerate(hm):
                for ax in (a, b):
                    if ax == "path":
                        if n_paths < 2:
                            raise self.err(f"report.heatmaps[{i}]", "'path' needs at least two paths")
                        continue
                    if ax not in AXES[kind]:
                        raise self.err(f"report.heatmaps[{i}]", f"unknown axis {ax!r}{_suggest(str(ax), list(AXES[kind]) + ['path'])} (axes and 'path')")
                    if len(axes[ax]) < 2:
                        raise self.err(f"report.heatmaps[{i}]", f"axis {ax!r} has one value; a heat map needs two varying axes")
                if a == b:
                    raise self.err(f"report.heatmaps[{i}]", f"the two axes must differ, got {a!r} twice")
                pairs.append((a, b))
        else:
            # numeric pairs first, then numeric x categorical, then categorical pairs; at most 6
            pairs = (list(itertools.combinations(numeric, 2)) + [(a, b) for a in numeric for b in others]
                     + list(itertools.combinations(others, 2)))[:6]
        allowed = list(METRICS[kind])
        metrics = tbl.get("metrics", list(METRICS[kind])[:2])
        if not isinstance(metrics, list) or not metrics:
            raise self.err("report.metrics", f"expected a non-empty list of metric names, got {metrics!r}")
        for m in metrics:
            if m not in allowed:
                raise self.err("report.metrics", f"unknown metric {m!r}{_suggest(str(m), allowed)}; metrics: {', '.join(allowed)}")
        return tuple(pairs), tuple(metrics)
