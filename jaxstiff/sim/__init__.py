"""Physics-engine check of the stiffness model (MuJoCo; extra ``[sim]``).

A result's postures are rebuilt as MuJoCo models (springs kj at the posture, gravity off), loaded at
the TCP, let settle, and the measured deflections compared with jaxstiff's compliance: task
``xy``/``xyz`` (pure force, tool free to turn), ``full`` (the 6x6 compliance, orientation held
through its inverse), and the CCT term under a finite load (SPEC section 2, sign included).
MuJoCo is imported only when a check runs: ``import jaxstiff.sim`` works without it.

Example:
    >>> from jaxstiff.sim import cases_from_result, check_cases     # doctest: +SKIP
    >>> rows = check_cases(cases_from_result("shape.npz", waypoints=3))  # doctest: +SKIP
    >>> all(r.passed for r in rows)                                  # doctest: +SKIP
    True
"""

from jaxstiff.runtime._moved import former_names

from ._build import MUJOCO_MISSING, build_model, require_mujoco
from ._check import TOL, SimRow, check_case, check_cases
from ._measure import SettleError
from ._report import markdown_table, rows_json
from ._setup import SimCase, cases_from_result, locked_joint_mode, spring_mask

__all__ = [
    "MUJOCO_MISSING",
    "SettleError",
    "SimCase",
    "SimRow",
    "TOL",
    "build_model",
    "cases_from_result",
    "check_case",
    "check_cases",
    "locked_joint_mode",
    "markdown_table",
    "require_mujoco",
    "rows_json",
    "spring_mask",
]

__getattr__ = former_names(__name__, {})  # the former modules (jaxstiff.sim.X read as an attribute)
