"""Jitted kernels of a :class:`~jaxstiff.solvers._problem.waypoint.WaypointProblem`, compiled once per
problem (cached), and their numpy wrappers (:mod:`jaxstiff.solvers._problem`)."""

from __future__ import annotations

import threading
from collections.abc import Callable

import jax
import jax.numpy as jnp
import numpy as np

from jaxstiff.runtime._export_cache import DiskJit
from jaxstiff.runtime._programs import program_cache
from jaxstiff.runtime._xla import kernel_compiler_options
from jaxstiff.solvers._problem.waypoint import WaypointProblem

__all__ = ["compiled", "compiled_report_rows", "REPORT_ROWS"]


@program_cache(maxsize=64)
def compiled_scaled(problem: WaypointProblem) -> DiskJit:
    """The jitted ``fused_scaled(y, params, scale)`` of a problem, compiled once per problem and dtype
    (its traced program kept on disk for the built-in criteria: :class:`~jaxstiff.runtime._export_cache.DiskJit`)."""
    fp = problem.fingerprint()
    return DiskJit(problem.fused_scaled, None if fp is None else f"fused_scaled|{fp}")


@program_cache(maxsize=64)
def compiled_scaled_rows(problem: WaypointProblem) -> Callable[..., jax.Array]:
    """``fused_scaled`` over rows: ``(Y (R, nx), params (R, np), scale) -> (R, out)``, jitted with
    jaxstiff's kernel compiler options (:mod:`jaxstiff.solvers._lockstep`'s batched evaluations;
    with these options a row's result has the same bits at every R >= 16 almost everywhere,
    measured on CPU; not at 2: :func:`jaxstiff.solvers._lockstep.bucket_size`, and the exceptions
    in :class:`jaxstiff.solvers._lockstep.RowsProgram`)."""
    return jax.jit(jax.vmap(problem.fused_scaled, in_axes=(0, 0, None)), compiler_options=kernel_compiler_options())


@program_cache(maxsize=64)
def compiled(problem: WaypointProblem) -> Callable[[np.ndarray, np.ndarray], jax.Array]:
    """``fused(x, params)`` of a problem, unscaled, on the one jitted kernel of :func:`compiled_scaled`."""
    fs = compiled_scaled(problem)
    nx = problem.nx
    ones: dict[np.dtype, jax.Array] = {}  # the unit scale on the device, once per dtype

    def fused(x, params):
        # the argument kinds the SLSQP driver uses (x numpy, the rest device arrays): jit's cache
        # keys numpy and device arrays apart, so mixing them would compile the kernel twice
        x = np.asarray(x)
        unit = ones.get(x.dtype)
        if unit is None:
            unit = ones[x.dtype] = jnp.ones(nx + 1, dtype=x.dtype)
        return fs(x, jnp.asarray(params, dtype=x.dtype), unit)

    fused._cache_size = fs._cache_size  # type: ignore[attr-defined]
    return fused


@program_cache(maxsize=64)
def compiled_report(problem: WaypointProblem) -> Callable[[np.ndarray, np.ndarray], jax.Array]:
    """Jitted single-point :meth:`WaypointProblem.report_x` ``(x, params)``: one compilation per problem
    (kept on disk like :func:`compiled_scaled`)."""
    fp = problem.fingerprint()
    return DiskJit(problem.report_x, None if fp is None else f"report_x|{fp}")


#: rows of one call of :func:`compiled_report_rows` (a report of fewer rows repeats its last one):
#: one compiled program serves reports of every size, so a waypoint's reported bits do not depend
#: on how many waypoints were reported with it
REPORT_ROWS = 128


@program_cache(maxsize=64)
def compiled_report_rows(problem: WaypointProblem) -> DiskJit:
    """:meth:`WaypointProblem.report_x` over rows, ``(X (REPORT_ROWS, nx), params (REPORT_ROWS, np))
    -> (REPORT_ROWS, out)``, jitted with jaxstiff's kernel compiler options and kept on disk like
    :func:`compiled_scaled` (what :func:`report_rows` calls)."""
    fp = problem.fingerprint()
    return DiskJit(jax.vmap(problem.report_x), None if fp is None else f"report_rows|{fp}", kernel_compiler_options())


#: report programs being compiled on a background thread (:func:`warm_report`), by problem
_warming: dict[WaypointProblem, threading.Thread] = {}


