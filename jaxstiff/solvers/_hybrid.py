"""``solver="hybrid"``: multi-start projected gradient (:mod:`._pgd`), then a per-waypoint SLSQP polish.

pgd finds a good basin for every waypoint of every path at once; SLSQP (exact JAX derivatives,
:mod:`._slsqp`) then converges each waypoint to high accuracy from pgd's point. The polish walks
each path in order and must never undo pgd:

With ``chain="pgd"``:

* waypoint p's box is the rate box around the hybrid's own reference state (the last usable
  waypoint before p, as :func:`jaxstiff.results.reference_states` rebuilds it) **intersected with
  the rate box around pgd's next usable waypoint** p' > p. So pgd's waypoint p' stays feasible
  with respect to the (possibly changed) waypoint p, and by induction pgd's own point x_p is
  always inside waypoint p's box;
* SLSQP starts from pgd's x_p; its answer (made exactly feasible and judged as in :mod:`._slsqp`)
  replaces x_p only if it is usable and its criterion is lower. Hence, per waypoint, the hybrid's
  criterion is never above pgd's, and every constraint holds exactly;
* where pgd found no usable point, SLSQP starts from the reference state (clipped into the box);
  if that succeeds the waypoint becomes usable (and the next waypoint's box refers to it, which
  the backward intersection keeps consistent).

Two chainings (``options["chain"]``):

* ``"greedy"`` (default): waypoint p's box is the plain rate box around the hybrid's own previous
  waypoint (as in the seed); candidates are pgd's x_p (kept when it lies inside this box), SLSQP
  from pgd's x_p and SLSQP from the previous state (the seed's own start); the lowest usable
  criterion wins. pgd is never undone where its point is still admissible, and the seed's own
  candidate is always tried, so per waypoint it is at least as good as a greedy SLSQP step from
  the same state. Costs up to 2 SLSQP solves per waypoint. Per-waypoint gains can still undo
  pgd's trajectory-level choice (a rollout may accept a worse waypoint to keep room later), so a
  path whose greedy polish ends worse than pgd's (more unusable waypoints, or a higher total) is
  polished again with the ``"pgd"`` chain and the better of the two is kept: no path's total is
  above pgd's.
* ``"pgd"``: the box is additionally intersected with the rate box around pgd's next usable
  waypoint (described above): per waypoint never worse than pgd, strictly, but the polish can
  not leave pgd's corridor.

Options (besides pgd's and SLSQP's ``maxiter``/``ftol``): ``chain``; ``polish_slsqp`` = ``"all"``
(default) or ``"unusable"`` (only where pgd failed); ``polish_skip_tol`` (default 1e-6): where
pgd's point is admissible and its criterion is within this (relative) of the criterion's least
possible value (f2: 1, f1: c), SLSQP is not run there; 0 runs it everywhere. For f2 = (1 + |alpha|)
(1 + |r - rho|) a gap of 1e-6 is a ratio within 1e-6 of r and an orientation within 1e-6 degrees,
and it is SLSQP's own precision at f2's kinks (its answers there end 1e-7 to 3e-7 above 1 at
ftol 1e-8): a polish could move such a point only in digits that mean nothing, and on the greedy
chain its new posture can send every later waypoint out of pgd's rate corridor, to be solved again
from scratch (one LWR path of 50 waypoints: 5000 lockstep rounds, then discarded as no better).

Speed: the B paths' polishes advance together (:mod:`jaxstiff.solvers._lockstep`): each path's
sequential logic is a generator of SLSQP kernel requests, and each round evaluates all pending
requests in one batched call. Within a waypoint, the SLSQP solves from its several starts are
independent and advance side by side too (:func:`~jaxstiff.solvers._lockstep.gather`), so a path
takes as many rounds as its longest solve there, not their sum. The per-waypoint ``time_s`` is
pgd's plus an equal share of the polish's wall time.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from jaxstiff.results import _files as R
from jaxstiff.settings._solvers import HybridOptions
from jaxstiff.solvers import _pgd as pgd
from jaxstiff.solvers._base import SolveRequest
from jaxstiff.solvers._first_waypoint import lockstep_slsqp, rows_objective
from jaxstiff.solvers._greedy import (
    Objective,
    PosAndJac,
    SolverOutput,
    give_up,
    judge,
    refuse_target_step,
)
from jaxstiff.solvers._lockstep import Steps, gather, run_lockstep
from jaxstiff.solvers._problem import (
    WaypointBatch,
    WaypointProblem,
    clip_to_box,
    jax_pos_and_jac,
)

if TYPE_CHECKING:
    from jaxstiff.solvers._slsqp import SLSQPSolver

__all__ = ["DEFAULT_OPTIONS", "polish", "run_request"]

#: The hybrid's own options (besides pgd's and SLSQP's), from :class:`~jaxstiff.settings._solvers.HybridOptions`:
#: ``polish_slsqp`` "all" (every waypoint) or "unusable" (only where pgd found no usable point);
#: ``chain`` "greedy" or "pgd" (module docstring).
DEFAULT_OPTIONS = HybridOptions.defaults()

#: one SLSQP answer taken for a waypoint: ``(x, status, pos_error, solver output)``
_Answer = tuple[np.ndarray, int, float, SolverOutput]


def check_options(options: Mapping[str, Any] | None) -> dict[str, Any]:
    """The hybrid's own options (:data:`DEFAULT_OPTIONS`) checked (ValueError naming the option)."""
    return HybridOptions.check_values(HybridOptions.own(options))


