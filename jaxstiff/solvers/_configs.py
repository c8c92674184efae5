"""Solver objects: a solver and its options as one typed, frozen value.

``jaxstiff.shape(robot, path, solver=PGD(iters=60, starts=4))`` instead of a solver name and an
options dict: a misspelt option is a ``TypeError`` naming it when the object is made, a bad value a
``ValueError`` naming the option (the checks of :mod:`jaxstiff.settings._solvers`, where every
option's default, unit and meaning are written once), and an editor completes the names.

* :class:`SLSQP`, :class:`SLSQPFD`: greedy per-waypoint SLSQP (JAX derivatives / the seed's finite
  differences), the fields of :class:`~jaxstiff.settings._solvers.SLSQPOptions`;
* :class:`PGD`: batched multi-start projected gradient (:class:`~jaxstiff.settings._solvers.PGDOptions`);
* :class:`Hybrid`: a :class:`PGD` run, then an :class:`SLSQP` polish, plus its own options;
* :class:`Trajectory`: a greedy warm start (a :class:`PGD`, :class:`Hybrid` or :class:`SLSQP`),
  then the whole trajectory at once;
* :class:`Registered`: a solver added with :func:`~jaxstiff.solvers._base.register_solver`, by name,
  with a free options dict.

A name (``solver="pgd"``) still works everywhere: the command line and sweep files name solvers,
and :func:`solver_from_name` turns a name and an options dict into the object. The objects pass on
only the options that differ from the defaults, so that a run with ``PGD()`` is the run with
``solver="pgd"`` bit for bit, and the result's ``meta`` is the same.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from typing import Any, ClassVar

from jaxstiff.runtime._messages import suggest
from jaxstiff.settings._solvers import HybridOptions, PGDOptions, SLSQPOptions, SolverOptions, TrajectoryOptions

__all__ = ["SLSQP", "SLSQPFD", "PGD", "Hybrid", "Trajectory", "Registered", "solver_from_name"]


def _changed(obj: SolverOptions, cls: type[SolverOptions]) -> dict[str, Any]:
    """The fields of ``cls`` whose value in ``obj`` differs from the default."""
    defaults = cls.defaults()
    return {k: getattr(obj, k) for k in cls.field_names() if getattr(obj, k) != defaults[k]}


class _Named:
    """What every solver object has: ``name`` (its registry name) and :meth:`options`, by default
    the fields of its options class ``options_of`` that differ from their defaults."""

    name: ClassVar[str] = ""
    options_of: ClassVar[type[SolverOptions] | None] = None

    def options(self) -> dict[str, Any]:
        """The options dict the solver reads (only the values that differ from its defaults)."""
        return {} if self.options_of is None else _changed(self, self.options_of)  # type: ignore[arg-type]


@dataclasses.dataclass(frozen=True)
class SLSQP(SLSQPOptions, _Named):
    """Greedy per-waypoint SLSQP with exact JAX derivatives (``"slsqp"``, the default solver)."""

    name: ClassVar[str] = "slsqp"
    options_of: ClassVar[type[SolverOptions] | None] = SLSQPOptions


@dataclasses.dataclass(frozen=True)
class SLSQPFD(SLSQPOptions, _Named):
    """The seed's own method: SLSQP with numpy and finite differences (``"slsqp-fd"``; the speed baseline)."""

    name: ClassVar[str] = "slsqp-fd"
    options_of: ClassVar[type[SolverOptions] | None] = SLSQPOptions


@dataclasses.dataclass(frozen=True)
class PGD(PGDOptions, _Named):
    """Batched multi-start projected gradient (``"pgd"``): many paths at once, on CPU or GPU."""

    name: ClassVar[str] = "pgd"
    options_of: ClassVar[type[SolverOptions] | None] = PGDOptions


@dataclasses.dataclass(frozen=True)
class Hybrid(HybridOptions, _Named):
    """pgd, then SLSQP from pgd's answers (``"hybrid"``): ``pgd`` and ``slsqp`` configure the two
    stages, the other fields are the hybrid's own (:class:`~jaxstiff.settings._solvers.HybridOptions`)."""

    name: ClassVar[str] = "hybrid"
    pgd: PGD = dataclasses.field(default_factory=PGD)
    slsqp: SLSQP = dataclasses.field(default_factory=SLSQP)

    def __post_init__(self) -> None:
        super().__post_init__()
        _check_type(self, "pgd", PGD)
        _check_type(self, "slsqp", SLSQP)

    def options(self) -> dict[str, Any]:
        """The flat options dict of the hybrid: its stages' and its own, defaults left out."""
        return {**self.pgd.options(), **self.slsqp.options(), **_changed(self, HybridOptions)}


#: the solvers a :class:`Trajectory` may start from
WarmStart = PGD | Hybrid | SLSQP


