"""CSCSettings: the settings of Configuration-based Stiffness Control (seed 001), defaults written once.

``csc_rollout()``, ``jaxstiff csc`` and a sweep's ``[csc]`` axes read their defaults here.
Seed 001 fixes the update rule (S1-13 ... S1-22) but not these numbers; every one is this
project's choice (SPEC section 6; the :mod:`jaxstiff.csc` docstrings say why). The flags of
``jaxstiff csc`` and the sweep's csc ``[axes]`` are made from these fields (:mod:`jaxstiff.settings._base`);
a swept field is static (one compiled rollout per value) unless its ``Axis`` says otherwise.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Literal

from jaxstiff.settings._base import Axis, Settings, positive, positive_finite, setting

__all__ = ["CSCSettings", "CSC_TASKS"]

CSC_TASKS = ("xy", "xyz", "full")  #: task rows; None = from the size of K_xd
TASK_BY_SIZE = {2: "xy", 3: "xyz", 6: "full"}  #: the task of a K_xd of size m x m (task None)
STEP_RULES = ("adaptive", "constant")  #: S1-22 (beta x |dq_P|) or a constant null-step length
JOINT_LIMIT_MODES = ("off", "priority", "sum")
#: the null-space objective: the seed's off-diagonal norm u (S1-19) or |K_xd - K_C(q)|_F itself (S1-10)
OBJECTIVES = ("offdiag", "frobenius")
#: a locked joint without a spring (SPEC section 1's default) or with one (a compliant actuator holding it)
LOCKED_JOINT_MODES = ("rigid", "spring")
DEFAULT_JL_GAIN = 0.3  #: the joint-limit gain used when avoidance is on and no gain is given
CSC_SWEEP_TASK = "xyz"  #: task None resolved for a sweep's 3x3 K_xd (jaxstiff.sweep._axes)


def _is_real(v: object) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and not math.isnan(v)


def _finite_non_negative(v: object) -> str | None:
    return None if _is_real(v) and math.isfinite(v) and v >= 0 else "must be a finite number >= 0"  # type: ignore[arg-type]


def _isotropy_threshold(v: object) -> str | None:
    return None if _is_real(v) and 0 <= v < 1 else "must be a number in [0, 1) (the isotropy is in [0, 1])"  # type: ignore[operator]


def _optional_positive(v: object) -> str | None:
    return (
        None
        if v is None
        else (
            None
            if _is_real(v) and math.isfinite(v) and v > 0  # type: ignore[arg-type]
            else "must be a finite number > 0 (or None: from K_xd and the dtype)"
        )
    )


def _optional_gain(v: object) -> str | None:
    return None if v is None else _finite_non_negative(v)


#: the most Newton corrections per step: each is unrolled into the compiled step (1000 compiled
#: for minutes); 1 keeps the TCP on a reachable path to ~1e-6 m at 3 cm waypoint spacing, 2 to ~1e-11 m
MAX_NEWTON = 50


def _newton_count(v: object) -> str | None:
    if isinstance(v, int) and not isinstance(v, bool) and 0 <= v <= MAX_NEWTON:
        return None
    return f"must be an integer 0..{MAX_NEWTON} (each correction is compiled into the step; 1 is the default)"


@dataclasses.dataclass(frozen=True)
class CSCSettings(Settings):
    """Settings of :func:`jaxstiff.csc_rollout` besides the robot, path, K_xd and q0.

    ``beta`` is also :func:`~jaxstiff.csc_rollout`'s fifth argument (default: this one). A None
    ``task`` follows from the size of K_xd (:data:`TASK_BY_SIZE`); a None ``null_eps`` is
    ``1e-9 |K_xd|_F`` (1e-5 in float32) plus tiny^(1/4); a None ``jl_gain`` is
    :data:`DEFAULT_JL_GAIN` with ``joint_limits`` priority or sum, else 0 (:attr:`resolved_jl_gain`).
    """

    section = "csc"
    sweep_static = True  # a rollout compiles per value: a swept field is part of the group key

    task: str | None = setting(
        None,
        choices=(None, *CSC_TASKS),
        doc="task rows (default: from the size of K_xd: 2 xy, 3 xyz, 6 full)",
        # a sweep's K_xd is 2x2 or 3x3 (jaxstiff.sweep._axes.kxd_matrix): None is xyz there
        axis=Axis(from_field=lambda v: v or CSC_SWEEP_TASK, choices=("xy", "xyz")),
    )
    step: str = setting(
        "adaptive",
        choices=STEP_RULES,
        doc="null-space step rule: adaptive = beta x |dq_P| (S1-22), constant = a null step of length beta",
    )
    beta: float = setting(
        1.0,
        unit="1 (adaptive) or rad per step (constant; m for prismatic joints)",
        doc="null-step multiplier (S1-22); constant rule: the null-step length",
        check=_finite_non_negative,
        axis=Axis(static=False, unit=""),  # one value per rollout: csc_rollout's fifth argument
    )
    kmin: float = setting(1.0, unit="Nm/rad", doc="actuator range: lowest joint stiffness", check=positive_finite)
    kmax: float = setting(
        math.inf, unit="Nm/rad", doc="actuator range: highest joint stiffness (inf: open)", check=positive
    )
    nu0: float = setting(
        1e-2,
        unit="1",
        doc="isotropy threshold: damping below nu0^(m/2) (S1-16's damped inverse)",
        check=_isotropy_threshold,
        axis=None,
    )
    damping: float = setting(
        0.1,
        unit="1",
        doc="relative damping lam / sqrt(tr(J J^T)/m) at a singularity",
        check=_finite_non_negative,
        axis=None,
    )
    null_eps: float | None = setting(
        None,
        unit="Nm/rad^2",
        doc="floor of |dq_N| (default: 1e-9 |K_xd|_F, from the dtype)",
        check=_optional_positive,
        axis=None,
    )
    newton: int = setting(
        1,
        doc="Newton corrections q += J+ (x_d - x(q)) of the TCP inside each step: 1 (default) keeps the TCP on a "
        "reachable path to ~1e-6 m at 3 cm waypoint spacing (~3e-8 m at 1 cm; the error shrinks with the spacing); "
        "2 reaches ~1e-11 m (0: drifts ~1e-6 m over 400 steps; scripts/bench_csc_newton.py)",
        check=_newton_count,
    )
    joint_limits: str = setting(
        "off",
        choices=JOINT_LIMIT_MODES,
        doc="joint-limit avoidance as a secondary task (joints are always clamped to their limits)",
    )
    jl_gain: float | None = setting(
        None,
        unit="rad per step (priority) or 1 (sum)",
        doc=f"joint-limit avoidance gain: priority = rad per step for a joint at its limit (before the projection), "
        f"sum = weight against the CSC gradient at a limit (default: {DEFAULT_JL_GAIN} with joint_limits priority "
        f"or sum, else 0)",
        check=_optional_gain,
        axis=Axis(unit=""),
    )

    objective: Literal["offdiag", "frobenius"] = setting(
        "offdiag",
        choices=OBJECTIVES,
        doc="null-space objective: offdiag = the seed's u(q), the off-diagonal norm of J^T K_xd J (S1-19); "
        "frobenius = |K_xd - K_C(q)|_F with K_C from the realised diagonal joint stiffness (S1-10; this "
        "project's own, beyond the seed); both are reported either way",
    )
    locked_joints: Literal["rigid", "spring"] = setting(
        "rigid",
        choices=LOCKED_JOINT_MODES,
        doc="locked joints: rigid = no spring (no compliance, no stiffness variable; kj reported as +inf; "
        "SPEC section 1) or spring = the locked joint keeps its spring in K_C, u and kj",
    )

    def __post_init__(self) -> None:
        super().__post_init__()
        if not self.kmax > self.kmin:  # a range of one value is a fixed spring: kj would not follow K_xd
            raise ValueError(
                f"csc.kmax ({self.kmax:g}) must be above csc.kmin ({self.kmin:g}) (Nm/rad): CSC chooses kj in that range"
            )

    @property
    def resolved_jl_gain(self) -> float:
        """The joint-limit gain that applies (:data:`DEFAULT_JL_GAIN` when avoidance is on and none is given)."""
        if self.jl_gain is not None:
            return float(self.jl_gain)
        return DEFAULT_JL_GAIN if self.joint_limits != "off" else 0.0
