"""L2 stiffness: task rows (:mod:`.tasks`), Cartesian/translational stiffness (:mod:`.core`), CMS
(:mod:`.cms`), the stiffness ellipsoid (:mod:`.ellipsoid`), the shaping criteria (:mod:`.criteria`).
``jaxstiff.stiffness.X`` keeps working for every public name of the former ``jaxstiff/stiffness.py``."""

from .core import TASK_ROWS as TASK_ROWS
from .core import cartesian_stiffness as cartesian_stiffness
from .core import check_task_feasible as check_task_feasible
from .core import cms_factor as cms_factor
from .core import cms_scale as cms_scale
from .core import compliance as compliance
from .core import compliance_condition as compliance_condition
from .core import joint_stiffness as joint_stiffness
from .core import task_rows as task_rows
from .core import translational_axes as translational_axes
from .core import translational_compliance as translational_compliance
from .core import translational_stiffness as translational_stiffness
