"""Static deflection measured in MuJoCo: settle under a wrench at the TCP, read the TCP's pose.

Settling is MuJoCo's own dynamics (``mj_step``: its kinematics, its joint springs, its mapping of
``xfrc_applied`` into joint torques), not a static solve with jaxstiff's formulas. The damping of
every spring joint is ``SETTLE_TIME * kj`` and the masses are tiny, so the motion is overdamped:
with MuJoCo's Euler step (damping implicit) each step moves the posture about half-way towards
the equilibrium of the current step (``TIMESTEP / SETTLE_TIME = 0.5``), and the error shrinks
geometrically. The settle stops when the **residual generalised force** at rest (``qvel = 0``:
springs + the applied wrench, MuJoCo's ``qfrc_smooth``) is below ``tol`` (1e-9) relative to the
spring torques, and fails (``SettleError``) if that takes more than ``max_steps``.

A deflection is the TCP's motion from the unloaded posture: translation (m) and rotation vector
(rad) of ``R_loaded R_ref^T``, both in the base (world) frame, as the rows ``[v; w]`` of the
geometric Jacobian. A compliance column is a central difference of two settles, ``+h`` and
``-h`` (second-order terms cancel), around a base wrench (zero, or the finite load of the CCT
check).
"""

from __future__ import annotations

import contextlib
import dataclasses
from collections.abc import Iterator
from typing import Any

import numpy as np

from jaxstiff.sim._build import SimModel, require_mujoco

__all__ = ["Settled", "settle", "deflection", "SETTLE_TOL", "FLOOR_TOL", "MAX_STEPS"]

SETTLE_TOL = 1e-9  #: residual generalised force / spring torques at which a settle has converged
FLOOR_TOL = 1e-6  #: a residual that stops falling below this is round-off's floor: accepted (and reported)
MAX_STEPS = 20000  #: a settle that needs more steps fails


class SettleError(RuntimeError):
    """MuJoCo did not settle within the step budget (an unstable or singular load case)."""


@dataclasses.dataclass(frozen=True)
class Settled:
    """An equilibrium found by MuJoCo.

    Attributes:
        qpos: (n_springs,) joint values, rad (m).
        spring: (n_springs,) MuJoCo's spring torques there, Nm (N).
        position: (3,) TCP position, m, base frame.
        rotation: (3, 3) TCP orientation, base frame.
        residual: ``|qfrc_smooth|_inf / |qfrc_spring|_inf`` at rest (0 for a zero load; the
            change of ``qfrc_spring`` since the base equilibrium for an increment).
        steps: MuJoCo steps taken.
    """

    qpos: np.ndarray
    spring: np.ndarray
    position: np.ndarray
    rotation: np.ndarray
    residual: float
    steps: int


def _residual(mujoco: Any, sim: SimModel, data: Any, wrench: np.ndarray, base_spring: np.ndarray | None) -> float:
    """Relative force residual of ``data.qpos`` at rest under ``wrench`` (also leaves the pose computed)."""
    data.qvel[:] = 0.0
    data.xfrc_applied[sim.tcp_body] = wrench
    mujoco.mj_forward(sim.model, data)
    change = data.qfrc_spring if base_spring is None else data.qfrc_spring - base_spring
    scale = float(np.max(np.abs(change))) if change.size else 0.0
    res = float(np.max(np.abs(data.qfrc_smooth))) if data.qfrc_smooth.size else 0.0
    return 0.0 if res == 0.0 else res / max(scale, 1e-300)


@contextlib.contextmanager
def mujoco_messages(mujoco: Any) -> Iterator[list[str]]:
    """MuJoCo's warnings while the block runs, collected into the yielded list instead of going to
    stdout and a ``MUJOCO_LOG.TXT`` in the working folder (MuJoCo's default: a stray file left by
    every run that meets one, e.g. a huge probe force); the previous handler is restored after."""
    seen: list[str] = []
    previous = mujoco.get_mju_user_warning()
    mujoco.set_mju_user_warning(seen.append)
    try:
        yield seen
    finally:
        mujoco.set_mju_user_warning(previous)


