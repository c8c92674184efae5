"""Shaping results: the :class:`ShapeResult` container, its ``.npz`` file, status codes, verification.

Result file (DESIGN.md contract), loadable with ``numpy.load(file, allow_pickle=False)``; leading
axis B over trajectories (B = 1 for one path), P waypoints, n actuated joints in chain order:

==============  ==========  ======================================================================
key             shape       meaning
==============  ==========  ======================================================================
joint_names     (n,)        actuated joints, chain order (unicode strings)
q               (B,P,n)     joint positions, rad (m for prismatic), locked joints included
kj              (B,P,n)     joint stiffnesses before CMS, Nm/rad; ``+inf``: a rigid locked joint (no
                            spring; locked_joints "rigid"), so ``J diag(1/kj) J^T`` stays the compliance
cms             (B,P)       common-mode factor k (S0 section III): ``kj_scaled = k * kj``
kj_scaled       (B,P,n)     ``cms[..., None] * kj``, Nm/rad (may exceed kmax: CMS is a scaling)
target          (B,P,3)     waypoints, m, base frame
direction       (B,P,3)     desired directions (unit)
position        (B,P,3)     achieved TCP position (FK of q), m
pos_error       (B,P)       ``|position - target|``, m
alpha_deg       (B,P)       orientation error of the ellipsoid, degrees
ratio           (B,P)       axis ratio lambda1 / lambda2
criterion       (B,P)       criterion value at (q, kj)
status          (B,P)       per-waypoint status, codes below
q0, kj0         (B,n)       start state (rad; Nm/rad, +inf rigid) the rate limits of waypoint 0 refer to
solver_code     (B,P)       the solver's own code, per solver (meta ``solver_code_meaning``): slsqp /
                            slsqp-fd the SLSQP exit mode (0 = converged, 10 = stalled, -1 =
                            exception); pgd and trajectory the index of the start that won (-1 =
                            none); hybrid the SLSQP mode where the polish's answer was taken, else
                            pgd's start index
nit, nfev       (B,P)       solver iterations and objective evaluations
time_s          (B,P)       wall time per waypoint, s
meta            ()          JSON string: every input, default, solver setting, versions, robot
                            URDF path + sha256, base/tip link, locked joints, tcp
==============  ==========  ======================================================================

Derived, not a file array: :attr:`ShapeResult.in_target` (B,P) (:mod:`jaxstiff.results._target`).
Per-path parameters in ``meta``: ``ratio`` is a number (every path) or a list of B numbers;
``limits.dq`` / ``limits.dk`` are n numbers (every path) or B lists of n numbers; ``per_path``
(newer files) names those given per path. :func:`path_parameters` reads either form (older
files included) as ``ratio (B,)``, ``dq (B, n)``, ``dk (B, n)``.

Status codes (per waypoint; the verdict comes from checking the final point, never from the
solver's own "success" flag):

* ``0`` SOLVED: TCP within ``pos_tol`` (1e-9 m) of the waypoint, q and kj inside the rate-limited
  box (exactly), criterion finite, and (SLSQP) the solver reported convergence. The batch solvers
  pgd and trajectory run a fixed number of iterations and have no convergence flag: for them 0
  means feasible (the best of their starts), not a certified optimum.
* ``1`` NOT_CONVERGED: the point passes every check above, but SLSQP stopped without reporting
  convergence (iteration limit, line-search stall, failed QP subproblem) or raised; the returned
  point is feasible and used as the next waypoint's start, but may be sub-optimal.
* ``2`` CLIPPED: the solver's answer was outside the box by more than 1e-9 or off the path by more
  than 1e-6 m; it was clipped into the box and projected back onto the path (Newton steps inside
  the box) and now passes every check.
* ``3`` UNREACHABLE: no point inside the box puts the TCP within ``pos_tol`` of the waypoint (it is
  outside the workspace, or too far for the rate limits). q/kj hold the closest point found
  (inside the box); the next waypoint starts again from the last usable state.
* ``4`` NONFINITE: NaN/Inf in the solver's answer or the criterion; q/kj hold the last usable
  state (clipped into the box); the next waypoint starts from the last usable state.
* ``5`` NOT_RUN: the run was interrupted (Ctrl-C, SIGTERM) before this waypoint was solved; q/kj
  hold the reference state (the last usable waypoint's, or the start state) unchanged. Only the
  per-waypoint SLSQP solvers keep their finished waypoints this way (meta ``interrupted``); the
  batch solvers finish all paths together and write nothing when interrupted.

Codes 0-2 are *usable*: the point is feasible and becomes the reference state of the next
waypoint's rate limits. Codes 3-5 are not: the next waypoint's rate limits refer to the last usable
waypoint before it (or to the start state). :func:`verify` checks exactly that.

Example:
    >>> import jaxstiff
    >>> res = jaxstiff.ShapeResult.load("shape.npz")          # doctest: +SKIP
    >>> jaxstiff.results.verify(res)["max_pos_error"] < 1e-6  # doctest: +SKIP
    True
"""

