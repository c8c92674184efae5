"""The Python boundary of a CSC rollout: settings with their defaults, checks, and the flat batch.

:func:`rollout_settings` merges a :class:`~jaxstiff.settings.CSCSettings` with the keywords of
:func:`jaxstiff.csc_rollout` (a keyword left at None takes the settings' value; the settings'
defaults are the only defaults). :func:`prepare_rollout` checks every input (clear
``ValueError``s naming the argument; value checks only for concrete inputs) and flattens the
broadcast batch to one axis, without compiling anything.

``null_eps`` default: ``1e-9 * |K_xd|_F * 1 m^2`` (1e-5 in float32) plus a floor of ``tiny^(1/4)``
(1e-77 in float64: derivatives stay finite at K_xd = 0).
"""

from __future__ import annotations

import math
import warnings
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from jaxstiff._numerics.batch import broadcast_batch, has_tracer, refuse_non_numeric, shown_value
from jaxstiff._numerics.safe import safe_sqrt
from jaxstiff.csc._step import StaticSettings
from jaxstiff.model._chain import check_locked_values
from jaxstiff.model._reach import check_reach as refuse_unreachable
from jaxstiff.model._robot import Robot
from jaxstiff.runtime._dtypes import refuse_half_precision
from jaxstiff.settings._csc import (
    DEFAULT_JL_GAIN,
    JOINT_LIMIT_MODES,
    LOCKED_JOINT_MODES,
    OBJECTIVES,
    STEP_RULES,
    TASK_BY_SIZE,
    CSCSettings,
)
from jaxstiff.settings._shape import task_dim
from jaxstiff.stiffness._core import TASK_ROWS, check_task_feasible
from jaxstiff.stiffness._tasks import check_planar_arm

__all__ = [
    "rollout_settings",
    "validate_values",
    "warn_far_start",
    "path_points",
    "SCALAR_SETTINGS",
    "CSCWarning",
    "check_planar_task",
    "warn_settings",
    "check_kxd",
    "kmax_message",
    "refuse_non_numeric",
]


class CSCWarning(UserWarning):
    """A CSC rollout that runs, but whose settings cannot do what CSC is for (lower ``u``): the
    adaptive step on a path that stands still, or an arm with no null space for the task.
    Emitted once per :func:`jaxstiff.csc_rollout` (or :func:`~jaxstiff.csc.csc_rollout_segments`) call."""


#: the largest |K_xd| entry taken, N/m (u and the Frobenius error square the entries of K_xd and of
#: J^T K_xd J: far beyond any real stiffness, far below float64's overflow)
K_XD_MAX = 1e100
#: the same in float32 (a rollout computes in q0's dtype): its squares stay below float32's 3e38
K_XD_MAX_FLOAT32 = 1e15
#: N/m: K_xd's largest eigenvalue must reach this (a K_xd of a smaller scale, e.g. 0 or 1e-200 I,
#: asks for no stiffness at all, and u and its gradient underflow: every step status 8, CSC does
#: not move); zero along some axes is taken (positive semi-definite)
K_XD_MIN = 1e-6
#: an eigenvalue of K_xd above -this share of its largest is zero to within rounding, not negative
K_XD_MIN_RATIO = 1e-12


def kxd_limit(dtype: Any) -> float:
    """The largest |K_xd| entry taken for a rollout in ``dtype``: :data:`K_XD_MAX` (float64) or
    :data:`K_XD_MAX_FLOAT32`."""
    return K_XD_MAX if jnp.finfo(dtype).bits >= 64 else K_XD_MAX_FLOAT32


#: the numeric settings that reach the compiled rollout as (differentiable) scalars
SCALAR_SETTINGS = ("kmin", "kmax", "nu0", "damping", "jl_gain")


#: rad (m for prismatic joints): how far a start posture may lie outside a joint's limits (rounding)
Q0_LIMIT_SLACK = 1e-9


def joints_outside_limits(robot: Robot, q: np.ndarray) -> np.ndarray:
    """(n,) bool: the free joints with a value of ``q`` (..., n) outside their limits by more than
    :data:`Q0_LIMIT_SLACK` (the rule for a rollout's start posture)."""
    qn = np.asarray(q, float).reshape(-1, robot.n)
    lo, hi = robot.lower - Q0_LIMIT_SLACK, robot.upper + Q0_LIMIT_SLACK
    return robot.free & (np.any(qn < lo, axis=0) | np.any(qn > hi, axis=0))


