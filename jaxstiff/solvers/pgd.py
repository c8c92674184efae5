"""Multi-start projected gradient for the waypoint problem, batched over many paths (``"pgd"``).

The waypoint problem of :mod:`jaxstiff.solvers.problem` (SPEC section 5, S0-10 ... S0-14) solved
for B trajectories x S starts at once in one jitted JAX function: ``vmap`` over trajectories,
``vmap`` over starts, ``lax.scan`` over the P waypoints (the rate limits chain waypoint p to the
last usable waypoint before it, exactly as :func:`jaxstiff.results.reference_states` rebuilds it),
``lax.fori_loop`` over a fixed number of gradient iterations. No Python loop runs over problems;
one compilation serves every chunk of the same shape (chunks are padded to the chunk size).

One waypoint, one start (``x = [q_free, kj]``, box ``[lb, ub]`` = joint/stiffness limits
intersected with the rate box around the reference state, rounded inwards so that
``|x - x_ref| <= dq, dk`` holds exactly in floating point):

1. start point: the reference state clipped into the box (start 0) or a uniform random point
   of a sub-box around it (starts 1..S-1); at the first waypoint without rate limits the joint
   perturbation is large (``posture_spread`` rad), so that after the Newton correction the starts
   are distinct null-space postures of the arm on the same TCP point, and the stiffnesses are
   drawn log-uniformly over ``[kmin, kmax]`` (the minima of f1/f2 often have several joints
   near ``kmin``, which uniform draws almost never visit);
2. Newton corrections onto the path (minimum-norm Gauss-Newton on the free joints, clipped to the
   box; joints that hit a bound are frozen for the rest of the correction, so every Newton step
   respects the box);
3. first waypoint only: a warm-up on a smooth shape surrogate (``surrogate_first``);
4. f1 and f2: ``lm_iters`` (first waypoint ``lm_iters_first``) box-constrained
   Levenberg-Marquardt steps on residuals whose zeros are exactly the criterion's minimum set
   (position rows, alignment of d with an eigenvector of K, log of the axis ratio minus log r;
   :meth:`_Ops.lm_residual`). Where the minimum set is reachable this converges to it to ~1e-9
   in a few steps, which first-order steps on the kinked criteria (|alpha|, |r - rho|) do not;
   where it is not, the alignment rows weigh ``lm_walign`` times more than the ratio row, as the
   criteria weigh degrees of alpha;
5. projected Adam steps on the criterion itself (``iters``; after the LM stage ``iters_lm``; first
   waypoint ``iters_first``) in box-scaled variables (each coordinate divided by its box width),
   bound-active coordinates removed, the joint part projected onto the null space of the position
   Jacobian, a geometrically decaying step ``step0 -> step1``; after each step: clip into the
   box, ``newton`` corrections. Its first iterate is the LM point, so it never returns worse;
6. the best iterate (lowest criterion among iterates whose position error is below
   ``accept_tol``) gets a final ``polish`` Newton corrections; the final status is decided on
   that point exactly as :mod:`jaxstiff.results` defines it: every coordinate inside the box
   (by construction: clip), position error <= ``pos_tol``, criterion finite.

Among the usable starts whose criterion is within ``tie_tol`` (relative) of the best, the one
farthest from the joint and stiffness limits (normalised, stiffness in log scale) is kept: f1 and
f2 have whole sets of optimal states, and one with a stiffness pinned at ``kmin``/``kmax`` or a
joint at its limit may leave no room to follow the rest of the path.

Two ways to use the S starts (``options["mode"]``):

* ``"rollout"`` (default): S independent trajectories, each carrying its own state from its own
  first posture (start 0 from q0, then greedy SLSQP's IK postures, then random ones); the
  trajectory with the fewest unusable waypoints, then the lowest total criterion, is kept. Wins
  whenever the first posture decides whether a joint or stiffness limit binds later, which on
  random paths is most of the difference: a greedy choice cannot undo its posture later.
* ``"best"``: at every waypoint all S starts begin around the one carried state and the best
  feasible point is kept and carried (greedy, like the seed, with S chances per waypoint and
  ``starts_first`` at the first). Wins on a single waypoint's local minima, loses when the one
  carried state is cornered against a limit (then every later waypoint can be lost).

Measured (KUKA LWR 4, A7 locked, r = 5, 2 deg / 5 Nm/rad per waypoint):
``experiments/quality_study.py --paths 100`` (100 random paths x 60 waypoints, S = 8), total
criterion over the random paths: f1 rollout 63.0, best 7429, greedy SLSQP 1054; f2 rollout 6066,
best 26013, SLSQP 7902. 100 bench paths x 100 waypoints, f2, S = 4: rollout mean 1.01169 (98.7%
of waypoints <= SLSQP + 1e-6), best 1.155 (97.4%), SLSQP 1.01153.

Status codes: ``0`` SOLVED (feasible), ``3`` UNREACHABLE (no start reached the path within
``pos_tol``), ``4`` NONFINITE. A fixed-iteration method has no convergence flag, so
NOT_CONVERGED (1) and CLIPPED (2) are not produced; ``solver_code`` is the index of the start that
won (``-1`` for none), ``nit`` the iterations per start, ``nfev`` the gradient evaluations over
all starts of that waypoint.

Runs unchanged on a GPU (pure ``jax.numpy``, no host callbacks); ``time_s`` is the chunk's wall
time spread evenly over its waypoints.
"""

