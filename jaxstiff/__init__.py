"""jaxstiff: stiffness-ellipsoid shaping and Configuration-based Stiffness Control in JAX.

The public names are re-exported here explicitly; see DESIGN.md for the contract and the layers.
"""
# ruff: noqa: E402  (the early-signal recorder must run before anything imports JAX)

# first, before JAX is imported: a Ctrl-C while the `jaxstiff` command starts up is remembered,
# not lost (see jaxstiff.runtime.early_signals; nothing changes when imported as a library)
from .runtime.early_signals import record_early_signals as _record_early_signals

_record_early_signals()

# the former module paths (jaxstiff.ellipsoid, ...) are loaded before the names that shadow them
from .criteria import f1 as f1
from .criteria import f2 as f2
from .criteria import frobenius as frobenius
from .criteria import get_criterion as get_criterion
from .criteria import offdiag as offdiag
from .criteria import register_criterion as register_criterion
from .csc import CSCResult as CSCResult
from .csc import csc_rollout as csc_rollout
from .csc import csc_rollout_segments as csc_rollout_segments
from .ellipsoid import Ellipsoid as Ellipsoid
from .ellipsoid import ellipsoid as ellipsoid
from .ellipsoid import orientation_error as orientation_error
from .kinematics import fk as fk
from .kinematics import fk_and_jacobian as fk_and_jacobian
from .kinematics import jacobian as jacobian
from .kinematics import position_and_jacobian as position_and_jacobian
from .paths import Path as Path
from .paths import default_path as default_path
from .results import ShapeResult as ShapeResult
from .robot import Robot as Robot
from .robot import robot_path as robot_path
from .robot import shipped_robots as shipped_robots
from .runtime.version import __version__ as __version__
from .settings import RobotSpec as RobotSpec
from .settings import ShapeSettings as ShapeSettings
from .shaping import shape as shape
from .stiffness import cartesian_stiffness as cartesian_stiffness
from .stiffness import cms_factor as cms_factor
from .stiffness import cms_scale as cms_scale
from .stiffness import compliance_condition as compliance_condition
from .stiffness import joint_stiffness as joint_stiffness
from .stiffness import translational_stiffness as translational_stiffness
