"""Joint <-> Cartesian stiffness mappings (SPEC section 2), batched over leading axes.

Joint stiffness is diagonal, ``K_j = diag(kj)`` with ``kj > 0`` (uni-articular actuators, S0-3).
The Cartesian stiffness is the inverse of the Cartesian compliance
``C = J_s K_j^-1 J_s^T = sum_i J_i J_i^T / kj_i`` (S0-4), ``J_s`` the task rows of the geometric
Jacobian (base frame, rows ``[v; w]``):

* ``"xy"``   rows (vx, vy): a planar chain, 2x2 (seed 000, Fig. 2-3).
* ``"xyz"``  rows (vx, vy, vz): ``K_C = C_TT^-1``, 3x3. Physically: the stiffness met by a pure
  force at the TCP (no moment) when the tool is free to turn; the tool rotates as the joint
  springs dictate.
* ``"full"`` all six rows, ``K_C`` 6x6 (N/m, N/rad, Nm/m, Nm/rad blocks). Its top-left 3x3 block
  ``K_TT`` (S0-6, S0-7, the seed's own choice) is the translational stiffness used for the
  ellipsoid. Physically: the force needed for a pure translation of the TCP while its
  orientation is held fixed (by a rigid contact or clamp). Since
  ``K_TT = (C_TT - C_TR C_RR^-1 C_RT)^-1`` (a Schur complement), ``K_TT >= C_TT^-1``: held
  orientation is always at least as stiff as free orientation, and equal only when translation
  and rotation compliance are uncoupled.

Regularisation. Near a singular ``J_s`` the compliance loses rank and ``K_C`` would be infinite
along the lost direction. The compliance is damped by ``delta I`` with
``delta = eps * trace(C) / m + sqrt(tiny)`` (``eps`` = 1e-12 in float64, 1e-6 in float32;
``tiny`` the dtype's smallest normal number): a relative change of ``eps``, far below every physical
number, that keeps every value and gradient finite; at an exact singularity the stiffness along the
lost direction is ``~1 / delta`` (about 1e12 times the others in float64). Because ``delta`` is
relative, scaling every kj by k still scales ``K_C`` by exactly k (CMS). :func:`compliance_condition`
reports the condition number of the damped compliance: above ~``0.1 / eps`` the posture is
singular for the task.

Speed. Inverses are closed forms on the matrix entries (2x2 and 3x3 adjugates; the 6x6 ``"full"``
case by blocks, a Schur complement with 3x3 closed forms), which fuse into one elementwise loop
over a batch; they agree with ``numpy.linalg.inv`` to ~1e-13 relative at non-singular postures
(tested), and are several times faster than a batched Cholesky on a CPU
(``scripts/bench_pipeline.py``).

Example:
    >>> import jax.numpy as jnp, jaxstiff
    >>> robot = jaxstiff.Robot.from_urdf("planar_3r")
    >>> J = robot.jacobian(jnp.array([1.309, -1.304, -1.332]))
    >>> jaxstiff.translational_stiffness(J, jnp.array([500.0, 300.0, 100.0]), task="xy").shape
    (2, 2)
"""

from __future__ import annotations

from typing import Any

import jax
import jax.numpy as jnp

__all__ = [
    "TASK_ROWS",
    "task_rows",
    "compliance",
    "compliance_condition",
    "cartesian_stiffness",
    "translational_stiffness",
    "joint_stiffness",
    "cms_factor",
    "cms_scale",
]

TASK_ROWS: dict[str, tuple[int, ...]] = {"xy": (0, 1), "xyz": (0, 1, 2), "full": (0, 1, 2, 3, 4, 5)}


def task_rows(task: str) -> tuple[int, ...]:
    """Jacobian rows of a task name; raises ValueError for an unknown task."""
    try:
        return TASK_ROWS[task]
    except (KeyError, TypeError):
        raise ValueError(f"unknown task {task!r}; choose one of {', '.join(TASK_ROWS)}") from None


def _reg_eps(dtype) -> float:
    return 1e-12 if jnp.finfo(dtype).bits >= 64 else 1e-6


