"""One CSC step (S1-13 ... S1-22): the body of the rollout's ``lax.scan``, in named parts.

One step ``k`` (one per path waypoint), with ``J`` the task rows of the geometric Jacobian at
``q_k`` (locked joints' columns zeroed for motion), :mod:`jaxstiff.csc._projections` for ``J+``:

.. code-block:: text

    dx    = x_d[k] - x(q_k)                            closed loop: the TCP does not drift
    dq_P  = J+ dx                                      (S1-13, particular solution)
    dq_N  = (I - J+ J) grad f(q_k)                     (S1-14, S1-15, S1-20; f = u or |K_xd - K_C|_F)
    alpha = beta |dq_P| / |dq_N|   ("adaptive", S1-22)  or  beta / |dq_N|   ("constant")
    q_k+1 = q_k + dq_P - alpha dq_N [+ dq_L]           (S1-13, S1-21)
    then ``newton`` optional corrections q <- q + J+(q) (x_d[k] - x(q)), then the joint limits.

Choices where the seed is silent (SPEC section 6 lets us choose):

* **Guard of |dq_N| -> 0.** ``|dq_N|`` is replaced by ``max(|dq_N|, null_eps)``: the null step
  has length beta (constant) or ``beta |dq_P|`` (adaptive) while the projected gradient is larger
  than ``null_eps``, and shrinks to plain projected gradient descent below it; at ``dq_N = 0``
  exactly it is zero. Norms use the double-``where`` trick, so values and gradients stay finite.
  With no more movable joints than task rows (a non-redundant arm, or too many joints frozen at
  their limits in a step) there is no null space: the null step is then zero (status
  ``NULL_SMALL``). In the adaptive rule ``|dq_P|`` below ``10 eps`` counts as 0: a path that
  starts at the TCP sits on the kink of ``|dq_P|`` at ``dx = 0``, and the derivative there is
  then the symmetric one (central differences'), not a side picked by the FK's round-off.
* **Joint limits.** Optional lower-priority secondary task (``joint_limits="priority"``): the
  Liegeois cost ``h = 1/2 sum_i (q_i - c_i)^2 / h_i`` (c_i the middle, h_i the half range of
  joint i, joints with finite limits only) gives ``dq_L = -jl_gain * grad h``; it is projected into
  the null space of the path task and then made orthogonal to ``dq_N`` (the null space of the
  path + CSC tasks), so it never disturbs them, and it does nothing when the arm has only one
  redundant degree of freedom. ``joint_limits="sum"`` instead adds it to the CSC gradient (a
  weighted sum, projected into the path task's null space only), which trades some ``u`` for
  distance from the limits. Independently of both, every free joint is clamped to its limits
  after each step (status ``JOINT_LIMIT``). Saturation inside a step: the joints that the step
  would push past a limit go exactly to it and are frozen, and the other joints solve the step
  again; a joint that this re-solve pushes out is frozen in turn (up to
  :data:`SATURATION_ROUNDS` rounds), so the tracking step is not cut by the final clamp. Known
  limit: a frozen joint is not released within the step (not a full active set): from a start
  with joints at their limits the arm can stall (status 2 + 8 on every step), or the TCP can fall
  behind the path (the tracking error says so). Start inside the limits, or use
  ``joint_limits="priority"`` to keep the arm off them.
* **Locked joints** never move: their Jacobian columns are zeroed for motion and, in this traced
  kernel, their entries of ``q0`` are replaced by the locked values (:func:`jaxstiff.csc_rollout`
  refuses a concrete ``q0`` that gives them another value, naming the joint). ``locked_joints="rigid"`` (default, SPEC section 1):
  they have no spring either, so their columns are zeroed for the stiffness too: ``u`` and its
  gradient, the realised joint stiffness and ``K_C = (J_f K_f^-1 J_f^T)^-1`` run over the free
  joints only, and a locked joint's reported ``kj`` is ``+inf`` (no spring: infinitely stiff,
  not a variable; :class:`jaxstiff.CSCResult`).
  ``"spring"``: they keep their springs, ``u``, ``kj`` and ``K_C`` use the full Jacobian.
* **Objective.** ``objective="offdiag"`` (default): the seed's ``u(q)`` (S1-19, closed-form
  gradient, :mod:`~jaxstiff.csc._offdiag`). ``"frobenius"`` (this project's own): ``|K_xd - K_C(q)|_F``
  with ``K_C`` from the realised (clipped) diagonal joint stiffness, the measure itself
  (:mod:`~jaxstiff.csc._frobenius`). Both are reported whichever drives the step.
* **Task rows.** ``"xy"``, ``"xyz"``, ``"full"`` (position follows the path, the tool orientation
  is held; the orientation error is ``1/2 sum_i r_i x r_d,i``, :func:`~jaxstiff.csc._pose.orientation_error`).
"""

