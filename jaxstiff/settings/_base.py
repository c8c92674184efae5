"""The machinery shared by every settings class: typed fields with units, documentation and checks.

A settings class is a frozen dataclass whose fields are declared with :func:`setting`. The field's
metadata carries its unit, a one-line doc, the allowed choices and a check; :class:`Settings`
validates every field on construction (a ``ValueError`` naming the field, the value and what is
allowed) and writes the ``meta`` record of a result file (:meth:`Settings.meta`). The API
(``shape()``, ``csc_rollout()``), the command line and the sweep config all read their defaults
from these classes, so a default is written once.

How a field appears elsewhere is metadata of the field too: :class:`Flag` (its command-line flag:
name, metavar, the unit the flag takes and its conversion, help) and :class:`Axis` (its sweep
axis: name, static or not, conversion, the sweep's own limits). ``jaxstiff.cli._setting_flags``
makes the flags of ``jaxstiff shape`` / ``jaxstiff csc`` and ``jaxstiff.sweep._axis_specs`` the
sweep's axes from them; a field added to a settings class appears in both, with its default,
check and help, without another edit (``flag=None`` / ``axis=None`` keep a field out).
"""

from __future__ import annotations

import dataclasses
import functools
import inspect
import math
import types
import typing
from collections.abc import Callable, Iterable, Mapping
from typing import Any, ClassVar, TypeVar

import numpy as np

from jaxstiff.runtime._io import nonfinite_text
from jaxstiff.runtime._messages import suggest as suggest  # (re-exported: its home before it moved down)

__all__ = ["Settings", "setting", "Axis", "positive", "finite", "suggest"]

S = TypeVar("S", bound="Settings")
Check = Callable[[Any], "str | None"]  # returns what is wrong, or None


@dataclasses.dataclass(frozen=True)
class Flag:
    """How a settings field is given on its command's line (``jaxstiff.cli._setting_flags`` reads it).

    Attributes:
        name: the flag ("": ``--`` and the field's name with ``-`` for ``_``).
        metavar: the value's name in ``--help`` (None: argparse's).
        unit: the unit the flag takes where it differs from the field's (``--dq-deg``: degrees).
        from_field: the flag's value of a field value (its default; e.g. rad -> degrees).
        to_field: the field's value of a flag value (the inverse).
        help: the whole help where the flag says it its own way ("": doc, unit and ``extra``).
        extra: appended to the generated help (``", > 1"``).
        choices: the values the flag takes where it takes fewer than the field (None: the field's).
        type: argparse's ``type`` where the command wants one (``str.lower``).
        group: flags of one group exclude each other (``--dq-deg`` / ``--dq-per-m``).
        off_help: a bool field: the help of its ``--no-...`` flag.
    """

    name: str = ""
    metavar: str | None = None
    unit: str | None = None
    from_field: Callable[[Any], Any] | None = None
    to_field: Callable[[Any], Any] | None = None
    help: str = ""
    extra: str = ""
    choices: tuple[Any, ...] | None = None
    type: Callable[[str], Any] | None = None
    group: str = ""
    off_help: str = ""


@dataclasses.dataclass(frozen=True)
class Axis:
    """How a settings field is swept (``jaxstiff.sweep._axis_specs`` reads it).

    Attributes:
        name: the key under ``[axes]`` and the results table's column ("": the field's name).
        static: part of a chunk's group key (None: the class's :attr:`Settings.sweep_static`).
        unit: the column's unit where it differs from the field's (None: the field's).
        from_field / to_field: the axis value of a field value (its default) and back.
        kind: ``"float"``, ``"int"``, ``"str"`` or ``"bool"`` ("": from the field's type).
        choices: the values the sweep allows where it allows fewer than the field.
        registry: ``"module:NAME"``, a registry whose keys are the allowed values (criteria, solvers).
        check: the axis's own check where its values mean something else than the field's
            (``starts = 0``: the solver's default); else the field's check runs on ``to_field(value)``.
        extra: appended to the field's doc in the sweep's report.
        before: the axis this one is listed before (the column order), "" for field order.
    """

    name: str = ""
    static: bool | None = None
    unit: str | None = None
    from_field: Callable[[Any], Any] | None = None
    to_field: Callable[[Any], Any] | None = None
    kind: str = ""
    choices: tuple[Any, ...] | None = None
    registry: str = ""
    check: Check | None = None
    extra: str = ""
    before: str = ""


@dataclasses.dataclass(frozen=True)
class FieldInfo:
    """What a settings field is: its name, default, unit, one-line doc, allowed choices, check,
    Python type (``kind``: bool, int, float or str, None stripped) and its flag and axis (None: none)."""

    name: str
    default: Any
    unit: str
    doc: str
    choices: tuple[Any, ...] | None
    check: Check | None = None
    kind: type | None = None
    flag: Flag | None = None
    axis: Axis | None = None


