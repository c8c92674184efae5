"""The off-diagonal norm ``u(q)`` (S1-19) and its gradient in closed form, with a hand-written VJP.

``u`` is :func:`jaxstiff.offdiag` of ``K_q = J^T K_xd J``; the CSC null-space step descends its
gradient (S1-20). :func:`offdiag_value_and_grad` is the rollout's routine (from the full
geometric Jacobian J6 (6, n) at q); :func:`offdiag_gradient` is its public, jitted, batched form.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from typing import Any

import jax
import jax.numpy as jnp

from jaxstiff._numerics.linalg import mm
from jaxstiff.model._kinematics import cross_cols, position_and_jacobian, running_sum, tangent_from_sums, tangent_sums
from jaxstiff.model._robot import Robot
from jaxstiff.settings._csc import LOCKED_JOINT_MODES, TASK_BY_SIZE
from jaxstiff.stiffness._core import TASK_ROWS
from jaxstiff.stiffness._criteria import offdiag_of

__all__ = ["offdiag_forward", "offdiag_vjp"]


def _offdiag_value_and_grad(J6: jax.Array, K_xd: jax.Array, rows: tuple[int, ...]) -> tuple[jax.Array, jax.Array]:
    """``u(q)`` (S1-19) and ``grad u(q)`` (n,) from the full geometric Jacobian J6 (6, n) at q.

    ``u`` is :func:`jaxstiff.offdiag`. Its derivative with respect to the task rows ``J_s``, for a
    symmetric ``K_xd``: with ``M`` = ``J_s^T K_xd J_s`` with its diagonal zeroed,
    ``u^2 = 1/2 |M|_F^2`` and ``G = du/dJ_s = K_xd J_s M / u`` (0 where u = 0). The chain rule
    through ``J(q)`` uses the closed-form derivative of the geometric Jacobian (columns
    ``[v_i; w_i]``, ``w_i`` the unit axis of a revolute joint, 0 for a prismatic one):

    .. code-block:: text

        d v_i / d q_k = w_k x v_i  (k < i),   w_i x v_k  (k >= i)
        d w_i / d q_k = w_k x w_i  (k < i),   0          (k >= i)

    which, contracted with G, gives in O(n) cross products

    .. code-block:: text

        du/dq_k = w_k . sum_{i>k} (v_i x Gv_i + w_i x Gw_i)  +  v_k . sum_{i<=k} (Gv_i x w_i).

    It equals ``jax.grad`` of ``offdiag(J_s(q), K_xd)`` through the kinematics (tested to 1e-15)
    and is much cheaper, also its own derivative (needed by the gradient of a rollout); it
    compiles to a much smaller program (measurements: docs/notes/csc.md).

    Reverse mode uses a hand-written VJP (:func:`offdiag_vjp`): with ``Gb`` the cotangent of
    G, the chain through the contraction above is ``Gb6 = dJ6[gb]`` (the directional derivative
    of J along the cotangent ``gb`` of g, :func:`jacobian_tangent`) plus a J6 cotangent built
    from the same prefix/suffix sums; the rest is the Hessian-vector product of u along ``Gb``
    (G is u's gradient), in closed form with m x n x n products (see the VJP's comments). It is
    installed as a custom JVP whose tangent map is the VJP's transpose (:func:`_offdiag_jvp`), so
    forward mode keeps working. Equal to autodiff of this function to round-off (tested).

    Args:
        J6: (..., 6, n) geometric Jacobian (rows v then w; base frame).
        K_xd: (..., m, m) symmetric desired Cartesian stiffness, N/m.
        rows: the task rows (``TASK_ROWS[task]``, static).

    Returns:
        ``u (...,)`` Nm/rad and ``grad u (..., n)`` Nm/rad^2.
    """
    u, g, _ = offdiag_forward(J6, K_xd, rows)
    return u, g


def offdiag_forward(J6: jax.Array, K_xd: jax.Array, rows: tuple[int, ...]) -> tuple[jax.Array, jax.Array, tuple]:
    """``(u, grad u, residuals)``: the forward formulas of :func:`offdiag_value_and_grad`, without
    its custom derivative rule (the autodiff reference of the tests; residuals for :func:`offdiag_vjp`)."""
    m = len(rows)
    J = J6[..., :m, :]
    KJ = mm(K_xd, J)  # (m, n)
    Kq = jnp.sum(J[..., :, :, None] * KJ[..., :, None, :], axis=-3)  # J^T K J (n, n)
    n = Kq.shape[-1]
    u = offdiag_of(Kq)  # offdiag(J, K_xd) from the same J^T K J
    M = Kq * (1.0 - jnp.eye(n, dtype=Kq.dtype))
    pos = u > 0
    inv_u = jnp.where(pos, 1.0 / jnp.where(pos, u, 1.0), 0.0)
    G = jnp.sum(KJ[..., :, :, None] * M[..., None, :, :], axis=-2) * inv_u[..., None, None]  # (m, n)
    G6 = jnp.concatenate([G, jnp.zeros_like(J6[..., m:, :])], axis=-2)
    g, prefix, suffix = jacobian_contraction(J6, G6)
    return u, g, (J6, K_xd, KJ, Kq, M, inv_u, G6, prefix, suffix)


def jacobian_contraction(J6: jax.Array, G6: jax.Array) -> tuple[jax.Array, jax.Array, jax.Array]:
    """``g_k = <G6, dJ6/dq_k>`` (n,) for a cotangent ``G6`` (6, n) of the geometric Jacobian J6 (6, n):
    the chain rule from ``df/dJ6`` to ``df/dq`` in O(n) cross products (the closed-form derivative of
    J6, :func:`offdiag_value_and_grad`). Also returns the prefix and suffix sums (3, n) it used.
    Exact where a column of J6 is zeroed (a rigid locked joint): that column's derivative is then 0."""
    Jv, Jw, Gv, Gw = J6[..., :3, :], J6[..., 3:, :], G6[..., :3, :], G6[..., 3:, :]
    a = cross_cols(Jv, Gv) + cross_cols(Jw, Gw)  # (3, n): term of joint i
    suffix = running_sum(a, reverse=True, exclusive=True)  # sum over i > k
    prefix = running_sum(cross_cols(Gv, Jw))  # sum over i <= k
    g = jnp.sum(Jw * suffix, axis=-2) + jnp.sum(Jv * prefix, axis=-2)
    return g, prefix, suffix


