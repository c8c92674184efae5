"""Forward kinematics and the geometric Jacobian (SPEC section 1), pure JAX, any leading batch axes.

The chain is unrolled at trace time. Every entry of every rotation and translation is carried as
its own array of the batch shape (structure of arrays), and the robot's constant geometry enters
as Python floats: multiplications by structural zeros and ones (axis-aligned joint axes, identity
origin rotations) are dropped while tracing, so XLA receives only the arithmetic the chain needs
and fuses it into a few elementwise loops over the batch. That is what makes the kernel fast on a
CPU, and it keeps the caller's dtype (float32 stays float32, float64 stays float64).

The Jacobian is the analytic geometric one, not autodiff of FK: for revolute joint i with world
axis ``z_i`` through the point ``p_i``, column i is ``[z_i x (p_tcp - p_i); z_i]``; for a
prismatic joint ``[z_i; 0]`` (rows ``[v; w]``, base frame, for the TCP point).

Example:
    >>> import jax.numpy as jnp, jaxstiff
    >>> robot = jaxstiff.Robot.from_urdf("planar_3r")
    >>> T, J = jaxstiff.fk_and_jacobian(robot, jnp.zeros((10, 3)))
    >>> T.shape, J.shape
    ((10, 4, 4), (10, 6, 3))
"""

from __future__ import annotations

import functools
import math
from typing import Union

import jax
import jax.numpy as jnp

from .robot import JOINT_PRISMATIC, Robot

__all__ = ["fk", "jacobian", "fk_and_jacobian", "position_and_jacobian"]

Scalar = Union[float, jax.Array]  # a Python float is a compile-time constant


# ---------------------------------------------------------------- constant-aware scalar algebra
def _is_const(a) -> bool:
    return isinstance(a, float)


def _mul(a: Scalar, b: Scalar) -> Scalar:
    if _is_const(a):
        if a == 0.0:
            return 0.0
        if _is_const(b):
            return a * b
        if a == 1.0:
            return b
        if a == -1.0:
            return -b
        return a * b
    if _is_const(b):
        return _mul(b, a)
    return a * b


def _add(a: Scalar, b: Scalar) -> Scalar:
    if _is_const(a) and a == 0.0:
        return b
    if _is_const(b) and b == 0.0:
        return a
    return a + b


def _sub(a: Scalar, b: Scalar) -> Scalar:
    return _add(a, _mul(-1.0, b))


def _dot3(a, b) -> Scalar:
    return _add(_add(_mul(a[0], b[0]), _mul(a[1], b[1])), _mul(a[2], b[2]))


def _matmul3(A, B):
    """3x3 @ 3x3, both nested lists/tuples of scalars."""
    return [[_dot3(A[i], [B[0][j], B[1][j], B[2][j]]) for j in range(3)] for i in range(3)]


def _matvec3(A, v):
    return [_dot3(A[i], v) for i in range(3)]


def _cross(a, b):
    return [
        _sub(_mul(a[1], b[2]), _mul(a[2], b[1])),
        _sub(_mul(a[2], b[0]), _mul(a[0], b[2])),
        _sub(_mul(a[0], b[1]), _mul(a[1], b[0])),
    ]


def _axis_rotation(axis, c: jax.Array, s: jax.Array):
    """Rodrigues: R = c I + s [a]x + (1 - c) a a^T, with constant unit axis a."""
    ax, ay, az = axis
    omc = 1.0 - c
    R = [[0.0] * 3 for _ in range(3)]
    skew = [[0.0, -az, ay], [az, 0.0, -ax], [-ay, ax, 0.0]]
    a = (ax, ay, az)
    for i in range(3):
        for j in range(3):
            term = _mul(skew[i][j], s)
            aa = a[i] * a[j]
            if i == j:
                # c + (1 - c) a_i^2 = a_i^2 + (1 - a_i^2) c
                term = _add(term, _add(aa, _mul(1.0 - aa, c)))
            else:
                term = _add(term, _mul(aa, omc))
            R[i][j] = term
    return R


# ---------------------------------------------------------------- the kernel
def _chain(robot: Robot, q: jax.Array, want_jacobian: bool):
    """Walk the chain. Returns (R_tcp 3x3, p_tcp 3, [(kind, z_i, p_i)]) as scalar entries."""
    R = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]
    p = [0.0, 0.0, 0.0]
    frames = []
    # sin/cos once for all joints, materialised: without the barrier XLA's loop fusion copies
    # the (costly, in float64) transcendental into every output entry that depends on it.
    cos_q, sin_q = jax.lax.optimization_barrier((jnp.cos(q), jnp.sin(q)))
    for i in range(robot.n):
        org = robot.origins[i]
        R0 = [list(org[r][:3]) for r in range(3)]
        p0 = [org[r][3] for r in range(3)]
        p = [_add(p[k], v) for k, v in enumerate(_matvec3(R, p0))]
        M = _matmul3(R, R0)  # world orientation of the joint frame before its motion
        axis = robot.axes[i]
        qi = q[..., i]
        if robot.joint_types[i] == JOINT_PRISMATIC:
            z = _matvec3(M, list(axis))
            p = [_add(p[k], _mul(z[k], qi)) for k in range(3)]
            R = M
            frames.append((JOINT_PRISMATIC, z, None))
        else:
            z = _matvec3(M, list(axis)) if want_jacobian else None
            frames.append((0, z, p))
            R = _matmul3(M, _axis_rotation(axis, cos_q[..., i], sin_q[..., i]))
    tip = robot.tip
    Rt = [list(tip[r][:3]) for r in range(3)]
    pt = [tip[r][3] for r in range(3)]
    p = [_add(p[k], v) for k, v in enumerate(_matvec3(R, pt))]
    R = _matmul3(R, Rt)
    return R, p, frames


