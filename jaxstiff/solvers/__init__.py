"""Solvers for stiffness-ellipsoid shaping along paths (SPEC section 5).

* :mod:`.problem`  the waypoint problem (objective, position constraint, rate-limited box, checks);
* :mod:`.slsqp`    seed 000's greedy per-waypoint SLSQP with exact JAX derivatives (``"slsqp"``);
* :mod:`.slsqp_fd` the seed's own way, numpy + finite differences, the speed baseline (``"slsqp-fd"``).

Solvers are chosen by name in :func:`jaxstiff.shape` (registry :data:`jaxstiff.solvers.base.SOLVERS`).
"""

from jaxstiff.solvers.problem import Limits as Limits
from jaxstiff.solvers.problem import WaypointProblem as WaypointProblem
