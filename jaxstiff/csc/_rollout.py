"""Configuration-based Stiffness Control (CSC, seed 001, SPEC section 6) as one ``lax.scan``.

A kinematically redundant arm follows a TCP path (the primary task) while its self-motion lowers
the off-diagonal norm ``u(q)`` of the joint-space stiffness ``K_q = J^T K_xd J`` (S1-19) that a
desired Cartesian stiffness ``K_xd`` would need. Uni-articular (one joint, one spring) actuators can
realise only the diagonal of ``K_q``; the seed argues that the smaller ``u``, the closer the
realised Cartesian stiffness comes to ``K_xd``. ``objective="frobenius"`` (this project's own)
lowers that distance ``|K_xd - K_C(q)|_F`` itself (:mod:`~jaxstiff.csc._frobenius`).

The parts: the step and its documented choices (:mod:`jaxstiff.csc._step`), the damped
projections (:mod:`~jaxstiff.csc._projections`), ``(u, grad u)`` (:mod:`~jaxstiff.csc._offdiag`),
the realised stiffness (:mod:`~jaxstiff.csc._measures`), the inputs and settings
(:mod:`~jaxstiff.csc._inputs`; defaults in :class:`~jaxstiff.settings.CSCSettings`), the result
(:mod:`~jaxstiff.csc._result`), long runs in segments (:mod:`~jaxstiff.csc._segments`).

The rollout is differentiable end to end (``jax.grad`` w.r.t. ``beta``, ``q0``, ``K_xd`` and the
numeric settings), batched over leading axes of every input (``vmap``), and jitted once per robot,
task and static setting. With ``remat=True`` (default) the scan body is rematerialised in the
backward pass, so the memory of a gradient grows with ``T * n`` per rollout only. Hand-written
VJPs (installed as custom JVPs that are their transposes, so forward mode keeps working) cover
``(u, grad u)``, the projections and the realised stiffness; the kinematics carry closed-form
JVPs; the saturation re-solve runs only in a chunk where some rollout reaches a limit; a constant
``K_xd`` is a constant of the time loop. Speed and what was tried: docs/notes/csc.md.

Example:
    >>> import jax.numpy as jnp, numpy as np, jaxstiff
    >>> robot = jaxstiff.Robot.from_urdf("planar_3r")
    >>> q0 = jnp.deg2rad(jnp.array([75.0, -74.74, -76.30]))
    >>> x0 = robot.fk(q0)[:2, 3]
    >>> c, s = np.cos(np.pi / 6), np.sin(np.pi / 6)
    >>> R = jnp.array([[c, -s], [s, c]])
    >>> K_xd = R @ jnp.diag(jnp.array([3000.0, 1000.0])) @ R.T
    >>> res = jaxstiff.csc_rollout(robot, jnp.tile(x0, (500, 1)), K_xd, q0, 2e-3, step="constant")
    >>> res.q.shape, bool(res.u[-1] < res.u_start)
    ((500, 3), True)
"""

from __future__ import annotations

import dataclasses
import functools
from collections.abc import Callable
from typing import Any

import jax
import jax.numpy as jnp

from jaxstiff.csc._inputs import is_concrete, prepare_rollout
from jaxstiff.csc._result import (
    STATUS_DAMPED,
    STATUS_JOINT_LIMIT,
    STATUS_NAN,
    STATUS_NULL_SMALL,
    STATUS_OK,
    CSCResult,
    CSCStatus,
    describe_status,
)
from jaxstiff.csc._step import StaticSettings, csc_step, step_context
from jaxstiff.model._kinematics import POLY_MIN_BATCH
from jaxstiff.model._robot import Robot
from jaxstiff.runtime._compile_cache import ensure_compile_cache
from jaxstiff.runtime._programs import program_cache
from jaxstiff.runtime._xla import kernel_compiler_options
from jaxstiff.settings._base import suggest
from jaxstiff.settings._csc import CSCSettings

__all__ = [
    "CSCResult",
    "CSCStatus",
    "csc_rollout",
    "rollout_one",
    "rollout_batch",
    "rollout_batch_jit",
    "BATCH_AXIS",
    "STATUS_OK",
    "STATUS_DAMPED",
    "STATUS_JOINT_LIMIT",
    "STATUS_NAN",
    "STATUS_NULL_SMALL",
    "describe_status",
]

