"""One pgd start at one waypoint: surrogate warm-up, LM stage, projected Adam on the criterion,
then the final Newton polish and the verdict (the numbered steps 3-6 of :mod:`jaxstiff.solvers.pgd`).
"""

from __future__ import annotations

import jax
import jax.numpy as jnp

from jaxstiff._numerics.batch import batched_like
from jaxstiff.solvers.pgd.ops import WaypointOps, adam_direction, box_scales, clip_box, spd_solve

__all__ = ["optimise", "descend", "finish"]


def optimise(ops: WaypointOps, x0, lb, ub, target, d, r, c, kspan, opts, first: bool | jax.Array = False, lm=None):
    """Surrogate phase, LM phase (``lm``: x -> x, f1/f2 only), then the criterion phase, from x0
    (on the path). Returns the best iterate of the criterion phase (its first iterate is the LM
    point, so the criterion phase never returns anything worse than LM's answer).

    ``first``: the first waypoint's settings (``iters_first``, ``surrogate_first``, ``step0_first``);
    a Python bool, or a traced bool (one program for every waypoint: the iteration counts become
    traced loop bounds, the step sizes and decays are selected from the same Python constants, so
    either waypoint computes exactly what the static program computes).
    """
    if isinstance(first, bool):
        iters, ns, s0, decay_s, decay_f = _phase_constants(opts, first, lm is not None)
    else:
        a = _phase_constants(opts, True, lm is not None)
        b = _phase_constants(opts, False, lm is not None)
        iters, ns, s0, decay_s, decay_f = (jnp.where(first, u, v) for u, v in zip(a, b, strict=True))
    if not (isinstance(ns, int) and ns == 0):
        x0 = descend(ops, ops.surrogate, x0, lb, ub, target, d, r, c, kspan, opts, ns, False, s0, decay_s)
    if lm is not None:
        x0 = lm(x0)
    return descend(ops, ops.f, x0, lb, ub, target, d, r, c, kspan, opts, iters, True, s0, decay_f)


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


def descend(ops: WaypointOps, obj, x0, lb, ub, target, d, r, c, kspan, opts, iters, track, s0, decay):
    """``iters`` projected Adam steps on ``obj`` (a Python int or a traced loop bound); with
    ``track`` the best acceptable iterate of the criterion is returned, else the last iterate.
    ``s0``, ``decay``: the first step (fraction of the box width) and its per-iteration decay
    (:func:`_phase_constants`)."""
    nn = int(opts["newton"])
    acc = float(opts["accept_tol"])
    nf = ops.nf
    k = len(ops.rows)
    s = box_scales(lb, ub, nf, kspan)
    vg = jax.value_and_grad(obj)

    def score(fv, err):
        ok = (err <= acc) & jnp.isfinite(fv)
        return jnp.where(ok, fv, jnp.inf)

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
        u, m1, m2 = adam_direction(g, s, m1, m2, (t + 1).astype(x.dtype))
        # bound-active coordinates dropped, joint part projected onto the path's null space
        free_c = ~(((x <= lb) & (u > 0)) | ((x >= ub) & (u < 0))) & (s > 0)
        u = jnp.where(free_c, u, 0.0)
        if nf:
            _, J = ops.pos_jac(x)
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


def finish(ops: WaypointOps, x, lb, ub, target, d, r, c, pos_tol, polish):
    """Final Newton polish and the verdict: (x, f, err, usable, finite)."""
    x = ops.newton(clip_box(x, lb, ub), target, lb, ub, polish)
    x = clip_box(x, lb, ub)
    fv = ops.f(x, d, r, c)
    err = ops.pos_err(x, target)
    finite = jnp.all(jnp.isfinite(x)) & jnp.isfinite(fv) & jnp.isfinite(err)
    usable = finite & (err <= pos_tol)
    return x, fv, err, usable, finite
