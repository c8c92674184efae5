"""Seed 000's method with exact derivatives: one SLSQP solve per waypoint, greedy along the path.

Each waypoint is the problem of :mod:`jaxstiff.solvers._problem` (S0-10 ... S0-14), solved with
``scipy.optimize.minimize(method="SLSQP")`` from the previous waypoint's state. Objective,
gradient, equality constraint and its Jacobian come from one jitted JAX function (compiled once
per robot/task/criterion, not per waypoint), called once per distinct point SLSQP asks about and
cached, so a SLSQP iteration costs one kernel call.

After SLSQP the answer is made exactly feasible and judged (status codes of
:mod:`jaxstiff.results`): clipped into the box, projected back onto the path with Newton steps
inside the box if needed, then checked (position error, box, finiteness). A waypoint that cannot
be reached keeps its status and the run goes on from the last usable state.

:func:`~jaxstiff.solvers._greedy.greedy_path` is the chaining loop (:mod:`jaxstiff.solvers._greedy`,
re-exported here), shared with the finite-difference baseline (:mod:`jaxstiff.solvers._slsqp_fd`)
and reusable by any per-waypoint solver.
"""

from __future__ import annotations

import math
import time
from collections import deque
from collections.abc import Callable, Generator, Mapping
from typing import Any, Protocol, cast

import jax.numpy as jnp
import numpy as np

from jaxstiff.runtime._export_cache import DiskJit
from jaxstiff.settings._solvers import SLSQPOptions
from jaxstiff.solvers._base import SolveRequest

# re-exported: the greedy chaining lived here (jaxstiff.solvers._slsqp.X keeps working)
from jaxstiff.solvers._greedy import CODE_MEANING as CODE_MEANING
from jaxstiff.solvers._greedy import PATH_RETRIES
from jaxstiff.solvers._greedy import REPAIR_POS as REPAIR_POS
from jaxstiff.solvers._greedy import TIE_RTOL as TIE_RTOL
from jaxstiff.solvers._greedy import PathInterrupted as PathInterrupted
from jaxstiff.solvers._greedy import SolverOutput as SolverOutput
from jaxstiff.solvers._greedy import WaypointOutcome as WaypointOutcome
from jaxstiff.solvers._greedy import WaypointSolver as WaypointSolver
from jaxstiff.solvers._greedy import check_single_start as check_single_start
from jaxstiff.solvers._greedy import greedy_path as greedy_path
from jaxstiff.solvers._greedy import judge as judge
from jaxstiff.solvers._greedy import not_run_outcomes as not_run_outcomes
from jaxstiff.solvers._greedy import run_greedy as run_greedy
from jaxstiff.solvers._lockstep import Steps, run_steps
from jaxstiff.solvers._problem import WaypointBatch, WaypointProblem, compiled_position, compiled_scaled
from jaxstiff.solvers._problem.target_step import TargetStep, target_step

__all__ = [
    "WaypointOutcome",
    "SolverOutput",
    "PathInterrupted",
    "greedy_path",
    "solve_path",
    "DEFAULT_OPTIONS",
    "run_request",
    "run_greedy",
    "check_single_start",
    "judge",
    "not_run_outcomes",
    "CODE_MEANING",
    "WaypointSolver",
    "REPAIR_POS",
    "TIE_RTOL",
]

#: SLSQP settings used unless overridden (``shape(..., options=...)``), from
#: :class:`~jaxstiff.settings._solvers.SLSQPOptions`: ``maxiter`` iterations per waypoint
#: (``first_maxiter`` for a first waypoint that is not rate-limited: a long way from the start
#: posture), ``ftol`` SLSQP's accuracy goal (objective change and constraint violation), and the
#: scaling SLSQP sees: stiffness in units of ``kj_scale`` Nm/rad (so q in rad and kj are both of
#: order 1), the criterion times ``f_scale``. ``driver``: ``"lean"`` calls scipy's SLSQP routine
#: (the same compiled Kraft algorithm that ``minimize(method="SLSQP")`` runs) from a minimal loop,
#: ``"scipy"`` goes through ``scipy.optimize.minimize``; see :func:`_slsqp_lean`.
DEFAULT_OPTIONS = SLSQPOptions.defaults()


