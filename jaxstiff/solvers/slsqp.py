"""Seed 000's method with exact derivatives: one SLSQP solve per waypoint, greedy along the path.

Each waypoint is the problem of :mod:`jaxstiff.solvers.problem` (S0-10 ... S0-14), solved with
``scipy.optimize.minimize(method="SLSQP")`` from the previous waypoint's state. Objective,
gradient, equality constraint and its Jacobian come from one jitted JAX function (compiled once
per robot/task/criterion, not per waypoint), called once per distinct point SLSQP asks about and
cached, so a SLSQP iteration costs one kernel call.

After SLSQP the answer is made exactly feasible and judged (status codes of
:mod:`jaxstiff.results`): clipped into the box, projected back onto the path with Newton steps
inside the box if needed, then checked (position error, box, finiteness). A waypoint that cannot
be reached keeps its status and the run goes on from the last usable state.

:func:`greedy_path` is the chaining loop, shared with the finite-difference baseline
(:mod:`jaxstiff.solvers.slsqp_fd`) and reusable by any per-waypoint solver.
"""

from __future__ import annotations

import dataclasses
import time
from typing import Callable, Sequence

import numpy as np

from .. import results as R
from .problem import (
    POS_TOL,
    BOUND_TOL,
    Limits,
    WaypointProblem,
    clip_to_box,
    compiled,
    compiled_position,
    compiled_scaled,
    jax_pos_and_jac,
    newton_project,
)

__all__ = ["WaypointOutcome", "SolverOutput", "greedy_path", "make_slsqp_solver", "solve_path", "DEFAULT_OPTIONS"]

#: SLSQP settings used unless overridden (``shape(..., options=...)``): ``maxiter`` iterations per
#: waypoint (``first_maxiter`` for a first waypoint that is not rate-limited: a long way from the
#: start posture), ``ftol`` SLSQP's accuracy goal (objective change and constraint violation;
#: 1e-8 gives alpha to ~1e-6 deg on the default path), and the scaling SLSQP sees: stiffness in
#: units of ``kj_scale`` Nm/rad (so q in rad and kj are both of order 1: 2.5x as many first
#: waypoints aligned as unscaled), the criterion times ``f_scale`` (fewer line-search steps).
DEFAULT_OPTIONS = {"maxiter": 200, "first_maxiter": 1000, "ftol": 1e-8, "kj_scale": 100.0, "f_scale": 0.1}

REPAIR_POS = 1e-6  #: m: a solver answer further than this off the path counts as CLIPPED when repaired


@dataclasses.dataclass
class SolverOutput:
    """What a per-waypoint solver returns: its point and its own bookkeeping."""

    x: np.ndarray
    code: int  # the solver's own exit code (SLSQP mode); -1 = exception
    converged: bool
    nit: int
    nfev: int


@dataclasses.dataclass
class WaypointOutcome:
    """Final, checked state of one waypoint."""

    x: np.ndarray
    status: int
    pos_error: float
    code: int
    nit: int
    nfev: int
    time_s: float


#: ``solver(x0, lb, ub, params, maxiter=None) -> SolverOutput``
WaypointSolver = Callable[..., SolverOutput]


def make_slsqp_solver(problem: WaypointProblem, options: dict | None = None) -> WaypointSolver:
    """A per-waypoint SLSQP solver ``(x0, lb, ub, params, maxiter=None) -> SolverOutput``, JAX derivatives."""
    from scipy.optimize import Bounds, minimize

    opts = {**DEFAULT_OPTIONS, **(options or {})}
    fused_s = compiled_scaled(problem)
    # compile now (once per problem and dtype), so that waypoint timings exclude compilation
    t0 = time.perf_counter()
    x_dummy = problem.x_of(np.nan_to_num(problem.robot.locked_values) + 0.1, np.ones(problem.n))
    np.asarray(fused_s(x_dummy, WaypointProblem.params(np.zeros(3), [1.0, 0.0, 0.0], 2.0, 0.0), np.ones(problem.nx + 1)))
    np.asarray(compiled_position(problem)(np.nan_to_num(problem.robot.locked_values)))
    compile_s = time.perf_counter() - t0
    nx, k = problem.nx, len(problem.pos_rows)
    sl_f, sl_g, sl_c = 0, slice(1, 1 + nx), slice(1 + nx, 1 + nx + k)
    sl_a = slice(1 + nx + k, None)

    # SLSQP works on y = x / scale: stiffness in units of kj_scale (Nm/rad), joints in rad; the
    # scaling is applied inside the kernel, so each evaluation is one call and array views.
    scale = np.r_[np.ones(problem.n_free), np.full(problem.n, float(opts["kj_scale"]))]
    svec = np.r_[scale, float(opts["f_scale"])]

    def solve(x0, lb, ub, params, maxiter=None) -> SolverOutput:
        last = [b"", None]
        count = [0]

        def ev(y):
            key = y.tobytes()
            if key != last[0]:
                last[0] = key
                last[1] = np.asarray(fused_s(y, params, svec))
                count[0] += 1
            return last[1]

        def fun(y):
            out = ev(y)
            return out[sl_f], out[sl_g]

        cons = {
            "type": "eq",
            "fun": lambda y: ev(y)[sl_c],
            "jac": lambda y: ev(y)[sl_a].reshape(k, nx),
        }
        res = minimize(
            fun, x0 / scale, jac=True, bounds=Bounds(lb / scale, ub / scale), constraints=[cons], method="SLSQP",
            options={"maxiter": int(maxiter or opts["maxiter"]), "ftol": float(opts["ftol"])},
        )
        x = np.asarray(res.x, float) * scale
        return SolverOutput(x, int(res.status), int(res.status) == 0, int(res.nit), count[0])

    solve.options = opts  # type: ignore[attr-defined]
    solve.compile_s = compile_s  # type: ignore[attr-defined]
    return solve