from __future__ import annotations

import dataclasses
from typing import Any, NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from jaxstiff.csc._algebra import mv, vector_norm
from jaxstiff.csc._frobenius import frobenius_value_and_grad
from jaxstiff.csc._measures import posture_measures
from jaxstiff.csc._offdiag import offdiag_value_and_grad
from jaxstiff.csc._pose import orientation_error, pos_jac, pose_jac
from jaxstiff.csc._projections import damped_pinv, damped_projections, isotropy_threshold
from jaxstiff.csc._result import CSCStatus
from jaxstiff.model._robot import Robot
from jaxstiff.stiffness._core import TASK_ROWS
from jaxstiff.stiffness._criteria import offdiag

__all__ = ["StepContext", "SATURATION_ROUNDS", "solve_step", "evaluate", "rigid_locks", "expand_free"]

#: re-solves of a step after joints were frozen at their limits (each round freezes the joints the
#: previous solve pushed past a limit); later violators are clamped by the final clip
SATURATION_ROUNDS = 3


@dataclasses.dataclass(frozen=True)
class StaticSettings:
    """Settings that shape the compiled program (hashable, a static jit argument)."""

    task: str
    step: str
    newton: int
    joint_limits: str
    remat: bool
    varying: bool
    objective: str  # "offdiag" (u, S1-19) or "frobenius" (|K_xd - K_C|_F)
    locked_joints: str  # "rigid" (no spring) or "spring"
    poly: bool = False  # joint cos/sin from kinematics.cos_sin (a CPU batch of >= 64 rollouts)


class StepContext(NamedTuple):
    """What every step of one rollout shares: the chain's constants and the rollout's settings.

    Joint arrays are (n,) in q's dtype: ``free`` (1 free, 0 locked), ``lock_vals`` (locked values,
    0 for free joints), ``lower``/``upper`` (limits, +-inf for locked joints), ``mid``/``half``
    (middle and half range of the finite limits, 0/1 elsewhere), ``finite_j`` (1 where both limits
    are finite and apart: the joints of the Liegeois term). Scalars (rollout's or traced): beta,
    kmin, kmax, nu0, damping, null_eps, jl_gain.
    """

    robot: Robot
    st: StaticSettings
    axis_name: str
    d: int  # target coordinates (2 for "xy", else 3)
    free: jax.Array
    free_b: np.ndarray  # bool (n,), numpy: a trace-time constant
    lock_vals: jax.Array
    lower: jax.Array
    upper: jax.Array
    mid: jax.Array
    half: jax.Array
    finite_j: jax.Array
    K_xd: jax.Array  # the constant (m, m) K_xd, or (T, m, m) when it varies (then read from xs)
    beta: Any
    kmin: Any
    kmax: Any
    nu0: Any
    damping: Any
    null_eps: Any
    jl_gain: Any
    R_hold: jax.Array | None  # the held rotation (task "full")

    @property
    def m(self) -> int:
        return len(TASK_ROWS[self.st.task])


def _joint_constants(robot: Robot, dtype: Any) -> dict[str, Any]:
    """The chain's per-joint constants of :class:`StepContext` (numpy, then q's dtype)."""
    free_b = np.asarray(robot.free)
    lo_f, hi_f = robot.lower, robot.upper
    # the Liegeois term's joints: finite limits with room between them (a one-value range, which a
    # URDF may give, has half range 0: its term would be 0 / 0 at every step; that joint cannot move)
    finite = np.isfinite(lo_f) & np.isfinite(hi_f) & free_b
    finite &= np.where(finite, hi_f, 0.0) > np.where(finite, lo_f, 0.0)
    lo_f, hi_f = np.where(finite, lo_f, 0.0), np.where(finite, hi_f, 0.0)  # continuous joints: no inf - inf
    return dict(
        free=jnp.asarray(robot.free, dtype=dtype),
        free_b=free_b,
        lock_vals=jnp.asarray(np.nan_to_num(robot.locked_values), dtype=dtype),
        lower=jnp.asarray(np.where(free_b, robot.lower, -np.inf), dtype=dtype),
        upper=jnp.asarray(np.where(free_b, robot.upper, np.inf), dtype=dtype),
        mid=jnp.asarray(np.where(finite, 0.5 * (lo_f + hi_f), 0.0), dtype=dtype),
        half=jnp.asarray(np.where(finite, 0.5 * (hi_f - lo_f), 1.0), dtype=dtype),
        finite_j=jnp.asarray(finite, dtype=dtype),
    )


