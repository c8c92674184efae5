"""jaxstiff's predictions that the physics check compares against (SPEC section 2).

Only the spring joints count (:func:`jaxstiff.sim._setup.spring_mask`): their Jacobian columns
``J_k`` and stiffnesses ``kj_k``.

* Unloaded compliance of the task rows, ``C = J_s K_j^-1 J_s^T`` (S0-4), from
  :func:`jaxstiff.stiffness.compliance`; for ``"full"`` the 6x6 one.
* Translational stiffness ``K_T`` from :func:`jaxstiff.stiffness.translational_stiffness`:
  ``C^-1`` for ``"xy"``/``"xyz"`` (tool free to turn), the top-left block of the 6x6 ``K_C`` for
  ``"full"`` (tool orientation held).
* Loaded compliance under a finite wrench F applied to the TCP (CCT, S1-7b, S0-2). Joint
  equilibrium ``K_j (q - q_ref) = J(q)^T F``; its differential at fixed F is
  ``(K_j - K_G) dq = J^T dF`` with ``K_G = d(J^T F)/dq``, so ``dx = J (K_j - K_G)^-1 J^T dF``.
  ``K_G`` comes from :func:`jaxstiff.stiffness.joint_stiffness` (SPEC: ``K_q = J^T K_x J + K_G``,
  F the wrench applied *to* the TCP); ``sign = -1`` evaluates the seeds' printed sign instead
  (``K_q = J^T K_x J - K_G``, right only for the wrench the robot exerts), which the physics must
  reject. Where ``J_s`` is square, ``K_q = K_j`` with ``K_x = C_loaded^-1`` is exactly
  ``joint_stiffness(J, K_x, F)``.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

from jaxstiff.model._chain import Chain
from jaxstiff.stiffness import compliance, joint_stiffness, task_rows, translational_stiffness

__all__: list[str] = []


def _jacobian(robot: Chain, q: np.ndarray) -> np.ndarray:
    from jaxstiff.model._kinematics import jacobian

    # A locked joint kept as a spring deflects under a load, so a loaded posture's value there
    # differs from the locked one by design: use the kernel without the locked-value check.
    kernel = getattr(jacobian, "__wrapped__", jacobian)
    with jax.enable_x64(True):
        return np.asarray(kernel(robot, jnp.asarray(q, dtype=jnp.float64)))


def joint_torque(robot: Chain, q: np.ndarray, wrench: np.ndarray) -> np.ndarray:
    """``tau = J(q)^T F`` (n,), Nm (N): the joint torques of a wrench (6,) applied to the TCP, base frame."""
    return _jacobian(robot, q).T @ np.asarray(wrench, dtype=float)


def predicted_compliance(robot: Chain, q: np.ndarray, kj: np.ndarray, springs: np.ndarray, task: str) -> np.ndarray:
    """``J_s K_j^-1 J_s^T`` over the spring joints (m, m); m = 6 for ``"full"``. m/N, rad/Nm."""
    J = _jacobian(robot, q)[:, springs]
    with jax.enable_x64(True):
        return np.asarray(compliance(jnp.asarray(J), jnp.asarray(np.asarray(kj, float)[springs]), task))


def predicted_stiffness(robot: Chain, q: np.ndarray, kj: np.ndarray, springs: np.ndarray, task: str) -> np.ndarray:
    """jaxstiff's ``K_T`` (2x2 or 3x3, N/m) over the spring joints."""
    J = _jacobian(robot, q)[:, springs]
    with jax.enable_x64(True):
        return np.asarray(translational_stiffness(jnp.asarray(J), jnp.asarray(np.asarray(kj, float)[springs]), task))


def stiffness_from_compliance(C: np.ndarray, task: str) -> np.ndarray:
    """``K_T`` of a (measured) task compliance: ``C^-1``, or for ``"full"`` the block of the 6x6 inverse."""
    K = np.linalg.inv(C)
    if task == "full":
        K = K[:3, :3]
    return 0.5 * (K + K.T)


def cct_term(robot: Chain, q: np.ndarray, wrench: np.ndarray, springs: np.ndarray) -> np.ndarray:
    """``K_G = d(J^T F)/dq`` over the spring joints (k, k), Nm/rad, from :func:`joint_stiffness`.

    ``wrench``: (6,) force (N) and moment (Nm) applied to the TCP, base frame.
    """
    J = _jacobian(robot, q)
    with jax.enable_x64(True):
        KG = joint_stiffness(
            jnp.asarray(J), jnp.zeros((6, 6)), jnp.asarray(wrench, dtype=jnp.float64), robot=robot,
            q=jnp.asarray(q, dtype=jnp.float64), task="full",
        )  # fmt: skip
    return np.asarray(KG)[np.ix_(springs, springs)]


def loaded_compliance(
    robot: Chain, q: np.ndarray, kj: np.ndarray, springs: np.ndarray, task: str, wrench: np.ndarray, sign: float = 1.0
) -> np.ndarray:
    """Compliance of the task rows at the loaded posture q under ``wrench``: ``J_s (K_j - sign K_G)^-1 J_s^T``.

    ``sign = +1`` is SPEC's convention (F applied to the TCP), ``-1`` the wrong one, ``0`` ignores
    the CCT term. (m, m); m = 6 for ``"full"``.
    """
    J = _jacobian(robot, q)[:, springs]
    Js = J[list(task_rows(task))]
    Kq = np.diag(np.asarray(kj, float)[springs]) - sign * cct_term(robot, q, wrench, springs)
    return Js @ np.linalg.solve(Kq, Js.T)
