"""The solver registry: :class:`SolveRequest`, :data:`SOLVERS`, :func:`register_solver`, and the
checks and meta record of the shipped solvers' options.

The shipped solvers (``slsqp``, ``slsqp-fd``, ``pgd``, ``hybrid``, ``trajectory``) are registered
here by name and imported on first use, so ``import jaxstiff`` loads none of them.
"""

from __future__ import annotations

import dataclasses
import importlib
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np

from jaxstiff.settings._shape import SINGLE_START_SOLVERS, SOLVER_NAMES
from jaxstiff.settings._solvers import (
    OPTIONS_OF,
    WARM_STARTS,
    HybridOptions,
    PGDOptions,
    SLSQPOptions,
    TrajectoryOptions,
)
from jaxstiff.solvers._problem import WaypointBatch

__all__ = ["SolveRequest", "SOLVERS", "register_solver", "solver_defaults", "check_options"]


# ---------------------------------------------------------------------- solver registry
@dataclasses.dataclass(frozen=True, eq=False)
class SolveRequest(WaypointBatch):
    """Everything a registered solver gets: the paths (the :class:`~jaxstiff.solvers._problem.WaypointBatch`
    fields, so a request is passed as is to the batch solvers) and how to solve them.

    Attributes (besides ``problem``, ``targets``, ``directions``, ``q0``, ``kj0``, ``limits``, ``ratio``, ``c``):
        starts: number of starts (multi-start solvers).
        options: solver options (dict).
        pos_tol: m, position tolerance of a usable waypoint.
        progress: ``progress(b, p)`` after each waypoint, or None.
        first_starts: per path, the first waypoint's extra start states ``(q (n,), kj (n,))``.
    """

    starts: int | None
    options: dict[str, Any] | None
    pos_tol: float
    progress: Callable[[int, int], None] | None
    first_starts: Sequence[Sequence[tuple[np.ndarray, np.ndarray]]]


#: A solver maps a :class:`SolveRequest` to a dict of arrays: ``q``, ``kj`` (B,P,n), ``status``,
#: ``pos_error``, ``solver_code``, ``nit``, ``nfev``, ``time_s`` (B,P), and optionally ``compile_s``
#: (float, compilation time kept out of ``time_s``) and ``time_s_run_only`` (True: ``time_s`` is the
#: run of compiled programs alone, no compilation in it). Every point with a usable
#: status (0-2) must satisfy the box of its reference state exactly and the position within
#: ``pos_tol``; the reported quantities are recomputed by :func:`shape`.
SOLVERS: dict[str, Callable[[SolveRequest], dict[str, Any]]] = {}


class SolverInterrupted(KeyboardInterrupt):
    """Raised by a solver interrupted (Ctrl-C, or SIGTERM under the command line) after some
    waypoints were finished: ``arrays`` is its full result dict, the waypoints not reached with
    status NOT_RUN (5) at their reference state. Solvers that cannot keep partial work let the
    plain ``KeyboardInterrupt`` through."""

    def __init__(self, arrays: dict[str, Any]):
        super().__init__()
        self.arrays = arrays


def register_solver(name: str, fn: Callable[[SolveRequest], dict[str, Any]]) -> None:
    """Make a solver available as ``shape(..., solver=name)`` and ``jaxstiff shape --solver name``."""
    if not callable(fn):
        raise ValueError(f"solver {name!r} must be callable")
    SOLVERS[name] = fn


