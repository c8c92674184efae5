"""Null-space Configuration-based Stiffness Control (seed 001, SPEC section 6) as a differentiable
rollout (``jaxstiff.csc.X`` keeps working for every public name of the former ``csc.py``).

Modules: :mod:`._result` (CSCResult, status bits), :mod:`._algebra` (small dense algebra),
:mod:`._offdiag` (u and its gradient, with their VJP), :mod:`._frobenius` (the objective
``|K_xd - K_C|_F`` and its gradient), :mod:`._pose` (kinematics with closed-form
JVPs, orientation error), :mod:`._projections` (damped J+ and I - J+ J), :mod:`._measures` (realised
stiffness), :mod:`._step` (one step), :mod:`._inputs` (settings and checks), :mod:`._rollout`
(csc_rollout), :mod:`._segments` (long runs), :mod:`._direction` (single-posture tools)."""

from ._direction import null_space_direction as null_space_direction
from ._direction import project_to_target as project_to_target
from ._frobenius import frobenius_gradient as frobenius_gradient
from ._offdiag import offdiag_gradient as offdiag_gradient
from ._result import STATUS_DAMPED as STATUS_DAMPED
from ._result import STATUS_JOINT_LIMIT as STATUS_JOINT_LIMIT
from ._result import STATUS_NAMES as STATUS_NAMES
from ._result import STATUS_NAN as STATUS_NAN
from ._result import STATUS_NULL_SMALL as STATUS_NULL_SMALL
from ._result import STATUS_OK as STATUS_OK
from ._result import CSCResult as CSCResult
from ._result import CSCStatus as CSCStatus
from ._result import describe_status as describe_status
from ._rollout import csc_rollout as csc_rollout
from ._segments import CSCInterrupted as CSCInterrupted
from ._segments import csc_rollout_segments as csc_rollout_segments
