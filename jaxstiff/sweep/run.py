"""Parameter sweeps: a TOML grid of settings x trajectories, solved in batches, resumable.

``run_sweep(config, out)`` (CLI: ``jaxstiff sweep CONFIG.toml --out DIR``) reads and validates the
config (:mod:`jaxstiff.sweep_config`: every problem is reported before any work starts), opens the
store in ``out`` (:mod:`jaxstiff.sweep_store`), computes every chunk that is not finished yet, and
assembles the results table (one row per trajectory x setting, Parquet), ``summary.md`` and heat
maps (:mod:`jaxstiff.sweep_report`). The table's columns: ``row_id, chunk, group, path,
path_index, P``, one per axis of the kind (:data:`jaxstiff.sweep_config.AXES`), ``q0_ik_error_m``
(the start posture's IK error, NaN where it is not an IK solution), the metrics
(:data:`jaxstiff.sweep_metrics.METRICS`), and ``result_file, result_index`` (where the row's
per-waypoint arrays are).

Batching. A chunk is a run of rows of one group (rows that share the static settings and the
number of waypoints, so one compiled kernel serves the whole group):

* kind ``"shape"``: the chunk's rows with the same numeric setting form one call of
  :func:`jaxstiff.shape` over a batch of paths (leading axis B), with per-path start postures;
  its per-waypoint arrays go to one result file (:meth:`~jaxstiff.results.ShapeResult.save`).
* kind ``"csc"``: the whole chunk is one call of :func:`jaxstiff.csc_rollout`: paths, K_xd, beta and
  q0 differ per row along one batch axis. The batch is padded to the chunk size (one compilation
  for every chunk of a group) and sharded across all local JAX devices
  (:func:`shard_batch`, ``jax.sharding.NamedSharding`` over a 1-D mesh), so XLA splits it between
  the devices (GPUs, or CPU devices from ``XLA_FLAGS=--xla_force_host_platform_device_count=N``).
  The per-waypoint SLSQP of ``shape`` is a host loop and does not shard.

Backends. ``"local"`` runs the chunks one after another in this process. ``"ray"`` submits each
chunk as a Ray task (``ray.init(address=...)``, extra ``jaxstiff[dist]``); the workers get the plan
(robot and paths included, no files needed) and return rows and arrays, which the driver writes to
the same store as they arrive. Both give the same table: a row's result depends only on its inputs
and on the numeric environment. One caveat there: Ray workers run with ``OMP_NUM_THREADS=1``, and
a different thread count (read by numpy's OpenBLAS when it loads) changes the last digits of the
linear algebra, which an optimiser can amplify (an audit measured up to 0.02 rad in q and one
status change between a local and a Ray run of the same SLSQP rows; a local run with
``OMP_NUM_THREADS=1`` gave the Ray table exactly). For bit-identical
tables across backends, machines and resumes, run every part with the same ``OMP_NUM_THREADS``
(``OMP_NUM_THREADS=1 jaxstiff sweep ...`` matches Ray's workers); each run's setting is recorded in
``manifest.json``.

Compilation. Every process compiles a group's kernel once (pgd on the LWR: about 100 s on a busy
2-core CPU). ``run_sweep`` turns on JAX's persistent compilation cache (``~/.cache/jaxstiff/xla``,
see :func:`default_cache_dir`), so a resumed run, Ray workers on the same host and later sweeps of
the same shapes load the compiled code.

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
import json
import math
import os
import socket
import sys
import time
import warnings
from typing import Any, Callable, Mapping

import numpy as np

from jaxstiff.runtime.io import json_default as _json_default

from jaxstiff.sweep.config import SweepPlan, kxd_matrix, load_config, parse_config
from jaxstiff.sweep.metrics import csc_row_metrics, shape_row_metrics
from jaxstiff.sweep.store import SweepStore, read_table

__all__ = [
    "run_sweep",
    "SweepOutcome",
    "compute_chunk",
    "start_posture",
    "shard_batch",
    "read_table",
    "load_config",
    "BACKENDS",
    "default_cache_dir",
    "enable_compile_cache",
]

BACKENDS = ("local", "ray")


# ---------------------------------------------------------------------------- start postures
_Q0_CACHE: dict[tuple, tuple[np.ndarray, float]] = {}


def start_posture(plan: SweepPlan, row_id: int) -> np.ndarray:
    """The start posture q0 (n,) rad of a row, from its q0 family (see :mod:`jaxstiff.sweep_config`).

    ``"ik"``: damped least-squares IK from the nominal posture to the path's first waypoint
    (x, y only for task ``"xy"``); ``"nominal"``: the nominal posture; ``"random"``: IK from a
    posture drawn uniformly inside the joint limits (``[-pi, pi]`` for continuous joints) with
    ``numpy.random.default_rng([seed, q0_seed, path_index])``; a list: that posture.

    An IK that ends more than :data:`IK_TOL_M` from the waypoint is retried from up to
    :data:`IK_RETRIES` further postures drawn the same way (for ``"random"`` the same generator
    continues; for ``"ik"`` ``default_rng([seed, path_index, 1])``), and the closest result is
    kept; if none reaches it, a warning names the path. The remaining distance of every row is
    the table column ``q0_ik_error_m`` (NaN for ``"nominal"`` and given postures).
    """
    return _start_posture(plan, row_id)[0]


#: IK distance (m) above which a start posture counts as not reaching the first waypoint
IK_TOL_M = 1e-4
#: further IK starts tried before a start posture is given up as not reaching the waypoint
IK_RETRIES = 8


def _start_posture(plan: SweepPlan, row_id: int) -> tuple[np.ndarray, float]:
    """``(q0, IK distance to the first waypoint in m, NaN without IK)`` of a row (:func:`start_posture`)."""
    from jaxstiff.ik import ik_position, nominal_posture

    st = plan.row_settings(row_id)
    traj = plan.row_trajectory(row_id)
    v = st["q0"]
    robot = plan.robot
    if isinstance(v, list):
        return np.asarray(v, dtype=float), math.nan
    if v == "nominal":
        return nominal_posture(robot), math.nan
    planar = st["task"] == "xy"
    seed_key = st["q0_seed"] if v == "random" else None
    key = (plan.plan_hash, v, seed_key, traj.index, planar)
    if key in _Q0_CACHE:
        q, err = _Q0_CACHE[key]
        return q.copy(), err
    lo = np.where(np.isfinite(robot.lower), robot.lower, -np.pi)
    hi = np.where(np.isfinite(robot.upper), robot.upper, np.pi)

    def draw(rng):
        return np.where(robot.free, rng.uniform(lo, hi), np.nan_to_num(robot.locked_values))

    rng = np.random.default_rng([plan.seed, int(st["q0_seed"]), traj.index]) if v == "random" else None
    q, err = ik_position(robot, traj.points[0], q_start=None if rng is None else draw(rng), planar=planar)
    if not err <= IK_TOL_M:
        rng = rng if rng is not None else np.random.default_rng([plan.seed, traj.index, 1])
        for _ in range(IK_RETRIES):
            q2, e2 = ik_position(robot, traj.points[0], q_start=draw(rng), planar=planar)
            if e2 < err or not math.isfinite(err):
                q, err = q2, e2
            if err <= IK_TOL_M:
                break
        if not err <= IK_TOL_M:
            warnings.warn(
                f"sweep: no start posture found for path {traj.name!r} (q0 = {v!r}"
                + (f", q0_seed = {st['q0_seed']}" if v == "random" else "")
                + f"): the IK ends {err:.3g} m from its first waypoint after {1 + IK_RETRIES} tries; its rows start "
                f"there (table column q0_ik_error_m). Is the waypoint within reach?",
                stacklevel=2,
            )
    if len(_Q0_CACHE) > 10000:
        _Q0_CACHE.clear()
    _Q0_CACHE[key] = (q, err)
    return q.copy(), err


# ---------------------------------------------------------------------------- device sharding
def shard_batch(arrays: Mapping[str, np.ndarray], size: int | None = None) -> tuple[dict[str, Any], int]:
    """Pad arrays along axis 0 and shard them across all local JAX devices (see :mod:`jaxstiff._sharding`)."""
    from jaxstiff.runtime.sharding import shard_rows

    return shard_rows(arrays, size)


# ---------------------------------------------------------------------------- chunks
def _table_settings(st: dict) -> dict:
    out = dict(st)
    if isinstance(out.get("q0"), list):
        out["q0"] = json.dumps(out["q0"])
    return out


def _worker() -> str:
    return f"{socket.gethostname()}:{os.getpid()}"


def compute_chunk(plan: SweepPlan, chunk_id: int, progress: Callable[[int], None] | None = None) -> dict:
    """Compute one chunk; returns the payload :meth:`SweepStore.commit` writes.

    Args:
        plan: the validated plan.
        chunk_id: which chunk.
        progress: ``progress(units)`` with units = waypoints (rollout steps) finished.

    Returns:
        dict with ``chunk``, ``rows`` (one dict per row: row_id, chunk, group, path, path_index, P,
        the settings, q0_ik_error_m, the metrics, result_file, result_index), ``arrays`` (``(name, data)``),
        ``wall_s``, ``worker``, ``devices``.
    """
    from jaxstiff.runtime.x64 import enable_x64

    enable_x64()
    t0 = time.perf_counter()
    chunk = plan.chunks[chunk_id]
    if plan.kind == "shape":
        rows, arrays, devices = _shape_chunk(plan, chunk, progress)
    else:
        rows, arrays, devices = _csc_chunk(plan, chunk, progress)
    return {"chunk": chunk.id, "rows": rows, "arrays": arrays, "wall_s": time.perf_counter() - t0,
            "worker": _worker(), "devices": devices}


def _base_row(plan: SweepPlan, chunk, r: int) -> dict:
    traj = plan.row_trajectory(r)
    return {"row_id": r, "chunk": chunk.id, "group": chunk.group, "path": traj.name, "path_index": traj.index,
            "P": traj.P, **_table_settings(plan.row_settings(r))}


def _shape_chunk(plan: SweepPlan, chunk, progress):
    from jaxstiff.paths import Path
    from jaxstiff.shaping import options_for_solver, shape

    calls: dict[str, list[int]] = {}
    for r in chunk.rows:
        st = plan.row_settings(r)
        key = json.dumps({k: v for k, v in st.items() if k not in ("q0", "q0_seed")}, sort_keys=True)
        calls.setdefault(key, []).append(r)
    rows, arrays = [], []
    for k, rids in enumerate(calls.values()):
        st = plan.row_settings(rids[0])
        trajs = [plan.row_trajectory(r) for r in rids]
        path = Path(np.stack([t.points for t in trajs]), np.stack([t.directions for t in trajs]),
                    name=";".join(t.name for t in trajs))
        starts = [_start_posture(plan, r) for r in rids]
        q0 = np.stack([q for q, _ in starts])
        tick = None if progress is None else (lambda b, p: progress(1))
        name = f"arrays/chunk-{chunk.id:06d}-{k}.npz"
        res = shape(
            plan.robot, path, st["criterion"], st["ratio"], task=st["task"], solver=st["solver"],
            starts=st["starts"] or None, q0=q0, dq=math.radians(st["dq_deg"]), dk=st["dk"], kmin=st["kmin"],
            kmax=st["kmax"], c=st["c"], first_rate_limit=st["first_rate_limit"], first_starts=st["first_starts"],
            options=options_for_solver(st["solver"], plan.options) or None, progress=tick,
            meta_extra={"sweep": {"name": plan.name, "plan_hash": plan.plan_hash, "chunk": chunk.id,
                                  "row_ids": list(rids), "paths": [t.name for t in trajs],
                                  "q0": [_table_settings(plan.row_settings(r))["q0"] for r in rids],
                                  "q0_ik_error_m": [None if math.isnan(e) else e for _, e in starts]}},
        )
        arrays.append((name, res))
        for b, r in enumerate(rids):
            row = _base_row(plan, chunk, r)
            row["q0_ik_error_m"] = starts[b][1]
            row.update(shape_row_metrics(
                res.status[b], res.alpha_deg[b], res.ratio[b], res.criterion[b], res.pos_error[b], res.cms[b],
                res.nfev[b], criterion=st["criterion"], ratio_target=st["ratio"],
                alpha_tol_deg=plan.alpha_tol_deg, ratio_rel_tol=plan.ratio_rel_tol))
            row.update(result_file=name, result_index=b)
            rows.append(row)
    # batched JAX solvers (pgd, hybrid, ...) shard their batch over the local devices; SLSQP is a host loop
    import jax

    devices = 1 if plan.settings[plan.rows[chunk.rows[0]][0]]["solver"] in ("slsqp", "slsqp-fd") else jax.local_device_count()
    return rows, arrays, devices


def _csc_chunk(plan: SweepPlan, chunk, progress):
    from jaxstiff.csc.rollout import csc_rollout
    from jaxstiff.settings.robot import robot_meta as _robot_meta, versions as _versions

    rids = list(chunk.rows)
    g = plan.groups[chunk.group]
    task = g["task"]
    sts = [plan.row_settings(r) for r in rids]
    trajs = [plan.row_trajectory(r) for r in rids]
    starts = [_start_posture(plan, r) for r in rids]
    inputs = {
        "targets": np.stack([t.points for t in trajs]),
        "K_xd": np.stack([kxd_matrix(task, s["kxd_major"], s["kxd_ratio"], s["kxd_angle_deg"]) for s in sts]),
        "q0": np.stack([q for q, _ in starts]),
        "beta": np.array([s["beta"] for s in sts], dtype=float),
    }
    chunk_size = int(plan.config["sweep"]["chunk_size"])
    sharded, _nd = shard_batch(inputs, size=min(chunk_size, max(len(c.rows) for c in plan.chunks)))
    res = csc_rollout(
        plan.robot, sharded["targets"], sharded["K_xd"], sharded["q0"], sharded["beta"], task=task,
        step=g["step"], kmin=g["kmin"], kmax=g["kmax"], newton=int(g["newton"]), joint_limits=g["joint_limits"],
        jl_gain=g["jl_gain"], kxd_varying=False,
    )
    devices = len(res.q.sharding.device_set)
    B = len(rids)
    out = {k: np.asarray(v)[:B] for k, v in res.as_dict().items()}
    if progress is not None:
        progress(sum(t.P for t in trajs))
    name = f"arrays/chunk-{chunk.id:06d}-0.npz"
    meta = {
        "format": "jaxstiff.sweep.csc/1",
        "sweep": {"name": plan.name, "plan_hash": plan.plan_hash, "chunk": chunk.id},
        "robot": _robot_meta(plan.robot),
        "static": {k: v for k, v in g.items() if k != "id"},
        "rows": [_table_settings(s) | {"row_id": r, "path": t.name} for r, s, t in zip(rids, sts, trajs)],
        "units": {"q": "rad", "u": "Nm/rad", "frobenius": "N/m", "tracking_error": "m", "K_xd": "N/m"},
        "versions": _versions(),
    }
    data = {k: (v.astype(np.int64) if k == "status" else v.astype(np.float64)) for k, v in out.items()}
    data.update(row_id=np.asarray(rids, dtype=np.int64), K_xd=inputs["K_xd"], q0=inputs["q0"], beta=inputs["beta"],
                joint_names=np.asarray(plan.robot.joint_names, dtype=str),
                meta=np.asarray(json.dumps(meta, sort_keys=True, default=_json_default)))
    rows = []
    for i, r in enumerate(rids):
        row = _base_row(plan, chunk, r)
        row["q0_ik_error_m"] = starts[i][1]
        row.update(csc_row_metrics(out["u"][i], out["frobenius"][i], out["tracking_error"][i], out["status"][i],
                                   out["u_start"][i], out["frobenius_start"][i]))
        row.update(result_file=name, result_index=i)
        rows.append(row)
    return rows, [(name, data)], devices


# ---------------------------------------------------------------------------- progress
def _hms(s: float) -> str:
    if not math.isfinite(s):
        return "?"
    s = int(round(s))
    return f"{s // 3600}:{s % 3600 // 60:02d}:{s % 60:02d}" if s >= 3600 else f"{s // 60}:{s % 60:02d}"


class Progress:
    """A one-line progress bar with ETA on stderr (no dependency).

    Counts work in waypoints (rollout steps), so the ETA moves inside long chunks. On a terminal
    the line is redrawn in place (at most 5 times a second); otherwise one line is printed at most
    every 10 s and at the end.
    """

    def __init__(self, name: str, plan: SweepPlan, done_chunks, enabled: bool = True, stream=None):
        self.stream = stream if stream is not None else sys.stderr
        self.enabled = enabled
        self.name = name
        units = {c.id: sum(plan.row_trajectory(r).P for r in c.rows) for c in plan.chunks}
        self.chunk_units = units
        self.total_units = sum(units.values())
        self.total_rows = plan.n_rows
        self.total_chunks = len(plan.chunks)
        self.rows_done = sum(len(plan.chunks[c].rows) for c in done_chunks)
        self.chunks_done = len(done_chunks)
        self.units_base = sum(units[c] for c in done_chunks)
        self.units_run = 0.0  # done in this run (committed + in flight)
        self.inflight = 0.0
        self.t0 = time.perf_counter()
        self.last = 0.0
        self.tty = bool(getattr(self.stream, "isatty", lambda: False)())
        self._draw(force=True)

    def tick(self, units: float = 1.0) -> None:
        self.inflight += units
        self.units_run += units
        self._draw()

    def chunk_done(self, chunk_id: int, rows: int) -> None:
        u = self.chunk_units[chunk_id]
        self.units_run += u - self.inflight
        self.inflight = 0.0
        self.rows_done += rows
        self.chunks_done += 1
        self._draw(force=not self.tty)

    def _line(self) -> str:
        done = self.units_base + self.units_run
        frac = done / self.total_units if self.total_units else 1.0
        el = time.perf_counter() - self.t0
        left = self.total_units - done
        eta = el * left / self.units_run if self.units_run > 0 else math.inf
        w = 24
        bar = "#" * int(round(w * frac)) + "-" * (w - int(round(w * frac)))
        return (f"[{self.name}] |{bar}| {100 * frac:5.1f}%  rows {self.rows_done}/{self.total_rows}  "
                f"chunks {self.chunks_done}/{self.total_chunks}  {_hms(el)} elapsed  ETA {_hms(eta if left > 0 else 0.0)}")

    def _draw(self, force: bool = False) -> None:
        if not self.enabled:
            return
        now = time.perf_counter()
        if not force and now - self.last < (0.2 if self.tty else 10.0):
            return
        if not self.tty and not force and now - self.last < 10.0:
            return
        self.last = now
        if self.tty:
            self.stream.write("\r" + self._line() + "\x1b[K")
        else:
            self.stream.write(self._line() + "\n")
        self.stream.flush()

    def close(self) -> None:
        if self.enabled:
            if self.tty:
                self.stream.write("\r" + self._line() + "\x1b[K\n")
            self.stream.flush()


# ---------------------------------------------------------------------------- backends
def _run_local(plan: SweepPlan, todo, store: SweepStore, prog: Progress, on_commit) -> None:
    for c in todo:
        payload = compute_chunk(plan, c.id, progress=prog.tick)
        store.commit(payload)
        prog.chunk_done(c.id, len(payload["rows"]))
        if on_commit is not None:
            on_commit(c.id)


def _ray_task(plan: SweepPlan, chunk_id: int, cache_dir: str | None = None) -> dict:
    """What a Ray worker runs: one chunk (x64 on, like every jaxstiff entry point), with the
    driver's compilation cache folder when given (a worker that cannot create it runs without)."""
    if cache_dir:
        enable_compile_cache(cache_dir)
    return compute_chunk(plan, chunk_id)