def kj_unit(kj_scale: float | None, kmin: float | None = None, kmax: float | None = None) -> float:
    """The stiffness unit SLSQP works in (Nm/rad): ``kj_scale`` where given, else ``kmax`` (100
    ``kmin`` where kmax is not finite; 100 where no range is known). With the range's top as the
    unit SLSQP sees the same scaled problem for [1, 100] and [1e4, 1e6] Nm/rad (f1 and f2 depend
    on the stiffnesses' ratios only); a fixed unit of 100 left a range of 1e4-1e6 at y ~ 1e4, where
    SLSQP's steps hardly moved the stiffnesses (ratio 2.7 instead of 5 on the planar 3R)."""
    if kj_scale is not None:
        return float(kj_scale)
    if kmax is not None and math.isfinite(kmax):
        return float(kmax)
    return 100.0 * float(kmin) if kmin is not None else 100.0


def variable_scale(
    problem: WaypointProblem, kj_scale: float | None, kj_range: tuple[float, float] | None = None
) -> np.ndarray:
    """The scale (nx,) of the variables SLSQP sees, ``y = x / scale``: joints in rad (1), stiffnesses
    in :func:`kj_unit` (``kj_range`` = ``(kmin, kmax)``); shared by both SLSQP solvers."""
    unit = kj_unit(kj_scale, *(kj_range or (None, None)))
    return np.r_[np.ones(problem.n_free), np.full(problem.n_spring, unit)]


def check_options(options: Mapping[str, Any] | None) -> dict[str, Any]:
    """:data:`DEFAULT_OPTIONS` updated by ``options``, values checked (ValueError naming the option)."""
    return SLSQPOptions.check_values({**DEFAULT_OPTIONS, **(options or {})})


def _compile_now(problem: WaypointProblem, fused_s: DiskJit) -> float:
    """Compile the solver's kernels now (once per problem and dtype), so that waypoint timings
    exclude compilation; return the seconds it took."""
    t0 = time.perf_counter()
    x_dummy = problem.x_of(np.nan_to_num(problem.robot.locked_values) + 0.1, np.ones(problem.n))
    # argument kinds as in every later call (y numpy; params, scale on the device): one cache entry
    np.asarray(
        fused_s(
            x_dummy,
            jnp.asarray(WaypointProblem.params(np.zeros(3), [1.0, 0.0, 0.0], 2.0, 0.0)),
            jnp.asarray(np.ones(problem.nx + 1)),
        )
    )
    np.asarray(compiled_position(problem)(np.nan_to_num(problem.robot.locked_values)))
    return time.perf_counter() - t0


class SLSQPSolver(WaypointSolver, Protocol):
    """:func:`make_slsqp_solver`'s solver: a :class:`WaypointSolver` that can also be driven step by
    step (``steps``, :mod:`jaxstiff.solvers._lockstep`), with its kernel's ``scale`` vector, the
    seconds its kernels took to compile and its ``driver`` ("lean" or "scipy.optimize.minimize")."""

    compile_s: float
    driver: str
    scale: np.ndarray

    def steps(
        self, x0: np.ndarray, lb: np.ndarray, ub: np.ndarray, params: np.ndarray, maxiter: int | None = None
    ) -> Steps[SolverOutput]: ...


