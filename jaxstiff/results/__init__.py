"""Shape results: :class:`ShapeResult` and its files, status codes, numpy-only verification
(``jaxstiff.results.X`` keeps working for every public name of the former ``results.py``)."""

from .files import CLIPPED as CLIPPED
from .files import NONFINITE as NONFINITE
from .files import NOT_CONVERGED as NOT_CONVERGED
from .files import NOT_RUN as NOT_RUN
from .files import SOLVED as SOLVED
from .files import STATUS_NAMES as STATUS_NAMES
from .files import UNREACHABLE as UNREACHABLE
from .files import USABLE as USABLE
from .files import ShapeResult as ShapeResult
from .files import atomic_save_npz as atomic_save_npz
from .files import file_sha256 as file_sha256
from .files import is_usable as is_usable
from .files import path_parameters as path_parameters
from .files import reference_states as reference_states
from .files import robot_from_meta as robot_from_meta
from .files import summary as summary
from .files import verify as verify
from .status import ShapeStatus as ShapeStatus
