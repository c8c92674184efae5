"""Start postures of sweep rows: the q0 families ``"ik"``, ``"nominal"``, ``"random"`` and given postures.

IK results are kept in :data:`Q0_CACHE` (keyed by plan hash, family, seed, path and planarity),
so the rows of one path share one IK solve per process.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable
from typing import Any

import numpy as np

from jaxstiff.sweep._plan import SweepPlan

__all__: list[str] = []

#: IK distance (m) above which a start posture counts as not reaching the first waypoint
IK_TOL_M = 1e-4
#: further IK starts tried before a start posture is given up as not reaching the waypoint
IK_RETRIES = 8
#: ``(plan_hash, family, q0_seed, path index, planar) -> (q0 (n,) rad, IK distance m)``; cleared
#: when it grows past 10000 entries (tests clear it to count IK calls)
Q0_CACHE: dict[tuple, tuple[np.ndarray, float]] = {}


def start_posture(plan: SweepPlan, row_id: int) -> np.ndarray:
    """The start posture q0 (n,) rad of a row, from its q0 family (see :mod:`jaxstiff.sweep._config`).

    ``"ik"``: damped least-squares IK from the nominal posture to the path's first waypoint
    (x, y only for task ``"xy"``); ``"nominal"``: the nominal posture; ``"random"``: IK from a
    posture drawn uniformly inside the joint limits (``[-pi, pi]`` for continuous joints) with
    ``numpy.random.default_rng([seed, q0_seed, path_index])``; a list: that posture.

    An IK that ends more than :data:`IK_TOL_M` from the waypoint is retried from up to
    :data:`IK_RETRIES` further postures drawn the same way (for ``"random"`` the same generator
    continues; for ``"ik"`` ``default_rng([seed, path_index, 1])``), and the closest result is
    kept; if none reaches it, a warning names the path. The remaining distance of every row is
    the table column ``q0_ik_error_m`` (NaN for ``"nominal"`` and given postures).
    """
    return start_posture_and_error(plan, row_id)[0]


def _retry_ik(
    robot: Any,
    target: np.ndarray,
    q: np.ndarray,
    err: float,
    draw: Callable[[np.random.Generator], np.ndarray],
    rng: np.random.Generator,
    planar: bool,
) -> tuple[np.ndarray, float]:
    """Up to :data:`IK_RETRIES` more IK solves from ``draw(rng)`` postures; the closest kept."""
    from jaxstiff.ik import ik_position

    for _ in range(IK_RETRIES):
        q2, e2 = ik_position(robot, target, q_start=draw(rng), planar=planar)
        if e2 < err or not math.isfinite(err):
            q, err = q2, e2
        if err <= IK_TOL_M:
            break
    return q, err


def start_posture_and_error(plan: SweepPlan, row_id: int) -> tuple[np.ndarray, float]:
    """``(q0, IK distance to the first waypoint in m, NaN without IK)`` of a row (:func:`start_posture`)."""
    from jaxstiff.ik import ik_position, nominal_posture

    st = plan.row_settings(row_id)
    traj = plan.row_trajectory(row_id)
    v = st["q0"]
    robot = plan.robot
    if isinstance(v, list):
        return np.asarray(v, dtype=float), math.nan
    if v == "nominal":
        return nominal_posture(robot), math.nan
    planar = st["task"] == "xy"
    key = (plan.plan_hash, v, st["q0_seed"] if v == "random" else None, traj.index, planar)
    if key in Q0_CACHE:
        q, err = Q0_CACHE[key]
        return q.copy(), err
    lo = np.where(np.isfinite(robot.lower), robot.lower, -np.pi)
    hi = np.where(np.isfinite(robot.upper), robot.upper, np.pi)

    def draw(rng: np.random.Generator) -> np.ndarray:
        return np.where(robot.free, rng.uniform(lo, hi), np.nan_to_num(robot.locked_values))

    rng = np.random.default_rng([plan.seed, int(st["q0_seed"]), traj.index]) if v == "random" else None
    q, err = ik_position(robot, traj.points[0], q_start=None if rng is None else draw(rng), planar=planar)
    if not err <= IK_TOL_M:
        rng = rng if rng is not None else np.random.default_rng([plan.seed, traj.index, 1])
        q, err = _retry_ik(robot, traj.points[0], q, err, draw, rng, planar)
        if not err <= IK_TOL_M:
            warnings.warn(
                f"sweep: no start posture found for path {traj.name!r} (q0 = {v!r}"
                + (f", q0_seed = {st['q0_seed']}" if v == "random" else "")
                + f"): the IK ends {err:.3g} m from its first waypoint after {1 + IK_RETRIES} tries; its rows start "
                f"there (table column q0_ik_error_m). Is the waypoint within reach?",
                stacklevel=3,
            )
    if len(Q0_CACHE) > 10000:
        Q0_CACHE.clear()
    Q0_CACHE[key] = (q, err)
    return q.copy(), err