@dataclasses.dataclass(frozen=True)
class Trajectory(TrajectoryOptions, _Named):
    """A greedy warm start, then the whole trajectory at once (``"trajectory"``): ``warm`` is the
    warm-start solver with its own options (``PGD()``, ``Hybrid()``, ``SLSQP()``, or its name
    ``"pgd"``, ``"hybrid"``, ``"slsqp"`` for the one with default options); the other fields are
    the trajectory stage's (:class:`~jaxstiff.settings._solvers.TrajectoryOptions`)."""

    name: ClassVar[str] = "trajectory"
    warm: WarmStart = dataclasses.field(default_factory=PGD)  # type: ignore[assignment]

    def __post_init__(self) -> None:
        if isinstance(self.warm, str) and self.warm in ("pgd", "hybrid", "slsqp"):
            object.__setattr__(self, "warm", _BY_NAME[self.warm]())  # frozen: set once, here
        elif isinstance(self.warm, str):
            raise ValueError(
                f"Trajectory.warm: unknown warm start {self.warm!r}{suggest(self.warm, ('pgd', 'hybrid', 'slsqp'))}; "
                "give 'pgd', 'hybrid' or 'slsqp', or one of those solver objects with options (PGD(...), Hybrid(...), SLSQP(...))"
            )
        _check_type(self, "warm", (PGD, Hybrid, SLSQP))
        for f in dataclasses.fields(self):  # the trajectory stage's own fields (warm is an object here)
            if f.name != "warm":
                self._check_field(f, getattr(self, f.name))

    def options(self) -> dict[str, Any]:
        """The trajectory stage's options, ``warm`` (the warm start's name) and ``warm_options``."""
        own = {k: v for k, v in _changed(self, TrajectoryOptions).items() if k != "warm"}
        out: dict[str, Any] = {**own, "warm": self.warm.name} if self.warm.name != "pgd" else dict(own)
        if self.warm.options():
            out["warm_options"] = self.warm.options()
        return out


@dataclasses.dataclass(frozen=True)
class Registered(_Named):
    """A solver added with :func:`~jaxstiff.solvers._base.register_solver`: its name and its options
    (a free dict: such a solver checks its own)."""

    solver: str
    opts: Mapping[str, Any] = dataclasses.field(default_factory=dict)

    def __post_init__(self) -> None:
        if not isinstance(self.solver, str):
            raise TypeError(f"Registered.solver must be the registered name (a str), got {self.solver!r}")
        if not isinstance(self.opts, Mapping):
            raise TypeError(f"Registered.opts must be a mapping {{option: value}}, got {self.opts!r}")

    def options(self) -> dict[str, Any]:
        """The options dict as given."""
        return dict(self.opts)


#: what ``shape(solver=...)`` takes besides a name
Solver = SLSQP | SLSQPFD | PGD | Hybrid | Trajectory | Registered

_BY_NAME: dict[str, type[Any]] = {c.name: c for c in (SLSQP, SLSQPFD, PGD, Hybrid, Trajectory)}


def _check_type(obj: Any, field: str, cls: type | tuple[type, ...]) -> None:
    v = getattr(obj, field)
    if not isinstance(v, cls):
        names = " or ".join(c.__name__ for c in (cls if isinstance(cls, tuple) else (cls,)))
        raise TypeError(f"{type(obj).__name__}.{field} must be a {names} object, got {v!r}")


def solver_from_name(name: str, options: Mapping[str, Any] | None = None) -> Solver:
    """The object for a solver name and a flat options dict (as the command line, sweep files and
    older calls give them): ``solver_from_name("pgd", {"iters": 60})`` is ``PGD(iters=60)``. For the
    trajectory solver, the options of its warm start (named by ``warm``) are the dict's entries
    that the warm start reads (those it shares with the trajectory stage, such as ``newton``, go
    to both, as in a flat dict). A name not shipped gives :class:`Registered`. Unknown options or
    bad values: ``ValueError`` naming them (:func:`~jaxstiff.solvers._base.check_options`)."""
    from jaxstiff.solvers._base import check_options

    opts = dict(options or {})
    check_options(name, opts)
    cls = _BY_NAME.get(name)
    if cls is None:
        return Registered(name, opts)
    if cls is Hybrid:
        return Hybrid(pgd=PGD(**PGDOptions.own(opts)), slsqp=SLSQP(**SLSQPOptions.own(opts)), **HybridOptions.own(opts))
    if cls is Trajectory:
        from jaxstiff.solvers._base import solver_option_names

        own = {k: v for k, v in TrajectoryOptions.own(opts).items() if k not in ("warm", "warm_options")}
        wname = str(opts.get("warm", "pgd"))
        if "warm_options" in opts:
            wopts = dict(opts["warm_options"])
        else:  # a flat dict: the warm start reads the entries it knows (shared ones go to both)
            wopts = {k: v for k, v in opts.items() if k in (solver_option_names(wname) or ())}
        return Trajectory(warm=solver_from_name(wname, wopts), **own)  # type: ignore[arg-type]
    return cls(**cls.own(opts))


def solver_call(solver: Any) -> tuple[str, dict[str, Any]]:
    """``(name, options)`` for a solver object or a name (what the registry and the meta record use)."""
    if isinstance(solver, str):
        return solver, {}
    if isinstance(solver, Registered):
        return solver.solver, solver.options()
    if isinstance(solver, _Named) and solver.name:
        return solver.name, solver.options()
    raise TypeError(
        "solver must be a name ('slsqp', 'slsqp-fd', 'pgd', 'hybrid', 'trajectory' or a registered one) or a "
        f"solver object (jaxstiff.solvers.SLSQP, SLSQPFD, PGD, Hybrid, Trajectory, Registered), got {solver!r}"
    )
