"""``shape()``: stiffness-ellipsoid shaping along TCP paths (seed 000, SPEC section 5).

For every waypoint of every path, joint positions q and joint stiffnesses kj are chosen so that the
stiffness ellipsoid's major axis follows the desired direction with the wanted axis ratio
(criterion f1 or f2), the TCP stays exactly on the path, and q and kj change no faster than the
rate limits allow (S0-10 ... S0-14). Afterwards the common-mode stiffness factor (CMS, S0 section
III) scales each waypoint's kj so that its ellipsoid reaches a target size.

Defaults the seed does not give (each one is also written into ``result.meta``):

* ``dq`` = 2 deg (0.0349 rad) per waypoint on every joint, ``dk`` = 5 Nm/rad per waypoint (5% of
  the seed's 1-100 Nm/rad range): on the 60-waypoint default path (about 1 cm between waypoints)
  that lets the ellipsoid turn with the tangent while keeping joint motion smooth.
* ``kmin`` = 1, ``kmax`` = 100 Nm/rad (seed); ``kj0`` = mid-range ``(kmin + kmax) / 2`` on every
  joint; ``c`` = 0.01 (seed, f1).
* ``q0``: damped-least-squares IK (:mod:`jaxstiff.ik`) from the nominal posture (every free joint
  30 deg past the middle of its range) to the first waypoint.
* ``first_rate_limit = False``: the rate limits do not apply between ``(q0, kj0)`` and the first
  waypoint, which is shaped within the full joint and stiffness ranges (the start state is only an
  initial guess: offline planning may move the arm into the shaped posture before the motion
  starts). Pass ``True`` when ``(q0, kj0)`` is the arm's actual state.
* ``first_starts = 8``: that first, unconstrained waypoint is non-convex (from a single start SLSQP
  finds an aligned ellipsoid about half the time on the default path), so it is solved from q0
  and 7 more IK postures (nominal posture perturbed by up to +-60 deg, from a fixed seed and the
  path's own data, so a path's postures do not depend on the rest of its batch) and the best
  usable answer is kept. Later waypoints are single-start from the previous one, as in the seed.
* CMS target: a geometric-mean axis of 1000 N/m, i.e. ``target_volume = 1000**m`` (N/m)^m (m = 3,
  or 2 for task "xy"), so the scaled ellipsoids are comparable along the path (seed Fig. 4e, 5e).
* task ``"full"``: K_T is the top-left 3x3 block of the 6x6 Cartesian stiffness (S0-6, S0-7).
* solver ``"slsqp"``: SLSQP per waypoint with JAX derivatives, ``maxiter`` 200 (1000 for the first,
  not rate-limited waypoint), ``ftol`` 1e-8, stiffness scaled by 1/100 and the criterion by 0.1
  inside SLSQP (:data:`jaxstiff.solvers.slsqp.DEFAULT_OPTIONS`).

Solvers are registered in :data:`SOLVERS` (name -> function); add one with :func:`register_solver`.

Example:
    >>> import jaxstiff
    >>> robot = jaxstiff.Robot.from_urdf("kuka_lwr4", locked={"lwr_a7": 0.0})
    >>> res = jaxstiff.shape(robot, jaxstiff.default_path(n=10), "f2", 5.0)   # doctest: +SKIP
    >>> res.status.shape                                                       # doctest: +SKIP
    (1, 10)
"""

from __future__ import annotations

import datetime
import math
import os
import time
import warnings
from typing import Any, Callable, Mapping

import jax
import numpy as np

from jaxstiff.results import files as R
from jaxstiff.stiffness.criteria import CRITERIA, get_criterion
from jaxstiff.ik import ik_position, nominal_posture, NOMINAL_OFFSET_DEG
from jaxstiff.paths import DEFAULT_PATH_SPEC, Path
from jaxstiff.runtime.io import deferred_interrupts
from jaxstiff.model.robot import Robot
from jaxstiff.settings.robot import robot_meta, versions
from jaxstiff.solvers.problem import POS_TOL, Limits, WaypointProblem, compiled_report, content_seed
from jaxstiff.stiffness.core import check_task_feasible, task_rows

__all__ = ["shape", "SOLVERS", "register_solver", "DEFAULTS", "SolveRequest", "ShapeInterrupted", "SolverInterrupted",
           "prefer_sync_cpu_dispatch", "first_start_rng"]

#: Defaults of the parameters the seed does not fix (see the module docstring).
DEFAULTS: dict[str, Any] = {
    "dq_deg": 2.0,
    "dk": 5.0,
    "kmin": 1.0,
    "kmax": 100.0,
    "c": 0.01,
    "first_rate_limit": False,
    "first_starts": 8,
    "cms_mean_axis": 1000.0,
    "q0": "ik_from_nominal",
    "kj0": "mid_range",
}


FIRST_STARTS_SEED = 0  #: seed of the extra first-waypoint start postures, mixed with each path's own data (:func:`first_start_rng`)
FIRST_STARTS_SPREAD_DEG = 60.0  #: perturbation of the nominal posture for the extra starts, +- deg

