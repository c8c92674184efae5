"""The parameter axes of a sweep: their specifications (defaults from the settings spine), their
values (a value, a list, or a range), and the checks that need the robot and the paths.

Defaults are not written here: every axis that is a setting is made from its field of
:class:`~jaxstiff.settings.ShapeSettings` or :class:`~jaxstiff.settings.CSCSettings` (default,
type, choices, check, unit, doc: :func:`~jaxstiff.sweep._axis_specs.setting_axes`), so a sweep row
at its defaults is the problem ``shape()`` / ``csc_rollout()`` / the commands solve, and a value
is refused by the field's own check. Where the sweep's column needs another form, the conversion
is written on the field's ``Axis``:

* ``dq_deg`` = ``degrees(ShapeSettings.dq)`` (the table is in degrees per waypoint);
* ``starts`` = 0 for ``ShapeSettings.starts = None`` (the solver's default; an integer column);
* csc ``task``: ``CSCSettings.task = None`` means "from the size of K_xd"; a sweep's K_xd
  (:func:`kxd_matrix`) is 3x3 unless the task is ``"xy"``, so None resolves to ``"xyz"``;
* csc ``jl_gain``: None (the settings' rule: 0.3 with ``joint_limits`` on, else 0) is resolved per
  row (:func:`resolve_jl_gain`); the table holds the gain that applied.

The axes that exist only in sweeps (``kxd_major``, ``kxd_ratio``, ``kxd_angle_deg``, ``q0``,
``q0_seed``) keep their own defaults. The axis tables themselves (:data:`AXES`) live in
:mod:`jaxstiff.sweep._axis_specs`; this module holds the values, their checks and :func:`kxd_matrix`.
"""

from __future__ import annotations

import functools
import json
import math
import warnings
from collections.abc import Mapping, Sequence
from typing import Any, ClassVar

import numpy as np
from pydantic import create_model

from jaxstiff.model._chain import check_locked_values
from jaxstiff.settings._csc import CSCSettings
from jaxstiff.settings._shape import SINGLE_START_SOLVERS
from jaxstiff.sweep._axis_specs import AXES as AXES
from jaxstiff.sweep._axis_specs import CSC_SWEEP_TASK as CSC_SWEEP_TASK
from jaxstiff.sweep._axis_specs import Q0_FAMILIES as Q0_FAMILIES
from jaxstiff.sweep._axis_specs import AxisSpec as AxisSpec
from jaxstiff.sweep._schema import SweepConfigError, Table, number, range_values, suggest, typename, validate

__all__ = ["AxisSpec", "AXES", "axis_values", "q0_values", "CSC_SWEEP_TASK", "Q0_FAMILIES"]


def kxd_matrix(task: str, major: float, ratio: float, angle_deg: float) -> np.ndarray:
    """Desired Cartesian stiffness of a CSC sweep row, N/m.

    ``"xy"``: ``R(theta) diag(major, major / ratio) R(theta)^T`` (2x2), the form of the project's
    planar CSC cases (R(30 deg) diag(3000, 1000) R(30 deg)^T; seed 001 has no simulation example). ``"xyz"``: ``R_z(theta) diag(major,
    major / ratio, major / ratio) R_z(theta)^T`` (3x3): the major axis in the horizontal plane at
    angle theta from base x.
    """
    t = math.radians(angle_deg)
    c, s = math.cos(t), math.sin(t)
    if task == "xy":
        R = np.array([[c, -s], [s, c]])
        D = np.diag([major, major / ratio])
    else:
        R = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
        D = np.diag([major, major / ratio, major / ratio])
    K = R @ D @ R.T
    return 0.5 * (K + K.T)


# ---------------------------------------------------------------------------- [axes]
class _AxesBase(Table):
    kind: ClassVar[str] = "shape"

    @classmethod
    def unknown_key(cls, key: str) -> str:
        specs, other = AXES[cls.kind], "csc" if cls.kind == "shape" else "shape"
        hint = f" (it is an axis of kind {other!r}; set sweep.kind)" if key in AXES[other] else ""
        return f"unknown axis for kind {cls.kind!r}{suggest(key, list(specs))}{hint}; axes: {', '.join(specs)}"


@functools.lru_cache(maxsize=8)
def _axes_model(kind: str, names: tuple[str, ...]) -> type[_AxesBase]:
    """The ``[axes]`` table of ``kind``: one optional key per axis (made again when the axes change)."""
    fields: dict[str, Any] = {name: (Any, None) for name in names}
    model = create_model(f"{kind.capitalize()}Axes", __base__=_AxesBase, **fields)
    model.kind = kind
    return model