from __future__ import annotations

import dataclasses
import os
from typing import TYPE_CHECKING, Any

import numpy as np

from jaxstiff.results._grid import PathGrid
from jaxstiff.results._npz import atomic_save_npz as atomic_save_npz
from jaxstiff.results._npz import path_parameters as path_parameters
from jaxstiff.results._numpy_check import (
    np_alpha_ratio,
    np_cms,
    np_criterion,
    np_fk_position,
    np_jacobian_rows,
    np_translational_stiffness,
    robot_from_meta,
)

# the status codes live in results.status; re-exported here for the former `jaxstiff.results` module
from jaxstiff.results._status import CLIPPED as CLIPPED
from jaxstiff.results._status import NONFINITE as NONFINITE
from jaxstiff.results._status import NOT_CONVERGED as NOT_CONVERGED
from jaxstiff.results._status import NOT_RUN as NOT_RUN
from jaxstiff.results._status import SOLVED as SOLVED
from jaxstiff.results._status import STATUS_NAMES as STATUS_NAMES
from jaxstiff.results._status import UNREACHABLE as UNREACHABLE
from jaxstiff.results._status import USABLE as USABLE
from jaxstiff.results._status import ShapeStatus as ShapeStatus
from jaxstiff.results._status import is_usable as is_usable
from jaxstiff.results._target import ALPHA_TOL_DEG, RATIO_REL_TOL, in_target, ratio_targets, target_masks
from jaxstiff.runtime._io import file_sha256, meta_dumps

if TYPE_CHECKING:
    from jaxstiff.model._robot import Robot

__all__ = [
    "np_translational_stiffness",
    "np_jacobian_rows",
    "ShapeResult",
    "verify",
    "summary",
    "path_parameters",
    "file_sha256",
    "atomic_save_npz",
    "robot_from_meta",
    "reference_states",
]

_ARRAYS_BPN = ("q", "kj", "kj_scaled")
_ARRAYS_BP3 = ("target", "direction", "position")
_ARRAYS_BP = ("cms", "pos_error", "alpha_deg", "ratio", "criterion", "status", "solver_code", "nit", "nfev", "time_s")
_ARRAYS_BN = ("q0", "kj0")
_INT_KEYS = ("status", "solver_code", "nit", "nfev")
_FIELDS = ("joint_names", *_ARRAYS_BPN, *_ARRAYS_BP3, *_ARRAYS_BP, *_ARRAYS_BN)