def prefer_sync_cpu_dispatch() -> bool:
    """Run JAX CPU computations inline (no async dispatch), if JAX has not started its backend yet.

    SLSQP calls one tiny kernel per point it asks about (about 80 per waypoint); with JAX's default
    asynchronous CPU dispatch each call pays a thread hand-off that costs more than the kernel
    itself (measured: ~45 us inline vs ~150-600 us async per call on a busy 2-core machine). The
    setting (``jax_cpu_enable_async_dispatch``) is process-wide and read once when the CPU backend
    starts, so only entry points call this (the ``jaxstiff shape`` command, the shaping
    benchmark and experiments); the library never changes it on its own. From your own script:
    ``jax.config.update("jax_cpu_enable_async_dispatch", False)`` before the first computation.

    Returns:
        True if CPU dispatch is (now) synchronous.
    """
    try:
        from jax._src import xla_bridge

        started = xla_bridge.backends_are_initialized()
    except (ImportError, AttributeError):  # pragma: no cover - private API moved
        started = True
    if not started:
        jax.config.update("jax_cpu_enable_async_dispatch", False)
    return not _cpu_async_dispatch()


def _cpu_async_dispatch() -> bool:
    """The value of ``jax_cpu_enable_async_dispatch`` (True if unknown)."""
    return bool(jax.config.values.get("jax_cpu_enable_async_dispatch", True))


# ---------------------------------------------------------------------- solver registry
class SolveRequest:
    """Everything a registered solver gets: the problem, the paths, the start states, the limits.

    Attributes:
        problem: :class:`~jaxstiff.solvers.problem.WaypointProblem`.
        targets, directions: (B, P, 3).
        q0, kj0: (B, n) start states.
        limits: :class:`~jaxstiff.solvers.problem.Limits`; ``dq``/``dk`` are (n,) (the same for
            every path) or (B, n) (per path): take path b's with ``limits.for_path(b)``.
        ratio: the wanted axis ratio, a float (every path) or a (B,) array (per path);
            :attr:`ratios` is always (B,).
        c: f1's offset (a float, every path).
        starts: number of starts (multi-start solvers).
        options: solver options (dict).
        pos_tol: m, position tolerance of a usable waypoint.
        progress: ``progress(b, p)`` after each waypoint, or None.
    """

    def __init__(self, **kw):
        self.__dict__.update(kw)

    @property
    def ratios(self) -> np.ndarray:
        """(B,) the wanted axis ratio of every path."""
        return np.broadcast_to(np.asarray(self.ratio, float), (self.targets.shape[0],)).copy()


#: A solver maps a :class:`SolveRequest` to a dict of arrays: ``q``, ``kj`` (B,P,n), ``status``,
#: ``pos_error``, ``solver_code``, ``nit``, ``nfev``, ``time_s`` (B,P), and optionally ``compile_s``
#: (float, compilation time kept out of ``time_s``). Every point with a usable
#: status (0-2) must satisfy the box of its reference state exactly and the position within
#: ``pos_tol``; the reported quantities are recomputed by :func:`shape`.
SOLVERS: dict[str, Callable[[SolveRequest], dict[str, np.ndarray]]] = {}


class SolverInterrupted(KeyboardInterrupt):
    """Raised by a solver interrupted (Ctrl-C, or SIGTERM under the command line) after some
    waypoints were finished: ``arrays`` is its full result dict, the waypoints not reached with
    status NOT_RUN (5) at their reference state. Solvers that cannot keep partial work let the
    plain ``KeyboardInterrupt`` through."""

    def __init__(self, arrays: dict):
        super().__init__()
        self.arrays = arrays


class ShapeInterrupted(KeyboardInterrupt):
    """:func:`shape` was interrupted after some waypoints were finished: ``result`` is a complete
    :class:`~jaxstiff.ShapeResult` whose unfinished waypoints have status NOT_RUN (5) and whose
    meta has ``interrupted: true``. A subclass of ``KeyboardInterrupt``, so an interrupt still
    stops the caller; catch it to keep the finished part (the command line saves it)."""

    def __init__(self, result):
        super().__init__()
        self.result = result


def register_solver(name: str, fn: Callable[[SolveRequest], dict[str, np.ndarray]]) -> None:
    """Make a solver available as ``shape(..., solver=name)`` and ``jaxstiff shape --solver name``."""
    if not callable(fn):
        raise ValueError(f"solver {name!r} must be callable")
    SOLVERS[name] = fn


def _outcomes_to_arrays(per_path, n_free: int, q0: np.ndarray, free_idx) -> dict[str, np.ndarray]:
    B, P = len(per_path), len(per_path[0])
    n = q0.shape[-1]
    q = np.repeat(q0[:, None, :], P, axis=1).astype(float)
    kj = np.zeros((B, P, n))
    out = {k: np.zeros((B, P), dtype=dt) for k, dt in
           (("status", np.int64), ("solver_code", np.int64), ("nit", np.int64), ("nfev", np.int64),
            ("pos_error", float), ("time_s", float))}
    fi = list(free_idx)
    for b, outs in enumerate(per_path):
        for p, o in enumerate(outs):
            q[b, p, fi] = o.x[:n_free]
            kj[b, p] = o.x[n_free:]
            out["status"][b, p] = o.status
            out["solver_code"][b, p] = o.code
            out["nit"][b, p] = o.nit
            out["nfev"][b, p] = o.nfev
            out["pos_error"][b, p] = o.pos_error
            out["time_s"][b, p] = o.time_s
    out["q"], out["kj"] = q, kj
    return out