def make_slsqp_solver(
    problem: WaypointProblem,
    options: Mapping[str, Any] | None = None,
    kj_range: tuple[float, float] | None = None,
    compile_now: bool = True,
) -> SLSQPSolver:
    """A per-waypoint SLSQP solver ``(x0, lb, ub, params, maxiter=None) -> SolverOutput``, JAX
    derivatives (:class:`SLSQPSolver`). ``kj_range``: ``(kmin, kmax)``, for the stiffness unit
    when the option ``kj_scale`` is None (:func:`kj_unit`). ``compile_now``: compile its
    single-point kernels here (``compile_s`` their seconds), so that waypoint timings exclude
    them; False for a caller that drives only ``steps`` on a batched program of its own
    (:mod:`jaxstiff.solvers._lockstep`): they then compile at their first call, if any."""
    from scipy.optimize import Bounds, minimize

    opts = check_options(options)
    fused_s = compiled_scaled(problem)
    compile_s = _compile_now(problem, fused_s) if compile_now else 0.0
    nx, k = problem.nx, len(problem.pos_rows)
    sl_f, sl_g, sl_c = 0, slice(1, 1 + nx), slice(1 + nx, 1 + nx + k)
    sl_a = slice(1 + nx + k, None)

    # SLSQP works on y = x / scale: stiffness in units of kj_scale (Nm/rad), joints in rad; the
    # scaling is applied inside the kernel, so each evaluation is one call and array views.
    scale = variable_scale(problem, opts["kj_scale"], kj_range)
    svec = np.r_[scale, float(opts["f_scale"])]

    svec_dev = jnp.asarray(svec)

    lean = opts["driver"] == "lean" and _lean_driver_works()

    def steps(
        x0: np.ndarray, lb: np.ndarray, ub: np.ndarray, params: np.ndarray, maxiter: int | None = None
    ) -> Steps[SolverOutput]:
        """The solve as a generator of kernel requests ``(y, params)`` (scaled point), sent back
        ``fused_scaled(y, params, scale)`` (:mod:`jaxstiff.solvers._lockstep`); returns its
        :class:`SolverOutput`. A point asked for twice in a row is evaluated once. The "scipy"
        driver cannot be driven this way: it solves at once and yields nothing."""
        iters = int(maxiter or opts["maxiter"])
        if not lean:
            return _solve_minimize(x0, lb, ub, params, iters)
        prm = np.asarray(params, dtype=float)
        last_key, out, count = b"", np.empty(0), 0
        gen = _slsqp_lean_steps(x0 / scale, lb / scale, ub / scale, k, iters, float(opts["ftol"]))
        try:
            y = next(gen)
            while True:
                key = y.tobytes()
                if key != last_key:
                    last_key = key
                    out = yield (y, prm)
                    count += 1
                y = gen.send((out[sl_f], out[sl_g], out[sl_c], out[sl_a].reshape(k, nx)))
        except StopIteration as stop:
            y, mode, nit = stop.value
        return SolverOutput(y * scale, mode, mode == 0, nit, count)

    def solve(
        x0: np.ndarray, lb: np.ndarray, ub: np.ndarray, params: np.ndarray, maxiter: int | None = None
    ) -> SolverOutput:
        params_dev = jnp.asarray(params)  # on the device once per waypoint, not once per call
        # every request of a solve has one signature: look the jitted kernel up once, not per call
        kernel = fused_s.specialize(np.asarray(x0, float), params_dev, svec_dev)
        return run_steps(
            steps(x0, lb, ub, params, maxiter), lambda req: np.asarray(kernel(req[0], params_dev, svec_dev))
        )

    def _solve_minimize(x0: np.ndarray, lb: np.ndarray, ub: np.ndarray, params: np.ndarray, iters: int) -> SolverOutput:
        last: list[Any] = [b"", None]
        count = [0]
        params_dev = jnp.asarray(params)
        kernel = fused_s.specialize(np.asarray(x0, float), params_dev, svec_dev)  # as in solve

        def ev(y: np.ndarray) -> np.ndarray:
            key = y.tobytes()
            if key != last[0]:
                last[0] = key
                last[1] = np.asarray(kernel(y, params_dev, svec_dev))
                count[0] += 1
            return last[1]

        def fun(y: np.ndarray) -> tuple[Any, np.ndarray]:
            out = ev(y)
            return out[sl_f], out[sl_g]

        cons = {
            "type": "eq",
            "fun": lambda y: ev(y)[sl_c],
            "jac": lambda y: ev(y)[sl_a].reshape(k, nx),
        }
        res = minimize(
            fun,
            x0 / scale,
            jac=True,
            bounds=Bounds(lb / scale, ub / scale),  # pyright: ignore[reportArgumentType] (stub: float; arrays are documented)
            constraints=[cons],
            method="SLSQP",
            options={"maxiter": iters, "ftol": float(opts["ftol"])},
        )
        x = np.asarray(res.x, float) * scale
        return SolverOutput(x, int(res.status), int(res.status) == 0, int(res.nit), count[0])

    solve.options = opts  # type: ignore[attr-defined]
    solve.compile_s = compile_s  # type: ignore[attr-defined]
    solve.steps = steps  # type: ignore[attr-defined]
    solve.scale = svec  # type: ignore[attr-defined]  # the kernel's scale vector, for batched evaluation
    solve.driver = "lean" if lean else "scipy.optimize.minimize"  # type: ignore[attr-defined]
    return cast(SLSQPSolver, solve)  # a function with its options attached


