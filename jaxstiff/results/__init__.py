"""Shape results: :class:`ShapeResult` and its files, status codes, numpy-only verification
(``jaxstiff.results.X`` keeps working for every public name of the former ``results.py``)."""

from ._files import CLIPPED as CLIPPED
from ._files import NONFINITE as NONFINITE
from ._files import NOT_CONVERGED as NOT_CONVERGED
from ._files import NOT_RUN as NOT_RUN
from ._files import SOLVED as SOLVED
from ._files import STATUS_NAMES as STATUS_NAMES
from ._files import UNREACHABLE as UNREACHABLE
from ._files import USABLE as USABLE
from ._files import ShapeResult as ShapeResult
from ._files import atomic_save_npz as atomic_save_npz
from ._files import file_sha256 as file_sha256
from ._files import is_usable as is_usable
from ._files import path_parameters as path_parameters
from ._files import reference_states as reference_states
from ._files import robot_from_meta as robot_from_meta
from ._files import summary as summary
from ._files import verify as verify
from ._status import ShapeStatus as ShapeStatus
