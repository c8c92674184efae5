"""Solvers for stiffness-ellipsoid shaping along paths (SPEC section 5).

A solver is chosen in :func:`jaxstiff.shape` by an object holding its options: ``SLSQP``,
``SLSQPFD``, ``PGD``, ``Hybrid``, ``Trajectory``, ``Registered`` (a solver added with
:func:`jaxstiff.shaping.register_solver`), or by its name (the registry
:data:`jaxstiff.shaping.SOLVERS`). ``WaypointProblem`` and ``Limits`` describe the waypoint problem
every solver solves.

The code lives in private modules (their former public paths still import, with a
``DeprecationWarning``):

* :mod:`._problem`  the waypoint problem (objective, position constraint, rate-limited box, checks);
* :mod:`._base`     the solve request, the registry and what the solvers share;
* :mod:`._configs`  the solver objects;
* :mod:`._slsqp`    seed 000's greedy per-waypoint SLSQP with exact JAX derivatives (``"slsqp"``;
  :mod:`._greedy` its per-waypoint loop, :mod:`._lockstep` the paths' solves advanced together,
  :mod:`._first_waypoint` the first waypoint's starts);
* :mod:`._slsqp_fd` the seed's own way, numpy + finite differences, the speed baseline (``"slsqp-fd"``);
* :mod:`._pgd`      multi-start projected gradient, batched over paths (``"pgd"``);
* :mod:`._hybrid`   pgd, then an SLSQP polish (``"hybrid"``);
* :mod:`._trajectory` all waypoints of a path optimised together (``"trajectory"``).
"""

from jaxstiff.runtime._moved import former_names

from ._configs import PGD, SLSQP, SLSQPFD, Hybrid, Registered, Trajectory
from ._problem import Limits, WaypointProblem

__all__ = ["PGD", "SLSQP", "SLSQPFD", "Hybrid", "Limits", "Registered", "Trajectory", "WaypointProblem"]

__getattr__ = former_names(__name__, {})  # the former modules (jaxstiff.solvers.pgd read as an attribute)