BATCH_AXIS = "jaxstiff_csc_rollouts"  #: the named vmap axis of a chunk's rollouts


def rollout_one(  # noqa: PLR0913 - the rollout's traced arrays, one argument each (vmapped)
    robot: Robot,
    st: StaticSettings,
    axis_name: str,
    targets: jax.Array,
    K_xd: jax.Array,
    q0: jax.Array,
    beta: jax.Array,
    kmin: jax.Array,
    kmax: jax.Array,
    nu0: jax.Array,
    damping: jax.Array,
    null_eps: jax.Array,
    jl_gain: jax.Array,
    R_hold: jax.Array | None = None,
) -> CSCResult:
    """One rollout. targets (T, d), K_xd (T, m, m) or (m, m), q0 (n,), beta (), R_hold (3, 3) or
    None (task "full": the orientation held; None: q0's). See :func:`csc_rollout`.
    Runs under ``vmap(axis_name=axis_name)`` over the rollouts of a chunk."""
    scalars = dict(beta=beta, kmin=kmin, kmax=kmax, nu0=nu0, damping=damping, null_eps=null_eps, jl_gain=jl_gain)
    ctx, q0 = step_context(robot, st, axis_name, targets.shape[-1], q0, K_xd, scalars, R_hold)
    # T + 1 iterations: iteration k reports the posture q_k (reached by step k - 1) against
    # waypoint k - 1, then steps towards waypoint k. The last iteration only reports q_T (its
    # step is discarded); row 0 reports the start posture. One loop body, no duplicate code.
    # A constant K_xd is a constant of the loop, not a sequence: its cotangent then sums in the
    # loop instead of filling (and zeroing) a (T + 1, m, m) buffer per rollout.
    K_ext = K_prev = None
    if st.varying:
        K_ext = jnp.concatenate([K_xd, K_xd[-1:]], axis=0)
        K_prev = jnp.concatenate([K_xd[:1], K_xd], axis=0)
    t_ext = jnp.concatenate([targets, targets[-1:]], axis=0)
    t_prev = jnp.concatenate([targets[:1], targets], axis=0)
    step_fn = functools.partial(csc_step, ctx)
    body = jax.checkpoint(step_fn) if st.remat else step_fn
    _, outs = jax.lax.scan(body, q0, (t_ext, K_ext, K_prev, t_prev))
    fields = {name: a[1:] for name, a in outs.items() if name not in ("null_step", "status")}
    fields["null_step"] = outs["null_step"][:-1]
    fields["status"] = outs["status"][:-1]
    fields["target"] = targets
    fields["u_start"] = outs["u"][0]
    fields["frobenius_start"] = outs["frobenius"][0]
    return CSCResult(**fields)


def rollout_batch(*args: Any) -> CSCResult:
    """The jitted batch rollout ``(robot, st, chunk, *arrays)`` (static: robot, settings, chunk).
    Called on concrete arrays it is compiled with jaxstiff's kernel options
    (:mod:`jaxstiff.runtime._xla`); inside a caller's trace (jit, grad) the caller's compilation
    decides (JAX refuses options on a nested jit)."""
    top_level = all(is_concrete(a) for a in jax.tree_util.tree_leaves(args[3:]))
    return rollout_batch_jit(jax.default_backend(), top_level)(*args)


@program_cache(None)
def rollout_batch_jit(backend: str, top_level: bool) -> Callable[..., CSCResult]:
    """The jitted batch rollout of a backend, top level (jaxstiff's XLA options) or nested (one per process)."""
    opts = kernel_compiler_options() if top_level else None
    return jax.jit(_rollout_batch_impl, static_argnums=(0, 1, 2), compiler_options=opts)