from __future__ import annotations

import functools
import time
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from jaxstiff.results import files as R
from jaxstiff.runtime.xla import kernel_compiler_options
from jaxstiff.stiffness.criteria import f1 as _f1, f2 as _f2
from jaxstiff.model.kinematics import jacobian_tangent, position_and_jacobian
from jaxstiff.stiffness.core import fusion_boundary, damped_inverse_primal, compliance, task_rows, translational_stiffness
from jaxstiff.solvers.problem import POS_TOL, Limits, WaypointProblem, check_option_values, content_seed, rate_bounds

__all__ = ["DEFAULT_OPTIONS", "solve_batch", "make_kernel"]

#: Settings (``shape(..., solver="pgd", starts=S, options=...)``).
DEFAULT_OPTIONS: dict[str, Any] = {
    "starts": 8,  # S starts per waypoint ("best") or independent rollouts ("rollout")
    "mode": "rollout",  # "rollout" | "best" (see the module docstring for when each wins)
    "iters": 40,  # projected gradient iterations per start and waypoint
    "iters_first": 150,  # iterations at the first waypoint (its box is the whole joint range)
    "starts_first": 16,  # starts at the first waypoint ("best" mode; rollouts: S)
    "newton": 2,  # Newton corrections after each step
    "polish": 6,  # Newton corrections of the final point
    "surrogate": 0.0,  # fraction of the iterations spent on the smooth surrogate first
    "surrogate_first": 0.5,  # the same at the first waypoint (no warm start there)
    "step0_first": 0.15,  # first step at the first waypoint, fraction of the box width
    "step0": 0.05,  # first step, fraction of the box width
    "step1": 1e-5,  # last step, fraction of the box width
    "spread": 0.5,  # random starts: fraction of the box half-width around the reference
    "posture_spread": 0.6,  # rad, joint perturbation of the first-waypoint postures (no rate limit)
    "accept_tol": 1e-7,  # m, position error of an iterate that may be kept as the best
    "iters_lm": 10,  # criterion iterations after the LM stage (f1, f2; later waypoints)
    "lm_iters": 20,  # Levenberg-Marquardt steps on the f1/f2 residuals before the gradient stage
    "lm_iters_first": 25,  # the same at the first waypoint
    "lm_wpos": 1e3,  # 1/m, weight of the position rows in the LM residual
    "lm_walign": 100.0,  # weight of the alignment rows against the log-ratio row (alpha first, as f1/f2 do)
    "tie_tol": 1e-7,  # starts within this (relative) of the best criterion tie; the one farthest from the limits is kept
    "chunk": 256,  # trajectories per compiled call (memory bound)
    "seed": 0,
}


def check_options(options: dict | None, starts: int | None = None) -> dict[str, Any]:
    """:data:`DEFAULT_OPTIONS` updated by ``options`` (and ``starts``), values checked (ValueError)."""
    opts = {**DEFAULT_OPTIONS, **(options or {})}
    if starts is not None:
        opts["starts"] = int(starts)
    unknown = set(opts) - set(DEFAULT_OPTIONS) - {"maxiter", "ftol", "kj_scale", "f_scale", "polish_slsqp", "traj_iters", "traj_step0", "traj_step1", "warm", "blocks", "mu0", "chain"}
    if unknown:
        raise ValueError(f"unknown pgd option(s) {sorted(unknown)}; known: {sorted(DEFAULT_OPTIONS)}")
    return check_option_values(
        "pgd", opts,
        int_min={"starts": 1, "iters": 1, "iters_first": 1, "starts_first": 1, "iters_lm": 1, "chunk": 1, "newton": 0,
                 "polish": 0, "lm_iters": 0, "lm_iters_first": 0, "seed": 0},
        positive=("step0_first", "step0", "step1", "accept_tol", "lm_wpos", "lm_walign"),
        nonnegative=("surrogate", "surrogate_first", "spread", "posture_spread", "tie_tol"),
        choices={"mode": ("best", "rollout")},
    )


