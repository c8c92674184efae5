"""The trajectory solver's second-order stage: Levenberg-Marquardt on the whole trajectory, the rate
limits by an augmented Lagrangian (:mod:`jaxstiff.solvers._trajectory`).

The Adam stage of the trajectory solver is a first-order penalty method: on a path where the rate
limits bind (a tight curve) it moves the trajectory slowly and stops short of the trajectory that
keeps every waypoint in target (LWR, 90 deg arc in 20 waypoints: mean f2 1.24 where IPOPT on the
whole-trajectory NLP reaches 1.00). This stage takes Gauss-Newton steps on all waypoints at once:

* per waypoint the smooth residuals of :meth:`~jaxstiff.solvers._problem.ops.WaypointOps.lm_residual`
  (position rows, alignment rows, log-ratio row), whose zeros are exactly the criterion's minimum
  set (f2: alpha = 0 and rho = r; f1: alpha = 0 and rho >= r), and their Jacobian (closed form);
* per pair of successive waypoints and variable the rate limits ``|x_p - x_{p-1}| <= dx`` as
  augmented-Lagrangian rows ``sqrt(rho) max(0, g + lam / rho)`` (``g = |x_p - x_{p-1}| / dx - 1``
  on either side); the multipliers ``lam`` are updated after each of ``lm_outer`` rounds of
  ``lm_iters`` steps and ``rho`` grows tenfold per round;
* the Gauss-Newton matrix is block tridiagonal (blocks of nx variables, the rate rows couple only
  neighbours): solved by a block Cholesky sweep along the path (``lax.scan``), O(P nx^3), damped
  (Levenberg-Marquardt, the damping adapted per step), with the joint/stiffness limits as an active
  set (coordinates at a bound whose step points outward are fixed and the step solved again) and a
  clip into the box; each step is followed by Newton corrections of the TCP positions and kept only
  if it lowers the augmented merit.

Variables are scaled by the rate limits (one unit = one rate limit; pi rad / the stiffness range
where a rate limit is infinite), so the damping and the rate rows are in the same units for every
joint. The stage returns a trajectory close to feasible: the caller makes it exactly feasible
(:func:`jaxstiff.solvers._trajectory.make_feasible_pass`) and keeps it only if it is better.
"""

from __future__ import annotations

from collections.abc import Callable

import jax
import jax.numpy as jnp

from jaxstiff.solvers._problem.ops import WaypointOps, clip_box

__all__ = ["block_tridiag_solve", "make_lm_stage"]

LAM0 = 1e-2  #: the damping at the start of each round (in rate-limit units squared)
LAM_MAX = 1e8  #: a round stops once the damping has grown past this (no step accepted)


def block_tridiag_solve(D: jax.Array, Boff: jax.Array, g: jax.Array) -> jax.Array:
    """Solve ``H z = g`` for a symmetric positive definite block tridiagonal H.

    Args:
        D: diagonal blocks (P, k, k).
        Boff: the off-diagonal blocks, diagonal matrices given by their diagonals (P, k): block
            (p, p-1) and (p-1, p) of H is ``diag(Boff[p])`` (``Boff[0]`` is not read).
        g: right-hand side (P, k).

    Returns:
        z (P, k). Block Cholesky (Thomas) sweep: ``S_p = D_p - B_p S_{p-1}^-1 B_p``.
    """
    k = D.shape[-1]
    eye = jnp.eye(k, dtype=D.dtype)

    def fwd(carry, inp):
        Sinv_prev, z_prev = carry
        Dp, Bp, gp = inp
        S = Dp - (Bp[:, None] * Sinv_prev) * Bp[None, :]
        S = 0.5 * (S + S.T)
        L = jnp.linalg.cholesky(S)
        Sinv = jax.scipy.linalg.cho_solve((L, True), eye)
        z = gp - Bp * (Sinv_prev @ z_prev)
        return (Sinv, z), (Sinv, z)

    zero = jnp.zeros((k, k), D.dtype)
    _, (Sinv, z) = jax.lax.scan(fwd, (zero, jnp.zeros_like(g[0])), (D, Boff.at[0].set(0.0), g))

    def bwd(x_next, inp):
        Sinv_p, z_p, B_next = inp
        x = Sinv_p @ (z_p - B_next * x_next)
        return x, x

    B_next = jnp.concatenate([Boff[1:], jnp.zeros_like(Boff[:1])])
    _, xs = jax.lax.scan(bwd, jnp.zeros_like(g[0]), (Sinv, z, B_next), reverse=True)
    return xs


