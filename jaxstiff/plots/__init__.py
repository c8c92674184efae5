"""Figures of the experiments: stiffness ellipses of planar arms (seed 000 Fig. 2 CMS, Fig. 3 CDS),
the criteria landscape (Fig. 6), the seven-panel path figure (Fig. 4/5) and CSC's u / Frobenius
curves; plus the small pieces every experiment script shares (its ``--out`` parser, summary tables).
Modules: :mod:`._base` (matplotlib, PNG writer, geometry), :mod:`._planar` (Fig. 2, 3, 6, CSC curves),
:mod:`._shape_path` (Fig. 4/5), :mod:`._task_modes` (held against free tool orientation), :mod:`._tables`; every name is importable as ``jaxstiff.plots.X``.
Matplotlib (Agg backend) is imported only inside these functions: the core library never imports
this module, and importing it pulls in numpy only.

Every figure function takes numbers computed by the library (stiffness matrices, criterion grids,
results), draws them with labelled axes and units, and writes the PNG atomically (a temporary file
in the same folder, then ``os.replace``), so a failed run never leaves a partial figure.

Example:
    >>> import numpy as np, jaxstiff
    >>> from jaxstiff import plots
    >>> pts = plots.ellipse_points(np.diag([5.0, 1.0]))  # (201, 2) N/m, semi-axes 5 along x, 1 along y
    >>> float(pts[:, 0].max()), float(pts[:, 1].max())
    (5.0, 1.0)
"""

from jaxstiff.plots._base import (
    chain_points,
    draw_arm,
    draw_scale_bar,
    ellipse_points,
    nice_value,
    pyplot,
    save_figure,
    style_ellipse_panel,
)
from jaxstiff.plots._planar import figure_cds, figure_cms, figure_criteria, figure_u_frobenius
from jaxstiff.plots._shape_path import figure_shape_path, figure_turning, rate_limited_joints, stiffness_axes
from jaxstiff.plots._tables import experiment_parser, markdown_table, save_table_csv, text_table
from jaxstiff.plots._task_modes import figure_task_modes, held_and_free
from jaxstiff.runtime._moved import former_names

__all__ = [
    "pyplot",
    "save_figure",
    "ellipse_points",
    "chain_points",
    "draw_arm",
    "style_ellipse_panel",
    "stiffness_axes",
    "figure_cms",
    "figure_cds",
    "figure_criteria",
    "figure_u_frobenius",
    "figure_shape_path",
    "figure_turning",
    "rate_limited_joints",
    "figure_task_modes",
    "held_and_free",
    "nice_value",
    "draw_scale_bar",
    "experiment_parser",
    "markdown_table",
    "text_table",
    "save_table_csv",
]

__getattr__ = former_names(__name__, {})  # the former modules (jaxstiff.plots.X read as an attribute)
