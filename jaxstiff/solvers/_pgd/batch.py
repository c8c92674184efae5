"""pgd over many paths: options, one compiled kernel per problem and settings, chunks of paths
padded to the chunk size, and the :data:`~jaxstiff.solvers._base.SOLVERS` adapter."""

from __future__ import annotations

import dataclasses
import threading
import time
from collections.abc import Mapping, Sequence
from typing import Any

import jax
import numpy as np

from jaxstiff.results import _files as R
from jaxstiff.runtime._export_cache import arg_signature, compile_with_export_cache
from jaxstiff.runtime._programs import program_cache, register_cache
from jaxstiff.runtime._threads import auto_chunk, chunk_rows, chunk_threads, map_chunks
from jaxstiff.runtime._xla import kernel_compiler_options
from jaxstiff.settings._solvers import PGDOptions
from jaxstiff.solvers._base import SolveRequest
from jaxstiff.solvers._pgd.kernel import PGDKernel
from jaxstiff.solvers._pgd.keys import chunk_keys, seed_key
from jaxstiff.solvers._problem import POS_TOL, WaypointBatch, WaypointProblem, content_seed
from jaxstiff.solvers._problem.ops import lm_kind

__all__ = [
    "DEFAULT_OPTIONS",
    "check_options",
    "compiled_kernel",
    "pad_rows",
    "waypoint_capacity",
    "solve_batch",
    "CODE_MEANING",
    "run_request",
    "first_start_rows",
    "exact_first_starts",
    "iteration_counts",
]

#: Settings (``shape(..., solver="pgd", starts=S, options=...)``), from
#: :class:`~jaxstiff.settings._solvers.PGDOptions` (what each one does is documented there).
DEFAULT_OPTIONS: dict[str, Any] = PGDOptions.defaults()

#: options of the other shipped solvers that may share an options dict with pgd's
_SHARED = frozenset(
    {
        "maxiter",
        "ftol",
        "kj_scale",
        "f_scale",
        "polish_slsqp",
        "traj_iters",
        "traj_step0",
        "traj_step1",
        "traj_lm_rounds",
        "traj_lm_iters",
        "traj_lm_rho0",
        "warm",
        "blocks",
        "mu0",
        "chain",
        "polish_skip_tol",
    }
)


def check_options(options: Mapping[str, Any] | None, starts: int | None = None) -> dict[str, Any]:
    """:data:`DEFAULT_OPTIONS` updated by ``options`` (and ``starts``), values checked (ValueError)."""
    opts = {**DEFAULT_OPTIONS, **(options or {})}
    if starts is not None:
        opts["starts"] = int(starts)
    unknown = set(opts) - set(DEFAULT_OPTIONS) - _SHARED
    if unknown:
        raise ValueError(f"unknown pgd option(s) {sorted(unknown)}; known: {sorted(DEFAULT_OPTIONS)}")
    return PGDOptions.check_values(opts)


@program_cache(maxsize=32)
def compiled_kernel(problem: WaypointProblem, opts_items: tuple[tuple[str, Any], ...], first_rate: bool) -> Any:
    """:meth:`PGDKernel.traj_batch <jaxstiff.solvers._pgd.kernel.PGDKernel.traj_batch>` (the
    kernel over a batch of paths) jitted, cached per problem, settings (sorted ``(name, value)``
    pairs) and first-waypoint rate limit."""
    opts = dict(opts_items)
    # per path: targets, directions, start state, key, rate limits (dq_f, dk) and ratio; shared:
    # kmin, kmax, c, pos_tol and the number of waypoints solved (the rest of the P rows is capacity)
    batched = PGDKernel(problem, opts, first_rate).traj_batch
    return jax.jit(batched, compiler_options=kernel_compiler_options())


def waypoint_capacity(P: int) -> int:
    """The P a compiled pgd program is built for: the next power of two from 8 up (P <= it). Paths of
    any length up to it run in the same program (the waypoint loop's bound is traced; the rows after
    the path's own are never computed), so a second run on a path of another length loads the
    program from the cache instead of compiling it again."""
    return max(8, 1 << max(int(P) - 1, 0).bit_length())


def pad_rows(a: np.ndarray, C: int) -> np.ndarray:
    """``a`` (m, ...) padded to C rows by repeating its last row (m <= C)."""
    if a.shape[0] == C:
        return a
    reps = np.repeat(a[-1:], C - a.shape[0], axis=0)
    return np.concatenate([a, reps], axis=0)


