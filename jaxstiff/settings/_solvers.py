"""The options of the shipped solvers, one frozen dataclass per solver: defaults written once.

``shape(..., solver=..., options={...})``, ``jaxstiff shape --option`` and a sweep's
``solver_options`` pass options as a dict; :meth:`SolverOptions.check_values` checks and normalises
those values (a ``ValueError`` naming the solver, the option, what is allowed and the value), and
each solver's ``DEFAULT_OPTIONS`` dict is :meth:`~jaxstiff.settings._base.Settings.defaults` of its
class here. What the options do is documented in the solver modules (:mod:`jaxstiff.solvers._slsqp`,
:mod:`jaxstiff.solvers._pgd`, :mod:`jaxstiff.solvers._hybrid`, :mod:`jaxstiff.solvers._trajectory`).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterable, Mapping
from typing import Any, ClassVar

import numpy as np

from jaxstiff.settings._base import Settings, setting

__all__ = [
    "OptionRule",
    "option",
    "SolverOptions",
    "SLSQPOptions",
    "PGDOptions",
    "HybridOptions",
    "TrajectoryOptions",
    "WARM_STARTS",
    "OPTIONS_OF",
]

WARM_STARTS = ("pgd", "hybrid", "slsqp")  #: the greedy solvers the trajectory solver's ``warm`` may name

_KINDS = ("int", "positive", "nonnegative")  # the order in which values are checked


@dataclasses.dataclass(frozen=True)
class OptionRule:
    """What a numeric option accepts: ``kind`` "int" (an integer >= ``lo``; an integer-valued float
    such as 2.0 is taken, 2.5 or "many" is not), "positive" / "nonnegative" (a finite number > 0 /
    >= 0). ``parse``: numbers are read with ``float()`` (strings such as "1e-8" are taken)."""

    kind: str
    lo: int = 0
    parse: bool = False
    optional: bool = False  #: None is taken too (the option's "work it out" value)

    def normalise(self, label: str, name: str, v: Any) -> Any:
        """``v`` as int / float, or a ValueError naming ``label``'s option ``name``."""
        if self.optional and _is_none(v):
            return None
        if self.kind == "int":
            ok = not isinstance(v, bool) and (
                isinstance(v, (int, np.integer)) or (isinstance(v, (float, np.floating)) and float(v).is_integer())
            )
            if not ok or v < self.lo:
                raise ValueError(f"{label} option {name!r} must be an integer >= {self.lo}, got {v!r}")
            return int(v)
        strict = self.kind == "positive"
        if self.parse:
            try:
                f = float(v)
            except (TypeError, ValueError):
                f = float("nan")
        else:
            num = not isinstance(v, bool) and isinstance(v, (int, float, np.integer, np.floating))
            f = float(v) if num else float("nan")
        if not math.isfinite(f) or (f <= 0.0 if strict else f < 0.0):
            raise ValueError(f"{label} option {name!r} must be a finite number {'>' if strict else '>='} 0, got {v!r}")
        return f

    def __call__(self, v: Any) -> str | None:
        """The :func:`~jaxstiff.settings._base.setting` check: what is wrong with ``v``, or None."""
        try:
            self.normalise("", "", v)
        except ValueError as e:
            msg = str(e)
            return msg[msg.index("must ") : msg.rindex(", got")]
        return None


def _is_none(v: Any) -> bool:
    return v is None


def option(
    default: Any,
    doc: str = "",
    *,
    unit: str = "",
    kind: str | None = None,
    lo: int = 0,
    parse: bool = False,
    optional: bool = False,
    choices: Iterable[Any] | None = None,
) -> Any:
    """A solver option field: a :func:`~jaxstiff.settings._base.setting` with an :class:`OptionRule`."""
    if kind is not None and kind not in _KINDS:
        raise ValueError(f"option kind must be one of {_KINDS}, got {kind!r}")
    rule = None if kind is None else OptionRule(kind, lo, parse, optional)
    return setting(default, unit=unit, doc=doc, choices=choices, check=rule)


class SolverOptions(Settings):
    """Base of the solvers' option classes: :meth:`check_values` checks an options dict."""

    #: the solver's name in error messages ("pgd option 'iters' must be ...")
    label: ClassVar[str] = ""

    @classmethod
    def choice_text(cls, allowed: tuple[Any, ...]) -> str:
        """How the allowed values of a choice option are written in an error message."""
        return "one of " + ", ".join(map(repr, allowed))

    @classmethod
    def check_values(cls, opts: Mapping[str, Any]) -> dict[str, Any]:
        """A copy of ``opts`` with this solver's option values checked and normalised (integers to
        int, numbers to float) before any work: integers first, then numbers > 0, numbers >= 0 and
        choices, each in declaration order. Entries that are not options of this class are left
        alone. ValueError naming the option on a bad value."""
        out = dict(opts)
        fields = dataclasses.fields(cls)  # type: ignore[arg-type]
        for kind in _KINDS:
            for f in fields:
                rule = f.metadata.get("check")
                if f.name in out and isinstance(rule, OptionRule) and rule.kind == kind:
                    out[f.name] = rule.normalise(cls.label, f.name, out[f.name])
        for f in fields:
            allowed = f.metadata.get("choices")
            if f.name in out and allowed is not None and out[f.name] not in allowed:
                raise ValueError(
                    f"{cls.label} option {f.name!r} must be {cls.choice_text(allowed)}, got {out[f.name]!r}"
                )
        return out

    @classmethod
    def own(cls, opts: Mapping[str, Any] | None) -> dict[str, Any]:
        """The entries of ``opts`` that are options of this class."""
        names = set(cls.field_names())
        return {k: v for k, v in (opts or {}).items() if k in names}


