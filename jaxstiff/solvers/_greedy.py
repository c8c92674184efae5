"""Seed 000's greedy chaining, shared by the per-waypoint solvers: waypoint after waypoint, each
solved from the last usable state inside its rate-limited box, the answer made exactly feasible
and judged (status codes of :mod:`jaxstiff.results`).

* :func:`greedy_path` one path, any per-waypoint solver ``(x0, lb, ub, params, maxiter=None) ->
  SolverOutput`` (SLSQP with JAX derivatives in :mod:`._slsqp`, with finite differences in
  :mod:`._slsqp_fd`);
* :func:`judge` the verdict on one solver answer: clip into the box, Newton projection back onto
  the path inside the box if needed, then the checks (position error, box, finiteness);
* :func:`run_greedy` every path of a :class:`~jaxstiff.solvers._base.SolveRequest` in the
  :data:`~jaxstiff.solvers._base.SOLVERS` format, the waypoints not reached before an interrupt
  marked NOT_RUN (:func:`not_run_outcomes`).
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable, Mapping, Sequence
from typing import Any, Protocol

import numpy as np

from jaxstiff.results import _files as R
from jaxstiff.results._target import ALPHA_TOL_DEG, RATIO_REL_TOL
from jaxstiff.runtime._io import hold_interrupts
from jaxstiff.solvers._base import SolveRequest, SolverInterrupted, outcomes_to_arrays
from jaxstiff.solvers._problem import (
    BOUND_TOL,
    POS_TOL,
    WaypointBatch,
    WaypointProblem,
    clip_to_box,
    compiled,
    content_seed,
    jax_pos_and_jac,
    newton_project,
)
from jaxstiff.solvers._problem.target_step import ACCEPT_REL, LM_STEPS, TargetStep
from jaxstiff.stiffness._criteria import f2

__all__ = ["CODE_MEANING", "GIVE_UP_REL"]

REPAIR_POS = 1e-6  #: m: a solver answer further than this off the path counts as CLIPPED when repaired
#: a waypoint without rate limit is given up (status 3, no SLSQP run) when neither its start postures
#: nor position IK from each of them and from as many random postures come closer to it than this
#: share of the robot's size (``length_scale``; 1 mm on a 1 m arm): a reachable waypoint's IK ends
#: within round-off of it, so only waypoints far off every posture tried are given up
GIVE_UP_REL = 1e-3
TIE_RTOL = 1e-3  #: criteria within this relative distance of the best one count as equally good
#: the first waypoint's best answer further than this (relative) above the criterion's least value
#: gets the target step from each usable answer (f2: a ratio within 1e-6 of r and an orientation
#: within 1e-6 deg count as reached, the hybrid's ``polish_skip_tol``)
FIRST_POLISH_REL = 1e-6

#: meaning of the result file's ``solver_code`` for the SLSQP solvers (meta ``solver_code_meaning``)
CODE_MEANING = (
    "SLSQP exit mode (0 = converged, scipy's modes 1-9 otherwise, 10 = stalled: infeasible and no "
    "longer moving), -1 = exception"
)
#: added to :data:`CODE_MEANING` where the walk had a target step
TARGET_STEP_MEANING = (
    "; 0 also where the target step reached the criterion's least value: at a rate-limited waypoint "
    "SLSQP then did not run (nit, nfev: its Levenberg-Marquardt steps); at the first waypoint it "
    "polished an SLSQP answer (its steps added to SLSQP's)"
)

#: ``q (n,) -> (position (3,), J[rows][:, free] (k, n_free))``
PosAndJac = Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]]
#: ``(x (nx,), params (8,)) -> criterion``
Objective = Callable[[np.ndarray, np.ndarray], float]


@dataclasses.dataclass
class SolverOutput:
    """What a per-waypoint solver returns: its point and its own bookkeeping."""

    x: np.ndarray
    code: int  # the solver's own exit code (SLSQP mode); -1 = exception
    converged: bool
    nit: int
    nfev: int


@dataclasses.dataclass
class WaypointOutcome:
    """Final, checked state of one waypoint."""

    x: np.ndarray
    status: int
    pos_error: float
    code: int
    nit: int
    nfev: int
    time_s: float


class WaypointSolver(Protocol):
    """A per-waypoint solver ``solver(x0, lb, ub, params, maxiter=None) -> SolverOutput`` (all (nx,)
    but params (8,); ``maxiter`` None: its own default) carrying its checked ``options``."""

    options: dict[str, Any]

    def __call__(
        self, x0: np.ndarray, lb: np.ndarray, ub: np.ndarray, params: np.ndarray, maxiter: int | None = None
    ) -> SolverOutput: ...


#: one judged answer for a waypoint: ``(x, status, pos_error, solver code, criterion)``
Candidate = tuple[np.ndarray, int, float, int, float]


class PathInterrupted(KeyboardInterrupt):
    """A ``KeyboardInterrupt`` (Ctrl-C, or SIGTERM under the command line) during
    :func:`greedy_path`, carrying the outcomes of the waypoints finished before it (``done``)."""

    def __init__(self, done: list[WaypointOutcome]):
        super().__init__()
        self.done = done


def not_run_outcomes(
    problem: WaypointProblem, done: Sequence[WaypointOutcome], P: int, q0: np.ndarray, kj0: np.ndarray
) -> list[WaypointOutcome]:
    """``done`` completed to P waypoints with status NOT_RUN: each holds the reference state (the
    last usable waypoint's x, else the start state), so bounds and rate limits still hold."""
    x_ref = problem.x_of(np.asarray(q0, float), np.asarray(kj0, float))
    for o in done:
        if o.status in R.USABLE:
            x_ref = o.x
    return list(done) + [WaypointOutcome(x_ref.copy(), R.NOT_RUN, 0.0, -1, 0, 0, 0.0) for _ in range(P - len(done))]


def kernel_objective(problem: WaypointProblem) -> Objective:
    """``(x, params) -> f`` (a Python float) on the problem's jitted kernel (:func:`compiled`)."""
    fused = compiled(problem)

    def objective(x: np.ndarray, params: np.ndarray) -> float:
        return float(np.asarray(fused(x, params))[0])

    return objective


def judge(
    problem: WaypointProblem,
    sol: SolverOutput,
    x_start: np.ndarray,
    lb: np.ndarray,
    ub: np.ndarray,
    target: np.ndarray,
    params: np.ndarray,
    pos_and_jac: PosAndJac,
    objective: Objective,
    pos_tol: float,
) -> tuple[np.ndarray, int, float]:
    """Make the solver's answer exactly feasible if possible and give it its status code."""
    nf = problem.n_free
    locked = np.nan_to_num(problem.robot.locked_values)
    free = list(problem.free_idx)
    rows = list(problem.pos_rows)

    def pos_err(x: np.ndarray) -> tuple[float, float]:
        q = locked.copy()
        q[free] = x[:nf]
        p, _ = pos_and_jac(q)
        e_rows = float(np.linalg.norm(p[rows] - target[rows]))
        return float(np.linalg.norm(p - target)), e_rows

    x = np.asarray(sol.x, float)
    nonfinite = not np.all(np.isfinite(x))
    if nonfinite:
        x = clip_to_box(x_start, lb, ub)
    excursion = float(np.max(np.r_[lb - x, x - ub, 0.0]))
    x = clip_to_box(x, lb, ub)
    err3, err_rows = pos_err(x)
    repaired = False
    if not np.isfinite(err_rows) or err_rows > 1e-13:
        x_new = newton_project(problem, x, target, lb, ub, pos_and_jac)
        e3_new, er_new = pos_err(x_new)
        if np.isfinite(er_new) and (not np.isfinite(err_rows) or er_new < err_rows):
            repaired = err_rows > REPAIR_POS
            x, err3, err_rows = x_new, e3_new, er_new
    f = objective(x, params) if np.all(np.isfinite(x)) else float("nan")
    if nonfinite or not np.isfinite(f) or not np.isfinite(err3):
        return x, R.NONFINITE, err3
    if err3 > pos_tol:
        return x, R.UNREACHABLE, err3
    if excursion > BOUND_TOL or repaired:
        return x, R.CLIPPED, err3
    return x, (R.SOLVED if sol.converged else R.NOT_CONVERGED), err3


def _pick(problem: WaypointProblem, cands: Sequence[Candidate]) -> Candidate:
    """The best of several answers for one waypoint: usable first, then the lowest criterion; among
    usable answers whose criterion is within :data:`TIE_RTOL` of the best (f2 and f1 have whole
    sets of optimal postures), the one farthest from the joint limits (smallest normalised margin
    of the free joints), so the next waypoints have room before a limit binds."""
    usable = [c for c in cands if c[1] in R.USABLE]
    if not usable:
        return min(cands, key=lambda c: c[2])
    fbest = min(c[4] for c in usable)
    ties = [c for c in usable if c[4] <= fbest + TIE_RTOL * max(abs(fbest), 1e-12)]
    lo, hi = problem.robot.lower, problem.robot.upper
    free = list(problem.free_idx)
    nf = problem.n_free
    span = (hi - lo)[free]
    # a continuous joint has no limit to keep away from, and a joint whose range is one value
    # no room to keep (its margin would be 0 / 0): neither counts
    finite = np.isfinite(span) & (span > 0)
    span = np.where(finite, span, 1.0)

    def margin(c: Candidate) -> float:
        qf = c[0][:nf]
        m = np.where(
            finite,
            np.minimum(qf - np.where(finite, lo[free], 0.0), np.where(finite, hi[free], 0.0) - qf) / span,
            np.inf,
        )
        return float(np.min(m)) if nf else 0.0

    return max(ties, key=margin)


def target_bound(problem: WaypointProblem, r: Any, c: float) -> np.ndarray | None:
    """The criterion value below which a waypoint is provably in target, for the wanted ratio(s)
    ``r`` (a number or an array: the bound has its shape), or None for a criterion without such a
    bound (a user's own) or a problem without stiffness variables. With the tolerances a = 1 deg
    and tol = 2 % (:mod:`jaxstiff.results._target`): f2 = (1 + alpha)(1 + |r - rho|) <
    min(1 + a, 1 + tol r) gives alpha < a and |rho - r| < tol r; f1 = (alpha + c) r / min(rho, r)
    < min(a + c, c / (1 - tol)) gives alpha < a and rho > (1 - tol) r."""
    if problem.criterion_minimum(c) is None or problem.n_spring == 0:
        return None
    r = np.asarray(r, float)
    a, tol = ALPHA_TOL_DEG, RATIO_REL_TOL
    if problem.criterion is f2:
        return np.minimum(1.0 + a, 1.0 + tol * r)
    return np.full(r.shape, min(a + c, c / (1.0 - tol)))


def maybe_off_target(problem: WaypointProblem, cands: Sequence[Candidate], r: float, c: float) -> bool:
    """False when a usable candidate's criterion value proves it in target (below
    :func:`target_bound`), else True; always False for other criteria (no such bound)."""
    bound = target_bound(problem, r, c)
    if bound is None:
        return False
    fbest = min((cd[4] for cd in cands if cd[1] in R.USABLE), default=np.inf)
    return not fbest < float(bound)


def rescue_starts(
    problem: WaypointProblem,
    count: int,
    ref: np.ndarray,
    lb: np.ndarray,
    ub: np.ndarray,
    target: np.ndarray,
    direction: np.ndarray,
) -> list[np.ndarray]:
    """``count`` start states for a first waypoint the usual starts left off the criterion's
    minimum: postures drawn uniformly over the joint ranges (continuous joints: one turn), each
    brought onto the waypoint by position IK, and stiffnesses drawn log-uniformly in the box. The
    usual starts are the nominal posture's neighbours with one shared mid-range stiffness; f1 and
    f2's minima may lie in another IK branch, or have joints near kmin. Seeded by the waypoint's
    own data (``ref``: the reference state), so a path gets the same starts anywhere in a batch."""
    import jax

    from jaxstiff.ik import ik_position

    robot = problem.robot
    rng = np.random.default_rng(content_seed(target, direction, ref))
    nf = problem.n_free
    lo = np.where(np.isfinite(robot.lower), robot.lower, -np.pi)
    hi = np.where(np.isfinite(robot.upper), robot.upper, np.pi)
    klo = np.log(np.maximum(lb[nf:], 1e-300))
    khi = np.log(np.maximum(ub[nf:], 1e-300))
    out = []
    for _ in range(count):
        q = np.where(robot.free, rng.uniform(lo, hi), np.nan_to_num(robot.locked_values))
        with jax.enable_x64(True):  # as the usual starts' IK (shape runs the solvers so; a direct call may not)
            q, _ = ik_position(robot, target, q, planar=problem.task == "xy")
        kj = np.exp(rng.uniform(klo, khi))
        out.append(clip_to_box(np.r_[np.asarray(q, float)[list(problem.free_idx)], kj], lb, ub))
    return out


def give_up(
    problem: WaypointProblem,
    starts: Sequence[np.ndarray],
    lb: np.ndarray,
    ub: np.ndarray,
    target: np.ndarray,
    direction: np.ndarray,
    pos_and_jac: PosAndJac,
) -> Candidate | None:
    """For a waypoint without rate limit: None when it may be reachable (some start posture is on
    it, or position IK from a start or from a rescue posture gets within ``GIVE_UP_REL *
    length_scale``), else the closest posture found, as an UNREACHABLE candidate.

    Why: an unreachable waypoint kept the usual 8 starts and the 8 rescue starts busy for up to
    ``first_maxiter`` (1000) SLSQP iterations each, about 13 s per waypoint on the LWR, and every
    later waypoint of a path whose first ones are unreachable is again one without rate limit.
    The IK costs milliseconds; on a reachable waypoint nothing changes (the solves run as before)."""
    from jaxstiff.ik import ik_position

    nf, rows = problem.n_free, list(problem.pos_rows)
    free = list(problem.free_idx)
    locked = np.nan_to_num(problem.robot.locked_values)
    tol = GIVE_UP_REL * problem.robot.length_scale

    def q_of(x: np.ndarray) -> np.ndarray:
        q = locked.copy()
        q[free] = x[:nf]
        return q

    def off(q: np.ndarray) -> float:
        return float(np.linalg.norm(pos_and_jac(q)[0][rows] - target[rows]))

    best: tuple[float, np.ndarray] | None = None
    for x in starts:
        e = off(q_of(x))
        if e <= tol:
            return None
        best = (e, x) if best is None or e < best[0] else best
    import jax

    planar = problem.task == "xy"
    tries = [q_of(x) for x in starts]
    for i, q in enumerate(tries):
        with jax.enable_x64(True):
            qi, e = ik_position(problem.robot, target, q, planar=planar)
        if e <= tol:
            return None
        x = clip_to_box(np.r_[np.asarray(qi, float)[free], starts[i][nf:]], lb, ub)
        best = (e, x) if best is None or e < best[0] else best
    for x in rescue_starts(problem, len(starts), starts[0], lb, ub, target, direction):
        e = off(q_of(x))
        if e <= tol:
            return None
        best = (e, x) if e < best[0] else best  # type: ignore[index]
    assert best is not None
    x = best[1]
    err3 = float(np.linalg.norm(pos_and_jac(q_of(x))[0] - target))
    return x, R.UNREACHABLE, err3, -1, np.inf


def _solve_starts(  # noqa: PLR0913 - one waypoint's problem, passed as its parts
    problem: WaypointProblem,
    solver: WaypointSolver,
    starts: Sequence[np.ndarray],
    lb: np.ndarray,
    ub: np.ndarray,
    target: np.ndarray,
    params: np.ndarray,
    pos_and_jac: PosAndJac,
    objective: Objective,
    pos_tol: float,
    maxiter: int | None,
) -> tuple[list[Candidate], int, int]:
    """One waypoint solved from each start (``starts[0]``: the reference state clipped into the
    box), each answer judged: the candidates and the iterations and evaluations of all solves."""
    cands: list[Candidate] = []
    nit = nfev = 0
    for xs in starts:
        try:
            sol = solver(xs.copy(), lb, ub, params, maxiter=maxiter)
        except (ValueError, ArithmeticError, np.linalg.LinAlgError, FloatingPointError):
            sol = SolverOutput(xs.copy(), -1, False, 0, 0)
        nit, nfev = nit + sol.nit, nfev + sol.nfev
        x, status, err = judge(problem, sol, xs, lb, ub, target, params, pos_and_jac, objective, pos_tol)
        if status == R.NONFINITE:
            x = starts[0]
        f = objective(x, params) if status in R.USABLE else np.inf
        cands.append((x, status, err, sol.code, f))
    return cands, nit, nfev


def greedy_path(  # noqa: PLR0913 - the greedy walk's inputs, each documented below
    batch: WaypointBatch,
    b: int,
    solver: WaypointSolver,
    pos_and_jac: PosAndJac | None = None,
    objective: Objective | None = None,
    pos_tol: float = POS_TOL,
    progress: Callable[[int], None] | None = None,
    first_starts: Sequence[tuple[np.ndarray, np.ndarray]] = (),
    first_maxiter: int | None = None,
    path_retries: int = 0,
    target_step: TargetStep | None = None,
) -> list[WaypointOutcome]:
    """Solve the waypoints of path ``b`` of ``batch`` one after the other (seed 000's greedy scheme).

    Waypoint p's box is built around the reference state: the last usable waypoint's
    (q, kj), or the start state ``(q0, kj0)`` before the first usable waypoint (with the rate
    limits only if ``limits.first_rate_limit``). The solver starts from the reference state
    clipped into the box.

    Args:
        batch: the paths (problem, targets and directions (B, P, 3), start states (B, n), limits,
            criterion parameters ratio and c).
        b: which path of the batch.
        solver: ``(x0, lb, ub, params) -> SolverOutput``.
        pos_and_jac: ``q -> (position (3,), J[rows][:, free])`` for the repair and the check;
            default: the JAX kernel.
        objective: ``(x, params) -> f`` for the final check; default: the JAX kernel.
        pos_tol: position tolerance (m) of a usable waypoint.
        progress: called with the waypoint index after each waypoint.
        first_starts: extra start states ``(q (n,), kj (n,))`` for the first waypoint when it is
            not rate-limited: the solver runs from the reference state and from each of these,
            and the usable answer with the lowest criterion is kept (a multi-start against the
            non-convexity of the first, unconstrained waypoint); ties (within 0.1%) go to the
            posture farthest from the joint limits (:data:`TIE_RTOL`).
        first_maxiter: iteration limit for that first, not rate-limited waypoint (None: the
            solver's default).
        path_retries: where a rate-limited waypoint ends off target (its criterion not below
            :func:`target_bound`) after a first waypoint in target, up to this many other optima of the
            first waypoint (the tied answers of its multi-start, farthest from the joint limits
            first) are walked again, keeping the walk with the fewest unsolved, then off-target
            waypoints, then the lowest sum of the criterion (not where the first waypoint itself
            is off target). f2 and f1 have whole sets of optimal first postures, and which one the
            walk leaves from decides whether a rate-limited stretch later can follow. The walks
            are stopped where they can no longer be kept: each at its first miss while one in
            target everywhere is looked for (the first found is kept), then, where none is, each
            as long as it can still rank better than the best so far. 0: seed 000's scheme alone.
        target_step: at a rate-limited waypoint, tried before the solver from the same start
            (:func:`jaxstiff.solvers._problem.target_step.target_step`); its answer is kept where it
            is usable with the criterion within ``ACCEPT_REL`` of its least value, and the solver
            does not run there. None: the solver alone.

    Returns:
        One :class:`WaypointOutcome` per waypoint.
    """
    t0 = time.perf_counter()
    walk = _GreedyWalk(batch, b, solver, pos_and_jac, objective, pos_tol, first_starts, first_maxiter, target_step)
    # the first walk stops at its first off-target waypoint where retries follow it (a first
    # waypoint in target with other optima); a walk that ends was in target throughout, or had
    # its first waypoint off target (its tied alternatives are as far off: a target no posture
    # reaches would cost every walk), or had no other optima to leave from
    try:
        return walk.run(None, progress, stop=walk.retry_due if path_retries > 0 else None)[0]
    except _Outranked as e:
        first = e.state
    assert walk.bound is not None  # retry_due holds only with a bound
    return _retries(walk, float(walk.bound), first.alternatives[:path_retries], first, progress, t0)


def _retries(
    walk: _GreedyWalk,
    bound: float,
    alternatives: Sequence[Candidate],
    first: _WalkState,
    progress: Callable[[int], None] | None,
    t0: float,
) -> list[WaypointOutcome]:
    """:func:`greedy_path`'s retries from the first waypoint's other optima, the first walk
    stopped at its first off-target waypoint (``first``): the walk kept."""
    # first, each alternative is walked only while it stays usable and in target: the first one
    # that ends is in target throughout, the walk the ranking keeps (no walk ranks better), found
    # without walking the first or the other alternatives further
    stopped: list[_WalkState] = []
    for alt in alternatives:
        try:
            o2, _, _ = walk.run(alt, None, stop=_above((0, 0)))
        except PathInterrupted:
            raise PathInterrupted(first.out) from None  # the first walk's finished waypoints
        except _Outranked as e:
            stopped.append(e.state)
            continue
        if progress is not None:
            for p in range(len(first.out), len(o2)):
                progress(p)
        return _spread(o2, t0)
    # none: the first walk goes on, then each alternative from where it stopped, as far as it can
    # still rank better than the best walk so far (the same choice as walking each whole, in
    # this order, for fewer waypoints: a walk stopped so ranks below the best)
    out, fs, _ = walk.run(None, progress, resume=first)
    rank = _walk_rank(out, fs, bound)
    for state in stopped:
        try:
            o2, f2s, _ = walk.run(None, None, stop=_above(rank[:2]), resume=state)
        except PathInterrupted:
            raise PathInterrupted(out) from None  # the best complete walk so far
        except _Outranked:
            continue
        r2 = _walk_rank(o2, f2s, bound)
        if r2 < rank:
            out, rank = o2, r2
    return _spread(out, t0)


def _above(counts: tuple[int, int]) -> Callable[[_WalkState], bool]:
    """A walk's stop rule: its (unsolved, off target) counts above ``counts``."""
    return lambda st: st.counts > counts


def _spread(out: list[WaypointOutcome], t0: float) -> list[WaypointOutcome]:
    """``out`` with the time since ``t0`` its waypoints do not count (the retries, the walks not
    kept) spread evenly over them: their times add up to the path's."""
    extra = max(time.perf_counter() - t0 - sum(o.time_s for o in out), 0.0) / max(len(out), 1)
    return [dataclasses.replace(o, time_s=o.time_s + extra) for o in out]


@dataclasses.dataclass
class _WalkState:
    """A walk stopped after ``len(out)`` waypoints, to go on from there: the reference state,
    the outcomes and criteria so far, and its (unsolved, off target) counts."""

    q_ref: np.ndarray
    kj_ref: np.ndarray
    at_start: bool
    out: list[WaypointOutcome]
    fs: list[float]
    counts: tuple[int, int]
    alternatives: list[Candidate] = dataclasses.field(default_factory=list)


class _Outranked(Exception):
    """A walk stopped by its stop rule (:meth:`_GreedyWalk.run`'s ``stop``); ``state`` lets it go
    on from there (``resume``)."""

    def __init__(self, state: _WalkState) -> None:
        super().__init__()
        self.state = state


def _walk_rank(out: Sequence[WaypointOutcome], fs: Sequence[float], bound: float) -> tuple[int, int, float]:
    """``(unsolved waypoints, usable ones not provably in target, sum of the criterion over the
    usable ones)`` of one walk: lower is better, compared in that order."""
    usable = [o.status in R.USABLE for o in out]
    off = sum(1 for u, f in zip(usable, fs, strict=True) if u and not f < bound)
    total = float(sum(f for u, f in zip(usable, fs, strict=True) if u))
    return (len(out) - sum(usable), off, total if np.isfinite(total) else np.inf)


class _GreedyWalk:
    """One greedy walk along a path (:func:`greedy_path`), repeatable from another first-waypoint
    answer."""

    def __init__(  # noqa: PLR0913 - greedy_path's inputs
        self,
        batch: WaypointBatch,
        b: int,
        solver: WaypointSolver,
        pos_and_jac: PosAndJac | None,
        objective: Objective | None,
        pos_tol: float,
        first_starts: Sequence[tuple[np.ndarray, np.ndarray]],
        first_maxiter: int | None,
        target_step: TargetStep | None = None,
    ) -> None:
        self.problem = batch.problem
        self.limits = batch.limits.for_path(b)
        self.targets, self.directions = batch.targets[b], batch.directions[b]
        self.ratio, self.c = float(batch.ratios[b]), batch.c
        self.q0, self.kj0 = np.asarray(batch.q0[b], float), np.asarray(batch.kj0[b], float)
        self.solver, self.pos_tol = solver, pos_tol
        self.pj = jax_pos_and_jac(self.problem) if pos_and_jac is None else pos_and_jac
        self.fobj = kernel_objective(self.problem) if objective is None else objective
        self.first_starts, self.first_maxiter = first_starts, first_maxiter
        self.bound = target_bound(self.problem, self.ratio, self.c)
        self.target_step = target_step
        least = self.problem.criterion_minimum(self.c) if target_step is not None else None
        self.accept_below = None if least is None else least + ACCEPT_REL * max(abs(least), 1e-300)
        #: the first waypoint's best answer above this: polished by the target step
        self.polish_above = None if least is None else least + FIRST_POLISH_REL * max(abs(least), 1e-300)

    def run(
        self,
        first: Candidate | None,
        progress: Callable[[int], None] | None,
        stop: Callable[[_WalkState], bool] | None = None,
        resume: _WalkState | None = None,
    ) -> tuple[list[WaypointOutcome], list[float], list[Candidate]]:
        """The walk: outcomes, the criterion of each, and the first waypoint's other optima (when
        it was solved here, not rate-limited); ``first`` given: the walk leaves from that answer
        of the first waypoint instead of solving it. ``stop``: checked after each waypoint on the
        walk's state (its (unsolved, off target) counts, :func:`_walk_rank`'s first two, only
        grow along it); where it holds, the walk raises :class:`_Outranked` carrying its state.
        ``resume``: a stopped walk's state, gone on from (``first`` is then not used)."""
        problem, limits, targets = self.problem, self.limits, self.targets
        if resume is None:
            st = _WalkState(self.q0, self.kj0, True, [], [], (0, 0))
        else:
            st = dataclasses.replace(resume, out=list(resume.out), fs=list(resume.fs))
            first = None
        try:
            if stop is not None and self.bound is not None and stop(st):
                raise _Outranked(st)
            for p in range(len(st.out), targets.shape[0]):
                t0 = time.perf_counter()
                rate = limits.first_rate_limit or not st.at_start
                if first is not None and not rate:
                    x, status, err, code, f = first
                    nit = nfev = 0
                else:
                    x, status, err, code, f, nit, nfev, alts = self._waypoint(p, st.q_ref, st.kj_ref, rate)
                    if not rate:
                        st.alternatives = alts
                st.out.append(WaypointOutcome(x, status, err, code, nit, nfev, time.perf_counter() - t0))
                st.fs.append(f)
                usable = status in R.USABLE
                if self.bound is not None:  # _walk_rank's first two counts, kept as the walk goes
                    st.counts = (st.counts[0] + (not usable), st.counts[1] + (usable and not f < float(self.bound)))
                if usable:
                    st.q_ref = st.q_ref.copy()
                    st.q_ref[list(problem.free_idx)] = x[: problem.n_free]
                    st.kj_ref = np.array(problem.kj_full(x[problem.n_free :]), copy=True)
                    st.at_start = False
                if progress is not None:
                    progress(p)
                if stop is not None and self.bound is not None and stop(st):
                    raise _Outranked(st)
        except KeyboardInterrupt:
            # the waypoints in `out` are finished and consistent (each is appended whole); the caller
            # may keep them (shape marks the rest NOT_RUN)
            raise PathInterrupted(st.out) from None
        return st.out, st.fs, st.alternatives

    def retry_due(self, st: _WalkState) -> bool:
        """The first walk's stop rule where retries may follow: an off-target waypoint after a
        first waypoint in target that has other optima (:func:`greedy_path`)."""
        if self.bound is None or st.counts[1] == 0 or not st.alternatives:
            return False
        return st.out[0].status in R.USABLE and st.fs[0] < float(self.bound)

    def _waypoint(
        self, p: int, q_ref: np.ndarray, kj_ref: np.ndarray, rate: bool
    ) -> tuple[np.ndarray, int, float, int, float, int, int, list[Candidate]]:
        """Waypoint p from the reference state: ``(x, status, pos_error, code, f, nit, nfev,
        other optima)`` (the other optima only where it is not rate-limited)."""
        problem, target, direction = self.problem, self.targets[p], self.directions[p]
        lb, ub = self.limits.box(problem, q_ref, kj_ref, rate)
        starts = [clip_to_box(problem.x_of(q_ref, kj_ref), lb, ub)]
        if not rate:
            starts += [clip_to_box(problem.x_of(qs, ks), lb, ub) for qs, ks in self.first_starts]
        params = WaypointProblem.params(target, direction, self.ratio, self.c)
        hopeless = None if rate else give_up(problem, starts, lb, ub, target, direction, self.pj)
        if hopeless is not None:  # out of reach of every posture tried: no SLSQP run (GIVE_UP_REL)
            x, status, err, code, f = hopeless
            return x, status, err, code, f, 0, 0, []
        if rate and self.target_step is not None and self.accept_below is not None:
            found = self._target_step(starts[0], lb, ub, target, direction, params)
            if found is not None:
                return (*found, [])
        args = (problem, self.solver)
        maxiter = None if rate else self.first_maxiter
        cands, nit, nfev = _solve_starts(
            *args, starts, lb, ub, target, params, self.pj, self.fobj, self.pos_tol, maxiter
        )
        if not rate and maybe_off_target(problem, cands, self.ratio, self.c):
            # no start is provably in target: as many again, from postures and stiffnesses
            # drawn over the whole ranges (not run where one start is in target)
            more = rescue_starts(problem, len(starts), starts[0], lb, ub, target, direction)
            extra, nit2, nfev2 = _solve_starts(
                *args, more, lb, ub, target, params, self.pj, self.fobj, self.pos_tol, maxiter
            )
            cands, nit, nfev = cands + extra, nit + nit2, nfev + nfev2
        best = _pick(problem, cands)
        if not rate and self.polish_above is not None and best[1] in R.USABLE and best[4] > self.polish_above:
            # the first waypoint's best answer above the criterion's least value: the target step
            # from each usable answer (SLSQP stops short of it at the kinks of |alpha| and
            # |r - rho|, or in a basin beside it), and an answer that reaches it joins
            polished = [self._target_step(c[0], lb, ub, target, direction, params) for c in cands if c[1] in R.USABLE]
            more_cands = [found[:5] for found in polished if found is not None]
            # counted where kept, as at a rate-limited waypoint (a step that is not kept is not)
            nit, nfev = nit + LM_STEPS * len(more_cands), nfev + (LM_STEPS + 1) * len(more_cands)
            if more_cands:
                cands = cands + more_cands
                best = _pick(problem, cands)
        x, status, err, code, f = best
        alts = [] if rate else _other_optima(problem, cands, best)
        return x, status, err, code, f, nit, nfev, alts

    def _target_step(
        self,
        x_start: np.ndarray,
        lb: np.ndarray,
        ub: np.ndarray,
        target: np.ndarray,
        direction: np.ndarray,
        params: np.ndarray,
    ) -> tuple[np.ndarray, int, float, int, float, int, int] | None:
        """The target step's answer from ``x_start`` as ``(x, status, pos_error, code 0, f, nit,
        nfev)`` where it is solved with the criterion at its least value (:data:`ACCEPT_REL`),
        else None (the solver runs)."""
        assert self.target_step is not None and self.accept_below is not None
        try:
            y = self.target_step(x_start, lb, ub, target, direction, self.ratio)
        except (ValueError, ArithmeticError, np.linalg.LinAlgError, FloatingPointError):
            return None
        if not np.all(np.isfinite(y)):
            return None
        sol = SolverOutput(y, 0, True, LM_STEPS, LM_STEPS + 1)
        x, status, err = judge(self.problem, sol, x_start, lb, ub, target, params, self.pj, self.fobj, self.pos_tol)
        if status != R.SOLVED:
            return None
        f = self.fobj(x, params)
        if not f <= self.accept_below:
            return None
        return x, status, err, 0, f, sol.nit, sol.nfev


def refuse_target_step(options: Mapping[str, Any] | None, who: str) -> None:
    """ValueError where ``options`` ask a solver without a target step for one (``target_step="lm"``)."""
    if (options or {}).get("target_step") == "lm":
        raise ValueError(
            f"option target_step='lm' is slsqp's: {who} has no target step (leave target_step 'auto', or 'none')"
        )


def _other_optima(problem: WaypointProblem, cands: Sequence[Candidate], best: Candidate) -> list[Candidate]:
    """The usable answers tied with ``best`` (criterion within :data:`TIE_RTOL`), each posture
    once (0.01 rad apart), ``best`` left out, in :func:`_pick`'s order of preference."""
    usable = [c for c in cands if c[1] in R.USABLE]
    if best[1] not in R.USABLE:
        return []
    fbest = best[4]
    ties = [c for c in usable if c[4] <= fbest + TIE_RTOL * max(abs(fbest), 1e-12)]
    out: list[Candidate] = []
    seen = [best[0][: problem.n_free]]
    while ties:
        c = _pick(problem, ties)
        ties = [t for t in ties if t is not c]
        q = c[0][: problem.n_free]
        if all(np.max(np.abs(q - s)) > 1e-2 for s in seen):
            out.append(c)
            seen.append(q)
    return out


# ---------------------------------------------------------------------- SOLVERS adapters
def check_single_start(starts: int | None, kind: str) -> None:
    """A per-waypoint SLSQP solver is single-start: ``starts`` must be None or 1."""
    if starts not in (None, 1):
        raise ValueError(f"solver {kind!r} is single-start (starts=1); got starts={starts}")


#: option ``path_retries`` None: this many for ``"slsqp"``; ``"slsqp-fd"``, the seed's method, none
PATH_RETRIES = 8


def run_greedy(
    req: SolveRequest, solver: WaypointSolver, extra: Mapping[str, Any], seed_scheme: bool = False
) -> dict[str, Any]:
    """Greedy SLSQP (``solver``, with :func:`greedy_path`'s keyword arguments ``extra``) over every
    path of ``req``, in the :data:`~jaxstiff.solvers._base.SOLVERS` dict format; raises
    :class:`~jaxstiff.solvers._base.SolverInterrupted` with the finished part on an interrupt.
    ``seed_scheme``: option ``path_retries`` None means 0 (seed 000's greedy scheme alone), else
    :data:`PATH_RETRIES`."""
    prob = req.problem
    retries = solver.options.get("path_retries")
    retries = (0 if seed_scheme else PATH_RETRIES) if retries is None else int(retries)

    per_path: list[list[WaypointOutcome]] = []
    B, P = req.targets.shape[:2]
    interrupted = False
    progress = req.progress
    for b in range(B):
        prog = None if progress is None else (lambda p, b=b: progress(b, p))
        try:
            per_path.append(
                greedy_path(
                    req,
                    b,
                    solver,
                    pos_tol=req.pos_tol,
                    progress=prog,
                    first_starts=req.first_starts[b],
                    first_maxiter=solver.options["first_maxiter"],
                    path_retries=retries,
                    **extra,
                )
            )
        except PathInterrupted as e:
            if e.done or any(per_path):
                hold_interrupts()  # finished waypoints: a second Ctrl-C before they are written must not lose them
            per_path.append(e.done)
            interrupted = True
            break
    # paths (or their ends) not reached before an interrupt: NOT_RUN at the reference state
    per_path += [[] for _ in range(B - len(per_path))]
    per_path = [not_run_outcomes(prob, d, P, req.q0[b], req.kj0[b]) for b, d in enumerate(per_path)]
    out: dict[str, Any] = outcomes_to_arrays(per_path, prob.n_free, req.q0, prob.free_idx, prob.kj_full)
    out["compile_s"] = float(getattr(solver, "compile_s", 0.0))
    out["driver"] = str(getattr(solver, "driver", "scipy.optimize.minimize"))
    out["code_meaning"] = CODE_MEANING + (TARGET_STEP_MEANING if extra.get("target_step") is not None else "")
    if interrupted:
        raise SolverInterrupted(out)
    return out