def solve_batch(
    batch: WaypointBatch,
    *,
    starts: int | None = None,
    options: Mapping[str, Any] | None = None,
    pos_tol: float = POS_TOL,
    return_timing: bool = False,
    first_starts: Sequence[Sequence[tuple[np.ndarray, np.ndarray]]] | None = None,
) -> dict[str, Any]:
    """Shape B paths with multi-start projected gradient (the solver behind ``solver="pgd"``).

    Args:
        batch: the paths: problem (robot, task, criterion), targets and directions (B, P, 3) (m, unit
            vectors, base frame), start states q0, kj0 (B, n) (rad; Nm/rad), limits (S0-11 ... S0-14;
            ``dq``/``dk`` (n,) or (B, n), one row per path), the wanted axis ratio r (a number or (B,):
            a parameter sweep in one call) and f1's offset c.
        starts: S (default ``options["starts"]``).
        options: see :data:`DEFAULT_OPTIONS`.
        pos_tol: m, position error of a usable waypoint.
        return_timing: also return ``compile_s`` and ``run_s`` (first chunk's compile apart).
        first_starts: per path, a list of start states ``(q (n,), kj (n,))`` for the first waypoint
            (e.g. :func:`jaxstiff.shaping.first_start_postures`, greedy SLSQP's IK postures); they
            replace random first-waypoint starts 1..E (at most ``starts_first - 1`` of them).

    Returns:
        dict with ``q``, ``kj`` (B,P,n), ``status``, ``pos_error``, ``solver_code``, ``nit``,
        ``nfev``, ``time_s``, ``criterion`` (B,P) in the :data:`jaxstiff.solvers._base.SOLVERS` format.
    """
    opts = check_options(options, starts)
    problem, limits, q0 = batch.problem, batch.limits, np.asarray(batch.q0, float)
    targets = np.asarray(batch.targets, float)
    directions = np.asarray(batch.directions, float)
    B, P = targets.shape[:2]
    nf = problem.n_free
    r_arr = batch.ratios
    x0 = np.asarray(problem.x_of(q0, np.asarray(batch.kj0, float)))
    # chunks of at least 2 rows (XLA compiles a batch of 1 differently: a lone path would differ
    # from the same path in a batch in the last bits; batches of 2 or more rows give every row
    # bit-identical results, measured on CPU), at least one per thread (runtime.threads)
    threads = chunk_threads(int(opts["threads"]))
    C = chunk_rows(B, auto_chunk(int(opts["chunk"])), threads)
    key_items = tuple(
        sorted(
            (k, v)
            for k, v in opts.items()
            if k in DEFAULT_OPTIONS and k not in ("chunk", "seed", "threads", "first_exact")
        )
    )
    first_rate = bool(limits.first_rate_limit)
    fn = compiled_kernel(problem, key_items, first_rate)
    fp = problem.fingerprint()
    disk_key = None if fp is None else f"pgd|{fp}|{key_items!r}|{first_rate}"

    dq_all, dk = limits.rows(B)  # (B, n) each: per-path rate limits
    dq_f = dq_all[:, list(problem.free_idx)]
    dk = problem.spring_cols(dk)  # (B, nk): the sprung joints' (rigid locked joints have no stiffness)
    S1 = max(int(opts["starts"]), int(opts["starts_first"])) if opts["mode"] == "best" else int(opts["starts"])
    if not first_rate and opts["first_exact"] == "slsqp":
        first_starts = exact_first_starts(batch, first_starts, options, pos_tol, S1)
    extra = first_start_rows(problem, first_starts, B)
    # each path's key from the seed and the path's own data, never from its index: a path's result
    # does not depend on its position in the batch or on the chunk size
    path_data = np.array([content_seed(targets[b], directions[b], x0[b]) for b in range(B)], dtype=np.uint32)
    per_path = (targets, directions, x0, path_data, dq_f, dk, r_arr, extra)
    shared = (float(limits.kmin), float(limits.kmax), float(batch.c), float(pos_tol))
    # option first_exact="retry" (the default): the criterion's in-target bound, None where the
    # retry cannot run (a rate-limited first waypoint, or a criterion without such a bound)
    retry_bound = None
    if not first_rate and opts["first_exact"] == "retry":
        from jaxstiff.solvers._greedy import target_bound

        retry_bound = target_bound(problem, batch.ratios, float(batch.c))
    if retry_bound is not None:
        from jaxstiff.solvers._first_waypoint import prepare_first_answers

        prepare_first_answers(batch, options)  # compiles beside pgd's kernel tracing, if that runs
    X, out, compile_s, run_s = _run_chunks(fn, per_path, shared, seed_key(int(opts["seed"])), (C, threads), disk_key)
    if retry_bound is not None:
        X, run_s = _retry_first(
            batch,
            retry_bound,
            first_starts,
            options,
            pos_tol,
            S1,
            (X, out, run_s),
            per_path,
            shared,
            opts,
            fn,
            (C, threads),
            disk_key,
        )
    q = np.repeat(q0[:, None, :], P, axis=1)
    q[..., list(problem.free_idx)] = X[..., :nf]
    out["q"], out["kj"] = q, np.array(problem.kj_full(X[..., nf:]), copy=True)
    out["nit"], out["nfev"] = iteration_counts(problem, opts, B, P)
    if return_timing:
        out["compile_s"], out["run_s"] = compile_s, run_s
    return out