@dataclasses.dataclass(frozen=True, eq=False)
class ShapeResult(PathGrid):
    """Per-waypoint solution of a shaping run; arrays as in the result file (module docstring).

    Use :meth:`save` / :meth:`load` for files, :func:`summary` for the headline numbers and
    :func:`verify` to re-check a result from the file and the URDF alone.
    """

    joint_names: np.ndarray
    q: np.ndarray
    kj: np.ndarray
    cms: np.ndarray
    kj_scaled: np.ndarray
    target: np.ndarray
    direction: np.ndarray
    position: np.ndarray
    pos_error: np.ndarray
    alpha_deg: np.ndarray
    ratio: np.ndarray
    criterion: np.ndarray
    status: np.ndarray
    q0: np.ndarray
    kj0: np.ndarray
    solver_code: np.ndarray
    nit: np.ndarray
    nfev: np.ndarray
    time_s: np.ndarray
    meta: dict[str, Any]

    @property
    def in_target(self) -> np.ndarray:
        """(B, P) bool: a usable waypoint (status 0-2) whose alpha and rho are within the summary's
        tolerances (:mod:`jaxstiff.results._target`); an unreachable waypoint's ellipsoid is that of a
        posture off the path, so it is never in target."""
        return in_target(self.alpha_deg, self.ratio, self.meta) & is_usable(self.status)

    def arrays(self) -> dict[str, np.ndarray]:
        """All arrays by file key (``meta`` excluded)."""
        return {f.name: getattr(self, f.name) for f in dataclasses.fields(self) if f.name != "meta"}

    def __post_init__(self):
        B, P, n = np.shape(self.q)
        want: dict[str, tuple[int, ...]] = {k: (B, P, n) for k in _ARRAYS_BPN}
        want.update({k: (B, P, 3) for k in _ARRAYS_BP3})
        want.update({k: (B, P) for k in _ARRAYS_BP})
        want.update({k: (B, n) for k in _ARRAYS_BN})
        want["joint_names"] = (n,)
        for key, shape in want.items():
            if np.shape(getattr(self, key)) != shape:
                raise ValueError(f"ShapeResult.{key} must have shape {shape}, got {np.shape(getattr(self, key))}")

    # ------------------------------------------------------------------ files
    def save(self, file: str | os.PathLike) -> str:
        """Write the ``.npz`` result file atomically (temp file in the same folder, then rename).

        Returns the path written (``.npz`` added to a name without a suffix; another suffix is a
        ValueError, as ``x.csv`` would be written as ``x.csv.npz``). An interrupted save leaves no
        partial file.
        """
        arrays = {}
        for k, v in self.arrays().items():
            a = np.asarray(v)
            if k == "joint_names":
                a = a.astype(str)
            elif k in _INT_KEYS:
                a = a.astype(np.int64)
            else:
                a = a.astype(np.float64)
            arrays[k] = a
        arrays["meta"] = np.asarray(meta_dumps(self.meta))
        return atomic_save_npz(file, arrays)

    @staticmethod
    def load(file: str | os.PathLike) -> ShapeResult:
        """Read a result file written by :meth:`save` (no pickles), its schema checked
        (:func:`jaxstiff.results._reader.read_arrays`: keys, shapes, dtypes, finiteness, meta types);
        not its robot (:meth:`read` checks that too).

        Raises:
            FileNotFoundError: no such file.
            ValueError: not a jaxstiff result file (missing keys, wrong shapes, bad meta): a
                :class:`~jaxstiff.results._reader.ResultFileError`.
        """
        from jaxstiff.results._reader import read_arrays

        _, arrays, meta = read_arrays(file, "shape")
        return ShapeResult(meta=meta, **arrays)

    @staticmethod
    def read(file: str | os.PathLike, urdf: str | os.PathLike | None = None) -> ShapeResult:
        """Read a result file and check it against its robot (:func:`jaxstiff.results._reader.read_result`:
        the URDF and its hash, joint names, locked joints, the stored positions by FK, the task).

        Raises:
            FileNotFoundError: no such file, or its URDF is missing.
            ValueError: a :class:`~jaxstiff.results._reader.ResultFileError` naming what disagrees.
        """
        from jaxstiff.results._reader import read_result

        return ShapeResult.from_file(read_result(file, urdf, kind="shape"))

    @staticmethod
    def from_file(rf: Any) -> ShapeResult:
        """The :class:`ShapeResult` of a shape :class:`~jaxstiff.results._reader.ResultFile`."""
        return ShapeResult(meta=rf.meta, **{k: rf.arrays[k] for k in _FIELDS})

    def summary(self) -> dict[str, Any]:
        """Headline numbers: see :func:`summary`."""
        return summary(self)

    def __repr__(self) -> str:
        """A short summary (size, criterion, shares in target, status counts, robot, solver), not the arrays."""
        try:
            s = summary(self)
            codes, counts = np.unique(np.asarray(self.status), return_counts=True)
            status = ", ".join(
                f"{STATUS_NAMES.get(int(c), int(c))} {int(k)}" for c, k in zip(codes, counts, strict=True)
            )
            shares = f"in target {100 * s['share_both']:.1f}% (alpha {100 * s['share_alpha']:.1f}%, rho {100 * s['share_ratio']:.1f}%)"
        except Exception:  # a half-built result still prints
            status, shares = "?", "in target ?"
        robot = (self.meta.get("robot") or {}).get("name", "?")
        return (
            f"ShapeResult({self.B} path(s) x {self.P} waypoints, {self.n} joints; robot {robot}; "
            f"criterion {self.meta.get('criterion', '?')}, ratio {self.meta.get('ratio', '?')}, "
            f"solver {self.meta.get('solver', '?')}; {shares}; status: {status})"
        )