def _select(J: jax.Array, task: str) -> jax.Array:
    rows = task_rows(task)
    J = jnp.asarray(J)
    if not jnp.issubdtype(J.dtype, jnp.floating):
        raise ValueError(f"J must have a floating dtype, got {J.dtype}")
    if J.ndim < 2:
        raise ValueError(f"J must have shape (..., 6, n) or (..., {len(rows)}, n), got {tuple(J.shape)}")
    if J.shape[-2] == len(rows):  # already the task rows
        return J
    if J.shape[-2] != 6:
        raise ValueError(f"J must have 6 rows (or the {len(rows)} rows of task {task!r}), got shape {tuple(J.shape)}")
    if rows == (0, 1, 2):
        return J[..., :3, :]
    return J[..., list(rows), :]


def _joint_stiffness_array(kj, J: jax.Array) -> jax.Array:
    kj = jnp.asarray(kj, dtype=J.dtype)
    if kj.ndim < 1 or kj.shape[-1] != J.shape[-1]:
        raise ValueError(f"kj must have shape (..., {J.shape[-1]}) to match J {tuple(J.shape)}, got {tuple(kj.shape)}")
    # kj > 0 is required; a clamp keeps a zero/negative kj from producing Inf/NaN inside a batch.
    return jnp.maximum(kj, jnp.sqrt(jnp.finfo(J.dtype).tiny))


def compliance(J: jax.Array, kj: jax.Array, task: str = "full") -> jax.Array:
    """Cartesian compliance ``C = J_s diag(1/kj) J_s^T`` (..., m, m), unregularised (S0-4).

    Args:
        J: geometric Jacobian (..., 6, n), or its task rows (..., m, n).
        kj: joint stiffnesses (..., n), Nm/rad (N/m for prismatic joints), > 0; broadcast with J.
        task: ``"xy"``, ``"xyz"`` or ``"full"``.

    Returns:
        (..., m, m) symmetric positive semi-definite, m/N in the translational block.
    """
    Js = _select(J, task)
    kj = _joint_stiffness_array(kj, Js)
    Jw = Js / kj[..., None, :]
    return jnp.sum(Jw[..., :, None, :] * Js[..., None, :, :], axis=-1)


# ---------------------------------------------------------------- closed forms on entries
# A symmetric matrix is handled as a dict {(i, j): entry (...,)} over i <= j.
Sym = dict


def _entries(C: jax.Array) -> Sym:
    m = C.shape[-1]
    return {(i, j): C[..., i, j] for i in range(m) for j in range(i, m)}


def _g(S: Sym, i: int, j: int):
    return S[(i, j)] if i <= j else S[(j, i)]


def _to_array(S: Sym, m: int) -> jax.Array:
    return jnp.stack([jnp.stack([_g(S, i, j) for j in range(m)], axis=-1) for i in range(m)], axis=-2)


def _damp(S: Sym, m: int) -> Sym:
    tr = sum(S[(i, i)] for i in range(m))
    dtype = tr.dtype
    delta = _reg_eps(dtype) * tr / m + jnp.sqrt(jnp.finfo(dtype).tiny)
    out = dict(S)
    for i in range(m):
        out[(i, i)] = S[(i, i)] + delta
    return out


def _inv2(S: Sym) -> Sym:
    a, b, d = S[(0, 0)], S[(0, 1)], S[(1, 1)]
    r = 1.0 / (a * d - b * b)
    return {(0, 0): d * r, (0, 1): -b * r, (1, 1): a * r}


def _inv3(S: Sym, off: int = 0) -> Sym:
    """Inverse of the symmetric 3x3 block starting at (off, off), by the adjugate."""
    a, b, c = S[(off, off)], S[(off, off + 1)], S[(off, off + 2)]
    d, e, f = S[(off + 1, off + 1)], S[(off + 1, off + 2)], S[(off + 2, off + 2)]
    A00 = d * f - e * e
    A01 = c * e - b * f
    A02 = b * e - c * d
    A11 = a * f - c * c
    A12 = b * c - a * e
    A22 = a * d - b * b
    r = 1.0 / (a * A00 + b * A01 + c * A02)
    return {(0, 0): A00 * r, (0, 1): A01 * r, (0, 2): A02 * r, (1, 1): A11 * r, (1, 2): A12 * r, (2, 2): A22 * r}