def is_concrete(x: Any) -> bool:
    """Whether ``x`` is a value (not a tracer of a caller's jit or grad)."""
    return not isinstance(x, jax.core.Tracer)  # pyright: ignore[reportAttributeAccessIssue]


#: what each array argument of a rollout must be (the messages of
#: :func:`jaxstiff._numerics.batch.refuse_non_numeric`)
EXPECTED = {
    "path": "a jaxstiff Path or an array of numbers of shape (..., T, 2 or 3) (TCP targets, m)",
    "K_xd": "an array of numbers of shape (m, m) or (..., m, m), m = 2, 3 or 6 (desired stiffness, N/m)",
    "beta": "a number or an array of numbers (rad per step, or 1 for the adaptive step)",
}


def path_points(path: Any) -> Any:
    """The (..., T, 2 or 3) targets of a :class:`jaxstiff.Path` or an array."""
    pts = getattr(path, "points", path)
    refuse_non_numeric("path", pts, EXPECTED["path"])
    if isinstance(pts, (list, tuple)):
        pts = np.asarray(pts, dtype=float)
    if not hasattr(pts, "shape"):
        raise ValueError(f"path must be {EXPECTED['path']}, got {shown_value(path)}")
    return pts


def rollout_settings(settings: CSCSettings | None = None, **given: Any) -> dict[str, Any]:
    """The settings a rollout runs with: ``settings`` (default :class:`CSCSettings`'s defaults),
    overridden by every keyword in ``given`` that is not None; ``jl_gain`` None resolves to
    :data:`DEFAULT_JL_GAIN` with joint-limit avoidance on, else 0. Keyword values are not checked
    here (they may be traced arrays): :func:`prepare_rollout` checks them."""
    if settings is None:
        settings = CSCSettings()
    if not isinstance(settings, CSCSettings):
        raise ValueError(f"settings must be a jaxstiff.settings.CSCSettings, got {type(settings).__name__}")
    unknown = sorted(set(given) - set(CSCSettings.field_names()))
    if unknown:
        raise TypeError(f"csc_rollout() got an unexpected keyword argument {unknown[0]!r}")
    out = {name: getattr(settings, name) for name in CSCSettings.field_names()}
    out.update({k: v for k, v in given.items() if v is not None})
    if out["jl_gain"] is None:
        out["jl_gain"] = DEFAULT_JL_GAIN if out["joint_limits"] != "off" else 0.0
    return out


def _check_static(robot: Robot, s: dict[str, Any], chunk: Any) -> None:
    """The settings that select the program: robot, step rule, joint-limit mode, objective, locked
    joints, newton, chunk."""
    if not isinstance(robot, Robot):
        raise ValueError(f"robot must be a jaxstiff.Robot, got {type(robot).__name__}")
    if s["step"] not in STEP_RULES:
        raise ValueError(f"step must be 'adaptive' or 'constant', got {s['step']!r}")
    for name, allowed in (
        ("joint_limits", JOINT_LIMIT_MODES),
        ("objective", OBJECTIVES),
        ("locked_joints", LOCKED_JOINT_MODES),
    ):
        if s[name] not in allowed:
            raise ValueError(f"{name} must be {' or '.join(map(repr, allowed))}, got {s[name]!r}")
    newton = s["newton"]
    if not isinstance(newton, (int, np.integer)) or isinstance(newton, bool) or newton < 0:
        raise ValueError(f"newton must be an integer >= 0, got {newton!r}")
    if chunk is not None and (isinstance(chunk, bool) or not isinstance(chunk, (int, np.integer)) or chunk < 1):
        raise ValueError(f"chunk must be a positive integer (rollouts per vmap chunk) or None, got {chunk!r}")


def _start_posture(robot: Robot, q0: Any) -> jax.Array:
    """q0 as an array of the rollout's dtype: the caller's floating dtype of q0 (or JAX's default float)."""
    q0 = jnp.asarray(q0) if not isinstance(q0, (list, tuple)) else jnp.asarray(np.asarray(q0, dtype=float))
    dtype = q0.dtype if jnp.issubdtype(q0.dtype, jnp.floating) else jnp.asarray(1.0).dtype
    if jnp.finfo(dtype).bits < 32:
        raise ValueError(
            f"q0 has dtype {jnp.dtype(dtype).name}: the rollout computes in q0's dtype, and {jnp.dtype(dtype).name} "
            "overflows (u ~ 1e3 Nm/rad squared) and cannot hold a step; pass float32 or float64"
        )
    return q0.astype(dtype)


