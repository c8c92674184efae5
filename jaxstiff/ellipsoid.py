"""The stiffness ellipsoid of a symmetric positive-definite K (SPEC section 3), gradient-safe.

Axes are the eigenvalues ``lambda1 >= lambda2 (>= lambda3)`` of K (the stiffness along each
principal direction, N/m); directions are the unit eigenvectors, as columns; the ellipsoid's
"direction" is ``v1``, its longest axis (S0-8). Ratio ``rho = lambda1 / lambda2``; volume
``lambda1 lambda2 lambda3`` (area ``lambda1 lambda2`` in 2-D).

Gradient safety. The derivative of an eigenvector carries ``1 / (lambda_i - lambda_j)``, infinite
where two axes coincide (a sphere, or ``lambda2 = lambda3``). :func:`eigh_descending` has a custom
JVP that drops the coupling between eigenvectors whose gap is below ``tol * max|lambda|``
(``tol`` = 1e-9 in float64, 1e-4 in float32): there the eigenvectors are not defined and any
choice is a valid one; everywhere else it is the exact derivative. The orientation error is
computed as ``atan2(|v1 x d|, |v1 . d|)`` with a norm whose gradient is finite at zero, instead of
``acos``, whose derivative is infinite at alpha = 0 (the optimum every solver aims for).

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

__all__ = ["Ellipsoid", "ellipsoid", "eigh_descending", "orientation_error", "axis_ratio", "volume"]


def _gap_tol(dtype) -> float:
    return 1e-9 if jnp.finfo(dtype).bits >= 64 else 1e-4


@jax.custom_jvp
def eigh_descending(K: jax.Array) -> tuple[jax.Array, jax.Array]:
    """Eigenvalues (..., m) in descending order and unit eigenvectors (..., m, m) as columns."""
    w, V = jnp.linalg.eigh(K)
    return w[..., ::-1], V[..., ::-1]


@eigh_descending.defjvp
def _eigh_descending_jvp(primals, tangents):
    (K,), (dK,) = primals, tangents
    w, V = eigh_descending(K)
    dK = 0.5 * (dK + jnp.swapaxes(dK, -1, -2))
    A = jnp.swapaxes(V, -1, -2) @ dK @ V  # V^T dK V
    dw = jnp.diagonal(A, axis1=-2, axis2=-1)
    gap = w[..., None, :] - w[..., :, None]  # gap[i, j] = w_j - w_i
    scale = jnp.max(jnp.abs(w), axis=-1)[..., None, None]
    ok = jnp.abs(gap) > _gap_tol(K.dtype) * scale + jnp.finfo(K.dtype).tiny
    Finv = jnp.where(ok, 1.0 / jnp.where(ok, gap, 1.0), 0.0)
    dV = V @ (Finv * A)
    return (w, V), (dw, dV)


@jax.tree_util.register_dataclass
@dataclasses.dataclass(frozen=True)
class Ellipsoid:
    """Principal axes of a stiffness matrix.

    Attributes:
        axes: (..., m) eigenvalues, descending (N/m).
        directions: (..., m, m) unit eigenvectors as columns; ``directions[..., :, 0]`` is ``v1``.
        ratio: (...,) ``lambda1 / lambda2``.
        volume: (...,) product of the axes.
    """

    axes: jax.Array
    directions: jax.Array
    ratio: jax.Array
    volume: jax.Array

    @property
    def major(self) -> jax.Array:
        """The unit direction of the longest axis, ``v1`` (..., m)."""
        return self.directions[..., :, 0]


def _check_square(K, name="K"):
    K = jnp.asarray(K)
    if K.ndim < 2 or K.shape[-1] != K.shape[-2] or K.shape[-1] not in (2, 3):
        raise ValueError(f"{name} must have shape (..., 2, 2) or (..., 3, 3), got {tuple(K.shape)}")
    if not jnp.issubdtype(K.dtype, jnp.floating):
        raise ValueError(f"{name} must have a floating dtype, got {K.dtype}")
    return K


def _safe_ratio(a, b):
    tiny = jnp.finfo(a.dtype).tiny
    return a / jnp.maximum(b, tiny * 1e6)


def ellipsoid(K: jax.Array) -> Ellipsoid:
    """Decompose a 2x2 or 3x3 stiffness matrix (..., m, m) into its ellipsoid (S0-8)."""
    K = _check_square(K)
    w, V = eigh_descending(K)
    return Ellipsoid(axes=w, directions=V, ratio=_safe_ratio(w[..., 0], w[..., 1]), volume=jnp.prod(w, axis=-1))


def axis_ratio(K: jax.Array) -> jax.Array:
    """``rho = lambda1 / lambda2`` (...,) of a 2x2 or 3x3 K."""
    return ellipsoid(K).ratio


def volume(K: jax.Array) -> jax.Array:
    """Product of the axes (...,): volume of a 3x3 ellipsoid (up to 4/3 pi), area of a 2x2 one (up to pi)."""
    return ellipsoid(K).volume


def _safe_norm(x: jax.Array, axis=-1) -> jax.Array:
    n2 = jnp.sum(x * x, axis=axis)
    pos = n2 > 0
    return jnp.where(pos, jnp.sqrt(jnp.where(pos, n2, 1.0)), 0.0)


def _alpha_rad(v1: jax.Array, d: jax.Array) -> jax.Array:
    d = jnp.asarray(d, dtype=v1.dtype)
    d = jnp.broadcast_to(d, v1.shape)
    dn = d / jnp.maximum(_safe_norm(d), jnp.finfo(v1.dtype).tiny)[..., None]
    cos = jnp.abs(jnp.sum(v1 * dn, axis=-1))
    if v1.shape[-1] == 2:
        sin = jnp.abs(v1[..., 0] * dn[..., 1] - v1[..., 1] * dn[..., 0])
    else:
        sin = _safe_norm(jnp.cross(v1, dn))
    return jnp.arctan2(sin, cos)


def orientation_error(K: jax.Array, d: jax.Array) -> jax.Array:
    """Angle alpha (degrees, in [0, 90]) between the ellipsoid's major axis and direction ``d``.

    ``alpha = acos(|v1 . d| / |d|)``, sign-free in both ``v1`` and ``d`` (SPEC section 3), computed
    as an ``atan2`` so that its gradient is finite at alpha = 0.

    Args:
        K: (..., m, m), m = 2 or 3.
        d: (..., m) desired direction (need not be unit; a zero d gives alpha = 0).
    """
    K = _check_square(K)
    d = jnp.asarray(d)
    if d.shape[-1:] != K.shape[-1:]:
        raise ValueError(f"d must have shape (..., {K.shape[-1]}) to match K {tuple(K.shape)}, got {tuple(d.shape)}")
    _, V = eigh_descending(K)
    return _alpha_rad(V[..., :, 0], d) * (180.0 / math.pi)
