"""Look at a result: ``jaxstiff view`` (a 3-D scene in the browser with viser, extra ``[view]``),
``jaxstiff plot`` and ``jaxstiff export`` (q / kj trajectories as CSV for a controller).

Modules: :mod:`._kinematics` (numpy FK for display, no compilation), :mod:`._data` (result files of
``shape``, ``csc`` and sweeps read into one view record), :mod:`._meshes` (link meshes when they
resolve, capsules otherwise), :mod:`._scene` and :mod:`._app` (the viser scene and its controls,
the static HTML page), :mod:`._export` (CSV export and reader). Importing this package imports nothing.
"""
