"""Former module path, kept so that old imports keep working: the code lives in :mod:`jaxstiff.stiffness.criteria`."""

from jaxstiff.stiffness.criteria import CRITERIA as CRITERIA
from jaxstiff.stiffness.criteria import Criterion as Criterion
from jaxstiff.stiffness.criteria import alpha_and_ratio as alpha_and_ratio
from jaxstiff.stiffness.criteria import f1 as f1
from jaxstiff.stiffness.criteria import f2 as f2
from jaxstiff.stiffness.criteria import frobenius as frobenius
from jaxstiff.stiffness.criteria import get_criterion as get_criterion
from jaxstiff.stiffness.criteria import offdiag as offdiag
from jaxstiff.stiffness.criteria import register_criterion as register_criterion
