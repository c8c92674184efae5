"""Common-mode stiffness (CMS, seed 000 section III): one factor k on every joint stiffness.

Scaling every kj by k scales ``K_C`` (and ``K_T``) by exactly k, so the ellipsoid keeps its shape
and orientation and reaches a wanted size.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

from jaxstiff._numerics.batch import check_square, is_traced, known_floats
from jaxstiff._numerics.eig import eigh_descending
from jaxstiff.stiffness._ellipsoid import refuse_indefinite

__all__ = ["cms_factor", "cms_scale"]


def _check_positive(name: str, value: object) -> None:
    """A concrete target (a number or an array of them): every entry finite and > 0."""
    a = known_floats(value, name)
    if a is None:  # inside a trace
        return
    bad = ~(np.isfinite(a) & (a > 0))
    if np.any(bad):
        shown = a if a.ndim == 0 else a[bad].ravel()[0]
        raise ValueError(
            f"{name} must be a finite number > 0, got {float(shown):g}" + (" (an entry)" if a.ndim else "")
        )


def _check_size(K: jax.Array, w: jax.Array, by_volume: bool) -> None:
    """A concrete K (eigenvalues ``w``, descending) that no finite k gives the size: not finite,
    indefinite, with a zero major axis, or, for a volume, singular (a zero axis makes the volume 0)."""
    if is_traced(w):
        return
    wn = np.asarray(w, dtype=float)
    refuse_indefinite(K, wn)
    with np.errstate(invalid="ignore"):
        bad = ~np.all(np.isfinite(wn), axis=-1) | (wn[..., -1 if by_volume else 0] <= 0)
    if np.any(bad):
        at = np.argwhere(bad)[0] if bad.ndim else np.zeros(0, int)
        where = f" at index {tuple(int(i) for i in at)}" if at.size else ""
        if by_volume:
            what = "positive definite and finite for a CMS volume (a singular K has a volume of 0, which no finite k scales)"
            val = f"its smallest eigenvalue is {float(wn[tuple(at)][-1]):g}"
        else:
            what = "finite, with a major axis > 0, for a CMS major axis"
            val = f"its largest eigenvalue is {float(wn[tuple(at)][0]):g}"
        raise ValueError(f"K must be {what}; {val}{where}")


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

    Raises:
        ValueError: (concrete input) a target that is not a finite number > 0, or a K that is
            not finite and positive semi-definite, a zero K, or (for ``target_volume``) a singular K:
            no finite k gives those the size. Inside ``jit``/``grad`` nothing is checked: such a
            K gives inf or NaN.
    """
    if (target_volume is None) == (target_major is None):
        raise ValueError("give exactly one of target_volume= or target_major=")
    K = check_square(K)
    m = K.shape[-1]
    w = eigh_descending(K)[0]
    _check_size(K, w, by_volume=target_volume is not None)
    if target_major is not None:
        _check_positive("target_major", target_major)
        return jnp.asarray(target_major, K.dtype) / w[..., 0]
    _check_positive("target_volume", target_volume)
    # (V / prod w)^(1/m) as V^(1/m) / prod(w^(1/m)): the same number, without the product of the
    # axes itself, which leaves float64 for axes far from 1 N/m (1e-300 I: a volume of 0, k = inf)
    root = 1.0 / m
    return jnp.asarray(target_volume, K.dtype) ** root / jnp.prod(w**root, axis=-1)


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
