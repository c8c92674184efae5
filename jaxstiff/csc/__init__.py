"""Null-space Configuration-based Stiffness Control (seed 001, SPEC section 6) as a differentiable
rollout (``jaxstiff.csc.X`` keeps working for every public name of the former ``csc.py``).

Modules: :mod:`.result` (CSCResult, status bits), :mod:`.algebra` (small dense algebra),
:mod:`.offdiag` (u and its gradient, with their VJP), :mod:`.frobenius` (the objective
``|K_xd - K_C|_F`` and its gradient), :mod:`.pose` (kinematics with closed-form
JVPs, orientation error), :mod:`.projections` (damped J+ and I - J+ J), :mod:`.measures` (realised
stiffness), :mod:`.step` (one step), :mod:`.inputs` (settings and checks), :mod:`.rollout`
(csc_rollout), :mod:`.segments` (long runs), :mod:`.direction` (single-posture tools)."""

from .direction import null_space_direction as null_space_direction
from .direction import project_to_target as project_to_target
from .frobenius import frobenius_gradient as frobenius_gradient
from .offdiag import offdiag_gradient as offdiag_gradient
from .result import STATUS_DAMPED as STATUS_DAMPED
from .result import STATUS_JOINT_LIMIT as STATUS_JOINT_LIMIT
from .result import STATUS_NAMES as STATUS_NAMES
from .result import STATUS_NAN as STATUS_NAN
from .result import STATUS_NULL_SMALL as STATUS_NULL_SMALL
from .result import STATUS_OK as STATUS_OK
from .result import CSCResult as CSCResult
from .result import CSCStatus as CSCStatus
from .result import describe_status as describe_status
from .rollout import csc_rollout as csc_rollout
from .segments import CSCInterrupted as CSCInterrupted
from .segments import csc_rollout_segments as csc_rollout_segments