def setting(
    default: Any,
    *,
    unit: str = "",
    doc: str = "",
    choices: Iterable[Any] | None = None,
    check: Check | None = None,
    flag: Flag | None = Flag(),  # noqa: B008 - frozen: one shared instance is safe
    axis: Axis | None = Axis(),  # noqa: B008 - frozen: one shared instance is safe
) -> Any:
    """A settings field: ``x: float = setting(1.0, unit="N/m", doc="...", check=positive)``.
    ``flag`` / ``axis``: how it appears on the command line and in sweeps (None: not at all)."""
    meta = {
        "unit": unit,
        "doc": doc,
        "choices": None if choices is None else tuple(choices),
        "check": check,
        "flag": flag,
        "axis": axis,
    }
    return dataclasses.field(default=default, metadata=meta)


def kind_problem(kind: type | None, value: Any) -> str | None:
    """What is wrong with ``value`` for a field of type ``kind`` (None: nothing): a yes/no field
    takes a bool, a count an integer, a number not a string (``"no"`` read as True, or 2.5 starts
    cut to 2, would change a run without a word). Arrays (per-joint or per-path values where a
    field allows them) are left to the field's own check."""
    if value is None or kind is None or isinstance(value, (np.ndarray, list, tuple)):
        return None
    if kind is bool and not isinstance(value, (bool, np.bool_)):
        return f"must be True or False, got {value!r}"
    if kind is int and (isinstance(value, (bool, np.bool_)) or not _is_whole(value)):
        return f"must be an integer, got {value!r}"
    if kind is float and isinstance(value, (str, bytes, bool, np.bool_)):
        return f"must be a number, got {value!r}"
    return None


def _is_whole(v: Any) -> bool:
    """An integer (Python or numpy), or a float with an integer value (8.0)."""
    if isinstance(v, (int, np.integer)):
        return True
    return isinstance(v, (float, np.floating)) and math.isfinite(v) and float(v).is_integer()


@functools.cache
def _field_kinds(cls: type) -> dict[str, type | None]:
    """``{field: bool | int | float | str | None}`` of a settings class (its type hints, once)."""
    try:
        hints = typing.get_type_hints(cls)
    except (NameError, TypeError):  # a name only imported for type checking: no kinds
        return {}
    return {f.name: _kind(hints.get(f.name)) for f in dataclasses.fields(cls)}  # type: ignore[arg-type]


def _kind(hint: Any) -> type | None:
    """bool, int, float or str of a field's type hint (``int | None`` -> int, ``Literal["a"]`` -> str)."""
    if typing.get_origin(hint) in (typing.Union, types.UnionType):
        inner = [a for a in typing.get_args(hint) if a is not type(None)]
        return _kind(inner[0]) if len(inner) == 1 else None
    if typing.get_origin(hint) is typing.Literal:
        return type(typing.get_args(hint)[0])
    return hint if hint in (bool, int, float, str) else None


def positive(v: Any) -> str | None:
    """Check: a number > 0 (inf allowed)."""
    return None if _is_number(v) and v > 0 else "must be a number > 0"


def positive_finite(v: Any) -> str | None:
    """Check: a finite number > 0."""
    return None if _is_number(v) and math.isfinite(v) and v > 0 else "must be a finite number > 0"


def non_negative(v: Any) -> str | None:
    """Check: a number >= 0."""
    return None if _is_number(v) and v >= 0 else "must be a number >= 0"


def at_least(lo: float) -> Check:
    """Check: a number >= ``lo``."""
    return lambda v: None if _is_number(v) and v >= lo else f"must be a number >= {lo:g}"


def finite(v: Any) -> str | None:
    """Check: a finite number."""
    return None if _is_number(v) and math.isfinite(v) else "must be a finite number"


def plain_number(v: Any) -> Any:
    """``v`` as a Python ``int`` or ``float`` where it is a real number of numpy's or JAX's (a
    ``np.float32``, an ``np.int64``, a 0-d array: what indexing an array gives), else ``v`` itself.
    Booleans stay as they are (a flag is not a number)."""
    if isinstance(v, (bool, str)) or v is None or (isinstance(v, (int, float)) and not isinstance(v, np.generic)):
        return v
    if isinstance(v, np.generic) or (hasattr(v, "__array__") and getattr(v, "shape", None) == ()):
        try:
            a = np.asarray(v)
        except Exception:  # noqa: BLE001 - a traced or otherwise unreadable value: left to the checks
            return v
        if a.ndim == 0 and a.dtype.kind in "iuf":
            return a.item()
    return v


def _is_number(v: Any) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and not math.isnan(v)


