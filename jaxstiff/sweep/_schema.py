"""The sweep TOML's tables as typed pydantic models, and their errors as :class:`SweepConfigError`.

Each table of a sweep config (``[sweep]``, ``[robot]``, ``[[paths]]``, a range ``{start, stop,
num | step}``) is a strict pydantic model (no unknown keys, no silent type conversion but int ->
float). :func:`validate` runs a model and turns the first pydantic error into a
:class:`SweepConfigError` whose message names the key path (``paths[1].radius``), the value, what
is allowed and, for a near miss, the likely key (``did you mean 'ratio'?``). The axes of a sweep
(:mod:`._axes`) and the paths (:mod:`._trajectories`) build their models on these pieces; the
plan (:mod:`._plan`) calls them in the order a user reads the file, so the first problem is the
one reported.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any, ClassVar, TypeVar

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, ValidationError, ValidationInfo, field_validator, model_validator
from pydantic_core import PydanticCustomError

from jaxstiff.runtime._messages import suggest as _suggest

__all__ = ["RangeTable", "problem", "number", "short_float"]

KINDS = ("shape", "csc")
TOP_KEYS = ("sweep", "robot", "paths", "axes", "solver_options", "report")
DEFAULT_CHUNK = {"shape": 16, "csc": 64}  #: rows per chunk when ``sweep.chunk_size`` is not given
MAX_ROWS = 10_000_000  #: most rows (and range values) a sweep may expand to


class SweepConfigError(ValueError):
    """A bad sweep config. ``key`` is the offending key (``"axes.ratio"``), ``str(err)`` says why."""

    def __init__(self, key: str, problem: str, source: str = ""):
        self.key = key
        self.problem = problem
        self.source = source
        where = f"{source}: " if source else ""
        super().__init__(f"{where}{key}: {problem}" if key else f"{where}{problem}")


# ---------------------------------------------------------------------------- message helpers
def typename(v: Any) -> str:
    """The TOML name of a value's type (``"string"``, ``"table"``, ...)."""
    names = {bool: "bool", int: "integer", float: "float", str: "string", list: "list", dict: "table"}
    return names.get(type(v), type(v).__name__)


def suggest(word: Any, options: Sequence[str]) -> str:
    """``" (did you mean 'x'?)"`` for a near miss among ``options``, else ``""``
    (:func:`jaxstiff.runtime._messages.suggest`, the one did-you-mean of the package)."""
    return _suggest(str(word), options)


def problem(text: str, at: str = "") -> PydanticCustomError:
    """A validator's error with our own wording; ``at`` is appended to the key path (``".stop"``)."""
    return PydanticCustomError("sweep", "{problem}", {"problem": text, "at": at})


def short_float(x: float) -> float:
    """``x``, or the shortest decimal of at most 12 significant digits within 8 units in the last
    place of it (range round-off: 1.2000000000000002 -> 1.2; 1/3 stays 1/3)."""
    for digits in range(1, 13):
        y = float(f"{x:.{digits}g}")
        if abs(y - x) <= 8 * np.spacing(abs(x)):
            return y
    return x


# ---------------------------------------------------------------------------- pydantic -> SweepConfigError
_EXPECTED = {
    "int_type": "an integer",
    "int_from_float": "an integer",
    "float_type": "a number",
    "string_type": "a string",
    "bool_type": "true or false",
    "dict_type": "a table",
    "model_type": "a table",
    "list_type": "a list",
    "tuple_type": "a list",
}
_BOUNDS = {"greater_than": ">", "greater_than_equal": ">=", "less_than": "<", "less_than_equal": "<="}

M = TypeVar("M", bound=BaseModel)


class Table(BaseModel):
    """A strict, frozen table: unknown keys and wrong types are errors (int is taken for float)."""

    model_config = ConfigDict(extra="forbid", strict=True, frozen=True)

    #: appended to the "unknown key" message (e.g. how a range is written)
    key_hint: ClassVar[str] = ""

    @classmethod
    def unknown_key(cls, key: str) -> str:
        """The problem text of an unknown key ``key`` of this table."""
        allowed = list(cls.model_fields)
        return f"unknown key{suggest(key, allowed)} (allowed: {', '.join(allowed)}){cls.key_hint}"

    @classmethod
    def missing_key(cls, key: str) -> str:
        """The problem text of a required key ``key`` that is not given."""
        return "missing (required: " + ", ".join(k for k, f in cls.model_fields.items() if f.is_required()) + ")"


