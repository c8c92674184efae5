"""Seed 000, Fig. 3: configuration-dependent stiffness (CDS): one TCP point, several postures, different ellipses.

Setup: ``urdf/planar_3r.urdf`` (L1 = L2 = L3 = 1 m), k_j = (500, 300, 100) Nm/rad (the seed's
values), task "xy". The TCP point is that of the seed's Fig. 2 posture, q = (75°, -74.74°, -76.30°),
i.e. (1.5, 0) m. The self-motion of the redundant arm is parametrised by the tool angle
phi = q1 + q2 + q3; each posture comes from the closed-form 3R inverse kinematics (wrist point
p - L3 (cos phi, sin phi), then 2R with the elbow on the side given by ``--elbow``) and is checked
with jaxstiff's forward kinematics.

Prints, and writes as ``summary.csv``/``summary.md``: per posture, phi, q (deg), the TCP error, the
axes lambda1, lambda2 (N/m), the ratio rho and the major-axis direction (deg from x). Writes
``fig3_cds.png``.

Usage:
    python experiments/fig3_cds.py [--out DIR] [--phi-deg=-76.04,-40,0,40,80] [--elbow up|down]
"""

from __future__ import annotations

import math
import os
import sys

Q_FIG2_DEG = (75.0, -74.74, -76.30)
KJ = (500.0, 300.0, 100.0)
LINKS = (1.0, 1.0, 1.0)


def _parse(argv=None):
    from jaxstiff.plots import experiment_parser

    p = experiment_parser("fig3_cds", "Seed 000 Fig. 3: CDS of the planar 3R arm")
    p.add_argument(
        "--phi-deg",
        default=f"{sum(Q_FIG2_DEG):.2f},-40,0,40,80",
        help="tool angles q1+q2+q3 (deg), comma-separated; the first default is the Fig. 2 posture's",
    )
    p.add_argument(
        "--elbow", choices=["up", "down"], default="up", help="elbow branch of the 2R sub-chain (up: q2 < 0)"
    )
    args = p.parse_args(argv)
    try:
        args.phi = [math.radians(float(v)) for v in args.phi_deg.split(",") if v.strip()]
    except ValueError:
        p.error(f"--phi-deg: expected comma-separated numbers, got {args.phi_deg!r}")
    if not args.phi:
        p.error("--phi-deg: give at least one angle")
    return args


def planar_3r_ik(p, phi: float, elbow_up: bool = True, links=LINKS):
    """Closed-form IK of a planar 3R for TCP point ``p`` (m) and tool angle ``phi`` (rad).

    Returns (3,) rad, or None when the wrist point is out of the 2R sub-chain's reach.
    """
    L1, L2, L3 = links
    wx, wy = p[0] - L3 * math.cos(phi), p[1] - L3 * math.sin(phi)
    c2 = (wx * wx + wy * wy - L1 * L1 - L2 * L2) / (2 * L1 * L2)
    if abs(c2) > 1.0:
        return None
    q2 = -math.acos(c2) if elbow_up else math.acos(c2)
    q1 = math.atan2(wy, wx) - math.atan2(L2 * math.sin(q2), L1 + L2 * math.cos(q2))
    q3 = phi - q1 - q2
    wrap = lambda a: (a + math.pi) % (2 * math.pi) - math.pi  # noqa: E731
    return [wrap(q1), wrap(q2), wrap(q3)]


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
    target = np.asarray(robot.fk(jnp.asarray(np.radians(Q_FIG2_DEG))))[:2, 3]
    postures, phis = [], []
    for phi in args.phi:
        q = planar_3r_ik(target, phi, elbow_up=args.elbow == "up")
        if q is None:
            print(f"tool angle {math.degrees(phi):.2f} deg: TCP point out of reach, skipped")
            continue
        postures.append(q)
        phis.append(phi)
    if not postures:
        print("error: no reachable posture for the given tool angles", file=sys.stderr)
        return 2
    Q = np.asarray(postures)
    T, J = robot.fk_and_jacobian(jnp.asarray(Q))
    err = np.linalg.norm(np.asarray(T)[:, :2, 3] - target, axis=-1)
    K = np.asarray(jaxstiff.translational_stiffness(J, jnp.asarray(KJ), task="xy"))
    e = jaxstiff.ellipsoid(jnp.asarray(K))
    axes, ratio, major = np.asarray(e.axes), np.asarray(e.ratio), np.asarray(e.major)
    angle = np.degrees(np.arctan2(major[:, 1], major[:, 0])) % 180.0
    cond = np.asarray(jaxstiff.compliance_condition(J, jnp.asarray(KJ), task="xy"))

    rows = []
    for i, (phi, q) in enumerate(zip(phis, Q, strict=True)):
        rows.append(
            {
                "posture": str(i + 1),
                "phi_deg": f"{math.degrees(phi):.2f}",
                "q1_deg": f"{math.degrees(q[0]):.2f}",
                "q2_deg": f"{math.degrees(q[1]):.2f}",
                "q3_deg": f"{math.degrees(q[2]):.2f}",
                "tcp_error_m": f"{err[i]:.1e}",
                "lambda1_N_per_m": f"{axes[i, 0]:.3f}",
                "lambda2_N_per_m": f"{axes[i, 1]:.3f}",
                "ratio": f"{ratio[i]:.4f}",
                "major_axis_deg": f"{angle[i]:.2f}",
                "compliance_cond": f"{cond[i]:.3g}",
            }
        )
    print(
        f"Seed 000 Fig. 3 (CDS): planar 3R, TCP = ({target[0]:.4f}, {target[1]:.4f}) m, k_j = {KJ} Nm/rad, task xy, elbow {args.elbow}"
    )
    print("\n".join(plots.text_table(rows, width=16)))
    print(
        f"across postures: ratio {ratio.min():.3f} ... {ratio.max():.3f}, major axis {angle.min():.1f} ... {angle.max():.1f} deg, "
        f"max TCP error {err.max():.1e} m"
    )

    plots.save_table_csv(rows, os.path.join(args.out, "summary.csv"))
    md = [
        "# Seed 000 Fig. 3: configuration-dependent stiffness",
        "",
        f"Planar 3R (L = 1 m), k_j = {KJ} Nm/rad, task xy; every posture puts the TCP at "
        f"({target[0]:.4f}, {target[1]:.4f}) m (the Fig. 2 posture's TCP); closed-form IK over the tool angle φ, "
        f"elbow {args.elbow}.",
        "",
        *plots.markdown_table(rows),
        "",
        f"Same TCP point, same k_j: the ratio ranges over {ratio.min():.2f} … {ratio.max():.2f} and the major axis over "
        f"{angle.min():.1f}° … {angle.max():.1f}° — the configuration alone turns and reshapes the ellipse.",
        "",
        "![Fig. 3](fig3_cds.png)",
        "",
    ]
    atomic_write_text(os.path.join(args.out, "summary.md"), "\n".join(md))
    labels = [f"φ = {math.degrees(p):.1f}°" for p in phis]
    png = plots.figure_cds(robot, list(Q), KJ, list(K), os.path.join(args.out, "fig3_cds.png"), labels=labels)
    print(f"wrote {png}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
