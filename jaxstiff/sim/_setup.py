"""What a physics check needs from a result file: robot, postures, stiffnesses, task, locked-joint mode.

The locked-joint mode (SPEC section 1) decides both the MuJoCo model and the prediction, through
:func:`locked_joint_mode` and :func:`spring_mask` alone:

* ``"rigid"`` (SPEC's default): a locked joint has no spring; it is no MuJoCo joint and its
  Jacobian column and kj are left out of the predicted compliance;
* ``"spring"``: a locked joint keeps its spring at the locked value (a MuJoCo joint with stiffness
  kj; its column counts in the compliance).

Result files record the mode as ``meta["settings"]["locked_joints"]``; a file without that key was
written before the option existed, when a locked joint always kept its spring: ``"spring"``.
"""

from __future__ import annotations

import dataclasses
import os
import warnings
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from jaxstiff.model._chain import Chain
from jaxstiff.results import ShapeResult, is_usable, robot_from_meta
from jaxstiff.results._reader import urdf_differs
from jaxstiff.stiffness import task_rows

__all__ = ["LOCKED_MODES", "select_waypoints", "cases_from_result", "sweep_row_result"]

LOCKED_MODES = ("rigid", "spring")


def locked_joint_mode(meta: Mapping[str, Any]) -> str:
    """``"rigid"`` or ``"spring"``: how the result treated its locked joints (module docstring).

    Raises:
        ValueError: an unknown value in ``meta["settings"]["locked_joints"]``.
    """
    settings = meta.get("settings")
    mode = settings.get("locked_joints") if isinstance(settings, Mapping) else None
    if mode is None:
        return "spring"  # written before the option existed: locked joints kept their springs
    if mode not in LOCKED_MODES:
        raise ValueError(f"meta settings.locked_joints must be one of {', '.join(LOCKED_MODES)}, got {mode!r}")
    return str(mode)


def spring_mask(chain: Chain, mode: str) -> np.ndarray:
    """(n,) bool: the joints with a spring, free ones always, locked ones in ``"spring"`` mode."""
    if mode not in LOCKED_MODES:
        raise ValueError(f"locked-joint mode must be one of {', '.join(LOCKED_MODES)}, got {mode!r}")
    return chain.free | (mode == "spring")


@dataclasses.dataclass(frozen=True)
class SimCase:
    """One posture to check.

    Attributes:
        robot: the chain (its locked joints are those of the result).
        q: (n,) posture, rad (m), locked joints at their values.
        kj: (n,) joint stiffnesses, Nm/rad (N/m).
        task: ``"xy"``, ``"xyz"`` or ``"full"``.
        mode: locked-joint mode, ``"rigid"`` or ``"spring"``.
        label: where it comes from (``"b0 p12"``).
    """

    robot: Chain
    q: np.ndarray
    kj: np.ndarray
    task: str
    mode: str
    label: str = ""

    def __post_init__(self) -> None:
        task_rows(self.task)  # refuses an unknown task
        spring_mask(self.robot, self.mode)
        n = self.robot.n
        for name in ("q", "kj"):
            a = np.asarray(getattr(self, name), dtype=float)
            if a.shape != (n,):
                raise ValueError(f"SimCase.{name} must have shape ({n},), got {a.shape}")
            object.__setattr__(self, name, a)
        if not np.all(np.isfinite(self.q)):
            raise ValueError(f"SimCase {self.label}: q has non-finite values")

    @property
    def springs(self) -> np.ndarray:
        """(n,) bool: joints with a spring."""
        return spring_mask(self.robot, self.mode)


def select_waypoints(P: int, waypoints: int | Sequence[int] | None) -> list[int]:
    """Waypoint indices: ``None`` -> all; an int N -> N evenly spaced (ends included); a list as given."""
    if waypoints is None:
        return list(range(P))
    if isinstance(waypoints, (int, np.integer)):
        if waypoints < 1:
            raise ValueError(f"--waypoints must be >= 1, got {waypoints}")
        return sorted({int(round(x)) for x in np.linspace(0, P - 1, min(int(waypoints), P))})
    out = [int(p) for p in waypoints]
    bad = [p for p in out if not -P <= p < P]
    if bad:
        raise ValueError(f"waypoint index {bad[0]} is out of range for a path of {P} waypoints")
    return [p % P for p in out]