def _greedy_solver(kind: str):
    def run(req: SolveRequest) -> dict[str, np.ndarray]:
        if req.starts not in (None, 1):
            raise ValueError(f"solver {kind!r} is single-start (starts=1); got starts={req.starts}")
        prob = req.problem
        if kind == "slsqp":
            from jaxstiff.solvers.slsqp import greedy_path, make_slsqp_solver

            solver = make_slsqp_solver(prob, req.options)
            extra = {}
        else:
            from jaxstiff.solvers.slsqp_fd import make_fd_solver, numpy_objective, numpy_pos_and_jac
            from jaxstiff.solvers.slsqp import greedy_path

            solver = make_fd_solver(prob, req.options)
            extra = {"pos_and_jac": numpy_pos_and_jac(prob), "objective": numpy_objective(prob)}
        from jaxstiff.solvers.slsqp import CODE_MEANING, PathInterrupted, not_run_outcomes

        per_path = []
        ratios = req.ratios
        B, P = req.targets.shape[:2]
        interrupted = False
        for b in range(B):
            prog = None if req.progress is None else (lambda p, b=b: req.progress(b, p))
            try:
                per_path.append(
                    greedy_path(prob, req.targets[b], req.directions[b], req.q0[b], req.kj0[b], req.limits.for_path(b),
                                float(ratios[b]), req.c, solver, pos_tol=req.pos_tol, progress=prog,
                                first_starts=req.first_starts[b], first_maxiter=solver.options["first_maxiter"], **extra)
                )
            except PathInterrupted as e:
                per_path.append(e.done)
                interrupted = True
                break
        # paths (or their ends) not reached before an interrupt: NOT_RUN at the reference state
        per_path += [[] for _ in range(B - len(per_path))]
        per_path = [not_run_outcomes(prob, d, P, req.q0[b], req.kj0[b]) for b, d in enumerate(per_path)]
        out = _outcomes_to_arrays(per_path, prob.n_free, req.q0, prob.free_idx)
        out["compile_s"] = float(getattr(solver, "compile_s", 0.0))
        out["driver"] = str(getattr(solver, "driver", "scipy.optimize.minimize"))
        out["code_meaning"] = CODE_MEANING
        if interrupted:
            raise SolverInterrupted(out)
        return out

    return run


register_solver("slsqp", _greedy_solver("slsqp"))
register_solver("slsqp-fd", _greedy_solver("slsqp-fd"))


def _lazy_solver(module: str):
    """Batch-engine solvers (issue 5), imported on first use."""

    def run(req: SolveRequest) -> dict[str, np.ndarray]:
        import importlib

        return importlib.import_module(f".solvers.{module}", __package__).run_request(req)

    return run


register_solver("pgd", _lazy_solver("pgd"))  # multi-start projected gradient, batched (solvers/pgd.py)
register_solver("hybrid", _lazy_solver("hybrid"))  # pgd + SLSQP polish (solvers/hybrid.py)
register_solver("trajectory", _lazy_solver("trajectory"))  # whole-trajectory optimisation (solvers/trajectory.py)


# ---------------------------------------------------------------------- input checks
def _per_joint(value, n: int, what: str, unit: str, B: int = 1) -> np.ndarray:
    """A rate limit: a number or (n,) -> (n,), the same for every path; (B, n) -> one row per path
    ((n,) again if all rows are equal). Errors name the path (row) and joint of a bad value."""
    try:
        a = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"{what} must be a number, {n} numbers or ({B}, {n}) numbers ({unit})") from None
    if a.ndim == 0:
        a = np.full(n, float(a))
    if a.shape != (n,) and a.shape != (B, n):
        raise ValueError(f"{what} must be a number, {n} numbers (one per joint) or shape ({B}, {n}) "
                         f"(one row per path) ({unit}), got shape {a.shape}")
    bad_nan = np.argwhere(np.isnan(a))
    bad_neg = np.argwhere(a < 0)
    for bad, why in ((bad_nan, "is NaN"), (bad_neg, f"must be >= 0 ({unit}; inf = no limit)")):
        if bad.size:
            idx = tuple(int(i) for i in bad[0])
            where = f"path {idx[0]}, joint {idx[1]}" if a.ndim == 2 else f"joint {idx[0]}"
            raise ValueError(f"{what} {why}: {where} has {a[idx]}")
    if a.ndim == 2 and np.all(a == a[:1]):
        a = a[0].copy()
    return a


def _ratios(value, B: int) -> float | np.ndarray:
    """The wanted axis ratio: a number (every path) or (B,) (one per path; a number again if all
    are equal). Each must be finite and > 1; errors name the path of a bad value."""
    try:
        a = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"ratio must be a number or {B} numbers (one per path), got {value!r}") from None
    if a.ndim == 0:
        r = float(a)
        if not (math.isfinite(r) and r > 1.0):
            raise ValueError(f"ratio must be finite and > 1 (lambda1 / lambda2), got {r}")
        return r
    if a.shape != (B,):
        raise ValueError(f"ratio must be a number or {B} numbers (one per path of the batch of {B}), got shape {a.shape}")
    bad = np.flatnonzero(~(np.isfinite(a) & (a > 1.0)))
    if bad.size:
        b = int(bad[0])
        raise ValueError(f"ratio must be finite and > 1 (lambda1 / lambda2) for every path, got {a[b]} for path {b}")
    if np.all(a == a[0]):
        return float(a[0])
    return a.copy()


