"""Solvers for stiffness-ellipsoid shaping along paths (SPEC section 5).

* :mod:`.problem`  the waypoint problem (objective, position constraint, rate-limited box, checks);
* :mod:`.slsqp`    seed 000's greedy per-waypoint SLSQP with exact JAX derivatives (``"slsqp"``);
* :mod:`.slsqp_fd` the seed's own way, numpy + finite differences, the speed baseline (``"slsqp-fd"``).

A solver is chosen in :func:`jaxstiff.shape` by an object holding its options (:mod:`.configs`:
``SLSQP``, ``SLSQPFD``, ``PGD``, ``Hybrid``, ``Trajectory``, ``Registered``) or by its name (registry
:data:`jaxstiff.solvers.base.SOLVERS`).
"""

from jaxstiff.solvers.configs import PGD as PGD
from jaxstiff.solvers.configs import SLSQP as SLSQP
from jaxstiff.solvers.configs import SLSQPFD as SLSQPFD
from jaxstiff.solvers.configs import Hybrid as Hybrid
from jaxstiff.solvers.configs import Registered as Registered
from jaxstiff.solvers.configs import Trajectory as Trajectory
from jaxstiff.solvers.problem import Limits as Limits
from jaxstiff.solvers.problem import WaypointProblem as WaypointProblem
