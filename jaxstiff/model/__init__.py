"""L1 the robot model: the :class:`Robot` and its kinematics, for users who build on the chain's
maps. The code is in private modules: chain data (``_chain``), URDF reading (``_urdf``), kinematics
(``_kinematics``, ``_kinematics_scan``, ``_kinematics_framed``), the reach bound (``_reach``), the
:class:`Robot` (``_robot``), the shipped robots (``_shipped``). The names below load on first use
(PEP 562): ``import jaxstiff.model`` imports no JAX."""

from __future__ import annotations

from typing import TYPE_CHECKING

from jaxstiff.runtime._lazy import lazy_exports

_SOURCES = {
    "._kinematics": ("fk", "fk_and_jacobian", "jacobian", "position_and_jacobian"),
    "._reach": ("UnreachableError",),
    "._robot": ("JOINT_PRISMATIC", "JOINT_REVOLUTE", "Robot", "robot_path", "shipped_robots"),
}
__all__ = [  # the names of _SOURCES (pyright reads a literal list)
    "JOINT_PRISMATIC",
    "JOINT_REVOLUTE",
    "Robot",
    "UnreachableError",
    "fk",
    "fk_and_jacobian",
    "jacobian",
    "position_and_jacobian",
    "robot_path",
    "shipped_robots",
]

#: names this package exported before, answered with a DeprecationWarning naming their module
_FORMER = {"jacobian_tangent": "jaxstiff.model._kinematics"}

__getattr__, __dir__ = lazy_exports(__name__, globals(), _SOURCES, _FORMER)


if TYPE_CHECKING:
    from ._kinematics import fk as fk
    from ._kinematics import fk_and_jacobian as fk_and_jacobian
    from ._kinematics import jacobian as jacobian
    from ._kinematics import position_and_jacobian as position_and_jacobian
    from ._reach import UnreachableError as UnreachableError
    from ._robot import JOINT_PRISMATIC as JOINT_PRISMATIC
    from ._robot import JOINT_REVOLUTE as JOINT_REVOLUTE
    from ._robot import Robot as Robot
    from ._robot import robot_path as robot_path
    from ._robot import shipped_robots as shipped_robots
