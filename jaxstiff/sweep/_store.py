"""The on-disk store of a sweep: atomic chunk files, a manifest, a lock, and the assembled table.

Layout of ``--out DIR``::

    DIR/config.toml              the config as given (empty for a dict config)
    DIR/plan.json                plan hash, kind, name, rows, groups, chunks (what "resume" checks)
    DIR/arrays/chunk-000012-0.npz  per-waypoint arrays of chunk 12, one file per batched call
                                 (shape: the ShapeResult file format; csc: the CSCResult arrays)
    DIR/chunks/chunk-000012.json the rows of chunk 12 (settings + metrics): the commit point
    DIR/manifest.json            finished chunks with wall time, worker and run; the runs
    DIR/results.parquet          the table, one row per (trajectory x setting), sorted by row_id
    DIR/timing.csv               wall time per chunk (kept out of the table: timing is not a result)
    DIR/summary.md, DIR/plots/   the report
    DIR/.lock                    held (filelock) while a sweep writes here; DIR/.lock.owner says who
                                 (removed when the run ends; one left by a killed run is stale)

Crash safety: every file is written to a temporary file in the same folder and renamed onto its
name (``os.replace``, atomic on POSIX), so a reader never sees a partial file. A chunk's arrays are
written first and its rows file last, so a rows file on disk means the chunk is complete; the
manifest is rewritten after it and is reconciled with the rows files on resume (a kill between the
two loses nothing). Temporary files left by a kill are removed when the store is opened again.

Damage: on resume every rows file is checked with the array files its rows point to
(:mod:`jaxstiff.sweep._stored`: its columns typed and equal to the plan's settings, the array files
read by the one result reader, each row's metrics recomputed from them); a damaged or tampered one
is refused naming the file and the field (delete the rows file to recompute that chunk). A damaged
``manifest.json`` (a log) is made again from the rows files, with a warning.

The table is assembled from the rows files sorted by ``row_id``; it holds no timing, so an
interrupted and resumed sweep gives the same table as an uninterrupted one.
"""

from __future__ import annotations

import contextlib
import datetime
import glob
import json
import os
import socket
import warnings
from collections.abc import Mapping
from typing import Any

from jaxstiff.runtime._export_cache import code_fingerprint
from jaxstiff.runtime._io import atomic_write, atomic_write_text
from jaxstiff.runtime._io import json_default as _json_default
from jaxstiff.sweep._axes import AXES
from jaxstiff.sweep._plan import SweepPlan, hashed_config
from jaxstiff.sweep._table import read_table as read_table
from jaxstiff.sweep._table import rows_csv, table_frame

__all__ = ["read_table", "atomic_write_text", "FORMAT"]

FORMAT = "jaxstiff.sweep/1"
LOCK_FILE = ".lock"  #: held while a sweep writes into the folder
OWNER_FILE = ".lock.owner"  #: who holds it (pid, host, since when), for the refusal message


def _json(obj: Any) -> str:
    return json.dumps(obj, indent=1, sort_keys=True, default=_json_default)


def _now() -> str:
    return datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="milliseconds")


