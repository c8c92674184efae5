"""One pgd start at one waypoint: surrogate warm-up, LM stage, projected Adam on the criterion,
then the final Newton polish and the verdict (the numbered steps 3-6 of :mod:`jaxstiff.solvers._pgd`).
"""

from __future__ import annotations

import jax
import jax.numpy as jnp

from jaxstiff._numerics.batch import batched_like
from jaxstiff.solvers._problem.ops import WaypointOps, adam_direction, box_scales, clip_box, spd_solve

__all__ = ["finish", "verdict"]


def optimise(  # noqa: PLR0913 - traced arrays, one argument each (a jitted signature)
    ops: WaypointOps,
    x0,
    lb,
    ub,
    target,
    d,
    r,
    c,
    kspan,
    opts,
    first: bool | jax.Array = False,
    lm=None,
    newton_steps: tuple[int, int, int] = (0, 0, 0),
):
    """One start from x0: Newton onto the path, the surrogate phase, the LM phase (``lm``: x -> x,
    f1/f2 only), Newton, the criterion phase, Newton polish. Returns the final point (in the box),
    its criterion value and its position error (:func:`judge`). The criterion phase returns its
    best iterate, and its first iterate is the LM point, so it never returns anything worse than
    LM's answer.

    ``newton_steps``: the Newton corrections before the surrogate phase, between the LM and the
    criterion phase, and of the final polish. ``first``: the first waypoint's settings
    (``iters_first``, ``surrogate_first``, ``step0_first``); a Python bool, or a traced bool (one
    program for every waypoint: the iteration counts become traced loop bounds, the step sizes and
    decays are selected from the same Python constants, so either waypoint computes exactly what
    the static program computes).

    The three phases are one loop in the program, run three times: each pass is Newton, projected
    Adam (the surrogate's gradient, the criterion's, none) and what follows it (the LM stage; the
    best iterate; the final point's criterion and position error, from the same branch). The pass
    is the loop's own counter, never batched, so the conditionals on it stay real branches under
    vmap (one branch runs), and the Adam loop with its projection and Newton corrections, and the
    Newton loop, are each compiled once instead of two or four times (a third fewer equations to
    trace in pgd's program; docs/notes/speed.md).
    """
    if isinstance(first, bool):
        iters, ns, s0, decay_s, decay_f = _phase_constants(opts, first, lm is not None)
    else:
        a = _phase_constants(opts, True, lm is not None)
        b = _phase_constants(opts, False, lm is not None)
        iters, ns, s0, decay_s, decay_f = (jnp.where(first, u, v) for u, v in zip(a, b, strict=True))

    def by_pass(ph, values):
        return (
            jnp.asarray(values[0]) if len(values) == 1 else jnp.where(ph == 0, values[0], by_pass(ph - 1, values[1:]))
        )

    def one_pass(ph, carry):
        surr = ph == 0
        x = ops.newton(clip_box(carry[0], lb, ub), target, lb, ub, by_pass(ph, newton_steps))
        n_it = by_pass(ph, (ns, iters, 0))
        last, bx, bf = _adam(
            ops, surr, x, lb, ub, target, d, r, c, kspan, opts, n_it, s0, jnp.where(surr, decay_s, decay_f)
        )

        def after_surrogate(last, bx, bf):
            return (last if lm is None else lm(last)), carry[1], carry[2]

        def judged(last, bx, bf):
            # the last iterate is in the box (each Adam step is clipped, Newton keeps to the box)
            fv, err = ops.f_and_err(last, d, r, c, target)
            sc = _score(fv, err, opts)
            best = jnp.where(sc < bf, last, bx)
            # nothing acceptable seen: the last iterate (the polish may still bring it onto the path)
            best = jnp.where(jnp.isinf(jnp.minimum(bf, sc)), last, best)
            return jnp.where(ph == 1, best, last), fv, err

        return jax.lax.cond(surr, after_surrogate, judged, last, bx, bf)

    z = jnp.zeros((), x0.dtype)
    # the trip count hidden from XLA, which would otherwise unroll a short loop (copies again)
    n_pass = jax.lax.optimization_barrier(jnp.int32(3))
    return jax.lax.fori_loop(0, n_pass, one_pass, batched_like((x0, z, z), x0))


