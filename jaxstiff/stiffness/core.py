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

Algorithm. ``K`` is computed from an unrolled Cholesky factorisation ``C = L L^T`` written as
elementwise arithmetic on the matrix entries, which fuses into one loop over a batch (several
times faster on a CPU than ``jnp.linalg.inv``/``eigh`` per matrix; ``scripts/bench_pipeline.py``).
For ``"full"`` the rotational rows are factorised first, so the translational block is the
inverse of the trailing 3x3 factor (the Cholesky factor of the Schur complement), and the rest of
the 6x6 inverse is never formed. Cholesky is backward stable: errors are ~``eps_machine *
cond(C)``, as for LAPACK (tested: 1e-12 relative to ``numpy.linalg.inv`` where ``cond(C) < 1e3``).
A block elimination with closed-form 3x3 inverses was tried first and dropped: at a rotational
singularity its huge ``C_RR^-1`` leaked rounding into the translational block and made ``K_TT``
indefinite.

Regularisation. Near a singular ``J_s`` the compliance loses rank and ``K_C`` would be infinite
along the lost direction. Pivot j of the factorisation, ``p_j`` (the part of row j of ``C`` not
explained by the rows before it), is damped by ``e_j = eps * t * exp(-p_j / (nu0 * C_jj))`` with
``t = trace(C) / m`` (``eps`` = 1e-12, ``nu0`` = 1e-6 in float64; 1e-6 and 1e-3 in float32). That
is the exact factorisation of ``C + diag(e)``. ``e`` underflows to exactly zero while every pivot
keeps more than ~1e-5 of its diagonal (every well-conditioned posture: ``K_C`` is then the exact
inverse), reaches ``eps * t`` where a row is (numerically) dependent on the others (the stiffness
along the lost direction becomes ``~1 / (eps t)``, about 1e12 times the others in float64, ``K``
stays symmetric positive definite and every value and gradient finite), and varies smoothly
between. ``e`` scales with ``C`` and the activation is scale-free, so scaling every kj by k still
scales ``K_C`` by exactly k (CMS). :func:`compliance_condition` reports the condition number of the
damped compliance: above ``0.1 / eps`` the posture is singular for the task.

Derivatives. The inverse has the custom JVP ``dK = -K dC K`` (the damping held constant), exact
wherever the damping is zero and finite everywhere; reverse mode through ``C(J, kj)`` is ordinary
autodiff.

Example:
    >>> import jax.numpy as jnp, jaxstiff
    >>> robot = jaxstiff.Robot.from_urdf("planar_3r")
    >>> J = robot.jacobian(jnp.array([1.309, -1.304, -1.332]))
    >>> jaxstiff.translational_stiffness(J, jnp.array([500.0, 300.0, 100.0]), task="xy").shape
    (2, 2)
