"""Gradient-safe elementwise functions: finite values and finite (zero) gradients where the plain
function has a NaN gradient (sqrt at 0, atan2 at the origin), NaN in -> NaN out."""

from __future__ import annotations

import jax
import jax.numpy as jnp

__all__: list[str] = []


def safe_sqrt(s: jax.Array) -> jax.Array:
    """``sqrt(s)`` of a sum of squares with a finite (zero) gradient at 0 (double ``where``); NaN
    stays NaN (a NaN input must not read as a perfect match, 0)."""
    pos = s > 0
    return jnp.where(pos, jnp.sqrt(jnp.where(pos, s, 1.0)), jnp.where(jnp.isnan(s), s, 0.0))


def safe_ratio(lam1: jax.Array, lam2: jax.Array) -> jax.Array:
    """``lambda1 / lambda2``, capped at ``1 / eps`` (4.5e15 in float64, 8.4e6 in float32).

    For SPD input the cap only binds beyond the precision at which ``lambda2`` is known at all,
    so the value is exact wherever it means something; the cap keeps value and gradient finite
    for (numerically) singular or indefinite input. A non-positive ``lambda1`` gives 1.
    """
    eps = jnp.finfo(lam1.dtype).eps
    den = jnp.maximum(lam2, lam1 * eps)
    ok = (lam1 > 0) & (den > 0)
    rho = jnp.where(ok, lam1 / jnp.where(ok, den, 1.0), 1.0)
    return jnp.where(jnp.isnan(lam1) | jnp.isnan(lam2), jnp.nan, rho)  # NaN is not "a sphere"


def safe_norm(x: jax.Array, axis: int = -1) -> jax.Array:
    n2 = jnp.sum(x * x, axis=axis)
    pos = n2 > 0
    return jnp.where(pos, jnp.sqrt(jnp.where(pos, n2, 1.0)), 0.0)


def safe_atan2(y: jax.Array, x: jax.Array) -> jax.Array:
    """``atan2(y, x)`` whose gradient is 0 (not NaN) at ``x = y = 0``."""
    ok = (x != 0) | (y != 0)
    return jnp.where(ok, jnp.arctan2(jnp.where(ok, y, 0.0), jnp.where(ok, x, 1.0)), 0.0)
