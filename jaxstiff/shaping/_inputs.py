"""Steps 1 and 2 of :func:`jaxstiff.shape`: the checked inputs (:class:`ShapeInputs`,
:func:`check_inputs`) and the start states (q0, kj0 and the first waypoint's extra start postures,
:func:`make_start_states`); private to :mod:`jaxstiff.shaping`."""

from __future__ import annotations

import dataclasses
import math
import os
import warnings
from collections.abc import Callable, Mapping
from typing import Any

import jax
import numpy as np

from jaxstiff._numerics.batch import NotNumbersError
from jaxstiff.ik import ik_position, nominal_posture
from jaxstiff.model._chain import LOCKED_JOINT_MODES, check_locked_values
from jaxstiff.model._robot import Robot
from jaxstiff.paths import Path
from jaxstiff.settings._base import suggest
from jaxstiff.settings._robot import RobotSpec
from jaxstiff.settings._shape import (
    SEGMENT_SPREAD_WARN,
    SINGLE_START_SOLVERS,
    ShapeSettings,
    limit_per_joint,
    per_metre_limit,
    ratio_per_path,
    shortest_segments,
    task_dim,
)
from jaxstiff.settings._solvers import OPTIONS_OF, SLSQPOptions
from jaxstiff.solvers._base import SOLVERS, check_options
from jaxstiff.solvers._greedy import check_single_start
from jaxstiff.solvers._problem import content_seed
from jaxstiff.stiffness._core import check_task_feasible, task_rows
from jaxstiff.stiffness._criteria import check_criterion_call, f1, f2, get_criterion
from jaxstiff.stiffness._tasks import check_planar_arm

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
    locked_joints: str = "rigid"  #: "rigid" or "spring" (SPEC section 1; jaxstiff.model._chain.LOCKED_JOINT_MODES)
    q0: np.ndarray | None = None
    kj0: np.ndarray | None = None
    q0_given: bool = False
    kj0_given: bool = False
    ik_error: list[float] | None = None

    @property
    def m(self) -> int:
        """Rows of the task stiffness: 2 for task "xy", else 3."""
        return task_dim(self.task)


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


def _as_floats(value: Any, what: str, unit: str) -> np.ndarray:
    """``value`` as a float array, or a :class:`~jaxstiff._numerics.batch.NotNumbersError` naming
    ``what`` (text, None, a ragged list)."""
    try:
        return np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise NotNumbersError(f"{what} must be numbers ({unit}), got {value!r:.60}") from None


def _start_states(robot: Robot, value: Any, B: int, what: str) -> np.ndarray:
    unit = "Nm/rad" if what.startswith("kj") else "rad; m for prismatic joints"
    a = _as_floats(value, what, unit)
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
        # locked joints first, with the message every entry point gives (model.chain)
        check_locked_values(robot, q, "q0" if q0.shape[0] == 1 else f"q0 (path {b})")
        bad = np.flatnonzero((q < lo) | (q > hi))
        if bad.size:
            i = int(bad[0])
            raise ValueError(
                f"q0[{i}] = {q[i]:.6g} {'m' if bool(robot.prismatic[i]) else 'rad'} for joint {robot.joint_names[i]!r} "
                "is outside its limits "
                f"[{lo[i]:.6g}, {hi[i]:.6g}]" + (f" (path {b})" if q0.shape[0] > 1 else "")
            )


def make_start_states(inp: ShapeInputs, q0: Any, kj0: Any) -> list[list[tuple[np.ndarray, np.ndarray]]]:
    """Step 2: the start states (B, n) into ``inp`` (``q0`` given or IK from the nominal posture to
    each path's first waypoint; ``kj0`` given or mid-range), and each path's extra start postures
    for the first waypoint (none when it is rate-limited)."""
    robot, bpath, B, n = inp.robot, inp.path, inp.path.B, inp.robot.n
    inp.kj0_given = kj0 is not None
    sprung = robot.free | (inp.locked_joints == "spring")  # joints whose stiffness is a variable
    if kj0 is None:
        inp.kj0 = np.full((B, n), 0.5 * (inp.kmin + inp.kmax))
    else:
        a = _as_floats(kj0, "kj0", "Nm/rad")
        if a.ndim >= 1 and a.shape[-1] != n and a.shape[-1] == int(sprung.sum()):  # one per sprung joint
            full = np.full(a.shape[:-1] + (n,), 0.5 * (inp.kmin + inp.kmax))
            full[..., sprung] = a
            a = full
        else:  # rigid locked joints' entries are not used: any value goes (inf, as results write it)
            a = np.where(sprung, a, 0.5 * (inp.kmin + inp.kmax)) if a.ndim >= 1 and a.shape[-1] == n else a
        inp.kj0 = _start_states(robot, np.full(n, float(a)) if a.ndim == 0 else a, B, "kj0")
        bad = np.argwhere(((inp.kj0 < inp.kmin) | (inp.kj0 > inp.kmax)) & sprung)
        if bad.size:
            bb, i = bad[0]
            raise ValueError(
                f"kj0[{i}] = {inp.kj0[bb, i]:.6g} Nm/rad for joint {robot.joint_names[i]!r} is outside "
                f"[kmin, kmax] = [{inp.kmin:g}, {inp.kmax:g}]"
            )
    inp.kj0 = np.where(sprung, inp.kj0, np.inf)  # rigid locked joints: infinite stiffness (no spring)
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


