"""Small dense algebra of the CSC step (m, n <= 7), written to fuse over a batch on a CPU.

Products are broadcast-multiply-and-sum (a batch of tiny dot products is slow on a CPU); the
determinant and the SPD inverse of the m x m matrices (m = 2, 3 closed forms, Cholesky above)
carry closed-form JVPs, so reverse mode through a rollout is one small product each, not the
transpose of the entry-wise formulas. ``K @ J`` is :func:`jaxstiff._numerics.linalg.mm`.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp

from jaxstiff._numerics.linalg import mm
from jaxstiff._numerics.safe import safe_sqrt

__all__ = ["outer"]


def mv(A: jax.Array, x: jax.Array) -> jax.Array:
    """(..., a, b) @ (..., b) -> (..., a)."""
    return jnp.sum(A * x[..., None, :], axis=-1)


def mtv(A: jax.Array, x: jax.Array) -> jax.Array:
    """(..., a, b)^T @ (..., a) -> (..., b)."""
    return jnp.sum(A * x[..., :, None], axis=-2)


def outer(a: jax.Array, b: jax.Array) -> jax.Array:
    """(..., a) x (..., b) -> (..., a, b)."""
    return a[..., :, None] * b[..., None, :]


def vector_norm(x: jax.Array) -> jax.Array:
    """Euclidean norm over the last axis with a finite (zero) gradient at 0 (double ``where``).

    Unlike :func:`jaxstiff._numerics.safe.safe_norm` a NaN stays NaN (the rollout's NaN guard
    must see a non-finite step, not a zero-length one).
    """
    return safe_sqrt(jnp.sum(x * x, axis=-1))


def det_cofactors(A: jax.Array) -> tuple[jax.Array, jax.Array]:
    """``det A`` and its cofactor matrix (= ``d det / dA``) for m = 2, 3, entry-wise closed forms."""
    m = A.shape[-1]
    c = [[A[..., i, j] for j in range(m)] for i in range(m)]
    if m == 2:
        cof = [[c[1][1], -c[1][0]], [-c[0][1], c[0][0]]]
    else:
        cof = [
            [
                c[(i + 1) % 3][(j + 1) % 3] * c[(i + 2) % 3][(j + 2) % 3]
                - c[(i + 1) % 3][(j + 2) % 3] * c[(i + 2) % 3][(j + 1) % 3]
                for j in range(3)
            ]
            for i in range(3)
        ]
    det = sum(c[0][j] * cof[0][j] for j in range(m))
    return det, jnp.stack([jnp.stack(r, -1) for r in cof], -2)  # type: ignore[return-value]


@jax.custom_jvp
def det_small(A: jax.Array) -> jax.Array:
    """``det A`` of (..., m, m), m = 2, 3 (closed form) or larger (LU).

    JVP ``d det = sum_ij cof_ij dA_ij`` with the cofactors from the primal pass: reverse mode
    through it is one multiply-and-sum, not the transpose of the entry-wise formula (whose
    slices become pads of whole arrays in the backward pass of a rollout).
    """
    if A.shape[-1] in (2, 3):
        return det_cofactors(A)[0]
    return jnp.linalg.det(A)


@det_small.defjvp
def _det_small_jvp(primals: tuple, tangents: tuple) -> tuple:
    (A,), (dA,) = primals, tangents
    if A.shape[-1] not in (2, 3):
        return jax.jvp(jnp.linalg.det, (A,), (dA,))
    det, cof = det_cofactors(A)
    return det, jnp.sum(cof * dA, axis=(-2, -1))


def spd_inverse_primal(A: jax.Array) -> jax.Array:
    """Inverse of a symmetric positive-definite (..., m, m) without the custom JVP (adjugate / det
    for m = 2, 3, Cholesky else); the projections' VJP calls it on the primal values."""
    m = A.shape[-1]
    if m in (2, 3):
        det, cof = det_cofactors(A)
        return jnp.swapaxes(cof, -1, -2) / det[..., None, None]  # adjugate / det
    L = jnp.linalg.cholesky(A)
    eye = jnp.broadcast_to(jnp.eye(m, dtype=A.dtype), A.shape)
    return jax.scipy.linalg.cho_solve((L, True), eye)


@jax.custom_jvp
def spd_inverse(A: jax.Array) -> jax.Array:
    """Inverse of a symmetric positive-definite (..., m, m): adjugate for m = 2, 3, Cholesky else.

    JVP ``d(A^-1) = -A^-1 dA A^-1`` (two small products), for the same reason as :func:`det_small`.
    """
    return spd_inverse_primal(A)


@spd_inverse.defjvp
def _spd_inverse_jvp(primals: tuple, tangents: tuple) -> tuple:
    (A,), (dA,) = primals, tangents
    Ai = spd_inverse_primal(A)
    return Ai, -mm(mm(Ai, dA), Ai)