def offdiag_vjp(rows: tuple[int, ...], res: tuple, cts: tuple) -> tuple[jax.Array, jax.Array]:
    """VJP of ``(u, g)`` w.r.t. ``(J6, K_xd)`` (derivation: :func:`offdiag_value_and_grad`)."""
    J6, K, P, Kq, M, s, G6, prefix, suffix = res  # P = K J, M = offdiag(J^T K J), s = 1/u (0 at u = 0)
    ub, gb = cts
    m = len(rows)
    n = Kq.shape[-1]
    Gv, Gw = G6[..., :3, :], G6[..., 3:, :]
    # g = <G6, dJ6/dq_k>: bilinear in (J6, G6). Its cotangent reaches J6 through both factors of
    # the contraction (Om, V: jacobian_tangent's sums along gb) and G6 as T6 = dJ6[gb], the
    # directional derivative of J6 along gb (jacobian_tangent(J6, gb)[1]).
    Om, V = tangent_sums(J6, gb)  # sum over k < i of gb_k w_k, over k >= i of gb_k v_k
    T6 = tangent_from_sums(J6, Om, V)
    Jvb = cross_cols(Gv, Om) + gb[..., None, :] * prefix
    Jwb = cross_cols(V, Gv) + cross_cols(Gw, Om) + gb[..., None, :] * suffix
    # G = du/dJ, so the cotangent T of G gives the Hessian-vector product d<G, T>/d(J, K), plus
    # ub du/d(J, K). With W = P^T T (n, n), Wo its off-diagonal, c = ub - s <G, T>:
    #   J_b = s (K (T + c J) M + P (Wo + Wo^T))                  (K symmetric)
    #   K_b = s ((T + c J) M + J (Wo - c L)) J^T,  L the strict lower triangle of M
    # (the c J L term: u reads only the upper triangle of J^T K J, so autodiff's K_b is not
    # symmetric; its symmetric part, all that a symmetric K_xd sees, is the same). Every product
    # is m x n x n or smaller, with two levels of sums: fewer and lighter kernels than the chain
    # rule through K J, J^T K J and K J M (measured: docs/notes/csc.md).
    J = J6[..., :m, :]
    T = T6[..., :m, :]
    G = G6[..., :m, :]
    c = ub - s * jnp.sum(G * T, axis=(-2, -1))
    X = T + c[..., None, None] * J
    Y = jnp.sum(X[..., :, :, None] * M[..., None, :, :], axis=-2)  # (T + c J) M  (m, n)
    W = jnp.sum(P[..., :, :, None] * T[..., :, None, :], axis=-3)  # P^T T (n, n)
    Wo = W * (1.0 - jnp.eye(n, dtype=W.dtype))
    S = Wo + jnp.swapaxes(Wo, -1, -2)
    Jb = s[..., None, None] * (mm(K, Y) + jnp.sum(P[..., :, :, None] * S[..., None, :, :], axis=-2))
    lower = jnp.tril(jnp.ones((n, n), dtype=W.dtype), k=-1)
    Z = Y + jnp.sum(J[..., :, :, None] * (Wo - c[..., None, None] * lower * M)[..., None, :, :], axis=-2)
    Kb = s[..., None, None] * jnp.sum(Z[..., :, None, :] * J[..., None, :, :], axis=-1)
    J6b = jnp.concatenate([Jvb, Jwb], axis=-2)
    J6b = J6b + jnp.concatenate([Jb, jnp.zeros_like(J6[..., m:, :])], axis=-2)
    return J6b, Kb


