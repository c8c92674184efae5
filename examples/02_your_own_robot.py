"""Your own robot: any URDF, the chain up to the link you name, a tool offset, locked joints.

The UR10 description (tests/data/robots/ur10.urdf, from example-robot-data) ends in several links;
``tip_link="tool0"`` picks the flange, ``tcp`` adds a 10 cm tool along its z axis. The path is a
15 cm line (along y) through the TCP's position at a comfortable posture, so it is reachable by construction.
The same from the command line: ``jaxstiff robot --robot ur10.urdf --tip-link tool0 --tcp 0,0,0.1``.
"""

import os

import numpy as np
from _common import HERE, figure, size

import jaxstiff
from jaxstiff.plots import figure_shape_path

urdf = os.path.join(HERE, "..", "tests", "data", "robots", "ur10.urdf")
robot = jaxstiff.Robot.from_urdf(
    urdf,
    tip_link="tool0",  # the link the chain ends at (default: the leaf reached through most joints)
    tcp=(0.0, 0.0, 0.10),  # m, in the tool0 frame; a 6-vector adds roll, pitch, yaw (rad)
    locked={"wrist_3_joint": 0.0},  # turning the flange moves no TCP point on its axis: lock it
)
for name, lo, hi, lock in zip(robot.joint_names, robot.lower_limits, robot.upper_limits, robot.locked, strict=True):
    print(f"  {name:20s} [{lo:+.2f}, {hi:+.2f}] rad", "" if lock is None else f"locked at {lock}")

q_home = np.array([0.0, -1.2, 1.6, -1.9, -1.6, 0.0])  # rad; elbow bent, tool pointing down
tcp = np.asarray(robot.fk(q_home))[:3, 3]  # (4, 4) pose of the TCP in the base frame
print("TCP at q_home (m):", tcp.round(3).tolist())

P = size(25, 5)  # waypoints 6 mm apart: the rate limits (2 deg, 5 Nm/rad) hold per waypoint
half = [0.0, 0.003 * (P - 1), 0.0]  # m
line = jaxstiff.paths.line(tcp - half, tcp + half, P)  # along y, base frame
# task "xyz": a pure force at the TCP, the tool free to turn. Task "full" (the default) would need
# all six joints to have springs; the locked wrist_3 is rigid, and shape() says so in one line.
res = jaxstiff.shape(robot, line, "f2", 3.0, task="xyz", q0=q_home)  # start the path from q_home
print(res)
print("alpha (deg):", res.alpha_deg[0].round(3).tolist())
print("rho (wanted 3):", res.ratio[0].round(3).tolist())
jaxstiff.results.verify(res, robot)
figure_shape_path(
    res, robot, figure("02_your_own_robot.png"), "UR10 to tool0 + 10 cm TCP, task xyz, f2, ratio 3", every=3
)