# ---------------------------------------------------------------------- summaries
def summary(
    res: ShapeResult | str | os.PathLike, alpha_tol_deg: float = ALPHA_TOL_DEG, ratio_rel_tol: float = RATIO_REL_TOL
) -> dict:
    """Headline numbers of a result (over all B x P waypoints); ``res`` a :class:`ShapeResult` or its file.

    * ``share_alpha`` : share of waypoints that are usable (status 0-2) with alpha < ``alpha_tol_deg``;
    * ``share_ratio`` : usable, and for f2 and others ``|rho - r| / r < ratio_rel_tol``; f1:
      ``rho >= (1 - ratio_rel_tol) r`` (f1 asks for *at least* r);
    * ``share_both``  : both (:attr:`ShapeResult.in_target`); ``share_usable``, ``share_solved``: status 0-2, 0;
    * ``max_pos_error`` (m), ``median_time_s`` and ``mean_time_s`` per waypoint, ``total_time_s``.
    """
    if isinstance(res, (str, os.PathLike)):
        res = ShapeResult.load(res)
    if not isinstance(res, ShapeResult):
        raise TypeError(f"summary: res must be a ShapeResult or a result file's path, got {type(res).__name__}")
    r_raw = res.meta.get("ratio", np.nan)
    r_b = ratio_targets(res.meta, res.B)  # one target per path; the rule: jaxstiff.results._target
    crit = str(res.meta.get("criterion", ""))
    a_ok, r_ok = target_masks(res.alpha_deg, res.ratio, r_b[:, None], crit, alpha_tol_deg, ratio_rel_tol)
    usable = is_usable(res.status)
    a_ok, r_ok = a_ok & usable, r_ok & usable  # as the command's table: usable waypoints only
    return {
        "B": res.B,
        "P": res.P,
        "criterion": crit,
        "ratio_target": float(r_b[0]) if np.ndim(r_raw) == 0 else r_b.tolist(),
        "share_alpha": float(np.mean(a_ok)),
        "share_ratio": float(np.mean(r_ok)),
        "share_both": float(np.mean(a_ok & r_ok)),
        "share_usable": float(np.mean(usable)),
        "share_solved": float(np.mean(res.status == SOLVED)),
        "max_pos_error": float(np.max(res.pos_error)) if usable.any() else float("nan"),
        "max_pos_error_usable": float(np.max(res.pos_error[usable])) if usable.any() else float("nan"),
        "median_alpha_deg": float(np.median(res.alpha_deg)),
        "median_time_s": float(np.median(res.time_s)),
        "mean_time_s": float(np.mean(res.time_s)),
        "total_time_s": float(np.sum(res.time_s)),
        "median_nfev": float(np.median(res.nfev)),
        "median_nit": float(np.median(res.nit)),
    }


# ---------------------------------------------------------------------- verification
def _stiffness_or_nan(robot: Robot, q: np.ndarray, kj: np.ndarray, task: str) -> np.ndarray:
    """numpy ``K_T`` at one waypoint, NaN where its compliance is exactly singular (no error)."""
    try:
        return np_translational_stiffness(robot, q, kj, task)
    except np.linalg.LinAlgError:
        from jaxstiff.settings._shape import task_dim  # (here: the settings package imports JAX)

        m = task_dim(task)
        return np.full((m, m), np.nan)


def _worst(prev: float, x: np.ndarray) -> float:
    """The larger of ``prev`` and the largest of ``x``, a NaN counting as ``inf`` (a check that
    cannot be made is reported, never swallowed: Python's ``max(0.0, nan)`` is 0.0)."""
    x = np.asarray(x, dtype=float)
    return max(prev, float(np.max(np.where(np.isnan(x), np.inf, x), initial=-np.inf)))