def _rollout_batch_impl(  # noqa: PLR0913 - the rollout's traced arrays, one argument each (jitted)
    robot: Robot,
    st: StaticSettings,
    chunk: int | None,
    targets: jax.Array,
    K_xd: jax.Array,
    q0: jax.Array,
    beta: jax.Array,
    kmin: jax.Array,
    kmax: jax.Array,
    nu0: jax.Array,
    damping: jax.Array,
    null_eps: jax.Array,
    jl_gain: jax.Array,
    R_hold: jax.Array | None,
) -> CSCResult:
    def one(xs: tuple) -> CSCResult:
        t, K, q, b, e, R = xs
        return rollout_one(robot, st, BATCH_AXIS, t, K, q, b, kmin, kmax, nu0, damping, e, jl_gain, R)

    B = q0.shape[0]
    # one rollout's kinematics sees a single posture under vmap: choose its cos/sin by the batch
    per_call = B if chunk is None else min(B, chunk)
    st = dataclasses.replace(st, poly=jax.default_backend() == "cpu" and per_call >= POLY_MIN_BATCH)
    batched = jax.vmap(one, axis_name=BATCH_AXIS)
    xs = (targets, K_xd, q0, beta, null_eps, R_hold)
    if chunk is None or B <= chunk:
        return batched(xs)
    # rollouts in chunks of `chunk` (vmap inside a sequential map): the working set of one
    # chunk stays in the CPU caches, which is faster than one vmap over a large batch
    nfull = B // chunk * chunk
    head = jax.tree.map(lambda x: x[:nfull].reshape((B // chunk, chunk) + x.shape[1:]), xs)
    out = jax.tree.map(lambda y: y.reshape((nfull,) + y.shape[2:]), jax.lax.map(batched, head))
    if nfull == B:
        return out
    tail = batched(jax.tree.map(lambda x: x[nfull:], xs))
    return jax.tree.map(lambda a, b: jnp.concatenate([a, b], axis=0), out, tail)


#: the keywords :func:`csc_rollout` takes besides its own: every CSCSettings field but beta (a
#: parameter), and two per-call inputs
INLINE_CSC_SETTINGS = frozenset(CSCSettings.field_names()) - {"beta"} | {"kxd_varying", "hold_orientation"}


def csc_rollout(
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
    **inline: Any,
) -> CSCResult:
    """Configuration-based Stiffness Control rollout along a path (seed 001, SPEC section 6).

    One step per waypoint; see :mod:`jaxstiff.csc._step` for the update and its documented choices.
    Every array input may carry leading batch axes; they broadcast against each other and the
    result carries the broadcast batch shape ``*B`` (computed with one ``vmap``).

    Settings (``beta`` and the ``**inline`` ones) come from ``settings`` (default: CSCSettings'
    defaults, as ``jaxstiff csc``'s); one given here that is not None overrides its field (arrays
    too). The body is two named steps (:func:`prepare_rollout`, :func:`rollout_batch`).

    Args:
        robot: the chain (static: one compilation per robot and setting).
        path: a :class:`jaxstiff.Path` (its ``.points``) or an array (*B, T, 3) / (*B, T, 2) of
            TCP targets, m, base frame, one step per waypoint. Task ``"xy"`` uses the first two
            columns. To hold a point, repeat it T times.
        K_xd: desired Cartesian stiffness, (*B, m, m) constant or (*B, T, m, m) along the path;
            N/m (translational rows), m = 2 (``"xy"``), 3 (``"xyz"``) or 6 (``"full"``). Symmetric.
        q0: start posture (*B, n), rad; a locked joint's entry must be its locked value (another
            value is refused, ValueError naming the joint; a traced q0 inside ``jit`` is not
            checked and the locked value is used). It need not be on the path: the first steps pull
            the TCP onto it, with the full step ``J+ (x_d - x)`` (S1-13, uncapped). Near the path that
            converges in a step or two; from far off (on the planar 4R, a start 1 m from the path
            did not, 0.5 m did) that step can throw joints onto their limits or fold the arm into a
            singular posture it does not leave, and ``tracking_error`` stays large. Start on the
            path (IK, e.g. :func:`jaxstiff.ik.ik_position`) or near it.
        beta: (*B,) step multiplier >= 0 (default ``settings.beta``, 1). ``"adaptive"``: the null
            step is ``beta`` times as long as the primary step (S1-22; zero when the path stands
            still). ``"constant"``: the null step is ``beta`` rad long (for holding a point).
        settings: a :class:`~jaxstiff.settings.CSCSettings` (its units and checks).
        remat: rematerialise the scan body in the backward pass (memory ~ T n per rollout).
        chunk: rollouts per ``vmap`` chunk; a larger batch runs as a sequential ``lax.map`` over
            chunks (bounded working set). ``None``: one vmap over the whole batch.
        check_reach: refuse waypoints out of the robot's reach before compiling anything
            (default True; ``robot.reach()``, :func:`jaxstiff.model._reach.check_reach`; a traced
            path is not checked). The sweep passes False: its rows over a workspace may leave the
            reach, and a rollout's cost does not depend on it (it tracks as far as it can).
        **inline: any :class:`~jaxstiff.settings.CSCSettings` field, and ``kxd_varying`` and
            ``hold_orientation``; a value that is not None wins over ``settings``:

            task: ``"xy"``, ``"xyz"`` or ``"full"``; default from K_xd's size.
            step: ``"adaptive"`` (default) or ``"constant"``.
            kmin, kmax: actuator range of the realised joint stiffness, Nm/rad (default [1, inf)).
            nu0: isotropy threshold: damping switches on below ``nu0^(m/2)`` (default 1e-2).
            damping: relative damping ``lam / sqrt(tr(J J^T)/m)`` at a singularity (default 0.1).
            null_eps: floor of ``|dq_N|`` (Nm/rad^2); default ``1e-9 |K_xd|_F`` (1e-5 in float32).
            newton: number of Newton corrections ``q += J+ (x_d - x(q))`` inside each step (static; default 1:
                on a reachable path the TCP stays within ~1e-6 m at 3 cm waypoint spacing (measured 3e-6 m on
                the Panda, 7e-7 m on a Gen3) and ~3e-8 m at 1 cm; ``newton=2`` reaches ~1e-11 m; 0 drifts
                ~1e-6 m over 400 steps).
            joint_limits: ``"off"`` (default), ``"priority"`` (lowest-priority secondary task) or
                ``"sum"`` (added to the CSC gradient); see :mod:`jaxstiff.csc._step`.
            jl_gain: joint-limit gain (rad per step for a joint at its limit, before projection; for
                ``"sum"``: relative weight against the CSC gradient); default 0.3 with
                ``joint_limits`` ``"priority"`` or ``"sum"``, else 0.
            objective: what the null-space step lowers: ``"offdiag"`` (default, the seed's ``u(q)``,
                S1-19) or ``"frobenius"`` (``|K_xd - K_C(q)|_F`` itself, this project's own; static).
                The result reports both measures either way.
            locked_joints: ``"rigid"`` (default, SPEC section 1: a locked joint has no spring, adds no
                compliance, has no stiffness variable; its ``kj`` is reported as +inf, infinite stiffness) or ``"spring"``
                (it keeps its spring in ``u``, ``kj`` and ``K_C``). Static.
            kxd_varying: whether K_xd's axis -3 runs along the path. Default: True when
                ``K_xd.ndim >= 3`` and ``K_xd.shape[-3] == T``; pass False for a batch of constant
                K_xd whose batch size happens to equal T.
            hold_orientation: task ``"full"`` only: the tool orientation to hold, a rotation matrix
                (*B, 3, 3) in the base frame; default: the orientation at ``q0``. (A rollout continued
                from a later posture, as :func:`csc_rollout_segments` does, passes the first one's.)

    Returns:
        :class:`CSCResult` with leading batch axes ``*B``.

    Raises:
        TypeError: an unknown keyword (the message names the nearest setting).
        ValueError: bad shapes, task, step, non-finite or out-of-limit inputs, negative beta,
            a non-symmetric or indefinite K_xd, ``kmin <= 0`` or ``kmin > kmax`` (checked for concrete inputs);
            :class:`~jaxstiff.model._reach.UnreachableError` for waypoints out of reach.
    """
    unknown = sorted(set(inline) - INLINE_CSC_SETTINGS)
    if unknown:
        k = unknown[0]
        raise TypeError(
            f"csc_rollout() got an unexpected keyword argument {k!r}{suggest(k, sorted(INLINE_CSC_SETTINGS))}"
        )
    ensure_compile_cache()  # the persistent compilation cache, before the first compilation (cheap when on)
    st, chunk, args, batch = prepare_rollout(
        robot, path, K_xd, q0, beta, settings=settings, remat=remat, chunk=chunk, check_reach=check_reach, **inline
    )
    res = rollout_batch(robot, st, chunk, *args)
    return jax.tree_util.tree_map(lambda a: a.reshape(batch + a.shape[1:]), res)