# ---------------------------------------------------------------------- lean SLSQP driver
#: exit mode of a solve stopped as stalled (scipy's modes end at 9): its last :data:`STALL_ITERS`
#: iterates moved at most :data:`STALL_STEP` (SLSQP's scaled variables, of order 1) while its
#: equality constraints were violated by more than SLSQP's own tolerance (10 ``acc``). That is
#: SLSQP stuck on a linearisation it cannot satisfy inside the box (a waypoint out of reach of the
#: rate box): each iteration's line search shrinks its step to nothing, and the solve would spend
#: the rest of its iterations (up to 10 evaluations each) on the same point. Measured on the UR10
#: (hybrid, 64 x 50, an Intel Xeon): 145 such solves ran 1900-2000 evaluations each to the
#: iteration limit, moving less than 1e-9 after their first few iterations. But standing still is
#: not always the end: after repeated line-search failures SLSQP resets its quasi-Newton matrix
#: and can move on. On an AMD EPYC the same 64 x 50 hybrid had 35 solves still for 10 iterations or
#: more, and 26 of them moved on afterwards (after up to 62 still iterations; 12 to a feasible
#: point). Hence a window of 100 iterations: beyond every escape seen (the one solve still that
#: long there, for 115 iterations, never moved again), while a solve stuck to its limit of 200
#: still ends about halfway.
STALLED = 10
STALL_ITERS = 100
STALL_STEP = 1e-9


def _slsqp_lean_steps(
    x0: np.ndarray,
    xl: np.ndarray,
    xu: np.ndarray,
    meq: int,
    maxiter: int,
    acc: float,
) -> Generator[np.ndarray, tuple[Any, np.ndarray, np.ndarray, np.ndarray], tuple[np.ndarray, int, int]]:
    """SLSQP with equality constraints only and finite bounds: scipy's own compiled routine
    (``scipy.optimize._slsqplib.slsqp``, the C port of Kraft's code in scipy >= 1.16), driven by
    the same reverse-communication loop as ``scipy.optimize.minimize(method="SLSQP")`` but without
    its per-iteration wrappers (ScalarFunction bookkeeping, constraint list assembly). The result
    is the same iterate sequence; for a per-waypoint solve with a ~50 us kernel the wrappers cost
    about as much as the kernel. One exit of its own: a solve whose iterates have stopped moving
    while its constraints are violated ends there with mode :data:`STALLED` (where scipy would
    spend its remaining iterations at that point).

    A generator: it yields each point ``y`` it needs and is sent ``(f, grad (n,), c (meq,),
    A (meq, n))`` at that point (:func:`_slsqp_lean` drives it with a function).

    Args:
        x0, xl, xu: start and bounds (n,).
        meq: number of equality constraints.
        maxiter, acc: iteration limit and accuracy (scipy's ``maxiter``, ``ftol``).

    Returns:
        ``(x, exit mode, iterations)``.
    """
    from scipy.optimize._slsqplib import slsqp as _kernel  # noqa: PLC2701 - scipy's routine without minimize's per-step wrappers (see above)

    n, m = x0.size, meq
    state = {
        "acc": float(acc),
        "alpha": 0.0,
        "f0": 0.0,
        "gs": 0.0,
        "h1": 0.0,
        "h2": 0.0,
        "h3": 0.0,
        "h4": 0.0,
        "t": 0.0,
        "t0": 0.0,
        "tol": 10.0 * float(acc),
        "exact": 0,
        "inconsistent": 0,
        "reset": 0,
        "iter": 0,
        "itermax": int(maxiter),
        "line": 0,
        "m": m,
        "meq": meq,
        "mode": 0,
        "n": n,
    }
    indices = np.zeros(max(m + 2 * n + 2, 1), dtype=np.int32)
    size = n * (n + 1) // 2 + 3 * m * n - (m + 5 * n + 7) * meq + 9 * m + 8 * n * n + 35 * n + meq * meq + 28
    size += 2 * n * (n + 1)  # no inequality constraints
    buffer = np.zeros(max(size, 1))
    mult = np.zeros(max(1, m + 2 * n + 2))
    xl = np.where(np.isfinite(xl), xl, np.nan)
    xu = np.where(np.isfinite(xu), xu, np.nan)
    x = np.clip(np.array(x0, dtype=float), np.nan_to_num(xl, nan=-np.inf), np.nan_to_num(xu, nan=np.inf))
    f, g, c, A = yield x
    g = np.array(g, dtype=float)
    C = np.zeros((max(1, m), n), order="F")
    d = np.zeros(max(1, m))
    C[:m] = A
    d[:m] = c
    recent: deque[np.ndarray] = deque(maxlen=STALL_ITERS + 1)  # the last accepted iterates
    while True:
        _kernel(state, float(f), g, C, d, x, mult, xl, xu, buffer, indices)
        mode = state["mode"]
        if mode == 1:
            f, _, c, _ = yield x
            d[:m] = c
        elif mode == -1:
            # x is a new iterate (its gradient is asked for): stalled while infeasible?
            recent.append(x.copy())
            # the violation first: it is small in most iterations, and the method forms skip
            # numpy's reduction wrappers (a few microseconds an iteration, 10^5 iterations a search)
            if (
                len(recent) > STALL_ITERS
                and m
                and np.abs(d[:m]).max() > state["tol"]
                and np.abs(x - recent[0]).max() <= STALL_STEP
            ):
                return x, STALLED, int(state["iter"])
            _, gg, _, A = yield x
            g[:] = gg
            C[:m] = A
        else:
            return x, int(mode), int(state["iter"])


