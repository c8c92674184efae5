"""Joint <-> Cartesian stiffness mappings (SPEC section 2), batched over leading axes.

Joint stiffness is diagonal, ``K_j = diag(kj)`` with ``kj > 0`` (uni-articular actuators).
The Cartesian stiffness is the inverse of the Cartesian compliance
``C = J_s K_j^-1 J_s^T = sum_i J_i J_i^T / kj_i`` (S0-4), ``J_s`` the task rows of the geometric
Jacobian:

* ``"xy"``   rows (vx, vy): a planar chain, 2x2 (seed 000, Fig. 2-3);
* ``"xyz"``  rows (vx, vy, vz): the stiffness met by a pure force when the tool may turn freely, 3x3;
* ``"full"`` all six rows; the translational stiffness is the top-left 3x3 block of the 6x6
  ``K_C`` (S0-6, S0-7): the stiffness met by a force when the tool's orientation is held by the
  same joint springs. This is the seed's own choice.

Near-singular ``J_s`` would make ``C`` singular and ``K_C`` infinite along the lost direction.
The compliance is regularised by a damping ``eps * trace(C) / m * I`` (``eps`` = 1e-12 in float64,
1e-6 in float32): far below every physical number (relative 1e-12) but enough to keep every value
and gradient finite. :func:`compliance_condition` reports how close a posture is to singular.

Example:
    >>> import jax.numpy as jnp, jaxstiff
    >>> robot = jaxstiff.Robot.from_urdf("planar_3r")
    >>> J = robot.jacobian(jnp.array([1.309, -1.304, -1.332]))
    >>> jaxstiff.translational_stiffness(J, jnp.array([500.0, 300.0, 100.0]), task="xy").shape
    (2, 2)
"""

from __future__ import annotations

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
]

TASK_ROWS: dict[str, tuple[int, ...]] = {"xy": (0, 1), "xyz": (0, 1, 2), "full": (0, 1, 2, 3, 4, 5)}


def task_rows(task: str) -> tuple[int, ...]:
    """Jacobian rows of a task name; raises ValueError for an unknown task."""
    try:
        return TASK_ROWS[task]
    except KeyError:
        raise ValueError(f"unknown task {task!r}; choose one of {', '.join(TASK_ROWS)}") from None


def _reg_eps(dtype) -> float:
    return 1e-12 if jnp.finfo(dtype).bits >= 64 else 1e-6


def _select(J: jax.Array, task: str) -> jax.Array:
    rows = task_rows(task)
    if J.shape[-2] == len(rows):  # already the task rows
        return J
    if J.shape[-2] != 6:
        raise ValueError(f"J must have 6 rows (or the {len(rows)} rows of task {task!r}), got shape {J.shape}")
    return J[..., list(rows), :]


def compliance(J: jax.Array, kj: jax.Array, task: str = "full") -> jax.Array:
    """Cartesian compliance ``C = J_s diag(1/kj) J_s^T`` (..., m, m), unregularised (S0-4).

    Args:
        J: geometric Jacobian (..., 6, n), or its task rows (..., m, n).
        kj: joint stiffnesses (..., n), Nm/rad (N/m for prismatic joints), > 0.
        task: ``"xy"``, ``"xyz"`` or ``"full"``.
    """
    Js = _select(J, task)
    kj = jnp.asarray(kj, dtype=Js.dtype)
    Jw = Js / kj[..., None, :]
    return jnp.einsum("...in,...jn->...ij", Jw, Js)


def _regularise(C: jax.Array) -> jax.Array:
    m = C.shape[-1]
    scale = jnp.trace(C, axis1=-2, axis2=-1) / m
    eps = _reg_eps(C.dtype)
    tiny = jnp.finfo(C.dtype).tiny
    return C + (eps * scale + tiny * 1e3)[..., None, None] * jnp.eye(m, dtype=C.dtype)


def compliance_condition(J: jax.Array, kj: jax.Array, task: str = "full") -> jax.Array:
    """Condition number of the regularised compliance (..., ): large means near-singular.

    A value above ``1e10`` (float64) means the posture is singular for the task: the Cartesian
    stiffness is then dominated by the regularisation along the lost direction.
    """
    w = jnp.linalg.eigvalsh(_regularise(compliance(J, kj, task)))
    return w[..., -1] / w[..., 0]


def cartesian_stiffness(J: jax.Array, kj: jax.Array, task: str = "full") -> jax.Array:
    """Cartesian stiffness ``K_C = (J_s K_j^-1 J_s^T)^-1`` (..., m, m), m = 2, 3 or 6 (S0-4).

    Units: N/m in the translational block, Nm/rad in the rotational block, mixed off-diagonal.
    """
    C = _regularise(compliance(J, kj, task))
    return _spd_inverse(C)


def translational_stiffness(J: jax.Array, kj: jax.Array, task: str = "full") -> jax.Array:
    """Translational stiffness ``K_T`` whose ellipsoid is shaped (SPEC section 2).

    ``"xy"`` -> (..., 2, 2) and ``"xyz"`` -> (..., 3, 3): ``K_C`` itself. ``"full"`` -> the top-left
    3x3 block of the 6x6 ``K_C`` (S0-6, S0-7). N/m.
    """
    K = cartesian_stiffness(J, kj, task)
    if task == "full":
        K = K[..., :3, :3]
    return 0.5 * (K + jnp.swapaxes(K, -1, -2))


