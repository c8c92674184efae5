"""Null-space Configuration-based Stiffness Control (seed 001, SPEC section 6) as a differentiable
rollout (``jaxstiff.csc.X`` keeps working for every public name of the former ``csc.py``)."""

from .rollout import CSCResult as CSCResult
from .rollout import csc_rollout as csc_rollout
from .rollout import csc_rollout_segments as csc_rollout_segments
from .rollout import CSCInterrupted as CSCInterrupted
from .rollout import null_space_direction as null_space_direction
from .rollout import offdiag_gradient as offdiag_gradient
from .rollout import project_to_target as project_to_target
from .rollout import STATUS_OK as STATUS_OK
from .rollout import STATUS_DAMPED as STATUS_DAMPED
from .rollout import STATUS_JOINT_LIMIT as STATUS_JOINT_LIMIT
from .rollout import STATUS_NAN as STATUS_NAN
from .rollout import STATUS_NULL_SMALL as STATUS_NULL_SMALL
from .rollout import describe_status as describe_status