def settle(
    sim: SimModel,
    wrench: np.ndarray,
    *,
    start: np.ndarray | None = None,
    base: Settled | None = None,
    tol: float = SETTLE_TOL,
    max_steps: int = MAX_STEPS,
) -> Settled:
    """Let the model come to rest under ``wrench`` = (force N, moment Nm) at the TCP, base frame.

    Args:
        start: initial joint values (default: ``base``'s, else the spring rest posture); the
            velocity starts at 0.
        base: an equilibrium this settle is a small increment from: the residual is then measured
            against the *change* of the spring torques since ``base`` (else against the spring
            torques), so a small probe on top of a finite load is resolved to ``tol`` too.

    Raises:
        SettleError: not at rest within ``max_steps`` (the message gives the residual).
    """
    mujoco = require_mujoco()
    model = sim.model
    data = mujoco.MjData(model)
    data.qpos[:] = start if start is not None else base.qpos if base is not None else sim.q_ref
    base_spring = None if base is None else base.spring
    wrench = np.asarray(wrench, dtype=float)
    steps = 0
    check_every = 10
    res = _residual(mujoco, sim, data, wrench, base_spring)
    prev = np.inf
    with mujoco_messages(mujoco) as said:
        while res > tol and not (res < FLOOR_TOL and res > 0.5 * prev):  # converged, or at round-off's floor
            prev = res
            if steps >= max_steps:
                raise SettleError(
                    f"MuJoCo did not settle within {max_steps} steps under the wrench {wrench.tolist()} "
                    f"(residual {res:.2e} > {tol:g}); the load may be past a stability limit"
                )
            data.xfrc_applied[sim.tcp_body] = wrench
            for _ in range(check_every):
                mujoco.mj_step(model, data)
            steps += check_every
            if not np.all(np.isfinite(data.qpos)) or said:
                why = f" (MuJoCo: {said[0]})" if said else ""
                raise SettleError(f"MuJoCo diverged under the wrench {wrench.tolist()} after {steps} steps{why}")
            res = _residual(mujoco, sim, data, wrench, base_spring)
    return Settled(
        qpos=data.qpos.copy(),
        spring=data.qfrc_spring.copy(),
        position=data.site_xpos[sim.tcp_site].copy(),
        rotation=data.site_xmat[sim.tcp_site].reshape(3, 3).copy(),
        residual=res,
        steps=steps,
    )


def deflection(ref: Settled, loaded: Settled) -> np.ndarray:
    """6-vector ``[dx; dtheta]`` (m; rad) of the TCP from ``ref`` to ``loaded``, base frame."""
    mujoco = require_mujoco()
    R = loaded.rotation @ ref.rotation.T
    quat = np.zeros(4)
    mujoco.mju_mat2Quat(quat, np.ascontiguousarray(R).ravel())
    rotvec = np.zeros(3)
    mujoco.mju_quat2Vel(rotvec, quat, 1.0)  # axis * angle
    return np.concatenate([loaded.position - ref.position, rotvec])


def probe_compliance(
    sim: SimModel, directions: np.ndarray, step: np.ndarray, base: np.ndarray | None = None
) -> tuple[np.ndarray, Settled, float, int]:
    """Measured response to wrench increments by central differences.

    Args:
        directions: (k, 6) unit wrench directions (force first, then moment), base frame.
        step: (k,) increment per direction (N for a force direction, Nm for a moment).
        base: (6,) wrench around which to probe (default zero: the unloaded posture).

    Returns:
        ``(D, ref, residual, steps)``: D (6, k) with column j = (deflection(+h) - deflection(-h))
        / (2 h) along direction j (m/N, rad/N, m/Nm, rad/Nm); the equilibrium under ``base``; the
        worst settle residual; the total MuJoCo steps.
    """
    base = np.zeros(6) if base is None else np.asarray(base, dtype=float)
    ref = settle(sim, base)
    D = np.empty((6, len(directions)))
    worst, steps = ref.residual, ref.steps
    for j, (u, h) in enumerate(zip(np.asarray(directions, dtype=float), np.asarray(step, dtype=float), strict=True)):
        plus = settle(sim, base + h * u, base=ref)
        minus = settle(sim, base - h * u, base=ref)
        D[:, j] = (deflection(ref, plus) - deflection(ref, minus)) / (2.0 * h)
        worst = max(worst, plus.residual, minus.residual)
        steps += plus.steps + minus.steps
    return D, ref, worst, steps
