"""The call itself: :func:`shape` (settings inline, a solver object) and :func:`run_shape` (the
solver by name, its options as a dict), the solve step between the inputs (``_inputs``) and the
report (``_steps``), and the CPU dispatch switch of the entry points. Private to
:mod:`jaxstiff.shaping`."""

from __future__ import annotations

import math
import os
import time
import warnings
from collections.abc import Callable, Mapping
from typing import Any

import jax
import numpy as np

from jaxstiff.model._reach import check_reach
from jaxstiff.model._robot import Robot
from jaxstiff.paths import Path
from jaxstiff.results._files import ShapeResult
from jaxstiff.results._singular import singular_meta, singular_waypoints, warn_singular
from jaxstiff.results._target import warn_missed_target, warn_unusable
from jaxstiff.runtime._compile_cache import CompileClock, ensure_compile_cache
from jaxstiff.runtime._dtypes import refuse_half_precision
from jaxstiff.settings._base import suggest
from jaxstiff.settings._robot import RobotSpec
from jaxstiff.settings._shape import ShapeSettings
from jaxstiff.shaping._inputs import ShapeInputs, check_inputs, make_start_states, robot_and_path
from jaxstiff.shaping._steps import (
    assemble_result,
    check_shape_size,
    cms_factors,
    report_at_solution,
    shape_meta,
    warn_off_plane,
)
from jaxstiff.solvers._base import SOLVERS, SolveRequest, SolverInterrupted
from jaxstiff.solvers._base import first_starts_use as _first_starts_use
from jaxstiff.solvers._base import options_meta as _options_meta
from jaxstiff.solvers._configs import Solver, solver_call
from jaxstiff.solvers._problem import POS_TOL, Limits, WaypointProblem, warm_report

_DEFAULT_SETTINGS = ShapeSettings()

#: Defaults of the parameters the seed does not fix, as ``meta["defaults"]`` records them (derived
#: from :class:`~jaxstiff.settings.ShapeSettings`; ``dq_deg`` is its ``dq`` in degrees).
DEFAULTS: dict[str, Any] = {
    "dq_deg": math.degrees(_DEFAULT_SETTINGS.dq),
    "dk": _DEFAULT_SETTINGS.dk,
    "kmin": _DEFAULT_SETTINGS.kmin,
    "kmax": _DEFAULT_SETTINGS.kmax,
    "c": _DEFAULT_SETTINGS.c,
    "first_rate_limit": _DEFAULT_SETTINGS.first_rate_limit,
    "first_starts": _DEFAULT_SETTINGS.first_starts,
    "cms_mean_axis": _DEFAULT_SETTINGS.cms_mean_axis,
    "q0": "ik_from_nominal",
    "kj0": "mid_range",
}


#: set to 1, this environment variable keeps JAX's asynchronous CPU dispatch in a process where
#: :func:`prefer_sync_cpu_dispatch` would turn it off (JAX itself reads no variable for it)
ASYNC_DISPATCH_ENV = "JAXSTIFF_CPU_ASYNC_DISPATCH"


def prefer_sync_cpu_dispatch() -> bool:
    """Run JAX CPU computations inline (no async dispatch), if JAX has not started its backend yet
    and the environment does not keep async dispatch (``JAXSTIFF_CPU_ASYNC_DISPATCH=1``).

    SLSQP calls one small kernel per point it asks about (80-400 per waypoint), and pgd's
    first-waypoint search and the hybrid's polish one batched kernel per lockstep round; with JAX's
    default asynchronous CPU dispatch each call pays a hand-off to a worker thread that costs more
    than the kernel when the caller does other work between calls (measured on a 2-core CPU, the
    LWR's SLSQP kernel: 34-40 us inline against 82-127 us async). The setting
    (``jax_cpu_enable_async_dispatch``) is process-wide and read once, when the CPU backend
    starts: :func:`run_shape` (so :func:`shape`, the command line and the sweeps) calls this
    first, and it takes effect where that call is the process's first JAX work; results are the
    same to the bit either way, only the time differs. A process that must keep async dispatch
    sets ``JAXSTIFF_CPU_ASYNC_DISPATCH=1``, or runs a JAX computation of its own before its first
    ``shape`` call (then nothing changes). Like the compilation cache (``ensure_compile_cache``),
    the setting is made by the call, never by ``import jaxstiff``.

    Returns:
        True if CPU dispatch is (now) synchronous.
    """
    if os.environ.get(ASYNC_DISPATCH_ENV, "").strip() == "1":  # the process keeps JAX's default
        return not cpu_async_dispatch()
    try:
        from jax._src import xla_bridge  # noqa: PLC2701 - jax has no public query for initialised backends

        started = xla_bridge.backends_are_initialized()
    except (ImportError, AttributeError):  # pragma: no cover - private API moved
        started = True
    if not started:
        jax.config.update("jax_cpu_enable_async_dispatch", False)
    return not cpu_async_dispatch()