@dataclasses.dataclass(frozen=True)
class _Polish:
    """What the polish of every path shares: the batch (B paths, P waypoints), pgd's result
    ``base``, the SLSQP solver and the problem's kernels."""

    batch: WaypointBatch
    ratios: np.ndarray  # (B,)
    base: dict[str, np.ndarray]
    mode: str  # option polish_slsqp
    skip_tol: float  # option polish_skip_tol
    solver: SLSQPSolver
    pos_and_jac: PosAndJac
    objective: Objective
    pos_tol: float
    first_starts: Sequence[Sequence[tuple[np.ndarray, np.ndarray]]] | None

    def params(self, b: int, p: int) -> np.ndarray:
        """The flat parameter vector of waypoint p of path b."""
        return WaypointProblem.params(
            self.batch.targets[b, p], self.batch.directions[b, p], self.ratios[b], self.batch.c
        )

    @property
    def problem(self) -> WaypointProblem:
        """The batch's waypoint problem."""
        return self.batch.problem


def polish(
    batch: WaypointBatch,
    base: dict[str, np.ndarray],
    options: Mapping[str, Any] | None = None,
    pos_tol: float = 1e-9,
    first_starts: Sequence[Sequence[tuple[np.ndarray, np.ndarray]]] | None = None,
) -> dict[str, np.ndarray]:
    """SLSQP polish of a feasible batch solution ``base`` (the SOLVERS dict format, e.g. pgd's).

    ``batch``: the paths (``ratio`` a number or (B,); ``limits.dq``/``dk`` (n,) or (B, n), per path).
    ``first_starts``: per path, the extra start states ``(q, kj)`` greedy SLSQP tries at a first
    waypoint without rate limit (:func:`jaxstiff.solvers._greedy.greedy_path`); with the greedy
    chain SLSQP runs from them there too, so the hybrid's first waypoint is never worse than
    greedy SLSQP's from those starts (greedy SLSQP's rescue starts, where none of them is in
    target, are not run here: pgd's own random first-waypoint starts cover the ranges).

    Returns a new dict in the same format; per waypoint the criterion is never above ``base``'s
    where ``base`` was usable.
    """
    opts = dict(options or {})
    own = {**DEFAULT_OPTIONS, **check_options(opts)}
    problem = batch.problem
    program, solver = lockstep_slsqp(batch, opts)
    B = batch.targets.shape[0]
    ctx = _Polish(
        batch,
        batch.ratios,
        base,
        own["polish_slsqp"],
        float(own["polish_skip_tol"]),
        solver,
        jax_pos_and_jac(problem),
        rows_objective(program),
        pos_tol,
        first_starts,
    )
    out = {k: np.array(v, copy=True) for k, v in base.items() if isinstance(v, np.ndarray)}
    t0 = time.perf_counter()
    gens = [
        _polish_greedy_path(ctx, b, out) if own["chain"] == "greedy" else _polish_path(ctx, b, "pgd", out)
        for b in range(B)
    ]
    # the B paths' SLSQP solves advance together, their kernel calls batched (one call per round)
    # (one rows program per problem and scale for the process: its compiled row counts are reused)
    run_lockstep(gens, program)
    # the polish's wall time, shared equally by the waypoints (the paths ran interleaved)
    out["time_s"] = out["time_s"] + (time.perf_counter() - t0) / max(out["time_s"].size, 1)
    return out