def _key_path(key: str, loc: Sequence[Any]) -> str:
    out = key
    for part in loc:
        if isinstance(part, int):
            out += f"[{part}]"
        elif str(part).startswith("["):
            out += str(part)
        else:
            out += f".{part}" if out else str(part)
    return out


def _message(model: type[Table], err: Mapping[str, Any]) -> tuple[tuple[Any, ...], str]:
    """(loc, problem text) of one pydantic error of ``model``."""
    kind, loc, v = err["type"], tuple(err["loc"]), err.get("input")
    ctx = err.get("ctx") or {}
    if kind == "sweep":
        return loc + ((ctx["at"],) if ctx.get("at") else ()), str(ctx["problem"])
    if kind == "extra_forbidden":
        return loc, model.unknown_key(str(loc[-1])) if len(loc) == 1 else f"unknown key {loc[-1]!r}"
    if kind == "missing":
        return loc, model.missing_key(str(loc[-1]))
    if kind in _EXPECTED:
        return loc, f"expected {_EXPECTED[kind]}, got {typename(v)} {v!r}"
    if kind in _BOUNDS:
        bound = next(iter(ctx.values()))
        return loc, f"must be {_BOUNDS[kind]} {bound:g}, got {v!r}"
    msg = str(err.get("msg", kind)).removeprefix("Value error, ")
    return loc, f"{msg}, got {v!r}"


def validate(model: type[M], raw: Any, key: str, source: str = "", context: Mapping[str, Any] | None = None) -> M:
    """``model.model_validate(raw)``; the first problem raised as a :class:`SweepConfigError`
    whose key is ``key`` followed by the error's location (``paths[0]`` + ``.radius``)."""
    if not isinstance(raw, Mapping):
        raise SweepConfigError(key or "config", f"expected a table, got {typename(raw)} {raw!r}", source)
    try:
        return model.model_validate(dict(raw), context=dict(context or {}))
    except ValidationError as exc:
        loc, text = _message(model, exc.errors()[0])  # type: ignore[arg-type]
        raise SweepConfigError(_key_path(key, loc), text, source) from None


def check_table(value: Any, key: str, source: str = "") -> dict:
    """``value`` as a dict, or an error naming ``key`` (a table was expected)."""
    if not isinstance(value, Mapping):
        raise SweepConfigError(key, f"expected a table, got {typename(value)} {value!r}", source)
    return dict(value)


def known_keys(tbl: Mapping[str, Any], allowed: Sequence[str], key: str, source: str = "", extra: str = "") -> None:
    """An error naming the first key of ``tbl`` that is not in ``allowed`` (with a did-you-mean)."""
    for k in tbl:
        if k not in allowed:
            where = f"{key}.{k}" if key else k
            raise SweepConfigError(
                where, f"unknown key{suggest(k, allowed)} (allowed: {', '.join(allowed)}){extra}", source
            )


# ---------------------------------------------------------------------------- numbers
def number(v: Any, key: str, integer: bool = False, source: str = "") -> float | int:
    """A TOML number as float (or int): bools, strings and (for floats) NaN are errors."""
    if isinstance(v, bool) or not isinstance(v, (int, float)) or (integer and not isinstance(v, int)):
        want = "an integer" if integer else "a number"
        raise SweepConfigError(key, f"expected {want}, got {typename(v)} {v!r}", source)
    if not integer and math.isnan(v):
        raise SweepConfigError(key, "NaN is not allowed", source)
    return int(v) if integer else float(v)