def first_start_rng(seed: int, target: np.ndarray, direction: np.ndarray, q0: np.ndarray) -> np.random.Generator:
    """The random generator of one path's extra first-waypoint start postures: seeded by ``seed``
    and a CRC-32 of the path's targets (P, 3), directions (P, 3) and start posture q0 (n,), so the
    same path gets the same postures wherever it stands in a batch."""
    return np.random.default_rng(np.random.SeedSequence([int(seed), content_seed(target, direction, q0)]))


def first_start_postures(robot: Robot, points: np.ndarray, directions: np.ndarray, q0: np.ndarray, kj0: np.ndarray,
                         count: int, task: str = "full", seed: int = FIRST_STARTS_SEED) -> list[tuple[np.ndarray, np.ndarray]]:
    """``count`` extra start states ``(q, kj0)`` for a path's first waypoint (no rate limit there).

    Each posture is the position IK of the first waypoint from the nominal posture perturbed by up
    to +-:data:`FIRST_STARTS_SPREAD_DEG` per free joint; the random draws come from
    :func:`first_start_rng` (the seed and the path's own data), so a path gets the same postures
    wherever it stands in a batch. Greedy SLSQP solves the first waypoint from each of them
    besides ``q0``; pgd and the hybrid use them as some of their first-waypoint starts.
    """
    spread = np.deg2rad(FIRST_STARTS_SPREAD_DEG)
    rng = first_start_rng(seed, points, directions, q0)
    out = []
    for _ in range(int(count)):
        qn = nominal_posture(robot) + np.where(robot.free, rng.uniform(-spread, spread, robot.n), 0.0)
        qn = np.clip(qn, robot.lower, robot.upper)
        qs, _ = ik_position(robot, points[0], qn, planar=(task == "xy"))
        out.append((qs, np.array(kj0, float, copy=True)))
    return out


def _start_states(robot: Robot, value, B: int, what: str) -> np.ndarray | None:
    if value is None:
        return None
    a = np.asarray(value, dtype=float)
    if a.ndim == 1:
        a = np.broadcast_to(a, (B, a.shape[0]))
    if a.ndim != 2 or a.shape != (B, robot.n):
        raise ValueError(f"{what} must have {robot.n} values (one per joint of {robot.name!r}) or shape ({B}, {robot.n}), got shape {np.shape(value)}")
    if not np.all(np.isfinite(a)):
        idx = tuple(int(i) for i in np.argwhere(~np.isfinite(a))[0])
        where = f"joint {robot.joint_names[idx[-1]]!r}" + (f" of path {idx[0]}" if B > 1 else "")
        raise ValueError(f"{what} contains NaN or Inf: {where} has {a[idx]}")
    return np.array(a, dtype=float)


def _check_q0(robot: Robot, q0: np.ndarray) -> None:
    lo, hi = robot.lower, robot.upper
    for b, q in enumerate(q0):
        bad = np.flatnonzero((q < lo) | (q > hi))
        if bad.size:
            i = int(bad[0])
            raise ValueError(
                f"q0[{i}] = {q[i]:.6g} rad for joint {robot.joint_names[i]!r} is outside its limits "
                f"[{lo[i]:.6g}, {hi[i]:.6g}]" + (f" (path {b})" if q0.shape[0] > 1 else "")
            )
        lv = robot.locked_values
        for i in np.flatnonzero(~np.isnan(lv)):
            if abs(q[i] - lv[i]) > 1e-12:
                raise ValueError(f"q0[{i}] = {q[i]:.6g} but joint {robot.joint_names[i]!r} is locked at {lv[i]:.6g}")






