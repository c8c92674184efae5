"""Robot: a serial chain read once from a URDF into a static, hashable description.

The chain between a base link and a tip link is extracted from any URDF tree. Fixed joints are
folded into the origin of the next movable joint (or into the tool transform after the tip).
Revolute, continuous and prismatic joints are supported; mimic joints inside the chain are refused
by name. Every number of the chain is kept as a Python float inside tuples, so a :class:`Robot` is
hashable and ``jax.jit`` compiles one kernel per robot: the geometry becomes compile-time
constants, which lets the kinematics kernel skip every multiplication by a structural zero or one.

Example:
    >>> import jaxstiff
    >>> robot = jaxstiff.Robot.from_urdf(jaxstiff.robot_path("kuka_lwr4"), locked={"lwr_a7": 0.0})
    >>> robot.n, robot.joint_names[0]
    (7, 'lwr_a1')
"""

from __future__ import annotations

import dataclasses
import os
from collections.abc import Mapping, Sequence

import jax
import numpy as np
from numpy.typing import ArrayLike

from jaxstiff.model._chain import JOINT_PRISMATIC, JOINT_REVOLUTE, Chain, check_q
from jaxstiff.model._kinematics import fk, fk_and_jacobian, jacobian
from jaxstiff.model._reach import Reach, chain_reach
from jaxstiff.model._shipped import robot_path, shipped_robots
from jaxstiff.model._urdf import parse_urdf_chain

__all__ = ["Robot", "robot_path", "shipped_robots", "JOINT_REVOLUTE", "JOINT_PRISMATIC"]


@dataclasses.dataclass(frozen=True, eq=False, repr=False)  # (Chain's one-line repr)
class Robot(Chain):
    """A :class:`~jaxstiff.model._chain.Chain` read from a URDF, with FK and Jacobian methods.

    The fields, units and frames are :class:`~jaxstiff.model._chain.Chain`'s.
    """

    # ------------------------------------------------------------------ construction
    @staticmethod
    def from_urdf(
        path: str | os.PathLike,
        base_link: str | None = None,
        tip_link: str | None = None,
        locked: Mapping[str, float] | None = None,
        tcp: Sequence[float] | np.ndarray | None = None,
    ) -> Robot:
        """Read the serial chain between ``base_link`` and ``tip_link`` of a URDF.

        Args:
            path: URDF file, or the name of a shipped robot (``"kuka_lwr4"``, ``"planar_3r"``).
            base_link: link the chain starts at; default: the tree's root link.
            tip_link: link the chain ends at; default: the automatic tip of
                :func:`jaxstiff.model._urdf.tip_candidates`: gripper and finger joints cut off, the
                leaf reached through the most actuated joints, ties broken by finger parts and
                end-effector names (tcp, tool, ee, flange); still tied: an error lists them all.
            locked: ``{joint_name: value}`` joints held at a value (rad or m). A locked joint
                stays in ``q`` and in the joint list but is not free for the position task
                (seed 000 locks the LWR's 7th joint at 0).
            tcp: tool offset after the tip link: a 3-vector (m, in the tip frame), a 6-vector
                ``(x, y, z, roll, pitch, yaw)`` (m, rad; as the commands' ``--tcp``) or a 4x4
                homogeneous transform.

        Fixed joints fold into the next joint's origin (or the tool transform after the tip);
        continuous joints get limits ``(-inf, inf)``. A ``<limit>`` without ``lower``/``upper``
        gets 0 for the missing one, as the URDF specification and urdfdom say; a movable joint
        whose range is then empty (lower == upper) draws a ``UserWarning`` naming it.

        Returns:
            The robot.

        Raises:
            FileNotFoundError: the file does not exist.
            ValueError: malformed or unsafe XML, unknown links or joints, no chain between the
                links, ambiguous tip, bad axis/origin/limits, mimic joints in the chain, a locked
                value outside its limits, a bad ``tcp``.
        """
        return Robot(**parse_urdf_chain(path, base_link, tip_link, locked, tcp))

    # ------------------------------------------------------------------ kinematics
    def fk(self, q: ArrayLike) -> jax.Array:
        """TCP pose ``T_base_tcp`` (..., 4, 4) for joint values ``q`` (..., n). See :func:`jaxstiff.fk`."""
        return fk(self, check_q(self, q))

    def jacobian(self, q: ArrayLike) -> jax.Array:
        """Geometric Jacobian ``J_base`` (..., 6, n), rows [v; w]. See :func:`jaxstiff.jacobian`."""
        return jacobian(self, check_q(self, q))

    def fk_and_jacobian(self, q: ArrayLike) -> tuple[jax.Array, jax.Array]:
        """Both in one pass: ``(T (..., 4, 4), J (..., 6, n))``."""
        return fk_and_jacobian(self, check_q(self, q))

    # ------------------------------------------------------------------ workspace
    def reach(self) -> Reach:
        """The shell that holds every TCP position within the joint limits: ``Reach(centre (3,) m,
        outer m, inner m, centre_joint)``, ``inner <= |p_tcp - centre| <= outer`` for every posture
        (bounds proved from the joint origins, axes and limits; :mod:`jaxstiff.model._reach`).
        ``jaxstiff.shape``, ``csc_rollout`` and their commands refuse waypoints outside it before
        any solve (:func:`jaxstiff.model._reach.check_reach`)."""
        return chain_reach(self)