"""

from __future__ import annotations

import functools
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from jaxstiff._numerics.batch import broadcast_batch, check_square, known_floats
from jaxstiff._numerics.eig import eigh_descending, eigh_descending_primal
from jaxstiff._numerics.linalg import fusion_boundary, mm

__all__ = [
    "TASK_ROWS",
    "task_rows",
    "check_task_feasible",
    "compliance",
    "compliance_condition",
    "cartesian_stiffness",
    "translational_stiffness",
    "joint_stiffness",
    "cms_factor",
    "cms_scale",
]

TASK_ROWS: dict[str, tuple[int, ...]] = {"xy": (0, 1), "xyz": (0, 1, 2), "full": (0, 1, 2, 3, 4, 5)}


def task_rows(task: str) -> tuple[int, ...]:
    """Jacobian rows of a task name; raises ValueError for an unknown task."""
    try:
        return TASK_ROWS[task]
    except (KeyError, TypeError):
        raise ValueError(f"unknown task {task!r}; choose one of {', '.join(TASK_ROWS)}") from None


_ROW_NAMES = ("vx", "vy", "vz", "wx", "wy", "wz")


@functools.lru_cache(maxsize=64)
def _task_rank_report(robot, task: str, motion: bool = False) -> str | None:
    rows = task_rows(task)
    m = len(rows)
    # the stiffness K = (J diag(1/kj) J^T)^-1 has every joint's spring, locked ones included; the
    # motion (a CSC rollout's primary task) has the free joints only
    cols = robot.free if motion else np.ones(robot.n, dtype=bool)
    k = int(cols.sum())
    lost = "so the path cannot be followed along the missing {}" if motion else "so its stiffness along the missing {} is undefined"
    if k < m:
        have = f"only {k} free joint(s) move the TCP" if motion else f"the robot has only {k} joint(s)"
        return (f"task {task!r} controls {m} Cartesian rows ({', '.join(_ROW_NAMES[r] for r in rows)}) but {have}, "
                + lost.format("rows"))
    # Structural rank: sample postures within the limits (continuous joints in [-pi, pi]); a task
    # whose Jacobian rows lose rank at every sample (a planar chain asked for z, an axis parallel
    # to another ...) is not a singular posture but a wrong task for this robot.
    from jaxstiff.model.kinematics import jacobian

    rng = np.random.default_rng(0)
    lo, hi = robot.lower, robot.upper  # a joint's own range; one turn where it is open
    lo_ok, hi_ok = np.isfinite(lo), np.isfinite(hi)
    lo = np.where(lo_ok, lo, np.where(hi_ok, np.where(hi_ok, hi, 0.0) - 2 * np.pi, -np.pi))
    hi = np.where(hi_ok, hi, lo + 2 * np.pi)
    q = lo + (hi - lo) * rng.uniform(0.05, 0.95, size=(6, robot.n))
    q = np.where(robot.free, q, np.nan_to_num(robot.locked_values))
    with jax.ensure_compile_time_eval(), jax.enable_x64(True):
        J = np.asarray(jacobian(robot, jnp.asarray(q, dtype=jnp.float64)))
    Js = J[:, list(rows), :][:, :, cols]
    s = np.linalg.svd(Js, compute_uv=False)
    if np.any(s[:, -1] > 1e-9 * np.maximum(s[:, 0], 1e-300)):
        return None
    dead = [_ROW_NAMES[r] for i, r in enumerate(rows) if np.all(np.abs(Js[:, i, :]) < 1e-12)]
    rank = int(np.max(np.sum(s > 1e-9 * s[:, :1], axis=1)))
    which = "free joints' " if motion else ""
    why = (f"row(s) {', '.join(dead)} of its {which}Jacobian are zero at every posture (a planar chain?)" if dead
           else f"its {m} task rows have rank {rank} at every sampled posture")
    return f"task {task!r} controls {m} Cartesian rows but {why}, " + lost.format("direction")


def check_task_feasible(robot, task: str, *, motion: bool = False) -> None:
    """Raise ValueError if ``robot`` cannot control the rows of ``task`` at any posture.

    Two causes: fewer joints than task rows (a 3-joint arm with ``"full"``), and task rows that
    lose rank at every posture (a planar chain with ``"xyz"``: its ``vz`` row is always zero).
    Either makes the Cartesian stiffness infinite along a lost direction everywhere, not just
    near a singular posture, so the result would only reflect the regularisation. Locked joints
    count: they keep their springs (SPEC section 1), so a 7-joint arm with two joints locked has a
    defined 6-row stiffness. With ``motion=True`` (a CSC rollout, whose primary task the free
    joints follow) only the free joints count. The check samples six postures within the joint
    limits once per (robot, task).
    """
    msg = _task_rank_report(robot, task, motion)
    if msg is not None:
        smaller = [t for t in ("xyz", "xy") if len(TASK_ROWS[t]) < len(TASK_ROWS[task])]
        ok = [t for t in smaller if _task_rank_report(robot, t, motion) is None]
        hint = (f"use task {ok[0]!r} ({'position only' if ok[0] == 'xyz' else 'the x and y rows only'})" if ok
                else "task 'xy' needs a chain that moves in the base xy plane")
        if motion and not robot.free.all():
            hint += ", or unlock joints"
        raise ValueError(f"{msg}; {hint}")


def _reg_eps(dtype) -> float:
    return 1e-12 if jnp.finfo(dtype).bits >= 64 else 1e-6


def _select(J: jax.Array, task: str) -> jax.Array:
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




def _joint_stiffness_array(kj, J: jax.Array) -> jax.Array:
    kj = jnp.asarray(kj, dtype=J.dtype)
    if kj.ndim < 1 or kj.shape[-1] != J.shape[-1]:
        raise ValueError(f"kj must have shape (..., {J.shape[-1]}) to match J {tuple(J.shape)}, got {tuple(kj.shape)}")
    broadcast_batch(("J", J.shape[:-2]), ("kj", kj.shape[:-1]))
    # kj > 0 is required; a clamp keeps a zero/negative kj from producing Inf/NaN inside a batch.
    return jnp.maximum(kj, jnp.sqrt(jnp.finfo(J.dtype).tiny))




def _positive_kj(fn):
    """A stiffness function that refuses a concrete ``kj <= 0`` with a clear error. Inside a trace
    (jit, grad, vmap) ``kj`` is not known, and the clamp of :func:`_joint_stiffness_array` keeps a
    batch finite; a concrete zero or negative kj would otherwise come back as a matrix of ~1e-140
    from the regularisation, which reads like data."""

    @functools.wraps(fn)
    def checked(J, kj, task: str = "full"):
        a = known_floats(kj)
        if a is not None and np.any(a <= 0):
            idx = tuple(int(i) for i in np.argwhere(a <= 0)[0])
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
    Js = _select(J, task)
    kj = _joint_stiffness_array(kj, Js)
    # J usually arrives as the stacked output of the unrolled kinematics kernel; without a fusion
    # boundary XLA fuses that kernel into the reductions below and re-evaluates it per entry.
    Js = fusion_boundary(Js)
    m = Js.shape[-2]
    w = jax.lax.rsqrt(kj)  # C = (J diag(kj)^-1/2)(J diag(kj)^-1/2)^T: exactly symmetric
    rows = [Js[..., a, :] * w for a in range(m)]
    C = {(a, b): jnp.sum(rows[a] * rows[b], axis=-1) for a in range(m) for b in range(a, m)}
    return _to_array(C, m, boundary=False)


# ---------------------------------------------------------------- closed forms on entries
# A symmetric matrix is handled as a dict {(i, j): entry (...,)} over i <= j (structure of arrays).
Sym = dict


def _nu0(dtype) -> float:
    return 1e-6 if jnp.finfo(dtype).bits >= 64 else 1e-3


def _g(S: Sym, i: int, j: int):
    return S[(i, j)] if i <= j else S[(j, i)]












def _to_array(S: Sym, m: int, boundary: bool = True) -> jax.Array:
    if boundary:
        S = fusion_boundary(S)
    return jnp.stack([jnp.stack([_g(S, i, j) for j in range(m)], axis=-1) for i in range(m)], axis=-2)


def _damped_cholesky(S: Sym, order: tuple[int, ...]) -> tuple[dict, list]:
    """Unrolled Cholesky ``P C P^T + diag(e) = L L^T`` of a symmetric PSD matrix, with damping.

    ``order`` permutes the rows (``P``). Pivot j is ``p_j = C_jj - sum_k L_jk^2``, the part of
    row j not explained by the rows before it. It is damped by
    ``e_j = eps * t * exp(-max(p_j, 0) / (nu0 * C_jj))`` (``t = trace / m``): exactly zero (to the
    last bit) while the pivot keeps more than ~10 nu0 of its diagonal, i.e. at every
    well-conditioned matrix, ``eps * t`` where a row is (numerically) dependent on the previous
    ones, smooth between. Adding ``e_j`` to pivot j is the same as factorising ``C + e_j E_jj``,
    so the result is the exact Cholesky factor of ``C + diag(e)``: backward stable (errors
    ~``eps_machine * |C|``, far below the damping), unlike a block elimination whose inverse of a
    near-singular block leaks its rounding into everything else.

    Returns:
        ``(L, e)``: ``L[(i, j)]`` for i >= j in the permuted order, and the damping per row.
    """
    m = len(order)
    diag = [S[(k, k)] for k in order]
    dtype = diag[0].dtype
    t = sum(diag) / m + jnp.sqrt(jnp.finfo(dtype).tiny)
    eps, nu0 = _reg_eps(dtype), _nu0(dtype)
    L: dict = {}
    damping = []
    for j in range(m):
        p = diag[j] - sum(L[(j, k)] * L[(j, k)] for k in range(j)) if j else diag[j]
        p = jnp.maximum(p, 0.0)
        e = eps * t * jnp.exp(-p / (nu0 * (diag[j] + eps * t)))
        Ljj = jnp.sqrt(p + e)
        inv = 1.0 / Ljj
        L[(j, j)] = Ljj
        damping.append(e)
        for i in range(j + 1, m):
            cij = _g(S, order[i], order[j])
            if j:
                cij = cij - sum(L[(i, k)] * L[(j, k)] for k in range(j))
            L[(i, j)] = cij * inv
    return L, damping


def _tri_inverse(L: dict, m: int, start: int = 0) -> dict:
    """Inverse W of the lower-triangular block ``L[start:, start:]`` (W[(i, j)], i >= j)."""
    W: dict = {}
    for i in range(start, m):
        W[(i, i)] = 1.0 / L[(i, i)]
        for j in range(i - 1, start - 1, -1):
            W[(i, j)] = -sum(L[(i, k)] * W[(k, j)] for k in range(j, i)) * W[(i, i)]
    return W


def _gram_of_inverse(W: dict, m: int, idx: list[int]) -> Sym:
    """``(W^T W)[idx, idx]``, W lower triangular: ``sum_k W_ka W_kb`` over k >= max(a, b)."""
    out: Sym = {}
    for ia, a in enumerate(idx):
        for b in idx[ia:]:
            out[(a, b)] = sum(W[(k, a)] * W[(k, b)] for k in range(max(a, b), m))
    return out


# Row order of the factorisation: for "full" the rotational rows first, so that the translational
# block of the inverse only needs the trailing 3x3 of L (the Cholesky factor of the Schur complement).
_ORDER = {2: (0, 1), 3: (0, 1, 2), 6: (3, 4, 5, 0, 1, 2)}


def _stiffness_entries(S: Sym, m: int, translational_only: bool = False) -> tuple[Sym, int]:
    """Entries of ``(C + diag(e))^-1`` (or of its translational 3x3 block for m = 6)."""
    order = _ORDER[m]
    L, _ = _damped_cholesky(S, order)
    if m == 6 and translational_only:
        W = _tri_inverse(L, 6, start=3)
        K = _gram_of_inverse(W, 6, [3, 4, 5])
        return {(a - 3, b - 3): v for (a, b), v in K.items()}, 3
    W = _tri_inverse(L, m)
    Kp = _gram_of_inverse(W, m, list(range(m)))
    pos = {row: i for i, row in enumerate(order)}  # original row -> permuted position
    return {(a, b): _g(Kp, pos[a], pos[b]) for a in range(m) for b in range(a, m)}, m




def damped_inverse_primal(C: jax.Array, translational_only: bool) -> jax.Array:
    m = C.shape[-1]
    S = {(i, j): C[..., i, j] for i in range(m) for j in range(i, m)}
    return _to_array(*_stiffness_entries(S, m, translational_only))


@functools.partial(jax.custom_jvp, nondiff_argnums=(1,))
def _damped_inverse(C: jax.Array, translational_only: bool = False) -> jax.Array:
    """``(C + diag(e))^-1`` (or its top-left 3x3 block) of a compliance ``C`` (..., m, m).

    The JVP is that of the matrix inverse, ``dK = -K dC K`` (``-P^T dC P`` with ``P = K[:, :3]``
    for the block), with the damping ``e`` held constant: exact wherever the damping is zero
    (every well-conditioned posture), finite everywhere, and several times cheaper in reverse
    mode than differentiating through the unrolled factorisation (whose entry-wise slices
    transpose into pads of whole arrays).
    """
    return damped_inverse_primal(C, translational_only)


@_damped_inverse.defjvp
def _damped_inverse_jvp(translational_only, primals, tangents):
    (C,), (dC,) = primals, tangents
    K = damped_inverse_primal(C, False)
    dC = 0.5 * (dC + jnp.swapaxes(dC, -1, -2))
    if translational_only:
        P = K[..., :, :3]
        return K[..., :3, :3], -mm(mm(jnp.swapaxes(P, -1, -2), dC), P)
    return K, -mm(mm(K, dC), K)


@_positive_kj
@functools.partial(jax.jit, static_argnames="task")
def compliance_condition(J: jax.Array, kj: jax.Array, task: str = "full") -> jax.Array:
    """Condition number (...,) of the compliance as damped by the stiffness functions.

    Equals ``cond(J_s K_j^-1 J_s^T)`` at every well-conditioned posture; near a singular one the
    damping caps it at about ``1 / eps`` (1e12 in float64, 1e6 in float32). A value above
    ``0.1 / eps`` means the posture is singular for the task: the Cartesian stiffness along the
    lost direction is then set by the damping, not by the robot. Not differentiated (a diagnostic).
    """
    C = jax.lax.stop_gradient(compliance(J, kj, task))
    m = C.shape[-1]
    S = {(i, j): C[..., i, j] for i in range(m) for j in range(i, m)}
    order = _ORDER[m]
    _, damping = _damped_cholesky(S, order)
    S = dict(S)
    for e, row in zip(damping, order):
        S[(row, row)] = S[(row, row)] + e
    C = _to_array(S, m)
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
        kj: joint stiffnesses (..., n), Nm/rad (N/m for prismatic joints), > 0.
        task: ``"xy"`` (2x2), ``"xyz"`` (3x3) or ``"full"`` (6x6); see the module docstring.

    Returns:
        (..., m, m) symmetric positive definite, dtype of J. Units: N/m in the translational
        block, Nm/rad in the rotational block, N/rad and Nm/m off-diagonal. Regularised near
        singular postures (module docstring).
    """
    return _damped_inverse(compliance(J, kj, task), False)