# ---------------------------------------------------------------------- shape
def shape(
    robot: Robot | str,
    path: Path | np.ndarray | None = None,
    criterion: str | Callable = "f2",
    ratio: float | np.ndarray = 5.0,
    *,
    task: str = "full",
    solver: str = "slsqp",
    starts: int | None = None,
    q0=None,
    kj0=None,
    dq=math.radians(DEFAULTS["dq_deg"]),
    dk=DEFAULTS["dk"],
    kmin: float = DEFAULTS["kmin"],
    kmax: float = DEFAULTS["kmax"],
    c: float = DEFAULTS["c"],
    first_rate_limit: bool = DEFAULTS["first_rate_limit"],
    first_starts: int = DEFAULTS["first_starts"],
    cms_volume: float | None = None,
    cms_major: float | None = None,
    options: Mapping[str, Any] | None = None,
    pos_tol: float = POS_TOL,
    progress: Callable[[int, int], None] | None = None,
    meta_extra: Mapping[str, Any] | None = None,
) -> R.ShapeResult:
    """Shape the stiffness ellipsoid along one or more TCP paths (seed 000, S0-9 ... S0-15).

    Args:
        robot: the chain (its locked joints stay fixed), or a URDF path / shipped robot name.
        path: a :class:`~jaxstiff.paths.Path` (P waypoints, or a batch of B paths), or points
            (P, 3) / (B, P, 3) in metres (directions: the tangent); default: the shipped
            :func:`~jaxstiff.paths.default_path`.
        criterion: ``"f1"`` (S0-9, ratio >= r), ``"f2"`` (S0-15, ratio = r), a registered name, or a
            JAX-traceable ``crit(K, d, r[, c])``.
        ratio: wanted axis ratio r = lambda1 / lambda2, > 1: a number, or (B,) one per path.
        task: ``"full"`` (K_T = top-left 3x3 of the 6x6 K_C, seed), ``"xyz"`` or ``"xy"``.
        solver: a name in :data:`SOLVERS`: ``"slsqp"`` (JAX derivatives), ``"slsqp-fd"`` (the
            seed's own way: numpy + finite differences; the speed baseline), ``"pgd"`` (batched
            projected gradient, multi-start), ``"hybrid"`` (pgd, then an SLSQP polish) or
            ``"trajectory"`` (a greedy warm start, then the whole trajectory at once).
        starts: starts per waypoint for multi-start solvers (default: their ``starts`` option, 8 for
            pgd and the hybrid; SLSQP: 1). Recorded in ``meta["starts"]``.
        q0: start posture (n,) or (B, n), rad, inside the limits, locked joints at their values;
            default: IK from the nominal posture to each path's first waypoint.
        kj0: start stiffness: a number, (n,) or (B, n), Nm/rad in [kmin, kmax]; default mid-range.
        dq: joint rate limit per waypoint, rad: a number, (n,) per joint, or (B, n) per path and
            joint; ``inf`` = none. Default 2 deg.
        dk: stiffness rate limit per waypoint, Nm/rad: a number, (n,) or (B, n). Default 5.
        kmin, kmax: stiffness range, Nm/rad, 0 < kmin < kmax. Default 1, 100 (seed).
        c: f1's offset (seed: 0.01), a number (the same for every path).
        first_rate_limit: apply dq/dk between (q0, kj0) and the first waypoint (default False).
        first_starts: when the first waypoint is not rate-limited, solve it from this many start
            postures (q0, then IK from the nominal posture perturbed by up to +-60 deg per free
            joint, drawn from a fixed seed and the path's own targets, directions and q0
            (:func:`first_start_rng`), so a path gets the same postures wherever it stands in a
            batch; kj from kj0) and keep the best (default 8).
        cms_volume: CMS target: product of the ellipsoid axes, (N/m)^m. Default ``1000**m``.
        cms_major: CMS target: the major axis lambda1, N/m (instead of the volume).
        options: solver options: SLSQP's :data:`jaxstiff.solvers.slsqp.DEFAULT_OPTIONS`, pgd's
            :data:`jaxstiff.solvers.pgd.DEFAULT_OPTIONS`, both (plus ``polish_slsqp``, ``chain``) for
            the hybrid, :data:`jaxstiff.solvers.trajectory.DEFAULT_OPTIONS` plus those of its warm
            start for the trajectory solver. An unknown name or a bad value is a ValueError before
            any work; ``meta["options"]`` records every option the run used, defaults included.
        pos_tol: m, largest position error of a usable waypoint (default 1e-9).
        progress: ``progress(b, p)`` called after each waypoint (for progress bars).
        meta_extra: more entries for ``meta`` (e.g. the CLI's path file names).

    Returns:
        :class:`~jaxstiff.results.ShapeResult` with leading axis B (B = 1 for one path).

    Raises:
        ValueError: bad input (ratio <= 1, kmin <= 0 or kmin >= kmax, negative rate limits,
            per-path values of the wrong shape, q0/kj0 of the wrong length or outside the limits,
            unknown solver/criterion/task); per-path values name the offending path.
        ShapeInterrupted: a ``KeyboardInterrupt`` after some waypoints were finished (SLSQP
            solvers): its ``result`` holds them, the others with status NOT_RUN (5).

    Per-path parameters: ``ratio`` (B,), ``dq``/``dk`` (B, n) give each path of the batch its
    own values; every solver honours them, and a path's result does not depend on the other paths
    of its batch (nor on its position there). ``meta`` records them: ``meta["ratio"]`` a number,
    or a list of B numbers when the paths differ; ``meta["limits"]["dq"]``/``["dk"]`` n numbers,
    or B lists of n when the paths differ (see :func:`jaxstiff.results.path_parameters`).
    """
    t_start = time.perf_counter()
    if isinstance(robot, (str, os.PathLike)):
        robot = Robot.from_urdf(robot)
    if not isinstance(robot, Robot):
        raise ValueError(f"robot must be a jaxstiff.Robot or a URDF path, got {type(robot).__name__}")
    if path is None:
        from jaxstiff.paths import default_path

        path = default_path()
    if isinstance(path, (list, tuple)) and path and all(isinstance(p, Path) for p in path):
        path = Path.stack(list(path))  # a list of equal-length paths -> one batch (B, P, 3)
    if not isinstance(path, Path):
        path = Path(path)
    bpath = path.as_batch()
    B, P = bpath.B, bpath.P
    n = robot.n

    # ---- parameters
    if solver not in SOLVERS:
        raise ValueError(f"unknown solver {solver!r}; choose one of {', '.join(SOLVERS)}")
    crit_fn = get_criterion(criterion)
    crit_name = criterion if isinstance(criterion, str) else getattr(criterion, "__name__", "custom")
    _check_options(solver, options)
    task_rows(task)
    check_task_feasible(robot, task)
    ratio = _ratios(ratio, B)
    try:
        kmin, kmax, c = float(kmin), float(kmax), float(c)
    except (TypeError, ValueError):
        raise ValueError("kmin, kmax and c must be numbers (c is the same for every path)") from None
    if not (math.isfinite(kmin) and math.isfinite(kmax)) or kmin <= 0 or kmin >= kmax:
        raise ValueError(f"need finite 0 < kmin < kmax (Nm/rad), got kmin={kmin}, kmax={kmax}")
    if not math.isfinite(c) or c < 0:
        raise ValueError(f"c must be a finite number >= 0, got {c}")
    if not (pos_tol > 0):
        raise ValueError(f"pos_tol must be > 0 (m), got {pos_tol}")
    dq_a = _per_joint(dq, n, "dq (joint rate limit per waypoint)", "rad", B)
    dk_a = _per_joint(dk, n, "dk (stiffness rate limit per waypoint)", "Nm/rad", B)
    if task == "xy" and np.any(np.abs(bpath.directions[..., 2]) > 1e-9):
        b, k = (int(i) for i in np.argwhere(np.abs(bpath.directions[..., 2]) > 1e-9)[0])
        raise ValueError(
            f"task 'xy' needs directions in the xy plane (dz = 0); path {b}"
            + (f" ({bpath.name})" if bpath.name else "")
            + f" has dz = {bpath.directions[b, k, 2]:.3g} at waypoint {k} (its z changes along the path, or a "
            "given direction leaves the plane: a planar task needs a path at constant z)"
        )
    m = 2 if task == "xy" else 3
    if cms_volume is not None and cms_major is not None:
        raise ValueError("give at most one of cms_volume and cms_major")
    if cms_major is not None and not (cms_major > 0):
        raise ValueError(f"cms_major must be > 0 (N/m), got {cms_major}")
    if cms_volume is not None and not (cms_volume > 0):
        raise ValueError(f"cms_volume must be > 0 ((N/m)^{m}), got {cms_volume}")
    if cms_volume is None and cms_major is None:
        cms_volume = DEFAULTS["cms_mean_axis"] ** m
    cms_meta = {"target_volume": cms_volume, "target_major": cms_major}

    kj0_given = kj0 is not None
    if kj0 is None:
        kj0 = np.full((B, n), 0.5 * (kmin + kmax))
    else:
        a = np.asarray(kj0, dtype=float)
        if a.ndim == 0:
            a = np.full(n, float(a))
        kj0 = _start_states(robot, a, B, "kj0")
        bad = np.argwhere((kj0 < kmin) | (kj0 > kmax))
        if bad.size:
            bb, i = bad[0]
            raise ValueError(f"kj0[{i}] = {kj0[bb, i]:.6g} Nm/rad for joint {robot.joint_names[i]!r} is outside [kmin, kmax] = [{kmin:g}, {kmax:g}]")

    with jax.enable_x64(True):
        q0_given = q0 is not None
        ik_err = None
        if q0 is not None:
            q0 = _start_states(robot, q0, B, "q0")
            _check_q0(robot, q0)
        else:
            q0 = np.zeros((B, n))
            ik_err = []
            for b in range(B):
                q0[b], e = ik_position(robot, bpath.points[b, 0], planar=(task == "xy"))
                ik_err.append(e)

        # extra starts for the first waypoint (used only when it is not rate-limited)
        n_first = int(first_starts)
        if n_first < 1:
            raise ValueError(f"first_starts must be >= 1, got {first_starts}")
        extra_starts = [
            [] if first_rate_limit else first_start_postures(robot, bpath.points[b], bpath.directions[b], q0[b], kj0[b], n_first - 1, task)
            for b in range(B)
        ]

        problem = WaypointProblem(robot, task, crit_fn)
        limits = Limits(dq=dq_a, dk=dk_a, kmin=kmin, kmax=kmax, first_rate_limit=bool(first_rate_limit))
        req = SolveRequest(
            problem=problem, targets=bpath.points, directions=bpath.directions, q0=q0, kj0=kj0,
            limits=limits, ratio=ratio, c=c, starts=starts, options=dict(options or {}), pos_tol=float(pos_tol),
            progress=progress, first_starts=extra_starts,
        )
        t_solve = time.perf_counter()
        try:
            arrays = SOLVERS[solver](req)
            interrupted = False
        except SolverInterrupted as e:  # the finished waypoints are kept, the others are NOT_RUN
            arrays, interrupted = e.arrays, True
        t_solved = time.perf_counter()

        # reported quantities, recomputed at the final points for every solver (a compile and B x P
        # small calls, seconds: the command line's Ctrl-C waits for them rather than lose the solve)
        with deferred_interrupts():
            report = compiled_report(problem)
            ratios = req.ratios
            pos, K, alpha, rho, f = (np.zeros((B * P, 3)), np.zeros((B * P, m, m)), np.zeros(B * P),
                                     np.zeros(B * P), np.zeros(B * P))
            for i, (b, p) in enumerate(np.ndindex(B, P)):
                x = problem.x_of(arrays["q"][b, p], arrays["kj"][b, p])
                prm = WaypointProblem.params(bpath.points[b, p], bpath.directions[b, p], ratios[b], c)
                pos[i], K[i], alpha[i], rho[i], f[i] = problem.unpack_report(np.asarray(report(x, prm)))
    w = np.linalg.eigvalsh(K)
    if cms_major is not None:
        cms = cms_major / w[:, -1]
    else:
        cms = (cms_volume / np.prod(w, axis=-1)) ** (1.0 / m)
    position = pos.reshape(B, P, 3)
    pos_error = np.linalg.norm(position - bpath.points, axis=-1)
    if task == "xy":
        dz = np.abs(position[..., 2] - bpath.points[..., 2])
        if np.any(dz > 1e-3):
            b = int(np.argmax(dz.max(axis=1)))
            warnings.warn(
                f"task 'xy' matches x and y only, and {int((dz > 1e-3).sum())} of {dz.size} waypoints end more than "
                f"1 mm from their target's z (path {b}: target z = {bpath.points[b, 0, 2]:.4g} m, TCP z = "
                f"{position[b, 0, 2]:.4g} m at the first waypoint); their status and pos_error count the 3-D "
                "distance (status 3, unreachable). Give the path the TCP's z (a planar chain moves in one plane)",
                stacklevel=2,
            )

    opts_meta = _options_meta(solver, starts, options)
    meta: dict[str, Any] = {
        "format": "jaxstiff.shape/1",
        "created": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
        "robot": robot_meta(robot),
        "criterion": crit_name,
        "criterion_custom": not (isinstance(criterion, str) and criterion in CRITERIA),
        "ratio": ratio if isinstance(ratio, float) else ratio.tolist(),
        "c": c,
        "task": task,
        "solver": solver,
        **opts_meta,
        "solver_driver": arrays.get("driver"),
        "solver_code_meaning": arrays.get("code_meaning"),
        "pos_tol": float(pos_tol),
        "limits": {
            "dq": dq_a.tolist(),
            "dk": dk_a.tolist(),
            "kmin": kmin,
            "kmax": kmax,
            "first_rate_limit": bool(first_rate_limit),
            "dq_unit": "rad per waypoint",
            "dk_unit": "Nm/rad per waypoint",
        },
        "per_path": [k for k, v in (("ratio", ratio), ("dq", dq_a), ("dk", dk_a)) if np.ndim(v) > (0 if k == "ratio" else 1)],
        "first_starts": {"count": n_first if not first_rate_limit else 1, "seed": FIRST_STARTS_SEED,
                         "use": _first_starts_use(solver, opts_meta, n_first, first_rate_limit),
                         "spread_deg": FIRST_STARTS_SPREAD_DEG,
                         "rng": "numpy default_rng(SeedSequence([seed, crc32 of the path's target, direction "
                                "(P, 3) and q0 (n,) as float64 bytes]))"},
        "q0_source": "given" if q0_given else f"ik_dls from nominal posture (mid-range, + {NOMINAL_OFFSET_DEG:g} deg for revolute joints)",
        "q_nominal": nominal_posture(robot).tolist(),
        "ik_error_m": ik_err,
        "kj0_source": "given" if kj0_given else "mid-range (kmin + kmax) / 2",
        "cms": cms_meta,
        "path": {"name": bpath.name, "B": B, "P": P,
                 "default_spec": DEFAULT_PATH_SPEC if bpath.name == "default" else None},
        "defaults": DEFAULTS,
        "status_codes": R.STATUS_NAMES,
        "timing_s": {"setup": t_solve - t_start, "solve": t_solved - t_solve, "compile": arrays.get("compile_s"),
                     "total": time.perf_counter() - t_start},
        "versions": versions(),
        "jax_cpu_async_dispatch": _cpu_async_dispatch(),
        "units": {"q": "rad", "kj": "Nm/rad", "position": "m", "alpha_deg": "deg", "stiffness": "N/m"},
        "interrupted": interrupted,
    }
    if meta_extra:
        meta.update(dict(meta_extra))
    result = R.ShapeResult(
        joint_names=np.asarray(robot.joint_names, dtype=str),
        q=arrays["q"],
        kj=arrays["kj"],
        cms=cms.reshape(B, P),
        kj_scaled=arrays["kj"] * cms.reshape(B, P, 1),
        target=np.array(bpath.points),
        direction=np.array(bpath.directions),
        position=position,
        pos_error=pos_error,
        alpha_deg=alpha.reshape(B, P),
        ratio=rho.reshape(B, P),
        criterion=f.reshape(B, P),
        status=arrays["status"],
        q0=q0,
        kj0=kj0,
        solver_code=arrays["solver_code"],
        nit=arrays["nit"],
        nfev=arrays["nfev"],
        time_s=arrays["time_s"],
        meta=meta,
    )
    if interrupted:
        raise ShapeInterrupted(result)
    return result


