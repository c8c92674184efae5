"""Former module path, kept so that old imports keep working: the code lives in :mod:`jaxstiff.model.robot`."""

from jaxstiff.model.robot import JOINT_PRISMATIC as JOINT_PRISMATIC
from jaxstiff.model.robot import JOINT_REVOLUTE as JOINT_REVOLUTE
from jaxstiff.model.robot import Robot as Robot
from jaxstiff.model.robot import robot_path as robot_path
from jaxstiff.model.robot import shipped_robots as shipped_robots