def step_context(
    robot: Robot,
    st: StaticSettings,
    axis_name: str,
    d: int,
    q0: jax.Array,
    K_xd: jax.Array,
    scalars: dict[str, Any],
    R_hold: jax.Array | None,
) -> tuple[StepContext, jax.Array]:
    """The :class:`StepContext` of one rollout and its start posture (locked joints at their values).

    ``scalars``: beta, kmin, kmax, nu0, damping, null_eps, jl_gain. ``R_hold`` None with task
    ``"full"``: the orientation at the start posture is held.
    """
    consts = _joint_constants(robot, q0.dtype)
    q0 = jnp.where(consts["free_b"], q0, consts["lock_vals"])
    if st.task == "full" and R_hold is None:
        R_hold = pose_jac(robot, st.poly, q0)[1]
    ctx = StepContext(robot=robot, st=st, axis_name=axis_name, d=d, K_xd=K_xd, R_hold=R_hold, **consts, **scalars)
    return ctx, q0


def kinematics(ctx: StepContext, q: jax.Array) -> tuple[jax.Array, jax.Array, jax.Array, jax.Array | None]:
    """Task position (d,), full Jacobian (6, n), full position (3,), rotation (3, 3) or None."""
    if ctx.st.task == "full":
        p, R, J6 = pose_jac(ctx.robot, ctx.st.poly, q)
        return p, J6, p, R
    p, J6 = pos_jac(ctx.robot, ctx.st.poly, q)
    return p[: ctx.d], J6, p, None


def task_error(ctx: StepContext, p: jax.Array, R: jax.Array | None, target: jax.Array) -> jax.Array:
    """``dx`` (m,): position error, m, then (task ``"full"``) the orientation error, rad."""
    e = target - p
    if ctx.st.task == "full":
        e = jnp.concatenate([e, orientation_error(R, ctx.R_hold)])  # type: ignore[arg-type]
    return e


def rigid_locks(ctx: StepContext) -> bool:
    """Whether some joints are locked and rigid (their columns then drop out of the stiffness)."""
    return ctx.st.locked_joints == "rigid" and not bool(ctx.free_b.all())


def expand_free(ctx: StepContext, x: jax.Array, fill: float = 0.0) -> jax.Array:
    """``x`` (..., n_free) over the free joints -> (..., n) in chain order, ``fill`` at the locked joints."""
    cols, k = [], 0
    for free in ctx.free_b:
        cols.append(x[..., k] if free else jnp.full_like(x[..., 0], fill))
        k += int(free)
    return jnp.stack(cols, axis=-1)


def evaluate(ctx: StepContext, q: jax.Array, K: jax.Array) -> tuple:
    """``(u, grad f, (p, J, p3, R), Js)`` at q: the kinematics, ``u`` (S1-19), the gradient (n,) of
    the objective ``f`` (``u`` itself, S1-20, or ``|K_xd - K_C|_F``), the task rows ``J`` (m, n)
    for motion and ``Js`` those of the stiffness: ``J`` itself, or with rigid locked joints only
    the free joints' columns (m, n_free; in chain order, the closed-form derivative of J stays
    exact without the zero columns, and the stiffness work shrinks)."""
    with jax.named_scope("csc_kinematics"):
        p, J6, p3, R = kinematics(ctx, q)
    J = J6[..., : ctx.m, :]
    rigid = rigid_locks(ctx)  # (static: nothing changes without rigid locked joints)
    J6s = J6[..., np.flatnonzero(ctx.free_b)] if rigid else J6
    Js = J6s[..., : ctx.m, :] if rigid else J
    if ctx.st.objective == "frobenius":
        with jax.named_scope("csc_frobenius"):
            _, g = frobenius_value_and_grad(J6s, K, ctx.kmin, ctx.kmax, ctx.st.task)
        u = offdiag(Js, K)
    else:
        with jax.named_scope("csc_offdiag"):
            u, g = offdiag_value_and_grad(J6s, K, TASK_ROWS[ctx.st.task])
    return u, expand_free(ctx, g) if rigid else g, (p, J, p3, R), Js