def _offdiag_jvp(rows: tuple[int, ...], primals: tuple, tangents: tuple) -> tuple:
    """Forward mode through the transpose of the hand-written VJP (a linear map of the cotangents):
    JVP and VJP then agree exactly, forward mode (``jax.jvp``, ``jax.hessian``) keeps working, and
    reverse mode transposes that map back into the VJP's own arithmetic."""
    (J6, K), (dJ6, dK) = primals, tangents
    u, g, res = offdiag_forward(J6, K, rows)
    lin = jax.linear_transpose(lambda ub, gb: offdiag_vjp(rows, res, (ub, gb)), u, g)
    du, dg = lin((dJ6, dK))
    return (u, g), (du, dg)


offdiag_value_and_grad = jax.custom_jvp(_offdiag_value_and_grad, nondiff_argnums=(2,))
offdiag_value_and_grad.defjvp(_offdiag_jvp)


def offdiag_gradient(
    robot: Robot,
    q: jax.typing.ArrayLike,
    K_xd: jax.typing.ArrayLike,
    task: str | None = None,
    *,
    locked_joints: str = "rigid",
) -> tuple[jax.Array, jax.Array]:
    """``(u(q), grad u(q))`` of the off-diagonal norm (S1-19) at postures q (..., n), K_xd (..., m, m).

    Uses the rollout's own closed-form routine (:func:`offdiag_value_and_grad`); ``jax.grad`` of
    ``offdiag(J_s(q), K_xd)`` through the kinematics gives the same numbers, slower. Jitted per
    robot, task and locked-joint mode. ``locked_joints="rigid"`` (default, as
    :class:`~jaxstiff.settings.CSCSettings`): locked joints have no spring, so ``u`` runs over the
    free joints and a locked joint's gradient entry is 0; ``"spring"``: every joint counts.

    Returns:
        ``u (...,)`` in Nm/rad and ``grad u (..., n)`` in Nm/rad^2.
    """
    q = jnp.asarray(q)
    K_xd = jnp.asarray(K_xd, dtype=q.dtype)
    return _offdiag_gradient(robot, task or TASK_BY_SIZE[K_xd.shape[-1]], locked_joints, q, K_xd)


@functools.partial(jax.jit, static_argnums=(0, 1, 2))
def _offdiag_gradient(
    robot: Robot, task: str, locked_joints: str, q: jax.Array, K_xd: jax.Array
) -> tuple[jax.Array, jax.Array]:
    rows = TASK_ROWS[task]
    f = lambda J, K: offdiag_value_and_grad(J, K, rows)  # noqa: E731 (rows positional: a custom_jvp's nondiff arg)
    return on_jacobians(robot, q, K_xd, f, locked_joints)


def on_jacobians(robot: Robot, q: jax.Array, K_xd: jax.Array, fn: Callable[..., Any], locked_joints: str) -> Any:
    """``fn(J6, K_xd)`` of one posture mapped over the broadcast batch of q (..., n) and K_xd (..., m, m),
    J6 (6, n) the geometric Jacobian at q (rigid locked joints' columns zeroed when
    ``locked_joints == "rigid"``)."""
    if locked_joints not in LOCKED_JOINT_MODES:
        raise ValueError(f"locked_joints must be 'rigid' or 'spring', got {locked_joints!r}")
    _, J6 = position_and_jacobian(robot, q)
    if locked_joints == "rigid":
        J6 = J6 * jnp.asarray(robot.free, dtype=q.dtype)
    batch = jnp.broadcast_shapes(q.shape[:-1], K_xd.shape[:-2])
    J6 = jnp.broadcast_to(J6, batch + J6.shape[-2:])
    K_xd = jnp.broadcast_to(K_xd, batch + K_xd.shape[-2:])
    for _ in batch:
        fn = jax.vmap(fn)
    return fn(J6, K_xd)
