"""Shape the stiffness ellipsoid along one path (seed 000's job, the `jaxstiff shape` default).

The KUKA LWR 4 with its 7th joint locked at 0 follows the shipped default path; at every waypoint
SLSQP picks joint positions q and joint stiffnesses kj so that the ellipsoid's major axis follows
the path tangent with the axis ratio 5 (criterion f2), the TCP stays on the path, and q and kj
move at most 2 deg and 5 Nm/rad per waypoint. Then CMS scales kj to a common ellipsoid size.
"""

from _common import figure, size

import jaxstiff
from jaxstiff.plots import figure_shape_path

robot = jaxstiff.Robot.from_urdf("kuka_lwr4", locked={"lwr_a7": 0.0})
path = jaxstiff.default_path(n=30)  # a half-sine bump in the plane z = 0.30 m, 30 waypoints
P = size(30, 5)  # the tests shape only the first 5 waypoints
path = jaxstiff.Path(path.points[:P], path.directions[:P])
res = jaxstiff.shape(robot, path, "f2", 5.0)

print(res)  # a one-line summary
print("status per waypoint (0 = solved):", res.status[0].tolist())
print("orientation error alpha (deg):   ", res.alpha_deg[0].round(3).tolist())
print("axis ratio rho (wanted 5):       ", res.ratio[0].round(3).tolist())
print("waypoints in target:", int(res.in_target.sum()), "of", res.P)
print("CMS-scaled kj at waypoint 0 (Nm/rad):", res.kj_scaled[0, 0].round(1).tolist())  # inf: the locked joint

res.save(figure("01_shape.npz"))  # npz + JSON meta; jaxstiff.ShapeResult.load reads it back
jaxstiff.results.verify(res, robot)  # an independent numpy re-check: TCP on the path, bounds, rates
out = figure_shape_path(res, robot, figure("01_shape_one_path.png"), "LWR 4, default path, f2, ratio 5", every=3)
print("figure:", out)