def _refuse_planar_path_for_3d_kxd(path: Any, K_xd: jax.Array, task: str | None) -> None:
    """A path of (x, y) points with a 3x3 or 6x6 K_xd and no task: the task follows K_xd's size, so
    say that the two disagree (the task check below would blame the robot's rows instead)."""
    pts = getattr(path, "points", path)
    if task is not None or np.ndim(pts) < 1 or np.shape(pts)[-1] != 2 or K_xd.ndim < 2:
        return
    m = K_xd.shape[-1]
    if m in TASK_BY_SIZE and m != 2:
        raise ValueError(
            f"K_xd is {m}x{m}, so the task is {TASK_BY_SIZE[m]!r}, but the path has 2 coordinates per point "
            "(x, y): give a 2x2 K_xd for task 'xy', or points with x, y, z"
        )


def _task_of(robot: Robot, K_xd: jax.Array, task: str | None) -> str:
    """The task rows, checked against K_xd's size and the robot (S1: m rows need m free joints)."""
    if K_xd.ndim < 2 or K_xd.shape[-1] != K_xd.shape[-2] or K_xd.shape[-1] not in TASK_BY_SIZE:
        raise ValueError(f"K_xd must have shape (..., m, m) with m = 2, 3 or 6, got {tuple(K_xd.shape)}")
    m = K_xd.shape[-1]
    if task is None:
        task = TASK_BY_SIZE[m]
    if task not in TASK_ROWS:
        raise ValueError(f"unknown task {task!r}; choose one of {', '.join(TASK_ROWS)}")
    if len(TASK_ROWS[task]) != m:
        raise ValueError(
            f"task {task!r} needs K_xd of shape (..., {len(TASK_ROWS[task])}, {len(TASK_ROWS[task])}), got {tuple(K_xd.shape)}"
        )
    # Fewer free joints than task rows, or free joints' rows that are dead at every posture: the
    # primary task could not be followed (the damped step would only approximate it). As many free
    # joints as rows is allowed: no redundancy, so the null-space step is zero and the rollout only
    # tracks. (A rigid locked joint has no spring, so the free joints carry the stiffness too; with
    # locked_joints="spring" the locked ones add their springs.)
    check_task_feasible(robot, task, motion=True)
    check_planar_task(robot, task)
    return task


def check_planar_task(robot: Robot, task: str) -> None:
    """Refuse task ``"xy"`` on an arm whose free joints move the TCP along z (the rule of
    :func:`jaxstiff.stiffness._tasks.check_planar_arm`, as ``shape`` applies it): the rollout would
    track x and y only and let z drift off the path while its tracking error (x, y) stays tiny."""
    if task != "xy":
        return
    try:
        check_planar_arm(robot)
    except ValueError as e:
        raise ValueError(
            f"{e}. For CSC: a 2x2 K_xd selects task 'xy', which tracks only the TCP's x and y, so z would drift "
            "off the path unreported; give a 3x3 K_xd (task 'xyz'; on the command line three --kxd values, "
            "e.g. --kxd 2000,1000,1000) or 6x6 (task 'full'), or use a planar arm"
        ) from None


def _standing_paths(targets: jax.Array) -> tuple[int, int]:
    """(paths that stand still, paths) of concrete targets (..., T, d); (0, 0) when traced or T < 2."""
    if not is_concrete(targets) or targets.shape[-2] < 2:
        return 0, 0
    t = np.asarray(targets, dtype=float).reshape((-1,) + targets.shape[-2:])
    still = np.max(np.abs(t - t[:, :1]), axis=(1, 2), initial=0.0) <= 1e-12
    return int(np.sum(still)), len(t)


