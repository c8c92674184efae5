"""The stiffness ellipsoid of a symmetric positive-definite K (SPEC section 3), gradient-safe.

Axes are the eigenvalues ``lambda1 >= lambda2 (>= lambda3)`` of K (the stiffness along each
principal direction, N/m); directions are the unit eigenvectors, as columns; the ellipsoid's
"direction" is ``v1``, its longest axis (S0-8: for a symmetric K the SVD and the
eigen-decomposition coincide). Ratio ``rho = lambda1 / lambda2``; volume ``lambda1 lambda2 lambda3``
(area ``lambda1 lambda2`` in 2-D), without the constant 4/3 pi (pi in 2-D).

Eigen-decomposition. 2x2 and 3x3 matrices are decomposed by Jacobi rotations written out as
elementwise array arithmetic: one exact rotation for 2x2, four cyclic sweeps (12 rotations) for
3x3, which converge to machine precision for every symmetric 3x3 matrix (Jacobi's method is
quadratically convergent; the tests check 1e-13 against numpy on random, graded and nearly
degenerate matrices). Over a batch this fuses into one loop and runs ~5x faster on a CPU than
LAPACK's batched ``eigh``, with the same accuracy. Larger matrices use ``jnp.linalg.eigh``.

Gradient safety. The derivative of an eigenvector carries ``1 / (lambda_i - lambda_j)``, infinite
where two axes coincide (a sphere ``lambda1 = lambda2``, or ``lambda2 = lambda3``).
:func:`eigh_descending` has a custom JVP that is the exact first-order perturbation result away
from degeneracy and drops the coupling between eigenvectors whose gap is below
``tol * max|lambda|`` (``tol`` = 1e-9 in float64, 1e-4 in float32): there the eigenvectors are not
defined and any choice is a valid one, so their derivative is set to the part that is defined.
Consequences, all tested: gradients of ``rho``, the volume and the axes are exact everywhere
(eigenvalue derivatives need no gap); the gradient of ``v1`` (and hence of alpha) is exact
whenever ``lambda1 > lambda2``, also at ``lambda2 = lambda3``, and finite (never NaN/Inf) at a
sphere, where alpha itself is undefined. The orientation error is computed as
``atan2(|v1 x d|, |v1 . d|)`` with a norm whose gradient is finite at zero, instead of ``acos``,
whose derivative is infinite at alpha = 0 (the optimum every solver aims for).

Example:
    >>> import jax.numpy as jnp, jaxstiff
    >>> e = jaxstiff.ellipsoid(jnp.diag(jnp.array([1.0, 5.0])))
    >>> float(e.ratio)
    5.0
"""

from __future__ import annotations

import dataclasses
import math

import jax
import jax.numpy as jnp
import numpy as np

from .stiffness import _broadcast_batch

__all__ = [
    "Ellipsoid",
    "ellipsoid",
    "eigh_descending",
    "orientation_error",
    "axis_ratio",
    "volume",
    "JACOBI_SWEEPS",
]

#: Cyclic Jacobi sweeps used for 3x3 matrices (each sweep is 3 rotations).
JACOBI_SWEEPS = 4


def _gap_tol(dtype) -> float:
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


def _compare_swap(w, cols, i, j):
    """Order eigenpairs i < j descending (elementwise over the batch)."""
    swap = w[j] > w[i]
    w[i], w[j] = jnp.where(swap, w[j], w[i]), jnp.where(swap, w[i], w[j])
    ci, cj = cols[i], cols[j]
    cols[i] = [jnp.where(swap, b, a) for a, b in zip(ci, cj)]
    cols[j] = [jnp.where(swap, a, b) for a, b in zip(ci, cj)]


def _assemble(w, cols):
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


_KEYS3 = ((0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2))


def _key(i: int, j: int) -> tuple[int, int]:
    return (i, j) if i <= j else (j, i)


def _jacobi_sweep3(_, carry):
    """One cyclic sweep (rotations (0,1), (0,2), (1,2)) over the upper triangle ``a`` and ``V``."""
    a, v = carry
    A = dict(zip(_KEYS3, a))
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
    a, v = jax.lax.fori_loop(0, sweeps, _jacobi_sweep3, (a, v))
    A = dict(zip(_KEYS3, a))
    w = [A[0, 0], A[1, 1], A[2, 2]]
    cols = [[v[3 * k + i] for k in range(3)] for i in range(3)]
    _compare_swap(w, cols, 0, 1)
    _compare_swap(w, cols, 1, 2)
    _compare_swap(w, cols, 0, 1)
    return _assemble(w, cols)


