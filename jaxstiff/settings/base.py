"""The machinery shared by every settings class: typed fields with units, documentation and checks.

A settings class is a frozen dataclass whose fields are declared with :func:`setting`. The field's
metadata carries its unit, a one-line doc, the allowed choices and a check; :class:`Settings`
validates every field on construction (a ``ValueError`` naming the field, the value and what is
allowed) and writes the ``meta`` record of a result file (:meth:`Settings.meta`). The API
(``shape()``, ``csc_rollout()``), the command line and the sweep config all read their defaults
from these classes, so a default is written once.
"""

from __future__ import annotations

import dataclasses
import inspect
import math
from collections.abc import Callable, Iterable
from typing import Any, ClassVar, TypeVar

from jaxstiff.runtime.messages import suggest as suggest  # (re-exported: its home before it moved down)

__all__ = ["Settings", "setting", "FieldInfo", "positive", "non_negative", "at_least", "finite", "suggest"]

S = TypeVar("S", bound="Settings")
Check = Callable[[Any], "str | None"]  # returns what is wrong, or None


@dataclasses.dataclass(frozen=True)
class FieldInfo:
    """What a settings field is: its name, default, unit, one-line doc and allowed choices."""

    name: str
    default: Any
    unit: str
    doc: str
    choices: tuple[Any, ...] | None


def setting(
    default: Any, *, unit: str = "", doc: str = "", choices: Iterable[Any] | None = None, check: Check | None = None
) -> Any:
    """A settings field: ``x: float = setting(1.0, unit="N/m", doc="...", check=positive)``."""
    meta = {"unit": unit, "doc": doc, "choices": None if choices is None else tuple(choices), "check": check}
    return dataclasses.field(default=default, metadata=meta)


def positive(v: Any) -> str | None:
    """Check: a number > 0 (inf allowed)."""
    return None if _is_number(v) and v > 0 else "must be a number > 0"


def non_negative(v: Any) -> str | None:
    """Check: a number >= 0."""
    return None if _is_number(v) and v >= 0 else "must be a number >= 0"


def at_least(lo: float) -> Check:
    """Check: a number >= ``lo``."""
    return lambda v: None if _is_number(v) and v >= lo else f"must be a number >= {lo:g}"


def finite(v: Any) -> str | None:
    """Check: a finite number."""
    return None if _is_number(v) and math.isfinite(v) else "must be a finite number"


def _is_number(v: Any) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and not math.isnan(v)


class Settings:
    """Base of the frozen settings dataclasses (see the module docstring)."""

    #: the label used in error messages (``"shape"``, ``"csc"``, ...)
    section: ClassVar[str] = ""

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
        for f in dataclasses.fields(self):  # type: ignore[arg-type]
            self._check_field(f, getattr(self, f.name))

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
        """Every field with its default, unit, doc and choices (for help texts, docs and tests)."""
        return [
            FieldInfo(
                f.name, f.default, f.metadata.get("unit", ""), f.metadata.get("doc", ""), f.metadata.get("choices")
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
        return str(v)  # "inf": JSON has no infinity
    if isinstance(v, tuple):
        return [_jsonable(x) for x in v]
    if isinstance(v, dict):
        return {k: _jsonable(x) for k, x in v.items()}
    return v
