"""L3 settings: frozen, typed settings that are the single source of defaults, units and
validation for the API, the command line and the sweep config (see :mod:`.base`)."""

from .base import Settings as Settings
from .csc import CSCSettings as CSCSettings
from .robot import DEFAULT_LOCKS as DEFAULT_LOCKS
from .robot import RobotSpec as RobotSpec
from .shape import ShapeSettings as ShapeSettings