def _spd_inverse(C: jax.Array) -> jax.Array:
    """Inverse of a (regularised) SPD matrix, closed form for 2x2 and 3x3."""
    m = C.shape[-1]
    if m == 2:
        a, b, d = C[..., 0, 0], C[..., 0, 1], C[..., 1, 1]
        det = a * d - b * b
        inv = jnp.stack([jnp.stack([d, -b], -1), jnp.stack([-b, a], -1)], -2)
        return inv / det[..., None, None]
    if m == 3:
        c = C
        A = c[..., 1, 1] * c[..., 2, 2] - c[..., 1, 2] * c[..., 2, 1]
        B = c[..., 0, 2] * c[..., 2, 1] - c[..., 0, 1] * c[..., 2, 2]
        Cc = c[..., 0, 1] * c[..., 1, 2] - c[..., 0, 2] * c[..., 1, 1]
        D = c[..., 0, 0] * c[..., 2, 2] - c[..., 0, 2] * c[..., 2, 0]
        E = c[..., 0, 2] * c[..., 1, 0] - c[..., 0, 0] * c[..., 1, 2]
        F = c[..., 0, 0] * c[..., 1, 1] - c[..., 0, 1] * c[..., 1, 0]
        det = c[..., 0, 0] * A + c[..., 0, 1] * (c[..., 1, 2] * c[..., 2, 0] - c[..., 1, 0] * c[..., 2, 2]) + c[..., 0, 2] * (c[..., 1, 0] * c[..., 2, 1] - c[..., 1, 1] * c[..., 2, 0])
        inv = jnp.stack(
            [jnp.stack([A, B, Cc], -1), jnp.stack([B, D, E], -1), jnp.stack([Cc, E, F], -1)], -2
        )
        return inv / det[..., None, None]
    L = jnp.linalg.cholesky(C)
    eye = jnp.broadcast_to(jnp.eye(m, dtype=C.dtype), C.shape)
    return jax.scipy.linalg.cho_solve((L, True), eye)


def joint_stiffness(J: jax.Array, K_x: jax.Array, F: jax.Array | None = None, *, robot=None, q=None, task: str = "full") -> jax.Array:
    """Joint-space stiffness by congruence, ``K_q = J_s^T K_x J_s`` (S1-8), plus CCT term under load.

    With an external wrench ``F`` at the TCP (S1-7b, S0-2), the conservative congruence
    transformation adds ``K_G[:, i] = d(J(q)^T F)/dq_i`` (sign convention: ``tau = J^T F``), computed
    by JAX autodiff of ``J(q)^T F``; that needs ``robot`` and ``q``. At ``F = 0`` it is S1-8.

    Args:
        J: Jacobian (..., 6, n) or its task rows (..., m, n).
        K_x: Cartesian stiffness (..., m, m).
        F: wrench (..., m) in the task rows' order (force first, then moment for ``"full"``).
        robot, q: the chain and joint values that gave ``J``, needed with ``F``.
        task: rows of ``J``/``K_x``/``F``.

    Returns:
        (..., n, n) symmetric for ``F = None``; with ``F``, ``K_G`` may be non-symmetric.
    """
    Js = _select(J, task)
    Kq = jnp.einsum("...mi,...mk,...kj->...ij", Js, K_x, Js)
    if F is None:
        return Kq
    if robot is None or q is None:
        raise ValueError("joint_stiffness with a wrench F needs robot= and q= for the geometric (CCT) term")
    from .kinematics import jacobian

    rows = list(task_rows(task))

    def tau(qq, FF):
        return jnp.swapaxes(jacobian(robot, qq)[..., rows, :], -1, -2) @ FF

    q = jnp.asarray(q)
    F = jnp.asarray(F, dtype=q.dtype)
    batch = q.shape[:-1]
    qf = q.reshape((-1, q.shape[-1]))
    Ff = jnp.broadcast_to(F, batch + F.shape[-1:]).reshape((-1, F.shape[-1]))
    KG = jax.vmap(jax.jacfwd(tau))(qf, Ff).reshape(batch + (q.shape[-1], q.shape[-1]))
    return Kq + KG


def cms_factor(K: jax.Array, target_volume: float | None = None, target_major: float | None = None) -> jax.Array:
    """Common-mode stiffness factor k (S0 section III) so that ``k K`` reaches a target size.

    Scaling every kj by k scales ``K_C`` by k: the ellipsoid keeps its shape and orientation.

    Args:
        K: translational stiffness (..., m, m), m = 2 or 3.
        target_volume: wanted product of the axes ``lambda1 * ... * lambda_m`` (N/m)^m
            (area ``lambda1 lambda2`` for m = 2).
        target_major: wanted major axis ``lambda1`` (N/m).

    Returns:
        k (...,) > 0.
    """
    if (target_volume is None) == (target_major is None):
        raise ValueError("give exactly one of target_volume= or target_major=")
    m = K.shape[-1]
    if target_major is not None:
        if not target_major > 0:
            raise ValueError(f"target_major must be > 0, got {target_major}")
        lam1 = jnp.linalg.eigvalsh(K)[..., -1]
        return target_major / lam1
    if not target_volume > 0:
        raise ValueError(f"target_volume must be > 0, got {target_volume}")
    det = jnp.linalg.det(K)
    return (target_volume / det) ** (1.0 / m)
