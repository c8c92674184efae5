"""Null-space Configuration-based Stiffness Control (seed 001, SPEC section 6) as a differentiable
rollout (``jaxstiff.csc.X`` keeps working for every public name of the former ``csc.py``).

Modules: :mod:`._result` (CSCResult, status bits), :mod:`._algebra` (small dense algebra),
:mod:`._offdiag` (u and its gradient, with their VJP), :mod:`._frobenius` (the objective
``|K_xd - K_C|_F`` and its gradient), :mod:`._pose` (kinematics with closed-form
JVPs, orientation error), :mod:`._projections` (damped J+ and I - J+ J), :mod:`._measures` (realised
stiffness), :mod:`._step` (one step), :mod:`._inputs` (settings and checks), :mod:`._rollout`
(csc_rollout), :mod:`._segments` (long runs), :mod:`._direction` (single-posture tools)."""

from jaxstiff.runtime._moved import former_names

from ._direction import null_space_direction, project_to_target
from ._frobenius import frobenius_gradient
from ._inputs import CSCWarning
from ._offdiag import offdiag_gradient
from ._result import (
    STATUS_DAMPED,
    STATUS_JOINT_LIMIT,
    STATUS_NAMES,
    STATUS_NAN,
    STATUS_NULL_SMALL,
    STATUS_OK,
    CSCResult,
    CSCStatus,
    describe_status,
)
from ._rollout import csc_rollout
from ._segments import CSCInterrupted, csc_rollout_segments

__all__ = [
    "CSCInterrupted",
    "CSCResult",
    "CSCStatus",
    "CSCWarning",
    "STATUS_DAMPED",
    "STATUS_JOINT_LIMIT",
    "STATUS_NAMES",
    "STATUS_NAN",
    "STATUS_NULL_SMALL",
    "STATUS_OK",
    "csc_rollout",
    "csc_rollout_segments",
    "describe_status",
    "frobenius_gradient",
    "null_space_direction",
    "offdiag_gradient",
    "project_to_target",
]

__getattr__ = former_names(__name__, {})  # the former modules (jaxstiff.csc.X read as an attribute)