@_positive_kj
@functools.partial(jax.jit, static_argnames="task")
def translational_stiffness(J: jax.Array, kj: jax.Array, task: str = "full") -> jax.Array:
    """Translational stiffness ``K_T`` whose ellipsoid is shaped (SPEC section 2), N/m.

    ``"xy"`` -> (..., 2, 2) and ``"xyz"`` -> (..., 3, 3): ``K_C`` itself (tool free to turn).
    ``"full"`` -> (..., 3, 3): the top-left block ``K_TT`` of the 6x6 ``K_C`` (S0-6, S0-7; tool
    orientation held), computed directly as the inverse of the Schur complement
    ``C_TT - C_TR C_RR^-1 C_RT`` without forming the rest of ``K_C``.

    A planar chain has no out-of-plane compliance at all: use ``"xy"`` for it; with ``"xyz"`` or
    ``"full"`` its z direction is a lost (damped) direction, ~1e12 times stiffer than the others.

    Args:
        J: geometric Jacobian (..., 6, n), or its task rows.
        kj: joint stiffnesses (..., n), > 0.
        task: ``"xy"``, ``"xyz"`` or ``"full"``.
    """
    C = compliance(J, kj, task)
    return _damped_inverse(C, C.shape[-1] == 6)


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
    Js = _select(J, task)
    K_x = jnp.asarray(K_x, dtype=Js.dtype)
    m = Js.shape[-2]
    if K_x.shape[-2:] != (m, m):
        raise ValueError(f"K_x must have shape (..., {m}, {m}) for task {task!r}, got {tuple(K_x.shape)}")
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
    from jaxstiff.model.kinematics import jacobian

    n, m = q.shape[-1], F.shape[-1]

    def tau(qq, FF):
        return jacobian(robot, qq)[list(rows), :].T @ FF

    batch = jnp.broadcast_shapes(q.shape[:-1], F.shape[:-1])
    qf = jnp.broadcast_to(q, batch + (n,)).reshape((-1, n))
    Ff = jnp.broadcast_to(F, batch + (m,)).reshape((-1, m))
    return jax.vmap(jax.jacfwd(tau))(qf, Ff).reshape(batch + (n, n))