def _null_length(ctx: StepContext, dqP: jax.Array) -> Any:
    """The null step's length: ``beta |dq_P|`` (adaptive, S1-22) or ``beta`` (constant)."""
    if ctx.st.step != "adaptive":
        return ctx.beta
    # |dq_P| has a kink at dx = 0 (holding still, a path that starts at the TCP), where the FK's
    # round-off (~eps) would pick the derivative's side; below 10 eps it is taken as 0 (value
    # change ~1e-15 rad), so the derivative there is the symmetric one
    nP = vector_norm(dqP)
    return ctx.beta * jnp.where(nP > 10.0 * jnp.finfo(dqP.dtype).eps, nP, 0.0)


def solve_step(ctx: StepContext, q: jax.Array, J: jax.Array, g: jax.Array, dx: jax.Array, mask: jax.Array) -> tuple:
    """The CSC update (S1-13 ... S1-22) with the joints of ``mask`` (float 0/1, (n,)) movable.

    Returns ``(dq (n,), null step (n,), nu, damped, small)``; ``small``: ``|dq_N| < null_eps`` or
    no null space (status ``NULL_SMALL``).
    """
    jl_gain, null_eps, m = ctx.jl_gain, ctx.null_eps, ctx.m
    Jm = J * mask
    gm = g * mask
    if ctx.st.joint_limits == "sum":
        gm = gm + jl_gain * ctx.finite_j * mask * (q - ctx.mid) / ctx.half * vector_norm(gm)
    vs = (gm,)
    if ctx.st.joint_limits == "priority":
        vs = (gm, -jl_gain * ctx.finite_j * mask * (q - ctx.mid) / ctx.half)
    dqP, Pvs, nu = damped_projections(Jm, dx, vs, ctx.nu0, ctx.damping)
    damped = nu < isotropy_threshold(ctx.nu0, m)
    dqN = Pvs[0]
    nN = vector_norm(dqN)
    length = _null_length(ctx, dqP)
    # no null space without more movable joints than task rows (a non-redundant arm, or joints
    # frozen at their limits): (I - J+ J) g is then round-off, or with damping a leftover that is
    # no null-space motion at all, which the adaptive length would blow up to |dq_P| and could
    # cancel the tracking step. The null step is then zero (status 8).
    has_null = jnp.sum(mask) > m
    null = jnp.where(has_null, -(length / jnp.maximum(nN, null_eps)), 0.0) * dqN
    dq = dqP + null
    if ctx.st.joint_limits == "priority":
        cN = Pvs[1]
        nn2 = jnp.sum(dqN * dqN)
        pos = nn2 > null_eps**2
        coef = jnp.where(pos, jnp.sum(cN * dqN) / jnp.where(pos, nn2, 1.0), 0.0)
        dq = dq + jnp.where(has_null, 1.0, 0.0) * (cN - coef * dqN)
    return dq, null, nu, damped, (nN < null_eps) | ~has_null


def saturate(
    ctx: StepContext, k: int, q: jax.Array, lin: tuple, prev: tuple, dq_sat: jax.Array, mask: jax.Array
) -> tuple:
    """Round ``k`` of the saturation: joints the step ``prev = (dq, null, small)`` pushes past a
    limit go exactly to it and are frozen; the other movable joints re-solve the same linearised
    step ``lin = (J, g, dx)`` for the rest. A joint the re-solve pushes out is frozen in turn, up to
    :data:`SATURATION_ROUNDS` rounds, so the final clamp does not throw away part of the tracking
    step. Returns ``(dq, null, small, mask)``.
    """
    J, g, dx = lin
    dq_prev, null_prev, small_prev = prev
    q1 = q + dq_prev
    over = (mask > 0) & ((q1 < ctx.lower) | (q1 > ctx.upper))
    any_over = jnp.any(over)
    dq_sat = dq_sat + jnp.where(over, jnp.clip(q1, ctx.lower, ctx.upper) - q, 0.0)
    mask_new = mask * (1.0 - over.astype(q.dtype))

    def resolve(_: None) -> tuple:
        with jax.named_scope("csc_resolve"):
            dq2, null2, _, _, small2 = solve_step(ctx, q, J, g, dx - mv(J, dq_sat), mask_new)
        dq2 = dq2 + dq_sat
        if k + 1 < SATURATION_ROUNDS:
            dq2, null2, small2, mask2 = saturate(ctx, k + 1, q, lin, (dq2, null2, small2), dq_sat, mask_new)
        else:
            mask2 = mask_new
        return (
            jnp.where(any_over, dq2, dq_prev),
            jnp.where(any_over, null2, null_prev),
            jnp.where(any_over, small2, small_prev),
            jnp.where(any_over, mask2, mask),
        )

    # Rare (a limit reached): re-solve only when some rollout of the vmapped chunk needs it. The
    # predicate is reduced over the batch axis, so it stays a branch under vmap. The branch is
    # rematerialised on its own: a cond's linearisation returns the residuals of both branches,
    # and the branch not taken fills them with zeros.
    need = jax.lax.pmax(any_over.astype(jnp.int32), ctx.axis_name) > 0
    return jax.lax.cond(need, jax.checkpoint(resolve), lambda _: (dq_prev, null_prev, small_prev, mask), None)


