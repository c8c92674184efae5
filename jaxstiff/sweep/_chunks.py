"""Computing one chunk of a sweep: its rows' settings, start postures, the batched solve, metrics.

* kind ``"shape"``: the chunk's rows with the same numeric setting form one call of
  :func:`jaxstiff.shape` over a batch of paths (leading axis B), with per-path start postures;
  its per-waypoint arrays go to one result file (:meth:`~jaxstiff.results.ShapeResult.save`).
* kind ``"csc"``: the whole chunk is one call of :func:`jaxstiff.csc_rollout`: paths, K_xd, beta and
  q0 differ per row along one batch axis, padded to the chunk size (one compilation for every
  chunk of a group) and sharded across all local JAX devices (:func:`shard_batch`).
"""

from __future__ import annotations

import json
import math
import os
import socket
import time
import warnings
from collections.abc import Callable, Mapping
from typing import Any

import numpy as np

from jaxstiff.results._singular import SingularPostureWarning
from jaxstiff.results._target import MissedTargetWarning, UnusableWaypointsWarning
from jaxstiff.runtime._io import json_default
from jaxstiff.settings._shape import SINGLE_START_SOLVERS, ShapeSettings
from jaxstiff.sweep._axes import AXES, kxd_matrix
from jaxstiff.sweep._metrics import csc_row_metrics, shape_row_metrics
from jaxstiff.sweep._plan import Chunk, SweepPlan
from jaxstiff.sweep._starts import start_posture_and_error

__all__ = ["table_settings", "setting_values"]


def shard_batch(arrays: Mapping[str, np.ndarray], size: int | None = None) -> tuple[dict[str, Any], int]:
    """Pad arrays along axis 0 and shard them across all local JAX devices (see :mod:`jaxstiff.runtime._sharding`)."""
    from jaxstiff.runtime._sharding import shard_rows

    return shard_rows(arrays, size)


def table_settings(st: dict) -> dict:
    """A row's settings as table cells (a given posture q0 as its JSON text)."""
    out = dict(st)
    if isinstance(out.get("q0"), list):
        out["q0"] = json.dumps(out["q0"])
    return out


def _worker() -> str:
    return f"{socket.gethostname()}:{os.getpid()}"


def compute_chunk(plan: SweepPlan, chunk_id: int, progress: Callable[[float], None] | None = None) -> dict:
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
    from jaxstiff.runtime._programs import release_if_near_map_limit
    from jaxstiff.runtime._x64 import enable_x64

    enable_x64()
    # a long sweep compiles a program set per setting: let them go before the process nears its
    # limit of memory mappings (past it XLA's compiler crashes; jaxstiff.runtime._programs)
    release_if_near_map_limit()
    t0 = time.perf_counter()
    chunk = plan.chunks[chunk_id]
    if plan.kind == "shape":
        rows, arrays, devices = _shape_chunk(plan, chunk, progress)
    else:
        rows, arrays, devices = _csc_chunk(plan, chunk, progress)
    return {
        "chunk": chunk.id,
        "rows": rows,
        "arrays": arrays,
        "wall_s": time.perf_counter() - t0,
        "worker": _worker(),
        "devices": devices,
    }


def base_row(plan: SweepPlan, chunk: Chunk, r: int) -> dict:
    """The columns of row ``r`` the plan fixes: ids, path, P and the settings (as table cells)."""
    traj = plan.row_trajectory(r)
    return {
        "row_id": r,
        "chunk": chunk.id,
        "group": chunk.group,
        "path": traj.name,
        "path_index": traj.index,
        "P": traj.P,
        **table_settings(plan.row_settings(r)),
    }


def setting_values(kind: str, values: Mapping[str, Any]) -> dict[str, Any]:
    """``{field: value}`` of the settings axes of ``kind`` found in ``values`` (a row's settings or
    a group's static key), each as its field takes it (``dq_deg`` -> ``dq`` in rad, ``starts`` 0 ->
    None: :meth:`AxisSpec.field_value`)."""
    return {a.field: a.field_value(values[n]) for n, a in AXES[kind].items() if a.field and n in values}