# ---------------------------------------------------------------------- JAX building blocks
class _Ops:
    """Traceable pieces of one waypoint problem on the decision vector x = [q_free, kj]."""

    def __init__(self, problem: WaypointProblem):
        self.pr = problem
        robot = problem.robot
        self.nf, self.n, self.nx = problem.n_free, problem.n, problem.nx
        free = list(problem.free_idx)
        self.free = np.asarray(free, dtype=int)
        self.rows = problem.pos_rows
        self.qlo = np.asarray(robot.lower, float)[free]
        self.qhi = np.asarray(robot.upper, float)[free]

    def box(self, xref, rate, dq_f, dk, kmin, kmax):
        """Rate-limited box (lb, ub) (nx,) around xref; ``rate`` a traced bool."""
        dt = xref.dtype
        qlo, qhi = jnp.asarray(self.qlo, dt), jnp.asarray(self.qhi, dt)
        klo = jnp.full((self.n,), kmin, dt)
        khi = jnp.full((self.n,), kmax, dt)
        rlq, ruq = rate_bounds(xref[: self.nf], dq_f, jnp)
        rlk, ruk = rate_bounds(xref[self.nf :], dk, jnp)
        lbq = jnp.where(rate, jnp.maximum(qlo, rlq), qlo)
        ubq = jnp.where(rate, jnp.minimum(qhi, ruq), qhi)
        lbk = jnp.where(rate, jnp.maximum(klo, rlk), klo)
        ubk = jnp.where(rate, jnp.minimum(khi, ruk), khi)
        return jnp.concatenate([lbq, lbk]), jnp.concatenate([ubq, ubk])

    def pos_jac(self, x):
        q = self.pr.q_of(x)
        p, J = position_and_jacobian(self.pr.robot, q, self.rows)
        return p, J[:, self.free]

    def f(self, x, d, r, c):
        return self.pr.objective(self.pr.q_of(x), self.pr.kj_of(x), d, r, c)

    def newton(self, x, target, lb, ub, steps: int):
        """``steps`` box-respecting minimum-norm Gauss-Newton corrections of the joint part."""
        if steps == 0 or self.nf == 0:
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
            step = Ja.T @ _spd_solve(JJt + mu * jnp.eye(k, dtype=x.dtype), e)
            step = jnp.where(jnp.all(jnp.isfinite(step)), step, 0.0)
            raw = x[: self.nf] + step
            new = jnp.minimum(jnp.maximum(raw, lb[: self.nf]), ub[: self.nf])
            active = active | (new != raw)
            return x.at[: self.nf].set(new), active

        x, _ = jax.lax.fori_loop(0, steps, body, (x, jnp.zeros(self.nf, bool)))
        return x

    def surrogate(self, x, d, r, c):
        """Smooth shape surrogate: ``|K/|K| - D/|D||_F^2`` with ``D = r d d^T + (I - d d^T)``.

        Zero iff K is a multiple of D (major axis along d, ratio r, minor axes equal); no
        eigen-decomposition, so no kinks or eigenvalue-ordering jumps: it pulls a poor start
        into the basin of the criterion's minimum before the criterion itself is optimised.
        """
        K = self.pr.stiffness(self.pr.q_of(x), self.pr.kj_of(x))
        m = K.shape[-1]
        dd = d[:m] / jnp.linalg.norm(d[:m])
        D = (r - 1.0) * jnp.outer(dd, dd) + jnp.eye(m, dtype=K.dtype)
        Kn = K / jnp.sqrt(jnp.sum(K * K))
        Dn = D / jnp.sqrt(jnp.sum(D * D))
        return jnp.sum((Kn - Dn) ** 2)

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
        p, J6 = position_and_jacobian(self.pr.robot, q)
        return self._residual_of(p, J6, self.pr.kj_of(x), target, d, r, kind, wpos, walign)

    def _residual_of(self, p, J6, kj, target, d, r, kind: str, wpos, walign):
        """:meth:`lm_residual` from the TCP position, the full Jacobian and the joint stiffnesses."""
        K = translational_stiffness(J6[..., list(task_rows(self.pr.task)), :], kj, task=self.pr.task)
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
        E = _complement_basis(dd)
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
        form :func:`jaxstiff.kinematics.jacobian_tangent` (from J alone). The stiffness derivatives
        are closed forms too: with ``C = J_s W J_s^T`` (``W = diag(1/kj)``), its (damped) inverse
        ``K_C``, ``P`` the translational columns of ``K_C`` (``K_T`` their top block; ``dK_C = -K_C
        dC K_C``), ``G = P^T J_s`` and ``H_j = P^T dJ_s/dq_j``:
        ``dK_T/dq_j = -(H_j W G^T + G W H_j^T)`` and ``dK_T/dkj_i = g_i g_i^T / kj_i^2`` (g_i the
        column i of G), the damping held fixed as in :func:`jaxstiff.stiffness.translational_stiffness`.
        Only the tiny map ``K_T -> shape rows`` is differentiated by JAX. Several times cheaper
        than ``jax.jacrev`` of :meth:`lm_residual` through the chain.
        """
        q, kj = self.pr.q_of(x), self.pr.kj_of(x)
        p, J6 = position_and_jacobian(self.pr.robot, q)
        n, nf = self.n, self.nf
        dt = x.dtype
        dp, dJ6, _ = jacobian_tangent(J6, jnp.eye(n, dtype=dt)[self.free])  # (nf, 3), (nf, 6, n)
        rows_t = list(task_rows(self.pr.task))
        Js, dJs = J6[rows_t, :], dJ6[:, rows_t, :]  # (m, n), (nf, m, n)
        w = 1.0 / jnp.maximum(kj, jnp.sqrt(jnp.finfo(dt).tiny))  # compliance()'s own clamp of kj
        m = Js.shape[0]
        t = 3 if m == 6 else m
        Kc = damped_inverse_primal(compliance(Js, kj, self.pr.task), False)  # the damped inverse, all of it (no AD through it here)
        P = Kc[:, :t]  # (m, t)
        K = Kc[:t, :t]
        G = jnp.sum(P[:, :, None] * Js[:, None, :], axis=0)  # (t, n)
        H = jnp.sum(P[None, :, :, None] * dJs[:, :, None, :], axis=1)  # (nf, t, n)
        HWG = jnp.sum(H[:, :, None, :] * (G * w)[None, None, :, :], axis=-1)  # (nf, t, t)
        dKq = -(HWG + jnp.swapaxes(HWG, -1, -2))
        gw = G * w  # (t, n)
        dKk = gw.T[:, :, None] * gw.T[:, None, :]  # (n, t, t)
        dK = jnp.concatenate([dKq, dKk])  # (nx, t, t)
        shape = lambda K: self._shape_rows(K, d, r, kind, walign)  # noqa: E731
        e_shape, dshape = jax.vmap(lambda T: jax.jvp(shape, (K,), (T,)))(dK)
        ep = self._pos_rows(p, target, wpos)
        rows_p = list(self.rows)
        Jp = jnp.concatenate([wpos * dp[:, rows_p], jnp.zeros((n, len(rows_p)), dt)])  # (nx, k)
        e = jnp.concatenate([ep, e_shape[0]])
        return e, jnp.concatenate([Jp, dshape], axis=1).T

    def lm(self, x, lb, ub, target, d, r, kind: str, iters: int, wpos: float, walign: float, s):
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
            return -Jy.T @ _spd_solve(A + mu * eye, e)

        def scaled(J):
            Jy = J * s[None, :]
            return jnp.where(jnp.isfinite(Jy), Jy, 0.0)

        def body(_, carry):
            x, lam, e, Jy = carry
            dy = solve(Jy, e, lam)
            out = ((x <= lb) & (dy < 0)) | ((x >= ub) & (dy > 0)) | (s <= 0)
            dy = solve(jnp.where(out[None, :], 0.0, Jy), e, lam)
            dy = jnp.where(out, 0.0, dy)
            xn = _clip(x + s * dy, lb, ub)
            en, Jn = ev(xn)
            ok = jnp.all(jnp.isfinite(en)) & jnp.all(jnp.isfinite(xn)) & (en @ en < e @ e)
            return (
                jnp.where(ok, xn, x),
                jnp.where(ok, jnp.maximum(lam / 3.0, 1e-9), jnp.minimum(lam * 4.0, 1e6)),
                jnp.where(ok, en, e),
                jnp.where(ok, scaled(Jn), Jy),
            )

        e0, J0 = ev(x)
        e0 = jnp.where(jnp.isfinite(e0), e0, 1e6)
        x, _, _, _ = jax.lax.fori_loop(0, iters, body, (x, jnp.asarray(1e-3, x.dtype), e0, scaled(J0)))
        return x


def _spd_solve(A, b):
    """``A^-1 b`` for a small symmetric positive definite A (k, k) by an unrolled Cholesky
    factorisation: under vmap this is elementwise arithmetic over the batch, several times
    faster on a CPU than LAPACK's batched LU for k ~ 7."""
    k = A.shape[-1]
    tiny = jnp.finfo(A.dtype).tiny
    L: dict = {}
    inv = []
    for j in range(k):
        s = A[j, j] - sum((L[(j, i)] * L[(j, i)] for i in range(j)), start=jnp.zeros((), A.dtype))
        L[(j, j)] = jnp.sqrt(jnp.maximum(s, tiny))
        inv.append(1.0 / L[(j, j)])
        for r in range(j + 1, k):
            L[(r, j)] = (A[r, j] - sum((L[(r, i)] * L[(j, i)] for i in range(j)), start=jnp.zeros((), A.dtype))) * inv[j]
    y = []
    for r in range(k):
        y.append((b[r] - sum((L[(r, i)] * y[i] for i in range(r)), start=jnp.zeros((), A.dtype))) * inv[r])
    x: list = [None] * k
    for r in reversed(range(k)):
        x[r] = (y[r] - sum((L[(i, r)] * x[i] for i in range(r + 1, k)), start=jnp.zeros((), A.dtype))) * inv[r]
    return jnp.stack(fusion_boundary(x))


