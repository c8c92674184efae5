"""The named steps of :func:`jaxstiff.shape` besides the input checks: the start states (q0, kj0
and the first waypoint's extra start postures), what is reported at the solved points, the CMS
factor, the ``meta`` record and the :class:`~jaxstiff.ShapeResult`.

Every reported quantity (position, K_T, alpha, ratio, criterion) is recomputed here at each
solver's final points with one compiled program, so all solvers report the same way. The common-
mode stiffness factor (CMS, seed 000 section III) scales each waypoint's kj so that its
translational stiffness ellipsoid reaches a target size: ``cms = (V / prod(lambda)) ** (1 / m)``
for a target volume V in (N/m)^m, or ``cms = lambda1_target / lambda1`` for a target major axis.
"""

from __future__ import annotations

import dataclasses
import datetime
import warnings
from collections.abc import Callable, Mapping
from typing import Any

import jax
import numpy as np

from jaxstiff.ik import NOMINAL_OFFSET_DEG, ik_position, nominal_posture
from jaxstiff.model.robot import Robot
from jaxstiff.paths import DEFAULT_PATH_SPEC, Path
from jaxstiff.results import files as R
from jaxstiff.runtime.io import deferred_interrupts
from jaxstiff.settings.robot import robot_meta, versions
from jaxstiff.settings.shape import ShapeSettings
from jaxstiff.solvers.problem import WaypointProblem, compiled_report, content_seed
from jaxstiff.stiffness.criteria import CRITERIA

__all__ = [
    "ShapeInputs",
    "Report",
    "first_start_rng",
    "first_start_postures",
    "make_start_states",
    "report_at_solution",
    "cms_factors",
    "warn_off_plane",
    "shape_meta",
    "array_units",
    "assemble_result",
    "FIRST_STARTS_SEED",
    "FIRST_STARTS_SPREAD_DEG",
]

FIRST_STARTS_SEED = 0  #: seed of the extra first-waypoint start postures, mixed with each path's own data
FIRST_STARTS_SPREAD_DEG = 60.0  #: perturbation of the nominal posture for the extra starts, +- deg


@dataclasses.dataclass
class ShapeInputs:
    """The checked inputs of one :func:`jaxstiff.shape` call (what the steps pass on).

    Shapes: B paths of P waypoints, n joints; ``ratio`` a float or (B,); ``dq``/``dk`` (n,) or
    (B, n); ``q0``/``kj0`` (B, n) once the start states are made. Units as in :func:`jaxstiff.shape`.
    """

    robot: Robot
    path: Path  #: the batch (B, P, 3)
    criterion: str | Callable[..., Any]
    crit_name: str
    crit_fn: Callable[..., Any]
    ratio: float | np.ndarray
    c: float
    task: str
    solver: str
    starts: int | None
    options: Mapping[str, Any] | None
    dq: np.ndarray
    dk: np.ndarray
    kmin: float
    kmax: float
    first_rate_limit: bool
    first_starts: int
    cms_volume: float | None
    cms_major: float | None
    pos_tol: float
    settings: ShapeSettings  #: the settings that ran, per-path arrays aside (meta["settings"])
    robot_spec: dict[str, Any] | None = None  #: the RobotSpec's meta, when one was given
    q0: np.ndarray | None = None
    kj0: np.ndarray | None = None
    q0_given: bool = False
    kj0_given: bool = False
    ik_error: list[float] | None = None

    @property
    def m(self) -> int:
        """Rows of the task stiffness: 2 for task "xy", else 3."""
        return 2 if self.task == "xy" else 3


def first_start_rng(seed: int, target: np.ndarray, direction: np.ndarray, q0: np.ndarray) -> np.random.Generator:
    """The random generator of one path's extra first-waypoint start postures: seeded by ``seed``
    and a CRC-32 of the path's targets (P, 3), directions (P, 3) and start posture q0 (n,), so the
    same path gets the same postures wherever it stands in a batch."""
    return np.random.default_rng(np.random.SeedSequence([int(seed), content_seed(target, direction, q0)]))