def outcomes_to_arrays(
    per_path: Sequence[Sequence[Any]],
    n_free: int,
    q0: np.ndarray,
    free_idx: Sequence[int],
    kj_full: Callable[[np.ndarray], np.ndarray] | None = None,
) -> dict[str, Any]:
    """Per-waypoint outcomes (``x``, ``status``, ``code``, ``nit``, ``nfev``, ``pos_error``, ``time_s``;
    ``per_path[b][p]``) as the :data:`SOLVERS` dict: ``q``, ``kj`` (B, P, n) and (B, P) arrays; locked
    joints keep ``q0`` (B, n). ``kj_full`` (:meth:`WaypointProblem.kj_full`) maps the stiffness
    variables to (n,) (``+inf`` for rigid locked joints); None: they are all n."""
    B, P = len(per_path), len(per_path[0])
    n = q0.shape[-1]
    q = np.repeat(q0[:, None, :], P, axis=1).astype(float)
    kj = np.zeros((B, P, n))
    out: dict[str, np.ndarray] = {
        k: np.zeros((B, P), dtype=dt)
        for k, dt in (
            ("status", np.int64),
            ("solver_code", np.int64),
            ("nit", np.int64),
            ("nfev", np.int64),
            ("pos_error", float),
            ("time_s", float),
        )
    }
    fi = list(free_idx)
    for b, outs in enumerate(per_path):
        for p, o in enumerate(outs):
            q[b, p, fi] = o.x[:n_free]
            kj[b, p] = o.x[n_free:] if kj_full is None else kj_full(o.x[n_free:])
            out["status"][b, p] = o.status
            out["solver_code"][b, p] = o.code
            out["nit"][b, p] = o.nit
            out["nfev"][b, p] = o.nfev
            out["pos_error"][b, p] = o.pos_error
            out["time_s"][b, p] = o.time_s
    out["q"], out["kj"] = q, kj
    return out


def _lazy_solver(module: str, attr: str = "run_request") -> Callable[[SolveRequest], dict[str, Any]]:
    """The solver ``jaxstiff.solvers._<module>.<attr>`` (a private module), imported on first use."""

    def run(req: SolveRequest) -> dict[str, Any]:
        return getattr(importlib.import_module(f"jaxstiff.solvers._{module}"), attr)(req)

    run.__name__ = f"{module}.{attr}"
    return run


register_solver("slsqp", _lazy_solver("slsqp"))  # greedy per-waypoint SLSQP, JAX derivatives (solvers/_slsqp.py)
register_solver("slsqp-fd", _lazy_solver("slsqp_fd"))  # the same, numpy + finite differences
register_solver("pgd", _lazy_solver("pgd"))  # multi-start projected gradient, batched (solvers/_pgd)
register_solver("hybrid", _lazy_solver("hybrid"))  # pgd + SLSQP polish (solvers/_hybrid.py)
register_solver("trajectory", _lazy_solver("trajectory"))  # whole-trajectory optimisation (solvers/_trajectory.py)


# ---------------------------------------------------------------------- solver options
def solver_defaults(solver: str) -> dict[str, Any]:
    """The default options of a shipped solver, as it applies them ({} for a user-registered one).

    The hybrid is pgd followed by an SLSQP polish, so its options are both sets plus its own two.
    The trajectory solver's own options are here; those of its warm start go to ``warm_options``.
    The defaults are those of :mod:`jaxstiff.settings._solvers`."""
    out: dict[str, Any] = {}
    for cls in OPTIONS_OF.get(solver, ()):
        out.update(cls.defaults())
    return out


def solver_option_names(solver: str, warm: str = "pgd") -> set[str] | None:
    """The option names a shipped solver reads (the trajectory solver's include those of its warm
    start ``warm``); None for a user-registered solver (its options are not checked)."""
    if solver not in SOLVER_NAMES:
        return None
    known = set(solver_defaults(solver))
    if solver == "trajectory":
        known |= set(solver_defaults(warm))
    return known


def options_for_solver(solver: str, options: Mapping[str, Any] | None) -> dict[str, Any]:
    """The entries of ``options`` that ``solver`` reads (all of them for a user-registered solver):
    a sweep over several solvers shares one options table."""
    opts = dict(options or {})
    known = solver_option_names(solver, opts.get("warm", "pgd"))
    return opts if known is None else {k: v for k, v in opts.items() if k in known}


