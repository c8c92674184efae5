"""Many paths at once: the batched solver ``pgd`` shapes B paths x S starts in one compiled program.

Arcs around the LWR's base at several radii and heights (the quick sweep's workspace), each with
its own wanted ratio. pgd runs ``vmap`` over paths and starts and a loop over waypoints; the same
program serves every path length up to its capacity, and it runs unchanged on a GPU.
"""

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from _common import figure, size

import jaxstiff
from jaxstiff.solvers import PGD

robot = jaxstiff.Robot.from_urdf("kuka_lwr4", locked={"lwr_a7": 0.0})
radii, heights = (0.45, 0.55, 0.65), (0.25, 0.45)  # m
B, P = size(len(radii) * len(heights), 2), size(24, 6)
arcs = [
    jaxstiff.paths.arc(center=(0.0, 0.0, z), radius=r, start_deg=-20.0, end_deg=-20.0 + 40.0 * (P - 1) / 23, n=P)
    for z in heights
    for r in radii
][:B]  # 40 degrees in 24 waypoints: about 1.7 deg per waypoint
ratios = np.linspace(3.0, 6.0, B)  # one wanted ratio per path (a scalar would apply to all)

res = jaxstiff.shape(robot, jaxstiff.Path.stack(arcs), "f2", ratios, solver=PGD(starts=size(4, 2)))
print(res)
print("criterion", res.criterion.shape, "q", res.q.shape)  # (B, P), (B, P, n): one leading B axis
share = res.in_target.mean(axis=1)  # in_target: alpha < 1 deg and rho within 2 % of r, (B, P)
for b, arc in enumerate(arcs):
    r_xy, z = np.linalg.norm(arc.points[0, :2]), arc.points[0, 2]
    print(f"path {b}: radius {r_xy:.2f} m, z {z:.2f} m, ratio {ratios[b]:.1f}: {100 * share[b]:5.1f} % in target")

# the ellipsoids' major axes from the result's q and CMS-scaled kj (N/m)
J = robot.jacobian(res.q)  # (B, P, 6, n): any leading axes
axes, dirs = jaxstiff.translational_axes(J, res.kj_scaled)  # (B, P, 3) N/m, (B, P, 3, 3) columns
major = np.asarray(dirs[..., :, 0]) * 0.015  # unit major axis, drawn 1.5 cm long each side
fig = plt.figure(figsize=(11, 4.4))
top, rho = fig.add_subplot(1, 2, 1, projection="3d"), fig.add_subplot(1, 2, 2)
for b in range(B):
    pts = arcs[b].points
    (line,) = top.plot(*pts.T, lw=1, label=f"z {pts[0, 2]:.2f} m, r = {ratios[b]:.1f}")
    for p in range(0, P, 2):
        seg = np.stack([pts[p] - major[b, p], pts[p] + major[b, p]])
        top.plot(*seg.T, color=line.get_color(), lw=2.5)
    rho.plot(res.ratio[b], color=line.get_color())
    rho.axhline(ratios[b], color=line.get_color(), ls=":", lw=0.8)
top.set(xlabel="x (m)", ylabel="y (m)", zlabel="z (m)", title="paths, and the ellipsoids' major axes (thick)")
rho.legend(fontsize=7, ncol=2, loc="center right")
rho.set(xlabel="waypoint p", ylabel="axis ratio rho (-)", title=f"{B} arcs shaped together (pgd, f2): rho per path")
fig.savefig(figure("03_many_paths.png"), dpi=110, bbox_inches="tight")
