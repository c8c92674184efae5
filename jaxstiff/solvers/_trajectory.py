"""``solver="trajectory"``: all waypoints of a path optimised together (trajectory-level mode).

The greedy scheme of seed 000 (and :mod:`.pgd`, :mod:`.hybrid`) fixes waypoint p before it looks at
p + 1, so it only reacts once a joint limit or a rate limit binds. Here the whole trajectory
``X`` (P, nx) (``x_p = [q_free, kj]``) minimises

    sum_p f(K_T(x_p), d_p, r)                                         (sum of S0-9 / S0-15)
    s.t. position(x_p) = target_p, joint/stiffness limits for every p,
         |x_p - x_{p-1}| <= (dq, dk)   (S0-11 ... S0-14, the coupling between waypoints)

by projected gradient over the whole (P, nx) array, batched over B paths with ``vmap``:

1. warm start from a greedy solution (``options["warm"]``: ``"pgd"`` (default), ``"hybrid"`` or
   ``"slsqp"``), which is feasible;
1b. for the built-in f1/f2: ``traj_lm_rounds`` rounds of whole-trajectory Levenberg-Marquardt on
   the smooth residuals whose zeros are the criterion's minimum set, the rate limits as an
   augmented Lagrangian (:mod:`jaxstiff.solvers._trajectory_lm`); each round's trajectory goes
   through the feasibility pass of step 3 and is kept if it is better. This second-order stage is
   what reaches the trajectory that keeps every waypoint in target where the rate limits bind (LWR,
   90 deg arcs of 15 and 20 waypoints: mean f2 1.90 / 1.24 with the Adam steps alone, 1.0000 with
   it, as CasADi + IPOPT's whole-trajectory NLP); the Adam steps then start from the best so far;
2. ``traj_iters`` Adam steps on ``sum f + mu * sum_p |relu(|x_p - x_{p-1}| - d) / d|^2`` (the rate
   limits as a quadratic penalty, so that a waypoint that needs to move pulls its neighbours along
   ahead of time), each step projected per waypoint onto the null space of its position Jacobian,
   clipped into the joint/stiffness limits and corrected back onto the path with Newton steps;
   ``mu`` grows over ``blocks`` blocks, the step size decays;
3. after each block a sequential feasibility pass (``lax.scan`` along the path: clip x_p into the
   rate box around the previous usable waypoint, box-respecting Newton polish, status check as in
   :mod:`jaxstiff.results`) makes the trajectory exactly feasible; the best feasible trajectory
   (fewest unusable waypoints, then lowest total criterion), the warm start included, is returned.

So the result satisfies every constraint exactly and its total criterion is never above the warm
start's. Status: ``0`` SOLVED, ``3`` UNREACHABLE, ``4`` NONFINITE (as :mod:`.pgd`).
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable, Mapping
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from jaxstiff.results import _files as R
from jaxstiff.runtime._export_cache import DiskJit
from jaxstiff.runtime._programs import program_cache
from jaxstiff.runtime._threads import chunk_rows, chunk_threads, map_chunks
from jaxstiff.runtime._xla import kernel_compiler_options
from jaxstiff.settings._solvers import WARM_STARTS as WARM_STARTS  # re-exported (sweep)
from jaxstiff.settings._solvers import PGDOptions, TrajectoryOptions
from jaxstiff.solvers._base import SolveRequest
from jaxstiff.solvers._pgd import WaypointOps, adam_direction, clip_box, finish, pad_rows
from jaxstiff.solvers._pgd.kernel import length_unit
from jaxstiff.solvers._problem import POS_TOL, WaypointBatch, WaypointProblem
from jaxstiff.solvers._problem.ops import lm_kind
from jaxstiff.solvers._trajectory_lm import make_lm_stage

__all__ = ["DEFAULT_OPTIONS", "refine_batch", "run_request"]

#: The trajectory solver's own options, from :class:`~jaxstiff.settings.TrajectoryOptions`.
DEFAULT_OPTIONS: dict[str, Any] = TrajectoryOptions.defaults()


def check_options(options: Mapping[str, Any] | None) -> dict[str, Any]:
    """The trajectory solver's own options (:data:`DEFAULT_OPTIONS`) checked and normalised
    (ValueError naming the option); those of its warm start are checked by that solver."""
    return TrajectoryOptions.check_values(TrajectoryOptions.own(options))


def make_feasible_pass(ops: WaypointOps, first_rate: bool, npol: int) -> Callable[..., tuple[jax.Array, ...]]:
    """The sequential feasibility pass ``(X (P, nx), targets, dirs, x0, dq_f, dk, kmin, kmax, r, c,
    pos_tol) -> (X, f, err, status, score)``: ``lax.scan`` along the path, x_p clipped into the rate
    box around the previous usable waypoint, box-respecting Newton polish (``npol`` steps) and the
    status check; score = unusable waypoints * 1e12 + total criterion (lower is better)."""

    def feasible_pass(X, targets, dirs, x0, dq_f, dk, kmin, kmax, r, c, pos_tol):  # noqa: PLR0913 - traced arrays, one argument each (a jitted signature)
        def step(carry, inp):
            xref, at_start = carry
            x, tgt, d = inp
            rate = (~at_start) | first_rate
            lb, ub = ops.box(xref, rate, dq_f, dk, kmin, kmax)
            xo, fv, err, usable, finite = finish(ops, x, lb, ub, tgt, d, r, c, pos_tol, npol)
            xo = jnp.where(finite, xo, clip_box(xref, lb, ub))
            st = jnp.where(usable, R.SOLVED, jnp.where(finite, R.UNREACHABLE, R.NONFINITE))
            return (jnp.where(usable, xo, xref), at_start & ~usable), (xo, fv, err, st)

        _, (Xo, F, E, ST) = jax.lax.scan(step, (x0, jnp.asarray(True)), (X, targets, dirs))
        bad = jnp.sum(ST != R.SOLVED)
        tot = jnp.sum(jnp.where(ST == R.SOLVED, F, 0.0))
        return Xo, F, E, ST, bad * 1e12 + jnp.where(jnp.isfinite(tot), tot, 1e11)

    return feasible_pass


def null_space_step(ops: WaypointOps, scale: jax.Array, X: jax.Array, U: jax.Array) -> jax.Array:
    """Each waypoint's step ``U[p]`` (in variables scaled by ``scale``) with its joint part
    projected onto the null space of the waypoint's position Jacobian (P, nx)."""
    nf = ops.nf

    def one(x, u):
        _, J = ops.pos_jac(x)
        Jy = J * scale[None, :nf]
        k = Jy.shape[0]
        JJt = Jy @ Jy.T
        mu = 1e-12 * jnp.maximum(jnp.trace(JJt), 1e-300)
        lam = jnp.linalg.solve(JJt + mu * jnp.eye(k, dtype=x.dtype), Jy @ u[:nf])
        return u.at[:nf].set(u[:nf] - Jy.T @ lam)

    return jax.vmap(one)(X, U)