def vec3(v: Any, key: str, source: str = "") -> list[float]:
    """Three finite numbers ``[x, y, z]`` (m)."""
    if not isinstance(v, list) or len(v) != 3:
        raise SweepConfigError(key, f"expected 3 numbers [x, y, z] (m), got {v!r}", source)
    out = [float(number(x, f"{key}[{i}]", source=source)) for i, x in enumerate(v)]
    if not all(math.isfinite(x) for x in out):
        raise SweepConfigError(key, f"values must be finite, got {v!r}", source)
    return out


# ---------------------------------------------------------------------------- [sweep]
class SweepTable(Table):
    """``[sweep]``: kind, label, chunking, seed and the summary tolerances."""

    kind: str = Field("shape", description='"shape" (seed 000) or "csc" (seed 001)')
    name: str | None = Field(None, description="label (default: the config's file name)")
    description: str = ""
    chunk_size: int | None = Field(None, ge=1, description="rows per chunk (default: 16 shape, 64 csc)")
    seed: int = Field(0, ge=0, description='seed of every random choice (q0 = "random")')
    alpha_tol_deg: float = Field(1.0, description="a waypoint is aligned when alpha < this (deg)")
    ratio_rel_tol: float = Field(0.02, description="... and reaches the ratio when |rho - r| / r < this")

    @field_validator("kind")
    @classmethod
    def _kind(cls, v: str) -> str:
        if v not in KINDS:
            raise problem(f"unknown kind {v!r}{suggest(v, KINDS)}; choose one of {', '.join(KINDS)}")
        return v

    @field_validator("name")
    @classmethod
    def _name(cls, v: str | None) -> str | None:
        if v is not None and not v.strip():
            raise problem(f"expected a non-empty string, got {v!r}")
        return v

    @field_validator("alpha_tol_deg")
    @classmethod
    def _alpha(cls, v: float) -> float:
        if not 0 < v <= 90:
            raise problem(f"must be in (0, 90] degrees, got {v}")
        return v

    @field_validator("ratio_rel_tol")
    @classmethod
    def _rtol(cls, v: float) -> float:
        if not 0 < v < 1:
            raise problem(f"must be in (0, 1), got {v}")
        return v


# ---------------------------------------------------------------------------- [robot]
class RobotTable(Table):
    """``[robot]``: a shipped robot (``name``) or a URDF file (``urdf``), links, locks, tool."""

    name: str | None = Field(None, description="a shipped robot")
    urdf: str | None = Field(None, description="a URDF file, relative to the config")
    locked: dict[str, float] | None = Field(None, description="locked joints {name: rad}; default: the shipped robot's")
    tcp: Any = Field(None, description="x,y,z (m), x,y,z,roll,pitch,yaw (m, rad) or a 4x4 transform")
    base_link: str | None = None
    tip_link: str | None = None

    @model_validator(mode="after")
    def _one_source(self) -> RobotTable:
        if (self.name is None) == (self.urdf is None):
            raise problem("give exactly one of 'name' (a shipped robot) and 'urdf' (a file)")
        return self

    @field_validator("locked")
    @classmethod
    def _locked(cls, v: dict[str, float] | None) -> dict[str, float] | None:
        for k, x in (v or {}).items():
            if math.isnan(x):
                raise problem("NaN is not allowed", at=k)
        return v

    @field_validator("tcp")
    @classmethod
    def _tcp(cls, v: Any) -> Any:
        if v is None:
            return None
        if isinstance(v, list) and len(v) == 4 and all(isinstance(r, list) for r in v):
            for i, r in enumerate(v):  # a 4x4 transform: numbers (Robot.from_urdf checks the rest)
                for j, x in enumerate(r):
                    if isinstance(x, bool) or not isinstance(x, (int, float)):
                        raise problem(f"expected a number, got {typename(x)} {x!r}", at=f"[{i}][{j}]")
            return [[float(x) for x in r] for r in v]
        ok = (
            isinstance(v, list)
            and len(v) in (3, 6)
            and all(isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x) for x in v)
        )
        if not ok:
            raise problem(
                "expected 3 numbers [x, y, z] (m), 6 numbers [x, y, z, roll, pitch, yaw] (m, rad) "
                f"or a 4x4 transform, all finite; got {v!r}"
            )
        return [float(x) for x in v]