def cpu_async_dispatch() -> bool:
    """The value of ``jax_cpu_enable_async_dispatch`` (True if unknown)."""
    return bool(jax.config.values.get("jax_cpu_enable_async_dispatch", True))


class ShapeInterrupted(KeyboardInterrupt):
    """:func:`shape` was interrupted after some waypoints were finished: ``result`` is a complete
    :class:`~jaxstiff.ShapeResult` whose unfinished waypoints have status NOT_RUN (5) and whose
    meta has ``interrupted: true``. A subclass of ``KeyboardInterrupt``, so an interrupt still
    stops the caller; catch it to keep the finished part (the command line saves it)."""

    def __init__(self, result: ShapeResult):
        super().__init__()
        self.result = result


def _solve(
    inp: ShapeInputs, extra_starts: list, progress: Callable[[int, int], None] | None
) -> tuple[WaypointProblem, SolveRequest, dict[str, Any], bool]:
    """Step 3: run the solver; an interrupt after some waypoints keeps them (the rest NOT_RUN)."""
    if inp.q0 is None or inp.kj0 is None:  # made by step 2 (the start states)
        raise RuntimeError("shape: the start states were not made before the solve")
    with jax.enable_x64(True):
        problem = WaypointProblem(inp.robot, inp.task, inp.crit_fn, inp.locked_joints)
        limits = Limits(dq=inp.dq, dk=inp.dk, kmin=inp.kmin, kmax=inp.kmax, first_rate_limit=inp.first_rate_limit)
        req = SolveRequest(
            problem=problem,
            targets=inp.path.points,
            directions=inp.path.directions,
            q0=inp.q0,
            kj0=inp.kj0,
            limits=limits,
            ratio=inp.ratio,
            c=inp.c,
            starts=inp.starts,
            options=dict(inp.options or {}),
            pos_tol=inp.pos_tol,
            progress=progress,
            first_starts=extra_starts,
        )
        warm_report(problem)  # the report program compiles beside the solve (a core that tracing leaves idle)
        try:
            return problem, req, SOLVERS[inp.solver](req), False
        except SolverInterrupted as e:  # the finished waypoints are kept, the others are NOT_RUN
            return problem, req, e.arrays, True


# ---------------------------------------------------------------------- shape
#: the settings :func:`run_shape` takes as keywords: every ShapeSettings field
_FIELDS = frozenset(ShapeSettings.field_names())
#: the keyword arguments :func:`shape` takes besides its own: every ShapeSettings field, and the
#: CMS target given as a volume or a major axis instead of ``cms_mean_axis``
INLINE_SETTINGS = _FIELDS - {"criterion", "ratio", "solver"} | {
    "cms_volume",
    "cms_major",
}
#: older keyword arguments of :func:`shape`, still taken with a DeprecationWarning: what to use instead
DEPRECATED_KEYWORDS = {
    "options": "a solver object, e.g. solver=jaxstiff.solvers.PGD(iters=60) (jaxstiff.solvers)",
    "pos_tol": "jaxstiff.shaping.run_shape(..., pos_tol=...)",
    "meta_extra": "jaxstiff.shaping.run_shape(..., meta_extra=...)",
}