class SweepStore:
    """Open (create or resume) the store of a plan in ``out``.

    Args:
        out: the folder.
        plan: the validated plan.
        resume: continue a sweep already in ``out`` (same plan); without it an existing sweep
            in ``out`` is an error.

    Raises:
        ValueError: ``out`` holds another sweep (different config), holds this sweep and
            ``resume`` is False, is a non-empty folder without a sweep, or another process is
            writing to it.
    """

    def __init__(self, out: str | os.PathLike, plan: SweepPlan, resume: bool = False):
        self.out = os.path.abspath(os.fspath(out))
        self.plan = plan
        if os.path.exists(self.out) and not os.path.isdir(self.out):
            raise ValueError(f"--out {self.out}: exists and is not a folder")
        # a folder that is not a sweep store is refused before anything (even the lock) is written into it
        self._check_foreign()
        created = self._make_folder()
        self._lock_obj: Any = None
        try:
            self._lock()
            self._open(resume)
        except BaseException:
            # refused or interrupted before the store existed: leave nothing behind, but only what
            # this process made and holds (a sweep started at the same moment on the same new
            # folder may hold the lock: its lock, owner record and folder are its own)
            mine = created and self._lock_obj is not None
            if mine:
                for f in (OWNER_FILE, LOCK_FILE):
                    with contextlib.suppress(OSError):
                        os.unlink(self.path(f))
            self.close()
            if mine:
                with contextlib.suppress(OSError):
                    os.rmdir(self.out)
            raise

    def _make_folder(self) -> bool:
        """Make the output folder; True if this call made it (``os.mkdir`` is atomic: of two
        processes starting on the same new folder, one only)."""
        parent = os.path.dirname(self.out)
        if parent:
            os.makedirs(parent, exist_ok=True)
        try:
            os.mkdir(self.out)
        except FileExistsError:
            if not os.path.isdir(self.out):
                raise ValueError(f"--out {self.out}: exists and is not a folder") from None
            return False
        return True

    def _check_foreign(self) -> None:
        if not os.path.isdir(self.out) or os.path.isfile(self.path("plan.json")):
            return
        # the lock, its owner record and the temporary file that record is written through
        # (another sweep taking the lock on a new folder at this moment) are not foreign
        others = [f for f in os.listdir(self.out) if f not in (LOCK_FILE, OWNER_FILE) and not f.startswith(".tmp-")]
        if {"chunks", "arrays"} & set(others):
            raise ValueError(
                f"--out {self.out} holds a sweep's chunks but no plan.json (the sweep's plan); it is not a usable "
                "sweep store: choose an empty or new folder"
            )
        if others:
            raise ValueError(
                f"--out {self.out} is not empty and holds no sweep (found {sorted(others)[:3]}); choose an empty or new folder"
            )

    # ------------------------------------------------------------------ paths
    def path(self, *parts: str) -> str:
        return os.path.join(self.out, *parts)

    def rows_file(self, chunk_id: int) -> str:
        return self.path("chunks", f"chunk-{chunk_id:06d}.json")

    def array_name(self, chunk_id: int, k: int) -> str:
        return f"arrays/chunk-{chunk_id:06d}-{k}.npz"

    # ------------------------------------------------------------------ open / lock
    def _lock(self) -> None:
        """Hold ``.lock`` (filelock: flock on POSIX, msvcrt on Windows) and say who holds it in ``.lock.owner``."""
        from filelock import FileLock, Timeout

        lock = FileLock(self.path(LOCK_FILE), timeout=0)
        try:
            lock.acquire()
        except Timeout:
            try:
                with open(self.path(OWNER_FILE), encoding="utf-8") as fh:
                    who = fh.readline().strip()  # the first line: pid, host, since
            except OSError:
                who = ""
            raise ValueError(
                f"another jaxstiff sweep is writing to {self.out} ({who or 'unknown process'}); "
                "wait for it or choose another --out"
            ) from None
        self._lock_obj = lock
        atomic_write_text(
            self.path(OWNER_FILE),
            f"pid {os.getpid()} on {socket.gethostname()} since {_now()}\n"
            "(removed when that run ends; left by a killed run it is stale and harmless: the OS freed the lock)\n",
        )

    def close(self) -> None:
        """Release the lock (also released by the OS if the process dies) and remove ``.lock.owner``
        first, while the lock is still held (a record left by a killed run is overwritten by the
        next run that takes the lock, and says that it is stale)."""
        if self._lock_obj is not None:
            with contextlib.suppress(OSError):
                os.unlink(self.path(OWNER_FILE))
            with contextlib.suppress(OSError):
                self._lock_obj.release()
            self._lock_obj = None

    def __enter__(self) -> SweepStore:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def _open(self, resume: bool) -> None:
        plan = self.plan
        plan_file = self.path("plan.json")
        if os.path.isfile(plan_file):
            from jaxstiff.sweep._stored import load_record

            try:
                old = load_record(plan_file, "sweep plan (plan.json)")
            except ValueError as exc:
                raise ValueError(f"{exc}; this folder is not a usable sweep store") from None
            if old.get("plan_hash") != plan.plan_hash:
                self._refuse_other_plan(plan_file, old)
            if resume:
                _warn_other_code(self.out, old)
            # without --resume only a store with no chunk done (a run stopped while it set the store
            # up: nothing to lose) runs again; the chunks are scanned once more below either way
            n = 0 if resume else len(self._scan_done())
            if n:
                raise ValueError(
                    f"--out {self.out} already holds this sweep ({n} of {len(plan.chunks)} chunks done); "
                    "pass --resume (resume=True in Python) to continue it, or choose another --out"
                )
        else:
            self._check_foreign()  # again under the lock: another process may have written meanwhile
            if resume:  # said, not refused: "run or continue" scripts pass it every time
                warnings.warn(
                    f"resume: {self.out} holds no sweep yet (no plan.json), so nothing is resumed and the sweep "
                    "starts from its first chunk; if you meant to continue an earlier sweep, check its folder's name",
                    stacklevel=3,
                )
            for sub in ("chunks", "arrays"):
                os.makedirs(self.path(sub), exist_ok=True)
            if plan.config_text:
                atomic_write_text(self.path("config.toml"), plan.config_text)
            atomic_write_text(plan_file, _json(self._plan_record()))
        for sub in ("chunks", "arrays"):
            os.makedirs(self.path(sub), exist_ok=True)
        self._clean_temporaries()
        self.done: dict[int, dict] = self._scan_done()
        self.manifest = self._load_manifest()
        self.run_index = len(self.manifest["runs"])
        self.manifest["runs"].append(
            {
                "run": self.run_index,
                "started": _now(),
                "host": socket.gethostname(),
                "pid": os.getpid(),
                "OMP_NUM_THREADS": os.environ.get("OMP_NUM_THREADS"),
                "skipped": sorted(self.done),
                "computed": [],
            }
        )
        self._write_manifest()

    def _refuse_other_plan(self, plan_file: str, old: dict) -> None:
        """Why ``plan.json`` (its record ``old``) is not this sweep: a renamed sweep, a changed config,
        or a plan hash that the config does not explain."""
        plan = self.plan
        cfg = old.get("config")
        cfg = cfg if isinstance(cfg, dict) and all(isinstance(cfg.get(k, {}), dict) for k in ("robot", "sweep")) else {}
        paths = cfg.get("paths", [])
        if not (isinstance(paths, list) and all(isinstance(p, dict) for p in paths)):
            cfg = {}
        # (only what the hash sees: a moved file is no change)
        diff = _config_diff(hashed_config(cfg), hashed_config(plan.config)) if cfg else ""
        if diff and set(diff.split(", ")) <= {"sweep.name", "sweep.description"}:
            was = cfg.get("sweep", {})
            changed = []
            if "sweep.name" in diff:
                changed.append(
                    f"sweep.name {was.get('name')!r}, now {plan.name!r}; the name defaults to the config's file name, "
                    "so a renamed file changes it"
                )
            if "sweep.description" in diff:
                now = (plan.config.get("sweep") or {}).get("description", "")
                changed.append(f"sweep.description {was.get('description', '')!r}, now {now!r}")
            sets = [f"name = {json.dumps(was.get('name'))}"] if "sweep.name" in diff else []
            if "sweep.description" in diff:
                sets.append(f"description = {json.dumps(was.get('description', ''))}")
            raise ValueError(
                f"--out {self.out} holds this sweep under another label ({'; '.join(changed)}): "
                f"set {' and '.join(sets)} in [sweep] to continue it, or use a new --out"
            )
        if diff:
            raise ValueError(
                f"--out {self.out} holds a different sweep ({old.get('name')!r}, plan {str(old.get('plan_hash'))[:12]}); "
                f"changed: {diff}. Use a new --out for a changed config"
            )
        why = (
            "the robot's or the paths' data changed, or the file was edited" if cfg else "its config record is damaged"
        )
        raise ValueError(
            f"{plan_file}: plan_hash: expected {plan.plan_hash[:12]}... (this config's plan), found "
            f"{str(old.get('plan_hash'))[:12]!r} ({why}); use a new --out"
        )

    def _plan_record(self) -> dict:
        p = self.plan
        return {
            "format": FORMAT,
            "plan_hash": p.plan_hash,
            "name": p.name,
            "kind": p.kind,
            "n_rows": p.n_rows,
            "n_chunks": len(p.chunks),
            "groups": list(p.groups),
            "chunks": [
                {"id": c.id, "group": c.group, "rows": [c.rows[0], c.rows[-1]], "n": len(c.rows)} for c in p.chunks
            ],
            "config": p.config,
            "source": os.path.abspath(p.source) if p.source else "",
            "created": _now(),
            # the code that computes the chunks: a resume by other code is said (_warn_other_code)
            "jaxstiff_version": _version(),
            "code_sha256": code_fingerprint(),
        }

    def _clean_temporaries(self) -> None:
        for folder in (self.out, self.path("chunks"), self.path("arrays"), self.path("plots")):
            for f in glob.glob(os.path.join(folder, ".tmp-*")):
                with contextlib.suppress(OSError):
                    os.unlink(f)

    def _scan_done(self) -> dict[int, dict]:
        """Finished chunks: every rows file, checked with the array files it points to
        (:mod:`jaxstiff.sweep._stored`: types, this plan's settings, metrics recomputed from the arrays)."""
        from jaxstiff.sweep._chunks import base_row
        from jaxstiff.sweep._stored import check_rows_arrays, check_rows_record, load_record

        plan = self.plan
        done = {}
        for f in sorted(glob.glob(self.path("chunks", "chunk-*.json"))):
            name = os.path.basename(f)
            cid = int(name[6:-5]) if name[6:-5].isdigit() else -1
            if not 0 <= cid < len(plan.chunks) or name != os.path.basename(self.rows_file(cid)):
                raise ValueError(f"{f}: not a chunk of this sweep (it has chunks 0..{len(plan.chunks) - 1}); delete it")
            chunk = plan.chunks[cid]
            try:
                rec = load_record(f, "sweep rows file")
                rows = check_rows_record(
                    f,
                    rec,
                    plan.kind,
                    plan_hash=plan.plan_hash,
                    chunk_id=cid,
                    row_ids=list(chunk.rows),
                    expected={r: base_row(plan, chunk, r) for r in chunk.rows},
                )
                check_rows_arrays(
                    self.out,
                    f,
                    rows,
                    plan.kind,
                    plan_hash=plan.plan_hash,
                    alpha_tol_deg=plan.alpha_tol_deg,
                    ratio_rel_tol=plan.ratio_rel_tol,
                )
            except (ValueError, FileNotFoundError) as exc:
                raise ValueError(f"{exc}; delete {f} to recompute chunk {cid}") from None
            done[cid] = rec
        return done

    def _load_manifest(self) -> dict:
        from jaxstiff.sweep._stored import load_record, manifest_problem

        f = self.path("manifest.json")
        man = {"format": FORMAT, "plan_hash": self.plan.plan_hash, "chunks": {}, "runs": []}
        if os.path.exists(f):
            try:
                old: Any = load_record(f, "sweep manifest")
                problem = manifest_problem(old, self.plan.plan_hash)
            except ValueError as exc:
                old, problem = None, str(exc)
            if problem is None:
                man.update({"chunks": old["chunks"], "runs": old["runs"]})
            else:  # a log, not a result: made again from the rows files (the run history is lost)
                warnings.warn(
                    f"{f}: {problem.removeprefix(f + ': ')}; made again from the chunks' rows files", stacklevel=2
                )
        # the rows files are the truth: drop entries without one, add those missing
        man["chunks"] = {k: v for k, v in man["chunks"].items() if int(k) in self.done}
        for cid, rec in self.done.items():
            man["chunks"].setdefault(
                str(cid),
                {
                    "wall_s": rec.get("wall_s"),
                    "finished": rec.get("finished"),
                    "worker": rec.get("worker"),
                    "devices": rec.get("devices"),
                    "run": None,
                },
            )
        return man

    def _write_manifest(self) -> None:
        self.manifest["n_chunks"] = len(self.plan.chunks)
        self.manifest["n_done"] = len(self.done)
        atomic_write_text(self.path("manifest.json"), _json(self.manifest))

    # ------------------------------------------------------------------ commit
    def commit(self, payload: dict) -> None:
        """Write one finished chunk: its array files, then its rows file, then the manifest.

        Args:
            payload: from :func:`jaxstiff.sweep._run.compute_chunk`: ``chunk``, ``rows`` (list of
                dicts), ``arrays`` (list of ``(relative name, data)``: a
                :class:`~jaxstiff.results.ShapeResult` or a dict of arrays), ``wall_s``,
                ``worker``, ``devices``.
        """
        from jaxstiff.results._files import ShapeResult, atomic_save_npz

        cid = int(payload["chunk"])
        for name, data in payload["arrays"]:
            if isinstance(data, ShapeResult):
                data.save(self.path(name))
            else:
                atomic_save_npz(self.path(name), data)
        rec = {
            "format": FORMAT,
            "plan_hash": self.plan.plan_hash,
            "chunk": cid,
            "group": self.plan.chunks[cid].group,
            "rows": payload["rows"],
            "wall_s": payload["wall_s"],
            "finished": _now(),
            "worker": payload.get("worker", ""),
            "devices": payload.get("devices", 1),
        }
        atomic_write_text(self.rows_file(cid), _json(rec))
        self.done[cid] = rec
        self.manifest["chunks"][str(cid)] = {
            "wall_s": rec["wall_s"],
            "finished": rec["finished"],
            "worker": rec["worker"],
            "devices": rec["devices"],
            "run": self.run_index,
        }
        self.manifest["runs"][-1]["computed"].append(cid)
        self._write_manifest()

    def finish_run(self, status: str) -> None:
        self.manifest["runs"][-1]["ended"] = _now()
        self.manifest["runs"][-1]["status"] = status
        self._write_manifest()

    # ------------------------------------------------------------------ assembly
    def columns(self) -> list[str]:
        from jaxstiff.sweep._metrics import METRICS

        k = self.plan.kind
        return (
            ["row_id", "chunk", "group", "path", "path_index", "P"]
            + list(AXES[k])
            + ["q0_ik_error_m"]
            + list(METRICS[k])
            + ["result_file", "result_index"]
        )

    def rows(self) -> list[dict]:
        """All finished rows, sorted by row_id."""
        out = [r for rec in self.done.values() for r in rec["rows"]]
        out.sort(key=lambda r: r["row_id"])
        return out

    def assemble(self) -> str:
        """Write ``results.parquet`` (or ``results.csv`` without pyarrow) and ``timing.csv``; return the table file.

        Raises:
            ValueError: chunks are missing (the sweep is not finished).
        """
        missing = [c.id for c in self.plan.chunks if c.id not in self.done]
        if missing:
            raise ValueError(
                f"{len(missing)} chunks are not finished yet (first: {missing[0]}); run again with --resume"
            )
        rows = self.rows()
        cols = self.columns()
        timing = ["chunk,rows,wall_s,devices,worker,finished"]
        for cid in sorted(self.done):
            rec = self.done[cid]
            timing.append(
                f"{cid},{len(rec['rows'])},{rec['wall_s']!r},{rec.get('devices', 1)},{rec.get('worker', '')},{rec['finished']}"
            )
        atomic_write_text(self.path("timing.csv"), "\n".join(timing) + "\n")
        try:
            import pandas as pd  # noqa: F401  (used by table_frame)
            import pyarrow  # noqa: F401
        except ImportError:
            f = self.path("results.csv")
            atomic_write_text(f, rows_csv(rows, cols))
            return f
        df = table_frame(rows, cols, self.plan.kind)
        f = self.path("results.parquet")
        return atomic_write(f, lambda fh: df.to_parquet(fh, index=False), binary=True)