def _solver_defaults(solver: str) -> dict[str, Any]:
    """The default options of a shipped solver, as it applies them ({} for a user-registered one).

    The hybrid is pgd followed by an SLSQP polish, so its options are both sets plus its own two.
    The trajectory solver's own options are here; those of its warm start go to ``warm_options``."""
    from jaxstiff.solvers import hybrid, pgd, slsqp, trajectory

    if solver in ("slsqp", "slsqp-fd"):
        return dict(slsqp.DEFAULT_OPTIONS)
    if solver == "pgd":
        return dict(pgd.DEFAULT_OPTIONS)
    if solver == "hybrid":
        return {**pgd.DEFAULT_OPTIONS, **slsqp.DEFAULT_OPTIONS, **hybrid.DEFAULT_OPTIONS}
    if solver == "trajectory":
        return dict(trajectory.DEFAULT_OPTIONS)
    return {}


def solver_option_names(solver: str, warm: str = "pgd") -> set[str] | None:
    """The option names a shipped solver reads (the trajectory solver's include those of its warm
    start ``warm``); None for a user-registered solver (its options are not checked)."""
    if solver not in ("slsqp", "slsqp-fd", "pgd", "hybrid", "trajectory"):
        return None
    known = set(_solver_defaults(solver))
    if solver == "trajectory":
        known |= set(_solver_defaults(warm))
    return known


