"""Which stiffness does a contact meet? Task "full" (tool orientation held) against "xyz" (tool free to turn).

K_C = (J K_j^-1 J^T)^-1 from the 6-row Jacobian is 6x6. Task "full" shapes its top-left 3x3 block
K_TT: the force per metre of a pure translation with the tool's orientation held (a clamp, a
rigid contact). Task "xyz" shapes C_TT^-1, the inverse of the translational compliance block: the
stiffness a pure force at the TCP meets when the tool is free to turn. K_TT - C_TT^-1 is positive
semi-definite (a Schur complement): holding the orientation never makes the arm softer.
"""

import jax.numpy as jnp
import matplotlib
import numpy as np
from _common import figure

import jaxstiff
from jaxstiff.plots import ellipse_points

matplotlib.use("Agg")
import matplotlib.pyplot as plt

robot = jaxstiff.Robot.from_urdf("kuka_lwr4", locked={"lwr_a7": 0.0})
q = jnp.deg2rad(jnp.array([0.0, 40.0, 0.0, -80.0, 0.0, 60.0, 0.0]))  # rad
kj = jnp.array([400.0, 300.0, 250.0, 200.0, 100.0, 50.0, jnp.inf])  # Nm/rad; inf: the rigid locked joint
J = robot.jacobian(q)  # (6, 7), rows [v; w], base frame

K_full = jaxstiff.translational_stiffness(J, kj, task="full")  # (3, 3) N/m = K_C[:3, :3]
K_xyz = jaxstiff.translational_stiffness(J, kj, task="xyz")  # (3, 3) N/m = (C_TT)^-1
K_C = jaxstiff.cartesian_stiffness(J, kj, task="full")  # (6, 6): N/m, N/rad, Nm/m, Nm/rad blocks
print("K_full == K_C[:3, :3]:", bool(jnp.allclose(K_full, K_C[:3, :3], rtol=1e-9)))
C_TT = (J[:3] / kj) @ J[:3].T  # translational compliance block, m/N (rigid joint: 1/inf = 0)
print("K_xyz == inv(C_TT):   ", bool(jnp.allclose(K_xyz, jnp.linalg.inv(C_TT), rtol=1e-9)))
print("eig(K_full - K_xyz) >= 0:", np.linalg.eigvalsh(np.asarray(K_full - K_xyz)).round(1).tolist(), "N/m")
for name, K in (("full", K_full), ("xyz", K_xyz)):
    e = jaxstiff.ellipsoid(K)  # axes (N/m, descending), directions, ratio, volume
    print(f"task {name:4s}: axes {np.asarray(e.axes).round(0).tolist()} N/m, ratio {float(e.ratio):.2f}")

fig, axs = plt.subplots(1, 2, figsize=(9, 4.2))
for ax, (i, j, lab) in zip(axs, ((0, 1, "xy (top view)"), (0, 2, "xz (side view)")), strict=True):
    for name, K, color in (("full: orientation held", K_full, "C0"), ("xyz: tool free to turn", K_xyz, "C3")):
        sub = np.asarray(K)[np.ix_([i, j], [i, j])]  # K_T for displacements within this plane, N/m
        pts = ellipse_points(sub)
        ax.plot(pts[:, 0], pts[:, 1], color=color, label=name)
    ax.set(aspect="equal", title=f"K_T in the {lab} plane", xlabel="N/m", ylabel="N/m")
    ax.grid(alpha=0.3)
axs[0].legend(fontsize=8)
fig.savefig(figure("07_task_modes.png"), dpi=110, bbox_inches="tight")