#: the chunk programs compiled in this process: (id of the kernel, its disk key, the arguments'
#: signature) -> (kernel, compiled program); a second run of the same shapes (the retry's rerun,
#: the next call) reuses the program instead of loading it from the caches again (about 0.5 s each)
class _Programs(dict):
    def cache_clear(self) -> None:  # runtime.programs.release_compiled
        self.clear()


_PROGRAMS: dict[tuple, tuple[Any, Any]] = register_cache(_Programs())
_PROGRAMS_MAX = 8
_PROGRAMS_LOCK = threading.Lock()


def _program_for(fn: Any, args: Sequence[Any], disk_key: str | None, options: Mapping[str, Any]) -> Any:
    """``fn`` compiled for ``args`` (:func:`~jaxstiff.runtime._export_cache.compile_with_export_cache`),
    kept for the process (:data:`_PROGRAMS`, the last few): the same compiled program, so the same
    results, as compiling again."""
    sig = (id(fn), disk_key, arg_signature(args), repr(sorted(options.items())))
    hit = _PROGRAMS.get(sig)
    if hit is not None and hit[0] is fn:
        return hit[1]
    comp = compile_with_export_cache(fn, args, disk_key, dict(options))
    with _PROGRAMS_LOCK:  # threads of one process solving at once must not trim the same entry
        _PROGRAMS[sig] = (fn, comp)  # fn held: its id stays its own while the entry lives
        while len(_PROGRAMS) > _PROGRAMS_MAX:
            _PROGRAMS.pop(next(iter(_PROGRAMS)))
    return comp


def _ranking(
    problem: WaypointProblem, batch: WaypointBatch, rows: np.ndarray, X: np.ndarray, status: np.ndarray, f: np.ndarray
) -> list[tuple[int, int, float]]:
    """Per path of ``rows`` (with ``X`` (k, P, nx), ``status``, ``f`` (k, P) their results), ``(waypoints
    not solved, solved waypoints not in target, sum of the criterion over the solved ones)``: lower
    is better, compared in that order. In target: alpha and rho of the report at ``X``
    (:func:`jaxstiff.results._target.target_masks`, the rule of the result's ``in_target``)."""
    from jaxstiff.results._target import target_masks
    from jaxstiff.solvers._problem import report_rows
    from jaxstiff.stiffness._criteria import f1 as _f1

    k, P = status.shape
    r = batch.ratios[rows]
    params = np.concatenate(
        [
            np.asarray(batch.targets, float)[rows].reshape(k * P, 3),
            np.asarray(batch.directions, float)[rows].reshape(k * P, 3),
            np.repeat(r, P)[:, None],
            np.full((k * P, 1), float(batch.c)),
        ],
        axis=1,
    )
    with jax.enable_x64(True):
        rep = report_rows(problem, X.reshape(k * P, -1), params)
    mm = problem.m * problem.m
    alpha, rho = rep[:, 3 + mm].reshape(k, P), rep[:, 4 + mm].reshape(k, P)
    a_ok, r_ok = target_masks(alpha, rho, r[:, None], "f1" if problem.criterion is _f1 else "f2")
    solved = status == R.SOLVED
    hit = solved & a_ok & r_ok
    tot = np.sum(np.where(solved, f, 0.0), axis=1)
    tot = np.where(np.isfinite(tot), tot, np.inf)
    return [(int(a), int(b), float(t)) for a, b, t in zip(np.sum(~solved, 1), np.sum(~hit, 1), tot, strict=True)]