def _shape_call(
    plan: SweepPlan, chunk: Chunk, k: int, rids: list[int], progress: Callable[[float], None] | None
) -> tuple:
    """One batched ``shape()`` call over the paths of rows ``rids`` (one setting): ``(name, result, starts)``."""
    from jaxstiff.paths import Path
    from jaxstiff.shaping import run_shape
    from jaxstiff.solvers._base import options_for_solver

    st = plan.row_settings(rids[0])
    trajs = [plan.row_trajectory(r) for r in rids]
    path = Path(
        np.stack([t.points for t in trajs]),
        np.stack([t.directions for t in trajs]),
        name=";".join(t.name for t in trajs),
    )
    starts = [start_posture_and_error(plan, r) for r in rids]
    q0 = np.stack([q for q, _ in starts])
    tick = None if progress is None else (lambda b, p: progress(1))
    name = f"arrays/chunk-{chunk.id:06d}-{k}.npz"
    with warnings.catch_warnings():
        # the sweep's table reports misses per row (share_both): a warning per chunk would be noise
        warnings.simplefilter("ignore", MissedTargetWarning)
        warnings.simplefilter("ignore", UnusableWaypointsWarning)  # the table's usable share and status keep it
        warnings.simplefilter("ignore", SingularPostureWarning)  # meta["singular"] of each chunk keeps it
        res = run_shape(
            plan.robot,
            path,
            settings=ShapeSettings(**setting_values("shape", st)),
            q0=q0,
            options=options_for_solver(st["solver"], plan.options) or None,
            progress=tick,
            meta_extra={
                "sweep": {
                    "name": plan.name,
                    "plan_hash": plan.plan_hash,
                    "chunk": chunk.id,
                    "row_ids": list(rids),
                    "paths": [t.name for t in trajs],
                    "q0": [table_settings(plan.row_settings(r))["q0"] for r in rids],
                    "q0_ik_error_m": [None if math.isnan(e) else e for _, e in starts],
                }
            },
        )
    return name, res, starts


def _split_reach(plan: SweepPlan, rids: list[int], planar: bool) -> tuple[list[int], list[tuple[int, np.ndarray]]]:
    """The rows whose paths lie within the robot's reach, and the others with their (P,) masks of
    waypoints out of reach (:func:`jaxstiff.model._reach.unreachable_mask`; task "xy": in the plane)."""
    from jaxstiff.model._reach import unreachable_mask

    ok, refused = [], []
    for r in rids:
        mask = unreachable_mask(plan.robot, plan.row_trajectory(r).points, planar)
        if mask.any():
            refused.append((r, mask))
        else:
            ok.append(r)
    return ok, refused


def _refused_row(
    plan: SweepPlan, chunk: Chunk, r: int, mask: np.ndarray, st: dict, progress: Callable[[float], None] | None
) -> dict:
    """The table row of a path with waypoints out of the robot's reach: not solved (a sweep over a
    workspace may leave it, so the row is marked, not the sweep refused). Its waypoints out of reach
    count as status 3 (unreachable), the others as 5 (not run); no start posture, no result file
    (``result_file`` "", ``result_index`` -1)."""
    from jaxstiff.results._files import NOT_RUN, UNREACHABLE

    P = mask.shape[0]
    status = np.where(mask, UNREACHABLE, NOT_RUN)
    nan = np.full(P, np.nan)
    row = base_row(plan, chunk, r)
    row["q0_ik_error_m"] = math.nan
    row.update(
        shape_row_metrics(
            status,
            nan,
            nan,
            nan,
            nan,
            nan,
            np.zeros(P),
            criterion=st["criterion"],
            ratio_target=st["ratio"],
            alpha_tol_deg=plan.alpha_tol_deg,
            ratio_rel_tol=plan.ratio_rel_tol,
        )
    )
    row.update(result_file="", result_index=-1)
    if progress is not None:
        progress(P)
    return row


def _shape_chunk(plan: SweepPlan, chunk: Chunk, progress: Callable[[float], None] | None) -> tuple[list, list, int]:
    import jax

    calls: dict[str, list[int]] = {}
    for r in chunk.rows:
        st = plan.row_settings(r)
        key = json.dumps({k: v for k, v in st.items() if k not in ("q0", "q0_seed")}, sort_keys=True)
        calls.setdefault(key, []).append(r)
    rows, arrays = [], []
    for k, all_rids in enumerate(calls.values()):
        st = plan.row_settings(all_rids[0])
        rids, refused = _split_reach(plan, all_rids, st["task"] == "xy")
        rows += [_refused_row(plan, chunk, r, mask, st, progress) for r, mask in refused]
        if not rids:
            continue
        name, res, starts = _shape_call(plan, chunk, k, rids, progress)
        arrays.append((name, res))
        for b, r in enumerate(rids):
            row = base_row(plan, chunk, r)
            row["q0_ik_error_m"] = starts[b][1]
            row.update(
                shape_row_metrics(
                    res.status[b],
                    res.alpha_deg[b],
                    res.ratio[b],
                    res.criterion[b],
                    res.pos_error[b],
                    res.cms[b],
                    res.nfev[b],
                    criterion=st["criterion"],
                    ratio_target=st["ratio"],
                    alpha_tol_deg=plan.alpha_tol_deg,
                    ratio_rel_tol=plan.ratio_rel_tol,
                )
            )
            row.update(result_file=name, result_index=b)
            rows.append(row)
    # batched JAX solvers (pgd, hybrid, ...) shard their batch over the local devices; SLSQP is a host loop
    devices = (
        1 if plan.settings[plan.rows[chunk.rows[0]][0]]["solver"] in SINGLE_START_SOLVERS else jax.local_device_count()
    )
    return rows, arrays, devices