def first_start_postures(
    robot: Robot,
    points: np.ndarray,
    directions: np.ndarray,
    q0: np.ndarray,
    kj0: np.ndarray,
    count: int,
    task: str = "full",
    seed: int = FIRST_STARTS_SEED,
) -> list[tuple[np.ndarray, np.ndarray]]:
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


def _start_states(robot: Robot, value: Any, B: int, what: str) -> np.ndarray:
    a = np.asarray(value, dtype=float)
    if a.ndim == 1:
        a = np.broadcast_to(a, (B, a.shape[0]))
    if a.ndim != 2 or a.shape != (B, robot.n):
        raise ValueError(
            f"{what} must have {robot.n} values (one per joint of {robot.name!r}) or shape ({B}, {robot.n}), got shape {np.shape(value)}"
        )
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


def make_start_states(inp: ShapeInputs, q0: Any, kj0: Any) -> list[list[tuple[np.ndarray, np.ndarray]]]:
    """Step 2: the start states (B, n) into ``inp`` (``q0`` given or IK from the nominal posture to
    each path's first waypoint; ``kj0`` given or mid-range), and each path's extra start postures
    for the first waypoint (none when it is rate-limited)."""
    robot, bpath, B, n = inp.robot, inp.path, inp.path.B, inp.robot.n
    inp.kj0_given = kj0 is not None
    if kj0 is None:
        inp.kj0 = np.full((B, n), 0.5 * (inp.kmin + inp.kmax))
    else:
        a = np.asarray(kj0, dtype=float)
        inp.kj0 = _start_states(robot, np.full(n, float(a)) if a.ndim == 0 else a, B, "kj0")
        bad = np.argwhere((inp.kj0 < inp.kmin) | (inp.kj0 > inp.kmax))
        if bad.size:
            bb, i = bad[0]
            raise ValueError(
                f"kj0[{i}] = {inp.kj0[bb, i]:.6g} Nm/rad for joint {robot.joint_names[i]!r} is outside "
                f"[kmin, kmax] = [{inp.kmin:g}, {inp.kmax:g}]"
            )
    with jax.enable_x64(True):
        inp.q0_given = q0 is not None
        if q0 is not None:
            inp.q0 = _start_states(robot, q0, B, "q0")
            _check_q0(robot, inp.q0)
        else:
            inp.q0, inp.ik_error = np.zeros((B, n)), []
            for b in range(B):
                inp.q0[b], e = ik_position(robot, bpath.points[b, 0], planar=(inp.task == "xy"))
                inp.ik_error.append(e)
        if inp.first_rate_limit:
            return [[] for _ in range(B)]
        return [
            first_start_postures(
                robot, bpath.points[b], bpath.directions[b], inp.q0[b], inp.kj0[b], inp.first_starts - 1, inp.task
            )
            for b in range(B)
        ]


@dataclasses.dataclass
class Report:
    """What is reported at the solved points, each (B, P, ...): position (m), K_T (N/m),
    alpha_deg (deg), ratio (1), criterion (the criterion's value)."""

    position: np.ndarray
    K: np.ndarray
    alpha_deg: np.ndarray
    ratio: np.ndarray
    criterion: np.ndarray


def report_at_solution(
    problem: WaypointProblem, inp: ShapeInputs, arrays: Mapping[str, np.ndarray], ratios: np.ndarray
) -> Report:
    """Recompute the reported quantities at every solver's final points (a compile and B x P small
    calls, seconds: the command line's Ctrl-C waits for them rather than lose the solve)."""
    B, P, m = inp.path.B, inp.path.P, inp.m
    pos, K, alpha, rho, f = (
        np.zeros((B * P, 3)),
        np.zeros((B * P, m, m)),
        np.zeros(B * P),
        np.zeros(B * P),
        np.zeros(B * P),
    )
    with jax.enable_x64(True), deferred_interrupts():
        report = compiled_report(problem)
        for i, (b, p) in enumerate(np.ndindex(B, P)):
            x = np.asarray(problem.x_of(arrays["q"][b, p], arrays["kj"][b, p]))
            prm = WaypointProblem.params(inp.path.points[b, p], inp.path.directions[b, p], float(ratios[b]), inp.c)
            pos[i], K[i], alpha[i], rho[i], f[i] = problem.unpack_report(np.asarray(report(x, prm)))
    return Report(pos.reshape(B, P, 3), K.reshape(B, P, m, m), alpha.reshape(B, P), rho.reshape(B, P), f.reshape(B, P))