# ---------------------------------------------------------------------- input checks
def robot_and_path(
    robot: Robot | RobotSpec | str | os.PathLike[str], path: Any
) -> tuple[Robot, dict[str, Any] | None, Path]:
    """The chain (and the RobotSpec's meta when one was given) and the paths as a batch (B, P, 3)."""
    spec = None
    if isinstance(robot, RobotSpec):
        spec, robot = robot.meta(), robot.build()
    elif isinstance(robot, (str, os.PathLike)):
        robot = Robot.from_urdf(robot)
    if not isinstance(robot, Robot):
        raise ValueError(f"robot must be a jaxstiff.Robot, a RobotSpec or a URDF path, got {type(robot).__name__}")
    if path is None:
        from jaxstiff.paths import default_path

        path = default_path()
    if isinstance(path, (str, os.PathLike)):  # a path file's name: read as `jaxstiff shape --path` reads it
        path = Path.from_csv(path)
    if isinstance(path, (list, tuple)) and path and all(isinstance(p, (Path, str, os.PathLike)) for p in path):
        # a list of equal-length paths (or their files) -> one batch (B, P, 3)
        path = Path.stack([p if isinstance(p, Path) else Path.from_csv(p) for p in path])
    if isinstance(path, (list, tuple)) and len(path) > 1 and all(np.ndim(p) == 2 for p in path):
        lengths = [len(p) for p in path]
        if len(set(lengths)) > 1:  # arrays of waypoints, one per path: a batch needs one length
            raise ValueError(
                f"path: a list of {len(path)} paths of different lengths ({', '.join(map(str, lengths[:6]))}"
                f"{', ...' if len(path) > 6 else ''} waypoints); a batch needs one length: shape them in separate "
                "calls, or make them with one waypoint count"
            )
    if not isinstance(path, Path):
        try:
            path = Path(path)
        except (TypeError, ValueError) as e:
            raise type(e)(
                f"path must be a jaxstiff.Path, a path file's name (CSV: x,y,z[,dx,dy,dz]), a list of them, or an "
                f"array of waypoints (P, 3) / (B, P, 3) in m; {e}"
            ) from None
    return robot, spec, path.as_batch()


def _numbers(
    v: Mapping[str, Any], cms_volume: float | None, cms_major: float | None, pos_tol: float, m: int
) -> tuple[float, float, float]:
    """kmin, kmax, c (checked) and the CMS targets and pos_tol (checked)."""
    try:
        kmin, kmax, c = float(v["kmin"]), float(v["kmax"]), float(v["c"])
    except (TypeError, ValueError):
        raise ValueError("kmin, kmax and c must be numbers (c is the same for every path)") from None
    if not (math.isfinite(kmin) and math.isfinite(kmax)) or kmin <= 0 or kmin >= kmax:
        raise ValueError(f"need finite 0 < kmin < kmax (Nm/rad), got kmin={kmin}, kmax={kmax}")
    if not math.isfinite(c) or c < 0:
        raise ValueError(f"c must be a finite number >= 0, got {c}")
    if not (pos_tol > 0):
        raise ValueError(f"pos_tol must be > 0 (m), got {pos_tol}")
    if cms_volume is not None and cms_major is not None:
        raise ValueError("give at most one of cms_volume and cms_major")
    if cms_major is not None and not (cms_major > 0 and math.isfinite(cms_major)):
        raise ValueError(f"cms_major must be a finite number > 0 (N/m), got {cms_major}")
    if cms_volume is not None and not (cms_volume > 0 and math.isfinite(cms_volume)):
        raise ValueError(f"cms_volume must be a finite number > 0 ((N/m)^{m}), got {cms_volume}")
    return kmin, kmax, c


