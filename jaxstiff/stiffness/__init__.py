"""L2 stiffness: the maps from joint stiffness to Cartesian stiffness and back, the stiffness
ellipsoid and the shaping criteria, for users who compose their own loops. The code is in private
modules: task rows (``_tasks``), Cartesian/translational stiffness (``_core``, the docs' API page
shows it whole), CMS (``_cms``), the Schur complement's tangents (``_schur``), the ellipsoid
(``_ellipsoid``; ``jaxstiff.Ellipsoid``, ``jaxstiff.ellipsoid`` and ``jaxstiff.orientation_error``
are its public names: a function ``ellipsoid`` here would hide the former module of that name from
``import jaxstiff.stiffness.ellipsoid as m``), the criteria and their registry (``_criteria``)."""

from jaxstiff.runtime._moved import former_names

from ._core import (
    TASK_ROWS,
    cartesian_stiffness,
    check_task_feasible,
    cms_factor,
    cms_scale,
    compliance,
    compliance_condition,
    joint_stiffness,
    task_rows,
    translational_axes,
    translational_compliance,
    translational_stiffness,
)
from ._criteria import f1, f2, frobenius, get_criterion, offdiag, register_criterion

__all__ = [
    "TASK_ROWS",
    "cartesian_stiffness",
    "check_task_feasible",
    "cms_factor",
    "cms_scale",
    "compliance",
    "compliance_condition",
    "f1",
    "f2",
    "frobenius",
    "get_criterion",
    "joint_stiffness",
    "offdiag",
    "register_criterion",
    "task_rows",
    "translational_axes",
    "translational_compliance",
    "translational_stiffness",
]


__getattr__ = former_names(__name__, {})  # the former modules (jaxstiff.stiffness.core, ...)
