"""Former module path, kept so that old imports keep working: the code lives in :mod:`jaxstiff.model.kinematics`."""

from jaxstiff.model.kinematics import cos_sin as cos_sin
from jaxstiff.model.kinematics import fk as fk
from jaxstiff.model.kinematics import fk_and_jacobian as fk_and_jacobian
from jaxstiff.model.kinematics import jacobian as jacobian
from jaxstiff.model.kinematics import jacobian_tangent as jacobian_tangent
from jaxstiff.model.kinematics import position_and_jacobian as position_and_jacobian