def _phase_constants(opts, first: bool, with_lm: bool) -> tuple[int, int, float, float, float]:
    """``(criterion iterations, surrogate iterations, first step, surrogate decay, criterion decay)``
    of one waypoint kind (Python numbers)."""
    if first:
        iters, frac, s0 = int(opts["iters_first"]), float(opts["surrogate_first"]), float(opts["step0_first"])
    else:
        iters = int(opts["iters_lm"] if with_lm else opts["iters"])
        frac, s0 = float(opts["surrogate"]), float(opts["step0"])
    ns = int(round(frac * iters))
    nc = max(iters - ns, 1)
    s1 = float(opts["step1"])
    return nc, ns, s0, (s1 / s0) ** (1.0 / max(ns - 1, 1)), (s1 / s0) ** (1.0 / max(nc - 1, 1))


def _score(fv, err, opts):
    """The criterion value of an iterate that may be kept as the best (position error within
    ``accept_tol``, finite), else inf."""
    ok = (err <= float(opts["accept_tol"])) & jnp.isfinite(fv)
    return jnp.where(ok, fv, jnp.inf)


def _adam(ops: WaypointOps, surrogate, x0, lb, ub, target, d, r, c, kspan, opts, iters, s0, decay):  # noqa: PLR0913 - traced arrays, one argument each (a jitted signature)
    """``iters`` projected Adam steps (a Python int or a traced loop bound) on the criterion, or on
    the surrogate where ``surrogate`` (:meth:`WaypointOps.descent_terms`). ``s0``, ``decay``: the
    first step (fraction of the box width) and its per-iteration decay (:func:`_phase_constants`).
    Returns the last iterate, the best acceptable one and its score (by the objective's own
    values: the best is only used with the criterion)."""
    nn = int(opts["newton"])
    nf = ops.nf
    k = len(ops.rows)
    s = box_scales(lb, ub, nf, kspan)

    def body(t, carry):
        x, bx, bf, m1, m2 = carry
        fv, g, p, J = ops.descent_terms(x, d, r, c, surrogate)
        err = jnp.linalg.norm(p - target)
        sc = _score(fv, err, opts)
        better = sc < bf
        bx = jnp.where(better, x, bx)
        bf = jnp.where(better, sc, bf)
        # Adam moments of the box-scaled gradient (per-coordinate normalisation: the joint and
        # stiffness coordinates differ by orders of magnitude in sensitivity)
        u, m1, m2 = adam_direction(g, s, m1, m2, (t + 1).astype(x.dtype))
        # bound-active coordinates dropped, joint part projected onto the path's null space
        free_c = ~(((x <= lb) & (u > 0)) | ((x >= ub) & (u < 0))) & (s > 0)
        u = jnp.where(free_c, u, 0.0)
        if nf:
            Jy = J * s[None, :nf] * free_c[None, :nf]
            JJt = Jy @ Jy.T
            mu = 1e-12 * jnp.maximum(jnp.trace(JJt), 1e-300)
            lam = spd_solve(JJt + mu * jnp.eye(k, dtype=x.dtype), Jy @ u[:nf])
            uq = u[:nf] - Jy.T @ lam
            u = u.at[:nf].set(jnp.where(free_c[:nf], uq, 0.0))
        eta = s0 * decay**t
        xn = clip_box(x - eta * s * u, lb, ub)
        xn = ops.newton(xn, target, lb, ub, nn)
        xn = jnp.where(jnp.all(jnp.isfinite(xn)), xn, x)
        return xn, bx, bf, m1, m2

    z = jnp.zeros_like(x0)
    init = batched_like((x0, x0, jnp.asarray(jnp.inf, x0.dtype), z, z), x0)
    x, bx, bf, _, _ = jax.lax.fori_loop(0, iters, body, init)
    return x, bx, bf


def finish(ops: WaypointOps, x, lb, ub, target, d, r, c, pos_tol, polish):
    """Final Newton polish and the verdict: (x, f, err, usable, finite)."""
    x = ops.newton(clip_box(x, lb, ub), target, lb, ub, polish)
    return verdict(ops, clip_box(x, lb, ub), target, d, r, c, pos_tol)


def verdict(ops: WaypointOps, x, target, d, r, c, pos_tol):
    """``(x, f, err, usable, finite)`` of a final point x (in the box)."""
    fv, err = ops.f_and_err(x, d, r, c, target)
    return judge(x, fv, err, pos_tol)


def judge(x, fv, err, pos_tol):
    """``(x, f, err, usable, finite)`` from a final point's criterion and position error."""
    finite = jnp.all(jnp.isfinite(x)) & jnp.isfinite(fv) & jnp.isfinite(err)
    usable = finite & (err <= pos_tol)
    return x, fv, err, usable, finite
