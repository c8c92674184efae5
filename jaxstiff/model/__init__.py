"""L1 the robot model: chain data (:mod:`.chain`), URDF reading (:mod:`.urdf`), kinematics
(:mod:`.kinematics`) and the :class:`Robot` (:mod:`.robot`). The names below load on first use
(PEP 562): ``import jaxstiff.model.chain`` / ``.urdf`` import no JAX."""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

_SOURCES = {
    ".kinematics": ("fk", "fk_and_jacobian", "jacobian", "jacobian_tangent", "position_and_jacobian"),
    ".robot": ("JOINT_PRISMATIC", "JOINT_REVOLUTE", "Robot", "robot_path", "shipped_robots"),
}
_LAZY = {name: module for module, names in _SOURCES.items() for name in names}
__all__ = sorted(_LAZY)


def __getattr__(name: str) -> Any:
    """Load a public name from its module on first use (and keep it here)."""
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'jaxstiff.model' has no attribute {name!r}")
    value = getattr(importlib.import_module(module, __name__), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))


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
