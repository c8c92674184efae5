"""Task rows of the geometric Jacobian (SPEC section 2) and the check that a robot can control them.

A task names the Cartesian rows of ``J`` (base frame, rows ``[vx, vy, vz, wx, wy, wz]``) that the
stiffness is defined on: ``"xy"`` (vx, vy), ``"xyz"`` (vx, vy, vz), ``"full"`` (all six).
"""

from __future__ import annotations

import functools
from typing import TYPE_CHECKING

import jax
import jax.numpy as jnp
import numpy as np

if TYPE_CHECKING:
    from jaxstiff.model._chain import Chain

__all__: list[str] = []

TASK_ROWS: dict[str, tuple[int, ...]] = {"xy": (0, 1), "xyz": (0, 1, 2), "full": (0, 1, 2, 3, 4, 5)}


def task_rows(task: str) -> tuple[int, ...]:
    """Jacobian rows of a task name; raises ValueError for an unknown task."""
    try:
        return TASK_ROWS[task]
    except (KeyError, TypeError):
        raise ValueError(f"unknown task {task!r}; choose one of {', '.join(TASK_ROWS)}") from None


_ROW_NAMES = ("vx", "vy", "vz", "wx", "wy", "wz")


@functools.lru_cache(maxsize=64)
def _task_rank_report(robot: Chain, task: str, motion: bool = False, springs: str = "rigid") -> str | None:
    rows = task_rows(task)
    m = len(rows)
    # the stiffness K = (J diag(1/kj) J^T)^-1 sums over the joints with a spring: the free ones, and
    # the locked ones only with springs="spring"; the motion (a CSC rollout's primary task) has the
    # free joints only
    cols = robot.free if motion or springs == "rigid" else np.ones(robot.n, dtype=bool)
    k = int(cols.sum())
    lost = (
        "so the path cannot be followed along the missing {}"
        if motion
        else "so its stiffness along the missing {} is undefined"
    )
    if k < m:
        if motion:
            have = f"only {k} free joint(s) move the TCP"
        elif k < robot.n:
            have = f"only {k} joint(s) have a spring (the {robot.n - k} locked one(s) are rigid)"
        else:
            have = f"the robot has only {k} joint(s)"
        return (
            f"task {task!r} controls {m} Cartesian rows ({', '.join(_ROW_NAMES[r] for r in rows)}) but {have}, "
            + lost.format("rows")
        )
    # Structural rank: sample postures within the limits (continuous joints in [-pi, pi]); a task
    # whose Jacobian rows lose rank at every sample (a planar chain asked for z, an axis parallel
    # to another ...) is not a singular posture but a wrong task for this robot.
    J = _sampled_jacobians(robot)
    Js = J[:, list(rows), :][:, :, cols]
    s = np.linalg.svd(Js, compute_uv=False)
    if np.any(s[:, -1] > 1e-9 * np.maximum(s[:, 0], 1e-300)):
        return None
    dead = [_ROW_NAMES[r] for i, r in enumerate(rows) if np.all(np.abs(Js[:, i, :]) < 1e-12)]
    rank = int(np.max(np.sum(s > 1e-9 * s[:, :1], axis=1)))
    which = "free joints' " if motion or k < robot.n else ""
    why = (
        f"row(s) {', '.join(dead)} of its {which}Jacobian are zero at every posture (a planar chain?)"
        if dead
        else f"its {m} task rows have rank {rank} at every sampled posture"
    )
    return f"task {task!r} controls {m} Cartesian rows but {why}, " + lost.format("direction")


def _sampled_jacobians(robot: Chain) -> np.ndarray:
    """The geometric Jacobian (6, 6, n) at six postures drawn within the joint limits (continuous
    joints in one turn), locked joints at their values: the same six for every call."""
    from jaxstiff.model._host import position_jacobian

    rng = np.random.default_rng(0)
    lo, hi = robot.lower, robot.upper  # a joint's own range; one turn where it is open
    lo_ok, hi_ok = np.isfinite(lo), np.isfinite(hi)
    lo = np.where(lo_ok, lo, np.where(hi_ok, np.where(hi_ok, hi, 0.0) - 2 * np.pi, -np.pi))
    hi = np.where(hi_ok, hi, lo + 2 * np.pi)
    q = lo + (hi - lo) * rng.uniform(0.05, 0.95, size=(6, robot.n))
    q = np.where(robot.free, q, np.nan_to_num(robot.locked_values))
    return position_jacobian(robot, q)  # numpy: a JAX trace of the chain costs ~0.2 s per command


def check_planar_arm(robot: Chain) -> None:
    """Raise ValueError if the free joints of ``robot`` move its TCP along z at a sampled posture:
    shaping with task ``"xy"`` constrains the TCP's x and y only, so on such an arm z drifts off
    the path and every waypoint ends out of reach (its 3-D position error is what is checked)."""
    J = _sampled_jacobians(robot)[:, :3, :][:, :, robot.free]
    scale = float(np.max(np.abs(J[:, :2, :]), initial=0.0))
    vz = float(np.max(np.abs(J[:, 2, :]), initial=0.0))
    if vz > 1e-9 * max(scale, 1e-300):
        raise ValueError(
            f"task 'xy' is for planar arms, whose joints cannot move the TCP along z; {robot.name!r} can "
            f"(its Jacobian's vz row reaches {vz:.3g} m/rad at a sampled posture), so z would be left free "
            "and the waypoints' z not met: use task 'xyz' (position) or 'full'"
        )


def check_task_feasible(robot: Chain, task: str, *, motion: bool = False, locked_joints: str = "rigid") -> None:
    """Raise ValueError if ``robot`` cannot control the rows of ``task`` at any posture.

    Two causes: fewer joints than task rows (a 3-joint arm with ``"full"``), and task rows that
    lose rank at every posture (a planar chain with ``"xyz"``: its ``vz`` row is always zero).
    Either makes the Cartesian stiffness infinite along a lost direction everywhere, not just
    near a singular posture, so the result would only reflect the regularisation. Which joints
    count: those with a spring for the stiffness (the free joints; with
    ``locked_joints="spring"`` the locked ones too, SPEC section 1, so a 7-joint arm with two
    sprung locked joints has a defined 6-row stiffness), and the free joints only with
    ``motion=True`` (a CSC rollout, whose primary task the free joints follow). The check samples
    six postures within the joint limits once per call.
    """
    if locked_joints not in ("rigid", "spring"):
        raise ValueError(f"locked_joints must be 'rigid' or 'spring', got {locked_joints!r}")
    msg = _task_rank_report(robot, task, motion, locked_joints)
    if msg is not None:
        smaller = [t for t in ("xyz", "xy") if len(TASK_ROWS[t]) < len(TASK_ROWS[task])]
        ok = [t for t in smaller if _task_rank_report(robot, t, motion, locked_joints) is None]
        hint = (
            f"use task {ok[0]!r} ({'position only' if ok[0] == 'xyz' else 'the x and y rows only'})"
            if ok
            else "no smaller task fits either (task 'xy' needs at least 2 joints with a spring that move the "
            "TCP in the base xy plane)"
        )
        if not robot.free.all():
            hint += ", or unlock joints"
            if not motion and locked_joints == "rigid":
                hint += " (or keep their springs: locked_joints='spring', --locked-joints spring)"
        raise ValueError(f"{msg}; {hint}")


def select_task_rows(J: jax.Array, task: str) -> jax.Array:
    """The task rows (..., m, n) of a Jacobian (..., 6, n), or ``J`` itself if it has m rows already."""
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
