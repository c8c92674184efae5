"""Shape results: :class:`ShapeResult` and its files, status codes, numpy-only verification
(``jaxstiff.results.X`` keeps working for every public name of the former ``results.py``)."""

from jaxstiff.runtime._moved import former_names

from ._files import (
    CLIPPED,
    NONFINITE,
    NOT_CONVERGED,
    NOT_RUN,
    SOLVED,
    STATUS_NAMES,
    UNREACHABLE,
    USABLE,
    ShapeResult,
    atomic_save_npz,
    file_sha256,
    is_usable,
    path_parameters,
    reference_states,
    robot_from_meta,
    summary,
    verify,
)
from ._status import ShapeStatus

__all__ = [
    "CLIPPED",
    "NONFINITE",
    "NOT_CONVERGED",
    "NOT_RUN",
    "SOLVED",
    "STATUS_NAMES",
    "ShapeResult",
    "ShapeStatus",
    "UNREACHABLE",
    "USABLE",
    "atomic_save_npz",
    "file_sha256",
    "is_usable",
    "path_parameters",
    "reference_states",
    "robot_from_meta",
    "summary",
    "verify",
]

__getattr__ = former_names(__name__, {})  # the former modules (jaxstiff.results.X read as an attribute)