def _newton(ctx: StepContext, q_new: jax.Array, mask: jax.Array, target: jax.Array) -> jax.Array:
    """``ctx.st.newton`` corrections ``q <- q + J+(q) (x_d - x(q))`` with the joints of ``mask``."""
    for _ in range(ctx.st.newton):
        pn, Jn, _, Rn = kinematics(ctx, q_new)
        Jpn, _, _ = damped_pinv(Jn[..., : ctx.m, :] * mask, ctx.nu0, ctx.damping)
        q_new = q_new + mv(Jpn, task_error(ctx, pn, Rn, target))
    return q_new


def _status(damped: jax.Array, hit: jax.Array, ok: jax.Array, small: jax.Array) -> jax.Array:
    """The step's :class:`CSCStatus` bit mask (int32)."""
    return (
        jnp.where(damped, int(CSCStatus.DAMPED), 0)
        + jnp.where(hit & ok, int(CSCStatus.JOINT_LIMIT), 0)
        + jnp.where(ok, 0, int(CSCStatus.NAN))
        + jnp.where(small, int(CSCStatus.NULL_SMALL), 0)
    ).astype(jnp.int32)


def csc_step(ctx: StepContext, q: jax.Array, xs: tuple) -> tuple[jax.Array, dict[str, jax.Array]]:
    """The scan body: report the posture q against the previous waypoint, then step towards the next.

    ``xs = (target, K, K_prev, target_prev)`` (``K``, ``K_prev`` None for a constant K_xd).
    Returns ``(q_next, row)``, row: the :class:`~jaxstiff.csc.CSCResult` fields of posture q.
    """
    target, K, K_prev, target_prev = xs
    if not ctx.st.varying:
        K = K_prev = ctx.K_xd
    u, g, (p, J, p3, R), Js = evaluate(ctx, q, K)
    # measures of the posture q (reached by the previous step) against the previous waypoint
    u_rep = u if not ctx.st.varying else offdiag(Js, K_prev)
    with jax.named_scope("csc_measures"):
        kj, K_C, frob, err, oerr = posture_measures(
            Js, K_prev, p, R, target_prev, kmin=ctx.kmin, kmax=ctx.kmax, task=ctx.st.task, R_hold=ctx.R_hold
        )
    if rigid_locks(ctx):  # a rigid locked joint: no spring, no variable; reported as +inf (infinite stiffness)
        kj = expand_free(ctx, kj, fill=np.inf)
    dx = task_error(ctx, p, R, target)
    with jax.named_scope("csc_solve"):
        dq1, null1, nu, damped, small1 = solve_step(ctx, q, J, g, dx, ctx.free)
    q1 = q + dq1
    any_over = jnp.any(ctx.free_b & ((q1 < ctx.lower) | (q1 > ctx.upper)))
    dq, null, small, mask2 = saturate(ctx, 0, q, (J, g, dx), (dq1, null1, small1), jnp.zeros_like(q), ctx.free)
    q_new = _newton(ctx, q + dq, mask2, target)
    q_clamped = jnp.clip(q_new, ctx.lower, ctx.upper)
    hit = any_over | jnp.any(q_clamped != q_new)
    q_clamped = jnp.where(ctx.free_b, q_clamped, ctx.lock_vals)
    ok = jnp.all(jnp.isfinite(q_clamped))
    q_next = jnp.where(ok, q_clamped, q)
    status = _status(damped, hit, ok, small)
    step_len = jnp.where(ok, vector_norm(null), 0.0)
    out = dict(
        q=q,
        u=u_rep,
        frobenius=frob,
        tracking_error=err,
        orientation_error=oerr,
        kj=kj,
        K_C=K_C,
        position=p3,
        isotropy=nu,
        null_step=step_len,
        status=status,
    )
    return q_next, out
