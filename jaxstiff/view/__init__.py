"""Look at a result: ``jaxstiff view`` (a 3-D scene in the browser with viser, extra ``[view]``),
``jaxstiff plot`` and ``jaxstiff export`` (q / kj trajectories as CSV for a controller).

Modules: :mod:`.kinematics` (numpy FK for display, no compilation), :mod:`.data` (result files of
``shape``, ``csc`` and sweeps read into one view record), :mod:`.meshes` (link meshes when they
resolve, capsules otherwise), :mod:`.scene` and :mod:`.app` (the viser scene and its controls,
the static HTML page), :mod:`.export` (CSV export and reader). Importing this package imports nothing.
"""
