"""Parameter sweeps: a TOML grid of settings x trajectories, solved in batches, resumable.

``run_sweep(config, out)`` (CLI: ``jaxstiff sweep CONFIG.toml --out DIR``) reads and validates the
config (:mod:`jaxstiff.sweep._config`: every problem is reported before any work starts), opens the
store in ``out`` (:mod:`jaxstiff.sweep._store`), computes every chunk that is not finished yet
(:mod:`jaxstiff.sweep._chunks`, on a backend of :mod:`jaxstiff.sweep._backends`), and assembles the
results table (one row per trajectory x setting, Parquet), ``summary.md`` and heat maps
(:mod:`jaxstiff.sweep._report`). The table's columns: ``row_id, chunk, group, path, path_index,
P``, one per axis of the kind (:data:`jaxstiff.sweep._config.AXES`), ``q0_ik_error_m`` (the start
posture's IK error, NaN where it is not an IK solution), the metrics
(:data:`jaxstiff.sweep._metrics.METRICS`), and ``result_file, result_index`` (where the row's
per-waypoint arrays are).

Batching. A chunk is a run of rows of one group (rows that share the static settings and the
number of waypoints, so one compiled kernel serves the whole group); see :mod:`._chunks`. The
per-waypoint SLSQP of ``shape`` is a host loop and does not shard; a csc chunk is sharded across
all local JAX devices (GPUs, or CPU devices from ``XLA_FLAGS=--xla_force_host_platform_device_count=N``).

Same table on every backend. A row's result depends only on its inputs and on the numeric
environment. Ray workers run with ``OMP_NUM_THREADS=1``, and a different thread count (read by
numpy's OpenBLAS when it loads) changes the last digits of the linear algebra, which an optimiser
can amplify (docs/notes/sweep.md). For bit-identical tables across backends, machines and resumes,
run every part with the same ``OMP_NUM_THREADS`` (``OMP_NUM_THREADS=1 jaxstiff sweep ...`` matches
Ray's workers); each run's setting is recorded in ``manifest.json``.

Resume. Every finished chunk is committed atomically; ``resume=True`` skips the committed chunks
and computes the rest. Random choices (``q0 = "random"``) are seeded by ``(seed, q0_seed, path)``,
never by chunk or time, and the table holds no timing, so an interrupted and resumed sweep gives
the same table as an uninterrupted one.

Example:
    >>> from jaxstiff.sweep import run_sweep
    >>> out = run_sweep("experiments/sweeps/quick.toml", "runs/quick")     # doctest: +SKIP
    >>> out.table_file                                                     # doctest: +SKIP
    '.../runs/quick/results.parquet'
"""

from __future__ import annotations

import dataclasses
import os
import sys
import time
from collections.abc import Callable, Mapping
from typing import Any

from jaxstiff.sweep._backends import (
    BACKENDS,
    Progress,
    default_cache_dir,
    enable_compile_cache,
    import_ray,
    run_local,
    run_ray,
)
from jaxstiff.sweep._chunks import compute_chunk, shard_batch
from jaxstiff.sweep._plan import SweepPlan, load_config, parse_config
from jaxstiff.sweep._starts import IK_RETRIES, IK_TOL_M, Q0_CACHE, start_posture, start_posture_and_error
from jaxstiff.sweep._store import SweepStore, read_table

__all__ = [
    "run_sweep",
    "compute_chunk",
    "start_posture",
    "start_posture_and_error",
    "shard_batch",
    "read_table",
    "load_config",
    "BACKENDS",
    "default_cache_dir",
    "enable_compile_cache",
    "Progress",
    "IK_TOL_M",
    "IK_RETRIES",
    "Q0_CACHE",
]


@dataclasses.dataclass(frozen=True)
class SweepOutcome:
    """What :func:`run_sweep` did.

    Attributes:
        out: the store folder.
        table_file: ``results.parquet`` (``results.csv`` without pyarrow).
        n_rows, n_chunks: of the plan.
        computed: chunk ids computed by this run, in commit order.
        skipped: chunk ids that were already finished (resume).
        wall_s: wall time of this run, s.
        plan: the plan.
    """

    out: str
    table_file: str
    n_rows: int
    n_chunks: int
    computed: tuple[int, ...]
    skipped: tuple[int, ...]
    wall_s: float
    plan: SweepPlan

    def table(self) -> Any:
        """The results table (pandas DataFrame)."""
        return read_table(self.out)

    def __repr__(self) -> str:
        """A short summary (rows, the axes varied, chunks, where the table is), not the plan's arrays."""
        plan = self.plan
        varied = [k for k, v in plan.axes.items() if len(v) > 1]
        done = f"{len(self.computed)} computed" + (f", {len(self.skipped)} already done" if self.skipped else "")
        return (
            f"SweepOutcome({plan.kind} sweep {plan.name!r}: {self.n_rows} rows = {len(plan.trajectories)} path(s) x "
            f"{len(plan.settings)} setting(s) (varied: {', '.join(varied) or 'none'}); {self.n_chunks} chunks "
            f"({done}) in {self.wall_s:.1f} s; table {self.table_file}, .table() reads it)"
        )


def _plan_of(config: str | os.PathLike | Mapping[str, Any] | SweepPlan) -> SweepPlan:
    if isinstance(config, SweepPlan):
        return config
    if isinstance(config, Mapping):
        return parse_config(config, base_dir=os.getcwd(), source="config")
    return load_config(config)


def _cache_dir(compile_cache: bool | str) -> str | None:
    """The compilation cache folder to use (``True``: :func:`default_cache_dir`), turned on."""
    if compile_cache is True:
        cache_dir = default_cache_dir()
    elif compile_cache:
        cache_dir = os.fspath(compile_cache)
    else:
        cache_dir = None
    if cache_dir is not None:
        enable_compile_cache(cache_dir)
    return cache_dir


