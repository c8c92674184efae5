"""CSCSettings: the settings of Configuration-based Stiffness Control (seed 001), defaults written once.

``csc_rollout()``, ``jaxstiff csc`` and a sweep's ``[csc]`` axes read their defaults here.
Seed 001 fixes the update rule (S1-20 ... S1-23) but not these numbers; every one is this
project's choice (SPEC section 6; the ``jaxstiff.csc`` docstrings say why).
"""

from __future__ import annotations

import dataclasses
import math

from jaxstiff.settings.base import Settings, non_negative, positive, setting

__all__ = ["CSCSettings", "CSC_TASKS", "STEP_RULES", "JOINT_LIMIT_MODES", "DEFAULT_JL_GAIN"]

CSC_TASKS = ("xy", "xyz", "full")  #: task rows; None = from the size of K_xd
STEP_RULES = ("adaptive", "constant")  #: S1-22 (beta x |dq_P|) or a constant null-step length
JOINT_LIMIT_MODES = ("off", "priority", "sum")
DEFAULT_JL_GAIN = 0.3  #: the joint-limit gain used when avoidance is on and no gain is given


def _optional_positive(v: object) -> str | None:
    return None if v is None else positive(v)


@dataclasses.dataclass(frozen=True)
class CSCSettings(Settings):
    """Settings of :func:`jaxstiff.csc_rollout` besides the robot, path, K_xd, q0 and beta."""

    section = "csc"

    task: str | None = setting(None, choices=(None, *CSC_TASKS), doc="task rows (None: from the size of K_xd)")
    step: str = setting("adaptive", choices=STEP_RULES, doc="null-space step rule")
    beta: float = setting(1.0, unit="1 (adaptive) or rad per step (constant)",
                          doc="null-step multiplier (S1-22); constant rule: the null-step length", check=non_negative)
    kmin: float = setting(1.0, unit="Nm/rad", doc="actuator range: lowest joint stiffness", check=positive)
    kmax: float = setting(math.inf, unit="Nm/rad", doc="actuator range: highest joint stiffness (inf: open)",
                          check=positive)
    nu0: float = setting(1e-2, doc="damping threshold of the least-squares inverse (S1-21's nu0)", check=positive)
    damping: float = setting(0.1, doc="damping factor of the least-squares inverse", check=non_negative)
    null_eps: float | None = setting(None, doc="null-step floor (None: from the dtype)", check=_optional_positive)
    newton: int = setting(0, doc="Newton corrections of the TCP inside each step", check=non_negative)
    joint_limits: str = setting("off", choices=JOINT_LIMIT_MODES, doc="joint-limit avoidance as a secondary task")
    jl_gain: float | None = setting(None, doc=f"joint-limit gain (None: {DEFAULT_JL_GAIN} with avoidance on, else 0)",
                                    check=lambda v: None if v is None else non_negative(v))

    @property
    def resolved_jl_gain(self) -> float:
        """The joint-limit gain that applies (:data:`DEFAULT_JL_GAIN` when avoidance is on and none is given)."""
        if self.jl_gain is not None:
            return float(self.jl_gain)
        return DEFAULT_JL_GAIN if self.joint_limits != "off" else 0.0