def _schur_blocks(S6: Sym):
    """For the 6x6 compliance: ``R = C_RR^-1`` (sym), ``X = C_TR R`` (3x3 list) and ``K_TT = S^-1``."""
    R = _inv3(S6, off=3)
    CTR = [[S6[(i, 3 + k)] for k in range(3)] for i in range(3)]
    X = [[sum(CTR[i][k] * _g(R, k, j) for k in range(3)) for j in range(3)] for i in range(3)]
    Schur = {(i, j): S6[(i, j)] - sum(X[i][k] * CTR[j][k] for k in range(3)) for i in range(3) for j in range(i, 3)}
    return R, X, _inv3(Schur)


def _inverse_sym(S: Sym, m: int) -> Sym:
    if m == 2:
        return _inv2(S)
    if m == 3:
        return _inv3(S)
    if m == 6:
        R, X, KTT = _schur_blocks(S)
        out = dict(KTT)
        # K_TR = -K_TT X ;  K_RR = R + X^T K_TT X
        KX = [[sum(_g(KTT, i, k) * X[k][j] for k in range(3)) for j in range(3)] for i in range(3)]
        for i in range(3):
            for j in range(3):
                out[(i, 3 + j)] = -KX[i][j]
        for i in range(3):
            for j in range(i, 3):
                out[(3 + i, 3 + j)] = _g(R, i, j) + sum(X[k][i] * KX[k][j] for k in range(3))
        return out
    raise ValueError(f"no closed-form inverse for {m}x{m}")


def _damped_compliance(J: jax.Array, kj: jax.Array, task: str) -> tuple[Sym, int]:
    """Entries of the damped compliance, computed straight from the rows of ``J_s``.

    Working on row slices (not on slices of a stacked ``C``) keeps reverse-mode cheap: the
    transpose of a slice of a stacked array is a pad of the whole array, once per entry.
    """
    Js = _select(J, task)
    kj = _joint_stiffness_array(kj, Js)
    m = Js.shape[-2]
    rows = [Js[..., a, :] for a in range(m)]
    wrows = [row / kj for row in rows]
    S = {(a, b): jnp.sum(wrows[a] * rows[b], axis=-1) for a in range(m) for b in range(a, m)}
    return _damp(S, m), m


def compliance_condition(J: jax.Array, kj: jax.Array, task: str = "full") -> jax.Array:
    """Condition number of the regularised compliance (...,): large means near-singular.

    A value above ``0.1 / eps`` (1e11 in float64, 1e5 in float32) means the posture is singular
    for the task: the Cartesian stiffness along the lost direction is then set by the
    regularisation, not by the robot. Not differentiated (it is a diagnostic).
    """
    S, m = _damped_compliance(J, kj, task)
    C = jax.lax.stop_gradient(_to_array(S, m))
    if m in (2, 3):
        from .ellipsoid import _eigh_desc_primal

        w, _ = _eigh_desc_primal(C)
        w = w[..., ::-1]
    else:
        w = jnp.linalg.eigvalsh(C)
    return w[..., -1] / jnp.maximum(w[..., 0], jnp.finfo(C.dtype).tiny)


def cartesian_stiffness(J: jax.Array, kj: jax.Array, task: str = "full") -> jax.Array:
    """Cartesian stiffness ``K_C = (J_s K_j^-1 J_s^T)^-1`` (..., m, m), m = 2, 3 or 6 (S0-4).

    Args:
        J: geometric Jacobian (..., 6, n) in the base frame, or its task rows (..., m, n).
        kj: joint stiffnesses (..., n), Nm/rad (N/m for prismatic joints), > 0.
        task: ``"xy"`` (2x2), ``"xyz"`` (3x3) or ``"full"`` (6x6); see the module docstring.

    Returns:
        (..., m, m) symmetric positive definite, dtype of J. Units: N/m in the translational
        block, Nm/rad in the rotational block, N/rad and Nm/m off-diagonal. Regularised near
        singular postures (module docstring).
    """
    S, m = _damped_compliance(J, kj, task)
    return _to_array(_inverse_sym(S, m), m)