# ---------------------------------------------------------------------------- [[paths]] file, ranges, [report]
class PathFileTable(Table):
    """A ``[[paths]]`` entry read from a CSV file (``x,y,z[,dx,dy,dz]``, relative to the config)."""

    file: str
    name: str | None = None

    @field_validator("name")
    @classmethod
    def _name(cls, v: str | None) -> str | None:
        if v is not None and not v:
            raise problem(f"expected a non-empty string, got {v!r}")
        return v


class RangeTable(Table):
    """A range of axis values: ``{start, stop, num}`` (linspace) or ``{start, stop, step}``
    (from start by step up to stop inclusive, within 1e-9 of a step). Values are checked by
    :func:`range_values` (integers for an integer axis)."""

    key_hint: ClassVar[str] = " (a range is {start, stop, num} or {start, stop, step})"

    start: Any = None
    stop: Any = None
    num: Any = None
    step: Any = None

    @model_validator(mode="before")
    @classmethod
    def _shape(cls, v: Any) -> Any:
        if isinstance(v, Mapping) and all(k in cls.model_fields for k in v):
            for need in ("start", "stop"):
                if need not in v:
                    raise problem(f"a range needs '{need}' (write {{start = ..., stop = ..., num = ...}})")
            if ("num" in v) == ("step" in v):
                raise problem("a range needs exactly one of 'num' and 'step'")
        return v

    @model_validator(mode="after")
    def _numbers(self, info: ValidationInfo) -> RangeTable:
        integer = bool((info.context or {}).get("integer"))
        for k in ("start", "stop", "step"):
            v = getattr(self, k)
            if v is not None and (
                isinstance(v, bool)
                or not isinstance(v, (int, float))
                or (integer and not isinstance(v, int))
                or (isinstance(v, float) and math.isnan(v))
            ):
                want = "an integer" if integer else "a number"
                raise problem(f"expected {want}, got {typename(v)} {v!r}", at=k)
        if self.num is not None and (isinstance(self.num, bool) or not isinstance(self.num, int)):
            raise problem(f"expected an integer, got {typename(self.num)} {self.num!r}", at="num")
        return self


def range_values(raw: Mapping[str, Any], key: str, integer: bool, source: str = "") -> list:
    """The values of a range table (see :class:`RangeTable`); floats are :func:`short_float`'d."""
    r = validate(RangeTable, raw, key, source, {"integer": integer})
    start, stop = r.start, r.stop
    if not (math.isfinite(start) and math.isfinite(stop)):
        raise SweepConfigError(key, "range start and stop must be finite", source)
    if r.num is not None:
        if r.num < 1:
            raise SweepConfigError(key, f"empty axis: a range needs num >= 1, got num = {r.num}", source)
        if r.num > MAX_ROWS:
            raise SweepConfigError(key, f"range has num = {r.num} values; the limit is {MAX_ROWS}", source)
        vals = np.linspace(start, stop, r.num)
    else:
        step = r.step
        if step == 0 or not math.isfinite(step) or (stop - start) * step < 0:
            raise SweepConfigError(key, f"range step {step!r} does not lead from {start!r} to {stop!r}", source)
        count = int(math.floor((stop - start) / step + 1e-9)) + 1
        if count > MAX_ROWS:
            raise SweepConfigError(key, f"range has {count} values; that is too many", source)
        vals = start + step * np.arange(count)
    if integer:
        if not np.allclose(vals, np.round(vals), rtol=0, atol=1e-9):
            shown = ", ".join(f"{x:g}" for x in vals[:6]) + (", ..." if len(vals) > 6 else "")
            raise SweepConfigError(
                key,
                f"an integer axis: this range gives values that are not integers ({shown}); "
                "give {start, stop, step} or a list",
                source,
            )
        return [int(round(x)) for x in vals]
    return [short_float(float(x)) for x in vals]


class ReportTable(Table):
    """``[report]``: the heat maps' axis pairs and metrics (checked against the plan in :mod:`._plan`)."""

    heatmaps: Any = None
    metrics: Any = None