@dataclasses.dataclass(frozen=True)
class SLSQPOptions(SolverOptions):
    """Greedy per-waypoint SLSQP (``"slsqp"``, ``"slsqp-fd"``; :mod:`jaxstiff.solvers._slsqp`)."""

    label = "SLSQP"
    section = "slsqp"

    maxiter: int = option(200, "SLSQP iterations per waypoint", kind="int", lo=1)
    first_maxiter: int = option(1000, "iterations at a first waypoint that is not rate-limited", kind="int", lo=1)
    ftol: float = option(
        1e-8, "SLSQP's accuracy goal (objective change and constraint violation)", kind="positive", parse=True
    )
    kj_scale: float | None = option(
        None,
        "stiffness unit inside SLSQP (None: kmax, so that SLSQP sees kj / kmax in [kmin / kmax, 1] whatever "
        "the range's units; 100 kmin where kmax is not finite)",
        unit="Nm/rad",
        kind="positive",
        parse=True,
        optional=True,
    )
    f_scale: float = option(0.1, "factor on the criterion inside SLSQP", kind="positive", parse=True)
    path_retries: int | None = option(
        None,
        "when a path has a rate-limited waypoint off target: other first-waypoint optima the path is walked "
        "again from, the best walk kept (0: seed 000's greedy scheme alone; None: 8 for slsqp, 0 for "
        "slsqp-fd, the seed's method)",
        kind="int",
        optional=True,
    )
    target_step: str = option(
        "auto",
        "rate-limited waypoints (f1, f2) of slsqp's greedy walk: lm: Levenberg-Marquardt onto the criterion's "
        "least value first, SLSQP only where that does not reach it; none: SLSQP everywhere; auto: lm for "
        "slsqp, none for slsqp-fd (the seed's method) and the hybrid's polish, which have no target step",
        choices=("auto", "lm", "none"),
    )
    driver: str = option(
        "lean",
        "lean: scipy's SLSQP routine from a minimal loop; scipy: scipy.optimize.minimize",
        choices=("lean", "scipy"),
    )

    @classmethod
    def choice_text(cls, allowed: tuple[Any, ...]) -> str:
        """``'lean' or 'scipy'``."""
        return ", ".join(map(repr, allowed[:-1])) + f" or {allowed[-1]!r}"


@dataclasses.dataclass(frozen=True)
class PGDOptions(SolverOptions):
    """Multi-start projected gradient, batched (``"pgd"``; :mod:`jaxstiff.solvers._pgd`)."""

    label = "pgd"
    section = "pgd"

    starts: int = option(8, "S starts per waypoint (best) or independent rollouts (rollout)", kind="int", lo=1)
    mode: str = option("rollout", "how the S starts are used", choices=("best", "rollout"))
    iters: int = option(40, "projected gradient iterations per start and waypoint", kind="int", lo=1)
    iters_first: int = option(
        150, "iterations at the first waypoint (its box is the whole joint range)", kind="int", lo=1
    )
    starts_first: int = option(16, "starts at the first waypoint (best mode; rollouts: S)", kind="int", lo=1)
    newton: int = option(2, "Newton corrections after each step", kind="int", lo=0)
    polish: int = option(6, "Newton corrections of the final point", kind="int", lo=0)
    surrogate: float = option(0.0, "fraction of the iterations spent on the smooth surrogate first", kind="nonnegative")
    surrogate_first: float = option(0.5, "the same at the first waypoint (no warm start there)", kind="nonnegative")
    step0_first: float = option(0.15, "first step at the first waypoint, fraction of the box width", kind="positive")
    step0: float = option(0.05, "first step, fraction of the box width", kind="positive")
    step1: float = option(1e-5, "last step, fraction of the box width", kind="positive")
    spread: float = option(
        0.5, "random starts: fraction of the box half-width around the reference", kind="nonnegative"
    )
    posture_spread: float = option(
        0.6, "joint perturbation of the first-waypoint postures (no rate limit)", unit="rad", kind="nonnegative"
    )
    accept_tol: float = option(
        1e-7, "position error of an iterate that may be kept as the best", unit="m", kind="positive"
    )
    iters_lm: int = option(10, "criterion iterations after the LM stage (f1, f2; later waypoints)", kind="int", lo=1)
    lm_iters: int = option(
        20, "Levenberg-Marquardt steps on the f1/f2 residuals before the gradient stage", kind="int", lo=0
    )
    lm_iters_first: int = option(25, "the same at the first waypoint", kind="int", lo=0)
    lm_wpos: float = option(
        1e3,
        "weight of the position rows in the LM residual, per length unit of the robot (the power of two "
        "nearest its size, Robot.length_scale: 1 m for the LWR, 4 m for the planar 3R)",
        kind="positive",
    )
    lm_walign: float = option(100.0, "weight of the alignment rows against the log-ratio row", kind="positive")
    tie_tol: float = option(
        1e-7,
        "starts within this (relative) of the best criterion tie; the one farthest from the limits is kept",
        kind="nonnegative",
    )
    chunk: int = option(
        0,
        "trajectories per compiled call (0: automatic: 8 on a CPU, where a call's cost per trajectory "
        "does not fall with its size and the first-waypoint retry reruns its few paths in a whole "
        "call; 256 on an accelerator, a memory bound)",
        kind="int",
        lo=0,
    )
    threads: int = option(
        0, "compiled calls running at once on a CPU (0: one per usable core; 1 on a GPU)", kind="int", lo=0
    )
    seed: int = option(0, "seed of the random starts", kind="int", lo=0)
    first_exact: str = option(
        "retry",
        "first waypoint without rate limit: retry: paths whose first waypoint pgd leaves out of "
        "target are solved again from greedy SLSQP's answers there (jaxstiff.solvers._first_waypoint), "
        "the better rollout kept; slsqp: every path starts from those answers; none: pgd's own stages alone",
        choices=("retry", "slsqp", "none"),
    )


