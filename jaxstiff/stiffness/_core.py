"""Joint <-> Cartesian stiffness mappings (SPEC section 2), batched over leading axes.

Joint stiffness is diagonal, ``K_j = diag(kj)`` with ``kj > 0`` (uni-articular actuators, S0-3).
The Cartesian stiffness is the inverse of the Cartesian compliance
``C = J_s K_j^-1 J_s^T = sum_i J_i J_i^T / kj_i`` (S0-4), ``J_s`` the task rows of the geometric
Jacobian (base frame, rows ``[v; w]``):

* ``"xy"``   rows (vx, vy): a planar chain, 2x2 (seed 000, Fig. 2-3).
* ``"xyz"``  rows (vx, vy, vz): ``K_C = C_TT^-1``, 3x3. Physically: the stiffness met by a pure
  force at the TCP (no moment) when the tool is free to turn; the tool rotates as the joint
  springs dictate.
* ``"full"`` all six rows, ``K_C`` 6x6 (N/m, N/rad, Nm/m, Nm/rad blocks). Its top-left 3x3 block
  ``K_TT`` (S0-6, S0-7, the seed's own choice) is the translational stiffness used for the
  ellipsoid. Physically: the force needed for a pure translation of the TCP while its
  orientation is held fixed (by a rigid contact or clamp). Since
  ``K_TT = (C_TT - C_TR C_RR^-1 C_RT)^-1`` (a Schur complement), ``K_TT >= C_TT^-1``: held
  orientation is always at least as stiff as free orientation, and equal only when translation
  and rotation compliance are uncoupled.

Algorithm. ``K_C`` (:func:`cartesian_stiffness`) is computed from an unrolled Cholesky
factorisation ``C = L L^T`` written as elementwise arithmetic on the matrix entries
(:mod:`jaxstiff._numerics.cholesky`), which fuses into one loop over a batch. Cholesky is backward
stable: errors are ~``eps_machine * cond(C)``, as for LAPACK (tested: 1e-12 relative to
``numpy.linalg.inv`` where ``cond(C) < 1e3``). ``K_T`` (:func:`translational_stiffness`) is the
inverse of the translational compliance (for ``"full"`` the Schur complement
``C_TT - C_TR C_RR^-1 C_RT``, ``C_RR`` factorised as above) from its eigen-decomposition, without
forming the rest of ``K_C`` (:mod:`jaxstiff.stiffness._schur`). Measurements and the alternatives
that were dropped: docs/notes/model.md.

Regularisation. Near a singular ``J_s`` the compliance loses rank and the stiffness would be
infinite along the lost direction. The two stiffness functions regularise it in two different
ways, with different condition numbers at a singular posture:

* :func:`cartesian_stiffness` (the whole ``K_C``) damps the pivots of the Cholesky factorisation.
  Pivot j, ``p_j`` (the part of row j of ``C`` not explained by the rows before it), is damped by
  ``e_j = eps * t * exp(-p_j / (nu0 * C_jj))`` with ``t = trace(C) / m`` (``eps`` = 1e-12,
  ``nu0`` = 1e-6 in float64; 1e-6 and 1e-3 in float32). That is the exact factorisation of
  ``C + diag(e)``. ``e`` underflows to exactly zero while every pivot keeps more than ~1e-5 of its
  diagonal (every well-conditioned posture: ``K_C`` is then the exact inverse), reaches
  ``eps * t`` where a row is (numerically) dependent on the others (the stiffness along the lost
  direction becomes ``~1 / (eps t)``, ``K_C`` stays symmetric positive definite and every value
  and gradient finite), and varies smoothly between. The condition number of ``K_C`` is then of
  the order of ``1 / eps``: measured 2.0e12 for ``planar_3r`` stretched (``q = 0``, task
  ``"xy"``) and 3.2e12 for the LWR at ``q = 0`` (``lwr_a7`` locked rigid, task ``"full"``).
  :func:`compliance_condition` returns the condition number of this damped compliance.
* :func:`translational_stiffness` (the ``K_T`` whose ellipsoid is shaped) damps the eigenvalues of
  the translational compliance instead (:mod:`jaxstiff.stiffness._schur`): a lost direction gets
  about ``1 / delta`` times the mean stiffness, and the condition number of ``K_T`` stays below
  ``r / delta`` (``delta`` = 1e-8 in float64, 1e-4 in float32; ``r`` = 2 or 3 translational rows):
  measured 2e8 for ``planar_3r`` stretched (task ``"xy"``) and 3e8 for the LWR at ``q = 0`` (task
  ``"full"``).

Both dampings scale with ``C`` and are scale-free, so scaling every kj by k still scales the
stiffness by exactly k (CMS); at a well-conditioned posture both are zero and both functions
return the exact inverse.

Derivatives. :func:`cartesian_stiffness` has the custom JVP ``dK = -K dC K`` (the damping held
constant), exact wherever the damping is zero and finite everywhere; the JVP of
:func:`translational_stiffness` is exact everywhere (:mod:`jaxstiff.stiffness._schur`). Reverse
mode through ``C(J, kj)`` is ordinary autodiff.

Example:
    >>> import jax.numpy as jnp, jaxstiff
    >>> robot = jaxstiff.Robot.from_urdf("planar_3r")
    >>> J = robot.jacobian(jnp.array([1.309, -1.304, -1.332]))
    >>> jaxstiff.translational_stiffness(J, jnp.array([500.0, 300.0, 100.0]), task="xy").shape
    (2, 2)
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from jaxstiff._numerics.batch import broadcast_batch, known_floats
from jaxstiff._numerics.cholesky import (
    CHOLESKY_ORDER,
    damped_cholesky,
    damped_inverse,
    damped_inverse_primal,
    sym_entries,
    sym_to_array,
)
from jaxstiff._numerics.eig import eigh_descending_primal
from jaxstiff._numerics.linalg import fusion_boundary
from jaxstiff.stiffness._cms import cms_factor, cms_scale
from jaxstiff.stiffness._schur import axes_of_compliance, schur_compliance, stiffness_of_compliance
from jaxstiff.stiffness._tasks import TASK_ROWS, check_task_feasible, select_task_rows, task_rows

__all__ = [
    "TASK_ROWS",
    "task_rows",
    "check_task_feasible",
    "compliance",
    "compliance_condition",
    "cartesian_stiffness",
    "translational_stiffness",
    "translational_compliance",
    "translational_axes",
    "joint_stiffness",
    "cms_factor",
    "cms_scale",
    "UNROLLED_SUM_MAX",
    "damped_inverse_primal",
    "fusion_boundary",
    "select_task_rows",
]


#: Chains up to this many joints sum the compliance in a fixed order (batch-size independent bits);
#: longer ones use XLA's reduction (whose rounding may depend on the batch size, ~1e-16 relative).
UNROLLED_SUM_MAX = 64


def _joint_stiffness_array(kj: jax.Array, J: jax.Array) -> jax.Array:
    kj = jnp.asarray(kj, dtype=J.dtype)
    if kj.ndim < 1 or kj.shape[-1] != J.shape[-1]:
        raise ValueError(f"kj must have shape (..., {J.shape[-1]}) to match J {tuple(J.shape)}, got {tuple(kj.shape)}")
    broadcast_batch(("J", J.shape[:-2]), ("kj", kj.shape[:-1]))
    # kj > 0 is required; a clamp keeps a zero/negative kj from producing Inf/NaN inside a batch.
    return jnp.maximum(kj, jnp.sqrt(jnp.finfo(J.dtype).tiny))


def _positive_kj(fn: Callable[..., jax.Array]) -> Callable[..., jax.Array]:
    """A stiffness function that refuses a concrete ``kj <= 0`` with a clear error. Inside a trace
    (jit, grad, vmap) ``kj`` is not known, and the clamp of :func:`_joint_stiffness_array` keeps a
    batch finite; a concrete zero or negative kj would otherwise come back as a matrix of ~1e-140
    from the regularisation, which reads like data."""

    @functools.wraps(fn)
    def checked(J: jax.Array, kj: jax.Array, task: str = "full") -> jax.Array:
        a = known_floats(kj)
        if a is not None and not np.all(a > 0):  # also NaN, which compares false with everything
            idx = tuple(int(i) for i in np.argwhere(~(a > 0))[0])
            raise ValueError(f"kj must be > 0 (Nm/rad; N/m for prismatic joints), got kj{list(idx)} = {a[idx]:g}")
        return fn(J, kj, task)

    for attr in ("lower", "trace", "eval_shape", "clear_cache", "_cache_size"):  # the jitted function's API
        if hasattr(fn, attr):
            setattr(checked, attr, getattr(fn, attr))
    return checked


@_positive_kj
@functools.partial(jax.jit, static_argnames="task")
def compliance(J: jax.Array, kj: jax.Array, task: str = "full") -> jax.Array:
    """Cartesian compliance ``C = J_s diag(1/kj) J_s^T`` (..., m, m), unregularised (S0-4).

    Args:
        J: geometric Jacobian (..., 6, n), or its task rows (..., m, n).
        kj: joint stiffnesses (..., n), Nm/rad (N/m for prismatic joints), > 0; broadcast with J.
        task: ``"xy"``, ``"xyz"`` or ``"full"``.

    Returns:
        (..., m, m) symmetric positive semi-definite, m/N in the translational block.
    """
    Js = select_task_rows(J, task)
    kj = _joint_stiffness_array(kj, Js)
    # J usually arrives as the stacked output of the unrolled kinematics kernel; without a fusion
    # boundary XLA fuses that kernel into the reductions below and re-evaluates it per entry.
    Js = fusion_boundary(Js)
    m = Js.shape[-2]
    w = jax.lax.rsqrt(kj)  # C = (J diag(kj)^-1/2)(J diag(kj)^-1/2)^T: exactly symmetric
    A = Js * w[..., None, :]  # (..., m, n)
    n = Js.shape[-1]
    if n <= UNROLLED_SUM_MAX:
        # a fixed left-to-right sum of the joints' outer products, each a whole (..., m, m) array:
        # the same bits at every batch size (XLA's reduction of a batch of 1000 rounds differently
        # from a batch of 1, issue 24) and exactly symmetric (a_i b_i == b_i a_i). Written per joint,
        # not per entry: 21 x 6 scalar products per 6x6 C cost the batch engine a quarter of its
        # run time and 13 s of compilation (docs/notes/speed.md).
        C = A[..., :, None, 0] * A[..., None, :, 0]
        for i in range(1, n):
            C = C + A[..., :, None, i] * A[..., None, :, i]
        return C
    C = {(a, b): jnp.sum(A[..., a, :] * A[..., b, :], axis=-1) for a in range(m) for b in range(a, m)}
    return sym_to_array(C, m, boundary=False)


@_positive_kj
@functools.partial(jax.jit, static_argnames="task")
def compliance_condition(J: jax.Array, kj: jax.Array, task: str = "full") -> jax.Array:
    """Condition number (...,) of the task compliance ``C`` (m x m) as :func:`cartesian_stiffness`
    damps it (the pivot damping of the module docstring), so also the condition number of ``K_C``.

    Equals ``cond(J_s K_j^-1 J_s^T)`` at every well-conditioned posture; near a singular one the
    damping caps it at the order of ``1 / eps`` (``eps`` = 1e-12 in float64, 1e-6 in float32): it
    returns 2.0e12 for ``planar_3r`` stretched (``q = 0``, task ``"xy"``, any kj). A value above
    ``0.1 / eps`` means the posture is singular for the task: the Cartesian stiffness along the
    lost direction is then set by the damping, not by the robot. It is not the condition number of
    :func:`translational_stiffness`, which damps the eigenvalues instead (its condition number stays
    below ``r / 1e-8`` in float64, ``r`` = 2 or 3 translational rows: 2e8 in that case) and, for
    task ``"full"``, is the 3x3 ``K_TT``, not the 6x6 ``K_C``. Not differentiated (a diagnostic).
    """
    C = jax.lax.stop_gradient(compliance(J, kj, task))
    m = C.shape[-1]
    S = sym_entries(C)
    order = CHOLESKY_ORDER[m]
    _, damping = damped_cholesky(S, order)
    S = dict(S)
    for e, row in zip(damping, order, strict=True):
        S[(row, row)] = S[(row, row)] + e
    C = sym_to_array(S, m)
    if m in (2, 3):
        w = eigh_descending_primal(C)[0][..., ::-1]
    else:
        w = jnp.linalg.eigvalsh(C)
    return w[..., -1] / jnp.maximum(w[..., 0], jnp.finfo(C.dtype).tiny)


@_positive_kj
@functools.partial(jax.jit, static_argnames="task")
def cartesian_stiffness(J: jax.Array, kj: jax.Array, task: str = "full") -> jax.Array:
    """Cartesian stiffness ``K_C = (J_s K_j^-1 J_s^T)^-1`` (..., m, m), m = 2, 3 or 6 (S0-4).

    Args:
        J: geometric Jacobian (..., 6, n) in the base frame, or its task rows (..., m, n).
        kj: joint stiffnesses (..., n), Nm/rad (N/m for prismatic joints), > 0 (a concrete
            kj <= 0 is refused; inside ``jit``/``grad`` it is not checked, and gives a finite,
            near-zero matrix that looks valid).
        task: ``"xy"`` (2x2), ``"xyz"`` (3x3) or ``"full"`` (6x6); see the module docstring.

    Returns:
        (..., m, m) symmetric positive definite, dtype of J. Units: N/m in the translational
        block, Nm/rad in the rotational block, N/rad and Nm/m off-diagonal. Regularised near
        singular postures (module docstring).
    """
    return damped_inverse(compliance(J, kj, task), False)


@_positive_kj
@functools.partial(jax.jit, static_argnames="task")
def translational_stiffness(J: jax.Array, kj: jax.Array, task: str = "full") -> jax.Array:
    """Translational stiffness ``K_T`` whose ellipsoid is shaped (SPEC section 2), N/m.

    ``"xy"`` -> (..., 2, 2) and ``"xyz"`` -> (..., 3, 3): ``K_C`` itself (tool free to turn).
    ``"full"`` -> (..., 3, 3): the top-left block ``K_TT`` of the 6x6 ``K_C`` (S0-6, S0-7; tool
    orientation held), computed directly as the inverse of the Schur complement
    ``S = C_TT - C_TR C_RR^-1 C_RT`` without forming the rest of ``K_C``.

    Singular postures (:mod:`jaxstiff.stiffness._schur`). ``K_T = V diag(1 / h(mu)) V^T`` from the
    eigen-decomposition of the translational compliance ``S`` (:func:`translational_compliance`),
    ``h(mu) = mu + a exp(-mu / a)``, ``a = 1e-8 trace(S) / t`` (1e-4 in float32). So ``K_T`` is the
    exact inverse of ``S`` wherever every eigenvalue of ``S`` exceeds ``40 a`` (a condition number
    of ``S`` below about ``t / 4e-7``; nearer a singularity the stiff direction reads low: on
    ``planar_3r`` at ``q = (0, 1e-3, 0)``, task ``"xy"``, its largest entry is 0.12 % below the
    exact 2.8e6 N/m, and at ``1e-4`` rad 1.4e7 against 2.8e8), symmetric positive definite with condition number below
    ``t / 1e-8`` everywhere, and independent of the batch size. At a singular posture the axes
    along which ``S`` has range are exact (the inverses of its eigenvalues there) and a lost
    direction, whose true stiffness is infinite, reads ``1 / a`` (~1e8 times the mean
    stiffness; the condition number of ``K_T`` is then 2e8 for ``planar_3r`` stretched, ``q = 0``,
    task ``"xy"``, against 2.0e12 for :func:`cartesian_stiffness`, whose damping differs: module
    docstring): use :func:`translational_axes` to get ``+inf`` there instead. A planar chain has
    no out-of-plane compliance at all: use ``"xy"`` for it (with ``"xyz"`` or ``"full"`` its z
    direction is such a lost direction). Values and gradients are finite everywhere; the JVP is
    exact.

    Args:
        J: geometric Jacobian (..., 6, n), or its task rows.
        kj: joint stiffnesses (..., n), > 0 (a concrete kj <= 0 is refused; inside ``jit``/``grad``
            it is not checked, and gives a finite, near-zero matrix of about 1e-137 that looks valid).
        task: ``"xy"``, ``"xyz"`` or ``"full"``.
    """
    return stiffness_of_compliance(compliance(J, kj, task))


@_positive_kj
@functools.partial(jax.jit, static_argnames="task")
def translational_compliance(J: jax.Array, kj: jax.Array, task: str = "full") -> jax.Array:
    """Translational compliance ``S`` (..., t, t), m/N, whose inverse is :func:`translational_stiffness`.

    ``"xy"``/``"xyz"``: the compliance ``C`` itself; ``"full"``: the Schur complement
    ``C_TT - C_TR C_RR^-1 C_RT`` (tool orientation held). Symmetric positive semi-definite and
    well defined at singular postures too, where it loses rank (:mod:`jaxstiff.stiffness._schur`).

    Args:
        J: geometric Jacobian (..., 6, n), or its task rows.
        kj: joint stiffnesses (..., n), > 0 (``inf``: a rigid joint).
        task: ``"xy"``, ``"xyz"`` or ``"full"``.
    """
    return schur_compliance(compliance(J, kj, task))[0]


@_positive_kj
@functools.partial(jax.jit, static_argnames="task")
def translational_axes(J: jax.Array, kj: jax.Array, task: str = "full") -> tuple[jax.Array, jax.Array]:
    """Stiffness-ellipsoid axes (..., t), N/m, descending, and directions (..., t, t), undamped.

    The axes are the inverses of the eigenvalues of :func:`translational_compliance`, accurate to
    rounding also next to a singular posture, and ``+inf`` along a direction the posture cannot
    yield in (an eigenvalue at or below ``1e-8`` of the mean compliance in float64, ``1e-4`` in
    float32): a flag that the posture is singular for the task, never a made-up number.
    :func:`translational_stiffness` gives the same axes except that an infinite one reads ~1e8
    times the mean stiffness there (so that ``K_T`` stays a finite matrix). Directions are unit
    columns (``[..., :, 0]`` belongs to the largest axis). Gradients are finite (zero for an
    infinite axis).

    Example:
        >>> import jax.numpy as jnp, jaxstiff
        >>> from jaxstiff.stiffness import translational_axes
        >>> J = jaxstiff.Robot.from_urdf("planar_3r").jacobian(jnp.zeros(3))  # stretched: singular
        >>> translational_axes(J, jnp.ones(3), task="xy")[0].tolist()[0]
        inf
    """
    return axes_of_compliance(compliance(J, kj, task))


def joint_stiffness(
    J: jax.Array,
    K_x: jax.Array,
    F: jax.Array | None = None,
    *,
    robot: Any = None,
    q: jax.Array | None = None,
    task: str = "full",
) -> jax.Array:
    """Joint-space stiffness by congruence, ``K_q = J_s^T K_x J_s`` (S1-8, S0-3), plus the CCT term.

    With an external wrench ``F`` at the TCP (S1-7b, S0-2) the conservative congruence
    transformation adds the geometric term ``K_G[:, i] = d(J_s(q)^T F)/dq_i`` (SPEC section 2;
    sign convention ``tau = J^T F``, F the wrench applied to the TCP), computed by forward-mode
    JAX autodiff of ``J_s(q)^T F``; that needs ``robot`` and ``q``. At ``F = 0`` it is S1-8.

    Args:
        J: Jacobian (..., 6, n) or its task rows (..., m, n), base frame.
        K_x: Cartesian stiffness (..., m, m).
        F: wrench (..., m) in the task rows' order (force first, then moment for ``"full"``),
            N and Nm, base frame.
        robot: the :class:`jaxstiff.Robot` that gave ``J`` (needed with ``F``).
        q: joint values (..., n) that gave ``J`` (needed with ``F``), rad.
        task: rows of ``J``/``K_x``/``F``.

    Returns:
        (..., n, n) in Nm/rad; symmetric for ``F = None``; with ``F``, ``K_G`` may be non-symmetric.
    """
    Js = select_task_rows(J, task)
    K_x = jnp.asarray(K_x, dtype=Js.dtype)
    m = Js.shape[-2]
    if K_x.shape[-2:] != (m, m):
        other = {2: "xy", 3: "xyz", 6: "full"}.get(K_x.shape[-1]) if K_x.ndim >= 2 else None
        hint = f" (a {K_x.shape[-1]}x{K_x.shape[-1]} K_x is task={other!r})" if other and other != task else ""
        raise ValueError(f"K_x must have shape (..., {m}, {m}) for task {task!r}, got {tuple(K_x.shape)}{hint}")
    Kq = jnp.einsum("...ai,...ab,...bj->...ij", Js, K_x, Js)
    if F is None:
        return Kq
    if robot is None or q is None:
        raise ValueError("joint_stiffness with a wrench F needs robot= and q= for the geometric (CCT) term")
    q = jnp.asarray(q, dtype=Js.dtype)
    F = jnp.asarray(F, dtype=Js.dtype)
    if F.shape[-1:] != (m,):
        raise ValueError(f"F must have shape (..., {m}) for task {task!r}, got {tuple(F.shape)}")
    return Kq + _cct_term(robot, task_rows(task), q, F)


@functools.partial(jax.jit, static_argnums=(0, 1))
def _cct_term(robot: Any, rows: tuple[int, ...], q: jax.Array, F: jax.Array) -> jax.Array:
    """``K_G[..., :, i] = d(J_s(q)^T F)/dq_i`` by forward-mode autodiff of the analytic Jacobian."""
    from jaxstiff.model._kinematics import jacobian

    n, m = q.shape[-1], F.shape[-1]

    def tau(qq: jax.Array, FF: jax.Array) -> jax.Array:
        return jacobian(robot, qq)[list(rows), :].T @ FF

    batch = jnp.broadcast_shapes(q.shape[:-1], F.shape[:-1])
    qf = jnp.broadcast_to(q, batch + (n,)).reshape((-1, n))
    Ff = jnp.broadcast_to(F, batch + (m,)).reshape((-1, m))
    return jax.vmap(jax.jacfwd(tau))(qf, Ff).reshape(batch + (n, n))