def _full(x: Scalar, like: jax.Array) -> jax.Array:
    if _is_const(x):
        return jnp.full(like.shape[:-1], x, dtype=like.dtype)
    return x


def _pose(R, p, q) -> jax.Array:
    zero, one = _full(0.0, q), _full(1.0, q)
    rows = [[_full(R[i][j], q) for j in range(3)] + [_full(p[i], q)] for i in range(3)]
    rows.append([zero, zero, zero, one])
    return jnp.stack([jnp.stack(r, axis=-1) for r in rows], axis=-2)


def _jacobian_entries(p_tcp, frames):
    cols = []
    for kind, z, p_i in frames:
        if kind == JOINT_PRISMATIC:
            cols.append(list(z) + [0.0, 0.0, 0.0])
        else:
            r = [_sub(p_tcp[k], p_i[k]) for k in range(3)]
            cols.append(_cross(z, r) + list(z))
    return cols


def _jacobian_array(cols, q, rows=range(6)) -> jax.Array:
    return jnp.stack(
        [jnp.stack([_full(cols[j][r], q) for j in range(len(cols))], axis=-1) for r in rows], axis=-2
    )


def _check(robot: Robot, q) -> None:
    if not isinstance(robot, Robot):
        raise TypeError(f"expected a jaxstiff.Robot, got {type(robot).__name__}")
    if q.ndim == 0 or q.shape[-1] != robot.n:
        raise ValueError(f"q must have shape (..., {robot.n}) for robot {robot.name!r}, got {tuple(q.shape)}")
    if not jnp.issubdtype(q.dtype, jnp.floating):
        raise ValueError(f"q must have a floating dtype, got {q.dtype}")


@functools.partial(jax.jit, static_argnums=0)
def fk(robot: Robot, q: jax.Array) -> jax.Array:
    """Pose of the TCP in the base frame, ``T_base_tcp``.

    Args:
        robot: the chain (static: one compilation per robot and input shape).
        q: joint values (..., n), rad for revolute and m for prismatic joints, locked joints included.

    Returns:
        (..., 4, 4) homogeneous transforms, dtype of ``q``.
    """
    q = jnp.asarray(q)
    _check(robot, q)
    R, p, _ = _chain(robot, q, want_jacobian=False)
    return _pose(R, p, q)


@functools.partial(jax.jit, static_argnums=0)
def jacobian(robot: Robot, q: jax.Array) -> jax.Array:
    """Geometric Jacobian of the TCP point in the base frame (SPEC section 1).

    Args:
        robot: the chain.
        q: joint values (..., n).

    Returns:
        (..., 6, n), rows ``[vx, vy, vz, wx, wy, wz]``; ``v = J[:3] @ dq`` is the TCP velocity.
    """
    q = jnp.asarray(q)
    _check(robot, q)
    _, p, frames = _chain(robot, q, want_jacobian=True)
    return _jacobian_array(_jacobian_entries(p, frames), q)


@functools.partial(jax.jit, static_argnums=0)
def fk_and_jacobian(robot: Robot, q: jax.Array) -> tuple[jax.Array, jax.Array]:
    """``(fk(robot, q), jacobian(robot, q))`` from one walk of the chain."""
    q = jnp.asarray(q)
    _check(robot, q)
    R, p, frames = _chain(robot, q, want_jacobian=True)
    return _pose(R, p, q), _jacobian_array(_jacobian_entries(p, frames), q)


@functools.partial(jax.jit, static_argnums=(0, 2))
def position_and_jacobian(robot: Robot, q: jax.Array, rows: tuple[int, ...] = (0, 1, 2, 3, 4, 5)):
    """TCP position (..., 3) and the selected Jacobian rows (..., len(rows), n), in one pass.

    The cheapest call for the stiffness and shaping code, which needs only the position and the
    task rows (``rows=(0, 1)`` for ``xy``, ``(0, 1, 2)`` for ``xyz``).
    """
    q = jnp.asarray(q)
    _check(robot, q)
    _, p, frames = _chain(robot, q, want_jacobian=True)
    pos = jnp.stack([_full(v, q) for v in p], axis=-1)
    return pos, _jacobian_array(_jacobian_entries(p, frames), q, rows=rows)