@dataclasses.dataclass(frozen=True)
class HybridOptions(SolverOptions):
    """The hybrid's own options, besides pgd's and SLSQP's (``"hybrid"``; :mod:`jaxstiff.solvers._hybrid`)."""

    label = "hybrid"
    section = "hybrid"

    polish_slsqp: str = option(
        "all",
        "all: SLSQP polishes every waypoint; unusable: only where pgd found no usable point",
        choices=("all", "unusable"),
    )
    chain: str = option(
        "greedy", "greedy: SLSQP chains from its own previous waypoint; pgd: from pgd's", choices=("greedy", "pgd")
    )
    polish_skip_tol: float = option(
        1e-6,
        "pgd's admissible waypoints whose criterion is within this (relative) of the criterion's "
        "least possible value (f2: 1, f1: c) are kept without SLSQP; 0 polishes them all",
        kind="nonnegative",
    )


@dataclasses.dataclass(frozen=True)
class TrajectoryOptions(SolverOptions):
    """The trajectory solver's own options; its warm start's are those of that solver
    (``"trajectory"``; :mod:`jaxstiff.solvers._trajectory`)."""

    label = "trajectory"
    section = "trajectory"

    warm: str = option("pgd", "greedy warm start", choices=WARM_STARTS)
    traj_iters: int = option(240, "Adam steps over the whole trajectory (all blocks)", kind="int", lo=1)
    blocks: int = option(
        4, "feasibility pass + best-so-far after each block; penalty weight grows per block", kind="int", lo=1
    )
    traj_step0: float = option(0.3, "first step, fraction of the rate limit", kind="positive")
    traj_step1: float = option(0.003, "last step, fraction of the rate limit", kind="positive")
    mu0: float = option(10.0, "first penalty weight; x10 per block", kind="positive")
    newton: int = option(2, "Newton corrections after each step", kind="int", lo=0)
    polish: int = option(8, "Newton corrections of the final point", kind="int", lo=0)
    traj_lm_rounds: int = option(
        4,
        "rounds of the whole-trajectory Levenberg-Marquardt stage before the Adam steps (built-in f1/f2; "
        "augmented-Lagrangian rate limits, multipliers updated and penalty x10 per round; 0: no such stage)",
        kind="int",
        lo=0,
    )
    traj_lm_iters: int = option(
        200,
        "Levenberg-Marquardt steps per round (at most: a round ends early once no step is accepted)",
        kind="int",
        lo=1,
    )
    traj_lm_rho0: float = option(
        1.0, "first penalty weight of the rate limits in that stage (per rate limit squared)", kind="positive"
    )
    chunk: int = option(64, "trajectories per compiled call", kind="int", lo=1)
    threads: int = option(
        0, "compiled calls running at once on a CPU (0: one per usable core; 1 on a GPU)", kind="int", lo=0
    )


#: the option classes of the shipped solvers (the hybrid also reads pgd's and SLSQP's)
OPTIONS_OF: dict[str, tuple[type[SolverOptions], ...]] = {
    "slsqp": (SLSQPOptions,),
    "slsqp-fd": (SLSQPOptions,),
    "pgd": (PGDOptions,),
    "hybrid": (PGDOptions, SLSQPOptions, HybridOptions),
    "trajectory": (TrajectoryOptions,),
}