def options_for_solver(solver: str, options: Mapping[str, Any] | None) -> dict[str, Any]:
    """The entries of ``options`` that ``solver`` reads (all of them for a user-registered solver):
    a sweep over several solvers shares one options table."""
    opts = dict(options or {})
    known = solver_option_names(solver, opts.get("warm", "pgd"))
    return opts if known is None else {k: v for k, v in opts.items() if k in known}


def _check_options(solver: str, options: Mapping[str, Any] | None) -> None:
    """Unknown option names of a shipped solver are an error (a typo would otherwise be ignored),
    and so are bad values, before any work (a hybrid would otherwise meet a bad SLSQP option only
    after its pgd stage). A user-registered solver checks its own options."""
    if not options:
        return
    if not isinstance(options, Mapping):
        raise ValueError(f"options must be a dict of solver options, got {type(options).__name__}")
    from jaxstiff.solvers import hybrid, pgd, slsqp, trajectory

    warm = options.get("warm", "pgd")
    if solver == "trajectory" and warm not in trajectory.WARM_STARTS:
        raise ValueError(f"option warm must be one of {', '.join(map(repr, trajectory.WARM_STARTS))}, got {warm!r}")
    known = solver_option_names(solver, warm)
    if known is None:
        return
    unknown = sorted(str(k) for k in options if k not in known)
    if unknown:
        import difflib

        hints = [f"{k!r} (did you mean {m[0]!r}?)" if (m := difflib.get_close_matches(k, known, n=1)) else repr(k) for k in unknown]
        raise ValueError(f"unknown option(s) for solver {solver!r}: {', '.join(hints)}; known: {', '.join(sorted(known))}")
    greedy = warm if solver == "trajectory" else solver  # the part that runs pgd and/or SLSQP
    if solver == "trajectory":
        trajectory.check_options(options)
    if greedy == "hybrid":
        hybrid.check_options(options)
    if greedy in ("pgd", "hybrid"):
        pgd.check_options({k: v for k, v in options.items() if k in pgd.DEFAULT_OPTIONS})
    if greedy in ("slsqp", "slsqp-fd", "hybrid"):
        slsqp.check_options({k: v for k, v in options.items() if k in slsqp.DEFAULT_OPTIONS})