def warn_settings(robot: Robot, task: str, step: str, targets: jax.Array) -> None:
    """One :class:`CSCWarning` per cause that leaves CSC unable to lower u: the adaptive step on a
    path that stands still (its null step is beta |dq_P| = 0), and no null space (as many free
    joints as task rows). Called once per call by :func:`prepare_rollout`."""
    standing, total = _standing_paths(targets)
    if step == "adaptive" and standing:
        which = "the path stands still" if total == 1 else f"{standing} of the {total} paths stand still"
        warnings.warn(
            f"step 'adaptive' on a held point ({which}): the adaptive null step is beta x |dq_P| (S1-22), zero "
            "while the target stands still, so the arm will not move to lower u; use step 'constant' "
            "(beta = rad per step, e.g. beta 2e-3; on the command line --step constant --beta 2e-3)",
            CSCWarning,
            stacklevel=3,
        )
    nfree, m = int(np.sum(robot.free)), len(TASK_ROWS[task])
    if nfree == m:
        warnings.warn(
            f"{robot.name!r} has {nfree} free joints for the {m} rows of task {task!r}: not redundant, so there is "
            "no null space and CSC cannot lower u (or |K_xd - K_C|_F) beyond what the path itself does (the null "
            "step is zero: status 'null-space gradient below null_eps'); use a smaller task, unlock joints, or a "
            "redundant arm",
            CSCWarning,
            stacklevel=3,
        )


#: m: a start posture whose TCP lies farther than this from the first target draws a CSCWarning
FAR_START_M = 0.01


def warn_far_start(robot: Robot, q0: Any, targets: Any) -> None:
    """A :class:`CSCWarning` where the start posture's TCP lies more than :data:`FAR_START_M` from the
    path's first target (concrete values only; d = 2: in the xy plane): the first step then pulls
    the arm onto the path in one jump (S1-20's position correction), which can throw joints by tens
    of degrees with every step's status 'ok'. Called once per call by :func:`prepare_rollout`."""
    if has_tracer((q0, targets)):
        return
    from jaxstiff.model._host import tcp_position

    q = np.asarray(q0, float)
    t0 = np.asarray(targets, float)[..., 0, :]
    d = t0.shape[-1]
    p = tcp_position(robot, q.reshape(-1, robot.n))[:, :d].reshape(q.shape[:-1] + (d,))
    try:
        gap = np.linalg.norm(np.broadcast_to(p, np.broadcast_shapes(p.shape, t0.shape)) - t0, axis=-1)
    except ValueError:  # batch axes that do not broadcast: prepare_rollout says so
        return
    worst = float(np.max(gap, initial=0.0))
    if worst > FAR_START_M:
        at = tuple(int(i) for i in np.unravel_index(int(np.argmax(gap)), gap.shape))
        where = "" if gap.size <= 1 else f" (rollout {at[0] if len(at) == 1 else at})"
        warnings.warn(
            f"the start posture's TCP lies {worst:.3g} m from the path's first target{where}: the first step pulls "
            "the arm onto the path in one jump, which can move joints by tens of degrees while every step's status "
            "says 'ok'; start on the path (jaxstiff.ik.ik_position(robot, first target), or the q of a shape "
            "result along the same path; on the command line --q0 ik)",
            CSCWarning,
            stacklevel=3,
        )


def _targets(path: Any, task: str, dtype: Any) -> jax.Array:
    """The path's (..., T, d) targets in the rollout's dtype (d = 2 for ``"xy"``, else 3)."""
    targets = jnp.asarray(path_points(path), dtype=dtype)
    if targets.ndim < 2 or targets.shape[-1] not in (2, 3) or targets.shape[-2] < 1:
        raise ValueError(f"path points must have shape (..., T, 2 or 3) with T >= 1, got {tuple(targets.shape)}")
    d = task_dim(task)
    if targets.shape[-1] < d:
        raise ValueError(f"task {task!r} needs 3-D path points (x, y, z), got shape {tuple(targets.shape)}")
    return targets[..., :d]


def _null_eps(null_eps: Any, K_xd: jax.Array, varying: bool, dtype: Any) -> jax.Array:
    """``null_eps`` as an array: the given scalar, or the default of the module docstring (per rollout)."""
    if null_eps is None:
        rel = 1e-9 if jnp.finfo(dtype).bits >= 64 else 1e-5
        knorm = safe_sqrt(jnp.sum(K_xd * K_xd, axis=(-2, -1)))  # finite gradient at K_xd = 0
        # floor tiny^(1/4) (1e-77 in float64): 1 / null_eps^2, which a tangent of the null step
        # carries, stays finite for K_xd = 0 (tiny itself made it inf, and inf * 0 = NaN)
        return rel * (knorm if not varying else jnp.max(knorm, axis=-1)) + jnp.finfo(dtype).tiny ** 0.25
    null_eps_a = jnp.asarray(null_eps, dtype=dtype)
    if null_eps_a.ndim != 0:
        raise ValueError(f"null_eps must be a scalar, got shape {tuple(null_eps_a.shape)}")
    return null_eps_a