def _compute(
    plan: SweepPlan,
    store: SweepStore,
    *,
    backend: str,
    progress: bool,
    log: Callable[[str], None],
    on_commit: Callable[[int], None] | None,
    address: str | None,
    ray_init: Mapping[str, Any] | None,
    cache_dir: str | None,
) -> list[int]:
    """Compute the chunks not yet in ``store``; returns the ids computed, in commit order. Records
    the run as finished or interrupted; a KeyboardInterrupt passes on after the resume hint."""
    computed: list[int] = []

    def committed(cid: int) -> None:
        computed.append(cid)
        if on_commit is not None:
            on_commit(cid)

    todo = [c for c in plan.chunks if c.id not in store.done]
    prog = Progress(plan.name, plan, store.done.keys(), enabled=progress)
    status = "interrupted"
    try:
        if backend == "local":
            run_local(plan, todo, store, prog, committed)
        else:
            run_ray(plan, todo, store, prog, committed, address, ray_init, cache_dir)
        status = "finished"
    except KeyboardInterrupt:
        prog.close()
        log(
            f"interrupted: {len(store.done)} of {len(plan.chunks)} chunks are saved in {store.out}; continue with --resume"
        )
        raise
    finally:
        store.finish_run(status)
    prog.close()
    return computed


def _check_backend(backend: str) -> None:
    """Refuse an unknown backend; for ``"ray"``, fail early (clear message) when Ray is missing."""
    if backend not in BACKENDS:
        raise ValueError(f"unknown backend {backend!r}; choose one of {', '.join(BACKENDS)}")
    if backend == "ray":
        import_ray()


def _assemble(plan: SweepPlan, store: SweepStore, report: bool, log: Callable[[str], None]) -> str:
    """Write the table (and, with ``report``, summary.md and the heat maps); return the table file."""
    table_file = store.assemble()
    if report:
        from jaxstiff.sweep._report import write_report

        write_report(plan, store.out, manifest=store.manifest)
    log(f"wrote {table_file} ({plan.n_rows} rows)")
    return table_file


def run_sweep(  # noqa: PLR0913 - public entry point: its keyword options are its interface
    config: str | os.PathLike | Mapping[str, Any] | SweepPlan,
    out: str | os.PathLike,
    *,
    resume: bool = False,
    backend: str = "local",
    address: str | None = None,
    ray_init: Mapping[str, Any] | None = None,
    progress: bool = True,
    report: bool = True,
    on_commit: Callable[[int], None] | None = None,
    log: Callable[[str], None] | None = None,
    compile_cache: bool | str = True,
) -> SweepOutcome:
    """Run (or resume) a sweep and write its table, summary and plots into ``out``.

    Args:
        config: a TOML file, a config dict (relative files resolve against the working folder)
            or a :class:`~jaxstiff.sweep._config.SweepPlan`.
        out: the store folder (created if missing): empty, or holding this same sweep; a store
            with finished chunks of it is continued only with ``resume=True`` (else ValueError).
        resume: continue the sweep in ``out``, skipping its finished chunks.
        backend: ``"local"`` or ``"ray"``.
        address: Ray cluster address (``"auto"``, ``"ray://host:10001"``); default: start a local one.
        ray_init: more ``ray.init`` arguments (e.g. ``{"num_cpus": 2}``).
        progress: draw the progress bar on stderr.
        report: write ``summary.md`` and the heat maps at the end.
        on_commit: called with each chunk id after it is committed (tests use it to interrupt).
        log: where one-line messages go (default: stderr when ``progress``, else nowhere).
        compile_cache: use jaxstiff's persistent compilation cache: True = the folder the
            environment names (``$JAXSTIFF_CACHE_DIR``, default ``~/.cache/jaxstiff/xla`` on Linux;
            off where ``JAXSTIFF_COMPILE_CACHE=0``), a folder name, or False. A JAX cache folder
            you set yourself (``jax_compilation_cache_dir``) is used as it is. See the docs' page
            Caches and runtime (``docs/reference/runtime.md``).

    Returns:
        :class:`SweepOutcome`.

    Raises:
        FileNotFoundError: the config file does not exist.
        ValueError: a bad config (:class:`~jaxstiff.sweep._config.SweepConfigError`), an unusable
            ``out``, an unknown backend or Ray missing.
        KeyboardInterrupt: after Ctrl-C; every finished chunk is on disk, resume with ``resume=True``.
    """
    from jaxstiff.runtime._x64 import enable_x64

    _check_backend(backend)
    if log is None:
        log = (lambda s: print(s, file=sys.stderr, flush=True)) if progress else (lambda s: None)
    plan = _plan_of(config)
    enable_x64()
    cache_dir = _cache_dir(compile_cache)
    t0 = time.perf_counter()
    store = SweepStore(out, plan, resume=resume)
    try:
        skipped = tuple(sorted(store.done))
        log(plan.describe())
        if skipped:
            log(f"resuming: {len(skipped)} of {len(plan.chunks)} chunks already finished in {store.out}")
        computed = _compute(
            plan,
            store,
            backend=backend,
            progress=progress,
            log=log,
            on_commit=on_commit,
            address=address,
            ray_init=ray_init,
            cache_dir=cache_dir,
        )
        table_file = _assemble(plan, store, report, log)
    finally:
        store.close()
    return SweepOutcome(
        out=store.out,
        table_file=table_file,
        n_rows=plan.n_rows,
        n_chunks=len(plan.chunks),
        computed=tuple(computed),
        skipped=skipped,
        wall_s=time.perf_counter() - t0,
        plan=plan,
    )
