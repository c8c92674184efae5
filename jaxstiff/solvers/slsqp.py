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
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import jax.numpy as jnp
import numpy as np

from jaxstiff.results import files as R
from jaxstiff.settings.solvers import SLSQPOptions
from jaxstiff.solvers.base import SolveRequest, SolverInterrupted, outcomes_to_arrays
from jaxstiff.solvers.problem import (
    BOUND_TOL,
    POS_TOL,
    Limits,
    WaypointProblem,
    clip_to_box,
    compiled,
    compiled_position,
    compiled_scaled,
    jax_pos_and_jac,
    newton_project,
)

__all__ = ["WaypointOutcome", "SolverOutput", "PathInterrupted", "greedy_path", "make_slsqp_solver", "solve_path",
           "DEFAULT_OPTIONS", "run_request", "run_greedy", "check_single_start", "judge"]

#: SLSQP settings used unless overridden (``shape(..., options=...)``), from
#: :class:`~jaxstiff.settings.solvers.SLSQPOptions`: ``maxiter`` iterations per waypoint
#: (``first_maxiter`` for a first waypoint that is not rate-limited: a long way from the start
#: posture), ``ftol`` SLSQP's accuracy goal (objective change and constraint violation), and the
#: scaling SLSQP sees: stiffness in units of ``kj_scale`` Nm/rad (so q in rad and kj are both of
#: order 1), the criterion times ``f_scale``. ``driver``: ``"lean"`` calls scipy's SLSQP routine
#: (the same compiled Kraft algorithm that ``minimize(method="SLSQP")`` runs) from a minimal loop,
#: ``"scipy"`` goes through ``scipy.optimize.minimize``; see :func:`_slsqp_lean`.
DEFAULT_OPTIONS = SLSQPOptions.defaults()

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


#: meaning of the result file's ``solver_code`` for the SLSQP solvers (meta ``solver_code_meaning``)
CODE_MEANING = "SLSQP exit mode (0 = converged, scipy's modes 1-9 otherwise), -1 = exception"


class PathInterrupted(KeyboardInterrupt):
    """A ``KeyboardInterrupt`` (Ctrl-C, or SIGTERM under the command line) during
    :func:`greedy_path`, carrying the outcomes of the waypoints finished before it (``done``)."""

    def __init__(self, done: list):
        super().__init__()
        self.done = done


def not_run_outcomes(problem, done: list, P: int, q0: np.ndarray, kj0: np.ndarray) -> list:
    """``done`` completed to P waypoints with status NOT_RUN: each holds the reference state (the
    last usable waypoint's x, else the start state), so bounds and rate limits still hold."""
    x_ref = problem.x_of(np.asarray(q0, float), np.asarray(kj0, float))
    for o in done:
        if o.status in R.USABLE:
            x_ref = o.x
    return list(done) + [WaypointOutcome(x_ref.copy(), R.NOT_RUN, 0.0, -1, 0, 0, 0.0) for _ in range(P - len(done))]


#: ``solver(x0, lb, ub, params, maxiter=None) -> SolverOutput``
WaypointSolver = Callable[..., SolverOutput]


def check_options(options: Mapping[str, Any] | None) -> dict[str, Any]:
    """:data:`DEFAULT_OPTIONS` updated by ``options``, values checked (ValueError naming the option)."""
    return SLSQPOptions.check_values({**DEFAULT_OPTIONS, **(options or {})})


def make_slsqp_solver(problem: WaypointProblem, options: dict | None = None) -> WaypointSolver:
    """A per-waypoint SLSQP solver ``(x0, lb, ub, params, maxiter=None) -> SolverOutput``, JAX derivatives."""
    from scipy.optimize import Bounds, minimize

    opts = check_options(options)
    fused_s = compiled_scaled(problem)
    # compile now (once per problem and dtype), so that waypoint timings exclude compilation
    t0 = time.perf_counter()
    x_dummy = problem.x_of(np.nan_to_num(problem.robot.locked_values) + 0.1, np.ones(problem.n))
    # argument kinds as in every later call (y numpy; params, scale on the device): one cache entry
    np.asarray(fused_s(x_dummy, jnp.asarray(WaypointProblem.params(np.zeros(3), [1.0, 0.0, 0.0], 2.0, 0.0)),
                       jnp.asarray(np.ones(problem.nx + 1))))
    np.asarray(compiled_position(problem)(np.nan_to_num(problem.robot.locked_values)))
    compile_s = time.perf_counter() - t0
    nx, k = problem.nx, len(problem.pos_rows)
    sl_f, sl_g, sl_c = 0, slice(1, 1 + nx), slice(1 + nx, 1 + nx + k)
    sl_a = slice(1 + nx + k, None)

    # SLSQP works on y = x / scale: stiffness in units of kj_scale (Nm/rad), joints in rad; the
    # scaling is applied inside the kernel, so each evaluation is one call and array views.
    scale = np.r_[np.ones(problem.n_free), np.full(problem.n, float(opts["kj_scale"]))]
    svec = np.r_[scale, float(opts["f_scale"])]

    svec_dev = jnp.asarray(svec)

    lean = opts["driver"] == "lean" and _lean_driver_works()

    def solve(x0, lb, ub, params, maxiter=None) -> SolverOutput:
        last = [b"", None]
        count = [0]
        params_dev = jnp.asarray(params)  # on the device once per waypoint, not once per call

        def ev(y):
            key = y.tobytes()
            if key != last[0]:
                last[0] = key
                last[1] = np.asarray(fused_s(y, params_dev, svec_dev))
                count[0] += 1
            return last[1]

        iters = int(maxiter or opts["maxiter"])
        if lean:
            def fgca(y):
                out = ev(y)
                return out[sl_f], out[sl_g], out[sl_c], out[sl_a].reshape(k, nx)

            y, mode, nit = _slsqp_lean(fgca, x0 / scale, lb / scale, ub / scale, k, iters, float(opts["ftol"]))
            return SolverOutput(y * scale, mode, mode == 0, nit, count[0])

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
            options={"maxiter": iters, "ftol": float(opts["ftol"])},
        )
        x = np.asarray(res.x, float) * scale
        return SolverOutput(x, int(res.status), int(res.status) == 0, int(res.nit), count[0])

    solve.options = opts  # type: ignore[attr-defined]
    solve.compile_s = compile_s  # type: ignore[attr-defined]
    solve.driver = "lean" if lean else "scipy.optimize.minimize"  # type: ignore[attr-defined]
    return solve