def _hold_rotation(hold_orientation: Any, task: str, dtype: Any) -> jax.Array | None:
    """The held tool rotation (..., 3, 3) of task ``"full"``, checked (None: q0's, set per rollout)."""
    if hold_orientation is None:
        return None
    if task != "full":
        raise ValueError(
            f"hold_orientation is for task 'full' (the held tool orientation); task {task!r} has no orientation rows"
        )
    R_hold = jnp.asarray(hold_orientation, dtype=dtype)
    if R_hold.ndim < 2 or R_hold.shape[-2:] != (3, 3):
        raise ValueError(f"hold_orientation must be a rotation matrix of shape (..., 3, 3), got {tuple(R_hold.shape)}")
    if is_concrete(R_hold):
        Rn = np.asarray(R_hold, dtype=float)
        orth = np.max(np.abs(np.swapaxes(Rn, -1, -2) @ Rn - np.eye(3))) if np.all(np.isfinite(Rn)) else np.inf
        if not (orth < 1e-6 and np.all(np.linalg.det(Rn) > 0)):
            raise ValueError(
                f"hold_orientation must be a finite rotation matrix (R^T R = I, det R = +1), max |R^T R - I| = {orth:g}"
            )
    return R_hold


def _check_complex(path: Any, K_xd: Any, q0: Any, beta: Any) -> None:
    for name, v in (("K_xd", K_xd), ("q0", q0), ("path", getattr(path, "points", path)), ("beta", beta)):
        if not isinstance(v, (list, tuple)) and np.iscomplexobj(v):  # (a cast would drop the imaginary part)
            raise ValueError(f"{name} is complex ({v.dtype}): stiffnesses, postures and paths are real")


