"""Symmetric eigen-decomposition with eigenvalues descending and a gradient-safe JVP.

2x2 and 3x3 matrices use closed-form / cyclic Jacobi rotations (unrolled, fusible, batched by
broadcasting); larger ones ``jnp.linalg.eigh``. The JVP drops the coupling between eigenvectors
whose eigenvalue gap is below a tolerance (there the eigenvectors are not defined and any
choice is valid), so gradients stay finite at repeated eigenvalues.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp

from jaxstiff._numerics.batch import batched_like
from jaxstiff._numerics.linalg import mm

__all__: list[str] = []

_KEYS3 = ((0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2))


#: Cyclic Jacobi sweeps used for 3x3 matrices (each sweep is 3 rotations).
JACOBI_SWEEPS = 4


def gap_tol(dtype: jnp.dtype) -> float:
    """Relative eigenvalue gap below which the JVP drops the coupling of two eigenvectors (1e-9 in float64, 1e-4 in float32)."""
    return 1e-9 if jnp.finfo(dtype).bits >= 64 else 1e-4


# ------------------------------------------------------------------ forward decomposition
def _jacobi_rotation(app: jax.Array, aqq: jax.Array, apq: jax.Array):
    """Rotation (t, c, s) that annihilates ``apq`` of the symmetric 2x2 ``[[app, apq], [apq, aqq]]``.

    ``t = tan(theta)`` is the smaller root of ``t^2 + 2 t cot(2 theta) - 1 = 0`` (|theta| <= 45 deg),
    written with ``hypot`` so that nothing overflows and ``apq = 0`` gives the identity.
    """
    d = aqq - app
    sgn = jnp.where(d >= 0, 1.0, -1.0).astype(d.dtype)
    den = jnp.abs(d) + jnp.hypot(d, 2.0 * apq)
    ok = den > 0
    t = jnp.where(ok, 2.0 * apq * sgn / jnp.where(ok, den, 1.0), 0.0)
    c = jax.lax.rsqrt(1.0 + t * t)
    return t, c, t * c


def _compare_swap(w: list, cols: list, i: int, j: int) -> None:
    """Order eigenpairs i < j descending (elementwise over the batch)."""
    swap = w[j] > w[i]
    w[i], w[j] = jnp.where(swap, w[j], w[i]), jnp.where(swap, w[i], w[j])
    ci, cj = cols[i], cols[j]
    cols[i] = [jnp.where(swap, b, a) for a, b in zip(ci, cj, strict=True)]
    cols[j] = [jnp.where(swap, a, b) for a, b in zip(ci, cj, strict=True)]


def _assemble(w: list, cols: list) -> tuple[jax.Array, jax.Array]:
    m = len(w)
    W = jnp.stack(w, axis=-1)
    V = jnp.stack([jnp.stack([cols[i][k] for i in range(m)], axis=-1) for k in range(m)], axis=-2)
    return W, V


def _eig2(K: jax.Array):
    a, c = K[..., 0, 0], K[..., 1, 1]
    b = 0.5 * (K[..., 0, 1] + K[..., 1, 0])
    t, cs, sn = _jacobi_rotation(a, c, b)
    w = [a - t * b, c + t * b]
    cols = [[cs, -sn], [sn, cs]]
    _compare_swap(w, cols, 0, 1)
    return _assemble(w, cols)


def _key(i: int, j: int) -> tuple[int, int]:
    return (i, j) if i <= j else (j, i)


def _jacobi_sweep3(_: int, carry: tuple) -> tuple:
    """One cyclic sweep (rotations (0,1), (0,2), (1,2)) over the upper triangle ``a`` and ``V``."""
    a, v = carry
    A = dict(zip(_KEYS3, a, strict=True))
    V = [list(v[3 * k : 3 * k + 3]) for k in range(3)]  # V[k][i]: row k, column i
    for p, q in ((0, 1), (0, 2), (1, 2)):
        r = 3 - p - q
        app, aqq, apq = A[p, p], A[q, q], A[p, q]
        t, c, s = _jacobi_rotation(app, aqq, apq)
        arp, arq = A[_key(r, p)], A[_key(r, q)]
        A[p, p] = app - t * apq
        A[q, q] = aqq + t * apq
        A[p, q] = jnp.zeros_like(apq)
        A[_key(r, p)] = c * arp - s * arq
        A[_key(r, q)] = s * arp + c * arq
        for k in range(3):
            vp, vq = V[k][p], V[k][q]
            V[k][p] = c * vp - s * vq
            V[k][q] = s * vp + c * vq
    return tuple(A[k] for k in _KEYS3), tuple(x for row in V for x in row)


def _eig3(K: jax.Array, sweeps: int = JACOBI_SWEEPS):
    a = tuple(K[..., i, j] if i == j else 0.5 * (K[..., i, j] + K[..., j, i]) for i, j in _KEYS3)
    one = jnp.ones_like(a[0])
    zero = jnp.zeros_like(one)
    v = tuple(one if i == k else zero for k in range(3) for i in range(3))
    # a loop over sweeps (not unrolled): 4x faster to compile, and as fast or faster to run
    a, v = jax.lax.fori_loop(0, sweeps, _jacobi_sweep3, batched_like((a, v), a[0]))
    A = dict(zip(_KEYS3, a, strict=True))
    w = [A[0, 0], A[1, 1], A[2, 2]]
    cols = [[v[3 * k + i] for k in range(3)] for i in range(3)]
    _compare_swap(w, cols, 0, 1)
    _compare_swap(w, cols, 1, 2)
    _compare_swap(w, cols, 0, 1)
    return _assemble(w, cols)


def eigh_descending_primal(K: jax.Array):
    m = K.shape[-1]
    if m == 2:
        w, V = _eig2(K)
    elif m == 3:
        w, V = _eig3(K)
    else:
        w, V = jnp.linalg.eigh(0.5 * (K + jnp.swapaxes(K, -1, -2)))
        w, V = w[..., ::-1], V[..., ::-1]
    # A NaN/Inf entry stops the Jacobi rotations (they become the identity), which would report
    # the coordinate axes as the ellipsoid: NaN in, NaN out instead.
    bad = ~jnp.all(jnp.isfinite(K), axis=(-2, -1))
    return jnp.where(bad[..., None], jnp.nan, w), jnp.where(bad[..., None, None], jnp.nan, V)


@jax.custom_jvp
def eigh_descending_inline(K: jax.Array) -> tuple[jax.Array, jax.Array]:
    """Eigen-decomposition of a symmetric matrix, eigenvalues descending, with a gradient-safe JVP.

    Args:
        K: symmetric matrix (..., m, m); only its symmetric part is used.

    Returns:
        ``(w, V)``: eigenvalues (..., m) with ``w[..., 0] >= w[..., 1] >= ...`` and unit
        eigenvectors (..., m, m) as columns (``V[..., :, i]`` belongs to ``w[..., i]``); the sign
        of each column is arbitrary. Dtype of ``K``.
    """
    return eigh_descending_primal(K)


@eigh_descending_inline.defjvp
def _eigh_descending_jvp(primals: tuple, tangents: tuple):
    (K,), (dK,) = primals, tangents
    w, V = eigh_descending_primal(K)
    dK = 0.5 * (dK + jnp.swapaxes(dK, -1, -2))
    Vt = jnp.swapaxes(V, -1, -2)
    A = mm(mm(Vt, dK), V)  # V^T dK V
    dw = jnp.diagonal(A, axis1=-2, axis2=-1)
    gap = w[..., None, :] - w[..., :, None]  # gap[i, j] = w_j - w_i
    scale = jnp.max(jnp.abs(w), axis=-1)[..., None, None]
    ok = jnp.abs(gap) > gap_tol(K.dtype) * scale + jnp.finfo(K.dtype).tiny
    Finv = jnp.where(ok, 1.0 / jnp.where(ok, gap, 1.0), 0.0)
    dV = mm(V, Finv * A)
    return (w, V), (dw, dV)


# jit at the entry point: an eager call compiles once per shape and dtype (instead of dispatching
# the unrolled rotations op by op); inside a caller's jit it is inlined.
eigh_descending = jax.jit(eigh_descending_inline)
eigh_descending.__doc__ = eigh_descending_inline.__doc__
