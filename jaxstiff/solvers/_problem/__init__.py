"""The per-waypoint shaping problem of seed 000 (SPEC section 5, S0-10 ... S0-14), solver-agnostic.

For waypoint p with target position ``x_p``, desired direction ``d_p`` and the previous state
``(q_{p-1}, kj_{p-1})``::

    (q_p, kj_p) = argmin  f(K_T(q, kj), d_p, r, c)                                   (S0-10)
        subject to  position(T(q))[rows] = x_p[rows]                                  (primary task)
                    max(q_min, q_{p-1} - dq) <= q  <= min(q_max, q_{p-1} + dq)        (S0-11, S0-12)
                    max(k_min, kj_{p-1} - dk) <= kj <= min(k_max, kj_{p-1} + dk)      (S0-13, S0-14)
                    locked joints fixed

Decision vector ``x = [q_free (n_free), kj_spring (n_spring)]``: the free joints' positions (rad
or m) and the stiffness (Nm/rad) of every joint with a spring. By default a locked joint is rigid
(SPEC section 1): no spring, no stiffness variable, no compliance term, its ``kj`` entry ``+inf``,
so ``n_spring = n_free``; with ``WaypointProblem(..., locked_joints="spring")`` a locked joint keeps
its spring and its stiffness is a variable (``n_spring = n``). ``rows`` are the position rows of the task: (x, y) for ``"xy"`` (a planar chain
cannot move along z, the z equation would be a zero row), (x, y, z) otherwise.

Everything here is a pure function of its inputs; :class:`WaypointProblem` is a frozen, hashable
description (robot, task, criterion) so that one compilation serves every waypoint of every path:

* :meth:`WaypointProblem.objective` ``(q, kj, d, r, c) -> f``, :meth:`~WaypointProblem.residual`
  ``(q, target) -> position - target``: traceable, vmappable building blocks for any solver
  (SLSQP here; projected gradient and trajectory-level solvers build on the same functions).
* :func:`compiled` ``(problem) -> fused(x, params)``: one jitted call returning objective,
  gradient, constraint and constraint Jacobian in one flat float64 array, compiled once per
  problem (cached), for callers that work on numpy vectors (SLSQP).
* :func:`box` the rate-limited bounds (numpy), :func:`clip_to_box`, :func:`newton_project` (put a
  point back on the position constraint inside the box) and :func:`check_point` (the honest
  per-waypoint verdict, used for the status codes of :mod:`jaxstiff.results`).

Units: metres, radians, Nm/rad; the criterion's alpha is in degrees (seed 000).

Modules: :mod:`.waypoint` (:class:`WaypointProblem`), :mod:`.compiled` (the jitted, cached kernels),
:mod:`.box` (bounds, :class:`Limits`, projection, checks); every name is importable from here.

Example:
    >>> import jaxstiff
    >>> from jaxstiff.solvers import WaypointProblem
    >>> robot = jaxstiff.Robot.from_urdf("kuka_lwr4", locked={"lwr_a7": 0.0})
    >>> prob = WaypointProblem(robot, "full", jaxstiff.f2)
    >>> prob.n_free, prob.nx  # lwr_a7 rigid: 6 joint + 6 stiffness variables
    (6, 12)
    >>> WaypointProblem(robot, "full", jaxstiff.f2, locked_joints="spring").nx
    13
"""

from jaxstiff.solvers._problem.box import BOUND_TOL as BOUND_TOL
from jaxstiff.solvers._problem.box import POS_TOL as POS_TOL
from jaxstiff.solvers._problem.box import Limits as Limits
from jaxstiff.solvers._problem.box import PointCheck as PointCheck
from jaxstiff.solvers._problem.box import WaypointBatch as WaypointBatch
from jaxstiff.solvers._problem.box import box as box
from jaxstiff.solvers._problem.box import check_point as check_point
from jaxstiff.solvers._problem.box import clip_to_box as clip_to_box
from jaxstiff.solvers._problem.box import content_seed as content_seed
from jaxstiff.solvers._problem.box import newton_project as newton_project
from jaxstiff.solvers._problem.box import rate_bounds as rate_bounds
from jaxstiff.solvers._problem.compiled import compiled as compiled
from jaxstiff.solvers._problem.compiled import compiled_evaluate as compiled_evaluate
from jaxstiff.solvers._problem.compiled import compiled_position as compiled_position
from jaxstiff.solvers._problem.compiled import compiled_report as compiled_report
from jaxstiff.solvers._problem.compiled import compiled_scaled as compiled_scaled
from jaxstiff.solvers._problem.compiled import compiled_scaled_rows as compiled_scaled_rows
from jaxstiff.solvers._problem.compiled import jax_pos_and_jac as jax_pos_and_jac
from jaxstiff.solvers._problem.compiled import report_rows as report_rows
from jaxstiff.solvers._problem.compiled import warm_report as warm_report
from jaxstiff.solvers._problem.waypoint import WaypointProblem as WaypointProblem