def _retry_first(  # noqa: PLR0913 - solve_batch's state handed to its retry step
    batch: WaypointBatch,
    bound: np.ndarray,
    first_starts: Sequence[Sequence[tuple[np.ndarray, np.ndarray]]] | None,
    options: Mapping[str, Any] | None,
    pos_tol: float,
    S1: int,
    done: tuple[np.ndarray, dict[str, Any], float],
    per_path: tuple[np.ndarray, ...],
    shared: tuple[float, float, float, float],
    opts: Mapping[str, Any],
    fn: Any,
    chunking: tuple[int, int],
    disk_key: str | None,
) -> tuple[np.ndarray, float]:
    """Option ``first_exact="retry"`` (the default): the paths whose first waypoint (no rate
    limit) pgd left out of target are solved again, their first-waypoint starts replaced by greedy
    SLSQP's answers there (:func:`exact_first_starts`); a path keeps the rerun where it has fewer
    unsolved waypoints, or as many and fewer out of target, or as many of both and a lower sum of
    the criterion (the rollout's own ranking with the in-target count put before the sum: the
    first waypoint is what the rerun is for, and a lower sum bought with it off target is not
    what a user asks for). Paths already in target are untouched, so the cost is paid only
    where pgd's own stages stalled (measured: most first waypoints of third-party arms such as the
    UR10, few of the LWR's). ``bound``: the criterion's in-target bound per path
    (:func:`jaxstiff.solvers._greedy.target_bound`). ``out`` is updated in place; returns the new
    ``X`` and run time."""
    X, out, run_s = done
    problem = batch.problem
    status, f = np.asarray(out["status"]), np.asarray(out["criterion"])
    redo = np.flatnonzero(~(np.isin(status[:, 0], list(R.USABLE)) & (f[:, 0] < bound)))
    if redo.size == 0:
        return X, run_s
    t0 = time.perf_counter()
    sub = dataclasses.replace(
        batch,
        targets=np.asarray(batch.targets, float)[redo],
        directions=np.asarray(batch.directions, float)[redo],
        q0=np.asarray(batch.q0, float)[redo],
        kj0=np.asarray(batch.kj0, float)[redo],
        limits=dataclasses.replace(
            batch.limits,
            dq=np.asarray(batch.limits.dq)[redo] if np.ndim(batch.limits.dq) == 2 else batch.limits.dq,
            dk=np.asarray(batch.limits.dk)[redo] if np.ndim(batch.limits.dk) == 2 else batch.limits.dk,
        ),
        ratio=batch.ratios[redo],
    )
    given = [first_starts[int(b)] for b in redo] if first_starts else None
    found: list[float] = []
    starts = exact_first_starts(sub, given, options, pos_tol, S1, found)
    # rerun only where SLSQP found a lower criterion at the first waypoint than pgd kept there
    # (where it did not, the rerun's first waypoint could not be better, and a target out of
    # every solver's reach cost a whole second run of the path for nothing)
    f_pgd = np.where(np.isin(status[redo, 0], list(R.USABLE)), f[redo, 0], np.inf)
    f_sl = np.asarray(found, float)
    worth = f_sl < f_pgd - 1e-9 * np.maximum(1.0, np.abs(np.where(np.isfinite(f_pgd), f_pgd, 1.0)))
    if not worth.any():
        dt = time.perf_counter() - t0
        out["time_s"] = np.asarray(out["time_s"], float) + dt / max(out["time_s"].size, 1)
        return X, run_s + dt
    redo = redo[worth]
    starts = [st for st, w in zip(starts, worth, strict=True) if w]
    extra = first_start_rows(problem, starts, len(redo))
    if extra.shape[1] != per_path[7].shape[1]:  # another count of extra starts: another program
        return X, run_s
    rows = tuple(a[redo] for a in per_path[:7]) + (extra,)
    X2, out2, _, _ = _run_chunks(fn, rows, shared, seed_key(int(opts["seed"])), chunking, disk_key)
    new_rank = _ranking(problem, batch, redo, X2, np.asarray(out2["status"]), np.asarray(out2["criterion"]))
    old_rank = _ranking(problem, batch, redo, X[redo], status[redo], f[redo])
    better = np.array([a < b for a, b in zip(new_rank, old_rank, strict=True)], bool)
    keep = redo[better]
    X = X.copy()
    X[keep] = X2[better]
    for k in ("status", "solver_code", "pos_error", "criterion"):
        if k in out and k in out2:
            out[k] = np.array(out[k], copy=True)
            out[k][keep] = out2[k][better]
    dt = time.perf_counter() - t0
    out["time_s"] = np.asarray(out["time_s"], float) + dt / max(out["time_s"].size, 1)
    return X, run_s + dt


