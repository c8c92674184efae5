"""One pgd trajectory as a traceable function: the starts of every waypoint, a loop over the
waypoints, the "rollout" and "best" modes (:mod:`jaxstiff.solvers._pgd`)."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from jaxstiff._numerics.batch import batched_like
from jaxstiff.results import _files as R
from jaxstiff.solvers._pgd.stages import judge, optimise
from jaxstiff.solvers._problem import WaypointProblem
from jaxstiff.solvers._problem.ops import WaypointOps, box_scales, clip_box, length_unit, lm_kind

__all__ = ["make_kernel", "length_unit"]

#: per waypoint: ``(x, criterion, position error, status, winning start)``
Waypoint = tuple[jax.Array, jax.Array, jax.Array, jax.Array, jax.Array]


def make_kernel(
    problem: WaypointProblem, opts: dict[str, Any], first_rate: bool
) -> Callable[..., dict[str, jax.Array]]:
    """The per-trajectory function ``(targets (P,3), dirs (P,3), x0 (nx,), key, dq_f, dk, kmin,
    kmax, r, c, pos_tol, extra (E, nx)) -> dict`` (traceable, vmappable over trajectories);
    ``extra``: given first-waypoint start states (E may be 0). :meth:`PGDKernel.traj`."""
    return PGDKernel(problem, opts, first_rate).traj


def waypoint_keys(key: jax.Array, P: int) -> jax.Array:
    """The P waypoints' random keys (P, 2) of a path whose key is ``key``: the first waypoint's is
    the last of ``split(key, P + 1)``, waypoint p's (p >= 1) the p-th."""
    k = jax.random.split(key, P + 1)
    return jnp.concatenate([k[P:], k[1:P]])