def _complement_basis(d):
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


def _lm_kind(problem: WaypointProblem) -> str | None:
    """``"f1"``/``"f2"`` where the LM stage applies (the built-in criteria), else None."""
    return "f2" if problem.criterion is _f2 else ("f1" if problem.criterion is _f1 else None)


def _clip(x, lb, ub):
    return jnp.minimum(jnp.maximum(x, lb), ub)


def _scales(lb, ub, nf, kspan):
    """Per-coordinate step scale: the box width, capped (unbounded / continuous joints: pi rad)."""
    w = ub - lb
    cap = jnp.concatenate([jnp.full((nf,), jnp.pi, lb.dtype), jnp.full((lb.shape[0] - nf,), kspan, lb.dtype)])
    w = jnp.where(jnp.isfinite(w), jnp.minimum(w, cap), cap)
    return jnp.maximum(w, 0.0)


def _optimise(ops: _Ops, x0, lb, ub, target, d, r, c, kspan, opts, first=False, lm=None):
    """Surrogate phase, LM phase (``lm``: x -> x, f1/f2 only), then the criterion phase, from x0
    (on the path). Returns the best iterate of the criterion phase (its first iterate is the LM
    point, so the criterion phase never returns anything worse than LM's answer).

    ``first``: the first waypoint's settings (``iters_first``, ``surrogate_first``, ``step0_first``).
    """
    if first:
        opts = {**opts, "iters": opts["iters_first"], "surrogate": opts["surrogate_first"], "step0": opts["step0_first"]}
    elif lm is not None:
        opts = {**opts, "iters": opts["iters_lm"]}
    iters = int(opts["iters"])
    ns = int(round(float(opts["surrogate"]) * iters))
    if ns > 0:
        x0 = _descend(ops, ops.surrogate, x0, lb, ub, target, d, r, c, kspan, opts, ns, track=False)
    if lm is not None:
        x0 = lm(x0)
    return _descend(ops, ops.f, x0, lb, ub, target, d, r, c, kspan, opts, max(iters - ns, 1), track=True)


