"""The Frobenius objective ``f(q) = |K_xd - K_C(q)|_F`` of CSC and its gradient (this project's own).

Seed 001 descends the off-diagonal norm ``u(q)`` (S1-19) and argues (its Proposition 2) that a
small ``u`` means a small discrepancy ``|K_xd - K_C|_F`` (S1-10). SPEC section 6 lets the null
space aim at the discrepancy itself: ``K_C(q) = (J_s diag(1/kj) J_s^T)^-1`` with the realised
diagonal joint stiffness ``kj(q) = clip(diag(J_s^T K_xd J_s), kmin, kmax)`` (uni-articular
springs, :mod:`jaxstiff.csc._measures`), the measure the rollout reports.

Gradient: ``df/dJ_s`` (m, n) by reverse-mode autodiff of ``f`` as a function of the task rows
``J_s`` (through the clip, ``diag(J^T K J)`` and :func:`~jaxstiff.csc._measures.realised_stiffness`
with its hand-written VJP), then ``df/dq_k = <df/dJ, dJ/dq_k>`` by the closed-form derivative
of the geometric Jacobian (:func:`~jaxstiff.csc._offdiag.jacobian_contraction`, as ``u``'s).
Both are plain JAX, so a rollout's own gradient differentiates them once more (tested against
central differences). Where the clip binds, ``kj`` does not depend on ``q`` (its derivative is 0,
as the realised spring is then at the actuator's limit). Units: ``f`` as ``K_xd`` (N/m), its
gradient N/m per rad.
"""

from __future__ import annotations

import functools
from typing import TypeAlias

import jax
import jax.numpy as jnp

from jaxstiff._numerics.linalg import mm
from jaxstiff.csc._measures import realised_stiffness
from jaxstiff.csc._offdiag import jacobian_contraction, on_jacobians
from jaxstiff.model._robot import Robot
from jaxstiff.settings._csc import TASK_BY_SIZE, CSCSettings
from jaxstiff.stiffness._core import TASK_ROWS

__all__ = ["frobenius_of_jacobian"]

ArrayLike: TypeAlias = jax.typing.ArrayLike
_DEFAULTS = CSCSettings()


def frobenius_of_jacobian(J: jax.Array, K_xd: jax.Array, kmin: ArrayLike, kmax: ArrayLike, task: str) -> jax.Array:
    """``|K_xd - K_C|_F`` () of one posture from its task rows ``J`` (m, n), ``K_xd`` (m, m) N/m and
    the actuator range ``[kmin, kmax]`` Nm/rad (the value the rollout reports as ``frobenius``)."""
    kj = jnp.clip(jnp.sum(J * mm(K_xd, J), axis=-2), kmin, kmax)  # diag(J^T K J), realised
    return realised_stiffness(J, kj, K_xd, task)[1]


def frobenius_value_and_grad(
    J6: jax.Array, K_xd: jax.Array, kmin: ArrayLike, kmax: ArrayLike, task: str
) -> tuple[jax.Array, jax.Array]:
    """``(f, grad f)`` of one posture from its full geometric Jacobian J6 (6, n) (module docstring).

    Args:
        J6: (6, n) geometric Jacobian at q (rows v then w, base frame; rigid locked joints' columns zeroed).
        K_xd: (m, m) desired Cartesian stiffness, N/m. kmin, kmax: actuator range, Nm/rad.
        task: the task rows (static).

    Returns:
        ``f`` () N/m and ``grad f`` (n,) N/m per rad (0 for a zeroed column's joint).
    """
    m = len(TASK_ROWS[task])
    f, pull = jax.vjp(lambda J: frobenius_of_jacobian(J, K_xd, kmin, kmax, task), J6[..., :m, :])
    (G,) = pull(jnp.ones_like(f))
    G6 = jnp.concatenate([G, jnp.zeros_like(J6[..., m:, :])], axis=-2)
    return f, jacobian_contraction(J6, G6)[0]


def frobenius_gradient(
    robot: Robot,
    q: jax.typing.ArrayLike,
    K_xd: jax.typing.ArrayLike,
    task: str | None = None,
    *,
    kmin: float = _DEFAULTS.kmin,
    kmax: float = _DEFAULTS.kmax,
    locked_joints: str = _DEFAULTS.locked_joints,
) -> tuple[jax.Array, jax.Array]:
    """``(f(q), grad f(q))`` of ``|K_xd - K_C(q)|_F`` at postures q (..., n), K_xd (..., m, m).

    The rollout's routine (:func:`frobenius_value_and_grad`) on the robot's Jacobian; with
    ``locked_joints="rigid"`` (default) locked joints have no spring and their gradient entry is 0.
    Jitted per robot, task and locked-joint mode.

    Returns:
        ``f (...,)`` N/m and ``grad f (..., n)`` N/m per rad.
    """
    q = jnp.asarray(q)
    K_xd = jnp.asarray(K_xd, dtype=q.dtype)
    kk = jnp.asarray(kmin, dtype=q.dtype), jnp.asarray(kmax, dtype=q.dtype)
    return _frobenius_gradient(robot, task or TASK_BY_SIZE[K_xd.shape[-1]], locked_joints, q, K_xd, *kk)


@functools.partial(jax.jit, static_argnums=(0, 1, 2))
def _frobenius_gradient(
    robot: Robot, task: str, locked_joints: str, q: jax.Array, K_xd: jax.Array, kmin: jax.Array, kmax: jax.Array
) -> tuple[jax.Array, jax.Array]:
    return on_jacobians(robot, q, K_xd, lambda J, K: frobenius_value_and_grad(J, K, kmin, kmax, task), locked_joints)
