"""Status codes of a shaped waypoint (``ShapeResult.status``, int64 in result files).

The integer values are those of the files and never change; :class:`ShapeStatus` names them. The
module constants (``SOLVED`` ... ``NOT_RUN``) are the enum's members under their former names.
"""

from __future__ import annotations

import enum

import numpy as np

__all__ = ["ShapeStatus"]


class ShapeStatus(enum.IntEnum):
    """What became of a waypoint (see :mod:`jaxstiff.results._files` for the exact rules)."""

    SOLVED = 0  #: feasible, the solver converged
    NOT_CONVERGED = 1  #: feasible, the solver stopped without reporting convergence
    CLIPPED = 2  #: feasible after clipping into the box and re-projecting onto the path
    UNREACHABLE = 3  #: no point of the box puts the TCP within pos_tol of the waypoint
    NONFINITE = 4  #: NaN/Inf in the answer or the criterion
    NOT_RUN = 5  #: interrupted before this waypoint was solved

    @property
    def label(self) -> str:
        """The one-line description written into ``meta["status_codes"]``."""
        return _LABELS[self]

    @property
    def usable(self) -> bool:
        """True for a feasible point that the next waypoint's rate limits start from (0, 1, 2)."""
        return self in USABLE


_LABELS = {
    ShapeStatus.SOLVED: "solved",
    ShapeStatus.NOT_CONVERGED: "not converged (feasible)",
    ShapeStatus.CLIPPED: "clipped and re-projected (feasible)",
    ShapeStatus.UNREACHABLE: "unreachable",
    ShapeStatus.NONFINITE: "non-finite",
    ShapeStatus.NOT_RUN: "not run (interrupted)",
}

SOLVED = ShapeStatus.SOLVED
NOT_CONVERGED = ShapeStatus.NOT_CONVERGED
CLIPPED = ShapeStatus.CLIPPED
UNREACHABLE = ShapeStatus.UNREACHABLE
NONFINITE = ShapeStatus.NONFINITE
NOT_RUN = ShapeStatus.NOT_RUN
#: code -> description, plain int keys (as in every result file's ``meta["status_codes"]``)
STATUS_NAMES: dict[int, str] = {int(s): s.label for s in ShapeStatus}
USABLE = (SOLVED, NOT_CONVERGED, CLIPPED)  #: codes whose point is feasible and used as the next reference


def is_usable(status: object) -> np.ndarray:
    """Boolean array: True where the status code marks a feasible, usable point (0, 1, 2)."""
    return np.isin(np.asarray(status, dtype=np.int64), np.asarray(USABLE, dtype=np.int64))
