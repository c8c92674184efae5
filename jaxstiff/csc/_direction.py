"""Single-posture CSC tools: the projected CSC direction at a posture, and a Newton projection of
postures onto a TCP target (differentiable, for parametrising start postures)."""

from __future__ import annotations

import functools
from typing import TypeAlias

import jax
import jax.numpy as jnp

from jaxstiff.csc._algebra import mv
from jaxstiff.csc._frobenius import frobenius_value_and_grad
from jaxstiff.csc._offdiag import offdiag_value_and_grad, on_jacobians
from jaxstiff.csc._projections import damped_pinv
from jaxstiff.model._kinematics import position_and_jacobian
from jaxstiff.model._robot import Robot
from jaxstiff.settings._csc import OBJECTIVES, TASK_BY_SIZE, CSCSettings
from jaxstiff.stiffness._core import TASK_ROWS

__all__: list[str] = []

ArrayLike: TypeAlias = jax.typing.ArrayLike
_DEFAULTS = CSCSettings()  # the damping rule's defaults (nu0, damping), as csc_rollout's


def null_space_direction(
    robot: Robot,
    q: ArrayLike,
    K_xd: ArrayLike,
    *,
    task: str | None = None,
    nu0: ArrayLike = _DEFAULTS.nu0,
    damping: ArrayLike = _DEFAULTS.damping,
    objective: str = _DEFAULTS.objective,
    locked_joints: str = _DEFAULTS.locked_joints,
    kmin: ArrayLike = _DEFAULTS.kmin,
    kmax: ArrayLike = _DEFAULTS.kmax,
) -> tuple[jax.Array, jax.Array, jax.Array]:
    """The projected CSC gradient ``dq_N = (I - J+ J) grad f(q)`` (S1-14, S1-15, S1-20) at q.

    Args:
        robot: the chain.
        q: (..., n) posture, rad.
        K_xd: (..., m, m) desired Cartesian stiffness.
        task: task rows; default from K_xd's size.
        nu0, damping: the damping rule of :func:`csc_rollout`.
        objective: ``f``: ``"offdiag"`` (u, S1-19) or ``"frobenius"`` (``|K_xd - K_C|_F``, with the
            actuator range ``kmin``, ``kmax`` of the realised joint stiffness), as :func:`csc_rollout`.
        locked_joints: ``"rigid"`` (no spring: out of the stiffness) or ``"spring"``, as :func:`csc_rollout`.

    Returns:
        ``(dq_N (..., n), f (...,), J (..., m, n))``; ``-dq_N`` lowers f to first order and moves the
        TCP only at second order (exactly so where the damping is off). Locked joints' entries are 0.
    """
    if objective not in OBJECTIVES:
        raise ValueError(f"objective must be 'offdiag' or 'frobenius', got {objective!r}")
    q = jnp.asarray(q)
    K_xd = jnp.asarray(K_xd, dtype=q.dtype)
    task = task or TASK_BY_SIZE[K_xd.shape[-1]]
    return _null_space_direction(robot, task, objective, locked_joints, q, K_xd, nu0, damping, kmin, kmax)


@functools.partial(jax.jit, static_argnums=(0, 1, 2, 3))
def _null_space_direction(
    robot: Robot,
    task: str,
    objective: str,
    locked_joints: str,
    q: jax.Array,
    K_xd: jax.Array,
    nu0: ArrayLike,
    damping: ArrayLike,
    kmin: ArrayLike,
    kmax: ArrayLike,
) -> tuple:
    rows = TASK_ROWS[task]
    free = jnp.asarray(robot.free, dtype=q.dtype)

    def one(J6: jax.Array, K: jax.Array) -> tuple:
        if objective == "frobenius":
            f, g = frobenius_value_and_grad(J6, K, kmin, kmax, task)
        else:
            f, g = offdiag_value_and_grad(J6, K, rows)
        J = J6[..., : len(rows), :]
        Jf = J * free
        Jp, _, _ = damped_pinv(Jf, nu0, damping)
        gf = g * free
        return gf - mv(Jp, mv(Jf, gf)), f, J

    return on_jacobians(robot, q, K_xd, one, locked_joints)


def project_to_target(
    robot: Robot,
    q: ArrayLike,
    target: ArrayLike,
    *,
    task: str = "xy",
    iters: int = 6,
    nu0: ArrayLike = _DEFAULTS.nu0,
    damping: ArrayLike = _DEFAULTS.damping,
) -> jax.Array:
    """Newton projection of postures onto ``x(q) = target``: ``q <- q + J+ (target - x(q))``, ``iters`` times.

    Differentiable (a fixed number of steps), so a start posture can be parametrised on its
    self-motion manifold, ``q0(theta) = project_to_target(robot, q_ref + N theta, x_0)``, and tuned
    by gradient descent (``experiments/csc_tune.py``). Locked joints stay put; the damped
    pseudo-inverse of :func:`csc_rollout` is used, so singular postures stay finite.

    Args:
        robot: the chain.
        q: (..., n) postures, rad.
        target: (..., d) TCP targets, m (d = 2 for ``"xy"``, else 3; task ``"full"`` matches the
            position only).
        task: ``"xy"`` or ``"xyz"`` (``"full"`` is treated as ``"xyz"``).
        iters: Newton steps (static).

    Returns:
        (..., n) postures; quadratic convergence from a nearby posture.
    """
    q = jnp.asarray(q)
    target = jnp.asarray(target, dtype=q.dtype)
    task = "xyz" if task == "full" else task
    if task not in ("xy", "xyz"):
        raise ValueError(f"task must be 'xy' or 'xyz', got {task!r}")
    return _project(robot, task, int(iters), q, target, nu0, damping)


@functools.partial(jax.jit, static_argnums=(0, 1, 2))
def _project(
    robot: Robot, task: str, iters: int, q: jax.Array, target: jax.Array, nu0: ArrayLike, damping: ArrayLike
) -> jax.Array:
    d = len(TASK_ROWS[task])
    free = jnp.asarray(robot.free, dtype=q.dtype)

    def one(qq: jax.Array, x: jax.Array) -> jax.Array:
        for _ in range(iters):
            p, J = position_and_jacobian(robot, qq, TASK_ROWS[task])
            Jp, _, _ = damped_pinv(J * free, nu0, damping)
            qq = qq + mv(Jp, x - p[:d])
        return qq

    batch = jnp.broadcast_shapes(q.shape[:-1], target.shape[:-1])
    qb = jnp.broadcast_to(q, batch + q.shape[-1:]).reshape((-1, q.shape[-1]))
    xb = jnp.broadcast_to(target, batch + target.shape[-1:]).reshape((-1, target.shape[-1]))
    return jax.vmap(one)(qb, xb).reshape(batch + q.shape[-1:])