def _eigh_desc_primal(K: jax.Array):
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


def _mm(A: jax.Array, B: jax.Array) -> jax.Array:
    """Small batched matrix product as a broadcast sum (fuses on CPU; dot_general on tiny batches does not)."""
    return jnp.sum(A[..., :, :, None] * B[..., None, :, :], axis=-2)


@jax.custom_jvp
def _eigh_descending(K: jax.Array) -> tuple[jax.Array, jax.Array]:
    """Eigen-decomposition of a symmetric matrix, eigenvalues descending, with a gradient-safe JVP.

    Args:
        K: symmetric matrix (..., m, m); only its symmetric part is used.

    Returns:
        ``(w, V)``: eigenvalues (..., m) with ``w[..., 0] >= w[..., 1] >= ...`` and unit
        eigenvectors (..., m, m) as columns (``V[..., :, i]`` belongs to ``w[..., i]``); the sign
        of each column is arbitrary. Dtype of ``K``.
    """
    return _eigh_desc_primal(K)


@_eigh_descending.defjvp
def _eigh_descending_jvp(primals, tangents):
    (K,), (dK,) = primals, tangents
    w, V = _eigh_desc_primal(K)
    dK = 0.5 * (dK + jnp.swapaxes(dK, -1, -2))
    Vt = jnp.swapaxes(V, -1, -2)
    A = _mm(_mm(Vt, dK), V)  # V^T dK V
    dw = jnp.diagonal(A, axis1=-2, axis2=-1)
    gap = w[..., None, :] - w[..., :, None]  # gap[i, j] = w_j - w_i
    scale = jnp.max(jnp.abs(w), axis=-1)[..., None, None]
    ok = jnp.abs(gap) > _gap_tol(K.dtype) * scale + jnp.finfo(K.dtype).tiny
    Finv = jnp.where(ok, 1.0 / jnp.where(ok, gap, 1.0), 0.0)
    dV = _mm(V, Finv * A)
    return (w, V), (dw, dV)


# jit at the entry point: an eager call compiles once per shape and dtype (instead of dispatching
# the unrolled rotations op by op); inside a caller's jit it is inlined.
eigh_descending = jax.jit(_eigh_descending)


@jax.tree_util.register_dataclass
@dataclasses.dataclass(frozen=True)
class Ellipsoid:
    """Principal axes of a stiffness matrix (a pytree: it passes through jit, vmap and grad).

    Attributes:
        axes: (..., m) eigenvalues, descending (N/m for a translational stiffness).
        directions: (..., m, m) unit eigenvectors as columns; ``directions[..., :, 0]`` is ``v1``.
        ratio: (...,) ``lambda1 / lambda2`` (>= 1).
        volume: (...,) product of the axes (no 4/3 pi; the area without pi in 2-D).
    """

    axes: jax.Array
    directions: jax.Array
    ratio: jax.Array
    volume: jax.Array

    @property
    def major(self) -> jax.Array:
        """The unit direction of the longest axis, ``v1`` (..., m)."""
        return self.directions[..., :, 0]


def _check_square(K, name: str = "K") -> jax.Array:
    K = jnp.asarray(K)
    if K.ndim < 2 or K.shape[-1] != K.shape[-2] or K.shape[-1] not in (2, 3):
        raise ValueError(f"{name} must have shape (..., 2, 2) or (..., 3, 3), got {tuple(K.shape)}")
    if not jnp.issubdtype(K.dtype, jnp.floating):
        raise ValueError(f"{name} must have a floating dtype, got {K.dtype}")
    return K


def _safe_ratio(lam1: jax.Array, lam2: jax.Array) -> jax.Array:
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


def ellipsoid(K: jax.Array) -> Ellipsoid:
    """Decompose a 2x2 or 3x3 stiffness matrix into its ellipsoid (S0-8).

    Args:
        K: symmetric positive-definite stiffness (..., m, m), m = 2 or 3, e.g. N/m.

    Returns:
        :class:`Ellipsoid` with axes (..., m), directions (..., m, m), ratio (...,), volume (...,).
        NaN or Inf in K gives NaN (never a made-up ellipsoid).

    Raises:
        ValueError: a (concrete, not traced) K with an eigenvalue below ``-1e-9 * lambda1``.

    Example:
        >>> e = ellipsoid(jnp.array([[3.0, 1.0], [1.0, 3.0]]))  # axes 4 and 2 along the diagonals
        >>> e.axes.tolist(), float(e.ratio)
        ([4.0, 2.0], 2.0)
    """
    e = _ellipsoid(_check_square(K))
    if not isinstance(e.axes, jax.core.Tracer):  # concrete input: an indefinite K has no ellipsoid
        w = np.asarray(e.axes)
        # (a positive semi-definite K, e.g. rotated diag(3000, 1000, 0), has rounding-level negatives)
        neg = w[..., -1] < -max(1e-9, 100 * np.finfo(w.dtype).eps) * np.abs(w[..., 0])
        if np.any(neg):
            at = np.argwhere(neg)[0]
            where = f" at index {tuple(int(i) for i in at)}" if at.size else ""
            raise ValueError(f"K must be positive (semi-)definite (a stiffness); it has the eigenvalue {float(w[tuple(at)][-1]):g}{where}")
    return e