def _descend(ops: _Ops, obj, x0, lb, ub, target, d, r, c, kspan, opts, iters, track):
    """``iters`` projected Adam steps on ``obj``; with ``track`` the best acceptable iterate of the
    criterion is returned, else the last iterate."""
    nn = int(opts["newton"])
    s0, s1, acc = float(opts["step0"]), float(opts["step1"]), float(opts["accept_tol"])
    nf = ops.nf
    rows = jnp.asarray(ops.rows)
    k = len(ops.rows)
    s = _scales(lb, ub, nf, kspan)
    vg = jax.value_and_grad(obj)
    decay = (s1 / s0) ** (1.0 / max(iters - 1, 1))

    def score(fv, err):
        ok = (err <= acc) & jnp.isfinite(fv)
        return jnp.where(ok, fv, jnp.inf)

    b1, b2 = 0.9, 0.999

    def body(t, carry):
        x, bx, bf, m1, m2 = carry
        fv, g = vg(x, d, r, c)
        err = ops.pos_err(x, target)
        sc = score(fv, err)
        better = sc < bf
        bx = jnp.where(better, x, bx)
        bf = jnp.where(better, sc, bf)
        # Adam moments of the box-scaled gradient (per-coordinate normalisation: the joint and
        # stiffness coordinates differ by orders of magnitude in sensitivity)
        gy = jnp.where(jnp.isfinite(g), g, 0.0) * s
        m1 = b1 * m1 + (1 - b1) * gy
        m2 = b2 * m2 + (1 - b2) * gy * gy
        tt = (t + 1).astype(x.dtype)
        u = (m1 / (1 - b1**tt)) / (jnp.sqrt(m2 / (1 - b2**tt)) + 1e-12)
        # bound-active coordinates dropped, joint part projected onto the path's null space
        free_c = ~(((x <= lb) & (u > 0)) | ((x >= ub) & (u < 0))) & (s > 0)
        u = jnp.where(free_c, u, 0.0)
        if nf:
            _, J = ops.pos_jac(x)
            Jy = J * s[None, :nf] * free_c[None, :nf]
            JJt = Jy @ Jy.T
            mu = 1e-12 * jnp.maximum(jnp.trace(JJt), 1e-300)
            lam = _spd_solve(JJt + mu * jnp.eye(k, dtype=x.dtype), Jy @ u[:nf])
            uq = u[:nf] - Jy.T @ lam
            u = u.at[:nf].set(jnp.where(free_c[:nf], uq, 0.0))
        eta = s0 * decay**t
        xn = _clip(x - eta * s * u, lb, ub)
        xn = ops.newton(xn, target, lb, ub, nn)
        xn = jnp.where(jnp.all(jnp.isfinite(xn)), xn, x)
        return xn, bx, bf, m1, m2

    z = jnp.zeros_like(x0)
    x, bx, bf, _, _ = jax.lax.fori_loop(0, iters, body, (x0, x0, jnp.asarray(jnp.inf, x0.dtype), z, z))
    if not track:
        return x
    # the last iterate has not been scored yet
    fv = ops.f(x, d, r, c)
    sc = score(fv, ops.pos_err(x, target))
    better = sc < bf
    bx = jnp.where(better, x, bx)
    # nothing acceptable seen: keep the last iterate (the polish may still bring it onto the path)
    bx = jnp.where(jnp.isinf(jnp.minimum(bf, sc)), x, bx)
    return bx


def _finish(ops: _Ops, x, lb, ub, target, d, r, c, pos_tol, polish):
    """Final Newton polish and the verdict: (x, f, err, usable, finite)."""
    x = ops.newton(_clip(x, lb, ub), target, lb, ub, polish)
    x = _clip(x, lb, ub)
    fv = ops.f(x, d, r, c)
    err = ops.pos_err(x, target)
    finite = jnp.all(jnp.isfinite(x)) & jnp.isfinite(fv) & jnp.isfinite(err)
    usable = finite & (err <= pos_tol)
    return x, fv, err, usable, finite


