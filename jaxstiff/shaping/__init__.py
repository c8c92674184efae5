"""``shape()``: stiffness-ellipsoid shaping along TCP paths (seed 000, SPEC section 5).

For every waypoint of every path, joint positions q and joint stiffnesses kj are chosen so that the
stiffness ellipsoid's major axis follows the desired direction with the wanted axis ratio
(criterion f1 or f2), the TCP stays exactly on the path, and q and kj change no faster than the
rate limits allow (S0-10 ... S0-14). Afterwards the common-mode stiffness factor (CMS, S0 section
III) scales each waypoint's kj so that its ellipsoid reaches a target size.

The defaults the seed leaves open live in :class:`~jaxstiff.settings.ShapeSettings` (values, units,
docs, written there once; every result file records them in ``meta["settings"]``). Without ``q0``
and ``kj0``: ``q0`` is damped-least-squares IK (:mod:`jaxstiff.ik`) from the nominal posture to the
first waypoint, ``kj0`` is mid-range. Why these values: docs/notes/shape.md.

This package is the one way in to the pipeline; its steps are private modules: check the inputs
and make the start states (``_inputs``) -> solve (a solver in :data:`SOLVERS`; add one with
:func:`register_solver`; ``_shape``) -> report, CMS and meta (``_steps``) ->
:class:`~jaxstiff.ShapeResult`. What it exports: :func:`shape` (also ``jaxstiff.shape``),
:func:`run_shape` (the solver by name, its options as a dict: the command line and the sweeps),
the solver registry, :data:`DEFAULTS` (``meta["defaults"]``), :func:`first_start_postures` (the
extra first-waypoint starts), :class:`ShapeInterrupted` and :func:`prefer_sync_cpu_dispatch` (the CPU
dispatch switch that :func:`run_shape` makes first).

Example:
    >>> import jaxstiff
    >>> robot = jaxstiff.Robot.from_urdf("kuka_lwr4", locked={"lwr_a7": 0.0})
    >>> res = jaxstiff.shape(robot, jaxstiff.default_path(n=10), "f2", 5.0)   # doctest: +SKIP
    >>> res.status.shape                                                       # doctest: +SKIP
    (1, 10)
"""

from __future__ import annotations

from jaxstiff.runtime._moved import former_names
from jaxstiff.shaping._inputs import first_start_postures
from jaxstiff.shaping._shape import DEFAULTS, ShapeInterrupted, prefer_sync_cpu_dispatch, run_shape, shape
from jaxstiff.solvers._base import SOLVERS, register_solver

__all__ = [
    "DEFAULTS",
    "SOLVERS",
    "ShapeInterrupted",
    "first_start_postures",
    "prefer_sync_cpu_dispatch",
    "register_solver",
    "run_shape",
    "shape",
]

#: names this module exported before it became a package, still answered with a
#: DeprecationWarning naming where each lives
_FORMER = {
    "INLINE_SETTINGS": "jaxstiff.shaping._shape",
    "DEPRECATED_KEYWORDS": "jaxstiff.shaping._shape",
    "cpu_async_dispatch": "jaxstiff.shaping._shape",
    "check_inputs": "jaxstiff.shaping._inputs",
    "make_start_states": "jaxstiff.shaping._inputs",
    "first_start_rng": "jaxstiff.shaping._inputs",
    "FIRST_STARTS_SEED": "jaxstiff.shaping._inputs",
    "FIRST_STARTS_SPREAD_DEG": "jaxstiff.shaping._inputs",
    "SolveRequest": "jaxstiff.solvers._base",
    "SolverInterrupted": "jaxstiff.solvers._base",
    "options_for_solver": "jaxstiff.solvers._base",
    "solver_option_names": "jaxstiff.solvers._base",
}
__getattr__ = former_names(__name__, _FORMER)