def prepare_rollout(
    robot: Robot,
    path: Any,
    K_xd: Any,
    q0: Any,
    beta: Any = None,
    *,
    settings: CSCSettings | None = None,
    remat: bool = True,
    chunk: int | None = 128,
    check_reach: bool = True,
    **given: Any,
) -> tuple[StaticSettings, int | None, tuple, tuple[int, ...]]:
    """Every check of :func:`jaxstiff.csc_rollout` and its inputs flattened to one batch axis:
    ``(static settings, chunk, arrays for rollout_batch, batch shape)``. No compilation: the
    command line calls it to report bad input before it announces the run. Arguments as
    :func:`jaxstiff.csc_rollout` (``given``: its inline keywords). Once the inputs are valid it
    emits the :class:`CSCWarning` s of :func:`warn_settings` (the segments of
    :func:`~jaxstiff.csc.csc_rollout_segments` ignore theirs: its own call warned once)."""
    kxd_varying, hold_orientation = given.pop("kxd_varying", None), given.pop("hold_orientation", None)
    if not isinstance(remat, (bool, np.bool_)):  # "no" would read as True
        raise TypeError(f"remat must be True or False, got {remat!r}")
    if isinstance(beta, (str, bytes)):
        raise TypeError(f"beta must be a number or an array (rad per step, or 1 for the adaptive step), got {beta!r}")
    s = rollout_settings(settings, **given)
    beta = s["beta"] if beta is None else beta
    _check_static(robot, s, chunk)
    path_points(path)  # (its own check of non-numbers)
    refuse_non_numeric("K_xd", K_xd, EXPECTED["K_xd"])
    refuse_non_numeric("q0", q0, f"an array of numbers of shape (..., {robot.n}) (joint positions, rad)")
    refuse_non_numeric("beta", beta, EXPECTED["beta"])
    _check_complex(path, K_xd, q0, beta)
    refuse_half_precision("csc_rollout", path=getattr(path, "points", path), K_xd=K_xd, q0=q0, beta=beta)
    q0 = _start_posture(robot, q0)
    dtype = q0.dtype
    if q0.ndim == 0 or q0.shape[-1] != robot.n:
        raise ValueError(f"q0 must have shape (..., {robot.n}) for robot {robot.name!r}, got {tuple(q0.shape)}")
    K_raw = None if has_tracer(K_xd) else np.asarray(K_xd, dtype=float)  # as given: before a float32 cast
    if K_raw is not None:  # the size limit before the cast (float32 would overflow 1e200 to inf)
        _refuse_huge_kxd(K_raw, dtype)
    K_xd = jnp.asarray(K_xd, dtype=dtype)
    _refuse_planar_path_for_3d_kxd(path, K_xd, s["task"])
    task = _task_of(robot, K_xd, s["task"])
    if K_raw is not None:  # on the values given: a cast to float32 makes 1e200 inf and 1e-200 zero
        _refuse_non_finite("K_xd", K_raw)
        check_kxd(K_raw, dtype)
    m = K_xd.shape[-1]
    targets = _targets(path, task, dtype)
    T = targets.shape[-2]
    if kxd_varying is None:
        kxd_varying = K_xd.ndim >= 3 and K_xd.shape[-3] == T
    if kxd_varying and (K_xd.ndim < 3 or K_xd.shape[-3] != T):
        raise ValueError(f"K_xd varying along the path must have shape (..., T={T}, {m}, {m}), got {tuple(K_xd.shape)}")
    k_batch = K_xd.shape[:-3] if kxd_varying else K_xd.shape[:-2]
    beta = jnp.asarray(beta, dtype=dtype)
    scalars = {}
    for name in SCALAR_SETTINGS:
        a = jnp.asarray(s[name], dtype=dtype)
        if a.ndim != 0:
            raise ValueError(f"{name} must be a scalar, got shape {tuple(a.shape)}")
        scalars[name] = a
    null_eps_a = _null_eps(s["null_eps"], K_xd, bool(kxd_varying), dtype)
    R_hold = _hold_rotation(hold_orientation, task, dtype)
    validate_values(robot, targets, K_xd, q0, beta, scalars, null_eps_a, check_reach)
    warn_settings(robot, task, s["step"], targets)
    warn_far_start(robot, q0, targets)
    K_xd = 0.5 * (K_xd + jnp.swapaxes(K_xd, -1, -2))  # exactly symmetric (validated to 1e-6)
    batches = [("q0", q0.shape[:-1]), ("beta", beta.shape), ("path", targets.shape[:-2]), ("K_xd", k_batch)]
    if R_hold is not None:
        batches.append(("hold_orientation", R_hold.shape[:-2]))
    batch = broadcast_batch(*batches)
    flat = _flatten(robot, batch, targets, K_xd, q0, beta, null_eps_a, R_hold, bool(kxd_varying))
    st = StaticSettings(
        task=task,
        step=s["step"],
        newton=int(s["newton"]),
        joint_limits=s["joint_limits"],
        remat=bool(remat),
        varying=bool(kxd_varying),
        objective=s["objective"],
        locked_joints=s["locked_joints"],
    )
    tb, kb, qb, bb, eb, rb = flat
    args = (
        tb,
        kb,
        qb,
        bb,
        scalars["kmin"],
        scalars["kmax"],
        scalars["nu0"],
        scalars["damping"],
        eb,
        scalars["jl_gain"],
        rb,
    )
    return st, chunk, args, batch


def _flatten(
    robot: Robot,
    batch: tuple[int, ...],
    targets: jax.Array,
    K_xd: jax.Array,
    q0: jax.Array,
    beta: jax.Array,
    null_eps: jax.Array,
    R_hold: jax.Array | None,
    varying: bool,
) -> tuple:
    """The per-rollout inputs broadcast to ``batch`` and flattened to one axis B."""
    B = math.prod(batch)
    k_tail = K_xd.shape[-3:] if varying else K_xd.shape[-2:]
    tb = jnp.broadcast_to(targets, batch + targets.shape[-2:]).reshape((B,) + targets.shape[-2:])
    kb = jnp.broadcast_to(K_xd, batch + k_tail).reshape((B,) + k_tail)
    qb = jnp.broadcast_to(q0, batch + (robot.n,)).reshape((B, robot.n))
    bb = jnp.broadcast_to(beta, batch).reshape((B,))
    eb = jnp.broadcast_to(null_eps, batch).reshape((B,)) if null_eps.ndim else jnp.broadcast_to(null_eps, (B,))
    rb = None if R_hold is None else jnp.broadcast_to(R_hold, batch + (3, 3)).reshape((B, 3, 3))
    return tb, kb, qb, bb, eb, rb


