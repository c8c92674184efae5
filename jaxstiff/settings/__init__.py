"""L3 settings: frozen, typed settings that are the single source of defaults, units and
validation for the API, the command line and the sweep config. Exported: the settings of a call
(:class:`ShapeSettings`, :class:`CSCSettings`, :class:`RobotSpec` with :data:`DEFAULT_LOCKS`), the
options of each solver (:class:`SLSQPOptions`, :class:`PGDOptions`, :class:`HybridOptions`,
:class:`TrajectoryOptions`; a solver object's fields) and their base :class:`Settings`. The code is
in private modules (``_base``: how a setting is written once, ``_shape``, ``_csc``, ``_robot``,
``_solvers``)."""

from jaxstiff.runtime._moved import former_names

from ._base import Settings
from ._csc import CSCSettings
from ._robot import DEFAULT_LOCKS, RobotSpec
from ._shape import ShapeSettings
from ._solvers import HybridOptions, PGDOptions, SLSQPOptions, TrajectoryOptions

__all__ = [
    "CSCSettings",
    "DEFAULT_LOCKS",
    "HybridOptions",
    "PGDOptions",
    "RobotSpec",
    "SLSQPOptions",
    "Settings",
    "ShapeSettings",
    "TrajectoryOptions",
]

__getattr__ = former_names(__name__, {})  # the former modules (jaxstiff.settings.X read as an attribute)