def _next_usable(usable: np.ndarray) -> np.ndarray:
    """(P,) index of the next usable waypoint after each waypoint (-1: none)."""
    nxt = np.full(usable.shape[0], -1)
    last = -1
    for p in range(usable.shape[0] - 1, -1, -1):
        nxt[p] = last
        if usable[p]:
            last = p
    return nxt


def _polish_path(ctx: _Polish, b: int, chain: str, dst: dict[str, np.ndarray]) -> Steps[None]:
    """Polish path b along ``chain`` ("greedy" or "pgd", module docstring), writing into ``dst``
    (a generator of SLSQP's kernel requests, :mod:`jaxstiff.solvers._lockstep`)."""
    problem = ctx.problem
    limits = ctx.batch.limits.for_path(b)  # path b's rate limits ((n,) dq, dk)
    dx = np.r_[np.asarray(limits.dq, float)[list(problem.free_idx)], problem.spring_cols(np.asarray(limits.dk, float))]
    Xb = problem.x_of(ctx.base["q"][b], ctx.base["kj"][b])
    usable_b = R.is_usable(ctx.base["status"][b])
    nxt = _next_usable(usable_b)
    q_ref, kj_ref = np.asarray(ctx.batch.q0[b], float).copy(), np.asarray(ctx.batch.kj0[b], float).copy()
    at_start = True
    for p in range(ctx.batch.targets.shape[1]):
        rate = limits.first_rate_limit or not at_start
        lb, ub = limits.box(problem, q_ref, kj_ref, rate)
        if chain == "pgd" and nxt[p] >= 0:
            xn = Xb[nxt[p]]
            lb, ub = np.maximum(lb, xn - dx), np.minimum(ub, xn + dx)
        usable_now = yield from _polish_waypoint(
            ctx, b, p, chain, dst, Xb, bool(usable_b[p]), lb, ub, rate, q_ref, kj_ref
        )
        if usable_now:
            q_ref = dst["q"][b, p].copy()
            kj_ref = dst["kj"][b, p].copy()
            at_start = False