def _refuse_huge_kxd(K: np.ndarray, dtype: Any = np.float64) -> None:
    """K_xd's entries (finite) not so large that u squares them into inf in ``dtype``
    (:func:`kxd_limit`); checked before anything that could overflow (eigenvalues, a cast)."""
    limit = kxd_limit(dtype)
    finite = np.abs(K[np.isfinite(K)])  # (NaN and Inf: refused by name once K_xd's shape is checked)
    if finite.size and np.max(finite) > limit:
        where = (
            "float64 beyond about 1e154"
            if limit == K_XD_MAX
            else f"{jnp.dtype(dtype).name} beyond about 1e19: the rollout computes in q0's dtype; pass q0 as float64 "
            "with jax_enable_x64 on for up to 1e+100"
        )
        raise ValueError(
            f"K_xd has an entry of {np.max(finite):g} N/m; at most {limit:g} (u and the Frobenius "
            f"error sum squares of such entries, which overflow {where})"
        )


def _kxd_not_definite(w_min: float, w_max: float) -> str | None:
    """Why eigenvalues ``w_min <= w_max`` of a symmetric K_xd are no desired stiffness (None: they
    are). Zero along an axis is taken (positive semi-definite, e.g. ``--kxd 3000,0``: stiff along x,
    no stiffness asked for along y); a negative eigenvalue, or none above :data:`K_XD_MIN`, is not."""
    if _negative(w_min, w_max):
        return "a desired stiffness is >= 0 along every axis (a spring pulls back; a negative one pushes away)"
    if w_max < K_XD_MIN:
        return (
            f"every eigenvalue is below {K_XD_MIN:g} N/m: no stiffness at all (u and its gradient are about 0 or "
            "underflow, so CSC would not move: every step status 8)"
        )
    return None


def _negative(w_min: Any, w_max: Any) -> Any:
    """An eigenvalue below zero beyond rounding (relative to the largest magnitude)."""
    return w_min < -K_XD_MIN_RATIO * np.maximum(np.abs(w_min), np.abs(w_max))


def check_kxd(K: np.ndarray, dtype: Any = np.float64) -> None:
    """K_xd's values (finite, checked before): not so large that u squares them into inf,
    symmetric, positive semi-definite with some stiffness (an eigenvalue of at least
    :data:`K_XD_MIN`). ``ValueError`` naming K_xd, the value and the reason."""
    _refuse_huge_kxd(K, dtype)
    asym = np.max(np.abs(K - np.swapaxes(K, -1, -2)), axis=(-2, -1))
    bad = asym > 1e-6 * np.max(np.abs(K)) + 1e-12
    if np.any(bad):
        first = _first(bad)
        raise ValueError(f"K_xd must be symmetric (max |K - K^T| = {np.max(asym):g}; first at {_at('K_xd', first)})")
    w = np.linalg.eigvalsh(0.5 * (K + np.swapaxes(K, -1, -2)))
    lo, hi = w[..., 0], w[..., -1]
    bad = _negative(lo, hi) | (hi < K_XD_MIN)
    if not np.any(bad):
        return
    worst = _first(bad)
    w_min, w_max = float(lo[worst]) + 0.0, float(hi[worst])  # (+ 0.0: -0 prints as 0)
    reason = _kxd_not_definite(w_min, w_max)
    at = f" ({_at('K_xd', worst)})" if worst else ""
    shown = "[" + ", ".join("[" + ", ".join(f"{x + 0.0:g}" for x in row) + "]" for row in np.asarray(K[worst])) + "]"
    raise ValueError(
        f"K_xd must be symmetric positive semi-definite and not zero (a stiffness, N/m): eigenvalues {w_min:g} to {w_max:g}{at}, "
        f"{reason}; K_xd{'' if not worst else _at('', worst)} = {shown}"
    )


def kmax_message(kmin: float, kmax: float, name: str = "{}") -> str:
    """The message for ``kmax <= kmin`` (``name``: how a field is named, e.g. ``"--{}"``): CSC needs an
    actuator range, kmin < kmax, as a csc sweep requires."""
    lo, hi = name.format("kmin"), name.format("kmax")
    if kmax < kmin:
        return f"{hi} ({kmax:g}) must be above {lo} ({kmin:g}) (Nm/rad)"
    return (
        f"{hi} ({kmax:g}) must be above {lo} ({kmin:g}) (Nm/rad): CSC realises kj = clip(diag(J^T K_xd J), kmin, "
        "kmax) with variable-stiffness actuators; a range of one value is a fixed spring, so kj, K_C and "
        "|K_xd - K_C|_F would not depend on K_xd (a csc sweep refuses it too: 0 < kmin < kmax)"
    )


