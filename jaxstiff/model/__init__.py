"""L1 the robot model: chain data (:mod:`.chain`), URDF reading (:mod:`.urdf`), kinematics
(:mod:`.kinematics`) and the :class:`Robot` (:mod:`.robot`). The names below load on first use
(PEP 562): ``import jaxstiff.model.chain`` / ``.urdf`` import no JAX."""

from __future__ import annotations

from typing import TYPE_CHECKING

from jaxstiff.runtime.lazy import lazy_exports

_SOURCES = {
    ".kinematics": ("fk", "fk_and_jacobian", "jacobian", "jacobian_tangent", "position_and_jacobian"),
    ".robot": ("JOINT_PRISMATIC", "JOINT_REVOLUTE", "Robot", "robot_path", "shipped_robots"),
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
    from .kinematics import fk as fk
    from .kinematics import fk_and_jacobian as fk_and_jacobian
    from .kinematics import jacobian as jacobian
    from .kinematics import jacobian_tangent as jacobian_tangent
    from .kinematics import position_and_jacobian as position_and_jacobian
    from .robot import JOINT_PRISMATIC as JOINT_PRISMATIC
    from .robot import JOINT_REVOLUTE as JOINT_REVOLUTE
    from .robot import Robot as Robot
    from .robot import robot_path as robot_path
    from .robot import shipped_robots as shipped_robots