def make_kernel(problem: WaypointProblem, opts: dict[str, Any], first_rate: bool):
    """The per-trajectory function ``(targets (P,3), dirs (P,3), x0 (nx,), key, dq_f, dk, kmin,
    kmax, r, c, pos_tol, extra (E, nx)) -> dict`` (traceable, vmappable over trajectories);
    ``extra``: given first-waypoint start states (E may be 0)."""
    ops = _Ops(problem)
    S = int(opts["starts"])
    mode = opts["mode"]
    spread, pspread = float(opts["spread"]), float(opts["posture_spread"])
    polish = int(opts["polish"])
    nf, nx = ops.nf, ops.nx

    def starts_at(key, xref, lb, ub, rate, kmin, kmax, S=S):
        """(S, nx) start points in the box: start 0 the reference, others random around it."""
        u = jax.random.uniform(key, (S, nx), xref.dtype, -1.0, 1.0)
        half = 0.5 * _scales(lb, ub, nf, kmax - kmin)
        near = xref[None, :] + u * (spread * half)[None, :]
        # first waypoint without rate limit: distinct postures (large joint moves) and stiffnesses
        # drawn log-uniformly over the range: the criterion only sees stiffness ratios, and the
        # minima often have several joints near kmin, which uniform draws almost never visit
        lo = jnp.log(jnp.maximum(lb[nf:], 1e-6 * kmax))
        hi = jnp.log(jnp.maximum(ub[nf:], 1e-6 * kmax))
        kfar = jnp.exp(lo[None, :] + 0.5 * (u[:, nf:] + 1.0) * (hi - lo)[None, :])
        far = jnp.concatenate([xref[None, :nf] + u[:, :nf] * pspread, kfar], axis=1)
        xs = jnp.where(rate, near, far)
        xs = xs.at[0].set(xref)
        return _clip(xs, lb[None, :], ub[None, :])

    kind = _lm_kind(problem)
    lm_it = int(opts["lm_iters_first"]), int(opts["lm_iters"])
    wpos, walign = float(opts["lm_wpos"]), float(opts["lm_walign"])

    def one_start(x0, lb, ub, tgt, d, r, c, kspan, pos_tol, rate, first=False):
        x0 = ops.newton(x0, tgt, lb, ub, 8)
        nlm = lm_it[0] if first else lm_it[1]
        lm = None
        if kind is not None and nlm > 0:
            def lm(x):
                x = ops.lm(x, lb, ub, tgt, d, r, kind, nlm, wpos, walign, _scales(lb, ub, nf, kspan))
                return ops.newton(x, tgt, lb, ub, 3)
        xb = _optimise(ops, x0, lb, ub, tgt, d, r, c, kspan, opts, first, lm=lm)
        return _finish(ops, xb, lb, ub, tgt, d, r, c, pos_tol, polish)

    vstart = jax.vmap(one_start, in_axes=(0, 0, 0, None, None, None, None, None, None, 0))
    S1 = max(S, int(opts["starts_first"])) if mode == "best" else S
    vfirst = jax.vmap(lambda *a: one_start(*a, first=True), in_axes=(0, None, None, None, None, None, None, None, None, None))

    qlo, qhi = ops.qlo, ops.qhi
    tie = float(opts["tie_tol"])

    def pick(x, fv, err, usable, finite, kmin, kmax):
        """Index of the kept start: among the usable ones within ``tie_tol`` (relative) of the best
        criterion, the one farthest from the joint and stiffness limits (normalised; stiffness in
        log scale), so that later waypoints have room to follow the path. None usable: the
        finite one closest to the path."""
        sc = jnp.where(usable, fv, jnp.inf)
        fb = jnp.min(sc)
        near = usable & (sc <= fb + tie * jnp.maximum(jnp.abs(fb), 1.0))
        dt = x.dtype
        lo = jnp.concatenate([jnp.asarray(np.where(np.isfinite(qlo), qlo, -np.pi), dt), jnp.full((ops.n,), jnp.log(kmin))])
        hi = jnp.concatenate([jnp.asarray(np.where(np.isfinite(qhi), qhi, np.pi), dt), jnp.full((ops.n,), jnp.log(kmax))])
        y = jnp.concatenate([x[:, :nf], jnp.log(jnp.maximum(x[:, nf:], 1e-300))], axis=1)
        room = jnp.min(jnp.minimum(y - lo, hi - y) / jnp.maximum(hi - lo, 1e-300), axis=1)
        i_near = jnp.argmax(jnp.where(near, room, -jnp.inf))
        return jnp.where(jnp.any(usable), i_near, jnp.argmin(jnp.where(finite, err, jnp.inf)))

    def traj(targets, dirs, x0, key, dq_f, dk, kmin, kmax, r, c, pos_tol, extra):
        kspan = kmax - kmin

        def step(carry, inp):
            xref, at_start = carry  # (S, nx), (S,)
            tgt, d, kk = inp
            rate = (~at_start) | first_rate
            lb, ub = jax.vmap(lambda xr, rt: ops.box(xr, rt, dq_f, dk, kmin, kmax))(xref, rate)
            if mode == "best":
                xs = starts_at(kk, xref[0], lb[0], ub[0], rate[0], kmin, kmax)
            else:
                # rollouts: one start each, from its own state; before the first usable waypoint
                # rollout s takes the s-th distinct posture (all refs still equal x0 there)
                xs0 = starts_at(kk, xref[0], lb[0], ub[0], rate[0], kmin, kmax)
                xs = jnp.where(at_start[:, None], xs0, jax.vmap(_clip)(xref, lb, ub))
            x, fv, err, usable, finite = vstart(xs, lb, ub, tgt, d, r, c, kspan, pos_tol, rate)
            if mode == "best":
                i = pick(x, fv, err, usable, finite, kmin, kmax)
                xw, fw, ew, uw, finw = x[i], fv[i], err[i], usable[i], finite[i]
                newref = jnp.where(uw, xw, xref[0])
                carry = (jnp.broadcast_to(newref, xref.shape), jnp.broadcast_to(at_start[0] & ~uw, at_start.shape))
                status = jnp.where(uw, R.SOLVED, jnp.where(finw, R.UNREACHABLE, R.NONFINITE))
                xw = jnp.where(finw, xw, _clip(xref[0], lb[0], ub[0]))
                out = (xw, fw, ew, status, jnp.where(jnp.any(usable), i, -1))
            else:
                newref = jnp.where(usable[:, None], x, xref)
                carry = (newref, at_start & ~usable)
                status = jnp.where(usable, R.SOLVED, jnp.where(finite, R.UNREACHABLE, R.NONFINITE))
                xo = jnp.where(finite[:, None], x, jax.vmap(_clip)(xref, lb, ub))
                out = (xo, fv, err, status, jnp.arange(S))
            return carry, out

        P = targets.shape[0]
        keys = jax.random.split(key, P + 1)
        # first waypoint apart: more starts and iterations (its box is usually the whole range)
        rate0 = jnp.asarray(first_rate)
        lb0, ub0 = ops.box(x0, rate0, dq_f, dk, kmin, kmax)
        xs0 = starts_at(keys[P], x0, lb0, ub0, rate0, kmin, kmax, S=S1)
        # given start states (greedy SLSQP's IK postures) replace random starts 1..E
        E = min(extra.shape[0], S1 - 1)
        if E > 0:
            xs0 = xs0.at[1 : 1 + E].set(_clip(extra[:E], lb0[None, :], ub0[None, :]))
        x1, f1, e1, u1, fin1 = vfirst(xs0, lb0, ub0, targets[0], dirs[0], r, c, kspan, pos_tol, rate0)
        st1 = jnp.where(u1, R.SOLVED, jnp.where(fin1, R.UNREACHABLE, R.NONFINITE))
        x1 = jnp.where(fin1[:, None], x1, _clip(x0, lb0, ub0)[None, :])
        if mode == "best":
            i1 = pick(x1, f1, e1, u1, fin1, kmin, kmax)
            first = (x1[i1], f1[i1], e1[i1], st1[i1], jnp.where(jnp.any(u1), i1, -1))
            carry0 = (jnp.broadcast_to(jnp.where(u1[i1], x1[i1], x0), (S, nx)), jnp.broadcast_to(~u1[i1], (S,)))
        else:
            first = (x1, f1, e1, st1, jnp.arange(S))
            carry0 = (jnp.where(u1[:, None], x1, x0[None, :]), ~u1)
        _, rest = jax.lax.scan(step, carry0, (targets[1:], dirs[1:], keys[1:P]))
        X, F, E, ST, WIN = (jnp.concatenate([a[None], b], axis=0) for a, b in zip(first, rest))
        if mode == "rollout":
            # X (P, S, nx): keep the trajectory with fewest unusable waypoints, then lowest sum f
            bad = jnp.sum(ST != R.SOLVED, axis=0)
            tot = jnp.sum(jnp.where(ST == R.SOLVED, F, 0.0), axis=0)
            sc = bad * 1e12 + jnp.where(jnp.isfinite(tot), tot, 1e11)
            i = jnp.argmin(sc)
            X, F, E, ST = X[:, i], F[:, i], E[:, i], ST[:, i]
            WIN = jnp.full((P,), i)
        return {"x": X, "f": F, "err": E, "status": ST, "start": WIN}

    return traj