def shape(
    robot: Robot | RobotSpec | str,
    path: Path | np.ndarray | None = None,
    criterion: str | Callable[..., Any] | None = None,
    ratio: float | np.ndarray | None = None,
    *,
    solver: str | Solver | None = None,
    settings: ShapeSettings | None = None,
    q0: Any = None,
    kj0: Any = None,
    progress: Callable[[int, int], None] | None = None,
    **inline: Any,
) -> ShapeResult:
    """Shape the stiffness ellipsoid along one or more TCP paths (seed 000, S0-9 ... S0-15).

    Args:
        robot: a :class:`~jaxstiff.Robot` (its locked joints stay fixed), a
            :class:`~jaxstiff.settings.RobotSpec`, or a URDF path / shipped robot name.
        path: a :class:`~jaxstiff.Path` (P waypoints, or a batch of B paths), a path file's name
            (read by :meth:`~jaxstiff.Path.from_csv`, as ``jaxstiff shape --path`` reads it), a list
            of paths or files of equal length (a batch), or points (P, 3) / (B, P, 3) in metres
            (directions: the tangent); default :func:`~jaxstiff.default_path`.
        criterion: ``"f1"`` (ratio at least r), ``"f2"`` (ratio exactly r), a registered name, or
            a JAX-traceable ``crit(K, d, r[, c])``.
        ratio: the wanted axis ratio 1 < r <= 1e6: a number, or (B,) one per path.
        solver: a solver object (:mod:`jaxstiff.solvers`: ``SLSQP()``, ``SLSQPFD()``, ``PGD()``,
            ``Hybrid()``, ``Trajectory()``, each with its options as fields) or a solver's name.
        settings: a :class:`~jaxstiff.settings.ShapeSettings`: every setting left out here.
        q0: start posture (n,) or (B, n), rad, inside the limits, locked joints at their values;
            default: IK from the nominal posture to each path's first waypoint.
        kj0: start stiffness: a number, (n,) or (B, n), Nm/rad in [kmin, kmax]; default mid-range.
        progress: ``progress(b, p)`` called after each waypoint (SLSQP solvers).
        **inline: any :class:`~jaxstiff.settings.ShapeSettings` field given here instead of in
            ``settings`` (``task="xy"``, ``dq=...``, ``kmin=...``; defaults, units and meaning are
            written there); ``ratio``, ``dq``, ``dk``, ``dq_per_m`` and ``dk_per_m`` also take
            per-path (and per-joint) arrays; ``cms_volume`` / ``cms_major`` give the CMS target as
            the ellipsoid's volume ((N/m)^m) or major axis (N/m) instead of ``cms_mean_axis``.

    Returns:
        :class:`~jaxstiff.ShapeResult` with leading axis B (B = 1 for one path).

    Raises:
        TypeError: an unknown keyword (the message names the nearest setting).
        ValueError: bad input, before any work (the message names the value, path and joint);
            :class:`~jaxstiff.model._reach.UnreachableError` for a waypoint out of reach.
        ShapeInterrupted: a ``KeyboardInterrupt`` after some waypoints were finished: its ``result``
            holds them, the others with status NOT_RUN (5).

    :func:`run_shape` is the same call with the solver by name and its options as a dict (the command
    line's way in). Where the call is the process's first JAX work it makes JAX's CPU dispatch
    synchronous, which the per-waypoint solvers' small kernels need (:func:`prefer_sync_cpu_dispatch`:
    why, and how to keep async dispatch).
    """
    kw: dict[str, Any] = {}
    for k, v in inline.items():
        if k in DEPRECATED_KEYWORDS:
            warnings.warn(
                f"shape({k}=...) is deprecated; use {DEPRECATED_KEYWORDS[k]}", DeprecationWarning, stacklevel=2
            )
        elif k not in INLINE_SETTINGS:
            raise TypeError(f"shape() got an unexpected keyword argument {k!r}{suggest(k, sorted(INLINE_SETTINGS))}")
        kw[k] = v
    name: str | None = None
    if solver is not None:
        name, sopts = solver_call(solver)
        if sopts and kw.get("options"):
            raise TypeError("give the solver's options in the solver object or in options=, not both")
        if "starts" in sopts and kw.get("starts") is not None and kw["starts"] != sopts["starts"]:
            raise TypeError(
                f"starts given twice: {sopts['starts']} in the solver object and starts={kw['starts']}; give one"
            )
        if sopts:
            kw["options"] = sopts
    return run_shape(
        robot,
        path,
        criterion,
        ratio,
        settings=settings,
        solver=name,
        q0=q0,
        kj0=kj0,
        progress=progress,
        _stacklevel=4,
        **kw,
    )