def axes_table(raw: Any, kind: str, robot: Any, source: str = "") -> dict[str, list]:
    """``[axes]`` as ``{axis: [values]}`` for every axis of ``kind`` (defaults filled in, in :data:`AXES` order)."""
    given = validate(_axes_model(kind, tuple(AXES[kind])), raw, "axes", source).model_dump(exclude_unset=True)
    out: dict[str, list] = {}
    for name, spec in AXES[kind].items():
        key = f"axes.{name}"
        vals = axis_values(given.get(name, spec.default), spec, key, robot, source)
        seen = set()
        for v in vals:
            h = json.dumps(v)
            if h in seen:
                raise SweepConfigError(key, f"duplicate value {v!r} (each value once)", source)
            seen.add(h)
        out[name] = vals
    if kind == "csc" and out["jl_gain"] == [None]:
        gains = {resolve_jl_gain(j, None) for j in out["joint_limits"]}
        if len(gains) == 1:  # one gain applies to every row (the table and the plan hash show it)
            out["jl_gain"] = [gains.pop()]
    return out


def resolve_jl_gain(joint_limits: str, jl_gain: float | None) -> float:
    """The joint-limit gain that applies (:attr:`CSCSettings.resolved_jl_gain`)."""
    return CSCSettings(joint_limits=joint_limits, jl_gain=jl_gain).resolved_jl_gain


def _one_value(v: Any, spec: AxisSpec, key: str, source: str) -> Any:
    if spec.type in ("float", "int"):
        try:
            x = number(v, key, integer=spec.type == "int", source=source)
        except SweepConfigError:
            want = "an integer" if spec.type == "int" else "a number"
            raise SweepConfigError(
                key, f"expected {want} or a list/range of them, got {typename(v)} {v!r}", source
            ) from None
        text = None
        if not math.isfinite(x) and not (isinstance(spec.default, float) and math.isinf(spec.default)):
            text = "must be finite"  # (an axis may be open only where its default is: csc kmax = inf)
        elif spec.check is not None:
            text = spec.check(x)
        if text:
            raise SweepConfigError(key, f"{text}, got {v!r}", source)
        return x
    if spec.type == "bool":
        if not isinstance(v, bool):
            raise SweepConfigError(key, f"expected true or false, got {typename(v)} {v!r}", source)
        return v
    if not isinstance(v, str):
        raise SweepConfigError(key, f"expected a string or a list of strings, got {typename(v)} {v!r}", source)
    allowed = spec.allowed()
    if allowed is not None and v not in allowed:
        raise SweepConfigError(
            key, f"unknown value {v!r}{suggest(v, allowed)}; choose one of {', '.join(allowed)}", source
        )
    return v


def axis_values(raw: Any, spec: AxisSpec, key: str, robot: Any, source: str = "") -> list:
    """The values of one axis: a value, a list of values, or a range table (numbers only)."""
    if spec.type == "q0":
        return q0_values(raw, key, robot, source)
    if raw is None and spec.default is None:
        return [None]  # (csc jl_gain: the settings' rule, resolved per row)
    if isinstance(raw, Mapping):
        if spec.type not in ("float", "int"):
            raise SweepConfigError(
                key, f"a range table only works for numbers; {spec.name} takes {spec.type} values", source
            )
        vals = range_values(dict(raw), key, spec.type == "int", source)
    elif isinstance(raw, list):
        if not raw:
            raise SweepConfigError(key, "empty axis: give at least one value", source)
        vals = list(raw)
    else:
        vals = [raw]
    return [_one_value(v, spec, key, source) for v in vals]


def _posture(v: list, i: int, key: str, robot: Any, source: str) -> list[float]:
    q = [float(number(x, f"{key}[{i}][{j}]", source=source)) for j, x in enumerate(v)]
    if len(q) != robot.n:
        raise SweepConfigError(
            key,
            f"posture {i} has {len(q)} values; robot {robot.name!r} has {robot.n} joints "
            f"({', '.join(robot.joint_names)})",
            source,
        )
    try:  # locked joints at their values: the message every entry point gives
        check_locked_values(robot, q, f"posture {i}: q")
    except ValueError as e:
        raise SweepConfigError(key, str(e), source) from None
    lo, hi = robot.lower, robot.upper
    for j, x in enumerate(q):
        if not (lo[j] <= x <= hi[j]):
            unit = "m" if bool(robot.prismatic[j]) else "rad"  # a prismatic joint's values are lengths
            raise SweepConfigError(
                key,
                f"posture {i}: q[{j}] = {x:g} {unit} is outside the limits [{lo[j]:g}, {hi[j]:g}] "
                f"of joint {robot.joint_names[j]!r}",
                source,
            )
    return q