def check_options(solver: str, options: Mapping[str, Any] | None) -> None:
    """Unknown option names of a shipped solver are an error (a typo would otherwise be ignored),
    and so are bad values, before any work (a hybrid would otherwise meet a bad SLSQP option only
    after its pgd stage). A user-registered solver checks its own options."""
    if not options:
        return
    if not isinstance(options, Mapping):
        raise ValueError(f"options must be a dict of solver options, got {type(options).__name__}")
    if solver == "trajectory" and "warm_options" in options:  # the warm start's options apart
        _check_split_trajectory(options)
        return
    warm = options.get("warm", "pgd")
    if solver == "trajectory" and warm not in WARM_STARTS:
        raise ValueError(f"option warm must be one of {', '.join(map(repr, WARM_STARTS))}, got {warm!r}")
    known = solver_option_names(solver, warm)
    if known is None:
        return
    unknown = sorted(str(k) for k in options if k not in known)
    if unknown:
        from jaxstiff.runtime._messages import suggest

        hints = [f"{k!r}{suggest(k, sorted(known))}" for k in unknown]
        raise ValueError(
            f"unknown option(s) for solver {solver!r}: {', '.join(hints)}; known: {', '.join(sorted(known))}"
        )
    greedy = warm if solver == "trajectory" else solver  # the part that runs pgd and/or SLSQP
    # values: the trajectory solver's own, then those of the part that runs pgd and/or SLSQP
    classes = OPTIONS_OF[greedy] + ((TrajectoryOptions,) if solver == "trajectory" else ())
    for cls in (TrajectoryOptions, HybridOptions, PGDOptions, SLSQPOptions):
        if cls in classes:
            cls.check_values(cls.own(options))


def _check_split_trajectory(options: Mapping[str, Any]) -> None:
    """:func:`check_options` of the trajectory solver given its warm start's options apart
    (``warm_options``, as :class:`jaxstiff.solvers._configs.Trajectory` passes them)."""
    warm, wopts = options.get("warm", "pgd"), options["warm_options"]
    if warm not in WARM_STARTS:
        raise ValueError(f"option warm must be one of {', '.join(map(repr, WARM_STARTS))}, got {warm!r}")
    if not isinstance(wopts, Mapping):
        raise ValueError(f"option warm_options must be a dict of {warm} options, got {type(wopts).__name__}")
    own = {k: v for k, v in options.items() if k != "warm_options"}
    unknown = sorted(str(k) for k in own if k not in TrajectoryOptions.field_names())
    if unknown:
        raise ValueError(
            f"unknown option(s) for solver 'trajectory' (its warm start's go in warm_options): {', '.join(unknown)}"
        )
    TrajectoryOptions.check_values(own)
    check_options(str(warm), wopts)


def first_starts_use(solver: str, opts_meta: dict[str, Any], n_first: int, first_rate_limit: bool) -> str:
    """What the solver does with the first waypoint's start postures (meta ``first_starts.use``):
    SLSQP solves from each of them, pgd makes them some of its own (more) random starts."""
    if first_rate_limit:
        return "first waypoint rate-limited: solved from q0 alone"
    greedy = solver
    popts = opts_meta["options"]
    if solver == "trajectory":
        popts = opts_meta["warm_options"]
        greedy = str(opts_meta["options"].get("warm", "pgd"))
    if greedy in ("pgd", "hybrid"):
        S = int(opts_meta["starts"])
        S1 = max(S, int(popts["starts_first"])) if popts.get("mode") == "best" else S
        return (
            f"{min(n_first, S1)} of the {S1} first-waypoint starts of pgd (q0 first; the rest random "
            "postures, options starts/starts_first)"
        )
    if greedy in SINGLE_START_SOLVERS:
        return "SLSQP solves the first waypoint from each (q0 first); the best is kept"
    return "passed to the solver as SolveRequest.first_starts"


def options_meta(solver: str, starts: int | None, options: Mapping[str, Any] | None) -> dict[str, Any]:
    """meta's ``starts`` and ``options`` (and ``warm_options`` for the trajectory solver): the
    values the solver ran with, defaults filled in, so that a result file says how it was made."""
    given = dict(options or {})
    own = solver_defaults(solver)
    opts = {**own, **given}
    out: dict[str, Any] = {"options": opts}
    warm = None
    if solver == "trajectory":
        warm = str(opts.get("warm", "pgd"))
        wdef = solver_defaults(warm)
        split = given.pop("warm_options", None)  # the warm start's options given apart (configs.Trajectory)
        out["options"] = opts = {**own, **{k: v for k, v in given.items() if k in own}}
        wgiven = given if split is None else dict(split)
        out["warm_options"] = {**wdef, **{k: v for k, v in wgiven.items() if k in wdef}}
    multi = solver in ("pgd", "hybrid") or warm in ("pgd", "hybrid")
    if not multi:
        out["starts"] = 1
    else:
        target = out["warm_options"] if solver == "trajectory" else opts
        if starts is not None:
            target["starts"] = int(starts)
        out["starts"] = int(target["starts"])
    return out