def _with_kj_unit(solver: str, options: Mapping[str, Any] | None, kmin: float, kmax: float) -> Mapping[str, Any] | None:
    """``options`` with SLSQP's stiffness unit ``kj_scale`` filled in from the range where the
    solver runs SLSQP (slsqp, slsqp-fd, hybrid, trajectory warm-started by one of them) and the
    option is not given: the solver and the result's meta both get the number it works with."""
    opts = dict(options or {})
    greedy = str(opts.get("warm", "pgd")) if solver == "trajectory" else solver
    if solver == "trajectory" and "warm_options" in opts:  # the warm start's options given apart
        opts["warm_options"] = _with_kj_unit(greedy, opts["warm_options"], kmin, kmax) or {}
        return opts
    if SLSQPOptions not in OPTIONS_OF.get(greedy, ()) or opts.get("kj_scale") is not None:
        return options
    from jaxstiff.solvers._slsqp import kj_unit

    opts["kj_scale"] = kj_unit(None, kmin, kmax)
    return opts


def _check_planar(path: Path, task: str) -> None:
    if task == "xy" and np.any(np.abs(path.directions[..., 2]) > 1e-9):
        b, k = (int(i) for i in np.argwhere(np.abs(path.directions[..., 2]) > 1e-9)[0])
        raise ValueError(
            f"task 'xy' needs directions in the xy plane (dz = 0); path {b}"
            + (f" ({path.name})" if path.name else "")
            + f" has dz = {path.directions[b, k, 2]:.3g} at waypoint {k} (its z changes along the path, or a "
            "given direction leaves the plane: a planar task needs a path at constant z)"
        )


def _same_value(a: np.ndarray) -> float | None:
    """The one value of a per-joint array (n,) whose entries are all equal, else None."""
    return float(a[0]) if a.ndim == 1 and a.size and np.all(a == a[0]) else None


def _locked_mode(value: Any) -> str:
    """``locked_joints`` checked: one of :data:`~jaxstiff.model._chain.LOCKED_JOINT_MODES`."""
    if value not in LOCKED_JOINT_MODES:
        raise ValueError(
            f"locked_joints must be one of {', '.join(map(repr, LOCKED_JOINT_MODES))}, got {value!r}"
            + suggest(str(value), LOCKED_JOINT_MODES)
        )
    return str(value)


def _rate_limits(
    values: Mapping[str, Any], base: ShapeSettings, path: Path, n: int
) -> tuple[np.ndarray, np.ndarray, dict[str, Any]]:
    """Per-waypoint rate limits dq, dk ((n,) or (B, n)): given per waypoint, or per metre of path
    times each path's shortest segment (:mod:`jaxstiff.settings._shape`); and the per-metre values
    for the recorded settings (numbers only; arrays are recorded through dq/dk)."""
    out, per_m = [], {}
    default = ShapeSettings()
    for key, unit in (("dq", "rad"), ("dk", "Nm/rad")):
        pm = values.get(f"{key}_per_m")
        if pm is None:
            what = f"{key} ({'joint' if key == 'dq' else 'stiffness'} rate limit per waypoint)"
            out.append(limit_per_joint(values[key], n, what, unit, path.B))
            continue
        # the per-waypoint value counts as given when it is not the settings' own or not the default
        if values[key] is not getattr(base, key) or getattr(base, key) != getattr(default, key):
            raise ValueError(
                f"give {key} (per waypoint) or {key}_per_m (per metre of path), not both "
                f"(command line: --{'dq-deg/--dq-m' if key == 'dq' else 'dk'} or --{key}-per-m)"
            )
        lo, hi = shortest_segments(path.points)
        if np.any(hi > SEGMENT_SPREAD_WARN * lo) and not per_m.get("warned"):
            b = int(np.argmax(hi / lo))
            per_m["warned"] = True
            warnings.warn(
                f"rate limits per metre: the waypoints of path {b} are not evenly spaced (segments {1e3 * lo[b]:.3g} "
                f"to {1e3 * hi[b]:.3g} mm); its per-waypoint limits use the shortest segment, so they are tighter "
                "than asked on the longer ones (resample the path evenly by arc length for exact limits)",
                stacklevel=4,
            )
        out.append(per_metre_limit(pm, lo, n, f"{key}_per_m", f"{unit} per metre of path"))
        if np.ndim(pm) == 0:
            per_m[f"{key}_per_m"] = float(pm)
    per_m.pop("warned", None)
    return out[0], out[1], per_m


