"""The parameter axes of each sweep kind, as one table per kind (:data:`AXES`).

The axes that are settings are made from the fields of :class:`~jaxstiff.settings.ShapeSettings`
/ :class:`~jaxstiff.settings.CSCSettings` (:func:`setting_axes`: each field with an
:class:`~jaxstiff.settings._base.Axis`, its default, type, choices, check, unit and doc; the
conversions are documented in :mod:`jaxstiff.sweep._axes`); a field added there is an axis here
without another edit. The sweep-only axes (``kxd_major``, ``kxd_ratio``, ``kxd_angle_deg``, ``q0``,
``q0_seed``) are written here with their own defaults.
"""

from __future__ import annotations

import dataclasses
import importlib
import math
from collections.abc import Callable, Sequence
from typing import Any

from jaxstiff.settings._base import Check, FieldInfo, Settings
from jaxstiff.settings._csc import CSC_SWEEP_TASK, CSCSettings
from jaxstiff.settings._shape import ShapeSettings

__all__ = ["CSC_SWEEP_TASK", "setting_axes", "sweep_axes"]

Q0_FAMILIES = ("ik", "nominal", "random")


@dataclasses.dataclass(frozen=True)
class AxisSpec:
    """One parameter axis of a sweep kind.

    Attributes:
        name: the key under ``[axes]`` and the column of the results table.
        type: ``"float"``, ``"int"``, ``"str"``, ``"bool"`` or ``"q0"``.
        default: the value when the axis is not given (None for csc ``jl_gain``: the settings' rule).
        static: part of the group key (changes a compiled shape or the solver structure).
        unit: unit of the values ("" if none).
        doc: one line for ``--help`` and the report.
        choices: allowed strings (``"str"`` axes), or a function returning them (registries).
        check: ``check(value) -> problem text or None`` for numbers (the settings field's check,
            on the field's value: ``to_field(value)``).
        setting: the settings field the axis is (``"ShapeSettings.dq"``), "" if none.
        field: that field's name ("" if none): the keyword a row's value is given as.
        to_field: the field's value of an axis value (``dq_deg`` -> rad), None: the same.
    """

    name: str
    type: str
    default: Any
    static: bool = False
    unit: str = ""
    doc: str = ""
    choices: Sequence[str] | Callable[[], Sequence[str]] | None = None
    check: Callable[[Any], str | None] | None = None
    setting: str = ""
    field: str = ""
    to_field: Callable[[Any], Any] | None = None

    def allowed(self) -> list[str] | None:
        """The allowed strings, or None (any value of the type)."""
        if self.choices is None:
            return None
        return list(self.choices() if callable(self.choices) else self.choices)

    def field_value(self, value: Any) -> Any:
        """The settings field's value of an axis value."""
        return value if self.to_field is None else self.to_field(value)


def _registry(where: str) -> Callable[[], list[str]]:
    """The sorted keys of a registry ``"module:NAME"`` (read when asked: registered names count)."""
    module, _, name = where.partition(":")
    return lambda: sorted(getattr(importlib.import_module(module), name))


def _on_field(check: Check | None, to_field: Callable[[Any], Any] | None) -> Check | None:
    """A field's check run on the field's value of an axis value."""
    if check is None or to_field is None:
        return check
    return lambda v: check(to_field(v))


def _axis_spec(cls: type[Settings], info: FieldInfo) -> AxisSpec:
    ax = info.axis
    assert ax is not None
    kind = ax.kind or {bool: "bool", int: "int", float: "float", str: "str"}.get(info.kind or str, "str")
    choices: Any = ax.choices or (_registry(ax.registry) if ax.registry else None)
    if choices is None and info.choices is not None:
        choices = tuple(c for c in info.choices if c is not None)
    return AxisSpec(
        ax.name or info.name,
        kind,
        info.default if ax.from_field is None else ax.from_field(info.default),
        static=cls.sweep_static if ax.static is None else ax.static,
        unit=info.unit if ax.unit is None else ax.unit,
        doc=(info.doc or info.name) + ax.extra,
        choices=choices,
        check=ax.check or _on_field(info.check, ax.to_field),
        setting=f"{cls.__name__}.{info.name}",
        field=info.name,
        to_field=ax.to_field,
    )


def setting_axes(cls: type[Settings]) -> list[AxisSpec]:
    """The axes of the fields of ``cls`` with an :class:`~jaxstiff.settings._base.Axis`: the static
    ones first, then the others, each in field order (an ``Axis.before`` moves one before another)."""
    infos = [i for i in cls.fields_info() if i.axis is not None]
    specs = [_axis_spec(cls, i) for i in infos]
    order = [s for s in specs if s.static] + [s for s in specs if not s.static]
    for info in infos:
        if info.axis is not None and info.axis.before:
            moved = next(s for s in order if s.field == info.name)
            order.remove(moved)
            order.insert(next(k for k, s in enumerate(order) if s.name == info.axis.before), moved)
    return order


# the checks of the sweep-only axes (a settings axis runs its field's check); the value is added by the caller
def _gt(x0: float) -> Check:
    return lambda v: None if v > x0 else f"must be > {x0:g}"


def _ge(x0: float) -> Check:
    return lambda v: None if v >= x0 else f"must be >= {x0:g}"


def _finite(v: Any) -> str | None:
    return None if math.isfinite(v) else "must be finite"


def _both(a: Check, b: Check) -> Check:
    return lambda v: a(v) or b(v)


def _q0_specs() -> tuple[AxisSpec, AxisSpec]:
    return (
        AxisSpec("q0", "q0", "ik", doc='start posture: "ik", "nominal", "random" or [q_1..q_n] rad'),
        AxisSpec("q0_seed", "int", 0, check=_ge(0), doc='seed index of q0 = "random" postures'),
    )


def _sweep_only_csc() -> tuple[AxisSpec, ...]:
    """The K_xd of a CSC sweep row (:func:`jaxstiff.sweep._axes.kxd_matrix`)."""
    return (
        AxisSpec("kxd_major", "float", 3000.0, unit="N/m", check=_both(_gt(0.0), _finite), doc="K_xd major axis"),
        AxisSpec("kxd_ratio", "float", 3.0, check=_both(_ge(1.0), _finite), doc="K_xd major / minor axis"),
        AxisSpec("kxd_angle_deg", "float", 30.0, unit="deg", check=_finite, doc="K_xd major axis angle about base z"),
    )


def sweep_axes(
    shape: type[Settings] = ShapeSettings, csc: type[Settings] = CSCSettings
) -> dict[str, dict[str, AxisSpec]]:
    """:data:`AXES` of the settings classes ``shape`` and ``csc``: their fields' axes, then the sweep's own."""
    out = {
        "shape": (*setting_axes(shape), *_q0_specs()),
        "csc": (*setting_axes(csc), *_sweep_only_csc(), *_q0_specs()),
    }
    per_row = [a.name for a in out["csc"] if a.field and not a.static and a.field != "beta"]
    if per_row:  # csc_rollout takes one value per row of beta only: every other field is one per chunk
        raise TypeError(f"csc sweep axes {per_row} must be static (Axis(static=True)): only beta varies per row")
    return {kind: {a.name: a for a in specs} for kind, specs in out.items()}


#: The axes of each sweep kind, in the order rows are enumerated (:func:`itertools.product`).
AXES: dict[str, dict[str, AxisSpec]] = sweep_axes()
