"""Shaping criteria (seed 000 section IV, seed 001 eq. 10 and 19). All jit-able and vmappable.

* :func:`f1` (S0-9), "at least ratio r, aligned": ``(|alpha| + c) / (min(rho, r) / r)``;
  minimum set alpha = 0 and any rho >= r.
* :func:`f2` (S0-15), "exactly ratio r, aligned": ``(1 + |alpha|) (1 + |r - rho|)``; unique
  minimum alpha = 0, rho = r.
* :func:`frobenius` (S1-10): ``||K_d - K_C||_F``.
* :func:`offdiag` (S1-19): ``u = sqrt(sum_{i<j} (J^T K_xd J)_ij^2)``.

alpha is in degrees inside f1 and f2, as in the seed.

Your own criterion: any JAX-traceable function ``crit(K, d, r) -> (...,)`` of the translational
stiffness ``K`` (..., m, m), the desired direction ``d`` (..., m) and the ratio ``r`` can be passed
wherever a criterion name is accepted (``shape(..., criterion=my_crit)``), or registered by name
with :func:`register_criterion`. Keep it finite for every SPD K (use :func:`jaxstiff.ellipsoid`
and :func:`jaxstiff.orientation_error`, which are gradient-safe).

Example:
    >>> import jax.numpy as jnp, jaxstiff
    >>> K = jnp.diag(jnp.array([5.0, 1.0]))
    >>> float(jaxstiff.f2(K, jnp.array([1.0, 0.0]), 5.0))
    1.0
"""

from __future__ import annotations

from typing import Callable

import jax
import jax.numpy as jnp

from .ellipsoid import _alpha_rad, _check_square, eigh_descending, _safe_ratio

__all__ = ["f1", "f2", "frobenius", "offdiag", "get_criterion", "register_criterion", "CRITERIA", "alpha_and_ratio"]

Criterion = Callable[[jax.Array, jax.Array, jax.Array], jax.Array]


def alpha_and_ratio(K: jax.Array, d: jax.Array) -> tuple[jax.Array, jax.Array]:
    """Orientation error alpha (degrees) and axis ratio rho of K, from one eigen-decomposition."""
    K = _check_square(K)
    w, V = eigh_descending(K)
    alpha = _alpha_rad(V[..., :, 0], jnp.asarray(d, dtype=K.dtype)) * (180.0 / jnp.pi)
    return alpha, _safe_ratio(w[..., 0], w[..., 1])


def f1(K: jax.Array, d: jax.Array, r, c: float = 0.01) -> jax.Array:
    """Seed 000 criterion f1 (S0-9): ``(|alpha| + c) / (min(rho, r) / r)``, alpha in degrees.

    Args:
        K: translational stiffness (..., m, m).
        d: desired direction (..., m).
        r: wanted minimum axis ratio (> 1).
        c: offset that keeps the criterion sensitive to rho when alpha = 0 (seed: 0.01).
    """
    alpha, rho = alpha_and_ratio(K, d)
    r = jnp.asarray(r, dtype=alpha.dtype)
    return (alpha + c) / (jnp.minimum(rho, r) / r)


def f2(K: jax.Array, d: jax.Array, r, c: float = 0.0) -> jax.Array:
    """Seed 000 criterion f2 (S0-15): ``(1 + |alpha|) (1 + |r - rho|)``, alpha in degrees.

    ``c`` is accepted and ignored so that f1 and f2 share one call signature.
    """
    del c
    alpha, rho = alpha_and_ratio(K, d)
    r = jnp.asarray(r, dtype=alpha.dtype)
    return (1.0 + alpha) * (1.0 + jnp.abs(r - rho))


def frobenius(K: jax.Array, K_d: jax.Array) -> jax.Array:
    """``||K_d - K||_F`` (...,) (S1-10)."""
    D = jnp.asarray(K_d) - jnp.asarray(K)
    return jnp.sqrt(jnp.sum(D * D, axis=(-2, -1)))


def offdiag(J: jax.Array, K_xd: jax.Array) -> jax.Array:
    """Norm of the off-diagonal joint stiffness ``u = sqrt(sum_{i<j} (J^T K_xd J)_ij^2)`` (S1-19).

    Args:
        J: task-row Jacobian (..., m, n).
        K_xd: desired Cartesian stiffness (..., m, m).

    Returns:
        (...,) with a gradient that is finite also where u = 0.
    """
    Kq = jnp.einsum("...mi,...mk,...kj->...ij", J, K_xd, J)
    n = Kq.shape[-1]
    iu = jnp.triu_indices(n, k=1)
    off = Kq[..., iu[0], iu[1]]
    s = jnp.sum(off * off, axis=-1)
    pos = s > 0
    return jnp.where(pos, jnp.sqrt(jnp.where(pos, s, 1.0)), 0.0)


CRITERIA: dict[str, Criterion] = {"f1": f1, "f2": f2}


def register_criterion(name: str, fn: Criterion) -> None:
    """Make ``fn(K, d, r, c=...)`` available by name to ``shape``, the CLI and sweeps."""
    if not callable(fn):
        raise ValueError(f"criterion {name!r} must be callable")
    CRITERIA[name] = fn


def get_criterion(criterion) -> Criterion:
    """Resolve a criterion name (``"f1"``, ``"f2"``, registered ones) or pass a callable through."""
    if callable(criterion):
        return criterion
    try:
        return CRITERIA[criterion]
    except (KeyError, TypeError):
        raise ValueError(f"unknown criterion {criterion!r}; choose one of {', '.join(CRITERIA)} or pass a function") from None