def q0_values(raw: Any, key: str, robot: Any, source: str = "") -> list:
    """The q0 axis: families (``"ik"``, ``"nominal"``, ``"random"``) and postures ``[q_1..q_n]`` (rad)."""
    if isinstance(raw, str):
        items = [raw]
    elif isinstance(raw, list):
        if not raw:
            raise SweepConfigError(key, "empty axis: give at least one value", source)
        if all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in raw):
            raise SweepConfigError(key, "a posture must be written inside a list: q0 = [[q_1, ..., q_n]] (rad)", source)
        items = raw
    else:
        raise SweepConfigError(
            key, f'expected "ik", "nominal", "random" or a list of postures, got {typename(raw)} {raw!r}', source
        )
    out: list = []
    for i, v in enumerate(items):
        if isinstance(v, str):
            if v not in Q0_FAMILIES:
                raise SweepConfigError(
                    key,
                    f"unknown q0 family {v!r}{suggest(v, Q0_FAMILIES)}; choose ik, nominal, random or a posture",
                    source,
                )
            out.append(v)
        elif isinstance(v, list):
            out.append(_posture(v, i, key, robot, source))
        else:
            raise SweepConfigError(
                key, f"item {i}: expected a string or a posture list, got {typename(v)} {v!r}", source
            )
    return out


# ---------------------------------------------------------------------------- checks across axes
def _check_tasks(kind: str, axes: Mapping[str, list], robot: Any, source: str) -> None:
    from jaxstiff.stiffness._core import TASK_ROWS, check_task_feasible

    modes = axes.get("locked_joints", ["rigid"]) if kind == "shape" else ["rigid"]
    for task in axes["task"]:
        for mode in modes:
            try:
                check_task_feasible(robot, task, motion=kind == "csc", locked_joints=mode)
            except ValueError as e:
                also = f" (locked_joints {mode!r})" if kind == "shape" and not robot.free.all() else ""
                raise SweepConfigError("axes.task", f"robot {robot.name!r}{also}: {e}", source) from None
        m = len(TASK_ROWS[task])
        if kind == "csc" and robot.n_free <= m:  # allowed (tracking only), but the sweep's point is lost
            warnings.warn(
                f"{source or 'config'}: axes.task {task!r}: robot {robot.name!r} has {robot.n_free} free "
                f"joints for {m} task rows: no null space, so the arm only tracks the path, and beta and the "
                "step rule do not change its motion",
                stacklevel=3,
            )


def _warn_out_of_reach(kind: str, trajectories: Sequence[Any], robot: Any, planar: bool) -> None:
    """Say which paths have waypoints beyond the robot's reach (``jaxstiff shape`` refuses such a
    path; a sweep runs it: shape rows give those waypoints status 3, csc rollouts cannot track
    them): said before the run, with the millimetre hint, not found in the table after it."""
    from jaxstiff.model._reach import _mm_hint, chain_reach, unreachable_mask

    for t in trajectories:
        bad = unreachable_mask(robot, t.points, planar)
        if not bad.any():
            continue
        reach = chain_reach(robot)
        warnings.warn(
            f"path {t.name!r}: {int(bad.sum())} of {t.P} waypoints lie beyond the reach of robot {robot.name!r} "
            f"({reach.outer:.4g} m from the origin of joint {reach.centre_joint!r}; Robot.reach()): "
            + (
                "they are status 3 (unreachable) in every row"
                if kind == "shape"
                else "no rollout can track them (the tracking error shows how far each ends)"
            )
            + _mm_hint(reach, np.asarray(t.points, float)),
            stacklevel=2,
        )


def cross_checks(
    kind: str, axes: Mapping[str, list], trajectories: Sequence[Any], robot: Any, source: str = ""
) -> None:
    """Checks that need several axes, the robot or the paths (kmin < kmax, single-start solvers,
    feasible tasks, random seeds, planar directions)."""
    for lo in axes["kmin"]:
        for hi in axes["kmax"]:
            if not lo < hi:
                raise SweepConfigError(
                    "axes.kmin",
                    f"kmin = {lo:g} is not below kmax = {hi:g} (axes.kmax); every combination needs 0 < kmin < kmax",
                    source,
                )
    if kind == "shape":
        for s in axes["solver"]:
            if s in SINGLE_START_SOLVERS and any(k > 1 for k in axes["starts"]):
                raise SweepConfigError(
                    "axes.starts",
                    f"solver {s!r} is single-start; starts must be 0 or 1 (or sweep multi-start solvers separately)",
                    source,
                )
    _check_tasks(kind, axes, robot, source)
    _warn_out_of_reach(kind, trajectories, robot, planar=set(axes.get("task", ())) == {"xy"})
    if len(axes["q0_seed"]) > 1 and "random" not in axes["q0"]:
        raise SweepConfigError(
            "axes.q0_seed",
            f'{len(axes["q0_seed"])} seeds, but axes.q0 has no "random" family: '
            "the seed only draws random postures, so every seed would repeat the same rows",
            source,
        )
    if kind == "shape" and "xy" in axes["task"]:
        for t in trajectories:
            if np.any(np.abs(t.directions[:, 2]) > 1e-9):
                raise SweepConfigError(
                    "axes.task",
                    f"task 'xy' needs directions in the xy plane (dz = 0); path {t.name!r} has dz != 0",
                    source,
                )
