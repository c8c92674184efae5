"""Position inverse kinematics by damped least squares (start posture of a shaping run, SPEC section 5).

From a nominal posture, the free joints move by the damped least-squares step
``dq = J^T (J J^T + lambda^2 I)^-1 e`` (e = target - position, J the position rows of the
geometric Jacobian restricted to the free joints), clipped to the joint limits, with a step
length cap; locked joints stay at their values. Fixed iteration count (``lax.fori_loop``), so it
jit-compiles once per robot and never hangs. A final undamped Gauss-Newton phase makes the
position exact to round-off when the target is reachable.

Example:
    >>> import numpy as np, jaxstiff
    >>> from jaxstiff.ik import ik_position, nominal_posture
    >>> robot = jaxstiff.Robot.from_urdf("kuka_lwr4", locked={"lwr_a7": 0.0})
    >>> q, err = ik_position(robot, np.array([0.45, -0.25, 0.35]))
    >>> bool(err < 1e-6)  # float32 (JAX's default) ~3e-8 m, float64 ~1e-15 m
    True
"""

from __future__ import annotations

import functools

import jax
import jax.numpy as jnp
import numpy as np
from numpy.typing import ArrayLike

from jaxstiff.model._chain import check_locked_values
from jaxstiff.model._kinematics import position_and_jacobian
from jaxstiff.model._robot import JOINT_REVOLUTE, Robot
from jaxstiff.runtime._export_cache import DiskJit
from jaxstiff.runtime._programs import program_cache

__all__: list[str] = []

#: Nominal posture: every free joint at the middle of its range plus this offset (degrees),
#: clipped to the range. For the LWR (ranges symmetric about 0) that is 30 degrees on every
#: joint: elbow and wrist bent, away from the straight-up singular posture q = 0.
NOMINAL_OFFSET_DEG = 30.0


def nominal_posture(robot: Robot) -> np.ndarray:
    """A generic non-singular start posture (n,): mid-range + 30 deg per free revolute joint, mid-range
    for a prismatic one (30 deg is no length); locked joints at their values."""
    lo, hi = robot.lower, robot.upper
    finite = np.isfinite(lo) & np.isfinite(hi)  # continuous joints: (-inf, inf), mid-range 0
    mid = np.where(finite, 0.5 * (np.where(finite, lo, 0.0) + np.where(finite, hi, 0.0)), 0.0)
    revolute = np.asarray(robot.joint_types) == JOINT_REVOLUTE
    q = np.clip(mid + np.where(revolute, np.deg2rad(NOMINAL_OFFSET_DEG), 0.0), lo, hi)
    return np.where(robot.free, q, np.nan_to_num(robot.locked_values))


@program_cache(maxsize=64)
def ik_program(robot: Robot, iters: int, rows: tuple[int, ...]) -> DiskJit:
    """:func:`_ik` jitted for one robot, iteration count and rows (its traced program kept on disk:
    :class:`~jaxstiff.runtime._export_cache.DiskJit`)."""
    key = f"ik|{robot.fingerprint()}|{iters}|{rows}"
    return DiskJit(functools.partial(_ik, robot, iters=iters, rows=rows), key)


def _ik(
    robot: Robot, target: jax.Array, q_start: jax.Array, iters: int, rows: tuple[int, ...]
) -> tuple[jax.Array, jax.Array]:
    """The DLS/Gauss-Newton iteration: ``(q (n,), position error (m) over ``rows``)``; see :func:`ik_position`."""
    free = np.asarray(robot.free)
    lo = jnp.asarray(np.where(free, robot.lower, -np.inf), dtype=q_start.dtype)
    hi = jnp.asarray(np.where(free, robot.upper, np.inf), dtype=q_start.dtype)
    mask = jnp.asarray(free, dtype=q_start.dtype)
    rows_a = jnp.asarray(rows)
    k = len(rows)

    def step(i: jax.Array, q: jax.Array) -> jax.Array:
        p, J = position_and_jacobian(robot, q, rows)
        e = target[rows_a] - p[rows_a]
        J = J * mask[None, :]
        # damping: strong while far (DLS), vanishing in the last third (Gauss-Newton polish)
        lam2 = jnp.where(i < (2 * iters) // 3, 1e-4, 1e-14 * jnp.trace(J @ J.T))
        dq = J.T @ jnp.linalg.solve(J @ J.T + lam2 * jnp.eye(k, dtype=q.dtype), e)
        nrm = jnp.linalg.norm(dq)
        dq = dq * jnp.minimum(1.0, 0.2 / jnp.maximum(nrm, 1e-300))  # at most 0.2 rad per step
        return jnp.clip(q + dq, lo, hi)

    q = jax.lax.fori_loop(0, iters, step, q_start)
    p, _ = position_and_jacobian(robot, q, rows)
    err = jnp.linalg.norm(target[rows_a] - p[rows_a])
    return q, err


def ik_position(
    robot: Robot,
    target: ArrayLike,
    q_start: ArrayLike | None = None,
    iters: int = 150,
    planar: bool = False,
) -> tuple[np.ndarray, float]:
    """Joint values that put the TCP at ``target``, starting from ``q_start`` (default: nominal).

    Args:
        robot: the chain; locked joints stay at their locked values.
        target: (3,) m, base frame.
        q_start: (n,) start posture, locked joints at their locked values (another value is
            refused: :func:`jaxstiff.model._chain.check_locked_values`); default :func:`nominal_posture`.
        iters: iterations (fixed; the first two thirds damped, the rest Gauss-Newton).
        planar: match only x and y (task "xy": a planar chain cannot move along z).

    Returns:
        ``(q (n,), error)``: q within the joint limits; error = remaining position distance (m)
        over the matched rows. The caller decides what error is acceptable (unreachable targets
        return the closest posture found, not an exception).
    """
    tgt = np.asarray(target, dtype=float)
    if tgt.shape != (3,) or not np.all(np.isfinite(tgt)):
        raise ValueError(f"IK target must be 3 finite numbers (m), got {tgt!r}")
    q0 = nominal_posture(robot) if q_start is None else np.asarray(q_start, dtype=float)
    if q_start is not None:
        if q0.shape != (robot.n,) or not np.all(np.isfinite(q0)):
            raise ValueError(f"q_start must be {robot.n} finite numbers (rad; m for prismatic joints), got {q0!r}")
        check_locked_values(robot, q0, "q_start")
    dtype = jnp.float64 if jax.config.read("jax_enable_x64") else jnp.float32
    program = ik_program(robot, int(iters), (0, 1) if planar else (0, 1, 2))
    q, err = program(jnp.asarray(tgt, dtype), jnp.asarray(q0, dtype))
    return np.asarray(q, dtype=float), float(err)
