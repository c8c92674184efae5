"""jaxstiff: stiffness-ellipsoid shaping and Configuration-based Stiffness Control in JAX.

The public names (``__all__``; DESIGN.md has the contract and the layers) are loaded on first use
(PEP 562 module ``__getattr__``): ``import jaxstiff`` imports neither JAX nor the solvers, so that
commands which only read result files (``jaxstiff view``) start fast. ``jaxstiff.fk`` and the like
import their module the first time they are used; ``from jaxstiff import fk`` works as before.
"""

from __future__ import annotations

import sys as _sys
from typing import TYPE_CHECKING

# Importing the package changes nothing process-wide: the command line (jaxstiff.cli) installs
# its early signal handlers and tunes glibc's allocator; a script opts in with
# jaxstiff.runtime.tune_allocator() (why and the cost: jaxstiff.runtime._allocator).
from .runtime._lazy import lazy_exports
from .runtime._moved import install_moved_modules, keep_public_names, private_module_paths
from .runtime._version import __version__ as __version__

#: the packages whose implementation modules are private (``_name.py``, or a subpackage ``_name/``
#: and its modules; each package's ``__init__`` is its way in): every former path
#: ``jaxstiff.<package>.<name>`` (and ``jaxstiff.<package>.<name>.<module>``) is answered
_PRIVATE_MODULES = (
    "cli",
    "csc",
    "model",
    "paths",
    "plots",
    "results",
    "runtime",
    "settings",
    "sim",
    "solvers",
    "stiffness",
    "sweep",
    "view",
)

#: former module paths -> where the code lives now (importing one warns and gives the new module):
#: the top-level modules from before the package layout, then the implementation modules of
#: _PRIVATE_MODULES from before they became private (made from the package folders)
MOVED = {
    "jaxstiff.robot": "jaxstiff.model._robot",
    "jaxstiff.kinematics": "jaxstiff.model._kinematics",
    "jaxstiff.ellipsoid": "jaxstiff.stiffness._ellipsoid",
    "jaxstiff.criteria": "jaxstiff.stiffness._criteria",
    "jaxstiff.sweep_config": "jaxstiff.sweep._config",
    "jaxstiff.sweep_metrics": "jaxstiff.sweep._metrics",
    "jaxstiff.sweep_report": "jaxstiff.sweep._report",
    "jaxstiff.sweep_store": "jaxstiff.sweep._store",
    "jaxstiff.shaping_inputs": "jaxstiff.shaping._inputs",
    "jaxstiff.shaping_steps": "jaxstiff.shaping._steps",
    **private_module_paths(__name__, __path__[0], _PRIVATE_MODULES),
    # pgd's waypoint operations, shared with greedy SLSQP's target step since, moved below both
    "jaxstiff.solvers.pgd.ops": "jaxstiff.solvers._problem.ops",
    "jaxstiff.solvers._pgd.ops": "jaxstiff.solvers._problem.ops",
}
#: the public module to name in a former path's warning where it is not the private module's own
#: package: the ellipsoid's names are public at the top level only (see _SOURCES)
_WAY_IN = {"jaxstiff.stiffness._ellipsoid": "jaxstiff"}
install_moved_modules(MOVED, _WAY_IN)

#: public name -> the public package (relative to this one) that exports it. ``Ellipsoid``,
#: ``ellipsoid`` and ``orientation_error`` are public here only (from the private module
#: ``stiffness._ellipsoid``, not from the former path ``jaxstiff.ellipsoid``, whose import would
#: rebind the name ``jaxstiff.ellipsoid``; not from ``stiffness``, where a function ``ellipsoid``
#: would hide the former module ``jaxstiff.stiffness.ellipsoid`` from ``import ... as m``).
_SOURCES = {
    ".csc": ("CSCResult", "csc_rollout", "csc_rollout_segments"),
    ".model": (
        "Robot",
        "fk",
        "fk_and_jacobian",
        "jacobian",
        "position_and_jacobian",
        "robot_path",
        "shipped_robots",
    ),
    ".paths": ("Path", "default_path"),
    ".results": ("ShapeResult",),
    ".settings": ("RobotSpec", "ShapeSettings"),
    ".shaping": ("shape",),
    ".stiffness._ellipsoid": ("Ellipsoid", "ellipsoid", "orientation_error"),
    ".stiffness": (
        "cartesian_stiffness",
        "cms_factor",
        "cms_scale",
        "compliance_condition",
        "f1",
        "f2",
        "frobenius",
        "get_criterion",
        "joint_stiffness",
        "offdiag",
        "register_criterion",
        "translational_axes",
        "translational_compliance",
        "translational_stiffness",
    ),
}

__all__ = [
    "CSCResult",
    "Ellipsoid",
    "Path",
    "Robot",
    "RobotSpec",
    "ShapeResult",
    "ShapeSettings",
    "__version__",
    "cartesian_stiffness",
    "cms_factor",
    "cms_scale",
    "compliance_condition",
    "csc_rollout",
    "csc_rollout_segments",
    "default_path",
    "ellipsoid",
    "f1",
    "f2",
    "fk",
    "fk_and_jacobian",
    "frobenius",
    "get_criterion",
    "jacobian",
    "joint_stiffness",
    "offdiag",
    "orientation_error",
    "position_and_jacobian",
    "register_criterion",
    "robot_path",
    "shape",
    "shipped_robots",
    "translational_axes",
    "translational_compliance",
    "translational_stiffness",
]  # the names of _SOURCES and the version


__getattr__, __dir__ = lazy_exports(__name__, globals(), _SOURCES)
keep_public_names(_sys.modules[__name__], MOVED, __all__)  # jaxstiff.ellipsoid stays the function


if TYPE_CHECKING:  # the names as the type checker and the IDE see them
    from .csc import CSCResult as CSCResult
    from .csc import csc_rollout as csc_rollout
    from .csc import csc_rollout_segments as csc_rollout_segments
    from .model import Robot as Robot
    from .model import fk as fk
    from .model import fk_and_jacobian as fk_and_jacobian
    from .model import jacobian as jacobian
    from .model import position_and_jacobian as position_and_jacobian
    from .model import robot_path as robot_path
    from .model import shipped_robots as shipped_robots
    from .paths import Path as Path
    from .paths import default_path as default_path
    from .results import ShapeResult as ShapeResult
    from .settings import RobotSpec as RobotSpec
    from .settings import ShapeSettings as ShapeSettings
    from .shaping import shape as shape
    from .stiffness import cartesian_stiffness as cartesian_stiffness
    from .stiffness import cms_factor as cms_factor
    from .stiffness import cms_scale as cms_scale
    from .stiffness import compliance_condition as compliance_condition
    from .stiffness import f1 as f1
    from .stiffness import f2 as f2
    from .stiffness import frobenius as frobenius
    from .stiffness import get_criterion as get_criterion
    from .stiffness import joint_stiffness as joint_stiffness
    from .stiffness import offdiag as offdiag
    from .stiffness import register_criterion as register_criterion
    from .stiffness import translational_axes as translational_axes
    from .stiffness import translational_compliance as translational_compliance
    from .stiffness import translational_stiffness as translational_stiffness
    from .stiffness._ellipsoid import Ellipsoid as Ellipsoid
    from .stiffness._ellipsoid import ellipsoid as ellipsoid
    from .stiffness._ellipsoid import orientation_error as orientation_error
