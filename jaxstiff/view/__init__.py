"""Look at a result: ``jaxstiff view`` (a 3-D scene in the browser with viser, extra ``[view]``),
``jaxstiff plot`` and ``jaxstiff export`` (q / kj trajectories as CSV for a controller).

Exported: :func:`export_csv` and :func:`read_csv` (what ``jaxstiff export`` writes, and reading it
back). The code is in private modules: ``_kinematics`` (numpy FK for display, no compilation),
``_data`` (result files of ``shape``, ``csc`` and sweeps read into one view record), ``_meshes``
(link meshes when they resolve, capsules otherwise), ``_scene`` and ``_app`` (the viser scene and
its controls), ``_static`` (the static HTML page), ``_export`` (CSV export and reader). The names
load on first use (PEP 562): importing this package imports nothing.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from jaxstiff.runtime._lazy import lazy_exports

_SOURCES = {"._export": ("export_csv", "read_csv")}
__all__ = ["export_csv", "read_csv"]

__getattr__, __dir__ = lazy_exports(__name__, globals(), _SOURCES)


if TYPE_CHECKING:
    from ._export import export_csv as export_csv
    from ._export import read_csv as read_csv