def _judge(
    problem: WaypointProblem,
    sol: SolverOutput,
    x_start: np.ndarray,
    lb: np.ndarray,
    ub: np.ndarray,
    target: np.ndarray,
    params: np.ndarray,
    pos_and_jac,
    objective: Callable[[np.ndarray, np.ndarray], float],
    pos_tol: float,
) -> tuple[np.ndarray, int, float]:
    """Make the solver's answer exactly feasible if possible and give it its status code."""
    nf = problem.n_free
    locked = np.nan_to_num(problem.robot.locked_values)
    free = list(problem.free_idx)
    rows = list(problem.pos_rows)

    def pos_err(x):
        q = locked.copy()
        q[free] = x[:nf]
        p, _ = pos_and_jac(q)
        e_rows = float(np.linalg.norm(p[rows] - target[rows]))
        return float(np.linalg.norm(p - target)), e_rows

    x = np.asarray(sol.x, float)
    nonfinite = not np.all(np.isfinite(x))
    if nonfinite:
        x = clip_to_box(x_start, lb, ub)
    excursion = float(np.max(np.r_[lb - x, x - ub, 0.0]))
    x = clip_to_box(x, lb, ub)
    err3, err_rows = pos_err(x)
    repaired = False
    if not np.isfinite(err_rows) or err_rows > 1e-13:
        x_new = newton_project(problem, x, target, lb, ub, pos_and_jac)
        e3_new, er_new = pos_err(x_new)
        if np.isfinite(er_new) and (not np.isfinite(err_rows) or er_new < err_rows):
            repaired = err_rows > REPAIR_POS
            x, err3, err_rows = x_new, e3_new, er_new
    f = objective(x, params) if np.all(np.isfinite(x)) else float("nan")
    if nonfinite or not np.isfinite(f) or not np.isfinite(err3):
        return x, R.NONFINITE, err3
    if err3 > pos_tol:
        return x, R.UNREACHABLE, err3
    if excursion > BOUND_TOL or repaired:
        return x, R.CLIPPED, err3
    return x, (R.SOLVED if sol.converged else R.NOT_CONVERGED), err3


TIE_RTOL = 1e-3  #: criteria within this relative distance of the best one count as equally good


def _pick(problem: WaypointProblem, cands):
    """The best of several answers for one waypoint: usable first, then the lowest criterion; among
    usable answers whose criterion is within :data:`TIE_RTOL` of the best (f2 and f1 have whole
    sets of optimal postures), the one farthest from the joint limits (smallest normalised margin
    of the free joints), so the next waypoints have room before a limit binds."""
    usable = [c for c in cands if c[1] in R.USABLE]
    if not usable:
        return min(cands, key=lambda c: c[2])
    fbest = min(c[4] for c in usable)
    ties = [c for c in usable if c[4] <= fbest + TIE_RTOL * max(abs(fbest), 1e-12)]
    lo, hi = problem.robot.lower, problem.robot.upper
    free = list(problem.free_idx)
    nf = problem.n_free
    span = np.where(np.isfinite(hi - lo), hi - lo, np.inf)[free]

    def margin(c):
        qf = c[0][:nf]
        m = np.minimum(qf - lo[free], hi[free] - qf) / span
        return float(np.min(np.where(np.isfinite(m), m, np.inf))) if nf else 0.0

    return max(ties, key=margin)


