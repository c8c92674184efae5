"""Configuration-based Stiffness Control (CSC, seed 001, SPEC section 6) as one ``lax.scan``.

A kinematically redundant arm follows a TCP path (the primary task) while its self-motion lowers
the off-diagonal norm ``u(q)`` of the joint-space stiffness ``K_q = J^T K_xd J`` (S1-19) that a
desired Cartesian stiffness ``K_xd`` would need. Uni-articular (one joint, one spring) actuators can
realise only the diagonal of ``K_q``; the smaller ``u``, the closer the realised Cartesian stiffness
comes to ``K_xd``.

One step ``k`` (one per path waypoint), with ``J`` the task rows of the geometric Jacobian at ``q_k``
(locked joints' columns zeroed for motion):

.. code-block:: text

    dx    = x_d[k] - x(q_k)                            closed loop: the TCP does not drift
    J+    = J^T (J J^T + lam^2 I)^-1                   (S1-16, damped near singularities, below)
    dq_P  = J+ dx                                      (S1-13, particular solution)
    dq_N  = (I - J+ J) grad u(q_k)                     (S1-14, S1-15, S1-20)
    alpha = beta |dq_P| / |dq_N|   ("adaptive", S1-22)  or  beta / |dq_N|   ("constant")
    q_k+1 = q_k + dq_P - alpha dq_N [+ dq_L]           (S1-13, S1-21)
    then ``newton`` optional corrections q <- q + J+(q) (x_d[k] - x(q)), then the joint limits.

Choices this module makes where the seed is silent (SPEC section 6 lets us choose):

* **Damping rule.** With ``A = J J^T`` (m x m), the isotropy ``nu = det A / (tr A / m)^m`` is in
  [0, 1]: 1 for an isotropic Jacobian, 0 at a singularity, scale-free (for m = 2 it is about
  ``4 sigma_min^2 / sigma_max^2`` near a singularity). It is a product of m ratios, so it is
  compared with ``nu_th = nu0^(m/2)`` (1e-2 for m = 2, 1e-3 for m = 3, 1e-6 for m = 6 with the
  default ``nu0 = 1e-2``; for the 6-row task this also allows for rows in m/rad next to rows in
  rad/rad). Below ``nu_th`` the damping ``lam^2 = damping^2 * (tr A / m) * (1 - nu / nu_th)^2``
  switches on (a Nakamura-Hanafusa style rule, made scale-free by ``tr A / m``); above it
  ``lam = 0`` and ``J+`` is the exact Moore-Penrose inverse (S1-16). ``lam^2`` and its first
  derivative are continuous at ``nu_th``. Status bit :data:`STATUS_DAMPED` marks the steps where
  it is active. While damped, ``I - J+ J`` is no longer an exact projector; the closed loop pulls
  the TCP back.
* **Guard of |dq_N| -> 0.** ``|dq_N|`` is replaced by ``max(|dq_N|, null_eps)``: the null step
  has length beta (constant) or ``beta |dq_P|`` (adaptive) while the projected gradient is larger
  than ``null_eps``, and shrinks to plain projected gradient descent below it; at ``dq_N = 0``
  exactly it is zero. Norms use the double-``where`` trick, so values and gradients stay finite.
  With no more movable joints than task rows (a non-redundant arm, or too many joints frozen at
  their limits in a step) there is no null space: ``(I - J+ J) grad u`` is round-off or, damped,
  a leftover that the adaptive rule would scale up to ``|dq_P|``; the null step is then zero
  (status :data:`STATUS_NULL_SMALL`). In the adaptive rule ``|dq_P|`` below ``10 eps`` counts as 0:
  a path that starts at the TCP sits on the kink of ``|dq_P|`` at ``dx = 0``, and the derivative
  there is then the symmetric one (central differences'), not a side picked by the FK's round-off.
  Default ``null_eps = 1e-9 * |K_xd|_F * 1 m^2`` (1e-5 in float32) plus a floor of ``tiny^(1/4)``
  (1e-77 in float64: derivatives stay finite at K_xd = 0). Status :data:`STATUS_NULL_SMALL`.
* **Joint limits.** Optional lower-priority secondary task (``joint_limits="priority"``): the
  Liegeois cost ``h = 1/2 sum_i (q_i - c_i)^2 / h_i`` (c_i the middle, h_i the half range of
  joint i, joints with finite limits only) gives ``dq_L = -jl_gain * grad h``; it is projected into
  the null space of the path task and then made orthogonal to ``dq_N`` (the null space of the
  path + CSC tasks), so it never disturbs them, and it does nothing when the arm has only one
  redundant degree of freedom. ``joint_limits="sum"`` instead adds it to the CSC gradient (a
  weighted sum, projected into the path task's null space only), which trades some ``u`` for
  distance from the limits. Independently of both, every free joint is clamped to its limits
  after each step (status :data:`STATUS_JOINT_LIMIT`). Saturation inside a step: the joints that
  the step would push past a limit go exactly to it and are frozen, and the other joints solve
  the step again; a joint that this re-solve pushes out is frozen in turn (up to three rounds),
  so the tracking step is not cut by the final clamp. Known limit: a frozen joint is not released
  within the step, i.e. this is not a full active set. From a start with joints at their limits,
  where lowering u needs one of them to move back inward, the arm can stall (status 2 + 8 on
  every step); and where the path, with the frozen joints held at their limits, leaves the reach
  of the other joints, the TCP falls behind it (millimetres for some steps; the tracking error
  says so): each step is linear, and to first order the other joints can still follow, so
  nothing tells the frozen joint to move back inward (an active set on the linear step, tried,
  does not see it either). Start inside the limits, or use ``joint_limits="priority"`` to keep
  the arm off them.
* **Locked joints** never move: their Jacobian columns are zeroed for motion and their entries of
  ``q0`` are replaced by the locked values. They keep their springs: ``u``, the realised joint
  stiffness and ``K_C`` use the full Jacobian.
* **Realised stiffness.** ``kj = clip(diag(J^T K_xd J), kmin, kmax)`` (the uni-articular part of
  S1-8), ``K_C = (J diag(1/kj) J^T)^-1`` (S0-4, :func:`jaxstiff.cartesian_stiffness`), and
  ``|K_xd - K_C|_F`` (S1-10). Default actuator range ``[1, inf)`` Nm/rad.
* **Task rows.** ``"xy"`` (planar arms, 2-D targets), ``"xyz"`` (position, 3-D targets), ``"full"``
  (position follows the path, the tool orientation is held at its orientation in ``q0``; the
  orientation error is ``1/2 sum_i r_i x r_d,i``, the columns of the current and held rotation).
  By default the task follows from ``K_xd``'s size (2 -> xy, 3 -> xyz, 6 -> full).

* **grad u.** ``u`` is :func:`jaxstiff.offdiag`; its gradient is ``jax.grad`` of ``offdiag`` with
  respect to the task Jacobian, chained through ``J(q)`` by the closed-form derivative of the
  geometric Jacobian (:func:`_offdiag_value_and_grad`; equal to ``jax.grad`` of ``u(q)`` through the
  kinematics to round-off, tested, and about 5x cheaper). The kinematics inside the rollout carry
  a closed-form JVP built from J alone, so differentiating a rollout never sweeps the chain
  kernel backwards.

The rollout is differentiable end to end (``jax.grad`` w.r.t. ``beta``, ``q0``, ``K_xd`` and the
numeric settings), batched over leading axes of every input (``vmap``), and jitted once per robot,
task and static setting. With ``remat=True`` (default) the scan body is rematerialised in the
backward pass, so the memory of a gradient grows with ``T * n`` per rollout only.

Speed (``scripts/bench_csc.py``, 2-core CPU, float64, 1024 rollouts x 1000 steps of the LWR, chunk
128, jaxstiff's XLA options; the machine is shared, so ranges of repeated runs): forward
0.68-1.49 s, forward + gradient 2.7-3.7 s, 2.3-4.7x the forward over the runs of 2026-12-01/02
(mostly 3.1-3.7x; goal 3x: not met reliably). What makes it so:

* hand-written VJPs, each installed as a custom JVP that is its transpose (forward mode and
  hessians keep working): ``(u, grad u)`` (:func:`_offdiag_value_and_grad`), the step's
  projections ``J+ dx``, ``(I - J+ J) v`` with the damping rule (:func:`_damped_projections`), and
  the realised stiffness (:func:`_realised_stiffness`); closed-form JVPs of the small det and
  inverse and of the kinematics (from J alone);
* the saturation re-solve runs only in a chunk where some rollout reaches a limit: a
  ``lax.cond`` whose predicate is reduced over the named ``vmap`` axis of the chunk, so it stays a
  branch (under a caller's own ``vmap`` it becomes a select: same values, no saving); the branch
  is rematerialised on its own, else the linearised cond carries both branches' residuals;
* a constant ``K_xd`` is a constant of the time loop, not a per-step sequence (no (T + 1, m, m)
  buffers per rollout for it and its cotangent);
* the joint cosines and sines from :func:`jaxstiff.kinematics.cos_sin` (a batch of >= 64
  rollouts) and running sums unrolled (``jnp.cumsum`` is an unfusable reduce-window on CPU).

The gradient's parts (profile of the compiled program, 128 x 1000; ``jax.named_scope`` names
``csc_kinematics``, ``csc_offdiag``, ``csc_measures``, ``csc_solve``, ``csc_resolve``): the forward
pass ~1x, the recomputed step ~1-1.4x, its transpose ~1.5-2x. Kernels are a few microseconds
each, so their number counts as much as their arithmetic. Tried without gain: saving the
kinematics, the realised-stiffness, projection or ``(u, grad u)`` residuals (named inside the custom
JVP rules, so the rematerialised step really skips them) instead of recomputing them, no remat
(the residual stores cost more than the recomputation), the step written entry-wise (structure of
arrays: 4x fewer forward kernels, but XLA:CPU splits its transpose into ~500 tiny ones), cumsum
as a triangular product, a fusion boundary in the ``(u, grad u)`` VJP (XLA fuses its nested sums
into one loop that re-evaluates the inner ones per output entry; the boundary costs what it saves),
fusion boundaries after the kinematics, after ``(u, grad u)`` or after the solve (10-40% slower),
and no remat with every residual of a step packed into one array (~1090 numbers per rollout and
step: 3.8x slower than recomputing; storing is bound by memory traffic, not by kernel count). A
bound from an ablation (128 x 1000, the three hand-written VJPs replaced by near-free stand-ins):
the gradient would still take ~2.8x the forward, so the remaining cost is the recomputed step and
the transposes of the glue between them, not any one block. The step is compute-bound: a
rollout-step costs the same (~1.0 us) run sequentially (a scan of 1000 steps) or all at once
(64000 postures, one step, chunks of 128 to 8192), so recomputing the residuals of every step in
one batched pass would save nothing either.

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
import inspect
import math
from typing import Any, NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from jaxstiff.runtime.xla import kernel_compiler_options
from jaxstiff._numerics.batch import broadcast_batch
from jaxstiff._numerics.linalg import mm
from jaxstiff._numerics.safe import safe_sqrt
from jaxstiff.stiffness.criteria import offdiag, offdiag_of
from jaxstiff.model.kinematics import POLY_MIN_BATCH, cross_cols, fk_and_jacobian_raw, position_and_jacobian_raw, running_sum, tangent_from_sums, tangent_sums, jacobian_tangent, position_and_jacobian
from jaxstiff.model.robot import Robot
from jaxstiff.stiffness.core import TASK_ROWS, cartesian_stiffness, check_task_feasible

__all__ = [
    "CSCResult",
    "csc_rollout",
    "null_space_direction",
    "offdiag_gradient",
    "project_to_target",
    "STATUS_OK",
    "STATUS_DAMPED",
    "STATUS_JOINT_LIMIT",
    "STATUS_NAN",
    "STATUS_NULL_SMALL",
    "describe_status",
]

STATUS_OK = 0  #: a plain step
STATUS_DAMPED = 1  #: isotropy below ``nu0^(m/2)``: the damped pseudo-inverse was active (near singular)
STATUS_JOINT_LIMIT = 2  #: a free joint was clamped at its limit after the step
STATUS_NAN = 4  #: the step came out non-finite and was replaced by no motion
STATUS_NULL_SMALL = 8  #: ``|dq_N| < null_eps``: at a stationary point of u on the self-motion manifold

_STATUS_NAMES = {
    STATUS_DAMPED: "damped (near singular)",
    STATUS_JOINT_LIMIT: "joint limit reached",
    STATUS_NAN: "NaN guard (step dropped)",
    STATUS_NULL_SMALL: "null-space gradient below null_eps",
}

_M_TO_TASK = {2: "xy", 3: "xyz", 6: "full"}


def describe_status(code: int) -> str:
    """Human-readable text of a status bit mask (``0`` -> ``"ok"``)."""
    code = int(code)
    if code == 0:
        return "ok"
    return ", ".join(name for bit, name in _STATUS_NAMES.items() if code & bit)


@jax.tree_util.register_dataclass
@dataclasses.dataclass(frozen=True)
class CSCResult:
    """One or a batch of CSC rollouts. Leading axes ``*B`` are the broadcast batch of the inputs.

    Row ``k`` of every per-step array describes the posture reached by step ``k``, i.e. after the
    arm was sent towards waypoint ``k``, measured against waypoint ``k``'s target and ``K_xd``.

    Attributes:
        q: (*B, T, n) joint values (rad; m for prismatic), locked joints included.
        u: (*B, T) off-diagonal norm ``u(q)`` of ``J^T K_xd J`` (S1-19), Nm/rad.
        frobenius: (*B, T) ``|K_xd - K_C|_F`` (S1-10) with the realised ``K_C``.
        tracking_error: (*B, T) ``|x_d - x(q)|`` over the task's position rows, m.
        orientation_error: (*B, T) angle of the held-orientation error (task ``"full"``), rad; 0 otherwise.
        kj: (*B, T, n) realised joint stiffness ``clip(diag(J^T K_xd J), kmin, kmax)``, Nm/rad.
        K_C: (*B, T, m, m) realised Cartesian stiffness (S0-4) from ``kj``.
        position: (*B, T, 3) TCP position, m, base frame.
        target: (*B, T, d) the path targets used (d = 2 for ``"xy"``, else 3), m.
        isotropy: (*B, T) ``nu = det(J J^T) / (tr(J J^T)/m)^m`` of the free joints, in [0, 1].
        null_step: (*B, T) length of the null-space step ``|alpha dq_N|`` taken in step k, rad.
        status: (*B, T) int32 bit mask of :data:`STATUS_DAMPED`, :data:`STATUS_JOINT_LIMIT`,
            :data:`STATUS_NAN`, :data:`STATUS_NULL_SMALL` (0 = plain step) of step k, the step that
            reached row k's posture. It was computed at the posture before it, so its
            :data:`STATUS_DAMPED` goes with ``isotropy`` of row k - 1 (of the start posture for k = 0).
        u_start: (*B,) ``u`` at the start posture (with the first waypoint's ``K_xd``).
        frobenius_start: (*B,) ``|K_xd - K_C|_F`` at the start posture.
    """

    q: jax.Array
    u: jax.Array
    frobenius: jax.Array
    tracking_error: jax.Array
    orientation_error: jax.Array
    kj: jax.Array
    K_C: jax.Array
    position: jax.Array
    target: jax.Array
    isotropy: jax.Array
    null_step: jax.Array
    status: jax.Array
    u_start: jax.Array
    frobenius_start: jax.Array

    def as_dict(self) -> dict[str, Any]:
        """The fields as a ``{name: array}`` dict (numpy-convertible)."""
        return {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}


# ------------------------------------------------------------------------ small dense algebra
# Written as broadcast-multiply-and-sum so that XLA fuses them over the batch (a batch of tiny
# dot products is slow on a CPU); m, n <= 7.
def _mv(A: jax.Array, x: jax.Array) -> jax.Array:
    """(..., a, b) @ (..., b) -> (..., a)."""
    return jnp.sum(A * x[..., None, :], axis=-1)


def _mtv(A: jax.Array, x: jax.Array) -> jax.Array:
    """(..., a, b)^T @ (..., a) -> (..., b)."""
    return jnp.sum(A * x[..., :, None], axis=-2)


def _safe_norm(x: jax.Array) -> jax.Array:
    """Euclidean norm over the last axis with a finite gradient at 0 (double ``where``)."""
    return safe_sqrt(jnp.sum(x * x, axis=-1))


def _det_cofactors(A: jax.Array):
    """``det A`` and its cofactor matrix (= ``d det / dA``) for m = 2, 3, entry-wise closed forms."""
    m = A.shape[-1]
    c = [[A[..., i, j] for j in range(m)] for i in range(m)]
    if m == 2:
        cof = [[c[1][1], -c[1][0]], [-c[0][1], c[0][0]]]
    else:
        cof = [[c[(i + 1) % 3][(j + 1) % 3] * c[(i + 2) % 3][(j + 2) % 3]
                - c[(i + 1) % 3][(j + 2) % 3] * c[(i + 2) % 3][(j + 1) % 3] for j in range(3)] for i in range(3)]
    det = sum(c[0][j] * cof[0][j] for j in range(m))
    return det, jnp.stack([jnp.stack(r, -1) for r in cof], -2)


@jax.custom_jvp
def _det_small(A: jax.Array) -> jax.Array:
    """``det A`` of (..., m, m), m = 2, 3 (closed form) or larger (LU).

    JVP ``d det = sum_ij cof_ij dA_ij`` with the cofactors from the primal pass: reverse mode
    through it is one multiply-and-sum, not the transpose of the entry-wise formula (whose
    slices become pads of whole arrays in the backward pass of a rollout).
    """
    if A.shape[-1] in (2, 3):
        return _det_cofactors(A)[0]
    return jnp.linalg.det(A)


@_det_small.defjvp
def _det_small_jvp(primals, tangents):
    (A,), (dA,) = primals, tangents
    if A.shape[-1] not in (2, 3):
        return jax.jvp(jnp.linalg.det, (A,), (dA,))
    det, cof = _det_cofactors(A)
    return det, jnp.sum(cof * dA, axis=(-2, -1))


def _spd_inverse_primal(A: jax.Array) -> jax.Array:
    m = A.shape[-1]
    if m in (2, 3):
        det, cof = _det_cofactors(A)
        return jnp.swapaxes(cof, -1, -2) / det[..., None, None]  # adjugate / det
    L = jnp.linalg.cholesky(A)
    eye = jnp.broadcast_to(jnp.eye(m, dtype=A.dtype), A.shape)
    return jax.scipy.linalg.cho_solve((L, True), eye)


@jax.custom_jvp
def _spd_inverse(A: jax.Array) -> jax.Array:
    """Inverse of a symmetric positive-definite (..., m, m): adjugate for m = 2, 3, Cholesky else.

    JVP ``d(A^-1) = -A^-1 dA A^-1`` (two small products), for the same reason as :func:`_det_small`.
    """
    return _spd_inverse_primal(A)


@_spd_inverse.defjvp
def _spd_inverse_jvp(primals, tangents):
    (A,), (dA,) = primals, tangents
    Ai = _spd_inverse_primal(A)
    return Ai, -mm(mm(Ai, dA), Ai)


def _offdiag_value_and_grad(J6: jax.Array, K_xd: jax.Array, rows: tuple[int, ...]):
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
    but costs about a fifth of it, and its own derivative (needed by the gradient of a rollout)
    about a tenth, and it compiles to a much smaller program.

    Reverse mode uses a hand-written VJP (:func:`_offdiag_vjp_bwd`): with ``Gb`` the cotangent of
    G, the chain through the contraction above is ``Gb6 = dJ6[gb]`` (the directional derivative
    of J along the cotangent ``gb`` of g, :func:`jacobian_tangent`) plus a J6 cotangent built
    from the same prefix/suffix sums; the rest is the Hessian-vector product of u along ``Gb``
    (G is u's gradient), in closed form with m x n x n products (see the VJP's comments). It is
    installed as a custom JVP whose tangent map is the VJP's transpose (:func:`_offdiag_jvp`), so
    forward mode keeps working. Equal to autodiff of this function to round-off (tested); it took
    the gradient of ``scripts/bench_csc.py`` from 4.8-5.0 s to 4.0-4.2 s.
    """
    u, g, _ = _offdiag_forward(J6, K_xd, rows)
    return u, g


def _offdiag_forward(J6, K_xd, rows):
    m = len(rows)
    J = J6[..., :m, :]
    KJ = _mtv_cols(K_xd, J)  # (m, n)
    Kq = jnp.sum(J[..., :, :, None] * KJ[..., :, None, :], axis=-3)  # J^T K J (n, n)
    n = Kq.shape[-1]
    u = offdiag_of(Kq)  # offdiag(J, K_xd) from the same J^T K J
    M = Kq * (1.0 - jnp.eye(n, dtype=Kq.dtype))
    pos = u > 0
    inv_u = jnp.where(pos, 1.0 / jnp.where(pos, u, 1.0), 0.0)
    G = jnp.sum(KJ[..., :, :, None] * M[..., None, :, :], axis=-2) * inv_u[..., None, None]  # (m, n)
    G6 = jnp.concatenate([G, jnp.zeros_like(J6[..., m:, :])], axis=-2)
    Jv, Jw, Gv, Gw = J6[..., :3, :], J6[..., 3:, :], G6[..., :3, :], G6[..., 3:, :]
    a = cross_cols(Jv, Gv) + cross_cols(Jw, Gw)  # (3, n): term of joint i
    suffix = running_sum(a, reverse=True, exclusive=True)  # sum over i > k
    prefix = running_sum(cross_cols(Gv, Jw))  # sum over i <= k
    g = jnp.sum(Jw * suffix, axis=-2) + jnp.sum(Jv * prefix, axis=-2)
    return u, g, (J6, K_xd, KJ, Kq, M, inv_u, G6, prefix, suffix)


def _offdiag_vjp_bwd(rows, res, cts):
    """VJP of ``(u, g)`` w.r.t. ``(J6, K_xd)`` (derivation: :func:`_offdiag_value_and_grad`)."""
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
    # rule through K J, J^T K J and K J M (1.7x faster on its own, ~10% of a rollout's gradient).
    J = J6[..., :m, :]
    T = T6[..., :m, :]
    G = G6[..., :m, :]
    c = ub - s * jnp.sum(G * T, axis=(-2, -1))
    X = T + c[..., None, None] * J
    Y = jnp.sum(X[..., :, :, None] * M[..., None, :, :], axis=-2)  # (T + c J) M  (m, n)
    W = jnp.sum(P[..., :, :, None] * T[..., :, None, :], axis=-3)  # P^T T (n, n)
    Wo = W * (1.0 - jnp.eye(n, dtype=W.dtype))
    S = Wo + jnp.swapaxes(Wo, -1, -2)
    Jb = s[..., None, None] * (_mtv_cols(K, Y) + jnp.sum(P[..., :, :, None] * S[..., None, :, :], axis=-2))
    lower = jnp.tril(jnp.ones((n, n), dtype=W.dtype), k=-1)
    Z = Y + jnp.sum(J[..., :, :, None] * (Wo - c[..., None, None] * lower * M)[..., None, :, :], axis=-2)
    Kb = s[..., None, None] * jnp.sum(Z[..., :, None, :] * J[..., None, :, :], axis=-1)
    J6b = jnp.concatenate([Jvb, Jwb], axis=-2)
    J6b = J6b + jnp.concatenate([Jb, jnp.zeros_like(J6[..., m:, :])], axis=-2)
    return J6b, Kb


def _offdiag_jvp(rows, primals, tangents):
    """Forward mode through the transpose of the hand-written VJP (a linear map of the cotangents):
    JVP and VJP then agree exactly, forward mode (``jax.jvp``, ``jax.hessian``) keeps working, and
    reverse mode transposes that map back into the VJP's own arithmetic."""
    (J6, K), (dJ6, dK) = primals, tangents
    u, g, res = _offdiag_forward(J6, K, rows)
    lin = jax.linear_transpose(lambda ub, gb: _offdiag_vjp_bwd(rows, res, (ub, gb)), u, g)
    du, dg = lin((dJ6, dK))
    return (u, g), (du, dg)


_offdiag_value_and_grad = jax.custom_jvp(_offdiag_value_and_grad, nondiff_argnums=(2,))
_offdiag_value_and_grad.defjvp(_offdiag_jvp)


@functools.partial(jax.custom_jvp, nondiff_argnums=(0, 1))
def _pos_jac(robot: Robot, poly: bool, q: jax.Array):
    """``position_and_jacobian(robot, q)`` (all 6 rows) with a closed-form JVP.

    The JVP needs only the Jacobian itself (:func:`jacobian_tangent`), so reverse mode through a
    rollout never differentiates the kinematics kernel's internals: the backward pass of a step
    costs a few cross products instead of a reverse sweep through the chain.
    """
    return position_and_jacobian_raw(robot, q, poly=poly)


@_pos_jac.defjvp
def _pos_jac_jvp(robot, poly, primals, tangents):
    (q,), (qd,) = primals, tangents
    p, J6 = _pos_jac(robot, poly, q)
    dp, dJ6, _ = jacobian_tangent(J6, qd)
    return (p, J6), (dp, dJ6)


@functools.partial(jax.custom_jvp, nondiff_argnums=(0, 1))
def _pose_jac(robot: Robot, poly: bool, q: jax.Array):
    """``(p (3,), R (3, 3), J6 (6, n))`` from ``fk_and_jacobian`` with a closed-form JVP."""
    T, J6 = fk_and_jacobian_raw(robot, q, poly=poly)
    return T[..., :3, 3], T[..., :3, :3], J6


@_pose_jac.defjvp
def _pose_jac_jvp(robot, poly, primals, tangents):
    (q,), (qd,) = primals, tangents
    p, R, J6 = _pose_jac(robot, poly, q)
    dp, dJ6, om = jacobian_tangent(J6, qd)
    dR = cross_cols(jnp.broadcast_to(om[..., :, None], R.shape), R)  # omega x each column of R
    return (p, R, J6), (dp, dR, dJ6)


def offdiag_gradient(robot: Robot, q, K_xd, task: str | None = None):
    """``(u(q), grad u(q))`` of the off-diagonal norm (S1-19) at postures q (..., n), K_xd (..., m, m).

    Uses the rollout's own closed-form routine (:func:`_offdiag_value_and_grad`); ``jax.grad`` of
    ``offdiag(J_s(q), K_xd)`` through the kinematics gives the same numbers, slower. Jitted per
    robot and task.

    Returns:
        ``u (...,)`` in Nm/rad and ``grad u (..., n)`` in Nm/rad^2 (locked joints included).
    """
    q = jnp.asarray(q)
    K_xd = jnp.asarray(K_xd, dtype=q.dtype)
    return _offdiag_gradient(robot, task or _M_TO_TASK[K_xd.shape[-1]], q, K_xd)


@functools.partial(jax.jit, static_argnums=(0, 1))
def _offdiag_gradient(robot: Robot, task: str, q, K_xd):
    rows = TASK_ROWS[task]
    _, J6 = position_and_jacobian(robot, q)
    batch = jnp.broadcast_shapes(q.shape[:-1], K_xd.shape[:-2])
    J6 = jnp.broadcast_to(J6, batch + J6.shape[-2:])
    K_xd = jnp.broadcast_to(K_xd, batch + K_xd.shape[-2:])
    f = lambda J, K: _offdiag_value_and_grad(J, K, rows)  # noqa: E731 (rows positional: a custom_jvp's nondiff arg)
    for _ in batch:
        f = jax.vmap(f)
    return f(J6, K_xd)


@dataclasses.dataclass(frozen=True)
class _Static:
    """Settings that shape the compiled program (hashable, a static jit argument)."""

    task: str
    step: str
    newton: int
    joint_limits: str
    remat: bool
    varying: bool
    poly: bool = False  # joint cos/sin from kinematics.cos_sin (a CPU batch of >= 64 rollouts)


def _damped_pinv(Jf: jax.Array, nu0, damping):
    """Damped pseudo-inverse of the free-joint task Jacobian (m, n) -> (J+ (n, m), nu, damped)."""
    Ainv, nu, damped = _damped_inverse(Jf, nu0, damping)
    Jp = jnp.sum(Jf[..., :, :, None] * Ainv[..., :, None, :], axis=-3)  # J^T A^-1, (n, m)
    return Jp, nu, damped


def _damped_inverse(Jf: jax.Array, nu0, damping):
    """``(J J^T + lam^2 I)^-1`` (m, m) of the damping rule (module docstring), isotropy nu, damped flag."""
    d = _damping_rule(Jf, nu0, damping)
    return _spd_inverse(d.A), d.nu, d.damped


class _Damping(NamedTuple):
    A0: jax.Array  # J J^T
    A: jax.Array  # J J^T + lam^2 I (I where J = 0)
    scale: jax.Array  # tr(J J^T) / m
    safe_scale: jax.Array
    pos: jax.Array  # scale > 0
    nu_raw: jax.Array  # det(J J^T) / scale^m
    nu: jax.Array  # the isotropy, in [0, 1]
    thr: jax.Array  # nu0^(m/2)
    damped: jax.Array  # nu < thr
    t: jax.Array  # 1 - nu / thr
    w: jax.Array  # t^2 where damped, else 0: lam^2 = damping^2 scale w


def _isotropy_threshold(nu0, m: int):
    """``nu_th = nu0^(m/2)``: nu0 for m = 2, nu0^1.5 for m = 3, nu0^3 for m = 6 (module docstring)."""
    return nu0 ** (m / 2.0)


def _damping_rule(Jf: jax.Array, nu0, damping) -> _Damping:
    """The damping rule of the module docstring for a task Jacobian Jf (m, n), term by term."""
    m = Jf.shape[-2]
    A0 = jnp.sum(Jf[..., :, None, :] * Jf[..., None, :, :], axis=-1)  # J J^T
    scale = jnp.trace(A0, axis1=-2, axis2=-1) / m
    pos = scale > 0
    safe_scale = jnp.where(pos, scale, 1.0)
    nu_raw = _det_small(A0) / safe_scale**m
    nu = jnp.where(pos, jnp.clip(nu_raw, 0.0, 1.0), 0.0)
    thr = _isotropy_threshold(nu0, m)
    damped = nu < thr
    t = 1.0 - nu / thr
    w = jnp.where(damped, t * t, 0.0)
    lam2 = damping**2 * scale * w + jnp.finfo(Jf.dtype).tiny * 1e3
    eye = jnp.eye(m, dtype=Jf.dtype)
    # J = 0 (every joint frozen): any A gives J+ = 0; I keeps the inverse finite (tiny I underflows)
    A = jnp.where(pos[..., None, None], A0 + lam2[..., None, None] * eye, eye)
    return _Damping(A0, A, scale, safe_scale, pos, nu_raw, nu, thr, damped, t, w)


def _damped_projections(Jf: jax.Array, dx: jax.Array, vs: tuple, nu0, damping):
    """``(J+ dx, tuple((I - J+ J) v for v in vs), nu)`` with ``J+ = J^T (J J^T + lam^2 I)^-1`` of the
    damping rule (module docstring; :func:`_damped_inverse` gives the same ``(J J^T + lam^2 I)^-1``)
    and the isotropy ``nu``, for the free-joint task Jacobian ``Jf`` (m, n), dx (m,), vs of (n,).

    The core of a CSC step, with a hand-written VJP (:func:`_projections_vjp`): with the
    forward's ``y = A^-1 dx`` and ``z = A^-1 J v`` (``A = J J^T + lam^2 I``), the cotangents
    ``dqP_b``, ``Pv_b`` give ``dx_b = A^-1 J dqP_b``, ``r_b = -A^-1 J Pv_b``, ``v_b = Pv_b + J^T r_b``,
    ``A_b = -dx_b y^T - sum r_b z^T`` (no matrix product: ``A^-1`` is symmetric), and
    ``J_b = y dqP_b^T + sum (r_b v^T - z Pv_b^T) + (A0_b + A0_b^T) J`` where ``A0_b`` adds to
    ``A_b`` the damping rule's chain (``lam^2`` through ``tr A0 / m`` and ``nu = det A0 / (tr A0 /
    m)^m``, the determinant's cofactors; zero while undamped). It is installed, like
    :func:`_offdiag_value_and_grad`'s, as a custom JVP that is its transpose, so forward mode keeps
    working and reverse mode runs the VJP's own arithmetic (fewer, larger kernels than the
    transpose of the forward formulas).
    """
    dqP, Pvs, nu, _ = _projections_forward(Jf, dx, vs, nu0, damping)
    return dqP, Pvs, nu


def _projections_forward(Jf, dx, vs, nu0, damping):
    d = _damping_rule(Jf, nu0, damping)
    cof = _det_cofactors(d.A0)[1] if Jf.shape[-2] in (2, 3) else None  # d det / dA0 (XLA shares it with det)
    Ainv = _spd_inverse_primal(d.A)
    y = _mv(Ainv, dx)
    dqP = _mtv(Jf, y)
    zs = tuple(_mv(Ainv, _mv(Jf, v)) for v in vs)
    Pvs = tuple(v - _mtv(Jf, z) for v, z in zip(vs, zs))
    return dqP, Pvs, d.nu, (Jf, d, cof, Ainv, y, zs, vs, nu0, damping)


def _outer(a: jax.Array, b: jax.Array) -> jax.Array:
    return a[..., :, None] * b[..., None, :]


def _projections_vjp(res, cts):
    """VJP of :func:`_damped_projections` w.r.t. ``(Jf, dx, vs, nu0, damping)`` (derivation there)."""
    Jf, d, cof, Ainv, y, zs, vs, nu0, damping = res
    A0, scale, safe_scale, pos, nu_raw, nu, damped, t, w, thr = (
        d.A0, d.scale, d.safe_scale, d.pos, d.nu_raw, d.nu, d.damped, d.t, d.w, d.thr)
    dqP_b, Pv_bs, nu_b = cts
    m = Jf.shape[-2]
    dx_b = _mv(Ainv, _mv(Jf, dqP_b))
    J_b = _outer(y, dqP_b)
    A_b = -_outer(dx_b, y)
    vs_b = []
    for v, z, Pv_b in zip(vs, zs, Pv_bs):
        r_b = -_mv(Ainv, _mv(Jf, Pv_b))
        J_b = J_b + _outer(r_b, v) - _outer(z, Pv_b)
        A_b = A_b - _outer(r_b, z)
        vs_b.append(Pv_b + _mtv(Jf, r_b))
    # A = A0 + lam2 I, lam2 = damping^2 scale w (+ tiny), w = t^2 (damped), t = 1 - nu / thr
    lam2_b = jnp.trace(A_b, axis1=-2, axis2=-1)
    damping_b = lam2_b * 2.0 * damping * scale * w
    scale_b = lam2_b * damping**2 * w
    t_b = jnp.where(damped, 2.0 * t * lam2_b * damping**2 * scale, 0.0)
    nu_b = nu_b - t_b / thr
    thr_b = t_b * nu / (thr * thr)
    nu0_b = thr_b * (m / 2.0) * nu0 ** (m / 2.0 - 1.0)
    # nu = clip(det / scale^m, 0, 1) where scale > 0
    nr_b = jnp.where(pos & (nu_raw > 0) & (nu_raw < 1), nu_b, 0.0)
    det_b = nr_b / safe_scale**m
    scale_b = scale_b - m * nr_b * nu_raw / safe_scale
    if cof is not None:
        det_grad = det_b[..., None, None] * cof
    else:
        det_grad = jax.vjp(jnp.linalg.det, A0)[1](det_b)[0]
    A0_b = A_b + det_grad + (scale_b / m)[..., None, None] * jnp.eye(m, dtype=A0.dtype)
    J_b = J_b + mm(A0_b + jnp.swapaxes(A0_b, -1, -2), Jf)
    return J_b, dx_b, tuple(vs_b), nu0_b, damping_b


_damped_projections = jax.custom_jvp(_damped_projections)


@_damped_projections.defjvp
def _damped_projections_jvp(primals, tangents):
    """Forward mode as the transpose of :func:`_projections_vjp` (see :func:`_offdiag_jvp`)."""
    dqP, Pvs, nu, res = _projections_forward(*primals)
    lin = jax.linear_transpose(lambda *cts: _projections_vjp(res, cts), dqP, Pvs, nu)
    return (dqP, Pvs, nu), lin(tuple(tangents))


def _realised_stiffness(J: jax.Array, kj: jax.Array, K_xd: jax.Array, task: str):
    """``K_C = cartesian_stiffness(J, kj, task)`` (m, m) and ``|K_xd - K_C|_F`` (S1-10).

    With a hand-written VJP (:func:`_realised_vjp`; :func:`cartesian_stiffness`'s JVP rule
    ``dK_C = -K_C dC K_C``, damping held, and ``C = J diag(1/kj) J^T``): with ``E = K_xd - K_C``,
    ``E_b = f_b E / |E|_F``, ``S = sym(KC_b - E_b)`` and ``C_b = -K_C S K_C``, the cotangents are
    ``J_b = 2 C_b J diag(1/kj)``, ``kj_b = -diag(J^T C_b J) / kj^2`` and ``K_xd_b = E_b``: four
    small products instead of the transpose of the factorisation's JVP and of the compliance's
    entry-wise rows. Installed as a custom JVP that is its transpose (see :func:`_offdiag_jvp`).
    """
    K_C, frob, _ = _realised_forward(J, kj, K_xd, task)
    return K_C, frob


def _realised_forward(J, kj, K_xd, task):
    K_C = cartesian_stiffness(J, kj, task)
    E = K_xd - K_C
    frob = safe_sqrt(jnp.sum(E * E, axis=(-2, -1)))  # as criteria.frobenius
    floor = jnp.sqrt(jnp.finfo(J.dtype).tiny)  # compliance's floor of kj (stiffness._joint_stiffness_array)
    return K_C, frob, (J, jnp.maximum(kj, floor), kj > floor, K_C, E, frob > 0, frob)


def _realised_vjp(task, res, cts):
    """VJP of :func:`_realised_stiffness` w.r.t. ``(J, kj, K_xd)`` (derivation there)."""
    J, kj, kj_free, K_C, E, pos, frob = res
    KC_b, f_b = cts
    E_b = (jnp.where(pos, f_b / jnp.where(pos, frob, 1.0), 0.0))[..., None, None] * E
    S = KC_b - E_b
    S = 0.5 * (S + jnp.swapaxes(S, -1, -2))
    CbJ = -mm(mm(K_C, S), mm(K_C, J))  # C_b J, C_b = -K_C S K_C (symmetric)
    inv_kj = 1.0 / kj
    J_b = 2.0 * CbJ * inv_kj[..., None, :]
    kj_b = jnp.where(kj_free, -jnp.sum(J * CbJ, axis=-2) * inv_kj * inv_kj, 0.0)
    return J_b, kj_b, E_b


_realised_stiffness = jax.custom_jvp(_realised_stiffness, nondiff_argnums=(3,))


@_realised_stiffness.defjvp
def _realised_jvp(task, primals, tangents):
    K_C, frob, res = _realised_forward(*primals, task)
    lin = jax.linear_transpose(lambda a, b: _realised_vjp(task, res, (a, b)), K_C, frob)
    return (K_C, frob), lin(tuple(tangents))


def _orientation_error(R: jax.Array, Rd: jax.Array) -> jax.Array:
    """``1/2 sum_i r_i x r_d,i`` (base frame, rad for small errors): rotates R towards Rd."""
    return 0.5 * jnp.sum(jnp.cross(R, Rd, axisa=-2, axisb=-2, axisc=-1), axis=-2)


def _orientation_angle(R: jax.Array, Rd: jax.Array) -> jax.Array:
    """Angle (rad, in [0, pi]) of the rotation from R to Rd. ``|_orientation_error|`` is its sine
    and ``(tr(R^T Rd) - 1) / 2`` its cosine; atan2 of the two is accurate at every angle (arccos
    of the cosine alone loses half the digits near 0), with a finite gradient at 0."""
    return jnp.arctan2(_safe_norm(_orientation_error(R, Rd)), 0.5 * (jnp.sum(R * Rd, axis=(-2, -1)) - 1.0))


def _rollout_one(robot: Robot, st: _Static, axis_name: str, targets, K_xd, q0, beta, kmin, kmax, nu0, damping, null_eps,
                 jl_gain, R_hold=None):
    """One rollout. targets (T, d), K_xd (T, m, m) or (m, m), q0 (n,), beta (), R_hold (3, 3) or
    None (task "full": the orientation held; None: q0's). See csc_rollout.
    Runs under ``vmap(axis_name=axis_name)`` over the rollouts of a chunk."""
    dtype = q0.dtype
    rows = TASK_ROWS[st.task]
    full = st.task == "full"
    d = targets.shape[-1]
    free = jnp.asarray(robot.free, dtype=dtype)
    free_b = np.asarray(robot.free)
    lock_vals = jnp.asarray(np.nan_to_num(robot.locked_values), dtype=dtype)
    q0 = jnp.where(free_b, q0, lock_vals)
    lower = jnp.asarray(np.where(free_b, robot.lower, -np.inf), dtype=dtype)
    upper = jnp.asarray(np.where(free_b, robot.upper, np.inf), dtype=dtype)
    lo_f, hi_f = robot.lower, robot.upper
    finite = np.isfinite(lo_f) & np.isfinite(hi_f) & free_b
    lo_f, hi_f = np.where(finite, lo_f, 0.0), np.where(finite, hi_f, 0.0)  # continuous joints: no inf - inf
    mid = jnp.asarray(np.where(finite, 0.5 * (lo_f + hi_f), 0.0), dtype=dtype)
    half = jnp.asarray(np.where(finite, 0.5 * (hi_f - lo_f), 1.0), dtype=dtype)
    finite_j = jnp.asarray(finite, dtype=dtype)

    def kin(q):
        """Task position (d,), full Jacobian (6, n), full position (3,), rotation (3, 3) or None."""
        if full:
            p, R, J6 = _pose_jac(robot, st.poly, q)
            return p, J6, p, R
        p, J6 = _pos_jac(robot, st.poly, q)
        return p[:d], J6, p, None

    if full:
        Rd = _pose_jac(robot, st.poly, q0)[1] if R_hold is None else R_hold

    def task_error(p, R, target):
        e = target - p
        if full:
            e = jnp.concatenate([e, _orientation_error(R, Rd)])
        return e

    def evaluate(q, K):
        with jax.named_scope("csc_kinematics"):
            p, J6, p3, R = kin(q)
        J = J6[..., : len(rows), :]
        with jax.named_scope("csc_offdiag"):
            u, g = _offdiag_value_and_grad(J6, K, rows)
        return u, g, (p, J, p3, R)

    def measures(J, K, p, p3, R, target):
        kj = jnp.sum(J * _mtv_cols(K, J), axis=-2)  # diag(J^T K J)
        kj = jnp.clip(kj, kmin, kmax)
        K_C, frob = _realised_stiffness(J, kj, K, st.task)
        err = _safe_norm(target - p)
        oerr = _orientation_angle(R, Rd) if full else jnp.zeros((), dtype)
        return kj, K_C, frob, err, oerr

    def solve(q, J, g, dx, mask):
        """The CSC update (S1-13 ... S1-22) with the joints of ``mask`` (float 0/1, (n,)) movable."""
        Jm = J * mask
        gm = g * mask
        if st.joint_limits == "sum":
            gm = gm + jl_gain * finite_j * mask * (q - mid) / half * _safe_norm(gm)
        vs = (gm,)
        if st.joint_limits == "priority":
            vs = (gm, -jl_gain * finite_j * mask * (q - mid) / half)
        dqP, Pvs, nu = _damped_projections(Jm, dx, vs, nu0, damping)
        damped = nu < _isotropy_threshold(nu0, len(rows))
        dqN = Pvs[0]
        nN = _safe_norm(dqN)
        if st.step == "adaptive":
            # |dq_P| has a kink at dx = 0 (holding still, a path that starts at the TCP), where the
            # FK's round-off (~eps) would pick the derivative's side; below 10 eps it is taken as 0
            # (value change ~1e-15 rad), so the derivative there is the symmetric one
            nP = _safe_norm(dqP)
            length = beta * jnp.where(nP > 10.0 * jnp.finfo(dtype).eps, nP, 0.0)
        else:
            length = beta
        # no null space without more movable joints than task rows (a non-redundant arm, or
        # joints frozen at their limits): (I - J+ J) g is then round-off, or with damping a
        # leftover that is no null-space motion at all, which the adaptive length would blow up
        # to |dq_P| and could cancel the tracking step. The null step is then zero (status 8).
        has_null = jnp.sum(mask) > len(rows)
        null = jnp.where(has_null, -(length / jnp.maximum(nN, null_eps)), 0.0) * dqN
        dq = dqP + null
        if st.joint_limits == "priority":
            cN = Pvs[1]
            nn2 = jnp.sum(dqN * dqN)
            pos = nn2 > null_eps**2
            coef = jnp.where(pos, jnp.sum(cN * dqN) / jnp.where(pos, nn2, 1.0), 0.0)
            dq = dq + jnp.where(has_null, 1.0, 0.0) * (cN - coef * dqN)
        return dq, null, nu, damped, (nN < null_eps) | ~has_null

    def step_fn(q, xs):
        target, K, K_prev, target_prev = xs
        if not st.varying:
            K = K_prev = K_xd
        u, g, (p, J, p3, R) = evaluate(q, K)
        # measures of the posture q (reached by the previous step) against the previous waypoint
        u_rep = u if not st.varying else offdiag(J, K_prev)
        with jax.named_scope("csc_measures"):
            kj, K_C, frob, err, oerr = measures(J, K_prev, p, p3, R, target_prev)
        dx = task_error(p, R, target)
        with jax.named_scope("csc_solve"):
            dq1, null1, nu, damped, small1 = solve(q, J, g, dx, free)
        # Saturation: joints that the step would push past a limit go exactly to the limit and
        # are frozen; the remaining free joints re-solve the same linearised step for the rest.
        # The re-solved step can push further joints past a limit (the frozen ones' share of the
        # task moves to them): those are frozen too and the step solved again, up to
        # _SATURATION_ROUNDS times, so that the final clamp does not throw away part of the
        # primary (tracking) step.
        def saturate(k, dq_prev, null_prev, small_prev, dq_sat, mask):
            q1 = q + dq_prev
            over = (mask > 0) & ((q1 < lower) | (q1 > upper))
            any_over = jnp.any(over)
            dq_sat = dq_sat + jnp.where(over, jnp.clip(q1, lower, upper) - q, 0.0)
            mask_new = mask * (1.0 - over.astype(dtype))

            def resolve(_):
                with jax.named_scope("csc_resolve"):
                    dq2, null2, _, _, small2 = solve(q, J, g, dx - _mv(J, dq_sat), mask_new)
                dq2 = dq2 + dq_sat
                if k + 1 < _SATURATION_ROUNDS:
                    dq2, null2, small2, mask2 = saturate(k + 1, dq2, null2, small2, dq_sat, mask_new)
                else:
                    mask2 = mask_new
                return (jnp.where(any_over, dq2, dq_prev), jnp.where(any_over, null2, null_prev),
                        jnp.where(any_over, small2, small_prev), jnp.where(any_over, mask2, mask))

            # Rare (a limit reached): re-solve only when some rollout of the vmapped chunk needs it.
            # The predicate is reduced over the batch axis, so it stays a branch under vmap.
            # The branch is rematerialised on its own: a cond's linearisation returns the residuals of
            # both branches, and the branch not taken fills them with zeros (28 copies per step).
            need = jax.lax.pmax(any_over.astype(jnp.int32), axis_name) > 0
            return jax.lax.cond(need, jax.checkpoint(resolve), lambda _: (dq_prev, null_prev, small_prev, mask), None)

        q1 = q + dq1
        any_over = jnp.any(free_b & ((q1 < lower) | (q1 > upper)))
        dq, null, small, mask2 = saturate(0, dq1, null1, small1, jnp.zeros_like(q), free)
        q_new = q + dq
        for _ in range(st.newton):
            pn, Jn, _, Rn = kin(q_new)
            Jpn, _, _ = _damped_pinv(Jn[..., : len(rows), :] * mask2, nu0, damping)
            q_new = q_new + _mv(Jpn, task_error(pn, Rn, target))
        q_clamped = jnp.clip(q_new, lower, upper)
        hit = any_over | jnp.any(q_clamped != q_new)
        q_clamped = jnp.where(free_b, q_clamped, lock_vals)
        ok = jnp.all(jnp.isfinite(q_clamped))
        q_next = jnp.where(ok, q_clamped, q)
        status = (
            jnp.where(damped, STATUS_DAMPED, 0)
            + jnp.where(hit & ok, STATUS_JOINT_LIMIT, 0)
            + jnp.where(ok, 0, STATUS_NAN)
            + jnp.where(small, STATUS_NULL_SMALL, 0)
        ).astype(jnp.int32)
        step_len = jnp.where(ok, _safe_norm(null), 0.0)
        out = dict(q=q, u=u_rep, frobenius=frob, tracking_error=err, orientation_error=oerr, kj=kj, K_C=K_C,
                   position=p3, isotropy=nu, null_step=step_len, status=status)
        return q_next, out

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
    body = jax.checkpoint(step_fn) if st.remat else step_fn
    _, outs = jax.lax.scan(body, q0, (t_ext, K_ext, K_prev, t_prev))
    fields = {name: a[1:] for name, a in outs.items() if name not in ("null_step", "status")}
    fields["null_step"] = outs["null_step"][:-1]
    fields["status"] = outs["status"][:-1]
    fields["target"] = targets
    fields["u_start"] = outs["u"][0]
    fields["frobenius_start"] = outs["frobenius"][0]
    return CSCResult(**fields)


def _mtv_cols(K: jax.Array, J: jax.Array) -> jax.Array:
    """K @ J for K (m, m), J (m, n) -> (m, n), as a fused broadcast sum."""
    return jnp.sum(K[..., :, :, None] * J[..., None, :, :], axis=-2)


def _rollout_batch(*args):
    """The jitted batch rollout (static: robot, settings, chunk). Called on concrete arrays it is
    compiled with jaxstiff's kernel options (:mod:`jaxstiff._xla`); inside a caller's trace (jit,
    grad) the caller's compilation decides (JAX refuses options on a nested jit)."""
    top_level = all(_is_concrete(a) for a in jax.tree_util.tree_leaves(args[3:]))
    return _rollout_batch_jit(jax.default_backend(), top_level)(*args)


@functools.lru_cache(maxsize=None)
def _rollout_batch_jit(backend: str, top_level: bool):
    opts = kernel_compiler_options() if top_level else None
    return jax.jit(_rollout_batch_impl, static_argnums=(0, 1, 2), compiler_options=opts)


def _rollout_batch_impl(robot, st, chunk, targets, K_xd, q0, beta, kmin, kmax, nu0, damping, null_eps, jl_gain, R_hold):
    def one(xs):
        t, K, q, b, e, R = xs
        return _rollout_one(robot, st, _BATCH_AXIS, t, K, q, b, kmin, kmax, nu0, damping, e, jl_gain, R)

    B = q0.shape[0]
    # one rollout's kinematics sees a single posture under vmap: choose its cos/sin by the batch
    per_call = B if chunk is None else min(B, chunk)
    st = dataclasses.replace(st, poly=jax.default_backend() == "cpu" and per_call >= POLY_MIN_BATCH)
    batched = jax.vmap(one, axis_name=_BATCH_AXIS)
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


_BATCH_AXIS = "jaxstiff_csc_rollouts"
#: re-solves of a step after joints were frozen at their limits (each round freezes the joints the
#: previous solve pushed past a limit); later violators are clamped by the final clip
_SATURATION_ROUNDS = 3


# ------------------------------------------------------------------------ public entry point
def _is_concrete(x) -> bool:
    return not isinstance(x, jax.core.Tracer)


def _path_points(path):
    pts = getattr(path, "points", path)
    if isinstance(pts, (list, tuple)):
        pts = np.asarray(pts, dtype=float)
    if not hasattr(pts, "shape"):
        raise ValueError(f"path must be a jaxstiff Path or an array (..., T, 2 or 3) of TCP targets, got {type(path).__name__}")
    return pts


def csc_rollout(
    robot: Robot,
    path,
    K_xd,
    q0,
    beta,
    *,
    task: str | None = None,
    step: str = "adaptive",
    kmin=1.0,
    kmax=jnp.inf,
    nu0=1e-2,
    damping=0.1,
    null_eps=None,
    newton: int = 0,
    joint_limits: str = "off",
    jl_gain=0.0,
    kxd_varying: bool | None = None,
    hold_orientation=None,
    remat: bool = True,
    chunk: int | None = 128,
) -> CSCResult:
    """Configuration-based Stiffness Control rollout along a path (seed 001, SPEC section 6).

    One step per waypoint; see the module docstring for the update and its documented choices.
    Every array input may carry leading batch axes; they broadcast against each other and the
    result carries the broadcast batch shape ``*B`` (computed with one ``vmap``).

    Args:
        robot: the chain (static: one compilation per robot and setting).
        path: a :class:`jaxstiff.Path` (its ``.points``) or an array (*B, T, 3) / (*B, T, 2) of
            TCP targets, m, base frame, one step per waypoint. Task ``"xy"`` uses the first two
            columns. To hold a point, repeat it T times.
        K_xd: desired Cartesian stiffness, (*B, m, m) constant or (*B, T, m, m) along the path;
            N/m (translational rows), m = 2 (``"xy"``), 3 (``"xyz"``) or 6 (``"full"``). Symmetric.
        q0: start posture (*B, n), rad; locked joints are set to their locked values. It need not
            be on the path: the first steps pull the TCP onto it.
        beta: (*B,) step multiplier >= 0. ``"adaptive"``: the null step is ``beta`` times as long as
            the primary step (S1-22; zero when the path stands still). ``"constant"``: the null
            step is ``beta`` rad long (for holding a point).
        task: ``"xy"``, ``"xyz"`` or ``"full"``; default from K_xd's size.
        step: ``"adaptive"`` or ``"constant"``.
        kmin, kmax: actuator range of the realised joint stiffness, Nm/rad (default [1, inf)).
        nu0: isotropy threshold: damping switches on below ``nu0^(m/2)`` (default 1e-2).
        damping: relative damping ``lam / sqrt(tr(J J^T)/m)`` at a singularity (default 0.1).
        null_eps: floor of ``|dq_N|`` (Nm/rad^2); default ``1e-9 |K_xd|_F`` (1e-5 in float32).
        newton: number of Newton corrections ``q += J+ (x_d - x(q))`` inside each step (static).
        joint_limits: ``"off"``, ``"priority"`` (lowest-priority secondary task) or ``"sum"``
            (added to the CSC gradient); see the module docstring.
        jl_gain: joint-limit gain (rad per step for a joint at its limit, before projection; for
            ``"sum"``: relative weight against the CSC gradient).
        kxd_varying: whether K_xd's axis -3 runs along the path. Default: True when
            ``K_xd.ndim >= 3`` and ``K_xd.shape[-3] == T``; pass False for a batch of constant
            K_xd whose batch size happens to equal T.
        hold_orientation: task ``"full"`` only: the tool orientation to hold, a rotation matrix
            (*B, 3, 3) in the base frame; default: the orientation at ``q0``. (A rollout continued
            from a later posture, as :func:`csc_rollout_segments` does, passes the first one's.)
        remat: rematerialise the scan body in the backward pass (memory ~ T n per rollout);
            without it the stored residuals make a gradient about twice as slow on a CPU.
        chunk: rollouts per ``vmap`` chunk; a larger batch runs as a sequential ``lax.map`` over
            chunks (bounded working set). ``None``: one vmap over the whole batch.

    Returns:
        :class:`CSCResult` with leading batch axes ``*B``.

    Raises:
        ValueError: bad shapes, task, step, non-finite or out-of-limit inputs, negative beta,
            a non-symmetric or indefinite K_xd, ``kmin <= 0`` or ``kmin > kmax`` (checked for concrete inputs).
    """
    st, chunk, args, batch = _prepare_rollout(
        robot, path, K_xd, q0, beta, task=task, step=step, kmin=kmin, kmax=kmax, nu0=nu0, damping=damping,
        null_eps=null_eps, newton=newton, joint_limits=joint_limits, jl_gain=jl_gain, kxd_varying=kxd_varying,
        hold_orientation=hold_orientation, remat=remat, chunk=chunk)
    res = _rollout_batch(robot, st, chunk, *args)
    return jax.tree_util.tree_map(lambda a: a.reshape(batch + a.shape[1:]), res)


def _prepare_rollout(robot, path, K_xd, q0, beta, *, task, step, kmin, kmax, nu0, damping, null_eps, newton, joint_limits,
                     jl_gain, kxd_varying, hold_orientation, remat, chunk):
    """Every check of :func:`csc_rollout` and its inputs flattened to one batch axis: ``(static
    settings, chunk, arrays for _rollout_batch, batch shape)``. No compilation: the command line
    calls it to report bad input before it announces the run."""
    if not isinstance(robot, Robot):
        raise ValueError(f"robot must be a jaxstiff.Robot, got {type(robot).__name__}")
    if step not in ("adaptive", "constant"):
        raise ValueError(f"step must be 'adaptive' or 'constant', got {step!r}")
    if joint_limits not in ("off", "priority", "sum"):
        raise ValueError(f"joint_limits must be 'off', 'priority' or 'sum', got {joint_limits!r}")
    if not isinstance(newton, (int, np.integer)) or isinstance(newton, bool) or newton < 0:
        raise ValueError(f"newton must be an integer >= 0, got {newton!r}")

    for name, v in (("K_xd", K_xd), ("q0", q0), ("path", getattr(path, "points", path)), ("beta", beta)):
        if not isinstance(v, (list, tuple)) and np.iscomplexobj(v):  # (a cast would drop the imaginary part)
            raise ValueError(f"{name} is complex ({v.dtype}): stiffnesses, postures and paths are real")
    # dtype: the caller's floating dtype of q0 (or JAX's default float)
    q0 = jnp.asarray(q0) if not isinstance(q0, (list, tuple)) else jnp.asarray(np.asarray(q0, dtype=float))
    dtype = q0.dtype if jnp.issubdtype(q0.dtype, jnp.floating) else jnp.asarray(1.0).dtype
    if jnp.finfo(dtype).bits < 32:
        raise ValueError(f"q0 has dtype {jnp.dtype(dtype).name}: the rollout computes in q0's dtype, and {jnp.dtype(dtype).name} "
                         "overflows (u ~ 1e3 Nm/rad squared) and cannot hold a step; pass float32 or float64")
    q0 = q0.astype(dtype)
    if chunk is not None and (isinstance(chunk, bool) or not isinstance(chunk, (int, np.integer)) or chunk < 1):
        raise ValueError(f"chunk must be a positive integer (rollouts per vmap chunk) or None, got {chunk!r}")
    if q0.ndim == 0 or q0.shape[-1] != robot.n:
        raise ValueError(f"q0 must have shape (..., {robot.n}) for robot {robot.name!r}, got {tuple(q0.shape)}")

    K_xd = jnp.asarray(K_xd, dtype=dtype)
    if K_xd.ndim < 2 or K_xd.shape[-1] != K_xd.shape[-2] or K_xd.shape[-1] not in _M_TO_TASK:
        raise ValueError(f"K_xd must have shape (..., m, m) with m = 2, 3 or 6, got {tuple(K_xd.shape)}")
    m = K_xd.shape[-1]
    if task is None:
        task = _M_TO_TASK[m]
    if task not in TASK_ROWS:
        raise ValueError(f"unknown task {task!r}; choose one of {', '.join(TASK_ROWS)}")
    if len(TASK_ROWS[task]) != m:
        raise ValueError(f"task {task!r} needs K_xd of shape (..., {len(TASK_ROWS[task])}, {len(TASK_ROWS[task])}), got {tuple(K_xd.shape)}")
    # Fewer free joints than task rows, or free joints' rows that are dead at every posture: the
    # primary task could not be followed (the damped step would only approximate it). As many free
    # joints as rows is allowed: no redundancy, so the null-space step is zero and the rollout only
    # tracks. (The stiffness itself has every joint's spring, locked ones too.)
    check_task_feasible(robot, task, motion=True)

    pts = _path_points(path)
    targets = jnp.asarray(pts, dtype=dtype)
    if targets.ndim < 2 or targets.shape[-1] not in (2, 3) or targets.shape[-2] < 1:
        raise ValueError(f"path points must have shape (..., T, 2 or 3) with T >= 1, got {tuple(targets.shape)}")
    d = 2 if task == "xy" else 3
    if targets.shape[-1] < d:
        raise ValueError(f"task {task!r} needs 3-D path points (x, y, z), got shape {tuple(targets.shape)}")
    targets = targets[..., :d]
    T = targets.shape[-2]

    if kxd_varying is None:
        kxd_varying = K_xd.ndim >= 3 and K_xd.shape[-3] == T
    if kxd_varying and (K_xd.ndim < 3 or K_xd.shape[-3] != T):
        raise ValueError(f"K_xd varying along the path must have shape (..., T={T}, {m}, {m}), got {tuple(K_xd.shape)}")
    k_batch = K_xd.shape[:-3] if kxd_varying else K_xd.shape[:-2]

    beta = jnp.asarray(beta, dtype=dtype)
    scalars = {}
    for name, v in (("kmin", kmin), ("kmax", kmax), ("nu0", nu0), ("damping", damping), ("jl_gain", jl_gain)):
        a = jnp.asarray(v, dtype=dtype)
        if a.ndim != 0:
            raise ValueError(f"{name} must be a scalar, got shape {tuple(a.shape)}")
        scalars[name] = a
    if null_eps is None:
        rel = 1e-9 if jnp.finfo(dtype).bits >= 64 else 1e-5
        knorm = safe_sqrt(jnp.sum(K_xd * K_xd, axis=(-2, -1)))  # finite gradient at K_xd = 0
        # floor tiny^(1/4) (1e-77 in float64): 1 / null_eps^2, which a tangent of the null step
        # carries, stays finite for K_xd = 0 (tiny itself made it inf, and inf * 0 = NaN)
        null_eps_a = rel * (knorm if not kxd_varying else jnp.max(knorm, axis=-1)) + jnp.finfo(dtype).tiny ** 0.25
    else:
        null_eps_a = jnp.asarray(null_eps, dtype=dtype)
        if null_eps_a.ndim != 0:
            raise ValueError(f"null_eps must be a scalar, got shape {tuple(null_eps_a.shape)}")

    R_hold = None
    if hold_orientation is not None:
        if task != "full":
            raise ValueError(f"hold_orientation is for task 'full' (the held tool orientation); task {task!r} has no orientation rows")
        R_hold = jnp.asarray(hold_orientation, dtype=dtype)
        if R_hold.ndim < 2 or R_hold.shape[-2:] != (3, 3):
            raise ValueError(f"hold_orientation must be a rotation matrix of shape (..., 3, 3), got {tuple(R_hold.shape)}")
        if _is_concrete(R_hold):
            Rn = np.asarray(R_hold, dtype=float)
            orth = np.max(np.abs(np.swapaxes(Rn, -1, -2) @ Rn - np.eye(3))) if np.all(np.isfinite(Rn)) else np.inf
            if not (orth < 1e-6 and np.all(np.linalg.det(Rn) > 0)):
                raise ValueError(f"hold_orientation must be a finite rotation matrix (R^T R = I, det R = +1), "
                                 f"max |R^T R - I| = {orth:g}")

    _validate(robot, targets, K_xd, q0, beta, scalars, null_eps_a)
    K_xd = 0.5 * (K_xd + jnp.swapaxes(K_xd, -1, -2))  # exactly symmetric (validated to 1e-6)

    batches = [("q0", q0.shape[:-1]), ("beta", beta.shape), ("path", targets.shape[:-2]), ("K_xd", k_batch)]
    if R_hold is not None:
        batches.append(("hold_orientation", R_hold.shape[:-2]))
    batch = broadcast_batch(*batches)
    B = math.prod(batch)
    k_tail = K_xd.shape[-3:] if kxd_varying else K_xd.shape[-2:]
    tb = jnp.broadcast_to(targets, batch + targets.shape[-2:]).reshape((B,) + targets.shape[-2:])
    kb = jnp.broadcast_to(K_xd, batch + k_tail).reshape((B,) + k_tail)
    qb = jnp.broadcast_to(q0, batch + (robot.n,)).reshape((B, robot.n))
    bb = jnp.broadcast_to(beta, batch).reshape((B,))
    eb = jnp.broadcast_to(null_eps_a, batch).reshape((B,)) if null_eps_a.ndim else jnp.broadcast_to(null_eps_a, (B,))
    rb = None if R_hold is None else jnp.broadcast_to(R_hold, batch + (3, 3)).reshape((B, 3, 3))

    st = _Static(task=task, step=step, newton=int(newton), joint_limits=joint_limits, remat=bool(remat), varying=bool(kxd_varying))
    args = (tb, kb, qb, bb, scalars["kmin"], scalars["kmax"], scalars["nu0"], scalars["damping"], eb, scalars["jl_gain"], rb)
    return st, chunk, args, batch


def _validate(robot, targets, K_xd, q0, beta, scalars, null_eps) -> None:
    """Value checks at the Python boundary, in numpy (skipped for traced inputs)."""

    def val(x):
        return None if not _is_concrete(x) else np.asarray(x, dtype=float)

    for name, a in (("path", targets), ("K_xd", K_xd), ("q0", q0), ("beta", beta)):
        v = val(a)
        if v is not None and not np.all(np.isfinite(v)):
            raise ValueError(f"{name} contains NaN or Inf")
    b = val(beta)
    if b is not None and np.any(b < 0):
        raise ValueError(f"beta must be >= 0, got min {b.min():g}")
    K = val(K_xd)
    if K is not None:
        asym = np.max(np.abs(K - np.swapaxes(K, -1, -2)))
        if asym > 1e-6 * np.max(np.abs(K)) + 1e-12:
            raise ValueError(f"K_xd must be symmetric (max |K - K^T| = {asym:g})")
        w = np.linalg.eigvalsh(0.5 * (K + np.swapaxes(K, -1, -2)))
        worst = np.unravel_index(np.argmin(w[..., 0]), w.shape[:-1]) if w.ndim > 1 else ()
        if w[worst][0] < -1e-9 * np.max(np.abs(w[worst])):
            at = f" (K_xd{list(worst)})" if worst else ""
            raise ValueError(f"K_xd must be positive semi-definite (a stiffness, N/m): eigenvalue {w[worst][0]:g}{at}")
    kmin, kmax = val(scalars["kmin"]), val(scalars["kmax"])
    if kmin is not None and not kmin > 0:
        raise ValueError(f"kmin must be > 0 Nm/rad, got {float(kmin):g}")
    if kmin is not None and kmax is not None and not kmax >= kmin:
        raise ValueError(f"kmax ({float(kmax):g}) must be >= kmin ({float(kmin):g})")
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
        qn = qn.reshape(-1, robot.n)
        lo, hi = robot.lower, robot.upper
        bad = robot.free & (np.any(qn < lo - 1e-9, axis=0) | np.any(qn > hi + 1e-9, axis=0))
        if bad.any():
            i = int(np.argmax(bad))
            raise ValueError(
                f"q0 of joint {robot.joint_names[i]!r} is outside its limits [{lo[i]:g}, {hi[i]:g}] "
                f"(got values in [{qn[:, i].min():g}, {qn[:, i].max():g}])"
            )


class CSCInterrupted(KeyboardInterrupt):
    """A :func:`csc_rollout_segments` run stopped by Ctrl-C (or SIGTERM under the command line).

    Attributes:
        result: :class:`CSCResult` of numpy arrays with the ``steps_done`` finished steps (the
            segment in flight when the interrupt came is lost).
        steps_done, steps_total: finished and requested steps per rollout.
    """

    def __init__(self, result: CSCResult, steps_done: int, steps_total: int):
        super().__init__(f"CSC rollout interrupted after {steps_done} of {steps_total} steps")
        self.result, self.steps_done, self.steps_total = result, steps_done, steps_total


_START_FIELDS = ("u_start", "frobenius_start")  # per rollout, no step axis


def _rollout_defaults() -> dict:
    """csc_rollout's keyword arguments and their defaults."""
    return {k: p.default for k, p in inspect.signature(csc_rollout).parameters.items() if p.kind is p.KEYWORD_ONLY}


def _step_axis(name: str, ndim: int) -> int:
    """Axis of the steps in a CSCResult field with ``ndim`` dimensions: (*B, T, m, m), (*B, T, n) or (*B, T)."""
    return ndim - (3 if name == "K_C" else 2 if name in ("q", "kj", "position", "target") else 1)


def _concat_results(parts: list[CSCResult]) -> CSCResult:
    """Join segments along the step axis; the start values are the first segment's."""
    out = {}
    for f in dataclasses.fields(CSCResult):
        arrays = [getattr(r, f.name) for r in parts]
        out[f.name] = arrays[0] if f.name in _START_FIELDS else np.concatenate(arrays, axis=_step_axis(f.name, arrays[0].ndim))
    return CSCResult(**out)


def csc_rollout_segments(robot: Robot, path, K_xd, q0, beta, *, segment_steps: int, progress=None, **kwargs) -> CSCResult:
    """:func:`csc_rollout` run as consecutive segments of ``segment_steps`` steps, for long runs
    that should show progress and keep their finished steps when interrupted.

    Each segment continues from the posture the previous one reached, with the same held
    orientation (task ``"full"``: ``q0``'s) and the same settings, so the rows are those of one
    :func:`csc_rollout` over the whole path (the same compiled step, to round-off). All segments
    have the same length (the last is padded with its final waypoint and the extra rows are
    dropped), so the program is compiled once. Not differentiable and not jittable (numpy out,
    Python loop): for gradients use :func:`csc_rollout`.

    Args:
        robot, path, K_xd, q0, beta: as :func:`csc_rollout` (``K_xd`` constant or along the path).
        segment_steps: steps per segment (>= 1).
        progress: optional ``progress(steps_done, steps_total)``: once with 0 when the inputs have
            been checked (before the first segment compiles and runs), then after every segment.
        **kwargs: the other keywords of :func:`csc_rollout` (not ``hold_orientation``).

    Returns:
        :class:`CSCResult` of numpy arrays, as :func:`csc_rollout`'s.

    Raises:
        CSCInterrupted: a ``KeyboardInterrupt`` after at least one finished segment, carrying the
            finished rows (``.result``). One before the first segment ends is raised as is.
        ValueError: as :func:`csc_rollout`, or a bad ``segment_steps``.
    """
    from jaxstiff.runtime.io import raise_if_interrupted

    if isinstance(segment_steps, bool) or not isinstance(segment_steps, (int, np.integer)) or segment_steps < 1:
        raise ValueError(f"segment_steps must be a positive integer, got {segment_steps!r}")
    if "hold_orientation" in kwargs:
        raise ValueError("csc_rollout_segments holds q0's orientation itself; hold_orientation is not accepted")
    varying = kwargs.pop("kxd_varying", None)
    # the whole path and every setting are checked before the first segment runs (a bad value
    # in a late waypoint must not surface after the work of the first segments)
    st = _prepare_rollout(robot, path, K_xd, q0, beta, **{**_rollout_defaults(), **kwargs, "kxd_varying": varying})[0]
    pts = np.asarray(_path_points(path))
    T = pts.shape[-2]
    L = int(min(segment_steps, T))
    K = np.asarray(K_xd)
    q = np.asarray(q0)
    R_hold = None
    if st.task == "full":  # every segment holds q0's orientation
        R_hold = np.asarray(robot.fk(np.where(robot.free, q, np.nan_to_num(robot.locked_values))))[..., :3, :3]

    def seg(a, x, axis):  # rows a ... a + L - 1 of axis `axis`, padded with the last row
        idx = np.minimum(np.arange(a, a + L), T - 1)
        return np.take(x, idx, axis=axis)

    if progress is not None:
        progress(0, T)
    parts, done = [], 0
    try:
        while done < T:
            keep = min(L, T - done)
            Kseg = seg(done, K, K.ndim - 3) if st.varying else K
            r = csc_rollout(robot, seg(done, pts, pts.ndim - 2), Kseg, q, beta, kxd_varying=st.varying,
                            hold_orientation=R_hold, **kwargs)
            r = jax.tree_util.tree_map(np.asarray, r)
            if keep < L:  # the padded last segment: drop the rows past the path's end
                r = CSCResult(**{name: (a if name in _START_FIELDS else np.take(a, np.arange(keep), axis=_step_axis(name, a.ndim)))
                                 for name, a in r.as_dict().items()})
            parts.append(r)
            q = r.q[..., -1, :]
            done += keep
            if progress is not None:
                progress(done, T)
            raise_if_interrupted()  # (an interrupt that JAX swallowed during the segment)
    except KeyboardInterrupt as e:
        if not parts:
            raise
        raise CSCInterrupted(_concat_results(parts), done, T) from e
    return _concat_results(parts)


def null_space_direction(robot: Robot, q, K_xd, *, task: str | None = None, nu0=1e-2, damping=0.1):
    """The projected CSC gradient ``dq_N = (I - J+ J) grad u(q)`` (S1-14, S1-15, S1-20) at q.

    Args:
        robot: the chain.
        q: (..., n) posture, rad.
        K_xd: (..., m, m) desired Cartesian stiffness.
        task: task rows; default from K_xd's size.
        nu0, damping: the damping rule of :func:`csc_rollout`.

    Returns:
        ``(dq_N (..., n), u (...,), J (..., m, n))``; ``-dq_N`` lowers u to first order and moves the
        TCP only at second order (exactly so where the damping is off). Locked joints' entries are 0.
    """
    q = jnp.asarray(q)
    K_xd = jnp.asarray(K_xd, dtype=q.dtype)
    return _null_space_direction(robot, task or _M_TO_TASK[K_xd.shape[-1]], q, K_xd, nu0, damping)


@functools.partial(jax.jit, static_argnums=(0, 1))
def _null_space_direction(robot: Robot, task: str, q, K_xd, nu0, damping):
    rows = TASK_ROWS[task]
    free = jnp.asarray(robot.free, dtype=q.dtype)

    def one(qq, K):
        _, J6 = position_and_jacobian(robot, qq)
        u, g = _offdiag_value_and_grad(J6, K, rows)
        J = J6[..., : len(rows), :]
        Jf = J * free
        Jp, _, _ = _damped_pinv(Jf, nu0, damping)
        gf = g * free
        return gf - _mv(Jp, _mv(Jf, gf)), u, J

    batch = jnp.broadcast_shapes(q.shape[:-1], K_xd.shape[:-2])
    qb = jnp.broadcast_to(q, batch + q.shape[-1:]).reshape((-1, q.shape[-1]))
    Kb = jnp.broadcast_to(K_xd, batch + K_xd.shape[-2:]).reshape((-1,) + K_xd.shape[-2:])
    out = jax.vmap(one)(qb, Kb)
    return jax.tree_util.tree_map(lambda a: a.reshape(batch + a.shape[1:]), out)


def project_to_target(robot: Robot, q, target, *, task: str = "xy", iters: int = 6, nu0=1e-2, damping=0.1):
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
def _project(robot: Robot, task: str, iters: int, q, target, nu0, damping):
    d = len(TASK_ROWS[task])
    free = jnp.asarray(robot.free, dtype=q.dtype)

    def one(qq, x):
        for _ in range(iters):
            p, J = position_and_jacobian(robot, qq, TASK_ROWS[task])
            Jp, _, _ = _damped_pinv(J * free, nu0, damping)
            qq = qq + _mv(Jp, x - p[:d])
        return qq

    batch = jnp.broadcast_shapes(q.shape[:-1], target.shape[:-1])
    qb = jnp.broadcast_to(q, batch + q.shape[-1:]).reshape((-1, q.shape[-1]))
    xb = jnp.broadcast_to(target, batch + target.shape[-1:]).reshape((-1, target.shape[-1]))
    return jax.vmap(one)(qb, xb).reshape(batch + q.shape[-1:])
