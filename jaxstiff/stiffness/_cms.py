"""Common-mode stiffness (CMS, seed 000 section III): one factor k on every joint stiffness.

Scaling every kj by k scales ``K_C`` (and ``K_T``) by exactly k, so the ellipsoid keeps its shape
and orientation and reaches a wanted size.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp

from jaxstiff._numerics.batch import check_square
from jaxstiff._numerics.eig import eigh_descending

__all__ = ["cms_factor", "cms_scale"]


def _check_positive(name: str, value: object) -> None:
    if isinstance(value, (int, float)) and not value > 0:
        raise ValueError(f"{name} must be > 0, got {value}")


def cms_factor(K: jax.Array, target_volume: float | None = None, target_major: float | None = None) -> jax.Array:
    """Common-mode stiffness factor k (S0 section III) so that ``k K`` reaches a target size.

    Scaling every kj by k scales ``K_C`` (and ``K_T``) by exactly k: the ellipsoid keeps its
    shape (ratio) and orientation; its axes scale by k and its volume by ``k^m``.

    Args:
        K: translational stiffness (..., m, m), m = 2 or 3, N/m, symmetric positive definite.
        target_volume: wanted product of the axes ``lambda1 * ... * lambda_m`` in (N/m)^m
            (the area ``lambda1 lambda2`` for m = 2; no 4/3 pi or pi factor).
        target_major: wanted major axis ``lambda1`` (N/m).

    Returns:
        k (...,) > 0; the scaled joint stiffnesses are ``k * kj`` (:func:`cms_scale`).
    """
    if (target_volume is None) == (target_major is None):
        raise ValueError("give exactly one of target_volume= or target_major=")
    K = check_square(K)
    m = K.shape[-1]
    w = eigh_descending(K)[0]
    if target_major is not None:
        _check_positive("target_major", target_major)
        return jnp.asarray(target_major, K.dtype) / w[..., 0]
    _check_positive("target_volume", target_volume)
    return (jnp.asarray(target_volume, K.dtype) / jnp.prod(w, axis=-1)) ** (1.0 / m)


def cms_scale(
    K: jax.Array, kj: jax.Array, *, target_volume: float | None = None, target_major: float | None = None
) -> tuple[jax.Array, jax.Array]:
    """CMS in one call: ``(k, k * kj)`` so that the scaled ellipsoid reaches the target size.

    Args:
        K: translational stiffness (..., m, m) obtained with ``kj``.
        kj: joint stiffnesses (..., n) that gave ``K``.
        target_volume, target_major: as in :func:`cms_factor` (exactly one).

    Returns:
        k (...,) and the scaled joint stiffnesses (..., n).
    """
    k = cms_factor(K, target_volume=target_volume, target_major=target_major)
    return k, k[..., None] * jnp.asarray(kj, dtype=k.dtype)
