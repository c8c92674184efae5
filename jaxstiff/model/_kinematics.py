"""Forward kinematics and the geometric Jacobian (SPEC section 1), pure JAX, any leading batch axes.

The chain is unrolled at trace time. Every entry of every rotation and translation is carried as
its own array of the batch shape (structure of arrays), and the robot's constant geometry enters
as Python floats: multiplications by structural zeros and ones (axis-aligned joint axes, identity
origin rotations) are dropped while tracing, so XLA receives only the arithmetic the chain needs
and fuses it into a few elementwise loops over the batch. The caller's dtype is kept (float32
stays float32, float64 stays float64). For CPU batches the joint cosines and sines come from
:func:`jaxstiff._numerics.trig.cos_sin` (one shared range reduction and two polynomials, within
2 ulp of libm), which XLA vectorises and fuses (measurements: docs/notes/model.md).

A chain with rotated joint frames (a joint axis or an origin rotation that is not axis-aligned:
almost every real URDF) is walked unrolled in frames aligned with its joint axes, with the
constant rotations folded at trace time (:mod:`jaxstiff.model._kinematics_framed`); walked as
written, its dense constants made XLA's program minutes to compile. Long chains run as one
``lax.scan`` over their joints (:mod:`jaxstiff.model._kinematics_scan`): more than
``UNROLL_MAX_JOINTS`` (12) axis-aligned joints or ``FRAMED_MAX_JOINTS`` (8) other ones, where an
unrolled program compiles in time that grows far faster than the chain; the scan compiles in
about a second at any length. :func:`jaxstiff.model._kinematics_scan.kernel_for` makes the choice,
from the chain only (all three agree to rounding: tested to 1e-12; measurements:
docs/notes/model.md, ``scripts/bench_kinematics.py``, ``scripts/bench_long_chain.py``).

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
import warnings
from collections.abc import Sequence
from typing import cast

import jax
import jax.numpy as jnp
import numpy as np

from jaxstiff._numerics.batch import has_tracer, refuse_non_numeric
from jaxstiff._numerics.trig import POLY_MIN_BATCH, cos_sin, joint_cos_sin
from jaxstiff.model._chain import JOINT_PRISMATIC, Chain, check_locked_values
from jaxstiff.model._kinematics_framed import framed_chain
from jaxstiff.model._kinematics_scan import UNROLL_MAX_JOINTS, kernel_for, scan_pose, scan_pose_and_jacobian
from jaxstiff.model._scalars import Mat3, Scalar, Vec3
from jaxstiff.model._scalars import add as _add
from jaxstiff.model._scalars import cross as _cross
from jaxstiff.model._scalars import is_const as _is_const
from jaxstiff.model._scalars import matmul3 as _matmul3
from jaxstiff.model._scalars import matvec3 as _matvec3
from jaxstiff.model._scalars import mul as _mul
from jaxstiff.model._scalars import sub as _sub
from jaxstiff.runtime._dtypes import refuse_half_precision

__all__ = [
    "fk",
    "jacobian",
    "fk_and_jacobian",
    "position_and_jacobian",
    "jacobian_tangent",
    "cos_sin",
    "POLY_MIN_BATCH",
    "UNROLL_MAX_JOINTS",
]


# ---------------------------------------------------------------- the kernels
def _axis_rotation(axis: Sequence[float], c: jax.Array, s: jax.Array) -> list[list[Scalar]]:
    """Rodrigues: R = c I + s [a]x + (1 - c) a a^T, with constant unit axis a."""
    ax, ay, az = axis
    omc = 1.0 - c
    R: list[list[Scalar]] = [[0.0] * 3 for _ in range(3)]
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


def _chain(robot: Chain, q: jax.Array, want_jacobian: bool, poly: bool | None = None):
    """Walk the chain. Returns (R_tcp 3x3, p_tcp 3, [(kind, z_i, p_i)]) as scalar entries.

    ``poly``: take the joint cosines and sines from :func:`cos_sin` (True) or XLA (False); None
    decides from q's batch shape (:func:`jaxstiff._numerics.trig.joint_cos_sin`). A caller inside ``vmap`` sees one
    configuration, so it passes the batch it knows.
    """
    R = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]
    p = [0.0, 0.0, 0.0]
    frames = []
    cos_q, sin_q = joint_cos_sin(q, poly)
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


_KERNELS = (None, "unrolled", "framed", "scan")


def _pick(robot: Chain, kernel: str | None) -> str:
    """The kernel to trace: ``kernel`` if given (tests, benchmarks), else :func:`kernel_for`."""
    if kernel not in _KERNELS:
        raise ValueError(f"kernel must be None, 'unrolled', 'framed' or 'scan', got {kernel!r}")
    return kernel if kernel is not None else kernel_for(robot)


def _walk(robot: Chain, q: jax.Array, want_jacobian: bool, poly: bool | None, kernel: str):
    """The unrolled walk of ``kernel`` ("unrolled" or "framed"): (R, p) as scalar entries and a function
    that returns the Jacobian's columns (called after the caller's pose entries, so that the unrolled
    kernel traces its operations in the order it always had)."""
    if kernel == "framed":
        R, p, cols = framed_chain(robot, q, want_jacobian, poly)
        return R, p, lambda: cols
    R, p, frames = _chain(robot, q, want_jacobian, poly)
    return R, p, lambda: _jacobian_entries(p, frames)


def _full(x: Scalar, like: jax.Array) -> jax.Array:
    if _is_const(x):
        return jnp.full(like.shape[:-1], x, dtype=like.dtype)
    return jnp.asarray(x)


def _pose(R: Mat3, p: Vec3, q: jax.Array) -> jax.Array:
    zero, one = _full(0.0, q), _full(1.0, q)
    rows = [[_full(R[i][j], q) for j in range(3)] + [_full(p[i], q)] for i in range(3)]
    rows.append([zero, zero, zero, one])
    return jnp.stack([jnp.stack(r, axis=-1) for r in rows], axis=-2)


def _pose_array(R: jax.Array, p: jax.Array) -> jax.Array:
    """(..., 4, 4) from R (..., 3, 3) and p (..., 3) arrays (the scan kernel's output)."""
    top = jnp.concatenate([R, p[..., :, None]], axis=-1)
    last = jnp.broadcast_to(jnp.asarray([0.0, 0.0, 0.0, 1.0], dtype=R.dtype), R.shape[:-2] + (1, 4))
    return jnp.concatenate([top, last], axis=-2)


def _jacobian_entries(p_tcp: Vec3, frames: list) -> list[list[Scalar]]:
    cols = []
    for kind, z, p_i in frames:
        if kind == JOINT_PRISMATIC:
            cols.append(list(z) + [0.0, 0.0, 0.0])
        else:
            r = [_sub(p_tcp[k], p_i[k]) for k in range(3)]
            cols.append(_cross(z, r) + list(z))
    return cols


def _jacobian_array(cols: list[list[Scalar]], q: jax.Array, rows: Sequence[int] = range(6)) -> jax.Array:
    return jnp.stack([jnp.stack([_full(cols[j][r], q) for j in range(len(cols))], axis=-1) for r in rows], axis=-2)


def _check(robot: Chain, q: jax.Array) -> None:
    if not isinstance(robot, Chain):
        raise TypeError(f"expected a jaxstiff.Robot, got {type(robot).__name__}")
    if q.ndim == 0 or q.shape[-1] != robot.n:
        raise ValueError(f"q must have shape (..., {robot.n}) for robot {robot.name!r}, got {tuple(q.shape)}")
    if not jnp.issubdtype(q.dtype, jnp.floating):
        raise ValueError(f"q must have a floating dtype, got {q.dtype}")


_warned_float32 = False


def warn_if_float32(q: object) -> None:
    """Warn once per process when float64 joint values (numpy, lists) will be computed in float32
    because JAX's x64 mode is off: JAX then rounds every input to float32 silently (results to
    about 1e-7 relative). A float32 ``q`` given as such is the caller's choice and draws nothing;
    the kinematics keep the dtype they compute in (float32 in, float32 out)."""
    global _warned_float32
    if _warned_float32 or isinstance(q, jax.Array) or jax.dtypes.canonicalize_dtype(np.float64) == np.float64:
        return
    if has_tracer(q):  # a list holding a traced value (fk(robot, [a, 0, 0]) under jit or grad): JAX's dtype
        return
    dt = getattr(q, "dtype", None)
    if dt is None and isinstance(q, (list, tuple, float)):
        dt = np.asarray(q).dtype
    if dt is not None and np.dtype(dt) == np.float64:
        _warned_float32 = True
        warnings.warn(
            "jaxstiff kinematics: JAX's x64 mode is off, so these float64 joint values are computed in float32 "
            "(about 1e-7 relative; the results are float32). For float64, call "
            "jax.config.update('jax_enable_x64', True) at startup or set JAX_ENABLE_X64=1 "
            "(this warning is shown once)",
            UserWarning,
            stacklevel=3,
        )


def _refuse_non_numbers(name: str, robot: object, q: object) -> None:
    """``name(robot, q)`` with arguments JAX would meet with its own internal errors: a robot that is
    not one (the arguments swapped), or a ``q`` that is no array of real numbers (text, None, a
    ragged list: :func:`jaxstiff._numerics.batch.refuse_non_numeric`)."""
    if not isinstance(robot, Chain):
        swapped = " (the arguments swapped? the robot comes first)" if isinstance(q, Chain) else ""
        raise TypeError(f"{name}(robot, q): robot must be a jaxstiff.Robot, got {type(robot).__name__}{swapped}")
    expected = f"joint values, an array of numbers of shape (..., {robot.n}) (rad; m for prismatic joints)"
    refuse_non_numeric(f"{name}: q", q, expected, kinds="biuf")


def _locked_checked(fn):
    """A jitted kinematics function that first refuses a concrete ``q`` whose locked joints are not at
    their locked values (:func:`jaxstiff.model.chain.check_locked_values`; a tracer is not checked),
    and warns once if float64 values will be computed in float32 (:func:`warn_if_float32`)."""

    @functools.wraps(fn)
    def checked(robot: Chain, q: jax.Array, *args, **kwargs):
        _refuse_non_numbers(fn.__name__, robot, q)
        if isinstance(q, (list, tuple)) and not has_tracer(q):  # [0, 0, 0] too, as Robot.fk takes it
            q = cast(jax.Array, np.asarray(q, dtype=float))  # numpy: warn_if_float32 still sees float64
        # a list where a static tuple goes (position_and_jacobian's rows): jit cannot hash a list
        args = tuple(tuple(a) if isinstance(a, list) else a for a in args)
        kwargs = {k: tuple(v) if isinstance(v, list) else v for k, v in kwargs.items()}
        if isinstance(robot, Chain):  # anything else: the kernel's own check says what is wrong
            check_locked_values(robot, q)
        refuse_half_precision(fn.__name__, q=q)  # as shape and csc_rollout: ~1 mm off in FK
        warn_if_float32(q)
        return fn(robot, q, *args, **kwargs)

    for attr in ("lower", "trace", "eval_shape", "clear_cache", "_cache_size"):  # the jitted function's API
        if hasattr(fn, attr):
            setattr(checked, attr, getattr(fn, attr))
    return checked


@_locked_checked
@functools.partial(jax.jit, static_argnums=0)
def fk(robot: Chain, q: jax.Array) -> jax.Array:
    """Pose of the TCP in the base frame, ``T_base_tcp``.

    Args:
        robot: the chain (static: one compilation per robot and input shape).
        q: joint values (..., n), rad for revolute and m for prismatic joints, locked joints included.

    Returns:
        (..., 4, 4) homogeneous transforms, dtype of ``q``.

    Shapes and dtypes are checked; values are not (the function is jitted, and a value check
    would need them on the host): a NaN in ``q`` gives NaN, as in ``jnp.sin``. The exception: a
    concrete (not traced) ``q`` whose locked joints are not at their locked values is refused
    (ValueError, :func:`jaxstiff.model._chain.check_locked_values`), here and in
    :func:`jacobian`, :func:`fk_and_jacobian` and :func:`position_and_jacobian`. The method
    :meth:`jaxstiff.Robot.fk` (likewise ``jacobian``) also refuses non-finite concrete values.
    """
    q = jnp.asarray(q)
    _check(robot, q)
    kernel = kernel_for(robot)
    if kernel == "scan":
        return _pose_array(*scan_pose(robot, q))
    R, p, _ = _walk(robot, q, False, None, kernel)
    return _pose(R, p, q)


@_locked_checked
@functools.partial(jax.jit, static_argnums=0)
def jacobian(robot: Chain, q: jax.Array) -> jax.Array:
    """Geometric Jacobian of the TCP point in the base frame (SPEC section 1).

    Args:
        robot: the chain.
        q: joint values (..., n).

    Returns:
        (..., 6, n), rows ``[vx, vy, vz, wx, wy, wz]``; ``v = J[:3] @ dq`` is the TCP velocity.
    """
    q = jnp.asarray(q)
    _check(robot, q)
    kernel = kernel_for(robot)
    if kernel == "scan":
        return scan_pose_and_jacobian(robot, q)[2]
    _, _, columns = _walk(robot, q, True, None, kernel)
    return _jacobian_array(columns(), q)


@_locked_checked
@functools.partial(jax.jit, static_argnums=0)
def fk_and_jacobian(robot: Chain, q: jax.Array) -> tuple[jax.Array, jax.Array]:
    """``(fk(robot, q), jacobian(robot, q))`` from one walk of the chain."""
    q = jnp.asarray(q)
    _check(robot, q)
    return fk_and_jacobian_raw(robot, q)


def fk_and_jacobian_raw(
    robot: Chain, q: jax.Array, poly: bool | None = None, kernel: str | None = None
) -> tuple[jax.Array, jax.Array]:
    """:func:`fk_and_jacobian` without checks or jit (to trace inside a caller's kernel).

    ``kernel``: ``"unrolled"``, ``"framed"`` or ``"scan"`` forces one kernel (tests and benchmarks);
    None picks by the chain (:func:`jaxstiff.model._kinematics_scan.kernel_for`).
    """
    kernel = _pick(robot, kernel)
    if kernel == "scan":
        R, p, J = scan_pose_and_jacobian(robot, q, poly)
        return _pose_array(R, p), J
    R, p, columns = _walk(robot, q, True, poly, kernel)
    return _pose(R, p, q), _jacobian_array(columns(), q)


@_locked_checked
@functools.partial(jax.jit, static_argnums=(0, 2))
def position_and_jacobian(robot: Chain, q: jax.Array, rows: tuple[int, ...] = (0, 1, 2, 3, 4, 5)):
    """TCP position (..., 3) and the selected Jacobian rows (..., len(rows), n), in one pass.

    The cheapest call for the stiffness and shaping code, which needs only the position and the
    task rows (``rows=(0, 1)`` for ``xy``, ``(0, 1, 2)`` for ``xyz``).
    """
    q = jnp.asarray(q)
    _check(robot, q)
    if not isinstance(rows, tuple) or not rows or any(not isinstance(r, int) or not 0 <= r < 6 for r in rows):
        raise ValueError(f"rows must be a non-empty tuple of Jacobian row indices in 0..5, got {rows!r}")
    return position_and_jacobian_raw(robot, q, rows)


def position_and_jacobian_raw(
    robot: Chain,
    q: jax.Array,
    rows: Sequence[int] = (0, 1, 2, 3, 4, 5),
    poly: bool | None = None,
    kernel: str | None = None,
) -> tuple[jax.Array, jax.Array]:
    """:func:`position_and_jacobian` without checks or jit (to trace inside a caller's kernel).

    ``kernel``: as in :func:`fk_and_jacobian_raw` (None: by :func:`jaxstiff.model._kinematics_scan.kernel_for`)."""
    kernel = _pick(robot, kernel)
    if kernel == "scan":
        _, p, J = scan_pose_and_jacobian(robot, q, poly)
        return p, J[..., list(rows), :]
    _, p, columns = _walk(robot, q, True, poly, kernel)
    pos = jnp.stack([_full(v, q) for v in p], axis=-1)
    return pos, _jacobian_array(columns(), q, rows=rows)


# ------------------------------------------------------------------ derivatives from J alone
def cross_cols(a: jax.Array, b: jax.Array) -> jax.Array:
    """Cross product over axis -2 of (..., 3, k) arrays."""
    a0, a1, a2 = a[..., 0, :], a[..., 1, :], a[..., 2, :]
    b0, b1, b2 = b[..., 0, :], b[..., 1, :], b[..., 2, :]
    return jnp.stack([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0], axis=-2)


def jacobian_tangent(J6: jax.Array, qd: jax.Array):
    """Directional derivative of the TCP position and of J6 (6, n) along qd (n,), from J6 alone.

    With columns ``[v_i; w_i]`` (``w_i`` = 0 for prismatic joints), ``Om_i = sum_{k<i} qd_k w_k`` and
    ``V_i = sum_{k>=i} qd_k v_k``: ``dp = sum_k qd_k v_k``, ``dv_i = Om_i x v_i + w_i x V_i``,
    ``dw_i = Om_i x w_i``: the closed-form derivative of the geometric Jacobian of a serial chain
    (``d v_i/d q_k = w_k x v_i`` for k < i and ``w_i x v_k`` for k >= i; ``d w_i/d q_k = w_k x w_i``
    for k < i, else 0), O(n) cross products and no differentiation of the chain.
    Returns ``(dp (3,), dJ6 (6, n), omega (3,))``, omega the TCP's angular velocity; batches over
    leading axes.
    """
    v, w = J6[..., :3, :], J6[..., 3:, :]
    dJ6 = tangent_from_sums(J6, *tangent_sums(J6, qd))
    return jnp.sum(v * qd[..., None, :], axis=-1), dJ6, jnp.sum(w * qd[..., None, :], axis=-1)


def tangent_sums(J6: jax.Array, qd: jax.Array):
    """``Om_i = sum_{k<i} qd_k w_k`` and ``V_i = sum_{k>=i} qd_k v_k`` (each (..., 3, n)) of
    :func:`jacobian_tangent`; also used by the VJP of ``grad u`` in :mod:`jaxstiff.csc`."""
    v, w = J6[..., :3, :], J6[..., 3:, :]
    return running_sum(w * qd[..., None, :], exclusive=True), running_sum(v * qd[..., None, :], reverse=True)


def tangent_from_sums(J6: jax.Array, Om: jax.Array, V: jax.Array) -> jax.Array:
    """``dJ6 = [Om_i x v_i + w_i x V_i; Om_i x w_i]`` (..., 6, n) of :func:`jacobian_tangent`."""
    v, w = J6[..., :3, :], J6[..., 3:, :]
    return jnp.concatenate([cross_cols(Om, v) + cross_cols(w, V), cross_cols(Om, w)], axis=-2)


def running_sum(x: jax.Array, reverse: bool = False, exclusive: bool = False) -> jax.Array:
    """Running sum over the last axis: ``sum_{k<=i}`` (``sum_{k>=i}`` if ``reverse``; ``<``, ``>``
    if ``exclusive``).

    Unrolled over the columns for the short axes of a chain (n <= 32), so that XLA fuses it with
    its neighbours (``jnp.cumsum`` is a kernel of its own on the CPU: docs/notes/model.md); longer
    axes use ``jnp.cumsum``.
    """
    n = x.shape[-1]
    if n > 32:
        y = jnp.flip(jnp.cumsum(jnp.flip(x, -1), axis=-1), -1) if reverse else jnp.cumsum(x, axis=-1)
        return y - x if exclusive else y
    cols = [x[..., i] for i in range(n)]
    out: list = [None] * n
    acc = None
    for i in range(n - 1, -1, -1) if reverse else range(n):
        if exclusive:
            out[i] = jnp.zeros_like(cols[i]) if acc is None else acc
        acc = cols[i] if acc is None else acc + cols[i]
        if not exclusive:
            out[i] = acc
    return jnp.stack(out, axis=-1)