def greedy_path(
    problem: WaypointProblem,
    targets: np.ndarray,
    directions: np.ndarray,
    q0: np.ndarray,
    kj0: np.ndarray,
    limits: Limits,
    ratio: float,
    c: float,
    solver: WaypointSolver,
    pos_and_jac=None,
    objective: Callable[[np.ndarray, np.ndarray], float] | None = None,
    pos_tol: float = POS_TOL,
    progress: Callable[[int], None] | None = None,
    first_starts: Sequence[tuple[np.ndarray, np.ndarray]] = (),
    first_maxiter: int | None = None,
) -> list[WaypointOutcome]:
    """Solve the waypoints of one path one after the other (seed 000's greedy scheme).

    Waypoint p's box is built around the reference state: the last usable waypoint's
    (q, kj), or the start state ``(q0, kj0)`` before the first usable waypoint (with the rate
    limits only if ``limits.first_rate_limit``). The solver starts from the reference state
    clipped into the box.

    Args:
        problem: the waypoint problem.
        targets, directions: (P, 3).
        q0, kj0: (n,) start state.
        limits: stiffness range and rate limits.
        ratio, c: criterion parameters.
        solver: ``(x0, lb, ub, params) -> SolverOutput``.
        pos_and_jac: ``q -> (position (3,), J[rows][:, free])`` for the repair and the check;
            default: the JAX kernel.
        objective: ``(x, params) -> f`` for the final check; default: the JAX kernel.
        pos_tol: position tolerance (m) of a usable waypoint.
        progress: called with the waypoint index after each waypoint.
        first_starts: extra start states ``(q (n,), kj (n,))`` for the first waypoint when it is
            not rate-limited: the solver runs from the reference state and from each of these,
            and the usable answer with the lowest criterion is kept (a multi-start against the
            non-convexity of the first, unconstrained waypoint); ties (within 0.1%) go to the
            posture farthest from the joint limits (:func:`_pick`).
        first_maxiter: iteration limit for that first, not rate-limited waypoint (None: the
            solver's default).

    Returns:
        One :class:`WaypointOutcome` per waypoint.
    """
    if pos_and_jac is None:
        pos_and_jac = jax_pos_and_jac(problem)
    if objective is None:
        fused = compiled(problem)

        def objective(x, params):
            return float(np.asarray(fused(x, params))[0])

    q_ref, kj_ref = np.asarray(q0, float), np.asarray(kj0, float)
    at_start = True
    out: list[WaypointOutcome] = []
    for p in range(targets.shape[0]):
        t0 = time.perf_counter()
        rate = limits.first_rate_limit or not at_start
        lb, ub = limits.box(problem, q_ref, kj_ref, rate)
        x_start = clip_to_box(problem.x_of(q_ref, kj_ref), lb, ub)
        params = WaypointProblem.params(targets[p], directions[p], ratio, c)
        starts = [x_start]
        if not rate:
            starts += [clip_to_box(problem.x_of(qs, ks), lb, ub) for qs, ks in first_starts]
        cands = []
        nit = nfev = 0
        for xs in starts:
            try:
                sol = solver(xs.copy(), lb, ub, params, maxiter=None if rate else first_maxiter)
            except (ValueError, ArithmeticError, np.linalg.LinAlgError, FloatingPointError):
                sol = SolverOutput(xs.copy(), -1, False, 0, 0)
            nit, nfev = nit + sol.nit, nfev + sol.nfev
            x, status, err = _judge(problem, sol, xs, lb, ub, targets[p], params, pos_and_jac, objective, pos_tol)
            if status == R.NONFINITE:
                x = x_start
            f = objective(x, params) if status in R.USABLE else np.inf
            cands.append((x, status, err, sol.code, f))
        x, status, err, code, _ = _pick(problem, cands)
        out.append(WaypointOutcome(x, status, err, code, nit, nfev, time.perf_counter() - t0))
        if status in R.USABLE:
            q_ref = q_ref.copy()
            q_ref[list(problem.free_idx)] = x[: problem.n_free]
            kj_ref = x[problem.n_free :].copy()
            at_start = False
        if progress is not None:
            progress(p)
    return out


def solve_path(problem, targets, directions, q0, kj0, limits, ratio, c, options=None, progress=None):
    """Greedy SLSQP with JAX derivatives along one path; see :func:`greedy_path`."""
    solver = make_slsqp_solver(problem, options)
    return greedy_path(
        problem, targets, directions, q0, kj0, limits, ratio, c, solver, progress=progress,
        first_maxiter=solver.options["first_maxiter"],
    )
