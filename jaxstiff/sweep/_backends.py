"""Where a sweep's chunks run, how their progress is shown, and the persistent compilation cache.

Backends. ``"local"`` runs the chunks one after another in this process. ``"ray"`` submits each
chunk as a Ray task (``ray.init(address=...)``, extra ``jaxstiff[dist]``); the workers get the plan
(robot and paths included, no files needed) and return rows and arrays, which the driver writes to
the same store as they arrive (:mod:`jaxstiff.sweep._run` says what makes both tables equal).

Compilation. Every process compiles a group's kernel once; :func:`enable_compile_cache` turns on
JAX's persistent compilation cache (:func:`default_cache_dir`), so a resumed run, Ray workers on
the same host and later sweeps of the same shapes load the compiled code.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping
from typing import Any

from jaxstiff.runtime._compile_cache import default_cache_dir as default_cache_dir
from jaxstiff.runtime._compile_cache import enable_compile_cache as runtime_enable_compile_cache
from jaxstiff.runtime._progress import Progress as _Bar
from jaxstiff.sweep._chunks import compute_chunk
from jaxstiff.sweep._plan import Chunk, SweepPlan
from jaxstiff.sweep._store import SweepStore

__all__ = ["RAY_MAX_RETRIES", "ray_task", "default_cache_dir"]

BACKENDS = ("local", "ray")
#: how often Ray reruns a chunk whose worker process died (Ray's own default, made explicit)
RAY_MAX_RETRIES = 3


class ChunkLostError(RuntimeError):
    """A chunk whose Ray worker died more than :data:`RAY_MAX_RETRIES` times; the committed chunks
    stay, and ``--resume`` finishes the sweep."""


OnCommit = Callable[[int], None] | None


class Progress:
    """A sweep's progress on stderr (:mod:`jaxstiff.runtime._progress`: a tqdm bar on a terminal,
    otherwise a plain line every 10 s and at the end).

    Counts work in waypoints (rollout steps) as they are solved, so the ETA moves inside long
    chunks; the note says the rows and chunks *saved* (a chunk's waypoints can all be solved while
    its result is still being written: an interrupt then redoes that chunk on ``--resume``). A
    resumed run starts at the finished chunks' share.
    """

    def __init__(
        self, name: str, plan: SweepPlan, done_chunks: Iterable[int], enabled: bool = True, stream: Any = None
    ):
        done = list(done_chunks)
        self.chunk_units = {c.id: sum(plan.row_trajectory(r).P for r in c.rows) for c in plan.chunks}
        self.total_rows, self.total_chunks = plan.n_rows, len(plan.chunks)
        self.rows_done = sum(len(plan.chunks[c].rows) for c in done)
        self.chunks_done = len(done)
        self.inflight = 0.0
        self.bar = _Bar(
            sum(self.chunk_units.values()),
            name,
            "waypoints",
            initial=sum(self.chunk_units[c] for c in done),
            enabled=enabled,
            file=stream,
            log_every=10.0,
        )
        self.bar.set_note(self._note())

    def _note(self) -> str:
        return f"saved: rows {self.rows_done}/{self.total_rows}, chunks {self.chunks_done}/{self.total_chunks}"

    def tick(self, units: float = 1.0) -> None:
        """``units`` more waypoints of the chunk in flight are done."""
        self.inflight += units
        self.bar.update(units)

    def chunk_done(self, chunk_id: int, rows: int) -> None:
        """A chunk is committed: count the rest of its waypoints, its rows and itself."""
        self.rows_done += rows
        self.chunks_done += 1
        self.bar.update(self.chunk_units[chunk_id] - self.inflight, note=self._note())
        self.inflight = 0.0

    def close(self) -> None:
        """End the bar (safe to call twice)."""
        self.bar.close()


# ---------------------------------------------------------------------------- backends
def run_local(plan: SweepPlan, todo: Iterable[Chunk], store: SweepStore, prog: Progress, on_commit: OnCommit) -> None:
    """Compute ``todo`` one chunk after another in this process, committing each."""
    for c in todo:
        payload = compute_chunk(plan, c.id, progress=prog.tick)
        store.commit(payload)
        prog.chunk_done(c.id, len(payload["rows"]))
        if on_commit is not None:
            on_commit(c.id)


def ray_task(plan: SweepPlan, chunk_id: int, cache_dir: str | None = None) -> dict:
    """What a Ray worker runs: one chunk (x64 on, like every jaxstiff entry point), with the
    driver's compilation cache folder when given (a worker that cannot create it runs without)."""
    if cache_dir:
        enable_compile_cache(cache_dir)
    return compute_chunk(plan, chunk_id)


def import_ray() -> Any:
    """The ``ray`` module, or a ValueError saying how to install it."""
    try:
        import ray
    except ImportError:
        raise ValueError("--backend ray needs the 'ray' package: pip install 'jaxstiff[dist]'") from None
    return ray


def run_ray(
    plan: SweepPlan,
    todo: Iterable[Chunk],
    store: SweepStore,
    prog: Progress,
    on_commit: OnCommit,
    address: str | None,
    ray_init: Mapping[str, Any] | None,
    cache_dir: str | None,
) -> None:
    """Submit every chunk of ``todo`` as a Ray task and commit the results as they arrive (a Ray
    instance started here is shut down at the end; unfinished tasks are cancelled)."""
    ray = import_ray()
    started = False
    if not ray.is_initialized():
        kw = {"include_dashboard": False, "log_to_driver": False, **dict(ray_init or {})}
        if address:
            kw["address"] = address
        ray.init(**kw)
        started = True
    pending: dict = {}
    try:
        # a worker process that dies mid-chunk (killed, out of memory, node lost) is retried on
        # another worker up to RAY_MAX_RETRIES times; the chunk's result is deterministic, so the table
        # is that of an uninterrupted run (tests/sweep/test_sweep_ray_lost_worker.py)
        task = ray.remote(num_cpus=1, max_retries=RAY_MAX_RETRIES)(ray_task)
        plan_ref = ray.put(plan)
        pending = {task.remote(plan_ref, c.id, cache_dir): c.id for c in todo}
        while pending:
            ready, _ = ray.wait(list(pending), num_returns=1)
            for ref in ready:
                cid = pending.pop(ref)
                try:
                    payload = ray.get(ref)
                except ray.exceptions.WorkerCrashedError as e:  # retries exhausted
                    raise ChunkLostError(
                        f"chunk {cid}: its Ray worker died {RAY_MAX_RETRIES + 1} times ({type(e).__name__}); "
                        "the chunks committed so far are kept: run the same command with --resume to finish"
                    ) from None
                store.commit(payload)
                prog.chunk_done(cid, len(payload["rows"]))
                if on_commit is not None:
                    on_commit(cid)
    finally:
        for ref in pending:
            try:
                ray.cancel(ref, force=True)
            except Exception:  # noqa: BLE001 - best effort on the way out
                pass
        if started:
            ray.shutdown()


# ---------------------------------------------------------------------------- compile cache
def enable_compile_cache(path: str | None) -> str | None:
    """Turn on JAX's persistent compilation cache in ``path`` for a sweep
    (:func:`jaxstiff.runtime._compile_cache.enable_compile_cache`; programs compiling under 2 s are not stored).

    With the cache, a resumed run, the Ray workers of one host and the next sweep of the same
    shapes load a group's compiled code instead of compiling it again (measured timings:
    docs/notes/sweep.md). Returns the folder in use (None: no cache).
    """
    return runtime_enable_compile_cache(path, min_compile_s=2.0)
