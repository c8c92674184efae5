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

from ._build import MUJOCO_MISSING as MUJOCO_MISSING
from ._build import build_model as build_model
from ._build import require_mujoco as require_mujoco
from ._check import TOL as TOL
from ._check import SimRow as SimRow
from ._check import check_case as check_case
from ._check import check_cases as check_cases
from ._measure import SettleError as SettleError
from ._report import markdown_table as markdown_table
from ._report import rows_json as rows_json
from ._setup import SimCase as SimCase
from ._setup import cases_from_result as cases_from_result
from ._setup import locked_joint_mode as locked_joint_mode
from ._setup import spring_mask as spring_mask