def _import_ray():
    try:
        import ray
    except ImportError:
        raise ValueError("--backend ray needs the 'ray' package: pip install 'jaxstiff[dist]'") from None
    return ray


def _run_ray(plan: SweepPlan, todo, store: SweepStore, prog: Progress, on_commit, address, ray_init, cache_dir) -> None:
    ray = _import_ray()
    started = False
    if not ray.is_initialized():
        kw = {"include_dashboard": False, "log_to_driver": False, **dict(ray_init or {})}
        if address:
            kw["address"] = address
        ray.init(**kw)
        started = True
    pending: dict = {}
    try:
        task = ray.remote(num_cpus=1)(_ray_task)
        plan_ref = ray.put(plan)
        pending = {task.remote(plan_ref, c.id, cache_dir): c.id for c in todo}
        while pending:
            ready, _ = ray.wait(list(pending), num_returns=1)
            for ref in ready:
                cid = pending.pop(ref)
                payload = ray.get(ref)
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
def default_cache_dir() -> str | None:
    """Folder of the persistent XLA compilation cache of sweeps, or None when disabled.

    ``$JAXSTIFF_COMPILE_CACHE=0`` disables it; ``$JAXSTIFF_CACHE_DIR`` chooses the folder; default
    ``$XDG_CACHE_HOME/jaxstiff/xla`` (``~/.cache/jaxstiff/xla``).
    """
    if os.environ.get("JAXSTIFF_COMPILE_CACHE", "1").strip().lower() in ("0", "false", "no", "off"):
        return None
    d = os.environ.get("JAXSTIFF_CACHE_DIR")
    if d:
        return d
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return os.path.join(base, "jaxstiff", "xla")