def _csc_meta(  # noqa: PLR0913 - the chunk's rows, settings, paths and start postures' IK errors
    plan: SweepPlan, chunk: Chunk, g: dict, rids: list[int], sts: list[dict], trajs: list, ik: list[float]
) -> dict:
    from jaxstiff.settings._robot import robot_meta, versions

    return {
        "format": "jaxstiff.sweep.csc/1",
        "sweep": {"name": plan.name, "plan_hash": plan.plan_hash, "chunk": chunk.id},
        "task": g["task"],  # (as a csc result file records it: the reader checks K_C against it)
        "settings": {"task": g["task"], "locked_joints": g["locked_joints"]},
        "robot": robot_meta(plan.robot),
        "static": {k: v for k, v in g.items() if k != "id"},
        "rows": [
            table_settings(s) | {"row_id": r, "path": t.name, "q0_ik_error_m": None if math.isnan(e) else e}
            for r, s, t, e in zip(rids, sts, trajs, ik, strict=True)
        ],
        "units": {"q": "rad", "u": "Nm/rad", "frobenius": "N/m", "tracking_error": "m", "K_xd": "N/m"},
        "versions": versions(),
    }


def _csc_chunk(plan: SweepPlan, chunk: Chunk, progress: Callable[[float], None] | None) -> tuple[list, list, int]:
    from jaxstiff.csc._inputs import CSCWarning
    from jaxstiff.csc._rollout import csc_rollout

    rids = list(chunk.rows)
    g = plan.groups[chunk.group]
    task = g["task"]
    sts = [plan.row_settings(r) for r in rids]
    trajs = [plan.row_trajectory(r) for r in rids]
    starts = [start_posture_and_error(plan, r) for r in rids]
    inputs = {
        "targets": np.stack([t.points for t in trajs]),
        "K_xd": np.stack([kxd_matrix(task, s["kxd_major"], s["kxd_ratio"], s["kxd_angle_deg"]) for s in sts]),
        "q0": np.stack([q for q, _ in starts]),
        "beta": np.array([s["beta"] for s in sts], dtype=float),
    }
    chunk_size = int(plan.config["sweep"]["chunk_size"])
    sharded, _nd = shard_batch(inputs, size=min(chunk_size, max(len(c.rows) for c in plan.chunks)))
    with warnings.catch_warnings():
        # a CSCWarning once per process, not once per chunk; set first, as a filter added later is matched
        # before it (the "not redundant" ignore, added before it, was never reached)
        warnings.simplefilter("once", CSCWarning)
        # "no null space" the config's check has already said (jaxstiff.sweep._axes)
        warnings.filterwarnings("ignore", message=".*not redundant", category=CSCWarning)
        # a start off the path is the row's own choice (q0 family "nominal" or a given posture), and the
        # table's tracking error shows it; said per chunk (another distance each time) it was noise
        warnings.filterwarnings("ignore", message="the start posture's TCP lies", category=CSCWarning)
        res = csc_rollout(
            plan.robot,
            sharded["targets"],
            sharded["K_xd"],
            sharded["q0"],
            sharded["beta"],
            # the static settings axes: one value per group (beta, per row, is the fifth argument)
            **{k: x for k, x in setting_values("csc", g).items() if k != "beta"},
            kxd_varying=False,
            check_reach=False,  # a rollout's cost does not depend on reach: rows out of it show their tracking error
        )
    devices = len(res.q.sharding.device_set)
    out = {k: np.asarray(v)[: len(rids)] for k, v in res.as_dict().items()}
    if progress is not None:
        progress(sum(t.P for t in trajs))
    name = f"arrays/chunk-{chunk.id:06d}-0.npz"
    data = {k: (v.astype(np.int64) if k == "status" else v.astype(np.float64)) for k, v in out.items()}
    data.update(
        row_id=np.asarray(rids, dtype=np.int64),
        K_xd=inputs["K_xd"],
        q0=inputs["q0"],
        beta=inputs["beta"],
        joint_names=np.asarray(plan.robot.joint_names, dtype=str),
        meta=np.asarray(
            json.dumps(
                _csc_meta(plan, chunk, g, rids, sts, trajs, [e for _, e in starts]),
                sort_keys=True,
                default=json_default,
            )
        ),
    )
    rows = []
    for i, r in enumerate(rids):
        row = base_row(plan, chunk, r)
        row["q0_ik_error_m"] = starts[i][1]
        row.update(
            csc_row_metrics(
                out["u"][i],
                out["frobenius"][i],
                out["tracking_error"][i],
                out["status"][i],
                out["u_start"][i],
                out["frobenius_start"][i],
            )
        )
        row.update(result_file=name, result_index=i)
        rows.append(row)
    return rows, [(name, data)], devices