def _polish_waypoint(  # noqa: PLR0913 - one waypoint's state beside the shared context ctx
    ctx: _Polish,
    b: int,
    p: int,
    chain: str,
    dst: dict[str, np.ndarray],
    Xb: np.ndarray,
    pgd_usable: bool,
    lb: np.ndarray,
    ub: np.ndarray,
    rate: bool,
    q_ref: np.ndarray,
    kj_ref: np.ndarray,
) -> Steps[bool]:
    """Waypoint p of path b inside its box ``[lb, ub]``: pgd's point ``Xb[p]`` (clipped exactly
    into the box, in place) where it is admissible, replaced by a better usable SLSQP answer;
    written into ``dst``. Returns whether the waypoint is usable."""
    nf = ctx.problem.n_free
    free = list(ctx.problem.free_idx)
    have = pgd_usable
    if chain == "greedy" and have:
        # pgd's point is a candidate only where it is inside this waypoint's box
        have = bool(np.all(Xb[p] >= lb - 1e-12) and np.all(Xb[p] <= ub + 1e-12))
    if have and np.all(lb <= ub):
        # pgd's point is inside this box up to rounding of the box arithmetic: clip exactly
        Xb[p] = clip_to_box(Xb[p], lb, ub)
        dst["q"][b, p, free] = Xb[p][:nf]
        dst["kj"][b, p] = ctx.problem.kj_full(Xb[p][nf:])
    take = None
    if np.all(lb <= ub) and (ctx.mode == "all" or not have):
        take = yield from _best_slsqp(ctx, b, p, chain, Xb[p], pgd_usable, have, lb, ub, rate, q_ref, kj_ref)
    if take is not None:
        x, status, err, sol = take
        dst["q"][b, p, free] = x[:nf]
        dst["kj"][b, p] = ctx.problem.kj_full(x[nf:])
        dst["status"][b, p] = status
        dst["pos_error"][b, p] = err
        dst["solver_code"][b, p] = sol.code
        dst["nit"][b, p] += sol.nit
        dst["nfev"][b, p] += sol.nfev
        return True
    if chain == "greedy" and pgd_usable and not have:
        # pgd's point left the box of the new chain and no SLSQP answer was usable
        dst["q"][b, p, free] = clip_to_box(Xb[p], lb, ub)[:nf]
        dst["kj"][b, p] = ctx.problem.kj_full(clip_to_box(Xb[p], lb, ub)[nf:])
        dst["status"][b, p] = R.UNREACHABLE
        return False
    if not have and np.all(lb <= ub):
        # an unusable waypoint still reports a state inside its own box (bounds and rate
        # limits hold at every waypoint): pgd's point, from pgd's chain, may be outside
        # the box of the hybrid's chain
        xc = clip_to_box(Xb[p], lb, ub)
        dst["q"][b, p, free] = xc[:nf]
        dst["kj"][b, p] = ctx.problem.kj_full(xc[nf:])
    return have


def _best_slsqp(  # noqa: PLR0913 - one waypoint's state beside the shared context ctx
    ctx: _Polish,
    b: int,
    p: int,
    chain: str,
    x_pgd: np.ndarray,
    pgd_usable: bool,
    have: bool,
    lb: np.ndarray,
    ub: np.ndarray,
    rate: bool,
    q_ref: np.ndarray,
    kj_ref: np.ndarray,
) -> Steps[_Answer | None]:
    """SLSQP from pgd's point (where pgd's waypoint was usable), from the reference state (the
    seed's own start; greedy chain, or where pgd's point is not admissible) and, at a first
    waypoint without rate limit, from greedy SLSQP's other starts: the usable answer with the
    lowest criterion if it is below pgd's (``have``: pgd's point is admissible), else None."""
    problem = ctx.problem
    params = ctx.params(b, p)
    starts = [x_pgd] if pgd_usable else []
    if chain == "greedy" or not have:
        starts.append(problem.x_of(q_ref, kj_ref))  # the seed's own start
        if chain == "greedy" and not rate and ctx.first_starts is not None:
            starts += [problem.x_of(qs, ks) for qs, ks in ctx.first_starts[b]]  # greedy SLSQP's others
    f_best = (yield from _criterion(ctx, x_pgd, params)) if have else np.inf
    f_min = problem.criterion_minimum(ctx.batch.c)
    if have and f_min is not None and f_best - f_min <= ctx.skip_tol * max(1.0, abs(f_min)):
        return None  # pgd's point is optimal to the tolerance: no SLSQP answer can be usefully lower
    if not pgd_usable and not rate and starts:
        # nothing usable from pgd at a waypoint without rate limit: given up when no start and no
        # IK from one gets near it (greedy.GIVE_UP_REL), instead of 1000-iteration SLSQP solves
        boxed = [clip_to_box(xs, lb, ub) for xs in starts]
        t, d = ctx.batch.targets[b, p], ctx.batch.directions[b, p]
        if give_up(problem, boxed, lb, ub, t, d, ctx.pos_and_jac) is not None:
            return None

    def one(xs: np.ndarray) -> Steps[tuple[_Answer, float] | None]:
        x_start = clip_to_box(xs, lb, ub)
        try:
            sol = yield from ctx.solver.steps(
                x_start.copy(), lb, ub, params, maxiter=None if rate else ctx.solver.options["first_maxiter"]
            )
        except (ValueError, ArithmeticError, np.linalg.LinAlgError, FloatingPointError):
            sol = SolverOutput(x_start.copy(), -1, False, 0, 0)
        x, status, err = judge(
            problem, sol, x_start, lb, ub, ctx.batch.targets[b, p], params, ctx.pos_and_jac, ctx.objective, ctx.pos_tol
        )
        if status not in R.USABLE:
            return None
        f_new = yield from _criterion(ctx, x, params)
        return (x, status, err, sol), f_new

    # the starts' solves are independent: run side by side (one round per step of the longest)
    take = None
    for res in (yield from gather([one(xs) for xs in starts])):
        if res is not None and res[1] < f_best:
            take, f_best = res
    return take