def _config_diff(old: dict, new: dict, prefix: str = "") -> str:
    keys = []
    for k in sorted(set(old) | set(new)):
        a, b = old.get(k), new.get(k)
        if isinstance(a, dict) and isinstance(b, dict):
            sub = _config_diff(a, b, f"{prefix}{k}.")
            if sub:
                keys.append(sub)
        elif json.dumps(a, sort_keys=True, default=str) != json.dumps(b, sort_keys=True, default=str):
            keys.append(f"{prefix}{k}")
    return ", ".join(keys)


def _version() -> str:
    from jaxstiff.runtime._version import __version__

    return __version__


def _warn_other_code(out: str, old: Mapping[str, Any]) -> None:
    """Resuming a store whose first chunks other jaxstiff code computed (its ``code_sha256``): said,
    not refused (a fix may be why the sweep is resumed), since the table then mixes two versions."""
    was = old.get("code_sha256")
    if not isinstance(was, str) or was == code_fingerprint():
        return
    warnings.warn(
        f"resume: the jaxstiff code differs from the code that started the sweep in {out} (version "
        f"{old.get('jaxstiff_version', '?')} then, {_version()} now; its source files changed): the chunks done "
        "before and after this resume come from different code; to have one version throughout, run the "
        "sweep into a new folder",
        stacklevel=4,
    )