def run_shape(  # noqa: PLR0913 - the full form behind shape(): solver by name, options as a dict, for the CLI and sweeps
    robot: Robot | RobotSpec | str,
    path: Path | np.ndarray | None = None,
    criterion: str | Callable[..., Any] | None = None,
    ratio: float | np.ndarray | None = None,
    *,
    settings: ShapeSettings | None = None,
    q0: Any = None,
    kj0: Any = None,
    cms_volume: float | None = None,
    cms_major: float | None = None,
    options: Mapping[str, Any] | None = None,
    pos_tol: float = POS_TOL,
    progress: Callable[[int, int], None] | None = None,
    meta_extra: Mapping[str, Any] | None = None,
    _stacklevel: int = 3,
    **given: Any,
) -> ShapeResult:
    """:func:`shape` with the solver by name and its options as a dict: the way in of the command
    line and the sweeps. The body is the named steps of the module docstring
    (:func:`check_inputs`, :func:`make_start_states`, solve, report, meta, result).

    Args:
        robot, path, criterion, ratio, q0, kj0, progress: as for :func:`shape`.
        settings: a :class:`~jaxstiff.settings.ShapeSettings`: every setting not given here
            (default ``ShapeSettings()``, where every default, unit, check and meaning is written).
        cms_volume, cms_major: the CMS target as the ellipsoid's volume, (N/m)^m, or its major
            axis lambda1, N/m, instead of ``cms_mean_axis``.
        options: the solver's options (names and defaults: the solver objects of
            :mod:`jaxstiff.solvers`); an unknown name or a bad value is a ValueError before any
            work; ``meta["options"]`` records every option the run used, defaults included.
        pos_tol: m, largest position error of a usable waypoint.
        meta_extra: more entries for ``meta`` (e.g. the CLI's path file names).
        **given: any :class:`~jaxstiff.settings.ShapeSettings` field (``solver`` by name). Per-path
            values: ``ratio`` (B,), ``dq`` / ``dk`` / ``dq_per_m`` / ``dk_per_m`` a number, (n,)
            per joint or (B, n) per path and joint; a path's result does not depend on the other
            paths of its batch, and ``meta`` records them (a list where the paths differ:
            :func:`jaxstiff.results.path_parameters`).

    Returns:
        :class:`~jaxstiff.results.ShapeResult` with leading axis B (B = 1 for one path).

    Raises:
        TypeError: a keyword that is no setting (the message names the nearest one).
        ValueError: bad input before any work (the message names the value, path and joint);
            :class:`~jaxstiff.model._reach.UnreachableError` for a waypoint out of reach.
        ShapeInterrupted: a ``KeyboardInterrupt`` after some waypoints were finished (SLSQP
            solvers): its ``result`` holds them, the others with status NOT_RUN (5).
    """
    prefer_sync_cpu_dispatch()  # before JAX starts its backend, where this call is the first JAX work
    ensure_compile_cache()  # before the first compilation (cheap when already on)
    t_start, w_start = time.perf_counter(), time.time()
    with CompileClock() as clock:
        base = settings if settings is not None else _DEFAULT_SETTINGS
        if not isinstance(base, ShapeSettings):
            raise ValueError(f"settings must be a jaxstiff.settings.ShapeSettings, got {type(base).__name__}")
        if progress is not None and not callable(progress):
            raise TypeError(f"progress must be a function progress(b, p) (or None), got {progress!r}")
        unknown = sorted(set(given) - _FIELDS)
        if unknown:
            raise TypeError(
                f"run_shape() got an unexpected keyword argument {unknown[0]!r}{suggest(unknown[0], sorted(_FIELDS))}"
            )
        if given.get("cms_mean_axis") is not None:  # the CMS target is read from the settings object
            base = base.replace(cms_mean_axis=given["cms_mean_axis"])
        given = {**given, "criterion": criterion, "ratio": ratio}
        values = {**dataclass_values(base), **{k: v for k, v in given.items() if v is not None}}
        refuse_half_precision("shape", q0=q0, kj0=kj0)  # (the path: Path refuses it)
        robot_, spec_meta, bpath = robot_and_path(robot, path)
        inp = check_inputs(
            robot_, bpath, values, base, cms_volume=cms_volume, cms_major=cms_major, options=options, pos_tol=pos_tol
        )
        inp.robot_spec = spec_meta
        check_shape_size(inp)  # before any work: B x P waypoints that cannot fit are refused
        # waypoints out of the robot's reach are refused before any IK or solve (milliseconds)
        check_reach(inp.robot, bpath.points, planar=inp.task == "xy")
        extra_starts = make_start_states(inp, q0, kj0)
        marks = [time.perf_counter(), time.time()]  # the solve starts (perf_counter, wall clock)
        problem, req, arrays, interrupted = _solve(inp, extra_starts, progress)
        marks += [time.perf_counter(), time.time()]  # ... and ends
        rep = report_at_solution(problem, inp, arrays, req.ratios)
        cms = cms_factors(rep.K, inp)
        warn_off_plane(rep.position, bpath, inp.task, stacklevel=_stacklevel)
        opts_meta = _options_meta(inp.solver, inp.starts, inp.options)
        use = _first_starts_use(inp.solver, opts_meta, inp.first_starts, inp.first_rate_limit)
        timing = _timing((t_start, w_start), marks, clock, arrays.get("compile_s"), bool(arrays.get("time_s_run_only")))
        meta = shape_meta(inp, arrays, opts_meta, use, timing, DEFAULTS, interrupted, cpu_async_dispatch())
        meta["compilation"] = clock.meta()
        singular = singular_waypoints(rep.K, np.asarray(arrays["status"]).reshape(rep.K.shape[:2]))
        meta["singular"] = singular_meta(singular)
        if meta_extra:
            meta.update(dict(meta_extra))
        result = assemble_result(inp, arrays, rep, cms, meta)
    if interrupted:
        raise ShapeInterrupted(result)
    warn_unusable(result, stacklevel=_stacklevel)  # waypoints without a usable solution: one warning
    warn_missed_target(result, stacklevel=_stacklevel)  # usable waypoints off target: one warning, named
    warn_singular(singular, inp.task, stacklevel=_stacklevel)  # ... and those whose ratio is the regularisation's
    return result