def make_lm_stage(  # noqa: PLR0915 - one traced program, read top to bottom
    ops: WaypointOps,
    first_rate: bool,
    kind: str,
    wpos: float,
    walign: float,
    outer: int,
    iters: int,
    rho0: float,
    newton: int,
) -> Callable[..., jax.Array]:
    """The stage ``(X (P, nx), targets, dirs, x0, dq_f, dk, kmin, kmax, r) -> Xs (outer, P, nx)``,
    the trajectory after each round (traceable, vmappable over paths); see the module docstring.
    ``kind``: "f1" or "f2" (the residuals)."""
    nf = ops.nf

    def stage(X, targets, dirs, x0, dq_f, dk, kmin, kmax, r):  # noqa: PLR0913 - traced arrays, one argument each
        P, nx = X.shape
        dt = X.dtype
        dx = jnp.concatenate([dq_f, dk])
        cap = jnp.concatenate([jnp.full((nf,), jnp.pi, dt), jnp.full((nx - nf,), kmax - kmin, dt)])
        sc = jnp.where(jnp.isfinite(dx), jnp.minimum(dx, cap), cap)  # x = y * sc
        w = jnp.where(jnp.isfinite(dx), sc / jnp.where(jnp.isfinite(dx), dx, 1.0), 0.0)  # dt/dy
        lb, ub = ops.box(x0, jnp.asarray(False), dq_f, dk, kmin, kmax)  # the limits alone
        # pair p couples waypoints p-1 and p; pair 0 couples waypoint 0 to x0 (with first_rate only)
        on = jnp.ones((P, 1), dt).at[0].set(1.0 if first_rate else 0.0)

        def rate_t(X):
            prev = jnp.concatenate([x0[None], X[:-1]], axis=0)
            return (X - prev) / jnp.where(jnp.isfinite(dx), dx, 1.0) * (w > 0)  # (P, nx), rate units

        def waypoint_terms(X):
            return jax.vmap(lambda x, t, d: ops.lm_residual_and_jacobian(x, t, d, r, kind, wpos, walign))(
                X, targets, dirs
            )

        def merit_parts(X, lp, lm_, rho):
            e, J = waypoint_terms(X)
            t = rate_t(X)
            ap = jnp.maximum(t - 1.0 + lp / rho, 0.0) * on
            am = jnp.maximum(-t - 1.0 + lm_ / rho, 0.0) * on
            m = 0.5 * jnp.sum(e * e) + 0.5 * rho * jnp.sum(ap * ap + am * am)
            return jnp.where(jnp.isfinite(m), m, jnp.inf), e, J, ap, am

        def step(X, lam, lp, lm_, rho, e, J, ap, am):
            Jy = J * sc[None, None, :]
            Jy = jnp.where(jnp.isfinite(Jy), Jy, 0.0)
            gw = jnp.einsum("prk,pr->pk", Jy, jnp.where(jnp.isfinite(e), e, 0.0))
            phi = rho * (ap - am)  # d merit / d t_p
            c = rho * ((ap > 0) | (am > 0)).astype(dt) * on  # Gauss-Newton curvature in t_p
            g = gw + w * phi - w * jnp.concatenate([phi[1:], jnp.zeros_like(phi[:1])])
            cw = c * w * w
            cnext = jnp.concatenate([cw[1:], jnp.zeros_like(cw[:1])])
            D = jnp.einsum("prk,prl->pkl", Jy, Jy) + jax.vmap(jnp.diag)(cw + cnext)
            Y = X / sc
            ylb, yub = lb / sc, ub / sc

            def solve(fixed):
                keep = (~fixed).astype(dt)
                Dm = D * keep[:, :, None] * keep[:, None, :] + jax.vmap(jnp.diag)(lam + (1.0 - keep))
                Bm = -cw * keep * jnp.concatenate([jnp.ones_like(keep[:1]), keep[:-1]])
                return -block_tridiag_solve(Dm, Bm, g * keep) * keep

            fixed0 = jnp.zeros(X.shape, bool)
            d0 = solve(fixed0)
            fixed = ((Y <= ylb) & (d0 < 0)) | ((Y >= yub) & (d0 > 0))
            dy = solve(fixed)
            dy = jnp.where(jnp.isfinite(dy), dy, 0.0)
            Xn = clip_box((Y + dy) * sc, lb, ub)
            Xn = jax.vmap(lambda x, tg: ops.newton(x, tg, lb, ub, newton))(Xn, targets)
            return jnp.where(jnp.all(jnp.isfinite(Xn)), Xn, X)

        def inner(carry):
            i, X, lam, m, e, J, ap, am, lp, lm_, rho = carry
            Xn = step(X, lam, lp, lm_, rho, e, J, ap, am)
            mn, en, Jn, apn, amn = merit_parts(Xn, lp, lm_, rho)
            ok = mn < m
            sel = lambda a, b: jnp.where(ok, a, b)  # noqa: E731
            lam = jnp.where(ok, jnp.maximum(lam / 3.0, 1e-9), lam * 4.0)
            return (
                i + 1,
                sel(Xn, X),
                lam,
                sel(mn, m),
                sel(en, e),
                sel(Jn, J),
                sel(apn, ap),
                sel(amn, am),
                lp,
                lm_,
                rho,
            )

        def going(carry):
            # until the step budget is spent, the merit is zero to rounding, or no step is accepted
            # any more (the damping has grown past any useful step)
            i, _, lam, m = carry[:4]
            return (i < iters) & (m > 1e-28) & (lam < LAM_MAX)

        def outer_round(carry, _):
            X, lp, lm_, rho = carry
            m, e, J, ap, am = merit_parts(X, lp, lm_, rho)
            lam0 = jnp.asarray(LAM0, dt)
            out = jax.lax.while_loop(going, inner, (jnp.int32(0), X, lam0, m, e, J, ap, am, lp, lm_, rho))
            X = out[1]
            t = rate_t(X)
            lp = jnp.maximum(lp + rho * (t - 1.0), 0.0) * on
            lm_ = jnp.maximum(lm_ + rho * (-t - 1.0), 0.0) * on
            return (X, lp, lm_, rho * 10.0), X

        z = jnp.zeros_like(X)
        _, Xs = jax.lax.scan(outer_round, (X, z, z, jnp.asarray(rho0, dt)), None, length=outer)
        return Xs

    return stage
