"""Seed 000, Fig. 2: common-mode stiffness (CMS) scales the stiffness ellipse, never turns or reshapes it.

Setup: ``urdf/planar_3r.urdf`` (L1 = L2 = L3 = 1 m), the seed's posture
q = (75°, -74.74°, -76.30°), task "xy" (K_T = K_C, 2x2, S0-4). The seed does not give the base joint
stiffnesses k_j0 of Fig. 2; we use those of its Fig. 3, k_j0 = (500, 300, 100) Nm/rad. Every
k_j = k * k_j0 for k in [0.5, 3] (S0 section III).

Prints, and writes as ``summary.csv``/``summary.md``: per k, the axes lambda1, lambda2 (N/m), the
ratio rho, the direction of the major axis (deg from x) and the area lambda1*lambda2, plus the
largest deviation from exact CMS scaling (lambda_i(k) / (k lambda_i(1)) - 1, rho(k) - rho(1), the
angle between major axes). Writes ``fig2_cms.png``.

Usage:
    python experiments/fig2_cms.py [--out DIR]
"""

from __future__ import annotations

import os
import sys

Q_DEG = (75.0, -74.74, -76.30)
KJ0 = (500.0, 300.0, 100.0)


def _parse(argv=None):
    from jaxstiff.plots import experiment_parser

    p = experiment_parser("fig2_cms", "Seed 000 Fig. 2: CMS of the planar 3R arm")
    p.add_argument("--k", default="0.5,1,1.5,2,2.5,3", help="CMS factors k, comma-separated (default 0.5..3)")
    args = p.parse_args(argv)
    try:
        args.k = [float(v) for v in args.k.split(",") if v.strip()]
    except ValueError:
        p.error(f"--k: expected comma-separated numbers, got {args.k!r}")
    if not args.k or min(args.k) <= 0:
        p.error("--k: give at least one factor, all > 0")
    return args


def main(argv=None) -> int:
    args = _parse(argv)
    from jaxstiff.runtime._x64 import enable_x64

    enable_x64()
    import jax.numpy as jnp
    import numpy as np

    import jaxstiff
    from jaxstiff import plots
    from jaxstiff.runtime._io import atomic_write_text

    os.makedirs(args.out, exist_ok=True)
    robot = jaxstiff.Robot.from_urdf("planar_3r")
    q = np.radians(Q_DEG)
    kj0 = np.asarray(KJ0)
    ks = np.asarray(args.k)
    J = robot.jacobian(jnp.asarray(q))
    K = np.asarray(jaxstiff.translational_stiffness(J, jnp.asarray(ks[:, None] * kj0), task="xy"))  # (k, 2, 2)
    e = jaxstiff.ellipsoid(jnp.asarray(K))
    axes, ratio, major = np.asarray(e.axes), np.asarray(e.ratio), np.asarray(e.major)
    angle = np.degrees(np.arctan2(major[:, 1], major[:, 0])) % 180.0  # direction of a line, [0, 180)
    K1 = np.asarray(jaxstiff.translational_stiffness(J, jnp.asarray(kj0), task="xy"))
    e1 = jaxstiff.ellipsoid(jnp.asarray(K1))
    ax1, rho1, v1 = np.asarray(e1.axes), float(e1.ratio), np.asarray(e1.major)
    dev_axes = float(np.max(np.abs(axes / (ks[:, None] * ax1) - 1.0)))
    dev_ratio = float(np.max(np.abs(ratio - rho1)))
    dev_angle = float(np.max(np.degrees(np.arcsin(np.clip(np.abs(major[:, 0] * v1[1] - major[:, 1] * v1[0]), 0, 1)))))
    tcp = np.asarray(robot.fk(jnp.asarray(q)))[:2, 3]

    rows = [
        {
            "k": f"{k:g}",
            "lambda1_N_per_m": f"{a[0]:.4f}",
            "lambda2_N_per_m": f"{a[1]:.4f}",
            "ratio": f"{rho:.6f}",
            "major_axis_deg": f"{ang:.4f}",
            "area_lambda1_lambda2": f"{a[0] * a[1]:.2f}",
        }
        for k, a, rho, ang in zip(ks, axes, ratio, angle, strict=True)
    ]
    print(
        f"Seed 000 Fig. 2 (CMS): planar 3R, q = {Q_DEG} deg, TCP = ({tcp[0]:.4f}, {tcp[1]:.4f}) m, k_j0 = {KJ0} Nm/rad, task xy"
    )
    print("\n".join(plots.text_table(rows, width=20, sep="  ")))
    print(
        f"max |lambda_i(k) / (k lambda_i(1)) - 1| = {dev_axes:.2e};  max |rho(k) - rho(1)| = {dev_ratio:.2e};  "
        f"max angle between major axes = {dev_angle:.2e} deg"
    )

    plots.save_table_csv(rows, os.path.join(args.out, "summary.csv"))
    md = [
        "# Seed 000 Fig. 2: common-mode stiffness",
        "",
        f"Planar 3R (L = 1 m), q = {Q_DEG} deg, TCP = ({tcp[0]:.4f}, {tcp[1]:.4f}) m; k_j = k · k_j0 with "
        f"k_j0 = {KJ0} Nm/rad (the seed's Fig. 3 values; Fig. 2 does not give them); task xy.",
        "",
        *plots.markdown_table(rows),
        "",
        f"CMS is exact: max |λ_i(k)/(k λ_i(1)) − 1| = {dev_axes:.1e}, max |ρ(k) − ρ(1)| = {dev_ratio:.1e}, "
        f"max angle between major axes = {dev_angle:.1e}°.",
        "",
        "![Fig. 2](fig2_cms.png)",
        "",
    ]
    atomic_write_text(os.path.join(args.out, "summary.md"), "\n".join(md))
    png = plots.figure_cms(robot, q, kj0, list(ks), list(K), os.path.join(args.out, "fig2_cms.png"))
    print(f"wrote {png}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