@jax.jit
def _ellipsoid(K: jax.Array) -> Ellipsoid:
    w, V = _eigh_descending(K)
    return Ellipsoid(axes=w, directions=V, ratio=_safe_ratio(w[..., 0], w[..., 1]), volume=jnp.prod(w, axis=-1))


def axis_ratio(K: jax.Array) -> jax.Array:
    """``rho = lambda1 / lambda2`` (...,) of a 2x2 or 3x3 K (S0-9: r_max / r_min)."""
    return ellipsoid(K).ratio


def volume(K: jax.Array) -> jax.Array:
    """Product of the axes (...,): volume of a 3x3 ellipsoid (up to 4/3 pi), area of a 2x2 one (up to pi)."""
    return ellipsoid(K).volume


def _safe_norm(x: jax.Array, axis: int = -1) -> jax.Array:
    n2 = jnp.sum(x * x, axis=axis)
    pos = n2 > 0
    return jnp.where(pos, jnp.sqrt(jnp.where(pos, n2, 1.0)), 0.0)


def _safe_atan2(y: jax.Array, x: jax.Array) -> jax.Array:
    """``atan2(y, x)`` whose gradient is 0 (not NaN) at ``x = y = 0``."""
    ok = (x != 0) | (y != 0)
    return jnp.where(ok, jnp.arctan2(jnp.where(ok, y, 0.0), jnp.where(ok, x, 1.0)), 0.0)


def _alpha_rad(v1: jax.Array, d: jax.Array) -> jax.Array:
    """Angle in [0, pi/2] between the line of ``v1`` (unit) and the line of ``d`` (any length)."""
    d = jnp.asarray(d, dtype=v1.dtype)
    shape = jnp.broadcast_shapes(v1.shape, d.shape)
    v1, d = jnp.broadcast_to(v1, shape), jnp.broadcast_to(d, shape)
    dnorm = _safe_norm(d)
    dn = d / jnp.where(dnorm > 0, dnorm, 1.0)[..., None]
    cos = jnp.abs(jnp.sum(v1 * dn, axis=-1))
    if v1.shape[-1] == 2:
        sin = jnp.abs(v1[..., 0] * dn[..., 1] - v1[..., 1] * dn[..., 0])
    else:
        sin = _safe_norm(jnp.cross(v1, dn))
    return _safe_atan2(sin, cos)


def _check_direction(K: jax.Array, d) -> jax.Array:
    d = jnp.asarray(d)
    if d.ndim < 1 or d.shape[-1] != K.shape[-1]:
        raise ValueError(f"d must have shape (..., {K.shape[-1]}) to match K {tuple(K.shape)}, got {tuple(d.shape)}")
    _broadcast_batch(("K", K.shape[:-2]), ("d", d.shape[:-1]))
    return d


def orientation_error(K: jax.Array, d: jax.Array) -> jax.Array:
    """Angle alpha (degrees, in [0, 90]) between the ellipsoid's major axis and direction ``d``.

    ``alpha = acos(|v1 . d| / |d|)`` (SPEC section 3; seed 000's alpha_error in S0-9, S0-15),
    sign-free in both ``v1`` and ``d``, computed as ``atan2(|v1 x d|, |v1 . d|)`` so that its
    gradient is finite at alpha = 0 and accurate for small angles.

    Args:
        K: stiffness (..., m, m), m = 2 or 3, in the frame of ``d``.
        d: desired direction (..., m), broadcast against K's batch; need not be unit. A zero d
            gives alpha = 0 (and a zero gradient).

    Returns:
        (...,) degrees, dtype of K.
    """
    K = _check_square(K)
    return _orientation_error(K, _check_direction(K, d))


@jax.jit
def _orientation_error(K: jax.Array, d: jax.Array) -> jax.Array:
    _, V = _eigh_descending(K)
    return _alpha_rad(V[..., :, 0], d) * (180.0 / math.pi)