def sweep_row_result(folder: str | os.PathLike, row: int, urdf: str | os.PathLike | None = None) -> ShapeResult:
    """Row ``row`` (row_id) of a shape sweep folder as a one-path :class:`ShapeResult`, read and
    checked as ``jaxstiff view/plot/export DIR --row K`` read it
    (:func:`jaxstiff.sweep._stored.read_sweep_row`).

    Raises:
        ValueError: no such row, an unsolved row, a csc sweep (check-sim checks shape results).
    """
    from jaxstiff.sweep._stored import read_sweep_row

    rf, b = read_sweep_row(os.fspath(folder), int(row), None if urdf is None else os.fspath(urdf))
    if rf.kind != "shape":
        raise ValueError(
            f"{os.fspath(folder)}: row {row} is a {rf.kind} sweep row; check-sim checks shape results "
            "(a shape sweep's rows, or a file written by `jaxstiff shape`)"
        )
    res = ShapeResult.from_file(rf)
    one = {f.name: getattr(res, f.name) for f in dataclasses.fields(res)}
    for name, value in one.items():
        if name not in ("meta", "joint_names") and isinstance(value, np.ndarray) and value.ndim >= 1:
            one[name] = value[b : b + 1]  # the row's path only
    return ShapeResult(**one)


def cases_from_result(
    result: ShapeResult | str | os.PathLike,
    waypoints: int | Sequence[int] | None = 5,
    *,
    scaled: bool = False,
    urdf: str | os.PathLike | None = None,
) -> list[SimCase]:
    """The postures of a shape result to check (every path b, the selected waypoints p).

    Args:
        result: a :class:`ShapeResult` or its ``.npz`` file.
        waypoints: see :func:`select_waypoints` (default: 5 evenly spaced per path), taken among
            the usable waypoints (status 0-2) only: a status 3-5 row holds no solution.
        scaled: use ``kj_scaled`` (after CMS) instead of ``kj``; CMS scales every spring by the same
            factor, so either checks the same mapping.
        urdf: the robot's URDF if the recorded path is not valid here (its sha256 must match).
    """
    # a file: the one reader (robot, joints, locked joints, positions by FK, task checked; an edited
    # --urdf that fails them is named first by the reader)
    res = result if isinstance(result, ShapeResult) else ShapeResult.read(result, urdf)
    meta = res.meta
    try:
        robot = robot_from_meta(meta, urdf=urdf)
    except KeyError as exc:
        raise ValueError(f"result meta has no robot description (missing {exc}); not a shape result?") from None
    differs = None if isinstance(result, ShapeResult) else urdf_differs(meta, urdf)
    if differs:  # the edited URDF passed every check: say so all the same
        warnings.warn(differs, stacklevel=2)
    task = meta.get("task") or (meta.get("settings") or {}).get("task")
    if task is None:
        raise ValueError("result meta has no 'task'; not a shape result?")
    mode = locked_joint_mode(meta)
    kj = res.kj_scaled if scaled else res.kj
    usable = is_usable(np.asarray(res.status))
    cases = []
    for b in range(res.B):
        good = np.flatnonzero(usable[b])
        if isinstance(waypoints, (int, np.integer)) and not isinstance(waypoints, bool):
            # N evenly spaced among the usable waypoints (a status 3-5 row holds no solution)
            picks = [int(good[i]) for i in select_waypoints(len(good), waypoints)] if len(good) else []
        else:
            picks = [p for p in select_waypoints(res.P, waypoints) if usable[b, p]]
        cases += [SimCase(robot, res.q[b, p], kj[b, p], str(task), mode, label=f"b{b} p{p}") for p in picks]
    if not cases:
        raise ValueError(
            "no usable waypoint (status 0-2) among those selected: the check compares solutions, and "
            "status 3-5 rows hold the reference state"
        )
    return cases