def check_inputs(
    robot: Robot,
    path: Path,
    values: Mapping[str, Any],
    base: ShapeSettings,
    *,
    cms_volume: float | None,
    cms_major: float | None,
    options: Mapping[str, Any] | None,
    pos_tol: float,
) -> ShapeInputs:
    """Step 1: check every input before any work (errors name the value, path and joint) and
    resolve the defaults. ``values`` holds every :class:`ShapeSettings` field, per-path arrays
    allowed for ratio (B,), dq, dk, dq_per_m, dk_per_m ((n,) or (B, n)); ``base`` gives the
    settings recorded for the rest."""
    B, n, task, solver = path.B, robot.n, values["task"], values["solver"]
    locked = _locked_mode(values.get("locked_joints", "rigid"))
    if solver not in SOLVERS:
        raise ValueError(f"unknown solver {solver!r}; choose one of {', '.join(SOLVERS)}")
    criterion = values["criterion"]
    crit_fn = get_criterion(criterion)
    crit_name = criterion if isinstance(criterion, str) else getattr(criterion, "__name__", "custom")
    check_options(solver, options)
    if solver in SINGLE_START_SOLVERS:  # before the plan's size, which counts the starts
        check_single_start(values["starts"], solver)
    task_rows(task)
    ShapeSettings.check_kinds(values)
    check_task_feasible(robot, task, locked_joints=locked)
    if task == "xy":
        check_planar_arm(robot)
    ratio = ratio_per_path(values["ratio"], B)
    m = task_dim(task)
    kmin, kmax, c = _numbers(values, cms_volume, cms_major, pos_tol, m)
    if crit_fn is not f1 and crit_fn is not f2:
        check_criterion_call(crit_fn, crit_name, m)
    if crit_fn is f1 and c == 0.0:
        raise ValueError(
            "c must be > 0 for criterion f1: with c = 0, f1 = (alpha + c) r / min(rho, r) is 0 wherever "
            "alpha = 0, whatever the ratio, so the ratio R would not be asked for (default c = 0.01)"
        )
    options = _with_kj_unit(solver, options, kmin, kmax)
    dq, dk, per_m = _rate_limits(values, base, path, n)
    _check_planar(path, task)
    n_first = int(values["first_starts"])
    if n_first < 1:
        raise ValueError(f"first_starts must be >= 1, got {values['first_starts']}")
    if values["cms_mean_axis"] != ShapeSettings().cms_mean_axis and not (cms_volume is None and cms_major is None):
        raise ValueError(
            "give one CMS target: cms_mean_axis, cms_volume or cms_major (the other would be ignored); "
            f"got cms_mean_axis={values['cms_mean_axis']!r} with "
            + (f"cms_volume={cms_volume!r}" if cms_volume is not None else f"cms_major={cms_major!r}")
        )
    explicit_volume = cms_volume
    if cms_volume is None and cms_major is None:
        cms_volume = float(values["cms_mean_axis"]) ** m
    scalars = {
        "criterion": crit_name,
        "task": task,
        "locked_joints": locked,
        "solver": solver,
        "starts": values["starts"],
        "kmin": kmin,
        "kmax": kmax,
        "c": c,
        "first_rate_limit": bool(values["first_rate_limit"]),
        "first_starts": n_first,
        # the mean axis the target amounts to: a volume given instead fixes it (V^(1/m)); a major
        # axis does not (meta["settings"] records None then: shaping._steps._settings_meta)
        "cms_mean_axis": float(values["cms_mean_axis"]) if explicit_volume is None else explicit_volume ** (1.0 / m),
        **per_m,
    }
    for key, one in (
        ("ratio", ratio if isinstance(ratio, float) else None),
        ("dq", _same_value(dq)),
        ("dk", _same_value(dk)),
    ):
        if one is not None:
            scalars[key] = one
    return ShapeInputs(
        robot=robot,
        path=path,
        criterion=criterion,
        crit_name=crit_name,
        crit_fn=crit_fn,
        ratio=ratio,
        c=c,
        task=task,
        solver=solver,
        starts=values["starts"],
        options=options,
        dq=dq,
        dk=dk,
        kmin=kmin,
        kmax=kmax,
        first_rate_limit=bool(values["first_rate_limit"]),
        first_starts=n_first,
        cms_volume=cms_volume,
        cms_major=cms_major,
        pos_tol=float(pos_tol),
        settings=base.replace(**scalars),
        locked_joints=locked,
    )
