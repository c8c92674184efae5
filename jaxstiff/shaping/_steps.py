"""The named steps of :func:`jaxstiff.shape` after the solve: what is reported at the solved points,
the CMS factor, the ``meta`` record and the :class:`~jaxstiff.ShapeResult` (private to
:mod:`jaxstiff.shaping`; the input checks and start states are in ``_inputs``).

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
from collections.abc import Mapping
from typing import Any

import jax
import numpy as np

from jaxstiff.ik import NOMINAL_OFFSET_DEG, nominal_posture
from jaxstiff.model._robot import Robot
from jaxstiff.paths import DEFAULT_PATH_SPEC, Path
from jaxstiff.results import _files as R
from jaxstiff.results._numpy_check import np_alpha_ratio, np_criterion
from jaxstiff.runtime._io import deferred_interrupts
from jaxstiff.runtime._plan_size import check_plan_size
from jaxstiff.settings._robot import robot_meta, versions
from jaxstiff.settings._shape import ShapeSettings
from jaxstiff.shaping._inputs import FIRST_STARTS_SEED, FIRST_STARTS_SPREAD_DEG, ShapeInputs
from jaxstiff.solvers._problem import WaypointProblem, report_rows
from jaxstiff.stiffness._criteria import CRITERIA


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
    """Recompute the reported quantities at every solver's final points with one compiled program
    over rows (:func:`jaxstiff.solvers._problem.report_rows`: a compile, then about a millisecond
    per 128 waypoints; the command line's Ctrl-C waits for it rather than lose the solve).

    A waypoint with status NOT_RUN (an interrupted run) holds its path's reference state
    unchanged, so its position, K_T and axis ratio are those of that state: they are computed
    once per distinct state, and only alpha and the criterion, which depend on the waypoint's
    direction, are evaluated per waypoint, in numpy (:func:`not_run_groups`). An interrupt after a
    few of 10^6 waypoints thus reports a few rows, not 10^6.
    """
    B, P, m = inp.path.B, inp.path.P, inp.m
    pos, K, alpha, rho, f = (
        np.zeros((B, P, 3)),
        np.zeros((B, P, m, m)),
        np.zeros((B, P)),
        np.zeros((B, P)),
        np.zeros((B, P)),
    )
    not_run = np.asarray(arrays["status"]).reshape(B, P) == R.NOT_RUN
    groups = {
        int(b): not_run_groups(inp, arrays, int(b), np.flatnonzero(not_run[b]))
        for b in np.flatnonzero(not_run.any(axis=1))
    }
    # the waypoints computed by the compiled report: every one that was run, and per NOT_RUN
    # group its first waypoint (all of them for a criterion numpy cannot evaluate)
    wanted = [np.argwhere(~not_run)]
    for b, gs in groups.items():
        for p0, rest, numpy_rest in gs:
            wanted.append(np.array([[b, p0]]))
            if not numpy_rest and rest.size:
                wanted.append(np.stack([np.full(rest.size, b), rest], axis=1))
    bp = np.concatenate(wanted).astype(int)
    if len(bp):
        bb, pp = bp[:, 0], bp[:, 1]
        X = np.asarray(problem.x_of(arrays["q"][bb, pp], arrays["kj"][bb, pp]), dtype=np.float64)
        prm = np.concatenate(
            [
                inp.path.points[bb, pp],
                inp.path.directions[bb, pp],
                np.asarray(ratios, dtype=np.float64)[bb, None],
                np.full((len(bb), 1), float(inp.c)),
            ],
            axis=1,
        )
        with jax.enable_x64(True), deferred_interrupts():
            out = report_rows(problem, X, prm)
        pos[bb, pp], K[bb, pp] = out[:, :3], out[:, 3 : 3 + m * m].reshape(-1, m, m)
        alpha[bb, pp], rho[bb, pp], f[bb, pp] = out[:, 3 + m * m], out[:, 4 + m * m], out[:, 5 + m * m]
    for b, gs in groups.items():
        for p0, rest, numpy_rest in gs:
            if not (numpy_rest and rest.size):
                continue
            pos[b, rest], K[b, rest], rho[b, rest] = pos[b, p0], K[b, p0], rho[b, p0]
            a, _ = np_alpha_ratio(K[b, p0][None], inp.path.directions[b, rest])
            alpha[b, rest] = a
            f[b, rest] = np_criterion(inp.crit_name, a, rho[b, rest], float(ratios[b]), inp.c)
    return Report(pos, K, alpha, rho, f)


#: the default first-waypoint start count: a memory refusal names the starts only above it
FIRST_STARTS_DEFAULT = ShapeSettings().first_starts


def check_shape_size(inp: ShapeInputs) -> None:
    """Refuse a run whose B x P waypoints cannot fit in memory, before the solve (the estimate,
    the limit and what to lower): per waypoint the result arrays (q, kj, kj_scaled: n each; about
    40 reported values) and each start's state (4 n values), float64, twice (solver and result).

    Raises:
        jaxstiff.runtime._plan_size.PlanTooLargeError: a ``ValueError`` naming the sizes.
    """
    B, P, n = inp.path.B, inp.path.P, inp.robot.n
    starts = max(int(inp.starts or 1), int(inp.first_starts or 1))
    # the knob to name: the starts too where they were raised above the default first-waypoint
    # count and weigh more than the rest of a waypoint's values
    knobs = "the number of waypoints (--path rows) or paths"
    if starts > FIRST_STARTS_DEFAULT and 4 * n * starts > 3 * n + 40:
        which = (
            "starts (--starts)"
            if int(inp.starts or 1) >= int(inp.first_starts or 1)
            else "first_starts (--first-starts)"
        )
        knobs = f"{which}, or {knobs}"
    check_plan_size(
        f"shape: {B} path(s) x {P} waypoints ({n} joints, {starts} start(s))",
        B * P,
        2 * 8 * (3 * n + 40 + 4 * n * starts),
        knobs,
    )


def not_run_groups(
    inp: ShapeInputs, arrays: Mapping[str, np.ndarray], b: int, idx: np.ndarray
) -> list[tuple[int, np.ndarray, bool]]:
    """The NOT_RUN waypoints ``idx`` of path ``b`` grouped by their state (q, kj): per group
    ``(p0, rest, numpy_rest)``, its first waypoint ``p0`` (computed by the compiled report), the
    other waypoints ``rest``, and whether those copy p0's position, K_T and ratio and get alpha
    (S0-8) and f1/f2 (S0-9, S0-15) from numpy (False: a custom criterion, each waypoint of
    ``rest`` goes through the compiled report)."""
    states = np.concatenate([arrays["q"][b, idx], arrays["kj"][b, idx]], axis=1)
    if np.all(states == states[0]):  # (the usual case: one reference state; np.unique of 10^6 rows takes 2 s)
        first, group = np.array([0]), np.zeros(len(idx), dtype=int)
    else:
        _, first, group = np.unique(states, axis=0, return_index=True, return_inverse=True)
    numpy_rest = inp.crit_name in ("f1", "f2") and isinstance(inp.criterion, str)
    out = []
    for g, i0 in enumerate(first):
        p0, members = int(idx[i0]), idx[np.ravel(group) == g]
        out.append((p0, members[members != p0], numpy_rest))
    return out


def cms_factors(K: np.ndarray, inp: ShapeInputs) -> np.ndarray:
    """CMS factor (B, P) of each waypoint's K_T (B, P, m, m): to the target volume (N/m)^m or the
    target major axis (N/m) (module docstring)."""
    w = np.linalg.eigvalsh(K.reshape(-1, inp.m, inp.m))
    with np.errstate(over="ignore", under="ignore", divide="ignore", invalid="ignore"):
        if inp.cms_major is not None:
            cms = inp.cms_major / w[:, -1]
        else:
            assert inp.cms_volume is not None  # set whenever cms_major is not (shaping._inputs)
            target = inp.cms_volume
            vol = np.prod(w, axis=-1)
            cms = (target / vol) ** (1.0 / inp.m)
            # a product of the axes beyond float64 (stiffness ranges like [1e-300, 1e-290] Nm/rad:
            # the volume underflowed to 0 and the factor was inf): the m-th roots first, as
            # jaxstiff.cms_factor does (there only: elsewhere the same bits as the product)
            redo = np.all(w > 0, axis=-1) & ((vol == 0) | ~np.isfinite(vol) | ~np.isfinite(cms))
            if np.any(redo):
                root = 1.0 / inp.m
                cms[redo] = target**root / np.prod(w[redo] ** root, axis=-1)
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
    if inp.cms_major is not None:  # a major-axis target has no one mean axis (meta["cms"] holds it)
        out["cms_mean_axis"] = None
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
    (``opts_meta``: :func:`jaxstiff.solvers._base.options_meta`; ``first_starts_use``: what the
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
            "dq_unit": "rad per waypoint (m for a prismatic joint)",
            "dk_unit": "Nm/rad per waypoint (N/m for a prismatic joint)",
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
