"""L2 stiffness: task rows (:mod:`._tasks`), Cartesian/translational stiffness (:mod:`._core`), CMS
(:mod:`._cms`), the stiffness ellipsoid (:mod:`._ellipsoid`), the shaping criteria (:mod:`._criteria`).
``jaxstiff.stiffness.X`` keeps working for every public name of the former ``jaxstiff/stiffness.py``."""

from ._core import TASK_ROWS as TASK_ROWS
from ._core import cartesian_stiffness as cartesian_stiffness
from ._core import check_task_feasible as check_task_feasible
from ._core import cms_factor as cms_factor
from ._core import cms_scale as cms_scale
from ._core import compliance as compliance
from ._core import compliance_condition as compliance_condition
from ._core import joint_stiffness as joint_stiffness
from ._core import task_rows as task_rows
from ._core import translational_axes as translational_axes
from ._core import translational_compliance as translational_compliance
from ._core import translational_stiffness as translational_stiffness
