"""Which stiffness is shaped? (issue 40, part 1): held against free tool orientation along the default path.

The README's main job (KUKA LWR 4, ``lwr_a7`` locked at 0, the shipped default path, f2, r = 5,
SLSQP) shaped twice: with task ``full`` (the default: the top-left 3x3 block of the 6x6 K_C, the
stiffness with the tool's orientation held) and with task ``xyz`` (the inverse of the translational
compliance: what a pure force at the TCP meets when the tool is free to turn). Per waypoint, the
angle between the major axis and the path tangent, the axis ratio and the major axis (N/m, with
the CMS-scaled springs) of (i) the held-orientation stiffness of the ``full`` solution, (ii) the
free-orientation stiffness of the same solution, (iii) the free-orientation stiffness of the
``xyz`` solution. Writes ``which_stiffness.png`` and ``summary.md`` (the numbers at five waypoints).

Usage:
    python experiments/task_modes.py [--out DIR]   # docs/images/ holds the figure the docs show
"""

from __future__ import annotations

import os
import sys

WAYPOINTS = (0, 15, 30, 44, 59)


def summary_lines(both: dict, own: dict, res_full, res_xyz) -> list[str]:
    """Markdown: the three stiffnesses at :data:`WAYPOINTS`, the share in target of each, and the
    ranges over every waypoint that the docs quote (the prose follows the numbers)."""
    import numpy as np

    from jaxstiff.results._target import target_masks

    r = float(res_full.meta["ratio"])
    rows = [("(i) full, held", both["held"]), ("(ii) full, free", both["free"]), ("(iii) xyz, free", own)]
    hit = {}
    for name, v in rows:
        a_ok, r_ok = target_masks(v["alpha_deg"], v["ratio"], r, res_full.meta["criterion"])
        hit[name] = a_ok & r_ok
    n_xyz, P = int(np.sum(hit["(iii) xyz, free"])), len(own["alpha_deg"])
    xyz_says = (
        f"the free ellipsoid is on target at all {P} waypoints"
        if n_xyz == P
        else f"the free ellipsoid is on target at {n_xyz} of {P} waypoints (elsewhere the rate limits hold it back)"
    )
    held, free = both["held"], both["free"]
    softer = held["major"] / free["major"]
    lines = [
        "### Which stiffness is shaped? Held against free tool orientation along the default path",
        "",
        "The README's main job (LWR, f2, r = 5, task `full`) shapes the stiffness a force meets with the "
        "tool's orientation held (i). A pure force on a tool free to turn meets the inverse of the "
        "translational compliance (ii): on the same solution its major axis is "
        f"{np.min(free['alpha_deg']):.0f}-{np.max(free['alpha_deg']):.0f} deg off the tangent, its ratio "
        f"{np.min(free['ratio']):.2f}-{np.max(free['ratio']):.2f}, and it is {np.min(softer):.1f}-{np.max(softer):.1f} "
        f"times softer along its major axis ({np.min(free['major']):.0f}-{np.max(free['major']):.0f} N/m against "
        f"{np.min(held['major']):.0f}-{np.max(held['major']):.0f} N/m), over all {P} waypoints. Shaped for that "
        f"contact (task `xyz`, iii), {xyz_says}.",
        "",
        "| stiffness | " + " | ".join(f"wp {p}" for p in WAYPOINTS) + " | in target |",
        "|---" * 7 + "|",
    ]
    for name, v in rows:
        cells = [f"{v['alpha_deg'][p]:.1f} deg, {v['ratio'][p]:.2f}, {v['major'][p]:.0f} N/m" for p in WAYPOINTS]
        lines.append(f"| {name} | " + " | ".join(cells) + f" | {np.mean(hit[name]):.1%} |")
    lines += ["", "Cells: major axis to the path tangent, axis ratio, major axis (CMS-scaled springs)."]
    return lines


def main(argv=None) -> int:
    from jaxstiff.plots import experiment_parser

    ap = experiment_parser("task_modes", __doc__ or "")
    args = ap.parse_args(argv)

    from jaxstiff.runtime._x64 import enable_x64
    from jaxstiff.shaping import prefer_sync_cpu_dispatch

    enable_x64()
    prefer_sync_cpu_dispatch()

    import jaxstiff
    from jaxstiff.plots import figure_task_modes, held_and_free
    from jaxstiff.runtime._io import atomic_write_text

    os.makedirs(args.out, exist_ok=True)
    robot = jaxstiff.Robot.from_urdf("kuka_lwr4", locked={"lwr_a7": 0.0})
    path = jaxstiff.default_path()
    res_full = jaxstiff.shape(robot, path, "f2", 5.0, task="full")
    res_xyz = jaxstiff.shape(robot, path, "f2", 5.0, task="xyz")
    png = figure_task_modes(
        res_full,
        res_xyz,
        robot,
        os.path.join(args.out, "which_stiffness.png"),
        "Which stiffness is shaped? KUKA LWR 4 (A7 locked), default path, f2, r = 5",
    )
    d = res_full.direction[0]
    both = held_and_free(robot, res_full.q[0], res_full.kj_scaled[0], d)
    own = held_and_free(robot, res_xyz.q[0], res_xyz.kj_scaled[0], d)["free"]
    lines = summary_lines(both, own, res_full, res_xyz)
    atomic_write_text(os.path.join(args.out, "summary.md"), "\n".join(lines) + "\n")
    print("\n".join(lines))
    print(f"wrote {png}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