class Settings:
    """Base of the frozen settings dataclasses (see the module docstring)."""

    #: the label used in error messages (``"shape"``, ``"csc"``, ...)
    section: ClassVar[str] = ""
    #: whether a swept field is static (part of a chunk's group key) unless its :class:`Axis` says
    sweep_static: ClassVar[bool] = False

    def __init_subclass__(cls, **kwargs: Any) -> None:
        """The class docstring gets an ``Attributes:`` section made from its fields' metadata
        (default, unit, doc, choices): the API reference lists every setting from the one place
        it is written."""
        super().__init_subclass__(**kwargs)
        lines = []
        for name, f in vars(cls).items():
            if isinstance(f, dataclasses.Field) and "doc" in f.metadata:
                m = f.metadata
                unit = f" [{m['unit']}]" if m.get("unit") else ""
                choices = f"; one of {', '.join(map(repr, m['choices']))}" if m.get("choices") else ""
                lines.append(f"    {name}: {m['doc'] or name}{unit} (default {f.default!r}{choices}).")
        if lines and cls.__doc__ and "Attributes:" not in cls.__doc__:
            cls.__doc__ = inspect.cleandoc(cls.__doc__) + "\n\nAttributes:\n" + "\n".join(lines) + "\n"

    def __post_init__(self) -> None:
        kinds = _field_kinds(type(self))
        for f in dataclasses.fields(self):  # type: ignore[arg-type]
            value = getattr(self, f.name)
            plain = plain_number(value)
            if plain is not value:  # a numpy or JAX number: its Python value (frozen: set here once)
                object.__setattr__(self, f.name, plain)
                value = plain
            self._check_kind(f.name, kinds.get(f.name), value)
            self._check_field(f, value)

    def _check_kind(self, name: str, kind: type | None, value: Any) -> None:
        problem = kind_problem(kind, value)
        if problem:
            raise ValueError(f"{self.section}.{name} {problem}" if self.section else f"{name} {problem}")

    @classmethod
    def check_kinds(cls, values: Mapping[str, Any]) -> None:
        """:meth:`__post_init__`'s type rule on the entries of ``values`` that are fields of this
        class, for a caller that takes the fields as keywords without building the object
        (``shape(first_rate_limit=...)``); an error names the keyword."""
        kinds = _field_kinds(cls)
        for name, value in values.items():
            problem = kind_problem(kinds.get(name), value)
            if problem:
                raise ValueError(f"{name} {problem}")

    def _check_field(self, f: dataclasses.Field, value: Any) -> None:
        where = f"{self.section}.{f.name}" if self.section else f.name
        choices = f.metadata.get("choices")
        if choices is not None and value not in choices:
            shown = ", ".join(repr(c) for c in choices)
            raise ValueError(f"{where} must be one of {shown}, got {value!r}{suggest(value, map(str, choices))}")
        check = f.metadata.get("check")
        if check is not None:
            problem = check(value)
            if problem:
                unit = f" ({f.metadata['unit']})" if f.metadata.get("unit") else ""
                raise ValueError(f"{where}{unit} {problem}, got {value!r}")

    @classmethod
    def fields_info(cls) -> list[FieldInfo]:
        """Every field with its default, unit, doc, choices, check, type, flag and axis (for the
        command line's flags, the sweep's axes, help texts, docs and tests)."""
        try:
            hints = typing.get_type_hints(cls)
        except (NameError, TypeError):  # a name only imported for type checking: no kinds
            hints = {}
        return [
            FieldInfo(
                f.name,
                f.default,
                f.metadata.get("unit", ""),
                f.metadata.get("doc", ""),
                f.metadata.get("choices"),
                f.metadata.get("check"),
                _kind(hints.get(f.name)),
                f.metadata.get("flag"),
                f.metadata.get("axis"),
            )
            for f in dataclasses.fields(cls)  # type: ignore[arg-type]
        ]

    @classmethod
    def defaults(cls) -> dict[str, Any]:
        """``{field: default}``."""
        return {i.name: i.default for i in cls.fields_info()}

    @classmethod
    def field_names(cls) -> tuple[str, ...]:
        """The field names, in declaration order."""
        return tuple(f.name for f in dataclasses.fields(cls))  # type: ignore[arg-type]

    def replace(self: S, **changes: Any) -> S:
        """A copy with some fields changed (validated again)."""
        unknown = set(changes) - set(self.field_names())
        if unknown:
            name = sorted(unknown)[0]
            raise TypeError(f"{type(self).__name__} has no setting {name!r}{suggest(name, self.field_names())}")
        return dataclasses.replace(self, **changes)  # type: ignore[type-var]

    def meta(self) -> dict[str, Any]:
        """The ``meta`` record: ``{field: value, ..., "units": {field: unit}}`` (JSON-ready values)."""
        out: dict[str, Any] = {f.name: _jsonable(getattr(self, f.name)) for f in dataclasses.fields(self)}  # type: ignore[arg-type]
        out["units"] = {i.name: i.unit for i in self.fields_info() if i.unit}
        return out


def _jsonable(v: Any) -> Any:
    if isinstance(v, float) and not math.isfinite(v):
        return nonfinite_text(v)  # JSON has no infinity: spelt as every result file's meta spells it
    if isinstance(v, tuple):
        return [_jsonable(x) for x in v]
    if isinstance(v, dict):
        return {k: _jsonable(x) for k, x in v.items()}
    return v
