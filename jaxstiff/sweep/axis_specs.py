"""The parameter axes of each sweep kind, as one table per kind (:data:`AXES`).

Defaults come from :class:`~jaxstiff.settings.ShapeSettings` / :class:`~jaxstiff.settings.CSCSettings`
(the conversions are documented in :mod:`jaxstiff.sweep.axes`); the sweep-only axes (``kxd_major``,
``kxd_ratio``, ``kxd_angle_deg``, ``q0``, ``q0_seed``) keep their own defaults here.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Sequence
from typing import Any

from jaxstiff.settings.csc import CSC_TASKS, JOINT_LIMIT_MODES, LOCKED_JOINT_MODES, OBJECTIVES, STEP_RULES, CSCSettings
from jaxstiff.settings.shape import LOCKED_JOINT_MODES as SHAPE_LOCKED_JOINT_MODES
from jaxstiff.settings.shape import TASKS, ShapeSettings

__all__ = ["AxisSpec", "AXES", "CSC_SWEEP_TASK", "Q0_FAMILIES"]

Q0_FAMILIES = ("ik", "nominal", "random")
CSC_SWEEP_TASK = "xyz"  #: CSCSettings.task = None resolved for a sweep's 3x3 K_xd (see the module docstring)


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
        check: ``check(value) -> problem text or None`` for numbers.
        setting: the settings field the default comes from (``"ShapeSettings.dq"``), "" if none.
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

    def allowed(self) -> list[str] | None:
        """The allowed strings, or None (any value of the type)."""
        if self.choices is None:
            return None
        return list(self.choices() if callable(self.choices) else self.choices)


def _gt(x0: float, what: str = "") -> Callable[[Any], str | None]:
    return lambda v: None if v > x0 else f"must be > {x0:g}{what}, got {v!r}"


def _ge(x0: float, what: str = "") -> Callable[[Any], str | None]:
    return lambda v: None if v >= x0 else f"must be >= {x0:g}{what}, got {v!r}"


def _finite(v: Any) -> str | None:
    return None if math.isfinite(v) else f"must be finite, got {v!r}"


def _both(a: Callable[[Any], str | None], b: Callable[[Any], str | None]) -> Callable[[Any], str | None]:
    return lambda v: a(v) or b(v)


def _criteria() -> list[str]:
    from jaxstiff.stiffness.criteria import CRITERIA

    return sorted(CRITERIA)


def _solvers() -> list[str]:
    from jaxstiff.solvers.base import SOLVERS

    return sorted(SOLVERS)


def _q0_specs() -> tuple[AxisSpec, AxisSpec]:
    return (
        AxisSpec("q0", "q0", "ik", doc='start posture: "ik", "nominal", "random" or [q_1..q_n] rad'),
        AxisSpec("q0_seed", "int", 0, check=_ge(0), doc='seed index of q0 = "random" postures'),
    )


def _shape_axes() -> dict[str, AxisSpec]:
    """The axes of a shape sweep. Long only because it is one table (one entry per axis); kept whole."""
    d = ShapeSettings()
    S = "ShapeSettings."
    specs = (
        AxisSpec(
            "criterion",
            "str",
            d.criterion,
            static=True,
            choices=_criteria,
            setting=S + "criterion",
            doc="shaping criterion (S0-9 f1, S0-15 f2)",
        ),
        AxisSpec(
            "task", "str", d.task, static=True, choices=TASKS, setting=S + "task", doc="task rows of K_T (SPEC 2)"
        ),
        AxisSpec(
            "locked_joints",
            "str",
            d.locked_joints,
            static=True,
            choices=SHAPE_LOCKED_JOINT_MODES,
            setting=S + "locked_joints",
            doc="locked joints rigid (no spring, no stiffness variable, kj = inf; SPEC 1) or spring",
        ),
        AxisSpec(
            "solver",
            "str",
            d.solver,
            static=True,
            choices=_solvers,
            setting=S + "solver",
            doc="solver of jaxstiff.shape",
        ),
        AxisSpec(
            "starts",
            "int",
            d.starts or 0,
            static=True,
            check=_ge(0),
            setting=S + "starts (None -> 0)",
            doc="starts per waypoint (0: the solver's default; SLSQP: 1)",
        ),
        AxisSpec(
            "ratio",
            "float",
            d.ratio,
            check=_gt(1.0, " (lambda1 / lambda2)"),
            setting=S + "ratio",
            doc="wanted axis ratio r",
        ),
        AxisSpec("c", "float", d.c, check=_ge(0.0), setting=S + "c", doc="offset c of f1 (S0-9)"),
        AxisSpec(
            "dq_deg",
            "float",
            float(f"{math.degrees(d.dq):.12g}"),
            unit="deg per waypoint",
            check=_ge(0.0),
            setting=S + "dq (rad -> deg)",
            doc="joint rate limit (S0-11, S0-12); a prismatic joint gets the same number in m (3 deg -> 0.0524 m)",
        ),
        AxisSpec(
            "dk",
            "float",
            d.dk,
            unit="Nm/rad per waypoint",
            check=_ge(0.0),
            setting=S + "dk",
            doc="stiffness rate limit (S0-13, S0-14)",
        ),
        AxisSpec(
            "kmin", "float", d.kmin, unit="Nm/rad", check=_gt(0.0), setting=S + "kmin", doc="lower stiffness bound"
        ),
        AxisSpec(
            "kmax", "float", d.kmax, unit="Nm/rad", check=_gt(0.0), setting=S + "kmax", doc="upper stiffness bound"
        ),
        AxisSpec(
            "first_rate_limit",
            "bool",
            d.first_rate_limit,
            setting=S + "first_rate_limit",
            doc="apply the rate limits between (q0, kj0) and waypoint 0",
        ),
        AxisSpec(
            "first_starts",
            "int",
            d.first_starts,
            check=_ge(1),
            setting=S + "first_starts",
            doc="IK start postures tried at the first waypoint (no rate limit)",
        ),
        *_q0_specs(),
    )
    return {a.name: a for a in specs}


def _static_choice(d: CSCSettings, name: str, choices: Sequence[str], doc: str) -> AxisSpec:
    """A static csc axis of strings whose default is the CSCSettings field ``name``."""
    return AxisSpec(name, "str", getattr(d, name), static=True, choices=choices, setting="CSCSettings." + name, doc=doc)


def _csc_axes() -> dict[str, AxisSpec]:
    """The axes of a CSC sweep. Long only because it is one table (one entry per axis); kept whole."""
    d = CSCSettings()
    C = "CSCSettings."
    specs = (
        AxisSpec(
            "task",
            "str",
            d.task or CSC_SWEEP_TASK,
            static=True,
            choices=tuple(t for t in CSC_TASKS if t != "full"),
            setting=C + "task (None -> xyz: the sweep's K_xd is 3x3)",
            doc="task rows (K_xd is 2x2 or 3x3)",
        ),
        AxisSpec(
            "step",
            "str",
            d.step,
            static=True,
            choices=STEP_RULES,
            setting=C + "step",
            doc="null-step rule (S1-22 or constant)",
        ),
        AxisSpec(
            "kmin",
            "float",
            d.kmin,
            static=True,
            unit="Nm/rad",
            check=_gt(0.0),
            setting=C + "kmin",
            doc="actuator range, lower",
        ),
        AxisSpec(
            "kmax",
            "float",
            d.kmax,
            static=True,
            unit="Nm/rad",
            check=_gt(0.0),
            setting=C + "kmax",
            doc="actuator range, upper (inf: open)",
        ),
        AxisSpec(
            "newton",
            "int",
            d.newton,
            static=True,
            check=_ge(0),
            setting=C + "newton",
            doc="Newton corrections per step",
        ),
        AxisSpec(
            "joint_limits",
            "str",
            d.joint_limits,
            static=True,
            choices=JOINT_LIMIT_MODES,
            setting=C + "joint_limits",
            doc="joint-limit secondary task",
        ),
        AxisSpec(
            "jl_gain",
            "float",
            d.jl_gain,
            static=True,
            check=_ge(0.0),
            setting=C + "jl_gain",
            doc="joint-limit gain (default: 0.3 with joint_limits on, else 0)",
        ),
        _static_choice(
            d,
            "objective",
            OBJECTIVES,
            "null-space objective: offdiag = u (S1-19, the seed's), frobenius = |K_xd - K_C|_F (S1-10)",
        ),
        _static_choice(
            d, "locked_joints", LOCKED_JOINT_MODES, "locked joints rigid (no spring, SPEC section 1) or spring"
        ),
        AxisSpec(
            "beta",
            "float",
            d.beta,
            check=_both(_ge(0.0), _finite),
            setting=C + "beta",
            doc="null-step multiplier beta (S1-22)",
        ),
        AxisSpec("kxd_major", "float", 3000.0, unit="N/m", check=_both(_gt(0.0), _finite), doc="K_xd major axis"),
        AxisSpec("kxd_ratio", "float", 3.0, check=_both(_ge(1.0), _finite), doc="K_xd major / minor axis"),
        AxisSpec("kxd_angle_deg", "float", 30.0, unit="deg", check=_finite, doc="K_xd major axis angle about base z"),
        *_q0_specs(),
    )
    return {a.name: a for a in specs}


#: The axes of each sweep kind, in the order rows are enumerated (:func:`itertools.product`).
AXES: dict[str, dict[str, AxisSpec]] = {"shape": _shape_axes(), "csc": _csc_axes()}
