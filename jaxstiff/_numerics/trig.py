"""Cosine and sine of joint angles: one shared range reduction and two polynomials of plain multiply/add.

XLA's CPU sine and cosine are scalar library calls in float64, and its loop fusion evaluates them
again in every fusion that reads them; the polynomial here is elementwise multiply/add, which XLA
vectorises and fuses (why and how much: docs/notes/model.md). Values agree with libm to 1-2 ulp.
"""

from __future__ import annotations

import math

import jax
import jax.numpy as jnp

__all__: list[str] = []

# pi/2 = P1 + P2 + P3 (Cody and Waite's split). P1 and P2 keep only the leading 33 (float64) or
# 12 (float32) bits of their part, so k * P1 and k * P2 are exact for |k| < 2^20 (float64) or
# 2^12 (float32), i.e. |x| < 1.6e6 rad or 6.4e3 rad; beyond that the reduced argument loses
# about ulp(x), the conditioning of sin itself there. Values derived with mpmath at 60 digits.
_PI_HALF = {
    8: (float.fromhex("0x1.921fb544p+0"), float.fromhex("0x1.0b4611a6p-34"), float.fromhex("0x1.3198a2e037073p-69")),
    4: (float.fromhex("0x1.92p+0"), float.fromhex("0x1.fb4p-12"), float.fromhex("0x1.4442d2p-24")),
}
# Taylor coefficients (-1)^i / (2i+1)! and (-1)^i / (2i)!, enough terms that the first one left
# out is below 1e-19 (float64) or 1e-9 (float32) on |r| <= pi/4.
_SIN_TERMS = {8: 9, 4: 5}  # through r^17 / r^9
_COS_TERMS = {8: 9, 4: 6}  # through r^16 / r^10


def _sincos_poly(x: jax.Array) -> tuple[jax.Array, jax.Array]:
    """(cos x, sin x) from one shared range reduction and two polynomials of plain mul/add."""
    if x.dtype.itemsize < 4:  # float16/bfloat16: compute in float32
        c, s = _sincos_poly(x.astype(jnp.float32))
        return c.astype(x.dtype), s.astype(x.dtype)
    size = 8 if x.dtype.itemsize >= 8 else 4
    p1, p2, p3 = _PI_HALF[size]
    k = jnp.round(x * (2.0 / math.pi))  # nearest multiple of pi/2
    r = ((x - k * p1) - k * p2) - k * p3  # |r| <= pi/4 (+ rounding)
    r2 = r * r
    ps = (-1.0) ** (_SIN_TERMS[size] - 1) / math.factorial(2 * _SIN_TERMS[size] - 1)
    for i in reversed(range(_SIN_TERMS[size] - 1)):
        ps = ps * r2 + (-1.0) ** i / math.factorial(2 * i + 1)
    pc = (-1.0) ** (_COS_TERMS[size] - 1) / math.factorial(2 * _COS_TERMS[size] - 2)
    for i in reversed(range(_COS_TERMS[size] - 1)):
        pc = pc * r2 + (-1.0) ** i / math.factorial(2 * i)
    sin_r, cos_r = r * ps, pc
    quadrant = k - 4.0 * jnp.floor(k * 0.25)  # k mod 4 in {0, 1, 2, 3}, exact in floating point
    odd = (quadrant == 1.0) | (quadrant == 3.0)
    sin_x = jnp.where(odd, cos_r, sin_r)
    cos_x = jnp.where(odd, sin_r, cos_r)
    sin_x = jnp.where(quadrant >= 2.0, -sin_x, sin_x)
    cos_x = jnp.where((quadrant == 1.0) | (quadrant == 2.0), -cos_x, cos_x)
    return cos_x, sin_x


@jax.custom_jvp
def cos_sin(x: jax.Array) -> tuple[jax.Array, jax.Array]:
    """``(cos x, sin x)`` elementwise, to within 1-2 ulp of libm, in the dtype of ``x``.

    One range reduction ``x = k pi/2 + r`` (``|r| <= pi/4``, Cody-Waite) shared by both, then
    Taylor polynomials in ``r`` and a quadrant swap. Its derivative is the exact ``(-sin x, cos x)``.

    Args:
        x: angles (rad), any shape, floating dtype.

    Returns:
        ``(cos x, sin x)``, each of the shape and dtype of ``x``.
    """
    return _sincos_poly(x)


@cos_sin.defjvp
def _cos_sin_jvp(primals: tuple[jax.Array], tangents: tuple[jax.Array]):
    (x,), (dx,) = primals, tangents
    c, s = cos_sin(x)
    return (c, s), (-s * dx, c * dx)


# Below this many configurations per call, XLA's own sin/cos is faster on the CPU: there the
# polynomial, duplicated by loop fusion into every output entry, is not amortised over a batch.
POLY_MIN_BATCH = 64


def joint_cos_sin(q: jax.Array, poly: bool | None = None) -> tuple[jax.Array, jax.Array]:
    """cos/sin of all joint values ``q`` (..., n): :func:`cos_sin` if ``poly``, else XLA's sin and cos;
    ``poly=None`` chooses :func:`cos_sin` for CPU batches of at least ``POLY_MIN_BATCH`` configurations."""
    if poly is None:
        batch = q.size // max(q.shape[-1], 1)
        poly = jax.default_backend() == "cpu" and batch >= POLY_MIN_BATCH
    return cos_sin(q) if poly else (jnp.cos(q), jnp.sin(q))