# ---------------------------------------------------------------------- lean SLSQP driver
def _slsqp_lean(fgca, x0, xl, xu, meq, maxiter, acc):
    """SLSQP with equality constraints only and finite bounds: scipy's own compiled routine
    (``scipy.optimize._slsqplib.slsqp``, the C port of Kraft's code in scipy >= 1.16), driven by
    the same reverse-communication loop as ``scipy.optimize.minimize(method="SLSQP")`` but without
    its per-iteration wrappers (ScalarFunction bookkeeping, constraint list assembly). The result
    is the same iterate sequence; for a per-waypoint solve with a ~50 us kernel the wrappers cost
    about as much as the kernel.

    Args:
        fgca: ``y -> (f, grad (n,), c (meq,), A (meq, n))``.
        x0, xl, xu: start and bounds (n,).
        meq: number of equality constraints.
        maxiter, acc: iteration limit and accuracy (scipy's ``maxiter``, ``ftol``).

    Returns:
        ``(x, exit mode, iterations)``.
    """
    from scipy.optimize._slsqplib import slsqp as _kernel

    n, m = x0.size, meq
    state = {"acc": float(acc), "alpha": 0.0, "f0": 0.0, "gs": 0.0, "h1": 0.0, "h2": 0.0, "h3": 0.0, "h4": 0.0,
             "t": 0.0, "t0": 0.0, "tol": 10.0 * float(acc), "exact": 0, "inconsistent": 0, "reset": 0, "iter": 0,
             "itermax": int(maxiter), "line": 0, "m": m, "meq": meq, "mode": 0, "n": n}
    indices = np.zeros(max(m + 2 * n + 2, 1), dtype=np.int32)
    size = n * (n + 1) // 2 + 3 * m * n - (m + 5 * n + 7) * meq + 9 * m + 8 * n * n + 35 * n + meq * meq + 28
    size += 2 * n * (n + 1)  # no inequality constraints
    buffer = np.zeros(max(size, 1))
    mult = np.zeros(max(1, m + 2 * n + 2))
    xl = np.where(np.isfinite(xl), xl, np.nan)
    xu = np.where(np.isfinite(xu), xu, np.nan)
    x = np.clip(np.array(x0, dtype=float), np.nan_to_num(xl, nan=-np.inf), np.nan_to_num(xu, nan=np.inf))
    f, g, c, A = fgca(x)
    g = np.array(g, dtype=float)
    C = np.zeros((max(1, m), n), order="F")
    d = np.zeros(max(1, m))
    C[:m] = A
    d[:m] = c
    while True:
        _kernel(state, float(f), g, C, d, x, mult, xl, xu, buffer, indices)
        mode = state["mode"]
        if mode == 1:
            f, _, c, _ = fgca(x)
            d[:m] = c
        elif mode == -1:
            _, gg, _, A = fgca(x)
            g[:] = gg
            C[:m] = A
        else:
            return x, int(mode), int(state["iter"])


_LEAN_OK: list[bool] = []