def translational_stiffness(J: jax.Array, kj: jax.Array, task: str = "full") -> jax.Array:
    """Translational stiffness ``K_T`` whose ellipsoid is shaped (SPEC section 2), N/m.

    ``"xy"`` -> (..., 2, 2) and ``"xyz"`` -> (..., 3, 3): ``K_C`` itself (tool free to turn).
    ``"full"`` -> (..., 3, 3): the top-left block ``K_TT`` of the 6x6 ``K_C`` (S0-6, S0-7; tool
    orientation held), computed directly as the inverse of the Schur complement
    ``C_TT - C_TR C_RR^-1 C_RT`` without forming the rest of ``K_C``.

    Args:
        J: geometric Jacobian (..., 6, n), or its task rows.
        kj: joint stiffnesses (..., n), > 0.
        task: ``"xy"``, ``"xyz"`` or ``"full"``.
    """
    S, m = _damped_compliance(J, kj, task)
    if m == 6:
        _, _, KTT = _schur_blocks(S)
        return _to_array(KTT, 3)
    return _to_array(_inverse_sym(S, m), m)


def joint_stiffness(
    J: jax.Array,
    K_x: jax.Array,
    F: jax.Array | None = None,
    *,
    robot: Any = None,
    q: jax.Array | None = None,
    task: str = "full",
) -> jax.Array:
    """Joint-space stiffness by congruence, ``K_q = J_s^T K_x J_s`` (S1-8, S0-3), plus the CCT term.

    With an external wrench ``F`` at the TCP (S1-7b, S0-2) the conservative congruence
    transformation adds the geometric term ``K_G[:, i] = d(J_s(q)^T F)/dq_i`` (SPEC section 2;
    sign convention ``tau = J^T F``, F the wrench applied to the TCP), computed by forward-mode
    JAX autodiff of ``J_s(q)^T F``; that needs ``robot`` and ``q``. At ``F = 0`` it is S1-8.

    Args:
        J: Jacobian (..., 6, n) or its task rows (..., m, n), base frame.
        K_x: Cartesian stiffness (..., m, m).
        F: wrench (..., m) in the task rows' order (force first, then moment for ``"full"``),
            N and Nm, base frame.
        robot: the :class:`jaxstiff.Robot` that gave ``J`` (needed with ``F``).
        q: joint values (..., n) that gave ``J`` (needed with ``F``), rad.
        task: rows of ``J``/``K_x``/``F``.

    Returns:
        (..., n, n) in Nm/rad; symmetric for ``F = None``; with ``F``, ``K_G`` may be non-symmetric.
    """
    Js = _select(J, task)
    K_x = jnp.asarray(K_x, dtype=Js.dtype)
    m = Js.shape[-2]
    if K_x.shape[-2:] != (m, m):
        raise ValueError(f"K_x must have shape (..., {m}, {m}) for task {task!r}, got {tuple(K_x.shape)}")
    Kq = jnp.einsum("...ai,...ab,...bj->...ij", Js, K_x, Js)
    if F is None:
        return Kq
    if robot is None or q is None:
        raise ValueError("joint_stiffness with a wrench F needs robot= and q= for the geometric (CCT) term")
    from .kinematics import jacobian

    rows = list(task_rows(task))
    q = jnp.asarray(q, dtype=Js.dtype)
    F = jnp.asarray(F, dtype=Js.dtype)
    n = q.shape[-1]
    if F.shape[-1:] != (m,):
        raise ValueError(f"F must have shape (..., {m}) for task {task!r}, got {tuple(F.shape)}")

    def tau(qq, FF):
        return jacobian(robot, qq)[rows, :].T @ FF

    batch = jnp.broadcast_shapes(q.shape[:-1], F.shape[:-1])
    qf = jnp.broadcast_to(q, batch + (n,)).reshape((-1, n))
    Ff = jnp.broadcast_to(F, batch + (m,)).reshape((-1, m))
    KG = jax.vmap(jax.jacfwd(tau))(qf, Ff).reshape(batch + (n, n))
    return Kq + KG


def _check_positive(name: str, value) -> None:
    if isinstance(value, (int, float)) and not value > 0:
        raise ValueError(f"{name} must be > 0, got {value}")


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
    """
    from .ellipsoid import _check_square, eigh_descending

    if (target_volume is None) == (target_major is None):
        raise ValueError("give exactly one of target_volume= or target_major=")
    K = _check_square(K)
    m = K.shape[-1]
    w = eigh_descending(K)[0]
    if target_major is not None:
        _check_positive("target_major", target_major)
        return jnp.asarray(target_major, K.dtype) / w[..., 0]
    _check_positive("target_volume", target_volume)
    return (jnp.asarray(target_volume, K.dtype) / jnp.prod(w, axis=-1)) ** (1.0 / m)


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