def _first(mask: np.ndarray) -> tuple[int, ...]:
    """The index of the first True entry of ``mask`` (C order) as plain ints (() for a 0-d mask)."""
    if mask.ndim == 0:
        return ()
    return tuple(int(i) for i in np.unravel_index(int(np.argmax(mask)), mask.shape))


def _at(name: str, index: tuple) -> str:
    """``K_xd[7]`` / ``path[0, 7]``: an index printed as plain ints (not numpy's ``np.int64(7)``)."""
    return f"{name}[{', '.join(str(int(i)) for i in index)}]" if len(index) else name


#: per input of :func:`validate_values`: its trailing axes that make one item (a waypoint's point,
#: a K_xd matrix, a posture), and what the last leading axis is called in a message
_ITEM_AXES = {"path": (1, "waypoint"), "K_xd": (2, None), "q0": (1, None), "beta": (0, None)}


def _refuse_non_finite(name: str, v: np.ndarray) -> None:
    """ValueError naming the first item (waypoint, K_xd matrix, posture) with a NaN or an Inf."""
    if np.all(np.isfinite(v)):
        return
    tail, axis_name = _ITEM_AXES[name]
    bad = ~np.isfinite(v)
    if tail:
        bad = np.any(bad, axis=tuple(range(-tail, 0)))
    first = _first(bad)
    where = f" (first at {_at(name, first)}" if first else ""
    if first and axis_name is not None:
        where += f", {axis_name} {first[-1]}"
    raise ValueError(f"{name} contains NaN or Inf{where}{')' if first else ''}")


def validate_values(  # noqa: C901 - a flat list of independent input checks
    robot: Robot,
    targets: jax.Array,
    K_xd: jax.Array,
    q0: jax.Array,
    beta: jax.Array,
    scalars: dict[str, jax.Array],
    null_eps: jax.Array,
    check_reach_: bool = True,
) -> None:
    """Value checks at the Python boundary, in numpy (skipped for traced inputs); ``check_reach_``:
    refuse waypoints out of the robot's reach (:func:`jaxstiff.model._reach.check_reach`)."""

    def val(x: Any) -> np.ndarray | None:
        return None if not is_concrete(x) else np.asarray(x, dtype=float)

    for name, a in (("path", targets), ("K_xd", K_xd), ("q0", q0), ("beta", beta)):
        v = val(a)
        if v is not None:
            _refuse_non_finite(name, v)
    pts = val(targets) if check_reach_ else None
    if pts is not None and pts.size:
        # waypoints out of the robot's reach, before any compilation (task "xy": (x, y) points)
        refuse_unreachable(robot, pts.reshape((-1,) + pts.shape[-2:]), planar=pts.shape[-1] == 2)
    b = val(beta)
    if b is not None and np.any(b < 0):
        raise ValueError(f"beta must be >= 0, got min {b.min():g}")
    K = val(K_xd)
    if K is not None:
        check_kxd(K, K_xd.dtype)
    kmin, kmax = val(scalars["kmin"]), val(scalars["kmax"])
    if kmin is not None and not (kmin > 0 and np.isfinite(kmin)):
        raise ValueError(f"kmin must be a finite number > 0 Nm/rad (kmax may be inf), got {float(kmin):g}")
    if kmin is not None and kmax is not None and not kmax > kmin:
        raise ValueError(kmax_message(float(kmin), float(kmax)))
    for name in ("nu0", "damping", "jl_gain"):
        v = val(scalars[name])
        if v is not None and not (np.isfinite(v) and v >= 0):
            raise ValueError(f"{name} must be finite and >= 0, got {float(v):g}")
    v = val(scalars["nu0"])
    if v is not None and not v < 1:
        raise ValueError(f"nu0 must be < 1 (the isotropy is in [0, 1]), got {float(v):g}")
    e = val(null_eps)
    if e is not None and not np.all(e > 0):
        raise ValueError("null_eps must be > 0")
    qn = val(q0)
    if qn is not None and qn.size:
        check_locked_values(robot, q0, "q0")  # the one rule (SPEC section 1), in q0's own dtype
        qn = qn.reshape(-1, robot.n)
        lo, hi = robot.lower, robot.upper
        bad = joints_outside_limits(robot, qn)
        if bad.any():
            i = int(np.argmax(bad))
            raise ValueError(
                f"q0 of joint {robot.joint_names[i]!r} is outside its limits [{lo[i]:g}, {hi[i]:g}] "
                f"(got values in [{qn[:, i].min():g}, {qn[:, i].max():g}])"
            )