def _timing(
    start: tuple[float, float], marks: list[float], clock: CompileClock, solver_compile: Any, run_only: bool = False
) -> dict[str, Any]:
    """``meta["timing_s"]``: wall seconds of the call (``total``) and its phases (``setup``: inputs,
    IK, start states; ``solve``; ``report``: report, CMS, meta), each with its compilation;
    ``compile``: JAX compilation in the whole call (tracing, lowering, XLA compile or cache load:
    :class:`~jaxstiff.runtime._compile_cache.CompileClock`), ``compile_solve`` the part in the solve,
    ``run`` = ``total - compile``; ``solver_compile``: the solver's own measurement of what it
    compiled before its first waypoint (kept out of the per-waypoint ``time_s``), None when the
    solver reports none; ``compile_in_time_s``: compilation during the solve that the solver did
    not keep apart (``compile_solve - solver_compile``, at least 0), an upper bound of the
    compilation inside the per-waypoint ``time_s`` (0: ``time_s`` is run time only; ``run_only``:
    the solver's ``time_s`` times its compiled programs' runs alone, as pgd's does)."""
    t_start, w_start = start
    t_solve, w_solve, t_solved, w_solved = marks
    now, w_now = time.perf_counter(), time.time()
    # JAX stamps its spans with the wall clock (time.time), the phases here use perf_counter: the
    # spans are cut to the call's window and the sums capped by the phases' lengths, so that a
    # wall-clock step (clock sync on a loaded machine) cannot give more compilation than time
    compile_s = min(clock.seconds_between(w_start, w_now), now - t_start)
    compile_solve = min(clock.seconds_between(w_solve, w_solved), t_solved - t_solve, compile_s)
    return {
        "total": now - t_start,
        "setup": t_solve - t_start,
        "solve": t_solved - t_solve,
        "report": now - t_solved,
        "compile": compile_s,
        "compile_solve": compile_solve,
        "run": max(now - t_start - compile_s, 0.0),
        "solver_compile": None if solver_compile is None else float(solver_compile),
        "compile_in_time_s": 0.0 if run_only else max(compile_solve - float(solver_compile or 0.0), 0.0),
    }


def dataclass_values(s: ShapeSettings) -> dict[str, Any]:
    """``{field: value}`` of a settings object."""
    return {name: getattr(s, name) for name in s.field_names()}