def enable_compile_cache(path: str | None) -> str | None:
    """Turn on JAX's persistent compilation cache in ``path`` (an entry-point setting, like x64).

    A sweep compiles its batched kernels once per process (pgd: about 100 s on a busy 2-core CPU);
    with the cache, a resumed run, the Ray workers of one host and the next sweep of the same
    shapes load the compiled code instead (measured: 100 s -> 23 s for a one-row pgd sweep). The
    cache is keyed by the compiled program, so a stale entry is never used. Left alone if the
    caller already configured a cache. Returns the folder in use (None: no cache).
    """
    import jax

    current = jax.config.jax_compilation_cache_dir
    if current:
        return current
    if not path:
        return None
    try:
        os.makedirs(path, exist_ok=True)
    except OSError:
        return None
    jax.config.update("jax_compilation_cache_dir", path)
    jax.config.update("jax_persistent_cache_min_compile_time_secs", 2.0)
    return path


# ---------------------------------------------------------------------------- run
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

    def table(self):
        """The results table (pandas DataFrame)."""
        return read_table(self.out)


def run_sweep(
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
            or a :class:`~jaxstiff.sweep_config.SweepPlan`.
        out: the store folder (created; must be empty or hold this same sweep).
        resume: continue the sweep in ``out``, skipping its finished chunks.
        backend: ``"local"`` or ``"ray"``.
        address: Ray cluster address (``"auto"``, ``"ray://host:10001"``); default: start a local one.
        ray_init: more ``ray.init`` arguments (e.g. ``{"num_cpus": 2}``).
        progress: draw the progress bar on stderr.
        report: write ``summary.md`` and the heat maps at the end.
        on_commit: called with each chunk id after it is committed (tests use it to interrupt).
        log: where one-line messages go (default: stderr when ``progress``, else nowhere).
        compile_cache: use JAX's persistent compilation cache (:func:`enable_compile_cache`):
            True = :func:`default_cache_dir`, a folder name, or False.

    Returns:
        :class:`SweepOutcome`.

    Raises:
        FileNotFoundError: the config file does not exist.
        ValueError: a bad config (:class:`~jaxstiff.sweep_config.SweepConfigError`), an unusable
            ``out``, an unknown backend or Ray missing.
        KeyboardInterrupt: after Ctrl-C; every finished chunk is on disk, resume with ``resume=True``.
    """
    from jaxstiff.runtime.x64 import enable_x64

    if backend not in BACKENDS:
        raise ValueError(f"unknown backend {backend!r}; choose one of {', '.join(BACKENDS)}")
    if backend == "ray":
        _import_ray()
    if log is None:
        log = (lambda s: print(s, file=sys.stderr, flush=True)) if progress else (lambda s: None)
    if isinstance(config, SweepPlan):
        plan = config
    elif isinstance(config, Mapping):
        plan = parse_config(config, base_dir=os.getcwd(), source="config")
    else:
        plan = load_config(config)
    enable_x64()
    if compile_cache is True:
        cache_dir = default_cache_dir()
    elif compile_cache:
        cache_dir = os.fspath(compile_cache)
    else:
        cache_dir = None
    if cache_dir is not None:
        enable_compile_cache(cache_dir)
    t0 = time.perf_counter()
    store = SweepStore(out, plan, resume=resume)
    computed: list[int] = []
    try:
        skipped = tuple(sorted(store.done))
        todo = [c for c in plan.chunks if c.id not in store.done]
        log(plan.describe())
        if skipped:
            log(f"resuming: {len(skipped)} of {len(plan.chunks)} chunks already finished in {store.out}")

        def committed(cid: int) -> None:
            computed.append(cid)
            if on_commit is not None:
                on_commit(cid)

        prog = Progress(plan.name, plan, store.done.keys(), enabled=progress)
        status = "interrupted"
        try:
            if backend == "local":
                _run_local(plan, todo, store, prog, committed)
            else:
                _run_ray(plan, todo, store, prog, committed, address, ray_init, cache_dir)
            status = "finished"
        except KeyboardInterrupt:
            prog.close()
            log(f"interrupted: {len(store.done)} of {len(plan.chunks)} chunks are saved in {store.out}; "
                "continue with --resume")
            raise
        finally:
            store.finish_run(status)
        prog.close()
        table_file = store.assemble()
        if report:
            from jaxstiff.sweep.report import write_report

            write_report(plan, store.out, manifest=store.manifest)
        log(f"wrote {table_file} ({plan.n_rows} rows)")
    finally:
        store.close()
    return SweepOutcome(out=store.out, table_file=table_file, n_rows=plan.n_rows, n_chunks=len(plan.chunks),
                        computed=tuple(computed), skipped=skipped, wall_s=time.perf_counter() - t0, plan=plan)
