"""L1 the robot model: chain data (:mod:`._chain`), URDF reading (:mod:`._urdf`), kinematics
(:mod:`._kinematics`) and the :class:`Robot` (:mod:`._robot`). The names below load on first use
(PEP 562): ``import jaxstiff.model._chain`` / ``._urdf`` import no JAX."""

from __future__ import annotations

from typing import TYPE_CHECKING

from jaxstiff.runtime._lazy import lazy_exports

_SOURCES = {
    "._kinematics": ("fk", "fk_and_jacobian", "jacobian", "jacobian_tangent", "position_and_jacobian"),
    "._robot": ("JOINT_PRISMATIC", "JOINT_REVOLUTE", "Robot", "robot_path", "shipped_robots"),
}
__all__ = [  # the names of _SOURCES (pyright reads a literal list)
    "JOINT_PRISMATIC",
    "JOINT_REVOLUTE",
    "Robot",
    "fk",
    "fk_and_jacobian",
    "jacobian",
    "jacobian_tangent",
    "position_and_jacobian",
    "robot_path",
    "shipped_robots",
]


__getattr__, __dir__ = lazy_exports(__name__, globals(), _SOURCES)


if TYPE_CHECKING:
    from ._kinematics import fk as fk
    from ._kinematics import fk_and_jacobian as fk_and_jacobian
    from ._kinematics import jacobian as jacobian
    from ._kinematics import jacobian_tangent as jacobian_tangent
    from ._kinematics import position_and_jacobian as position_and_jacobian
    from ._robot import JOINT_PRISMATIC as JOINT_PRISMATIC
    from ._robot import JOINT_REVOLUTE as JOINT_REVOLUTE
    from ._robot import Robot as Robot
    from ._robot import robot_path as robot_path
    from ._robot import shipped_robots as shipped_robots