@functools.lru_cache(maxsize=32)
def _compiled(problem: WaypointProblem, opts_items: tuple, first_rate: bool):
    opts = dict(opts_items)
    traj = make_kernel(problem, opts, first_rate)
    # per path: targets, directions, start state, key, rate limits (dq_f, dk) and ratio
    batched = jax.vmap(traj, in_axes=(0, 0, 0, 0, 0, 0, None, None, 0, None, None, 0))
    return jax.jit(batched, compiler_options=kernel_compiler_options())


def _pad(a: np.ndarray, C: int) -> np.ndarray:
    if a.shape[0] == C:
        return a
    reps = np.repeat(a[-1:], C - a.shape[0], axis=0)
    return np.concatenate([a, reps], axis=0)


def solve_batch(
    problem: WaypointProblem,
    targets: np.ndarray,
    directions: np.ndarray,
    q0: np.ndarray,
    kj0: np.ndarray,
    limits: Limits,
    ratio,
    c: float,
    *,
    starts: int | None = None,
    options: dict | None = None,
    pos_tol: float = POS_TOL,
    return_timing: bool = False,
    first_starts=None,
) -> dict[str, np.ndarray]:
    """Shape B paths with multi-start projected gradient (the solver behind ``solver="pgd"``).

    Args:
        problem: the waypoint problem (robot, task, criterion).
        targets, directions: (B, P, 3), m and unit vectors, base frame.
        q0, kj0: (B, n) start states (rad; Nm/rad).
        limits: rate limits and stiffness range (S0-11 ... S0-14); ``dq``/``dk`` (n,) or (B, n)
            (one row per path).
        ratio: wanted axis ratio r, a number or (B,) (one per path: a parameter sweep in one call).
        c: f1's offset.
        starts: S (default ``options["starts"]``).
        options: see :data:`DEFAULT_OPTIONS`.
        pos_tol: m, position error of a usable waypoint.
        return_timing: also return ``compile_s`` and ``run_s`` (first chunk's compile apart).
        first_starts: per path, a list of start states ``(q (n,), kj (n,))`` for the first waypoint
            (e.g. :func:`jaxstiff.shaping.first_start_postures`, greedy SLSQP's IK postures); they
            replace random first-waypoint starts 1..E (at most ``starts_first - 1`` of them).

    Returns:
        dict with ``q``, ``kj`` (B,P,n), ``status``, ``pos_error``, ``solver_code``, ``nit``,
        ``nfev``, ``time_s``, ``criterion`` (B,P) in the :data:`jaxstiff.shaping.SOLVERS` format.
    """
    opts = check_options(options, starts)
    targets = np.asarray(targets, float)
    directions = np.asarray(directions, float)
    B, P = targets.shape[:2]
    n, nf = problem.n, problem.n_free
    r_arr = np.broadcast_to(np.asarray(ratio, float), (B,)).copy()
    x0 = problem.x_of(np.asarray(q0, float), np.asarray(kj0, float))
    # at least 2 rows per compiled call: XLA compiles a batch of 1 differently (size-1 axes are
    # simplified away), so a lone path would differ from the same path in a batch in the last bits;
    # compiled batches of 2 or more rows give every row bit-identical results (measured on CPU)
    C = max(min(int(opts["chunk"]), B), 2)
    key_items = tuple(sorted((k, v) for k, v in opts.items() if k in DEFAULT_OPTIONS and k not in ("chunk", "seed")))
    fn = _compiled(problem, key_items, bool(limits.first_rate_limit))
    dq_all, dk = limits.rows(B)  # (B, n) each: per-path rate limits
    dq_f = dq_all[:, list(problem.free_idx)]
    base = jax.random.PRNGKey(int(opts["seed"]))
    # each path's key from the seed and the path's own data, never from its index: a path's result
    # does not depend on its position in the batch or on the chunk size
    E = min(len(fs) for fs in first_starts) if first_starts else 0
    extra = np.zeros((B, E, problem.nx))
    for b in range(B if E else 0):
        extra[b] = [problem.x_of(np.asarray(qs, float), np.asarray(ks, float)) for qs, ks in first_starts[b][:E]]
    path_data = np.array([content_seed(targets[b], directions[b], x0[b]) for b in range(B)], dtype=np.uint32)
    X = np.zeros((B, P, problem.nx))
    out = {k: np.zeros((B, P), dt) for k, dt in (("status", np.int64), ("solver_code", np.int64), ("pos_error", float), ("criterion", float), ("time_s", float))}
    compile_s, run_s = 0.0, 0.0
    with jax.enable_x64(True):
        for s in range(0, B, C):
            e = min(s + C, B)
            sl = slice(s, e)
            keys = jax.vmap(lambda i: jax.random.fold_in(base, i))(_pad(path_data[sl], C))
            args = (
                _pad(targets[sl], C), _pad(directions[sl], C), _pad(x0[sl], C), keys,
                _pad(dq_f[sl], C), _pad(dk[sl], C), float(limits.kmin), float(limits.kmax), _pad(r_arr[sl], C),
                float(c), float(pos_tol), _pad(extra[sl], C),
            )
            if jax.local_device_count() > 1:  # split the batch across all local devices (jaxstiff._sharding)
                from jaxstiff.runtime.sharding import shard_rows

                placed, _ = shard_rows({i: args[i] for i in (0, 1, 2, 3, 4, 5, 8, 11)})
                args = tuple(placed.get(i, a) for i, a in enumerate(args))
            t0 = time.perf_counter()
            if s == 0:
                lowered = fn.lower(*args)
                comp = lowered.compile()
                compile_s = time.perf_counter() - t0
                t0 = time.perf_counter()
                res = comp(*args)
            else:
                res = fn(*args)
            res = jax.tree_util.tree_map(np.asarray, res)
            dt = time.perf_counter() - t0
            run_s += dt
            m = e - s
            X[sl] = res["x"][:m]
            out["status"][sl] = res["status"][:m]
            out["solver_code"][sl] = res["start"][:m]
            out["pos_error"][sl] = res["err"][:m]
            out["criterion"][sl] = res["f"][:m]
            out["time_s"][sl] = dt / ((e - s) * P)  # the chunk's wall time over its real waypoints (padding rows excluded)
    q = np.repeat(np.asarray(q0, float)[:, None, :], P, axis=1)
    q[..., list(problem.free_idx)] = X[..., :nf]
    out["q"], out["kj"] = q, X[..., nf:].copy()
    S = int(opts["starts"])
    S1 = max(S, int(opts["starts_first"])) if opts["mode"] == "best" else S
    lm = _lm_kind(problem) is not None
    # fixed iteration counts per start (gradient/LM steps), first waypoint apart
    it = int(opts["iters_lm"]) + int(opts["lm_iters"]) if lm else int(opts["iters"])
    it1 = int(opts["iters_first"]) + (int(opts["lm_iters_first"]) if lm else 0)
    out["nit"] = np.full((B, P), it, np.int64)
    out["nit"][:, 0] = it1
    out["nfev"] = np.full((B, P), S * (it + 1), np.int64)
    out["nfev"][:, 0] = S1 * (it1 + 1)
    if return_timing:
        out["compile_s"], out["run_s"] = compile_s, run_s
    return out


#: meaning of the result file's ``solver_code`` for this solver (meta ``solver_code_meaning``)
CODE_MEANING = "index of the start that won (-1 = none); no convergence flag (fixed iterations)"


def run_request(req) -> dict[str, np.ndarray]:
    """Adapter for :data:`jaxstiff.shaping.SOLVERS` (``solver="pgd"``)."""
    res = solve_batch(
        req.problem, req.targets, req.directions, req.q0, req.kj0, req.limits, req.ratio, req.c,
        starts=req.starts, options=req.options, pos_tol=req.pos_tol, first_starts=req.first_starts,
    )
    res.pop("criterion", None)
    res["code_meaning"] = CODE_MEANING
    return res