def _slsqp_lean(
    fgca: Callable[[np.ndarray], tuple[Any, np.ndarray, np.ndarray, np.ndarray]],
    x0: np.ndarray,
    xl: np.ndarray,
    xu: np.ndarray,
    meq: int,
    maxiter: int,
    acc: float,
) -> tuple[np.ndarray, int, int]:
    """:func:`_slsqp_lean_steps` driven by ``fgca``: ``(x, exit mode, iterations)``."""
    return run_steps(_slsqp_lean_steps(x0, xl, xu, meq, maxiter, acc), fgca)


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

        def fgca(x: np.ndarray) -> tuple[float, np.ndarray, np.ndarray, np.ndarray]:
            f = float(np.sum(w * (x - 0.3) ** 4) + x[0] * x[1])
            g = 4 * w * (x - 0.3) ** 3
            g[0] += x[1]
            g[1] += x[0]
            c = np.array([x[0] + x[2] ** 2 - 0.5, x[1] - x[3] * x[4]])
            A = np.zeros((2, n))
            A[0, 0], A[0, 2], A[1, 1], A[1, 3], A[1, 4] = 1.0, 2 * x[2], 1.0, -x[4], -x[3]
            return f, g, c, A

        x0, lo, hi = np.full(n, 0.9), np.full(n, -1.0), np.full(n, 1.0)
        # scipy's stubs type Bounds' lb/ub as float; arrays are what its documentation describes
        ref = minimize(
            lambda x: fgca(x)[:2],
            x0,
            jac=True,
            bounds=Bounds(lo, hi),  # pyright: ignore[reportArgumentType]
            method="SLSQP",
            constraints=[{"type": "eq", "fun": lambda x: fgca(x)[2], "jac": lambda x: fgca(x)[3]}],
            options={"maxiter": 100, "ftol": 1e-10},
        )
        x, mode, nit = _slsqp_lean(fgca, x0, lo, hi, 2, 100, 1e-10)
        ok = bool(mode == ref.status and nit == ref.nit and np.allclose(x, ref.x, rtol=0, atol=1e-12))
    except Exception:  # private API moved or changed: use minimize
        ok = False
    _LEAN_OK.append(ok)
    return ok


def solve_path(
    batch: WaypointBatch,
    b: int = 0,
    options: Mapping[str, Any] | None = None,
    progress: Callable[[int], None] | None = None,
) -> list[WaypointOutcome]:
    """Greedy SLSQP with JAX derivatives along path ``b`` of ``batch``; see :func:`greedy_path`."""
    solver = make_slsqp_solver(batch.problem, options, (batch.limits.kmin, batch.limits.kmax))
    return greedy_path(
        batch,
        b,
        solver,
        progress=progress,
        first_maxiter=solver.options["first_maxiter"],
        path_retries=PATH_RETRIES
        if solver.options.get("path_retries") is None
        else int(solver.options["path_retries"]),
        target_step=_target_step_of(batch, solver),
    )


def _target_step_of(batch: WaypointBatch, solver: SLSQPSolver) -> TargetStep | None:
    """The greedy walk's target step (option ``target_step``), or None: also where no waypoint
    is rate-limited (one waypoint, the first without rate limit), so nothing is compiled for it."""
    if solver.options.get("target_step") == "none":
        return None
    if batch.targets.shape[1] < 2 and not batch.limits.first_rate_limit:
        return None
    return target_step(batch.problem, float(batch.limits.kmax) - float(batch.limits.kmin))


def run_request(req: SolveRequest) -> dict[str, Any]:
    """Adapter for :data:`~jaxstiff.solvers._base.SOLVERS` (``solver="slsqp"``)."""
    check_single_start(req.starts, "slsqp")
    solver = make_slsqp_solver(req.problem, req.options, (req.limits.kmin, req.limits.kmax))
    return run_greedy(req, solver, {"target_step": _target_step_of(req, solver)})
