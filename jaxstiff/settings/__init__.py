"""L3 settings: frozen, typed settings that are the single source of defaults, units and
validation for the API, the command line and the sweep config (see :mod:`._base`)."""

from ._base import Settings as Settings
from ._csc import CSCSettings as CSCSettings
from ._robot import DEFAULT_LOCKS as DEFAULT_LOCKS
from ._robot import RobotSpec as RobotSpec
from ._shape import ShapeSettings as ShapeSettings
