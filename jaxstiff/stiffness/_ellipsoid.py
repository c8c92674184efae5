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
degenerate matrices). Over a batch this fuses into one loop (faster on a CPU than LAPACK's
batched ``eigh``, with the same accuracy: docs/notes/model.md). Larger matrices use ``jnp.linalg.eigh``.

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
from numpy.typing import ArrayLike

from jaxstiff._numerics.batch import broadcast_batch, check_square, is_traced
from jaxstiff._numerics.eig import JACOBI_SWEEPS, eigh_descending, eigh_descending_inline
from jaxstiff._numerics.safe import safe_atan2, safe_norm, safe_ratio

__all__ = ["Ellipsoid", "ellipsoid", "eigh_descending", "orientation_error", "axis_ratio", "volume", "JACOBI_SWEEPS"]


@jax.tree_util.register_dataclass
@dataclasses.dataclass(frozen=True)
class Ellipsoid:
    """Principal axes of a stiffness matrix (a pytree: it passes through jit, vmap and grad).

    Attributes:
        axes: (..., m) eigenvalues, descending (N/m for a translational stiffness).
        directions: (..., m, m) unit eigenvectors as columns; ``directions[..., :, 0]`` is ``v1``.
        ratio: (...,) ``lambda1 / lambda2`` (>= 1). Capped at ``1 / eps`` (4.5e15 in float64,
            8.4e6 in float32) where ``lambda2`` is zero or below the precision it is known to (a
            singular K: value and gradient stay finite); 1 for K = 0, which has no direction.
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
    K = check_square(K)
    e = _ellipsoid(K)
    if not is_traced(e.axes):  # concrete input: an indefinite K has no ellipsoid
        refuse_indefinite(K, np.asarray(e.axes))
    return e


def _refuse_asymmetric(K: jax.Array) -> None:
    """A concrete K clearly not symmetric (an entry of ``K - K^T`` above ``max(1e-6, 100 eps)`` of
    the largest entry): the computations read its symmetric part, which is another matrix, and
    ``[[3, 2], [0, 3]]`` came out as the ellipsoid of ``[[3, 1], [1, 3]]`` without a word."""
    a = np.asarray(K)
    if not np.issubdtype(a.dtype, np.floating) or a.size == 0:
        return
    with np.errstate(invalid="ignore"):
        scale = np.max(np.abs(np.where(np.isfinite(a), a, 0.0)))
        asym = np.abs(a - np.swapaxes(a, -1, -2))
    tol = max(1e-6, 100 * float(np.finfo(a.dtype).eps)) * scale
    if np.any(asym > tol):
        at = tuple(int(i) for i in np.argwhere(asym > tol)[0])
        raise ValueError(
            f"K must be symmetric (a stiffness matrix): |K - K^T| is {float(asym[at]):g} at index {at}, "
            f"against entries up to {float(scale):g}"
        )


def refuse_indefinite(K: jax.Array, axes: np.ndarray | None = None) -> None:
    """Raise ValueError for a concrete K (..., m, m) with an eigenvalue below ``-1e-9 lambda1``, or
    clearly not symmetric (:func:`_refuse_asymmetric`).

    The one rule of :func:`ellipsoid`, :func:`orientation_error`, :func:`jaxstiff.f1`,
    :func:`jaxstiff.f2` and :func:`jaxstiff.stiffness._criteria.alpha_and_ratio`: an indefinite
    matrix is no stiffness, and its "major axis" or "ratio" would be made up (f2 gave 8.0 and alpha
    0.0 for one that ellipsoid refused). A positive semi-definite K (e.g. rotated diag(3000, 1000,
    0)) has rounding-level negatives and passes; NaN or Inf entries are left to the callers (they
    give NaN). Inside ``jit``/``grad``/``vmap`` (a traced K) nothing is checked.

    Args:
        K: the matrices.
        axes: their eigenvalues (..., m), descending, if already computed.
    """
    if is_traced(K):
        return
    _refuse_asymmetric(K)
    if axes is None:
        a = np.asarray(K, dtype=float)
        a = 0.5 * (a + np.swapaxes(a, -1, -2))  # what the computations read (eigvalsh alone reads one triangle)
        ok = np.all(np.isfinite(a), axis=(-2, -1))
        w = np.full(a.shape[:-1], np.nan)
        w[ok] = np.linalg.eigvalsh(a[ok])[..., ::-1]
    else:
        w = np.asarray(axes, dtype=float)
    # (a positive semi-definite K has rounding-level negatives)
    tol = max(1e-9, 100 * np.finfo(np.asarray(K).dtype).eps if np.issubdtype(np.asarray(K).dtype, np.floating) else 0)
    with np.errstate(invalid="ignore"):
        neg = w[..., -1] < -tol * np.abs(w[..., 0])
    if np.any(neg):
        at = np.argwhere(neg)[0]
        where = f" at index {tuple(int(i) for i in at)}" if at.size else ""
        raise ValueError(
            f"K must be positive (semi-)definite (a stiffness); it has the eigenvalue {float(w[tuple(at)][-1]):g}{where}"
        )


@jax.jit
def _ellipsoid(K: jax.Array) -> Ellipsoid:
    w, V = eigh_descending_inline(K)
    return Ellipsoid(axes=w, directions=V, ratio=safe_ratio(w[..., 0], w[..., 1]), volume=jnp.prod(w, axis=-1))


def axis_ratio(K: jax.Array) -> jax.Array:
    """``rho = lambda1 / lambda2`` (...,) of a 2x2 or 3x3 K (S0-9: r_max / r_min)."""
    return ellipsoid(K).ratio


def volume(K: jax.Array) -> jax.Array:
    """Product of the axes (...,): volume of a 3x3 ellipsoid (up to 4/3 pi), area of a 2x2 one (up to pi)."""
    return ellipsoid(K).volume


def alpha_rad(v1: jax.Array, d: jax.Array) -> jax.Array:
    """Angle in [0, pi/2] between the line of ``v1`` (unit) and the line of ``d`` (any length)."""
    d = jnp.asarray(d, dtype=v1.dtype)
    shape = jnp.broadcast_shapes(v1.shape, d.shape)
    v1, d = jnp.broadcast_to(v1, shape), jnp.broadcast_to(d, shape)
    dnorm = safe_norm(d)
    dn = d / jnp.where(dnorm > 0, dnorm, 1.0)[..., None]
    cos = jnp.abs(jnp.sum(v1 * dn, axis=-1))
    if v1.shape[-1] == 2:
        sin = jnp.abs(v1[..., 0] * dn[..., 1] - v1[..., 1] * dn[..., 0])
    else:
        sin = safe_norm(jnp.cross(v1, dn))
    return safe_atan2(sin, cos)


def check_direction(K: jax.Array, d: ArrayLike) -> jax.Array:
    d = jnp.asarray(d)
    if d.ndim < 1 or d.shape[-1] != K.shape[-1]:
        raise ValueError(f"d must have shape (..., {K.shape[-1]}) to match K {tuple(K.shape)}, got {tuple(d.shape)}")
    broadcast_batch(("K", K.shape[:-2]), ("d", d.shape[:-1]))
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
    K = check_square(K)
    refuse_indefinite(K)
    return _orientation_error(K, check_direction(K, d))


@jax.jit
def _orientation_error(K: jax.Array, d: jax.Array) -> jax.Array:
    _, V = eigh_descending_inline(K)
    return alpha_rad(V[..., :, 0], d) * (180.0 / math.pi)
