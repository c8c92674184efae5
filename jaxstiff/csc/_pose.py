"""The rollout's kinematics with closed-form JVPs, and the held-orientation error (task ``"full"``).

:func:`pos_jac` and :func:`pose_jac` are the chain kernel (:mod:`jaxstiff.model._kinematics`) with
a JVP built from the Jacobian alone, so differentiating a rollout never sweeps the chain kernel
backwards. Positions in m, rotations and Jacobians in the base frame.
"""

from __future__ import annotations

import functools

import jax
import jax.numpy as jnp

from jaxstiff.csc._algebra import vector_norm
from jaxstiff.model._kinematics import cross_cols, fk_and_jacobian_raw, jacobian_tangent, position_and_jacobian_raw
from jaxstiff.model._robot import Robot

__all__ = ["orientation_error"]


@functools.partial(jax.custom_jvp, nondiff_argnums=(0, 1))
def pos_jac(robot: Robot, poly: bool, q: jax.Array) -> tuple[jax.Array, jax.Array]:
    """``position_and_jacobian(robot, q)`` (all 6 rows) with a closed-form JVP.

    The JVP needs only the Jacobian itself (:func:`jacobian_tangent`), so reverse mode through a
    rollout never differentiates the kinematics kernel's internals: the backward pass of a step
    costs a few cross products instead of a reverse sweep through the chain.
    """
    return position_and_jacobian_raw(robot, q, poly=poly)


@pos_jac.defjvp
def _pos_jac_jvp(robot: Robot, poly: bool, primals: tuple, tangents: tuple) -> tuple:
    (q,), (qd,) = primals, tangents
    p, J6 = pos_jac(robot, poly, q)
    dp, dJ6, _ = jacobian_tangent(J6, qd)
    return (p, J6), (dp, dJ6)


@functools.partial(jax.custom_jvp, nondiff_argnums=(0, 1))
def pose_jac(robot: Robot, poly: bool, q: jax.Array) -> tuple[jax.Array, jax.Array, jax.Array]:
    """``(p (3,), R (3, 3), J6 (6, n))`` from ``fk_and_jacobian`` with a closed-form JVP."""
    T, J6 = fk_and_jacobian_raw(robot, q, poly=poly)
    return T[..., :3, 3], T[..., :3, :3], J6


@pose_jac.defjvp
def _pose_jac_jvp(robot: Robot, poly: bool, primals: tuple, tangents: tuple) -> tuple:
    (q,), (qd,) = primals, tangents
    p, R, J6 = pose_jac(robot, poly, q)
    dp, dJ6, om = jacobian_tangent(J6, qd)
    dR = cross_cols(jnp.broadcast_to(om[..., :, None], R.shape), R)  # omega x each column of R
    return (p, R, J6), (dp, dR, dJ6)


def orientation_error(R: jax.Array, Rd: jax.Array) -> jax.Array:
    """``1/2 sum_i r_i x r_d,i`` (base frame, rad for small errors): rotates R towards Rd."""
    return 0.5 * jnp.sum(jnp.cross(R, Rd, axisa=-2, axisb=-2, axisc=-1), axis=-2)


def orientation_angle(R: jax.Array, Rd: jax.Array) -> jax.Array:
    """Angle (rad, in [0, pi]) of the rotation from R to Rd. ``|orientation_error|`` is its sine
    and ``(tr(R^T Rd) - 1) / 2`` its cosine; atan2 of the two is accurate at every angle (arccos
    of the cosine alone loses half the digits near 0), with a finite gradient at 0."""
    return jnp.arctan2(vector_norm(orientation_error(R, Rd)), 0.5 * (jnp.sum(R * Rd, axis=(-2, -1)) - 1.0))