def exact_first_starts(
    batch: WaypointBatch,
    first_starts: Sequence[Sequence[tuple[np.ndarray, np.ndarray]]] | None,
    options: Mapping[str, Any] | None,
    pos_tol: float,
    S: int,
    criteria: list[float] | None = None,
) -> list[list[tuple[np.ndarray, np.ndarray]]]:
    """Per path, the first waypoint's start states for pgd's starts 1..S-1: greedy SLSQP's usable
    answers there, best first (:func:`jaxstiff.solvers._first_waypoint.exact_first_answers`, from
    ``(q0, kj0)``, ``first_starts`` and its rescue starts), then the given ``first_starts``
    themselves, at most S - 1 in all (option ``first_exact``). ``criteria``: as
    :func:`~jaxstiff.solvers._first_waypoint.exact_first_answers`'s."""
    from jaxstiff.solvers._first_waypoint import exact_first_answers

    problem = batch.problem
    answers = exact_first_answers(batch, first_starts, options, pos_tol, criteria)
    out = []
    for b, xs in enumerate(answers):
        q0 = np.asarray(batch.q0[b], float)
        states = []
        for x in xs:
            q = q0.copy()
            q[list(problem.free_idx)] = x[: problem.n_free]
            states.append((q, np.asarray(problem.kj_full(x[problem.n_free :]), float)))
        given = list(first_starts[b]) if first_starts else []
        out.append((states + given)[: max(S - 1, 0)])
    # every path the same count (the kernel's rows): a path with fewer repeats its start state
    E = max((len(o) for o in out), default=0)
    for b, o in enumerate(out):
        o += [(np.asarray(batch.q0[b], float), np.asarray(batch.kj0[b], float))] * (E - len(o))
    return out


def first_start_rows(
    problem: WaypointProblem, first_starts: Sequence[Sequence[tuple[np.ndarray, np.ndarray]]] | None, B: int
) -> np.ndarray:
    """(B, E, nx) the first waypoint's given start states as decision vectors, E the fewest any
    path has (0 without ``first_starts``)."""
    if not first_starts:
        return np.zeros((B, 0, problem.nx))
    E = min(len(fs) for fs in first_starts)
    extra = np.zeros((B, E, problem.nx))
    for b in range(B if E else 0):
        extra[b] = [problem.x_of(np.asarray(qs, float), np.asarray(ks, float)) for qs, ks in first_starts[b][:E]]
    return extra