def _kernel(problem: WaypointProblem, opts: dict[str, Any], first_rate: bool) -> Callable[..., dict[str, jax.Array]]:
    """One path's refinement ``(Xw (P, nx), targets, dirs, x0, dq_f, dk, kmin, kmax, r, c, pos_tol) -> dict``
    (traceable, vmappable over paths): steps 2 and 3 of the module docstring."""
    ops = WaypointOps(problem)
    nf = ops.nf
    T, nb = int(opts["traj_iters"]), int(opts["blocks"])
    per = max(T // nb, 1)
    s0, s1 = float(opts["traj_step0"]), float(opts["traj_step1"])
    decay = (s1 / s0) ** (1.0 / max(per * nb - 1, 1))
    nn, npol = int(opts["newton"]), int(opts["polish"])
    mu0 = float(opts["mu0"])

    feasible_pass = make_feasible_pass(ops, first_rate, npol)
    kind = lm_kind(problem)
    lm_rounds = int(opts["traj_lm_rounds"]) if kind is not None else 0
    if lm_rounds:
        pgd_defaults = PGDOptions.defaults()
        lm_stage = make_lm_stage(
            ops,
            first_rate,
            kind or "f2",
            float(pgd_defaults["lm_wpos"]) / length_unit(problem.robot.length_scale),
            float(pgd_defaults["lm_walign"]),
            lm_rounds,
            int(opts["traj_lm_iters"]),
            float(opts["traj_lm_rho0"]),
            nn,
        )

    def traj(Xw, targets, dirs, x0, dq_f, dk, kmin, kmax, r, c, pos_tol):  # noqa: PLR0913 - traced arrays, one argument each (a jitted signature)
        P = targets.shape[0]
        dx = jnp.concatenate([dq_f, dk])
        scale = jnp.minimum(dx, jnp.concatenate([jnp.full((nf,), jnp.pi), jnp.full(dk.shape, kmax - kmin)]))
        lb_all, ub_all = ops.box(x0, jnp.asarray(False), dq_f, dk, kmin, kmax)  # limits only
        # coupling pairs (p-1, p); the first waypoint is coupled to x0 only with first_rate
        w_pair = jnp.ones((P,)).at[0].set(1.0 if first_rate else 0.0)

        def total(X, mu):
            f = jax.vmap(ops.f, in_axes=(0, 0, None, None))(X, dirs, r, c)
            prev = jnp.concatenate([x0[None], X[:-1]], axis=0)
            v = jax.nn.relu(jnp.abs(X - prev) - dx) / dx
            return jnp.sum(f) + mu * jnp.sum(w_pair[:, None] * v * v)

        g_total = jax.grad(total)

        def project(X: jax.Array, U: jax.Array) -> jax.Array:
            return null_space_step(ops, scale, X, U)

        Xb, Fb, Eb, STb, scb = feasible_pass(Xw, targets, dirs, x0, dq_f, dk, kmin, kmax, r, c, pos_tol)
        if lm_rounds:  # the second-order stage (jaxstiff.solvers._trajectory_lm), kept if better
            Xls = lm_stage(Xb, targets, dirs, x0, dq_f, dk, kmin, kmax, r)  # (rounds, P, nx)
            for k in range(lm_rounds):  # each round's trajectory made feasible, the best kept
                Xl = jnp.where(jnp.all(jnp.isfinite(Xls[k])), Xls[k], Xb)
                Xo, F, E, ST, sc = feasible_pass(Xl, targets, dirs, x0, dq_f, dk, kmin, kmax, r, c, pos_tol)
                better = sc < scb
                Xb, Fb, Eb, STb = (jnp.where(better, a, b_) for a, b_ in ((Xo, Xb), (F, Fb), (E, Eb), (ST, STb)))
                scb = jnp.minimum(sc, scb)

        def block(i, carry):
            X, m1, m2, t, Xb, Fb, Eb, STb, scb = carry
            mu = mu0 * 10.0**i

            def it(_, c2):
                X, m1, m2, t = c2
                g = g_total(X, mu)
                tt = t + 1.0
                u, m1, m2 = adam_direction(g, scale, m1, m2, tt)
                u = project(X, u)
                eta = s0 * decay**t
                Xn = clip_box(X - eta * scale * u, lb_all, ub_all)
                Xn = jax.vmap(lambda x, tg: ops.newton(x, tg, lb_all, ub_all, nn))(Xn, targets)
                Xn = jnp.where(jnp.all(jnp.isfinite(Xn)), Xn, X)
                return Xn, m1, m2, tt

            X, m1, m2, t = jax.lax.fori_loop(0, per, it, (X, m1, m2, t))
            Xo, F, E, ST, sc = feasible_pass(X, targets, dirs, x0, dq_f, dk, kmin, kmax, r, c, pos_tol)
            better = sc < scb
            sel = lambda a, b_: jnp.where(better, a, b_)  # noqa: E731
            # continue from the feasible trajectory (the penalty alone leaves small rate excursions)
            return Xo, m1, m2, t, sel(Xo, Xb), sel(F, Fb), sel(E, Eb), sel(ST, STb), jnp.minimum(sc, scb)

        z = jnp.zeros_like(Xw)
        out = jax.lax.fori_loop(0, nb, block, (Xb, z, z, jnp.asarray(0.0, Xw.dtype), Xb, Fb, Eb, STb, scb))
        _, _, _, _, Xb, Fb, Eb, STb, _ = out
        return {"x": Xb, "f": Fb, "err": Eb, "status": STb}

    return traj


@program_cache(maxsize=16)
def _compiled(problem: WaypointProblem, opts_items: tuple[tuple[str, Any], ...], first_rate: bool) -> Any:
    traj = _kernel(problem, dict(opts_items), first_rate)
    # per path: warm start, targets, directions, start state, rate limits (dq_f, dk) and ratio;
    # the traced program kept on disk for the built-in criteria (jaxstiff.runtime.export_cache)
    fp = problem.fingerprint()
    return DiskJit(
        jax.vmap(traj, in_axes=(0, 0, 0, 0, 0, 0, None, None, 0, None, None)),
        None if fp is None else f"trajectory|{fp}|{opts_items!r}|{first_rate}",
        kernel_compiler_options(),
    )


def refine_batch(
    batch: WaypointBatch,
    warm: Mapping[str, Any],
    options: Mapping[str, Any] | None = None,
    pos_tol: float = POS_TOL,
) -> dict[str, Any]:
    """Trajectory-level refinement of a feasible batch solution ``warm`` (SOLVERS dict format).

    Args:
        batch: the paths (targets, directions (B, P, 3); q0, kj0 (B, n); ratio a number or (B,);
            ``limits.dq``/``dk`` (n,) or (B, n), per path).
        warm: the greedy solution (``q``, ``kj`` (B,P,n), ``status``...).

    Returns:
        The SOLVERS dict; per path, fewer unusable waypoints or a total criterion <= the warm start's.
    """
    opts = {**DEFAULT_OPTIONS, **{k: v for k, v in (options or {}).items() if k in DEFAULT_OPTIONS}}
    problem, limits = batch.problem, batch.limits
    targets = np.asarray(batch.targets, float)
    directions = np.asarray(batch.directions, float)
    B, P = targets.shape[:2]
    nf = problem.n_free
    free = list(problem.free_idx)
    Xw = problem.x_of(warm["q"], warm["kj"])
    x0 = problem.x_of(np.asarray(batch.q0, float), np.asarray(batch.kj0, float))
    r_arr = batch.ratios
    # at least 2 rows per compiled call: XLA compiles a batch of 1 differently (size-1 axes are
    # simplified away), so a lone path would differ from the same path in a batch in the last bits;
    # compiled batches of 2 or more rows give every row bit-identical results (measured on CPU)
    threads = chunk_threads(int(opts["threads"]))
    C = chunk_rows(B, int(opts["chunk"]), threads)
    items = tuple(sorted((k, v) for k, v in opts.items() if k not in ("chunk", "warm", "threads")))
    fn = _compiled(problem, items, bool(limits.first_rate_limit))
    dq_all, dk = limits.rows(B)  # (B, n) each: per-path rate limits
    dq_f = dq_all[:, free]
    dk = problem.spring_cols(dk)  # (B, nk): the sprung joints' (rigid locked joints have no stiffness)
    out: dict[str, Any] = {k: np.array(v, copy=True) for k, v in warm.items() if isinstance(v, np.ndarray)}
    pad = pad_rows
    chunks = [slice(s, min(s + C, B)) for s in range(0, B, C)]

    def run(sl: slice) -> dict[str, np.ndarray]:
        res = fn(
            pad(Xw[sl], C),
            pad(targets[sl], C),
            pad(directions[sl], C),
            pad(x0[sl], C),
            pad(dq_f[sl], C),
            pad(dk[sl], C),
            float(limits.kmin),
            float(limits.kmax),
            pad(r_arr[sl], C),
            float(batch.c),
            float(pos_tol),
        )
        return jax.tree_util.tree_map(np.asarray, res)

    t0 = time.perf_counter()
    with jax.enable_x64(True):  # map_chunks runs its worker threads under this setting too
        # the first chunk alone (it compiles), the others up to `threads` at once (runtime.threads)
        results = [run(chunks[0])] + map_chunks(run, chunks[1:], threads)
    dt = time.perf_counter() - t0
    for sl, res in zip(chunks, results, strict=True):
        m = sl.stop - sl.start
        q = out["q"][sl]
        q[..., free] = res["x"][:m, :, :nf]
        out["q"][sl] = q
        out["kj"][sl] = problem.kj_full(res["x"][:m, :, nf:])
        out["status"][sl] = res["status"][:m]
        out["pos_error"][sl] = res["err"][:m]
        out["nit"][sl] += int(opts["traj_iters"]) + (
            int(opts["traj_lm_rounds"]) * int(opts["traj_lm_iters"]) if lm_kind(problem) else 0
        )
    out["time_s"] += dt / (B * P)  # the refinement's wall time over all waypoints (chunks ran concurrently)
    return out


def run_request(req: SolveRequest) -> dict[str, Any]:
    """Adapter for :data:`jaxstiff.shaping.SOLVERS` (``solver="trajectory"``)."""
    opts = dict(req.options or {})
    warm_kind = opts.get("warm", DEFAULT_OPTIONS["warm"])
    split = opts.pop("warm_options", None)  # the warm start's options apart (else: the same dict)
    wreq = req if split is None else dataclasses.replace(req, options=dict(split))
    if warm_kind == "pgd":
        from jaxstiff.solvers import _pgd as pgd

        warm = pgd.run_request(wreq)
    elif warm_kind == "hybrid":
        from jaxstiff.solvers import _hybrid as hybrid

        warm = hybrid.run_request(wreq)
    elif warm_kind == "slsqp":
        from jaxstiff.solvers._base import SOLVERS, SolverInterrupted

        if req.starts not in (None, 1):
            raise ValueError(
                f"solver 'trajectory' with option warm='slsqp' is single-start (its warm start is SLSQP's "
                f"greedy chain from one state); got starts={req.starts}: give starts=1, or warm='pgd' or "
                "'hybrid' for several starts"
            )
        try:
            warm = SOLVERS["slsqp"](wreq)
        except SolverInterrupted:  # a partial warm start is no trajectory result: keep nothing
            raise KeyboardInterrupt from None
    else:
        raise ValueError(f"option warm must be 'pgd', 'hybrid' or 'slsqp', got {warm_kind!r}")
    out = refine_batch(
        req,
        warm,
        options=opts,
        pos_tol=req.pos_tol,
    )
    out["code_meaning"] = f"the warm start's ({warm_kind}): {warm.get('code_meaning')}"
    return out
