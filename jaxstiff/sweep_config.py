"""Former module path, kept so that old imports keep working: the code lives in :mod:`jaxstiff.sweep.config`."""

from jaxstiff.sweep.config import AXES as AXES
from jaxstiff.sweep.config import GENERATORS as GENERATORS
from jaxstiff.sweep.config import KINDS as KINDS
from jaxstiff.sweep.config import AxisSpec as AxisSpec
from jaxstiff.sweep.config import Chunk as Chunk
from jaxstiff.sweep.config import SweepConfigError as SweepConfigError
from jaxstiff.sweep.config import SweepPlan as SweepPlan
from jaxstiff.sweep.config import Trajectory as Trajectory
from jaxstiff.sweep.config import hashed_config as hashed_config
from jaxstiff.sweep.config import kxd_matrix as kxd_matrix
from jaxstiff.sweep.config import load_config as load_config
from jaxstiff.sweep.config import parse_config as parse_config
