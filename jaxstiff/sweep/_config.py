"""Sweep configuration: parse and validate a TOML file, expand it into rows, groups and chunks.

The code lives in :mod:`._schema` (the tables as pydantic models, errors), :mod:`._axes` (axis
specifications with defaults from :mod:`jaxstiff.settings`, values, cross checks),
:mod:`._trajectories` (``[[paths]]``) and :mod:`._plan` (:class:`SweepPlan`, :func:`load_config`);
this module gathers their public names (the format is described here).

A sweep is a grid of (trajectory x setting) *rows*. The TOML file names the robot, the paths
(CSV files or generators whose parameters may be lists or ranges) and the parameter *axes*; every
combination of axis values is one *setting*, and every setting is run on every trajectory.

Everything is checked here, before any work starts; every problem raises
:class:`SweepConfigError` whose message names the key (``axes.ratio``, ``paths[1].radius``,
``robot.name``) and the problem.

Layout of a config (every table but ``[robot]`` and ``[[paths]]`` is optional)::

    [sweep]
    kind = "shape"            # "shape" (jaxstiff.shape, seed 000) or "csc" (jaxstiff.csc_rollout, seed 001)
    name = "quick"            # label (default: the file name)
    chunk_size = 16           # rows per chunk: the unit that is computed, saved and resumed
    seed = 0                  # seed of every random choice (q0 = "random")
    alpha_tol_deg = 1.0       # summary metrics: a waypoint is aligned when alpha < this (degrees)
    ratio_rel_tol = 0.02      # ... and reaches the ratio when |rho - r| / r < this (f1: rho >= (1 - tol) r)

    [robot]                   # name = a shipped robot, or urdf = a file (relative to this TOML)
    name = "kuka_lwr4"
    locked = { lwr_a7 = 0.0 } # rad; default: the shipped robot's (kuka_lwr4: lwr_a7 = 0, as every
                              # command); locked = {} frees every joint
    tcp = [0.0, 0.0, 0.0]     # m, in the tip frame; or [x, y, z, roll, pitch, yaw] (m, rad), or a 4x4 transform
    # base_link = "...", tip_link = "..."

    [[paths]]                 # a CSV file (x,y,z[,dx,dy,dz]), relative to this TOML
    file = "my_path.csv"

    [[paths]]                 # a generator of jaxstiff.paths; a list or range = one path per value
                              # (several lists: every combination, or pairwise with zip = true)
    generator = "arc"
    center = [0.5, 0.0, 0.35]
    radius = [0.08, 0.12]
    start_deg = 0.0
    end_deg = { start = 30.0, stop = 90.0, num = 3 }
    n = 8

    [axes]                    # a value, a list of values, or a range {start, stop, num | step}
    criterion = ["f1", "f2"]
    ratio = { start = 2.0, stop = 6.0, num = 5 }
    dq_deg = [1.0, 2.0]

    [solver_options]          # passed to the solver (SLSQP: maxiter, ftol, kj_scale, f_scale)

    [report]
    heatmaps = [["ratio", "dq_deg"]]   # axis pairs of the heat maps ("path" too; default: up to 6 pairs of varying axes)

Ranges: ``{start, stop, num}`` is ``numpy.linspace(start, stop, num)``; ``{start, stop, step}``
runs from start by step up to stop inclusive (within 1e-9 of a step). Values that differ from a
short decimal by a few units in the last place (the round-off of ``start + i * step``:
1.2000000000000002) are stored as that decimal (1.2); an integer axis refuses a range whose
values are not integers.

Axes of kind ``"shape"`` (see :data:`AXES`): criterion, task, locked_joints, solver, starts, ratio, c, dq_deg, dk,
kmin, kmax, first_rate_limit, first_starts, q0, q0_seed. Axes of kind ``"csc"``: task, step, kmin, kmax,
newton, joint_limits, jl_gain, beta, kxd_major, kxd_ratio, kxd_angle_deg, q0, q0_seed. Defaults come
from :class:`~jaxstiff.settings.ShapeSettings` and :class:`~jaxstiff.settings.CSCSettings` (see
:mod:`._axes`; csc: beta 1.0, jl_gain 0.3 with joint_limits on, else 0).

q0 family (both kinds): ``"ik"`` (damped least-squares IK from the nominal posture to the path's
first waypoint, shape's own default), ``"nominal"`` (the nominal posture itself), ``"random"``
(IK from a posture drawn uniformly inside the joint limits with seed ``(seed, q0_seed, path)``:
different self-motion postures), or an explicit posture ``[q_1, ..., q_n]`` in rad (write a list
of postures, ``q0 = [[...], [...]]``).

Rows are numbered setting-major: ``row_id = setting_index * n_paths + path_index``, with the
settings in ``itertools.product`` order of the axes in the order of :data:`AXES`. Rows that share
the *static* axes (those that change a compiled shape or a solver's structure: criterion, task,
locked_joints, solver, starts for "shape"; task, step, kmin, kmax, newton, joint_limits, jl_gain for "csc") and the
number of waypoints form a *group*; each group is cut into chunks of at most ``chunk_size``
consecutive rows (kind "shape": whole settings, i.e. all paths of a setting, as long as they fit, so
that every batched call of a group has the same batch size and compiles once).
The plan, and so every row's result, depends only on the config, never on timing.

Example:
    >>> from jaxstiff.sweep._config import load_config
    >>> plan = load_config("experiments/sweeps/quick.toml")     # doctest: +SKIP
    >>> len(plan.rows), len(plan.chunks)                        # doctest: +SKIP
    (312, 6)
"""

from jaxstiff.sweep._axes import AXES as AXES
from jaxstiff.sweep._axes import AxisSpec as AxisSpec
from jaxstiff.sweep._axes import kxd_matrix as kxd_matrix
from jaxstiff.sweep._plan import Chunk as Chunk
from jaxstiff.sweep._plan import SweepPlan as SweepPlan
from jaxstiff.sweep._plan import hashed_config as hashed_config
from jaxstiff.sweep._plan import load_config as load_config
from jaxstiff.sweep._plan import parse_config as parse_config
from jaxstiff.sweep._schema import KINDS as KINDS
from jaxstiff.sweep._schema import SweepConfigError as SweepConfigError
from jaxstiff.sweep._trajectories import GENERATORS as GENERATORS
from jaxstiff.sweep._trajectories import Trajectory as Trajectory

__all__ = [
    "SweepConfigError",
    "AxisSpec",
    "AXES",
    "GENERATORS",
    "Trajectory",
    "Chunk",
    "SweepPlan",
    "load_config",
    "parse_config",
    "kxd_matrix",
    "hashed_config",
    "KINDS",
]
