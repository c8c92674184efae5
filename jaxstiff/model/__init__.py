"""L1 the robot model: chain data (:mod:`.chain`), URDF reading (:mod:`.urdf`), kinematics
(:mod:`.kinematics`) and the :class:`Robot` (:mod:`.robot`)."""

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