def cms_factors(K: np.ndarray, inp: ShapeInputs) -> np.ndarray:
    """CMS factor (B, P) of each waypoint's K_T (B, P, m, m): to the target volume (N/m)^m or the
    target major axis (N/m) (module docstring)."""
    w = np.linalg.eigvalsh(K.reshape(-1, inp.m, inp.m))
    if inp.cms_major is not None:
        cms = inp.cms_major / w[:, -1]
    else:
        cms = (inp.cms_volume / np.prod(w, axis=-1)) ** (1.0 / inp.m)
    return cms.reshape(K.shape[:2])


def warn_off_plane(position: np.ndarray, path: Path, task: str, stacklevel: int = 3) -> None:
    """Task "xy" matches x and y only: warn when TCPs end more than 1 mm from their target's z."""
    if task != "xy":
        return
    dz = np.abs(position[..., 2] - path.points[..., 2])
    if np.any(dz > 1e-3):
        b = int(np.argmax(dz.max(axis=1)))
        warnings.warn(
            f"task 'xy' matches x and y only, and {int((dz > 1e-3).sum())} of {dz.size} waypoints end more than "
            f"1 mm from their target's z (path {b}: target z = {path.points[b, 0, 2]:.4g} m, TCP z = "
            f"{position[b, 0, 2]:.4g} m at the first waypoint); their status and pos_error count the 3-D "
            "distance (status 3, unreachable). Give the path the TCP's z (a planar chain moves in one plane)",
            stacklevel=stacklevel,
        )


def array_units(robot: Robot) -> dict[str, str]:
    """``meta["units"]``: the unit of every array of the result file (joint values in m for
    prismatic joints, named only when the robot has one)."""
    prismatic = bool(np.any(robot.prismatic))
    joint = "rad (m for prismatic joints)" if prismatic else "rad"
    kj = "Nm/rad (N/m for prismatic joints)" if prismatic else "Nm/rad"
    return {
        "q": joint,
        "kj": kj,
        "position": "m",
        "alpha_deg": "deg",
        "stiffness": "N/m",
        "kj_scaled": kj,
        "cms": "1",
        "target": "m",
        "direction": "1 (unit vector)",
        "pos_error": "m",
        "ratio": "1 (lambda1 / lambda2)",
        "criterion": "f1: deg; f2: 1",
        "q0": joint,
        "kj0": kj,
        "time_s": "s",
        "status": "code (status_codes)",
        "solver_code": "code (solver_code_meaning)",
        "nit": "iterations",
        "nfev": "evaluations",
    }


def _settings_meta(inp: ShapeInputs) -> dict[str, Any]:
    """``meta["settings"]``: the settings' values and units (dq in rad); per-path arrays as lists."""
    out = inp.settings.meta()
    out["criterion"] = inp.crit_name
    for key, value in (("ratio", inp.ratio), ("dq", inp.dq), ("dk", inp.dk)):
        a = np.asarray(value)
        if a.ndim > 0 and not (key != "ratio" and a.ndim == 1 and np.all(a == a.flat[0])):
            out[key] = a.tolist()
    return out


