"""The (B, P, n) grid of a result: B paths, P waypoints, n joints, read from its ``q`` array.

Shared by :class:`jaxstiff.results.ShapeResult` and the viewer's data (numpy only, no JAX)."""

from __future__ import annotations

import numpy as np


class PathGrid:
    """Mixin for a result that holds joint positions ``q`` of shape (B, P, n)."""

    q: np.ndarray

    @property
    def B(self) -> int:
        """Number of paths."""
        return int(self.q.shape[0])

    @property
    def P(self) -> int:
        """Number of waypoints per path."""
        return int(self.q.shape[1])

    @property
    def n(self) -> int:
        """Number of joints (locked ones included)."""
        return int(self.q.shape[2])
