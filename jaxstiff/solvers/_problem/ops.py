"""The traceable pieces of one waypoint problem on the decision vector ``x = [q_free, kj]``, shared by
pgd, the trajectory solver's LM stage and greedy SLSQP's target step:
the rate-limited box, Newton corrections onto the path, the Levenberg-Marquardt stage on the f1/f2
residuals, the shape surrogate, and the small linear algebra and step rules they share
(:func:`spd_solve`, :func:`clip_box`, :func:`box_scales`, :func:`adam_direction`).
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

from jaxstiff._numerics.batch import batched_like
from jaxstiff.model._kinematics import jacobian_tangent
from jaxstiff.solvers._problem.box import rate_bounds
from jaxstiff.solvers._problem.waypoint import WaypointProblem
from jaxstiff.stiffness._core import (
    compliance,
    fusion_boundary,
    task_rows,
)
from jaxstiff.stiffness._criteria import f1 as _f1
from jaxstiff.stiffness._criteria import f2 as _f2
from jaxstiff.stiffness._schur import stiffness_and_tangents

__all__ = [
    "WaypointOps",
    "spd_solve",
    "complement_basis",
    "lm_kind",
    "clip_box",
    "box_scales",
    "adam_direction",
    "ADAM_B1",
    "ADAM_B2",
    "ADAM_EPS",
]


class WaypointOps:
    """Traceable pieces of one waypoint problem on the decision vector x = [q_free, kj_spring]
    (``nk`` stiffness variables: every joint's, or the free joints' when locked joints are rigid)."""

    def __init__(self, problem: WaypointProblem):
        self.pr = problem
        robot = problem.robot
        self.nf, self.n, self.nx = problem.n_free, problem.n, problem.nx
        self.nk = problem.n_spring
        free = list(problem.free_idx)
        self.free = np.asarray(free, dtype=int)
        self.rows = problem.pos_rows
        self.qlo = np.asarray(robot.lower, float)[free]
        self.qhi = np.asarray(robot.upper, float)[free]

    def box(self, xref, rate, dq_f, dk, kmin, kmax):
        """Rate-limited box (lb, ub) (nx,) around xref; ``rate`` a traced bool."""
        dt = xref.dtype
        qlo, qhi = jnp.asarray(self.qlo, dt), jnp.asarray(self.qhi, dt)
        klo = jnp.full((self.nk,), kmin, dt)
        khi = jnp.full((self.nk,), kmax, dt)
        rlq, ruq = rate_bounds(xref[: self.nf], dq_f, jnp)
        rlk, ruk = rate_bounds(xref[self.nf :], dk, jnp)
        lbq = jnp.where(rate, jnp.maximum(qlo, rlq), qlo)
        ubq = jnp.where(rate, jnp.minimum(qhi, ruq), qhi)
        lbk = jnp.where(rate, jnp.maximum(klo, rlk), klo)
        ubk = jnp.where(rate, jnp.minimum(khi, ruk), khi)
        return jnp.concatenate([lbq, lbk]), jnp.concatenate([ubq, ubk])

    def pos_jac(self, x):
        q = self.pr.q_of(x)
        p, J = self.pr.kinematics(q, self.rows)
        return p, J[:, self.free]

    def f(self, x, d, r, c):
        return self.pr.objective(self.pr.q_of(x), self.pr.kj_of(x), d, r, c)

    def newton(self, x, target, lb, ub, steps: int | jax.Array):
        """``steps`` box-respecting minimum-norm Gauss-Newton corrections of the joint part (a
        Python int or a traced loop bound)."""
        if (isinstance(steps, int) and steps == 0) or self.nf == 0:
            return x
        rows = jnp.asarray(self.rows)
        k = len(self.rows)

        def body(_, carry):
            x, active = carry
            p, J = self.pos_jac(x)
            e = target[rows] - p[rows]
            Ja = jnp.where(active[None, :], 0.0, J)
            JJt = Ja @ Ja.T
            mu = 1e-12 * jnp.maximum(jnp.trace(JJt), 1e-300)
            step = Ja.T @ spd_solve(JJt + mu * jnp.eye(k, dtype=x.dtype), e)
            step = jnp.where(jnp.all(jnp.isfinite(step)), step, 0.0)
            raw = x[: self.nf] + step
            new = jnp.minimum(jnp.maximum(raw, lb[: self.nf]), ub[: self.nf])
            active = active | (new != raw)
            return x.at[: self.nf].set(new), active

        x, _ = jax.lax.fori_loop(0, steps, body, batched_like((x, jnp.zeros(self.nf, bool)), x))
        return x

    def surrogate(self, x, d, r, c):
        """Smooth shape surrogate: ``|K/|K| - D/|D||_F^2`` with ``D = r d d^T + (I - d d^T)``.

        Zero iff K is a multiple of D (major axis along d, ratio r, minor axes equal); no
        eigen-decomposition, so no kinks or eigenvalue-ordering jumps: it pulls a poor start
        into the basin of the criterion's minimum before the criterion itself is optimised.
        """
        _, J = self.pr.kinematics(self.pr.q_of(x), task_rows(self.pr.task))
        return self.surrogate_of(J, self.pr.kj_of(x), d, r)

    def surrogate_of(self, J, kj, d, r):
        """:meth:`surrogate` from the task-row Jacobian and the joint stiffnesses."""
        K = self.pr.stiffness_of(J, kj)
        m = K.shape[-1]
        dd = d[:m] / jnp.linalg.norm(d[:m])
        D = (r - 1.0) * jnp.outer(dd, dd) + jnp.eye(m, dtype=K.dtype)
        Kn = K / jnp.sqrt(jnp.sum(K * K))
        Dn = D / jnp.sqrt(jnp.sum(D * D))
        return jnp.sum((Kn - Dn) ** 2)

    def f_and_err(self, x, d, r, c, target):
        """The criterion and the position error at x (:meth:`f`, :meth:`pos_err`), from one
        evaluation of the kinematics."""
        Jt, (p, _) = self._kinematics_rows(x)
        return self.pr.objective_of(Jt, self.pr.kj_of(x), d, r, c), jnp.linalg.norm(p - target)

    def _kinematics_rows(self, x):
        """``(J_task, (p, J_pos))`` at x from one evaluation of the kinematics over the union of
        the task rows and the position rows: the task-row Jacobian (all joints), the TCP position
        and the position-row Jacobian (all joints)."""
        pr = self.pr
        t_rows, p_rows = list(task_rows(pr.task)), list(self.rows)
        rows = tuple(sorted(set(t_rows) | set(p_rows)))
        p, J = pr.kinematics(pr.q_of(x), rows)
        return _take_rows(J, [rows.index(i) for i in t_rows]), (p, _take_rows(J, [rows.index(i) for i in p_rows]))

    def descent_terms(self, x, d, r, c, surrogate: bool | jax.Array):
        """What one projected gradient step needs at x, from one evaluation of the kinematics:
        ``(value, gradient (nx,), TCP position (3,), position-row Jacobian of the free joints)``
        of the criterion, or of the :meth:`surrogate` where ``surrogate`` (a Python bool, or a
        traced one that is not batched: then a real branch, one objective runs). The same values
        as :meth:`f` with ``jax.value_and_grad``, :meth:`pos_err` and :meth:`pos_jac`, which would
        evaluate the kinematics three times."""
        pr = self.pr
        Jt, back, (p, Jp) = jax.vjp(self._kinematics_rows, x, has_aux=True)

        def f_of(Jt, x):
            return pr.objective_of(Jt, pr.kj_of(x), d, r, c)

        def s_of(Jt, x):
            return self.surrogate_of(Jt, pr.kj_of(x), d, r)

        vg_f, vg_s = jax.value_and_grad(f_of, (0, 1)), jax.value_and_grad(s_of, (0, 1))
        if isinstance(surrogate, bool):
            v, (gJ, gx) = (vg_s if surrogate else vg_f)(Jt, x)
        else:
            v, (gJ, gx) = jax.lax.cond(surrogate, vg_s, vg_f, Jt, x)
        (gq,) = back(gJ)
        return v, gq + gx, p, Jp[:, self.free]

    def pos_err(self, x, target):
        p, _ = self.pos_jac(x)
        return jnp.linalg.norm(p - target)

    # ------------------------------------------------------------ Levenberg-Marquardt stage
    def lm_residual(self, x, target, d, r, kind: str, wpos, walign):
        """Residuals whose zeros are exactly the criterion's minimum set, position rows first.

        With ``Kn = K / (tr K / m)``, ``d`` unit and ``E`` an orthonormal basis of d's complement:

        * alignment ``a = (Kn d - (d^T Kn d) d) / (d^T Kn d)`` (m entries): zero iff d is an
          eigenvector of K; ``|a| ~ sin(alpha) (1 - 1/rho)`` near the optimum;
        * ratio ``b = log(d^T Kn d) - log(lambda_max(E^T Kn E)) - log(r)``: once d is an
          eigenvector, ``d^T K d / lambda_max(E^T K E)`` is the axis ratio rho (d the major axis
          iff it is >= 1), so b = 0 iff rho = r (f2); for f1 (rho >= r) ``b = min(b, 0)``.

        No eigen-decomposition of K: lambda_max of the 2x2 ``E^T Kn E`` is a closed form with a
        smoothed square root, so the residuals are smooth everywhere (spheres included).
        """
        q = self.pr.q_of(x)
        p, J6 = self.pr.kinematics(q)
        return self._residual_of(p, J6, self.pr.kj_of(x), target, d, r, kind, wpos, walign)

    def _residual_of(self, p, J6, kj, target, d, r, kind: str, wpos, walign):
        """:meth:`lm_residual` from the TCP position, the full Jacobian and the joint stiffnesses."""
        K = self.pr.stiffness_of(J6[..., list(task_rows(self.pr.task)), :], kj)
        return jnp.concatenate([self._pos_rows(p, target, wpos), self._shape_rows(K, d, r, kind, walign)])

    def _pos_rows(self, p, target, wpos):
        rows = jnp.asarray(list(self.rows))
        return wpos * (p[rows] - target[rows])

    @staticmethod
    def _shape_rows(K, d, r, kind: str, walign):
        m = K.shape[-1]
        dd = d[:m] / jnp.maximum(jnp.linalg.norm(d[:m]), 1e-300)
        Kn = K / jnp.maximum(jnp.trace(K) / m, 1e-300)
        Kd = Kn @ dd
        dKd = jnp.maximum(dd @ Kd, 1e-12)
        a = (Kd - dKd * dd) / dKd
        E = complement_basis(dd)
        M = E.T @ Kn @ E
        if m == 3:
            h = 0.5 * (M[0, 0] - M[1, 1])
            lam2 = 0.5 * (M[0, 0] + M[1, 1]) + jnp.sqrt(h * h + M[0, 1] ** 2 + 1e-24)
        else:
            lam2 = M[0, 0]
        b = jnp.log(dKd) - jnp.log(jnp.maximum(lam2, 1e-12)) - jnp.log(r)
        if kind == "f1":
            b = jnp.minimum(b, 0.0)
        return jnp.concatenate([walign * a, b[None]])

    def lm_residual_and_jacobian(self, x, target, d, r, kind: str, wpos, walign):
        """:meth:`lm_residual` (nr,) and its Jacobian (nr, nx), without differentiating the chain.

        The kinematics are evaluated once and their derivative along each free joint is the closed
        form :func:`jaxstiff.kinematics.jacobian_tangent` (from J alone). The compliance
        ``C = J_s W J_s^T`` (``W = diag(1/kj)``) has the closed-form tangents
        ``dC/dq_j = dJ_s W J_s^T + J_s W dJ_s^T`` and ``dC/dkj_i = -w_i^2 j_i j_i^T``; ``K_T`` and
        its tangents come from the same map ``C -> K_T`` as :func:`jaxstiff.stiffness.translational_stiffness`
        (:func:`jaxstiff.stiffness._schur.stiffness_of_compliance`, whose JVP is exact), so the LM
        stage and the reported stiffness agree also next to a singular posture. Only the small maps
        ``C -> K_T -> shape rows`` are differentiated by JAX. Several times cheaper than
        ``jax.jacrev`` of :meth:`lm_residual` through the chain.
        """
        q, kj = self.pr.q_of(x), x[self.nf :]  # kj: the nk sprung joints' stiffnesses
        p, J6 = self.pr.kinematics(q)
        n = self.nk  # the compliance sums over the sprung joints only (rigid locked joints add none)
        dt = x.dtype
        dp, dJ6, _ = jacobian_tangent(J6, jnp.eye(self.n, dtype=dt)[self.free])  # (nf, 3), (nf, 6, n)
        rows_t = list(task_rows(self.pr.task))
        Js, dJs = self.pr.spring_cols(J6[rows_t, :]), self.pr.spring_cols(dJ6[:, rows_t, :])  # (m, nk), (nf, m, nk)
        w = 1.0 / jnp.maximum(kj, jnp.sqrt(jnp.finfo(dt).tiny))  # compliance()'s own clamp of kj
        C = compliance(Js, kj, self.pr.task)

        def tangents_of(G):
            # tangents of S = P C P^T straight from P J_s and P dJ_s (P = [I, -G] for "full", I
            # otherwise): dS_q = PdJ W PJ^T + sym, dS_k = -w_i^2 (P j_i)(P j_i)^T, and the traces
            # of dC_TT that the eigenvalue floor reads; no (m, m) dC per tangent
            t = 3 if G is not None else Js.shape[-2]
            PJ = Js if G is None else Js[:3] - G @ Js[3:]  # (t, nk)
            PdJ = dJs if G is None else dJs[:, :3] - jnp.einsum("ab,fbn->fan", G, dJs[:, 3:])  # (nf, t, nk)
            PJW = PJ * w  # (t, nk)
            dSq = jnp.einsum("fan,bn->fab", PdJ, PJW)
            dSq = dSq + jnp.swapaxes(dSq, -1, -2)
            dSk = -(PJW.T[:, :, None] * PJW.T[:, None, :])  # (nk, t, t)
            JWt = Js[:t] * w
            tr_q = 2.0 * jnp.sum(dJs[:, :t] * JWt[None], axis=(-2, -1))  # (nf,)
            tr_k = -jnp.sum(JWt * JWt, axis=0)  # (nk,)
            return jnp.concatenate([dSq, dSk]), jnp.concatenate([tr_q, tr_k])

        K, dK = stiffness_and_tangents(C, tangents_of)
        shape = lambda K: self._shape_rows(K, d, r, kind, walign)  # noqa: E731
        e_shape, dshape = jax.vmap(lambda T: jax.jvp(shape, (K,), (T,)))(dK)
        ep = self._pos_rows(p, target, wpos)
        rows_p = list(self.rows)
        Jp = jnp.concatenate([wpos * dp[:, rows_p], jnp.zeros((n, len(rows_p)), dt)])  # (nx, k)
        e = jnp.concatenate([ep, e_shape[0]])
        return e, jnp.concatenate([Jp, dshape], axis=1).T

    def lm(self, x, lb, ub, target, d, r, kind: str, iters: int | jax.Array, wpos: float, walign: float, s):  # noqa: PLR0913 - traced arrays, one argument each (a jitted signature)
        """``iters`` box-constrained Levenberg-Marquardt steps on :meth:`lm_residual`.

        Minimum-norm steps in box-scaled coordinates (``s``: per-coordinate box width): the system
        is underdetermined (3 + m + 1 residuals, nf + n unknowns), so from a start near the
        minimum set the iteration converges to a nearby zero. Coordinates at a bound whose step
        points outward are removed and the step recomputed (one active-set pass); the step is
        then clipped into the box. A step is kept only if it lowers the residual norm (damping
        divided by 3), else the damping is multiplied by 4.
        """
        ev = lambda z: self.lm_residual_and_jacobian(z, target, d, r, kind, wpos, walign)  # noqa: E731
        nr = len(self.rows) + (3 if self.pr.m == 3 else 2) + 1
        eye = jnp.eye(nr, dtype=x.dtype)

        def solve(Jy, e, lam):
            A = Jy @ Jy.T
            mu = lam * jnp.maximum(jnp.trace(A) / nr, 1e-300)
            return -Jy.T @ spd_solve(A + mu * eye, e)

        def scaled(J):
            Jy = J * s[None, :]
            return jnp.where(jnp.isfinite(Jy), Jy, 0.0)

        def body(i, carry):
            # pass 0 only evaluates the start (the loop's own evaluation, not a second copy of the
            # residual and its Jacobian in the program: about a tenth fewer kernels to compile)
            x, lam, e, Jy = carry
            start = i == 0

            # the step, then again without the coordinates it pushes out of the box: one solve in
            # the program, run twice (the loop's counter is not batched; its trip count is
            # hidden from XLA, which would unroll it into two copies)
            def active_set_pass(k, carry):
                out, _ = carry
                dy = solve(jnp.where(out[None, :], 0.0, Jy), e, lam)
                new = ((x <= lb) & (dy < 0)) | ((x >= ub) & (dy > 0)) | (s <= 0)
                return jnp.where(k == 0, new, out), dy

            none_out = jnp.zeros(x.shape, bool)
            two = jax.lax.optimization_barrier(jnp.int32(2))
            out, dy = jax.lax.fori_loop(0, two, active_set_pass, batched_like((none_out, x), x))
            dy = jnp.where(out, 0.0, dy)
            xn = jnp.where(start, x, clip_box(x + s * dy, lb, ub))
            en, Jn = ev(xn)
            ok = jnp.all(jnp.isfinite(en)) & jnp.all(jnp.isfinite(xn)) & (en @ en < e @ e)
            return (
                jnp.where(ok, xn, x),
                jnp.where(start, lam, jnp.where(ok, jnp.maximum(lam / 3.0, 1e-9), jnp.minimum(lam * 4.0, 1e6))),
                jnp.where(start, jnp.where(jnp.isfinite(en), en, 1e6), jnp.where(ok, en, e)),
                jnp.where(start | ok, scaled(Jn), Jy),
            )

        nr0 = jnp.zeros((nr,), x.dtype)
        init = (x, jnp.asarray(1e-3, x.dtype), nr0, jnp.zeros((nr, x.shape[0]), x.dtype))
        x, _, _, _ = jax.lax.fori_loop(0, iters + 1, body, batched_like(init, x))
        return x


def _take_rows(J: jax.Array, idx: list[int]) -> jax.Array:
    """Rows ``idx`` of J: a slice where they are consecutive (no gather in the program)."""
    if idx == list(range(idx[0], idx[0] + len(idx))):
        return J[idx[0] : idx[0] + len(idx)]
    return J[np.asarray(idx)]


def spd_solve(A: jax.Array, b: jax.Array) -> jax.Array:
    """``A^-1 b`` for a small symmetric positive definite A (k, k) by an unrolled Cholesky
    factorisation: under vmap this is elementwise arithmetic over the batch (no LAPACK call;
    timing in docs/notes/solvers.md). A non-positive pivot is floored at the dtype's tiny."""
    k = A.shape[-1]
    tiny = jnp.finfo(A.dtype).tiny
    L: dict = {}
    inv = []
    for j in range(k):
        s = A[j, j] - sum((L[(j, i)] * L[(j, i)] for i in range(j)), start=jnp.zeros((), A.dtype))
        L[(j, j)] = jnp.sqrt(jnp.maximum(s, tiny))
        inv.append(1.0 / L[(j, j)])
        for r in range(j + 1, k):
            L[(r, j)] = (A[r, j] - sum((L[(r, i)] * L[(j, i)] for i in range(j)), start=jnp.zeros((), A.dtype))) * inv[
                j
            ]
    y = []
    for r in range(k):
        y.append((b[r] - sum((L[(r, i)] * y[i] for i in range(r)), start=jnp.zeros((), A.dtype))) * inv[r])
    x: list = [None] * k
    for r in reversed(range(k)):
        x[r] = (y[r] - sum((L[(i, r)] * x[i] for i in range(r + 1, k)), start=jnp.zeros((), A.dtype))) * inv[r]
    return jnp.stack(fusion_boundary(x))