class PGDKernel:
    """The pieces of pgd trajectories (settings fixed at construction, everything else traced):
    per path :meth:`starts_at` (start points), :meth:`one_start` (one start's optimisation),
    :meth:`pick` (the kept start), :meth:`step_pre` / :meth:`step_post` (a waypoint's starts and
    boxes / its outputs and the next carry); over a batch of paths :meth:`starts_batch` (every
    start of every path as one vmapped axis), :meth:`first` (the first waypoint), :meth:`step`
    (one waypoint, a step of the loop over waypoints) and :meth:`traj_batch` (the whole
    trajectories); :meth:`traj` is one trajectory (a batch of one)."""

    def __init__(self, problem: WaypointProblem, opts: dict[str, Any], first_rate: bool):
        self.ops = ops = WaypointOps(problem)
        self.opts = opts
        self.first_rate = first_rate
        self.S = int(opts["starts"])
        self.mode = opts["mode"]
        self.spread, self.pspread = float(opts["spread"]), float(opts["posture_spread"])
        self.polish = int(opts["polish"])
        self.nf, self.nx = ops.nf, ops.nx
        self.kind = lm_kind(problem)
        self.lm_it = int(opts["lm_iters_first"]), int(opts["lm_iters"])
        # the position rows' weight per length unit of the robot (a power of two near its size, so
        # that a robot of 0.71-1.41 m, the LWR among them, keeps lm_wpos exactly): position errors
        # in metres against dimensionless shape rows would otherwise tip the LM damping as the
        # robot grows (a planar 4R with 10 m links ended at ratio 3 instead of 5 with status 0)
        self.wpos = float(opts["lm_wpos"]) / length_unit(problem.robot.length_scale)
        self.walign = float(opts["lm_walign"])
        self.S1 = max(self.S, int(opts["starts_first"])) if self.mode == "best" else self.S
        self.tie = float(opts["tie_tol"])
        # one traced program for every waypoint (the first too) where the first waypoint differs only
        # in loop bounds and step constants: rollout mode (S1 = S), and the LM stage on or off alike
        lm_on = tuple(self.kind is not None and n > 0 for n in self.lm_it)
        self.one_program = self.mode == "rollout" and lm_on[0] == lm_on[1]

    def starts_at(
        self,
        key: jax.Array,
        xref: jax.Array,
        lb: jax.Array,
        ub: jax.Array,
        rate: jax.Array,
        kmin: jax.Array,
        kmax: jax.Array,
        S: int | None = None,
    ) -> jax.Array:
        """(S, nx) start points in the box: start 0 the reference, others random around it."""
        S = self.S if S is None else S
        nf, nx = self.nf, self.nx
        u = jax.random.uniform(key, (S, nx), xref.dtype, -1.0, 1.0)
        half = 0.5 * box_scales(lb, ub, nf, kmax - kmin)
        near = xref[None, :] + u * (self.spread * half)[None, :]
        # first waypoint without rate limit: distinct postures (large joint moves) and stiffnesses
        # drawn log-uniformly over the range: the criterion only sees stiffness ratios, and the
        # minima often have several joints near kmin, which uniform draws almost never visit
        lo = jnp.log(jnp.maximum(lb[nf:], 1e-6 * kmax))
        hi = jnp.log(jnp.maximum(ub[nf:], 1e-6 * kmax))
        kfar = jnp.exp(lo[None, :] + 0.5 * (u[:, nf:] + 1.0) * (hi - lo)[None, :])
        far = jnp.concatenate([xref[None, :nf] + u[:, :nf] * self.pspread, kfar], axis=1)
        xs = jnp.where(rate, near, far)
        xs = xs.at[0].set(xref)
        return clip_box(xs, lb[None, :], ub[None, :])

    def one_start(  # noqa: PLR0913 - traced arrays, one argument each (a jitted signature)
        self,
        x0: jax.Array,
        lb: jax.Array,
        ub: jax.Array,
        tgt: jax.Array,
        d: jax.Array,
        r: jax.Array,
        c: jax.Array,
        kspan: jax.Array,
        pos_tol: jax.Array,
        rate: jax.Array,
        first: bool | jax.Array = False,
    ):
        """One start's optimisation (:func:`~jaxstiff.solvers._pgd.stages.optimise`) and verdict
        (:func:`~jaxstiff.solvers._pgd.stages.finish`): ``(x, f, err, usable, finite)``. ``first``:
        the first waypoint's settings, a Python bool or a traced bool (:attr:`one_program`)."""
        ops, nf = self.ops, self.nf
        if isinstance(first, bool):
            nlm: int | jax.Array = self.lm_it[0] if first else self.lm_it[1]
            lm_on = nlm > 0
        else:
            nlm = jnp.where(first, self.lm_it[0], self.lm_it[1])
            lm_on = self.lm_it[1] > 0  # the same for both kinds (one_program)
        lm: Callable[[jax.Array], jax.Array] | None = None
        kind = self.kind
        if kind is not None and lm_on:

            def lm_stage(x: jax.Array) -> jax.Array:
                return ops.lm(x, lb, ub, tgt, d, r, kind, nlm, self.wpos, self.walign, box_scales(lb, ub, nf, kspan))

            lm = lm_stage
        # Newton onto the path first, 3 corrections after the LM stage, the polish last
        steps = (8, 3 if lm is not None else 0, self.polish)
        x, fv, err = optimise(ops, x0, lb, ub, tgt, d, r, c, kspan, self.opts, first, lm=lm, newton_steps=steps)
        # a start already on the path that the stages did not improve is kept: a first-waypoint
        # start given by the exact solver (:mod:`jaxstiff.solvers._first_waypoint`) is often
        # optimal, and the surrogate and LM stages can leave its basin. Starts of later
        # waypoints lie on the previous target, not on this one, so this never picks them
        # (unless the path stands still, where keeping the previous state is right too)
        xs = clip_box(x0, lb, ub)
        fs, es = ops.f_and_err(xs, d, r, c, tgt)
        start_ok = (es <= pos_tol) & jnp.isfinite(fs) & jnp.all(jnp.isfinite(xs))
        keep = start_ok & ~((err <= pos_tol) & (fv <= fs))
        x = jnp.where(keep, xs, x)
        fv, err = jnp.where(keep, fs, fv), jnp.where(keep, es, err)
        return judge(x, fv, err, pos_tol)

    def pick(
        self,
        x: jax.Array,
        fv: jax.Array,
        err: jax.Array,
        usable: jax.Array,
        finite: jax.Array,
        kmin: jax.Array,
        kmax: jax.Array,
    ) -> jax.Array:
        """Index of the kept start: among the usable ones within ``tie_tol`` (relative) of the best
        criterion, the one farthest from the joint and stiffness limits (normalised; stiffness in
        log scale), so that later waypoints have room to follow the path. None usable: the
        finite one closest to the path."""
        ops, nf = self.ops, self.nf
        qlo, qhi = ops.qlo, ops.qhi
        sc = jnp.where(usable, fv, jnp.inf)
        fb = jnp.min(sc)
        near = usable & (sc <= fb + self.tie * jnp.maximum(jnp.abs(fb), 1.0))
        dt = x.dtype
        lo = jnp.concatenate(
            [jnp.asarray(np.where(np.isfinite(qlo), qlo, -np.pi), dt), jnp.full((ops.nk,), jnp.log(kmin))]
        )
        hi = jnp.concatenate(
            [jnp.asarray(np.where(np.isfinite(qhi), qhi, np.pi), dt), jnp.full((ops.nk,), jnp.log(kmax))]
        )
        y = jnp.concatenate([x[:, :nf], jnp.log(jnp.maximum(x[:, nf:], 1e-300))], axis=1)
        # a variable whose range is one value (a joint limited to [a, a], kmin = kmax) has no room
        # to keep: left out, as in the greedy solvers' tie-break (it made every start's room 0)
        span = hi - lo
        room = jnp.min(jnp.where(span > 0, jnp.minimum(y - lo, hi - y) / jnp.maximum(span, 1e-300), jnp.inf), axis=1)
        i_near = jnp.argmax(jnp.where(near, room, -jnp.inf))
        return jnp.where(jnp.any(usable), i_near, jnp.argmin(jnp.where(finite, err, jnp.inf)))

    def step_pre(
        self, carry: tuple[jax.Array, jax.Array], inp: tuple[jax.Array, ...], lims: tuple[jax.Array, ...]
    ) -> tuple[jax.Array, jax.Array, jax.Array, jax.Array]:
        """One path's start points of a waypoint and their boxes ``(xs, lb, ub, rate)`` (S, ...):
        carry ``(xref (S, nx), at_start (S,))``, input ``(target, direction, key)`` for the
        waypoints after the first, or, in one-program mode (:attr:`one_program`: the first
        waypoint is the loop's first step), ``(target, direction, key, is_first, extra (E, nx))``;
        ``lims = (dq_f, dk, kmin, kmax, r, c, kspan, pos_tol)``."""
        ops, S = self.ops, self.S
        dq_f, dk, kmin, kmax = lims[:4]
        xref, at_start = carry  # (S, nx), (S,)
        kk = inp[2]
        rate = (~at_start) | self.first_rate
        lb, ub = jax.vmap(lambda xr, rt: ops.box(xr, rt, dq_f, dk, kmin, kmax))(xref, rate)
        if self.mode == "best":
            return self.starts_at(kk, xref[0], lb[0], ub[0], rate[0], kmin, kmax), lb, ub, rate
        # rollouts: one start each, from its own state; before the first usable waypoint
        # rollout s takes the s-th distinct posture (all refs still equal x0 there)
        xs0 = self.starts_at(kk, xref[0], lb[0], ub[0], rate[0], kmin, kmax)
        if len(inp) > 3:  # one program: at the first waypoint, given start states replace 1..E
            is_first, extra = inp[3], inp[4]
            E = min(extra.shape[0], S - 1)
            if E > 0:
                injected = xs0.at[1 : 1 + E].set(clip_box(extra[:E], lb[0][None, :], ub[0][None, :]))
                xs0 = jnp.where(is_first, injected, xs0)
        return jnp.where(at_start[:, None], xs0, jax.vmap(clip_box)(xref, lb, ub)), lb, ub, rate

    def step_post(
        self,
        carry: tuple[jax.Array, jax.Array],
        lb: jax.Array,
        ub: jax.Array,
        res: tuple[jax.Array, ...],
        lims: tuple[jax.Array, ...],
    ) -> tuple[tuple[jax.Array, jax.Array], Waypoint]:
        """One path's waypoint outputs and next carry from its starts' results ``res = (x, f,
        err, usable, finite)`` (S, ...) (:meth:`one_start`) in the boxes ``lb``, ``ub``."""
        kmin, kmax = lims[2], lims[3]
        xref, at_start = carry
        x, fv, err, usable, finite = res
        if self.mode == "best":
            i = self.pick(x, fv, err, usable, finite, kmin, kmax)
            xw, fw, ew, uw, finw = x[i], fv[i], err[i], usable[i], finite[i]
            newref = jnp.where(uw, xw, xref[0])
            carry = (jnp.broadcast_to(newref, xref.shape), jnp.broadcast_to(at_start[0] & ~uw, at_start.shape))
            status = jnp.where(uw, R.SOLVED, jnp.where(finw, R.UNREACHABLE, R.NONFINITE))
            xw = jnp.where(finw, xw, clip_box(xref[0], lb[0], ub[0]))
            return carry, (xw, fw, ew, status, jnp.where(jnp.any(usable), i, -1))
        newref = jnp.where(usable[:, None], x, xref)
        carry = (newref, at_start & ~usable)
        status = jnp.where(usable, R.SOLVED, jnp.where(finite, R.UNREACHABLE, R.NONFINITE))
        xo = jnp.where(finite[:, None], x, jax.vmap(clip_box)(xref, lb, ub))
        return carry, (xo, fv, err, status, jnp.arange(self.S))

    def starts_batch(self, xs, lb, ub, rate, tgt, d, r, lims, first: bool | jax.Array):
        """:meth:`one_start` for every start of every path of a batch as one vmapped axis (C * S
        lanes): ``xs``, ``lb``, ``ub`` (C, S, nx), ``rate`` (C, S), ``tgt``, ``d`` (C, 3), ``r``
        (C,). Results (C, S, ...). Under two nested vmaps (starts inside, paths outside) JAX
        batches every loop body in a start once per level; here once."""
        c, kspan, pos_tol = lims[5], lims[6], lims[7]
        C, S = xs.shape[:2]

        def flat(a):
            return a.reshape((C * S,) + a.shape[2:])

        def rep(a):
            return jnp.repeat(a, S, axis=0)

        one = jax.vmap(
            lambda x0, lb, ub, tgt, d, r, rate: self.one_start(x0, lb, ub, tgt, d, r, c, kspan, pos_tol, rate, first)
        )
        out = one(flat(xs), flat(lb), flat(ub), rep(tgt), rep(d), rep(r), flat(rate))
        return tuple(o.reshape((C, S) + o.shape[1:]) for o in out)

    def step(
        self,
        carry: tuple[jax.Array, jax.Array],
        inp: tuple[jax.Array, ...],
        lims: tuple[jax.Array, ...],
    ) -> tuple[tuple[jax.Array, jax.Array], Waypoint]:
        """One waypoint of a batch of C paths (a step of the loop over waypoints): carry
        ``(xref (C, S, nx), at_start (C, S))``; ``inp`` and ``lims`` as :meth:`step_pre`'s with a
        leading C axis on the per-path entries (targets, directions, keys, extra; dq_f, dk, r)."""
        per_path = (0, 0, None, None, 0, None, None, None)
        tgt, d = inp[0], inp[1]
        one_program = len(inp) > 3
        inp_axes = (0, 0, 0) + ((None, 0) if one_program else ())
        xs, lb, ub, rate = jax.vmap(self.step_pre, in_axes=(0, inp_axes, per_path))(carry, inp, lims)
        res = self.starts_batch(xs, lb, ub, rate, tgt, d, lims[4], lims, inp[3] if one_program else False)
        return jax.vmap(self.step_post, in_axes=(0, 0, 0, 0, per_path))(carry, lb, ub, res, lims)

    def first(
        self, key: jax.Array, x0: jax.Array, extra: jax.Array, tgt: jax.Array, d: jax.Array, lims: tuple[jax.Array, ...]
    ) -> tuple[Waypoint, tuple[jax.Array, jax.Array]]:
        """The first waypoint of a batch of C paths, apart (C leading on every argument but the
        shared ``lims``): more starts and iterations (its box is usually the whole range); given
        start states ``extra`` (C, E, nx) (greedy SLSQP's IK postures) replace random starts
        1..E. Returns its outputs and the loop's initial carry."""
        ops, S, nx = self.ops, self.S, self.nx
        per_path = (0, 0, None, None, 0, None, None, None)
        rate0 = jnp.asarray(self.first_rate)

        def pre(key, x0, extra, lims):
            dq_f, dk, kmin, kmax = lims[:4]
            lb0, ub0 = ops.box(x0, rate0, dq_f, dk, kmin, kmax)
            xs0 = self.starts_at(key, x0, lb0, ub0, rate0, kmin, kmax, S=self.S1)
            E = min(extra.shape[0], self.S1 - 1)
            if E > 0:
                xs0 = xs0.at[1 : 1 + E].set(clip_box(extra[:E], lb0[None, :], ub0[None, :]))
            S1 = self.S1
            return xs0, jnp.broadcast_to(lb0, (S1, nx)), jnp.broadcast_to(ub0, (S1, nx)), jnp.broadcast_to(rate0, (S1,))

        xs0, lb0, ub0, rates = jax.vmap(pre, in_axes=(0, 0, 0, per_path))(key, x0, extra, lims)
        res = self.starts_batch(xs0, lb0, ub0, rates, tgt, d, lims[4], lims, True)

        def post(x0, lb0, ub0, res, lims):
            x1, f1, e1, u1, fin1 = res
            kmin, kmax = lims[2], lims[3]
            st1 = jnp.where(u1, R.SOLVED, jnp.where(fin1, R.UNREACHABLE, R.NONFINITE))
            x1 = jnp.where(fin1[:, None], x1, clip_box(x0, lb0[0], ub0[0])[None, :])
            if self.mode == "best":
                i1 = self.pick(x1, f1, e1, u1, fin1, kmin, kmax)
                first = (x1[i1], f1[i1], e1[i1], st1[i1], jnp.where(jnp.any(u1), i1, -1))
                carry0 = (jnp.broadcast_to(jnp.where(u1[i1], x1[i1], x0), (S, nx)), jnp.broadcast_to(~u1[i1], (S,)))
            else:
                first = (x1, f1, e1, st1, jnp.arange(S))
                carry0 = (jnp.where(u1[:, None], x1, x0[None, :]), ~u1)
            return first, carry0

        return jax.vmap(post, in_axes=(0, 0, 0, 0, per_path))(x0, lb0, ub0, res, lims)

    def traj(  # noqa: PLR0913 - traced arrays, one argument each (a jitted signature)
        self,
        targets: jax.Array,
        dirs: jax.Array,
        x0: jax.Array,
        key: jax.Array,
        dq_f: jax.Array,
        dk: jax.Array,
        kmin: jax.Array,
        kmax: jax.Array,
        r: jax.Array,
        c: jax.Array,
        pos_tol: jax.Array,
        extra: jax.Array,
        n_valid: jax.Array | int | None = None,
    ) -> dict[str, jax.Array]:
        """One trajectory (see :func:`make_kernel`): ``x`` (P, nx), ``f``, ``err``, ``status``,
        ``start`` (P,). :meth:`traj_batch` of a batch of one.

        ``key``: the path's key, or its waypoints' keys (P, 2) (:func:`waypoint_keys` of the path's
        own length: then the rows after ``n_valid`` change nothing). ``n_valid``: the waypoints
        actually solved, the first ``n_valid`` of the P rows (None: all). The rows after them are
        capacity: one compiled program serves every path length up to P (a traced loop bound), and
        their outputs are zeros that the caller drops."""
        t, dr, x, k, dq, dkk, rr, ex = (jnp.asarray(a)[None] for a in (targets, dirs, x0, key, dq_f, dk, r, extra))
        out = self.traj_batch(t, dr, x, k, dq, dkk, kmin, kmax, rr, c, pos_tol, ex, n_valid)
        return {k: v[0] for k, v in out.items()}

    def traj_batch(  # noqa: PLR0913 - traced arrays, one argument each (a jitted signature)
        self,
        targets: jax.Array,
        dirs: jax.Array,
        x0: jax.Array,
        key: jax.Array,
        dq_f: jax.Array,
        dk: jax.Array,
        kmin: jax.Array,
        kmax: jax.Array,
        r: jax.Array,
        c: jax.Array,
        pos_tol: jax.Array,
        extra: jax.Array,
        n_valid: jax.Array | int | None = None,
    ) -> dict[str, jax.Array]:
        """C trajectories at once: the arguments of :meth:`traj` with a leading C axis on the
        per-path ones (``targets``, ``dirs``, ``x0``, ``key``, ``dq_f``, ``dk``, ``r``, ``extra``);
        ``kmin``, ``kmax``, ``c``, ``pos_tol`` and ``n_valid`` shared. Outputs (C, P, ...).

        The loop over waypoints runs over the whole batch, and each waypoint's starts of every
        path are one vmapped axis (:meth:`starts_batch`): JAX batches the loops inside a start
        once, where a vmap of :meth:`traj` over paths around the vmap over starts batched them
        twice (pgd's program traced in about a third more time)."""
        lims = (dq_f, dk, kmin, kmax, r, c, kmax - kmin, pos_tol)
        C, P = targets.shape[:2]
        n = jnp.asarray(P if n_valid is None else n_valid, jnp.int32)
        keys = key if key.ndim == 3 else jax.vmap(lambda k: waypoint_keys(k, P))(key)
        if self.one_program:
            # the first waypoint as the loop's first step (is_first): one traced and compiled
            # waypoint program instead of two, the same arithmetic
            xref0 = jnp.broadcast_to(x0[:, None, :], (C, self.S, self.nx))
            carry0 = (xref0, jnp.ones((C, self.S), bool))

            def inp(p):
                return (targets[:, p], dirs[:, p], keys[:, p], p == 0, extra)

            X, F, E, ST, WIN = self._waypoints(carry0, inp, lims, 0, n, P)
        else:
            first, carry0 = self.first(keys[:, 0], x0, extra, targets[:, 0], dirs[:, 0], lims)
            X, F, E, ST, WIN = self._waypoints(
                carry0, lambda p: (targets[:, p], dirs[:, p], keys[:, p]), lims, 1, n, P, first
            )
        if self.mode == "rollout":
            # X (C, P, S, nx): keep each path's trajectory with fewest unusable waypoints, then
            # lowest sum f
            valid = (jnp.arange(P) < n)[None, :, None]
            bad = jnp.sum(valid & (ST != R.SOLVED), axis=1)
            tot = jnp.sum(jnp.where(valid & (ST == R.SOLVED), F, 0.0), axis=1)
            sc = bad * 1e12 + jnp.where(jnp.isfinite(tot), tot, 1e11)
            i = jnp.argmin(sc, axis=1)  # (C,)

            def kept(A):
                return jnp.take_along_axis(A, i.reshape((C, 1, 1) + (1,) * (A.ndim - 3)), axis=2)[:, :, 0]

            X, F, E, ST = kept(X), kept(F), kept(E), kept(ST)
            WIN = jnp.broadcast_to(i[:, None], (C, P))
        return {"x": X, "f": F, "err": E, "status": ST, "start": WIN}

    def _waypoints(
        self,
        carry0: tuple[jax.Array, jax.Array],
        inp: Callable[[jax.Array], tuple[jax.Array, ...]],
        lims: tuple[jax.Array, ...],
        p0: int,
        n: jax.Array,
        P: int,
        first: Waypoint | None = None,
    ) -> Waypoint:
        """Waypoints ``p0 .. n - 1`` of a batch by :meth:`step` in a loop with a traced bound,
        written into (C, P, ...) outputs (row 0 from ``first`` when given; rows from n on stay
        zero)."""
        xref = carry0[0]
        C = xref.shape[0]
        # best: the kept start's; rollout: every start's
        lead = (C, P) if self.mode == "best" else (C, P, self.S)
        ft, it = xref.dtype, jnp.int32
        outs = (
            jnp.zeros(lead + (self.nx,), ft),
            jnp.zeros(lead, ft),
            jnp.zeros(lead, ft),
            jnp.zeros(lead, it),
            jnp.zeros(lead, it),
        )
        if first is not None:
            outs = tuple(o.at[:, 0].set(f.astype(o.dtype)) for o, f in zip(outs, first, strict=True))

        def body(p, state):
            carry, outs = state
            carry, w = self.step(carry, inp(p), lims)
            return carry, tuple(o.at[:, p].set(v.astype(o.dtype)) for o, v in zip(outs, w, strict=True))

        # (a caller's vmap around this batch: the carry starts batched, see batched_like)
        _, outs = jax.lax.fori_loop(p0, n, body, batched_like((carry0, outs), xref))
        return outs