def _lean_driver_works() -> bool:
    """Check once per process that the lean driver matches ``scipy.optimize.minimize`` exactly on
    a small bounded, equality-constrained problem (falls back to ``minimize`` otherwise)."""
    if _LEAN_OK:
        return _LEAN_OK[0]
    ok = False
    try:
        from scipy.optimize import Bounds, minimize

        n = 5
        w = np.arange(1.0, n + 1)

        def fgca(x):
            f = float(np.sum(w * (x - 0.3) ** 4) + x[0] * x[1])
            g = 4 * w * (x - 0.3) ** 3
            g[0] += x[1]
            g[1] += x[0]
            c = np.array([x[0] + x[2] ** 2 - 0.5, x[1] - x[3] * x[4]])
            A = np.zeros((2, n))
            A[0, 0], A[0, 2], A[1, 1], A[1, 3], A[1, 4] = 1.0, 2 * x[2], 1.0, -x[4], -x[3]
            return f, g, c, A

        x0, lo, hi = np.full(n, 0.9), np.full(n, -1.0), np.full(n, 1.0)
        ref = minimize(lambda x: fgca(x)[:2], x0, jac=True, bounds=Bounds(lo, hi), method="SLSQP",
                       constraints=[{"type": "eq", "fun": lambda x: fgca(x)[2], "jac": lambda x: fgca(x)[3]}],
                       options={"maxiter": 100, "ftol": 1e-10})
        x, mode, nit = _slsqp_lean(fgca, x0, lo, hi, 2, 100, 1e-10)
        ok = bool(mode == ref.status and nit == ref.nit and np.allclose(x, ref.x, rtol=0, atol=1e-12))
    except Exception:  # private API moved or changed: use minimize
        ok = False
    _LEAN_OK.append(ok)
    return ok


def judge(
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
    span = (hi - lo)[free]
    finite = np.isfinite(span)  # a continuous joint has no limit to keep away from
    span = np.where(finite, span, 1.0)

    def margin(c):
        qf = c[0][:nf]
        m = np.where(finite, np.minimum(qf - np.where(finite, lo[free], 0.0), np.where(finite, hi[free], 0.0) - qf) / span, np.inf)
        return float(np.min(m)) if nf else 0.0

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
    try:
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
                x, status, err = judge(problem, sol, xs, lb, ub, targets[p], params, pos_and_jac, objective, pos_tol)
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
    except KeyboardInterrupt:
        # the waypoints in `out` are finished and consistent (each is appended whole); the caller
        # may keep them (shape marks the rest NOT_RUN)
        raise PathInterrupted(out) from None
    return out


def solve_path(problem, targets, directions, q0, kj0, limits, ratio, c, options=None, progress=None):
    """Greedy SLSQP with JAX derivatives along one path; see :func:`greedy_path`."""
    solver = make_slsqp_solver(problem, options)
    return greedy_path(
        problem, targets, directions, q0, kj0, limits, ratio, c, solver, progress=progress,
        first_maxiter=solver.options["first_maxiter"],
    )


# ---------------------------------------------------------------------- SOLVERS adapters
def check_single_start(req: SolveRequest, kind: str) -> None:
    """A per-waypoint SLSQP solver is single-start: ``req.starts`` must be None or 1."""
    if req.starts not in (None, 1):
        raise ValueError(f"solver {kind!r} is single-start (starts=1); got starts={req.starts}")


def run_greedy(req: SolveRequest, solver: WaypointSolver, extra: Mapping[str, Any]) -> dict[str, np.ndarray]:
    """Greedy SLSQP (``solver``, with :func:`greedy_path`'s keyword arguments ``extra``) over every
    path of ``req``, in the :data:`~jaxstiff.solvers.base.SOLVERS` dict format; raises
    :class:`~jaxstiff.solvers.base.SolverInterrupted` with the finished part on an interrupt."""
    prob = req.problem

    per_path = []
    ratios = req.ratios
    B, P = req.targets.shape[:2]
    interrupted = False
    for b in range(B):
        prog = None if req.progress is None else (lambda p, b=b: req.progress(b, p))
        try:
            per_path.append(
                greedy_path(prob, req.targets[b], req.directions[b], req.q0[b], req.kj0[b], req.limits.for_path(b),
                            float(ratios[b]), req.c, solver, pos_tol=req.pos_tol, progress=prog,
                            first_starts=req.first_starts[b], first_maxiter=solver.options["first_maxiter"], **extra)
            )
        except PathInterrupted as e:
            per_path.append(e.done)
            interrupted = True
            break
    # paths (or their ends) not reached before an interrupt: NOT_RUN at the reference state
    per_path += [[] for _ in range(B - len(per_path))]
    per_path = [not_run_outcomes(prob, d, P, req.q0[b], req.kj0[b]) for b, d in enumerate(per_path)]
    out = outcomes_to_arrays(per_path, prob.n_free, req.q0, prob.free_idx)
    out["compile_s"] = float(getattr(solver, "compile_s", 0.0))
    out["driver"] = str(getattr(solver, "driver", "scipy.optimize.minimize"))
    out["code_meaning"] = CODE_MEANING
    if interrupted:
        raise SolverInterrupted(out)
    return out


def run_request(req: SolveRequest) -> dict[str, np.ndarray]:
    """Adapter for :data:`~jaxstiff.solvers.base.SOLVERS` (``solver="slsqp"``)."""
    check_single_start(req, "slsqp")
    return run_greedy(req, make_slsqp_solver(req.problem, req.options), {})