def shape_meta(
    inp: ShapeInputs,
    arrays: Mapping[str, Any],
    opts_meta: dict[str, Any],
    first_starts_use: str,
    timing: dict[str, Any],
    defaults: Mapping[str, Any],
    interrupted: bool,
    async_dispatch: bool,
) -> dict[str, Any]:
    """The ``meta`` record of a result file: every input, the defaults, the solver's settings
    (``opts_meta``: :func:`jaxstiff.solvers.base.options_meta`; ``first_starts_use``: what the
    solver does with the first waypoint's starts), timing and versions, and ``settings`` and
    ``units`` with the unit of each value and array."""
    bpath, first_rate_limit = inp.path, inp.first_rate_limit
    meta: dict[str, Any] = {
        "format": "jaxstiff.shape/1",
        "created": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
        "robot": robot_meta(inp.robot),
        "criterion": inp.crit_name,
        "criterion_custom": not (isinstance(inp.criterion, str) and inp.criterion in CRITERIA),
        "ratio": inp.ratio if isinstance(inp.ratio, float) else np.asarray(inp.ratio).tolist(),
        "c": inp.c,
        "task": inp.task,
        "solver": inp.solver,
        **opts_meta,
        "solver_driver": arrays.get("driver"),
        "solver_code_meaning": arrays.get("code_meaning"),
        "pos_tol": float(inp.pos_tol),
        "limits": {
            "dq": inp.dq.tolist(),
            "dk": inp.dk.tolist(),
            "kmin": inp.kmin,
            "kmax": inp.kmax,
            "first_rate_limit": bool(first_rate_limit),
            "dq_unit": "rad per waypoint",
            "dk_unit": "Nm/rad per waypoint",
        },
        "per_path": [
            k
            for k, v in (("ratio", inp.ratio), ("dq", inp.dq), ("dk", inp.dk))
            if np.ndim(v) > (0 if k == "ratio" else 1)
        ],
        "first_starts": {
            "count": inp.first_starts if not first_rate_limit else 1,
            "seed": FIRST_STARTS_SEED,
            "use": first_starts_use,
            "spread_deg": FIRST_STARTS_SPREAD_DEG,
            "rng": "numpy default_rng(SeedSequence([seed, crc32 of the path's target, direction "
            "(P, 3) and q0 (n,) as float64 bytes]))",
        },
        "q0_source": "given"
        if inp.q0_given
        else f"ik_dls from nominal posture (mid-range, + {NOMINAL_OFFSET_DEG:g} deg for revolute joints)",
        "q_nominal": nominal_posture(inp.robot).tolist(),
        "ik_error_m": inp.ik_error,
        "kj0_source": "given" if inp.kj0_given else "mid-range (kmin + kmax) / 2",
        "cms": {"target_volume": inp.cms_volume, "target_major": inp.cms_major},
        "path": {
            "name": bpath.name,
            "B": bpath.B,
            "P": bpath.P,
            "default_spec": DEFAULT_PATH_SPEC if bpath.name == "default" else None,
        },
        "defaults": dict(defaults),
        "settings": _settings_meta(inp),
        "status_codes": R.STATUS_NAMES,
        "timing_s": timing,
        "versions": versions(),
        "jax_cpu_async_dispatch": async_dispatch,
        "units": array_units(inp.robot),
        "interrupted": interrupted,
    }
    if inp.robot_spec is not None:
        meta["robot_spec"] = inp.robot_spec
    return meta


def assemble_result(
    inp: ShapeInputs, arrays: Mapping[str, np.ndarray], rep: Report, cms: np.ndarray, meta: dict[str, Any]
) -> R.ShapeResult:
    """The :class:`~jaxstiff.ShapeResult` (B, P, ...) of the solver's arrays and the report."""
    if inp.q0 is None or inp.kj0 is None:
        raise ValueError("the start states are made first (make_start_states)")
    return R.ShapeResult(
        joint_names=np.asarray(inp.robot.joint_names, dtype=str),
        q=arrays["q"],
        kj=arrays["kj"],
        cms=cms,
        kj_scaled=arrays["kj"] * cms[..., None],
        target=np.array(inp.path.points),
        direction=np.array(inp.path.directions),
        position=rep.position,
        pos_error=np.linalg.norm(rep.position - inp.path.points, axis=-1),
        alpha_deg=rep.alpha_deg,
        ratio=rep.ratio,
        criterion=rep.criterion,
        status=arrays["status"],
        q0=inp.q0,
        kj0=inp.kj0,
        solver_code=arrays["solver_code"],
        nit=arrays["nit"],
        nfev=arrays["nfev"],
        time_s=arrays["time_s"],
        meta=meta,
    )
