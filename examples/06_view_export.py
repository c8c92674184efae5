"""After shaping: keep the result file, check it, draw it, hand it to a controller, look at it in 3-D.

Every step here has a command too: ``jaxstiff plot shape.npz --out shape.png``,
``jaxstiff export shape.npz --csv traj.csv``, ``jaxstiff view shape.npz [--html page.html]``.
The CSV has one row per waypoint: q (rad), kj and the CMS-scaled kj_scaled (Nm/rad), TCP (m),
status; command the arm with kj_scaled, and only rows with status 0-2.
"""

import importlib.util

import numpy as np
from _common import figure, size

import jaxstiff
from jaxstiff.cli import main as jaxstiff_command
from jaxstiff.view import export_csv, read_csv

robot = jaxstiff.Robot.from_urdf("kuka_lwr4", locked={"lwr_a7": 0.0})
full = jaxstiff.default_path(n=60)
P = size(20, 4)
res = jaxstiff.shape(robot, jaxstiff.Path(full.points[:P], full.directions[:P]), "f2", 5.0)

file = res.save(figure("06_shape.npz"))  # arrays + strict-JSON meta (settings, robot, timings)
again = jaxstiff.ShapeResult.load(file)  # no pickles
assert np.array_equal(again.q, res.q)
print("re-checked from the file alone:", jaxstiff.results.verify(file))  # numpy only, no JAX

csv = export_csv(file, figure("06_trajectory.csv"))  # what a controller reads
table = read_csv(csv)
print("CSV columns:", ", ".join(table))
print("commanded stiffness at waypoint 0 (Nm/rad):", [round(float(table[k][0]), 1) for k in table if "kj_scaled" in k])

# the `jaxstiff plot` command from Python: seed 000's panels, ellipses at chosen waypoints
jaxstiff_command(["plot", file, "--out", figure("06_view_export.png"), "--waypoints", f"0,{P // 2},{P - 1}"])

if importlib.util.find_spec("viser"):  # pip install ".[view]"
    jaxstiff_command(["view", file, "--html", figure("06_view.html")])  # one page that opens from disk
    print("3-D page:", figure("06_view.html"))
