"""Constant-aware scalar algebra of the unrolled kinematics kernels (SPEC section 1).

A chain's geometry enters the kernels as Python floats (compile-time constants) and the joint
values as arrays of the batch shape; every entry of a rotation or a position is one such scalar.
The operations here fold constant arithmetic in Python and drop multiplications by 0, 1 and -1
and additions of 0, so XLA receives only the arithmetic a chain needs.
"""

from __future__ import annotations

from collections.abc import Sequence

import jax

__all__ = ["add", "sub"]

Scalar = float | jax.Array  # a Python float is a compile-time constant
Vec3 = Sequence[Scalar]
Mat3 = Sequence[Sequence[Scalar]]


def is_const(a: Scalar) -> bool:
    """Whether ``a`` is a compile-time constant (a Python float)."""
    return isinstance(a, float)


def mul(a: Scalar, b: Scalar) -> Scalar:
    """``a * b``, folded where a factor is a constant 0, 1 or -1 (or both are constants)."""
    if is_const(a):
        if a == 0.0:
            return 0.0
        if is_const(b):
            return a * b
        if a == 1.0:
            return b
        if a == -1.0:
            return -b
        return a * b
    if is_const(b):
        return mul(b, a)
    return a * b


def add(a: Scalar, b: Scalar) -> Scalar:
    """``a + b``, folded where a term is a constant 0."""
    if is_const(a) and a == 0.0:
        return b
    if is_const(b) and b == 0.0:
        return a
    return a + b


def sub(a: Scalar, b: Scalar) -> Scalar:
    """``a - b`` (as ``a + (-1) b``)."""
    return add(a, mul(-1.0, b))


def dot3(a: Vec3, b: Vec3) -> Scalar:
    """``a . b`` of two 3-vectors of scalars, summed left to right."""
    return add(add(mul(a[0], b[0]), mul(a[1], b[1])), mul(a[2], b[2]))


def matmul3(A: Mat3, B: Mat3) -> list[list[Scalar]]:
    """3x3 @ 3x3, both nested lists/tuples of scalars."""
    return [[dot3(A[i], [B[0][j], B[1][j], B[2][j]]) for j in range(3)] for i in range(3)]


def matvec3(A: Mat3, v: Vec3) -> list[Scalar]:
    """3x3 @ 3-vector."""
    return [dot3(A[i], v) for i in range(3)]


def cross(a: Vec3, b: Vec3) -> list[Scalar]:
    """``a x b`` of two 3-vectors of scalars."""
    return [
        sub(mul(a[1], b[2]), mul(a[2], b[1])),
        sub(mul(a[2], b[0]), mul(a[0], b[2])),
        sub(mul(a[0], b[1]), mul(a[1], b[0])),
    ]