def complement_basis(d: jax.Array) -> jax.Array:
    """Orthonormal basis (m, m-1) of the plane (m = 3) or line (m = 2) orthogonal to unit d."""
    m = d.shape[0]
    if m == 2:
        return jnp.stack([-d[1], d[0]])[:, None]
    # helper axis: the coordinate axis least aligned with d (never parallel to it)
    k = jnp.argmin(jnp.abs(d))
    h = jnp.zeros(3, d.dtype).at[k].set(1.0)
    e1 = h - (h @ d) * d
    e1 = e1 / jnp.linalg.norm(e1)
    e2 = jnp.cross(d, e1)
    return jnp.stack([e1, e2], axis=1)


def length_unit(size: float) -> float:
    """The power of two nearest a robot's size (m) in log scale (:attr:`Chain.length_scale`)."""
    return float(2.0 ** round(np.log2(size)))


def lm_kind(problem: WaypointProblem) -> str | None:
    """``"f1"``/``"f2"`` where the LM stage applies (the built-in criteria), else None."""
    return "f2" if problem.criterion is _f2 else ("f1" if problem.criterion is _f1 else None)


def clip_box(x: jax.Array, lb: jax.Array, ub: jax.Array) -> jax.Array:
    """``x`` clipped into the box ``[lb, ub]`` (elementwise)."""
    return jnp.minimum(jnp.maximum(x, lb), ub)