def reference_states(res: ShapeResult, b: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per waypoint of path b: the reference state (q_ref (P,n), kj_ref (P,n)) its box refers to,
    and whether rate limits apply (P,) bool (False only before the first usable waypoint when the
    run had ``first_rate_limit = False``)."""
    first_rate = bool(res.meta["limits"]["first_rate_limit"])
    q_ref, kj_ref = res.q0[b].copy(), res.kj0[b].copy()
    at_start = True
    Q, KJ, RATE = [], [], []
    for p in range(res.P):
        Q.append(q_ref.copy())
        KJ.append(kj_ref.copy())
        RATE.append(not (at_start and not first_rate))
        if res.status[b, p] in USABLE:
            q_ref, kj_ref, at_start = res.q[b, p], res.kj[b, p], False
    return np.asarray(Q), np.asarray(KJ), np.asarray(RATE)


def _verify_args(res: Any, robot: Any, urdf: str | os.PathLike | None) -> ShapeResult:
    """:func:`verify`'s ``res`` as a checked :class:`ShapeResult` (a path is read with
    :meth:`ShapeResult.read`, which checks robot, joints, locks, positions, task), and ``robot``'s type."""
    if isinstance(res, (str, os.PathLike)):
        res = ShapeResult.read(res, urdf)
    if not isinstance(res, ShapeResult):
        raise TypeError(f"verify: res must be a ShapeResult or a result file's path, got {type(res).__name__}")
    from jaxstiff.model._robot import Robot as _Robot  # (a runtime check; the module imports it for types only)

    if robot is not None and not isinstance(robot, _Robot):
        raise TypeError(
            f"verify: robot must be a jaxstiff.Robot (or None: rebuilt from the file), got {type(robot).__name__}"
        )
    return res