def _run_chunks(
    fn: Any,
    per_path: tuple[np.ndarray, ...],
    shared: tuple[float, float, float, float],
    base: jax.Array | np.ndarray,
    chunking: tuple[int, int],
    disk_key: str | None = None,
) -> tuple[np.ndarray, dict[str, Any], float, float]:
    """The compiled kernel ``fn`` over the paths in chunks of C rows (the last one padded), up to
    ``threads`` chunks at once (``chunking = (C, threads)``; :mod:`jaxstiff.runtime._threads`).

    ``disk_key``: the kernel's key for the traced-program cache
    (:func:`~jaxstiff.runtime._export_cache.compile_with_export_cache`; None: trace every time).

    ``per_path``: ``(targets, directions, x0, path_data, dq_f, dk, ratio, extra)``, B rows each;
    ``shared``: ``(kmin, kmax, c, pos_tol)``; ``base``: the seed's key, folded with each path's
    data. Returns ``X`` (B, P, nx), the (B, P) outputs ``status``, ``solver_code``, ``pos_error``,
    ``criterion``, ``time_s`` (the run's wall time over all waypoints: chunks run concurrently),
    and the compile time and the run time (s).
    """
    targets, directions, x0, path_data, dq_f, dk, r_arr, extra = per_path
    kmin, kmax, c, pos_tol = shared
    C, threads = chunking
    B, P = targets.shape[:2]
    # the waypoint axis padded to the program's capacity (its last waypoint repeated; never solved)
    cap = waypoint_capacity(P)
    targets, directions = (
        np.concatenate([a, np.repeat(a[:, -1:], cap - P, axis=1)], axis=1) for a in (targets, directions)
    )
    sharded = jax.local_device_count() > 1
    with jax.enable_x64(True):
        chunks = []
        for s in range(0, B, C):
            sl = slice(s, min(s + C, B))
            keys = chunk_keys(base, pad_rows(path_data[sl], C), P, cap)
            args = (
                pad_rows(targets[sl], C),
                pad_rows(directions[sl], C),
                pad_rows(x0[sl], C),
                keys,
                pad_rows(dq_f[sl], C),
                pad_rows(dk[sl], C),
                kmin,
                kmax,
                pad_rows(r_arr[sl], C),
                c,
                pos_tol,
                pad_rows(extra[sl], C),
                np.int32(P),
            )
            if sharded:  # split the batch across all local devices (jaxstiff.runtime._sharding)
                from jaxstiff.runtime._sharding import shard_rows

                placed, _ = shard_rows({str(i): args[i] for i in (0, 1, 2, 3, 4, 5, 8, 11)})
                args = tuple(placed.get(str(i), a) for i, a in enumerate(args))
            chunks.append(args)
        t0 = time.perf_counter()
        # every chunk has the same shapes (padded): one compiled program for all of them
        comp = _program_for(fn, chunks[0], None if sharded else disk_key, kernel_compiler_options())
        compile_s = time.perf_counter() - t0
        t0 = time.perf_counter()
        results = map_chunks(lambda a: jax.tree_util.tree_map(np.asarray, comp(*a)), chunks, 1 if sharded else threads)
        run_s = time.perf_counter() - t0
    cat = {k: np.concatenate([r[k] for r in results], axis=0)[:B, :P] for k in ("x", "status", "start", "err", "f")}
    out: dict[str, Any] = {
        "status": cat["status"].astype(np.int64),
        "solver_code": cat["start"].astype(np.int64),
        "pos_error": cat["err"].astype(float),
        "criterion": cat["f"].astype(float),
        "time_s": np.full((B, P), run_s / (B * P)),
    }
    return cat["x"].astype(float), out, compile_s, run_s


def iteration_counts(
    problem: WaypointProblem, opts: Mapping[str, Any], B: int, P: int
) -> tuple[np.ndarray, np.ndarray]:
    """``(nit, nfev)`` (B, P): the fixed iteration counts per start (gradient/LM steps) and the
    gradient evaluations over all starts, the first waypoint apart."""
    S = int(opts["starts"])
    S1 = max(S, int(opts["starts_first"])) if opts["mode"] == "best" else S
    lm = lm_kind(problem) is not None
    it = int(opts["iters_lm"]) + int(opts["lm_iters"]) if lm else int(opts["iters"])
    it1 = int(opts["iters_first"]) + (int(opts["lm_iters_first"]) if lm else 0)
    nit = np.full((B, P), it, np.int64)
    nit[:, 0] = it1
    nfev = np.full((B, P), S * (it + 1), np.int64)
    nfev[:, 0] = S1 * (it1 + 1)
    return nit, nfev


#: meaning of the result file's ``solver_code`` for this solver (meta ``solver_code_meaning``)
CODE_MEANING = "index of the start that won (-1 = none); no convergence flag (fixed iterations)"


def run_request(req: SolveRequest) -> dict[str, Any]:
    """Adapter for :data:`jaxstiff.solvers._base.SOLVERS` (``solver="pgd"``)."""
    res = solve_batch(
        req,
        starts=req.starts,
        options=req.options,
        pos_tol=req.pos_tol,
        first_starts=req.first_starts,
    )
    res.pop("criterion", None)
    res["code_meaning"] = CODE_MEANING
    res["time_s_run_only"] = True  # time_s: the compiled program's run over all waypoints, nothing else
    return res
