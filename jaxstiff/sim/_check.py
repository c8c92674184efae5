"""Predicted vs measured stiffness per posture: the physics check behind ``jaxstiff check-sim``.

For each posture (:class:`~jaxstiff.sim._setup.SimCase`) a MuJoCo model is built
(:func:`~jaxstiff.sim._build.build_model`) and probed (:mod:`jaxstiff.sim._measure`):

1. **Small loads** (linear regime). Forces ``+-h`` along x, y (, z) at the TCP give the columns of
   the measured translational compliance; for task ``"full"`` moments ``+-h`` about x, y, z as
   well, giving the 6x6 compliance, whose inverse's top-left block is the stiffness with the tool
   orientation held (SPEC section 2; exact, no constraint needed). Further diagonal force
   directions are compared as deflection vectors. Whatever the task, both stiffnesses a force can
   meet are reported: with the tool free to turn (the inverse of the force probes' translational
   block, task ``xyz``'s) and with the orientation held (from the 6x6; task ``xyz`` probes the
   moments too when the chain has six springs). Default ``h``: a deflection of about 1e-5 m
   (1e-5 rad for moments), where the central difference's O(h^2) error is ~1e-10.
2. **Finite load** (CCT). A force ``F0`` along the axis that makes the CCT term largest, sized so
   that ``|K_G| = 0.5 min(kj)`` (the term then changes K_T by ~1 to 30 %, at least ~10x the
   default tolerance, and the posture stays stable for either sign); the loaded equilibrium and the compliance around it are
   measured the same way, and compared with jaxstiff's loaded prediction for the sign under test
   (:func:`~jaxstiff.sim._predict.loaded_compliance`), for the wrong sign and without the term.

Errors (all relative, spectral norm): ``err_K = |K_meas - K_pred| / |K_pred|`` on ``K_T`` (N/m);
``err_C`` the same on its inverse (the translational compliance, tool free for ``"xy"``/``"xyz"``,
held for ``"full"``); ``err_dir = max_u |d_meas - C_pred u| / |C_pred u|`` over the extra
directions (whole 6-D deflection for ``"full"``). A posture passes when all are below ``tol``
(default 1e-3, the issue's bar) and the CCT error for the sign under test is too.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence

import numpy as np

from jaxstiff.settings._shape import task_dim
from jaxstiff.sim._build import build_model
from jaxstiff.sim._measure import probe_compliance
from jaxstiff.sim._predict import (
    cct_term,
    joint_torque,
    loaded_compliance,
    predicted_compliance,
    predicted_stiffness,
    stiffness_from_compliance,
)
from jaxstiff.sim._setup import SimCase
from jaxstiff.stiffness import task_rows

__all__ = ["DEFLECTION", "CCT_FRACTION", "check_cases", "cct_load", "probe_directions", "rel_error"]

TOL = 1e-3  #: the issue's bar for relative agreement
DEFLECTION = 1e-5  #: default probe size: largest deflection, m (rad for moment probes)
CCT_FRACTION = 0.5  #: finite load such that |K_G|_2 = CCT_FRACTION * min(kj)


@dataclasses.dataclass(frozen=True)
class SimRow:
    """One posture's result (module docstring for the error definitions).

    ``cct_*`` are NaN when the CCT check was not run; ``cct_err`` is for the sign under test,
    ``cct_err_wrong`` for the opposite sign, ``cct_err_none`` without the term.

    Whatever the task, the two stiffnesses a force at the TCP can meet (3x3, N/m): ``K_held_*``
    with the tool's orientation held (task ``full``'s; None for task ``xy`` and for a chain with
    fewer than six springs, which cannot hold the orientation and still move), ``K_free_*`` with
    the tool free to turn (task ``xyz``'s; for ``xy`` the 2x2 of the plane); ``err_held`` /
    ``err_free`` their errors as ``err_K`` (NaN where not measured).
    """

    label: str
    task: str
    mode: str
    K_pred: np.ndarray
    K_meas: np.ndarray
    err_K: float
    err_C: float
    err_dir: float
    force: float
    residual: float
    steps: int
    cct_load: float = float("nan")
    cct_err: float = float("nan")
    cct_err_wrong: float = float("nan")
    cct_err_none: float = float("nan")
    cct_eq_residual: float = float("nan")
    tol: float = TOL
    K_held_pred: np.ndarray | None = None
    K_held_meas: np.ndarray | None = None
    K_free_pred: np.ndarray | None = None
    K_free_meas: np.ndarray | None = None
    err_held: float = float("nan")
    err_free: float = float("nan")

    @property
    def stiffness_ok(self) -> bool:
        errs = [self.err_K, self.err_C, self.err_dir] + [e for e in (self.err_held, self.err_free) if not np.isnan(e)]
        return max(errs) <= self.tol

    @property
    def cct_ok(self) -> bool:
        return bool(np.isnan(self.cct_err) or (self.cct_err <= self.tol and self.cct_eq_residual <= self.tol))

    @property
    def passed(self) -> bool:
        return self.stiffness_ok and self.cct_ok


def rel_error(A: np.ndarray, B: np.ndarray) -> float:
    """``|A - B|_2 / |B|_2`` (spectral norm; vectors: Euclidean)."""
    A, B = np.atleast_1d(A), np.atleast_1d(B)
    ordv = 2 if A.ndim == 2 else None
    return float(np.linalg.norm(A - B, ord=ordv) / max(np.linalg.norm(B, ord=ordv), 1e-300))


def probe_directions(task: str) -> tuple[np.ndarray, np.ndarray]:
    """(axes, extra): wrench directions (k, 6) for the matrix columns and the extra checks."""
    m = len(task_rows(task))
    n_axes = 2 if m == 2 else 3
    axes = list(np.eye(6)[:n_axes]) + (list(np.eye(6)[3:]) if m == 6 else [])
    if m == 2:
        extra = [[1, 1, 0], [1, -1, 0]]
    else:
        extra = [[1, 1, 1], [1, -1, 1], [-1, 1, 1], [1, 1, -1]]
    extra6 = [np.r_[np.asarray(e, float) / np.linalg.norm(e), np.zeros(3)] for e in extra]
    return np.asarray(axes), np.asarray(extra6)


def _steps(C6: np.ndarray, dirs: np.ndarray, force: float | None, deflection: float) -> np.ndarray:
    """Probe size per direction: the given force (N; moments: force x 1 m), or ~``deflection``."""
    out = []
    for u in dirs:
        moment = bool(np.any(u[3:]))
        if force is not None:
            out.append(float(force))
            continue
        block = C6[3:, 3:] if moment else C6[:3, :3]
        out.append(deflection / max(float(np.linalg.norm(block, 2)), 1e-300))
    return np.asarray(out)


def _measured(D: np.ndarray, task: str) -> np.ndarray:
    """Task compliance from the axis probes' deflections D (6, k)."""
    rows = list(task_rows(task))
    return D[np.ix_(rows, range(len(rows)))]


def _held_and_free(
    case: SimCase, D: np.ndarray, moments: bool
) -> tuple[np.ndarray | None, np.ndarray | None, np.ndarray, np.ndarray]:
    """(held predicted, held measured, free predicted, free measured) from the axis probes'
    deflections D (6, k): forces along x, y (, z) first, then (``moments``) moments about x, y, z."""
    springs = case.springs
    if case.task == "xy":
        C = D[:2, :2]
        return None, None, predicted_stiffness(case.robot, case.q, case.kj, springs, "xy"), _sym(np.linalg.inv(C))
    free_pred = predicted_stiffness(case.robot, case.q, case.kj, springs, "xyz")
    free_meas = _sym(np.linalg.inv(D[:3, :3]))  # a pure force, the tool turns as the springs let it
    if not moments:
        return None, None, free_pred, free_meas
    held_pred = predicted_stiffness(case.robot, case.q, case.kj, springs, "full")
    held_meas = _sym(np.linalg.inv(D[:6, :6])[:3, :3])  # the force that translates with no rotation
    return held_pred, held_meas, free_pred, free_meas


def _sym(K: np.ndarray) -> np.ndarray:
    return 0.5 * (K + K.T)


def _stiffness_part(case: SimCase, sim: object, force: float | None, deflection: float, tol: float) -> SimRow:
    springs = case.springs
    C6 = predicted_compliance(case.robot, case.q, case.kj, springs, "full")
    K_pred = predicted_stiffness(case.robot, case.q, case.kj, springs, case.task)
    axes, extra = probe_directions(case.task)
    # task xyz probes the moments too when the chain can hold the orientation (six springs or more),
    # so that both stiffnesses a force can meet are measured whatever the task
    moments = case.task != "xy" and int(np.count_nonzero(springs)) >= 6
    if moments and len(axes) == 3:
        axes = np.concatenate([axes, np.eye(6)[3:]])
    dirs = np.concatenate([axes, extra])
    h = _steps(C6, dirs, force, deflection)
    D, _, residual, steps = probe_compliance(sim, dirs, h)  # type: ignore[arg-type]
    C_meas = _measured(D, case.task)
    K_meas = stiffness_from_compliance(C_meas, case.task)
    # direction checks: whole 6-D deflection for "full", the task rows otherwise
    rows = list(range(6)) if case.task == "full" else list(task_rows(case.task))
    err_dir = max(rel_error(D[rows, len(axes) + j], C6[np.ix_(rows, range(6))] @ u) for j, u in enumerate(extra))
    held_pred, held_meas, free_pred, free_meas = _held_and_free(case, D, moments)
    return SimRow(
        label=case.label, task=case.task, mode=case.mode, K_pred=K_pred, K_meas=K_meas,
        err_K=rel_error(K_meas, K_pred), err_C=rel_error(np.linalg.inv(K_meas), np.linalg.inv(K_pred)),
        err_dir=err_dir, force=float(h[0]), residual=residual, steps=steps, tol=tol,
        K_held_pred=held_pred, K_held_meas=held_meas, K_free_pred=free_pred, K_free_meas=free_meas,
        err_held=float("nan") if held_meas is None else rel_error(held_meas, held_pred),  # type: ignore[arg-type]
        err_free=rel_error(free_meas, free_pred),
    )  # fmt: skip


def cct_load(case: SimCase) -> np.ndarray:
    """The finite load (6,) of the CCT check: a force along the axis with the largest ``|K_G|``."""
    springs = case.springs
    n_axes = task_dim(case.task)
    norms = [np.linalg.norm(cct_term(case.robot, case.q, np.eye(6)[a], springs), 2) for a in range(n_axes)]
    a = int(np.argmax(norms))
    size = CCT_FRACTION * float(np.min(case.kj[springs])) / max(norms[a], 1e-300)
    return size * np.eye(6)[a]


def _cct_part(case: SimCase, sim: object, sign: float, deflection: float) -> dict[str, float]:
    springs = case.springs
    F0 = cct_load(case)
    axes, _ = probe_directions(case.task)
    C6 = predicted_compliance(case.robot, case.q, case.kj, springs, "full")
    D, loaded, _, _ = probe_compliance(sim, axes, _steps(C6, axes, None, deflection), base=F0)  # type: ignore[arg-type]
    q_loaded = case.q.copy()
    q_loaded[springs] = loaded.qpos
    K_meas = stiffness_from_compliance(_measured(D, case.task), case.task)

    def err(s: float) -> float:
        C = loaded_compliance(case.robot, q_loaded, case.kj, springs, case.task, F0, sign=s)
        return rel_error(K_meas, stiffness_from_compliance(C, case.task))

    # the loaded equilibrium itself against jaxstiff's Jacobian: K_j (q - q_ref) = J^T F (tau = J^T F)
    tau = joint_torque(case.robot, q_loaded, F0)[springs]
    spring = case.kj[springs] * (q_loaded - case.q)[springs]
    return dict(
        cct_load=float(np.linalg.norm(F0)), cct_err=err(sign), cct_err_wrong=err(-sign), cct_err_none=err(0.0),
        cct_eq_residual=rel_error(spring, tau),
    )  # fmt: skip


def check_case(
    case: SimCase,
    *,
    force: float | None = None,
    tol: float = TOL,
    cct: bool = True,
    cct_sign: float = 1.0,
    deflection: float = DEFLECTION,
) -> SimRow:
    """Measure one posture in MuJoCo and compare with jaxstiff (module docstring).

    Args:
        force: probe size, N (moment probes: Nm); default: a deflection of ``deflection``.
        tol: relative agreement required.
        cct: also run the finite-load (CCT) check.
        cct_sign: the sign of the CCT term in the prediction under test: +1 SPEC's (F applied to the
            TCP), -1 the seeds' printed one (which the physics must reject).

    Raises:
        ImportError: MuJoCo is not installed (the message says how to install it).
        jaxstiff.sim._measure.SettleError: MuJoCo did not come to rest.
    """
    sim = build_model(case.robot, case.q, case.kj, case.springs)
    row = _stiffness_part(case, sim, force, deflection, tol)
    if cct:
        row = dataclasses.replace(row, **_cct_part(case, sim, cct_sign, deflection))
    return row


def check_cases(cases: Sequence[SimCase], **kwargs: object) -> list[SimRow]:
    """:func:`check_case` for every case (same keyword arguments)."""
    return [check_case(c, **kwargs) for c in cases]  # type: ignore[arg-type]