def _criterion(ctx: _Polish, x: np.ndarray, params: np.ndarray) -> Steps[float]:
    """The criterion at ``x`` as a kernel request like SLSQP's (:mod:`jaxstiff.solvers._lockstep`:
    batched with the other paths' requests instead of a kernel call of its own)."""
    nx = ctx.problem.nx
    out = yield (x / ctx.solver.scale[:nx], params)
    return float(out[0]) / float(ctx.solver.scale[nx])


def _path_key(ctx: _Polish, d: Mapping[str, np.ndarray], b: int) -> Steps[tuple[int, float]]:
    """(unusable waypoints, total criterion of the usable ones) of path b in result d (the criterion
    values as kernel requests, :func:`_criterion`: one kernel call per waypoint was 4 s of a 64 x 50
    polish)."""
    u = R.is_usable(d["status"][b])
    values = yield from gather(
        [
            _criterion(ctx, ctx.problem.x_of(d["q"][b, p], d["kj"][b, p]), ctx.params(b, int(p)))
            for p in np.flatnonzero(u)
        ]
    )
    return int((~u).sum()), float(sum(values, 0.0))


def _polish_greedy_path(ctx: _Polish, b: int, out: dict[str, np.ndarray]) -> Steps[None]:
    """Path b with the greedy chain, and again with the "pgd" chain where that ends worse than pgd.

    The greedy chain takes any better point per waypoint, which can undo pgd's trajectory-level
    choice (a rollout may accept a worse first waypoint to keep room later; docs/notes/solvers.md).
    Where the greedy path ends worse than pgd's in total, the path is polished again inside pgd's
    corridor (chain "pgd": per waypoint never above pgd), and the better of the two is kept.
    """
    base = ctx.base
    yield from _polish_path(ctx, b, "greedy", out)
    k_g, k_b = yield from gather([_path_key(ctx, out, b), _path_key(ctx, base, b)])
    if k_g[0] > k_b[0] or (k_g[0] == k_b[0] and k_g[1] > k_b[1] * (1 + 1e-9) + 1e-12):
        greedy = {k: out[k][b].copy() for k in out}
        for k in out:
            out[k][b] = base[k][b]
        yield from _polish_path(ctx, b, "pgd", out)
        k_p = yield from _path_key(ctx, out, b)
        if not k_p < k_g:
            for k in out:
                out[k][b] = greedy[k]


def run_request(req: SolveRequest) -> dict[str, Any]:
    """Adapter for :data:`jaxstiff.solvers._base.SOLVERS` (``solver="hybrid"``)."""
    opts = dict(req.options or {})
    refuse_target_step(opts, "hybrid (its SLSQP polish)")
    pg_opts = {k: v for k, v in opts.items() if k in pgd.DEFAULT_OPTIONS}
    base = pgd.solve_batch(
        req,
        starts=req.starts,
        options=pg_opts,
        pos_tol=req.pos_tol,
        first_starts=req.first_starts,
    )
    base.pop("criterion", None)
    out: dict[str, Any] = polish(
        req,
        base,
        options=opts,
        pos_tol=req.pos_tol,
        first_starts=req.first_starts,
    )
    from jaxstiff.solvers._slsqp import CODE_MEANING

    out["code_meaning"] = (
        f"{CODE_MEANING}, where the polish's answer was taken; else the index of pgd's "
        "winning start (the file does not tell the two apart)"
    )
    return out
