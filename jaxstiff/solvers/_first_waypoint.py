"""The first waypoint without a rate limit, solved by the exact solver (SLSQP) for the batch solvers.

Why: that waypoint's box is the whole joint and stiffness range, and its problem is non-convex and
non-smooth (f2's ``|r - rho|`` and ``|alpha|``; rho's second axis is the larger of two eigenvalues,
whose crossing is a kink), with its optimum often on the stiffness bounds (some joints at
``kmin``, others at ``kmax``). pgd's fixed budget of surrogate, Levenberg-Marquardt and projected
Adam steps stalls there in poorer local optima than SLSQP reaches from the very same IK starts:
measured on the UR10 (tip tool0), one straight-line waypoint, the 8 starts greedy SLSQP uses
(q0 and 7 IK postures, kj0 mid-range): SLSQP reached f2 = 1.0012 (rho 4.9988, alpha 0) from 2 of
them, pgd's stages from none (best f2 14.4, rho 1.54). The arms differ in scale and frame, not
in this: the LWR's first waypoints are easier, not different (docs/notes/solvers.md).

What: :func:`exact_first_answers` runs greedy SLSQP's own first-waypoint search (its starts, its
iteration budget ``first_maxiter``, its rescue starts drawn over the whole ranges when no start
is provably in target: :func:`jaxstiff.solvers._greedy.greedy_path`) for every path at once, the
SLSQP solves advancing in lockstep with their kernel calls batched
(:mod:`jaxstiff.solvers._lockstep`). Its usable answers, best first, become pgd's first-waypoint
starts; pgd keeps a start that its own stages do not improve, so its first waypoint is at least
as good as the best answer it was given (:meth:`jaxstiff.solvers._pgd.kernel.PGDKernel.one_start`).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from jaxstiff.results import _files as R
from jaxstiff.runtime._programs import program_cache
from jaxstiff.solvers._greedy import (
    Candidate,
    SolverOutput,
    judge,
    maybe_off_target,
    rescue_starts,
)
from jaxstiff.solvers._lockstep import RowsProgram, Steps, gather, run_lockstep
from jaxstiff.solvers._problem import WaypointBatch, WaypointProblem, clip_to_box, compiled_scaled_rows, jax_pos_and_jac

__all__ = [
    "SLSQP_OPTION_NAMES",
    "rows_program",
    "lockstep_slsqp",
    "rows_objective",
    "prepare_first_answers",
]

#: the SLSQP options a batch solver's options may carry for this stage
SLSQP_OPTION_NAMES = ("maxiter", "first_maxiter", "ftol", "kj_scale", "f_scale", "driver")


@program_cache(maxsize=16)
def rows_program(problem: WaypointProblem, scale: tuple[float, ...], x64: bool) -> RowsProgram:
    """The lockstep evaluations of SLSQP's scaled kernel for ``problem`` (scale: SLSQP's variable
    scale, :func:`jaxstiff.solvers._slsqp.variable_scale`, with the criterion's), one object per
    problem, scale and x64 flag (the one in force when it is called): its programs, once compiled
    for a row count, serve every later search of the process (a row's result has the same bits at
    every bucket size almost everywhere, :class:`~jaxstiff.solvers._lockstep.RowsProgram`)."""
    return RowsProgram(compiled_scaled_rows(problem), jnp.asarray(np.asarray(scale, float)))


def rows_objective(program: RowsProgram) -> Callable[[np.ndarray, np.ndarray], float]:
    """``(x, params) -> f`` on a :func:`rows_program` itself, called with a unit scale (x as it is,
    f unscaled; the scale is an argument of the compiled programs): a lockstep caller's criterion
    for its answers without a single-point program to compile (2 s of a cold first pgd call on
    the LWR, 2-core CPU). A row's value is the one it has in any of the program's calls."""
    unit = jnp.ones_like(program.consts[0])

    def objective(x: np.ndarray, params: np.ndarray) -> float:
        return float(program.at_points(np.asarray(x, float)[None], np.asarray(params, float)[None], unit)[0, 0])

    return objective


def lockstep_slsqp(batch: WaypointBatch, options: Mapping[str, Any] | None) -> tuple[RowsProgram, Any]:
    """SLSQP's solver for ``batch`` with the SLSQP options among ``options``
    (:data:`SLSQP_OPTION_NAMES`), driven only through its ``steps`` (no single-point programs
    compiled), and the shared rows program those steps are evaluated with: ``(program, solver)``
    for a lockstep caller (this search, the hybrid's polish)."""
    from jaxstiff.solvers._slsqp import make_slsqp_solver

    sl_opts = {k: v for k, v in (options or {}).items() if k in SLSQP_OPTION_NAMES}
    solver = make_slsqp_solver(batch.problem, sl_opts, (batch.limits.kmin, batch.limits.kmax), compile_now=False)
    scale = tuple(float(v) for v in np.asarray(solver.scale, float).ravel())  # the x64 flag in force
    return rows_program(batch.problem, scale, bool(jax.config.read("jax_enable_x64"))), solver


def prepare_first_answers(batch: WaypointBatch, options: Mapping[str, Any] | None = None) -> None:
    """Start building, on a background thread, the 16-row program that :func:`exact_first_answers`
    evaluates ``batch``'s search with (its first program for a few paths, and its last rounds'
    for any number): for a caller that may run the search after a compilation of its own. pgd
    calls it before tracing its kernel, seconds of Python on one core that leave the other idle
    on a CPU; the program's XLA compilation (about 2 s on a 2-core CPU) runs there instead of
    after pgd's run. Costs a compilation nobody uses when the search does not run."""
    program, _ = lockstep_slsqp(batch, options)
    n_params = len(WaypointProblem.params(np.zeros(3), np.ones(3), 1.0, 0.0))
    program.prepare(16, batch.problem.nx, n_params)


def exact_first_answers(
    batch: WaypointBatch,
    first_starts: Sequence[Sequence[tuple[np.ndarray, np.ndarray]]] | None,
    options: Mapping[str, Any] | None = None,
    pos_tol: float = 1e-9,
    criteria: list[float] | None = None,
) -> list[list[np.ndarray]]:
    """Per path, the usable SLSQP answers (decision vectors ``x = [q_free, kj]``) of its first
    waypoint, lowest criterion first, from greedy SLSQP's starts: the start state ``(q0, kj0)``,
    the given ``first_starts`` and, where none of those answers is provably in target, as many
    rescue starts again (:func:`jaxstiff.solvers._greedy.greedy_path`'s first waypoint, for every
    path in lockstep). The first waypoint's box is the whole range (no rate limit: the caller
    runs this only then). A path with no usable answer gets an empty list. ``criteria``, a list
    given by the caller, receives each path's lowest criterion there (inf without a usable answer).
    """
    problem, limits = batch.problem, batch.limits
    program, solver = lockstep_slsqp(batch, options)
    maxiter = int(solver.options["first_maxiter"])
    pos_and_jac, objective = jax_pos_and_jac(problem), rows_objective(program)
    B = batch.targets.shape[0]

    def one(b: int, x_start: np.ndarray, lb: np.ndarray, ub: np.ndarray) -> Steps[Candidate]:
        params = WaypointProblem.params(batch.targets[b, 0], batch.directions[b, 0], float(batch.ratios[b]), batch.c)
        try:
            sol = yield from solver.steps(x_start.copy(), lb, ub, params, maxiter=maxiter)
        except (ValueError, ArithmeticError, np.linalg.LinAlgError, FloatingPointError):
            sol = SolverOutput(x_start.copy(), -1, False, 0, 0)
        x, status, err = judge(
            problem, sol, x_start, lb, ub, batch.targets[b, 0], params, pos_and_jac, objective, pos_tol
        )
        f = objective(x, params) if status in R.USABLE else np.inf
        return x, status, err, sol.code, f

    boxes: list[tuple[np.ndarray, np.ndarray]] = []
    starts: list[list[np.ndarray]] = []
    for b in range(B):
        lim = limits.for_path(b)
        q0, kj0 = np.asarray(batch.q0[b], float), np.asarray(batch.kj0[b], float)
        lb, ub = lim.box(problem, q0, kj0, False)
        boxes.append((lb, ub))
        given = first_starts[b] if first_starts else ()
        xs = [problem.x_of(q0, kj0)] + [problem.x_of(np.asarray(q, float), np.asarray(k, float)) for q, k in given]
        starts.append([clip_to_box(x, lb, ub) for x in xs])

    def search(b: int) -> Steps[list[Candidate]]:
        """Path b's search: its starts side by side; where none is provably in target, as many again
        from the whole ranges (greedy SLSQP's rescue), at once, while other paths' starts still run.
        (Run as two lockstep phases, every path's rescue waited for the slowest start of any path:
        on the UR10, 36 paths, 2494 + 3520 rounds where a path's own two phases take fewer.)"""
        found = yield from gather([one(b, x, *boxes[b]) for x in starts[b]])
        if maybe_off_target(problem, found, float(batch.ratios[b]), batch.c):
            lb, ub = boxes[b]
            more = rescue_starts(
                problem, len(starts[b]), starts[b][0], lb, ub, batch.targets[b, 0], batch.directions[b, 0]
            )
            found += yield from gather([one(b, x, lb, ub) for x in more])
        return found

    cands = run_lockstep([search(b) for b in range(B)], program)
    out = []
    for b in range(B):
        usable = sorted((c for c in cands[b] if c[1] in R.USABLE), key=lambda c: c[4])
        out.append([np.asarray(c[0], float) for c in usable])
        if criteria is not None:
            criteria.append(float(usable[0][4]) if usable else np.inf)
    return out
