"""A jaxstiff chain as a MuJoCo model: one body per actuated joint, springs at the reference posture.

The model is built with MuJoCo's model-editing API (``mujoco.MjSpec``) from the parsed chain
(:class:`jaxstiff.model._chain.Chain` fields), never from the URDF text, so MuJoCo sees exactly the
frames jaxstiff uses, rotated origins and tilted axes included:

* body ``link_i`` hangs off ``link_{i-1}`` (the world for i = 0) at ``Chain.origins[i]`` (position
  and the rotation as a quaternion); a spring joint sits at the body origin with axis
  ``Chain.axes[i]`` in the body frame: ``hinge`` for revolute/continuous joints, ``slide`` for
  prismatic ones. MuJoCo then places the body at ``parent * origin * motion(axis, q_i)``, the
  product jaxstiff's FK uses.
* each spring has stiffness ``kj_i`` (Nm/rad, N/m) and rest value ``springref = q_i`` (the
  waypoint's posture), so the unloaded equilibrium is the posture itself; the joint range is
  not enforced (a limit would be a second, one-sided spring).
* a **rigid** locked joint (SPEC section 1, the default) gets no MuJoCo joint at all: its motion at
  the locked value is folded into the body's fixed pose; a locked joint that keeps its spring
  (``locked_joints = "spring"``) is an ordinary spring joint with rest value = the locked value.
* body ``tcp`` is welded (no joint) to the last link at ``Chain.tip`` (tip link + tool offset) and
  carries a site ``tcp``; its centre of mass is its origin, so a wrench in ``xfrc_applied`` of this
  body acts at the TCP point (MuJoCo applies ``xfrc_applied`` at the body's centre of mass).
* every body has a small mass and inertia (only the settling speed depends on them, never the
  equilibrium), gravity is off, there are no geoms (no contacts), and every spring joint has a
  damping ``settle_time * kj_i``: with MuJoCo's Euler integrator, which treats joint damping
  implicitly, that makes the settling heavily overdamped (see :mod:`jaxstiff.sim._measure`).

Angles are radians (``compiler.degree = False``: MuJoCo's default is degrees, which would read the
spring rest values ``springref`` as degrees).
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np

from jaxstiff.model._chain import JOINT_PRISMATIC, Chain

__all__ = ["BODY_MASS", "TIMESTEP", "SETTLE_TIME"]

#: what to tell a user without MuJoCo
MUJOCO_MISSING = 'the physics check needs MuJoCo: pip install "jaxstiff[sim]"'

BODY_MASS = 1e-6  #: kg per body (inertia BODY_MASS * 1e-3 kg m^2): small against the damping
TIMESTEP = 0.01  #: s, MuJoCo's step
SETTLE_TIME = 0.02  #: s, damping / stiffness of every spring joint (TIMESTEP / SETTLE_TIME = 0.5)


def require_mujoco() -> Any:
    """The ``mujoco`` module, or ImportError saying how to install it."""
    try:
        import mujoco
    except ImportError as exc:
        raise ImportError(f"{MUJOCO_MISSING} ({exc})") from None
    return mujoco


@dataclasses.dataclass(frozen=True)
class SimModel:
    """A compiled MuJoCo model of one posture.

    Attributes:
        model: the ``mujoco.MjModel``.
        q_ref: (n_springs,) spring rest values = the posture's values of the spring joints.
        springs: (n,) bool, the chain joints that are MuJoCo joints (free + spring-locked), in order.
        tcp_body: body id whose ``xfrc_applied`` acts at the TCP.
        tcp_site: site id of the TCP.
    """

    model: Any
    q_ref: np.ndarray
    springs: np.ndarray
    tcp_body: int
    tcp_site: int


def _quat(R: np.ndarray) -> list[float]:
    mujoco = require_mujoco()
    quat = np.zeros(4)
    mujoco.mju_mat2Quat(quat, np.ascontiguousarray(R, dtype=float).ravel())
    return quat.tolist()


def _motion(axis: np.ndarray, kind: int, value: float) -> np.ndarray:
    """4x4 motion of a joint about/along its unit axis (Rodrigues; translation for prismatic)."""
    M = np.eye(4)
    if kind == JOINT_PRISMATIC:
        M[:3, 3] = axis * value
        return M
    K = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    M[:3, :3] = np.eye(3) + np.sin(value) * K + (1 - np.cos(value)) * (K @ K)
    return M


def _add_body(mujoco: Any, parent: Any, name: str, T: np.ndarray) -> Any:
    inertia = BODY_MASS * 1e-3
    return parent.add_body(
        name=name, pos=T[:3, 3].tolist(), quat=_quat(T[:3, :3]), mass=BODY_MASS, ipos=[0.0, 0.0, 0.0],
        inertia=[inertia] * 3, explicitinertial=True,
    )  # fmt: skip


def build_model(chain: Chain, q: np.ndarray, kj: np.ndarray, springs: np.ndarray) -> SimModel:
    """MuJoCo model of ``chain`` with spring joints at posture ``q`` (module docstring).

    Args:
        chain: the robot (a :class:`jaxstiff.Robot` or any Chain).
        q: (n,) posture, rad (m for prismatic joints), locked joints at their locked values.
        kj: (n,) joint stiffnesses, Nm/rad (N/m); only the entries of spring joints are read.
        springs: (n,) bool, True for a joint that gets a spring (free joints, and locked joints
            kept as springs); False for a rigid locked joint (fixed at ``q``).
    """
    mujoco = require_mujoco()
    q = np.asarray(q, dtype=float)
    kj = np.asarray(kj, dtype=float)
    springs = np.asarray(springs, dtype=bool)
    spec = mujoco.MjSpec()
    spec.compiler.degree = False
    spec.modelname = f"jaxstiff_{chain.name}"
    spec.option.gravity = [0.0, 0.0, 0.0]
    spec.option.timestep = TIMESTEP
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_EULER  # joint damping implicit
    parent = spec.worldbody
    for i, name in enumerate(chain.joint_names):
        T = chain.origin_matrix(i)
        axis = np.asarray(chain.axes[i], dtype=float)
        if not springs[i]:
            T = T @ _motion(axis, chain.joint_types[i], float(q[i]))  # rigid: fixed at its value
        body = _add_body(mujoco, parent, f"link_{i}_{name}", T)
        if springs[i]:
            if not (np.isfinite(kj[i]) and kj[i] > 0):
                raise ValueError(f"joint {name!r}: kj must be a finite positive number for its spring, got {kj[i]!r}")
            kind = (
                mujoco.mjtJoint.mjJNT_SLIDE if chain.joint_types[i] == JOINT_PRISMATIC else mujoco.mjtJoint.mjJNT_HINGE
            )
            joint = body.add_joint(name=name, type=kind, axis=axis.tolist(), pos=[0.0, 0.0, 0.0])
            joint.limited = mujoco.mjtLimited.mjLIMITED_FALSE
            joint.springref = float(q[i])
            joint.stiffness = [float(kj[i]), 0.0, 0.0]  # linear spring (MuJoCo 4's polynomial, order 1)
            joint.damping = [float(kj[i]) * SETTLE_TIME, 0.0, 0.0]
        parent = body
    tcp = _add_body(mujoco, parent, "tcp", chain.tip_matrix)
    tcp.add_site(name="tcp")
    model = spec.compile()
    return SimModel(
        model=model,
        q_ref=q[springs].copy(),
        springs=springs.copy(),
        tcp_body=int(mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, "tcp")),
        tcp_site=int(mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, "tcp")),
    )