def _first_starts_use(solver: str, opts_meta: dict, n_first: int, first_rate_limit: bool) -> str:
    """What the solver does with the first waypoint's start postures (meta ``first_starts.use``):
    SLSQP solves from each of them, pgd makes them some of its own (more) random starts."""
    if first_rate_limit:
        return "first waypoint rate-limited: solved from q0 alone"
    greedy = solver
    popts = opts_meta["options"]
    if solver == "trajectory":
        popts = opts_meta["warm_options"]
        greedy = str(opts_meta["options"].get("warm", "pgd"))
    if greedy in ("pgd", "hybrid"):
        S = int(opts_meta["starts"])
        S1 = max(S, int(popts["starts_first"])) if popts.get("mode") == "best" else S
        return (f"{min(n_first, S1)} of the {S1} first-waypoint starts of pgd (q0 first; the rest random "
                "postures, options starts/starts_first)")
    if greedy in ("slsqp", "slsqp-fd"):
        return "SLSQP solves the first waypoint from each (q0 first); the best is kept"
    return "passed to the solver as SolveRequest.first_starts"


def _options_meta(solver: str, starts: int | None, options: Mapping[str, Any] | None) -> dict[str, Any]:
    """meta's ``starts`` and ``options`` (and ``warm_options`` for the trajectory solver): the
    values the solver ran with, defaults filled in, so that a result file says how it was made."""
    given = dict(options or {})
    own = _solver_defaults(solver)
    opts = {**own, **given}
    out: dict[str, Any] = {"options": opts}
    warm = None
    if solver == "trajectory":
        warm = str(opts.get("warm", "pgd"))
        wdef = _solver_defaults(warm)
        out["options"] = opts = {**own, **{k: v for k, v in given.items() if k in own}}
        out["warm_options"] = {**wdef, **{k: v for k, v in given.items() if k in wdef}}
    multi = solver in ("pgd", "hybrid") or warm in ("pgd", "hybrid")
    if not multi:
        out["starts"] = 1
    else:
        target = out["warm_options"] if solver == "trajectory" else opts
        if starts is not None:
            target["starts"] = int(starts)
        out["starts"] = int(target["starts"])
    return out