def warm_report(problem: WaypointProblem) -> None:
    """Start compiling the report program of ``problem`` on a background thread, so that it is ready
    when the solve ends: a solver that traces a program of its own (pgd: seconds of Python on one
    core) leaves the other core idle meanwhile, and the report's compile (1.4 s on a 2-core CPU)
    fits there. :func:`report_rows` waits for it. Any error is left to the real call to raise."""
    if problem in _warming:
        return
    lo, hi = problem.robot.lower, problem.robot.upper
    fin = np.isfinite(lo) & np.isfinite(hi)
    q = np.clip(np.zeros(problem.n), lo, hi)
    q[fin] = 0.5 * (lo[fin] + hi[fin])
    q = np.where(np.isnan(problem.robot.locked_values), q, np.nan_to_num(problem.robot.locked_values))
    X = np.asarray(problem.x_of(q, np.ones(problem.n)), dtype=np.float64)[None, :]
    prm = WaypointProblem.params(np.zeros(3), np.array([1.0, 0.0, 0.0]), 2.0, 0.01)[None, :]

    def work() -> None:
        try:
            with jax.enable_x64(True):
                _report_rows(problem, X, prm)
        except Exception:  # noqa: BLE001 - the real call raises it where the user sees it
            pass

    # not a daemon: a process that ends during the compile waits for it (see lockstep.RowsProgram)
    t = threading.Thread(target=work, name="jaxstiff-report-warm-up", daemon=False)
    _warming[problem] = t
    t.start()


def report_rows(problem: WaypointProblem, X: np.ndarray, params: np.ndarray) -> np.ndarray:
    """:meth:`WaypointProblem.report_x` at every row of ``X`` (N, nx) with ``params`` (N, np) ->
    (N, out) float64, in calls of :data:`REPORT_ROWS` rows (one compiled program; a call costs
    about what one single-point call costs, so 10^5 waypoints take under a second, not the
    half minute of one call each). Call it with x64 enabled."""
    t = _warming.pop(problem, None)
    if t is not None:
        t.join()
    return _report_rows(problem, X, params)


def _report_rows(problem: WaypointProblem, X: np.ndarray, params: np.ndarray) -> np.ndarray:
    X, params = np.asarray(X, dtype=np.float64), np.asarray(params, dtype=np.float64)
    N = len(X)
    if N == 0:
        return np.zeros((0, 6 + problem.m * problem.m))
    fn = compiled_report_rows(problem)
    call = None
    outs = []
    for s in range(0, N, REPORT_ROWS):
        x, prm = X[s : s + REPORT_ROWS], params[s : s + REPORT_ROWS]
        k = len(x)
        if k < REPORT_ROWS:  # repeat the last row (rows are independent: the others are unchanged)
            x = np.concatenate([x, np.repeat(x[-1:], REPORT_ROWS - k, axis=0)])
            prm = np.concatenate([prm, np.repeat(prm[-1:], REPORT_ROWS - k, axis=0)])
        if call is None:
            call = fn.specialize(x, prm)
        outs.append(np.asarray(call(x, prm))[:k])
    return np.concatenate(outs)


@program_cache(maxsize=64)
def compiled_evaluate(problem: WaypointProblem):
    """Jitted batch report ``(q (N,n), kj (N,n), d (N,3), r, c) -> (pos, K_T, alpha, ratio, f)``."""
    return jax.jit(problem.report)


@program_cache(maxsize=64)
def compiled_position(problem: WaypointProblem):
    """Jitted ``q (n,) -> [position (3,), J[rows][:, free] (k*n_free,)]`` in one flat array."""
    rows = problem.pos_rows
    free = jnp.asarray(problem.free_idx, dtype=int)

    def pj(q):
        p, J = problem.kinematics(q, rows)
        return jnp.concatenate([p, J[:, free].ravel()])

    return jax.jit(pj)


def jax_pos_and_jac(problem: WaypointProblem) -> Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]]:
    """numpy wrapper of :func:`compiled_position`: ``q (n,) -> (position (3,), J (k, n_free))``."""
    fn = compiled_position(problem)
    k, nf = len(problem.pos_rows), problem.n_free

    def pos_and_jac(q):
        out = np.asarray(fn(q))
        return out[:3], out[3:].reshape(k, nf)

    return pos_and_jac