def _check_positive(name: str, value) -> None:
    if isinstance(value, (int, float)) and not value > 0:
        raise ValueError(f"{name} must be > 0, got {value}")


def cms_factor(K: jax.Array, target_volume: float | None = None, target_major: float | None = None) -> jax.Array:
    """Common-mode stiffness factor k (S0 section III) so that ``k K`` reaches a target size.

    Scaling every kj by k scales ``K_C`` (and ``K_T``) by exactly k: the ellipsoid keeps its
    shape (ratio) and orientation; its axes scale by k and its volume by ``k^m``.

    Args:
        K: translational stiffness (..., m, m), m = 2 or 3, N/m, symmetric positive definite.
        target_volume: wanted product of the axes ``lambda1 * ... * lambda_m`` in (N/m)^m
            (the area ``lambda1 lambda2`` for m = 2; no 4/3 pi or pi factor).
        target_major: wanted major axis ``lambda1`` (N/m).

    Returns:
        k (...,) > 0; the scaled joint stiffnesses are ``k * kj`` (:func:`cms_scale`).
    """
    if (target_volume is None) == (target_major is None):
        raise ValueError("give exactly one of target_volume= or target_major=")
    K = check_square(K)
    m = K.shape[-1]
    w = eigh_descending(K)[0]
    if target_major is not None:
        _check_positive("target_major", target_major)
        return jnp.asarray(target_major, K.dtype) / w[..., 0]
    _check_positive("target_volume", target_volume)
    return (jnp.asarray(target_volume, K.dtype) / jnp.prod(w, axis=-1)) ** (1.0 / m)


def cms_scale(
    K: jax.Array, kj: jax.Array, *, target_volume: float | None = None, target_major: float | None = None
) -> tuple[jax.Array, jax.Array]:
    """CMS in one call: ``(k, k * kj)`` so that the scaled ellipsoid reaches the target size.

    Args:
        K: translational stiffness (..., m, m) obtained with ``kj``.
        kj: joint stiffnesses (..., n) that gave ``K``.
        target_volume, target_major: as in :func:`cms_factor` (exactly one).

    Returns:
        k (...,) and the scaled joint stiffnesses (..., n).
    """
    k = cms_factor(K, target_volume=target_volume, target_major=target_major)
    return k, k[..., None] * jnp.asarray(kj, dtype=k.dtype)
