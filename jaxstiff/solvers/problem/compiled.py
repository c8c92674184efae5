"""Jitted kernels of a :class:`~jaxstiff.solvers.problem.waypoint.WaypointProblem`, compiled once per
problem (cached), and their numpy wrappers (:mod:`jaxstiff.solvers.problem`)."""

from __future__ import annotations

import functools
from collections.abc import Callable

import jax
import jax.numpy as jnp
import numpy as np

from jaxstiff.runtime.export_cache import DiskJit
from jaxstiff.runtime.xla import kernel_compiler_options
from jaxstiff.solvers.problem.waypoint import WaypointProblem

__all__ = [
    "compiled",
    "compiled_evaluate",
    "compiled_report",
    "compiled_scaled",
    "compiled_scaled_rows",
    "compiled_position",
    "jax_pos_and_jac",
]


@functools.lru_cache(maxsize=64)
def compiled_scaled(problem: WaypointProblem) -> DiskJit:
    """The jitted ``fused_scaled(y, params, scale)`` of a problem, compiled once per problem and dtype
    (its traced program kept on disk for the built-in criteria: :class:`~jaxstiff.runtime.export_cache.DiskJit`)."""
    fp = problem.fingerprint()
    return DiskJit(problem.fused_scaled, None if fp is None else f"fused_scaled|{fp}")


@functools.lru_cache(maxsize=64)
def compiled_scaled_rows(problem: WaypointProblem) -> Callable[..., jax.Array]:
    """``fused_scaled`` over rows: ``(Y (R, nx), params (R, np), scale) -> (R, out)``, jitted with
    jaxstiff's kernel compiler options (:mod:`jaxstiff.solvers.lockstep`'s batched evaluations;
    with these options a row's result has the same bits at every R >= 2, measured on CPU)."""
    return jax.jit(jax.vmap(problem.fused_scaled, in_axes=(0, 0, None)), compiler_options=kernel_compiler_options())


@functools.lru_cache(maxsize=64)
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


@functools.lru_cache(maxsize=64)
def compiled_report(problem: WaypointProblem) -> Callable[[np.ndarray, np.ndarray], jax.Array]:
    """Jitted single-point :meth:`WaypointProblem.report_x` ``(x, params)``: one compilation per problem
    (kept on disk like :func:`compiled_scaled`)."""
    fp = problem.fingerprint()
    return DiskJit(problem.report_x, None if fp is None else f"report_x|{fp}")


@functools.lru_cache(maxsize=64)
def compiled_evaluate(problem: WaypointProblem):
    """Jitted batch report ``(q (N,n), kj (N,n), d (N,3), r, c) -> (pos, K_T, alpha, ratio, f)``."""
    return jax.jit(problem.report)


@functools.lru_cache(maxsize=64)
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