def box_scales(lb: jax.Array, ub: jax.Array, nf: int, kspan: float | jax.Array) -> jax.Array:
    """Per-coordinate step scale: the box width, capped (unbounded / continuous joints: pi rad)."""
    w = ub - lb
    cap = jnp.concatenate([jnp.full((nf,), jnp.pi, lb.dtype), jnp.full((lb.shape[0] - nf,), kspan, lb.dtype)])
    w = jnp.where(jnp.isfinite(w), jnp.minimum(w, cap), cap)
    return jnp.maximum(w, 0.0)


#: Adam's moment decay rates and the floor of its denominator (both pgd and the trajectory solver)
ADAM_B1, ADAM_B2, ADAM_EPS = 0.9, 0.999, 1e-12


def adam_direction(
    g: jax.Array, scale: jax.Array, m1: jax.Array, m2: jax.Array, tt: jax.Array
) -> tuple[jax.Array, jax.Array, jax.Array]:
    """One Adam update of the scaled gradient: ``(u, m1, m2)``.

    ``gy = g * scale`` (non-finite gradient entries count as 0), ``m1 = b1 m1 + (1 - b1) gy``,
    ``m2 = b2 m2 + (1 - b2) gy^2``, ``u = (m1 / (1 - b1^tt)) / (sqrt(m2 / (1 - b2^tt)) + eps)``
    with ``tt`` the 1-based step number (a float of x's dtype). Any shape, elementwise; ``u`` is
    the step direction in scaled variables (the caller multiplies by its step size and ``scale``).
    """
    b1, b2 = ADAM_B1, ADAM_B2
    gy = jnp.where(jnp.isfinite(g), g, 0.0) * scale
    m1 = b1 * m1 + (1 - b1) * gy
    m2 = b2 * m2 + (1 - b2) * gy * gy
    u = (m1 / (1 - b1**tt)) / (jnp.sqrt(m2 / (1 - b2**tt)) + ADAM_EPS)
    return u, m1, m2