def verify(  # noqa: PLR0915 - one numpy re-check per reported quantity, in sequence
    res: ShapeResult | str | os.PathLike, robot: Robot | None = None, urdf: str | os.PathLike | None = None
) -> dict[str, float]:
    """Re-check a result with numpy only (no JAX): FK, bounds, rate limits, reported values.

    ``res``: a :class:`ShapeResult` or the path of a result file (read with
    :meth:`ShapeResult.read`: a file whose robot, joints, locked joints, positions or task disagree
    with its meta is refused with a :class:`~jaxstiff.results._reader.ResultFileError`).

    Uses the robot rebuilt from ``meta`` (or the one given), a plain numpy FK, and a numpy
    recomputation of ``K_T``, alpha, rho and f1/f2 (other criteria: criterion not re-checked).

    Returns:
        ``max_pos_error`` (m, usable waypoints), ``max_bound_violation`` (joint and stiffness
        limits, all waypoints), ``max_rate_violation`` (rad or Nm/rad, against each waypoint's
        reference state), ``max_position_mismatch`` (reported vs recomputed position),
        ``max_alpha_mismatch`` (deg), ``max_ratio_mismatch`` (relative), ``max_criterion_mismatch``
        (relative; NaN where the criterion is one of the user's own, which is not re-checked),
        ``max_cms_mismatch`` (relative), ``max_kj_scaled_mismatch`` (relative: ``kj_scaled`` against
        ``cms * kj``, what a controller is commanded with). A non-finite joint position, or a NaN
        stiffness, makes the checks it enters ``inf`` (never an error). The file's ``joint_names``
        must be the robot's, in chain order (ValueError otherwise).
    """
    res = _verify_args(res, robot, urdf)
    if robot is None:
        robot = robot_from_meta(res.meta, urdf)
    lim = res.meta["limits"]
    prm = path_parameters(res.meta, res.B, res.n)  # per-path ratio, dq, dk (or the shared ones)
    kmin, kmax = float(lim["kmin"]), float(lim["kmax"])
    task = res.meta["task"]
    c = prm["c"]
    names = [str(x) for x in np.asarray(res.joint_names).ravel()]
    if names != list(robot.joint_names):
        raise ValueError(
            f"the result's joint_names {names} are not the robot's joints in chain order {list(robot.joint_names)}"
        )
    out = dict(
        max_pos_error=0.0,
        max_bound_violation=0.0,
        max_rate_violation=0.0,
        max_locked_violation=0.0,
        max_position_mismatch=0.0,
        max_alpha_mismatch=0.0,
        max_ratio_mismatch=0.0,
        max_criterion_mismatch=0.0,
        max_cms_mismatch=0.0,
        max_kj_scaled_mismatch=0.0,
    )
    if res.meta["criterion"] not in ("f1", "f2"):
        out["max_criterion_mismatch"] = float("nan")  # a criterion of the user's own: not re-checked
    locked = robot.locked_values
    inf = float("inf")
    lmask = ~np.isnan(locked)
    for b in range(res.B):
        q, kj = res.q[b], res.kj[b]
        # a corrupt waypoint (NaN or inf joint position, NaN stiffness): computed at a harmless
        # stand-in so that nothing raises, and every check it enters reads inf
        bad = ~np.all(np.isfinite(q), axis=-1) | np.any(np.isnan(kj), axis=-1)
        if bad.any():
            q = np.where(bad[:, None], 0.5 * (np.nan_to_num(robot.lower) + np.nan_to_num(robot.upper)), q)
            kj = np.where(bad[:, None] & np.isnan(kj), 0.5 * (kmin + kmax), kj)
            for k in ("max_bound_violation", "max_position_mismatch", "max_alpha_mismatch", "max_ratio_mismatch"):
                out[k] = inf
        # a rigid locked joint (SPEC section 1) has kj = +inf: no spring, so no stiffness bounds or
        # rate limit apply to it; +inf anywhere else is a violation
        rigid = lmask[None, :] & (kj == np.inf)
        kjb = np.where(rigid, 0.5 * (kmin + kmax), kj)
        pos = np_fk_position(robot, q)
        usable = is_usable(res.status[b])
        err = np.where(bad, inf, np.linalg.norm(pos - res.target[b], axis=-1))
        if usable.any():
            out["max_pos_error"] = _worst(out["max_pos_error"], err[usable])
        out["max_position_mismatch"] = _worst(out["max_position_mismatch"], np.abs(pos - res.position[b]))
        bound = np.r_[
            (robot.lower - q).ravel(), (q - robot.upper).ravel(), (kmin - kjb).ravel(), (kjb - kmax).ravel(), 0.0
        ]
        out["max_bound_violation"] = _worst(out["max_bound_violation"], bound)
        if lmask.any():
            out["max_locked_violation"] = _worst(out["max_locked_violation"], np.abs(q[:, lmask] - locked[lmask]))
        Qr, Kr, rate = reference_states(res, b)
        if rate.any():
            dqv = np.abs(q[rate] - Qr[rate]) - prm["dq"][b]
            Kr = np.where(lmask[None, :] & (Kr == np.inf), kjb, Kr)
            dkv = np.abs(kjb[rate] - Kr[rate]) - prm["dk"][b]
            out["max_rate_violation"] = _worst(out["max_rate_violation"], np.r_[dqv.ravel(), dkv.ravel(), 0.0])
        # reported stiffness quantities, recomputed in numpy
        K = np.stack([_stiffness_or_nan(robot, q[p], kj[p], task) for p in range(res.P)])
        if np.isnan(K).any():  # an exactly singular compliance: its reported values cannot be re-checked
            out["max_alpha_mismatch"] = out["max_ratio_mismatch"] = inf
        ok = np.all(np.isfinite(K), axis=(-2, -1))
        alpha, rho = np.full(res.P, np.nan), np.full(res.P, np.nan)
        if ok.any():
            alpha[ok], rho[ok] = np_alpha_ratio(K[ok], res.direction[b][ok])
        out["max_alpha_mismatch"] = _worst(out["max_alpha_mismatch"], np.abs(alpha - res.alpha_deg[b]))
        out["max_ratio_mismatch"] = _worst(out["max_ratio_mismatch"], (np.abs(rho - res.ratio[b]) / rho))
        crit = res.meta["criterion"]
        if crit in ("f1", "f2"):
            f = np_criterion(crit, alpha, rho, float(prm["ratio"][b]), c)
            out["max_criterion_mismatch"] = _worst(
                out["max_criterion_mismatch"], np.abs(f - res.criterion[b]) / np.abs(f)
            )
        cms_ref = np.full(res.P, np.nan)
        if ok.any():
            cms_ref[ok] = np_cms(K[ok], res.meta["cms"])
        out["max_cms_mismatch"] = _worst(out["max_cms_mismatch"], (np.abs(cms_ref - res.cms[b]) / cms_ref))
        # what the controller is commanded with: cms * kj (a rigid joint's inf stays inf)
        want = res.cms[b][:, None] * res.kj[b]
        got = res.kj_scaled[b]
        same = (want == got) | (np.isnan(want) & np.isnan(got))
        with np.errstate(invalid="ignore", divide="ignore"):
            rel = np.where(same, 0.0, np.abs(got - want) / np.abs(want))
        out["max_kj_scaled_mismatch"] = _worst(out["max_kj_scaled_mismatch"], np.nan_to_num(rel, nan=inf))
    return out
