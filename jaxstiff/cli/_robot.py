"""``jaxstiff robot``: print a robot's chain, limits, and FK/Jacobian at a posture.

The robot flags are every command's (:func:`~jaxstiff.cli._common.add_robot_flags`): the shipped
kuka_lwr4 has its 7th joint locked at 0 here too, as in ``jaxstiff shape`` (``--lock none`` frees it).
"""

from __future__ import annotations

import argparse
import shlex
import warnings
from typing import Any

from ._common import add_robot_flags, command, parse_floats, reads, robot_spec_from_args


@command("robot", "print a robot's candidate tip links, chain, limits, and FK/Jacobian at a posture")
def _add_robot(p: argparse.ArgumentParser) -> Any:
    reads(
        p.add_argument(
            "urdf",
            nargs="?",
            default=None,
            metavar="URDF",
            help="URDF file or shipped robot name (the same as --robot)",
        ),
        shipped_robot=True,
    )
    add_robot_flags(p, springs=False)  # no --locked-joints here: the chain and FK only
    p.add_argument(
        "--q",
        default=None,
        help="posture, comma-separated rad (m for prismatic joints; default: the nominal posture, mid-range + 30 deg per revolute joint, mid-range for a prismatic one)",
    )

    def run(args: argparse.Namespace) -> int:
        import numpy as np

        from ..runtime._x64 import enable_x64

        enable_x64()
        from ..settings._robot import DEFAULT_ROBOT

        if args.urdf is not None:
            if args.robot not in (DEFAULT_ROBOT, args.urdf):
                raise ValueError(f"give the robot once: URDF {args.urdf!r} or --robot {args.robot!r}")
            args.robot = args.urdf
        spec = robot_spec_from_args(args)
        try:
            robot = spec.build()
        except ValueError:
            if _no_automatic_tip(spec.urdf, spec.base_link, spec.tip_link):
                # the refusal is the tip's: the candidate tips and why none was chosen first (an
                # ambiguous tip's own error is raised by print_tip_candidates, with how to choose)
                print_tip_candidates(spec.urdf, spec.base_link, spec.tip_link)
            raise  # any other refusal alone, with nothing printed before it
        print_tip_candidates(spec.urdf, spec.base_link, spec.tip_link)
        if args.q is None:
            from ..ik import nominal_posture

            q = nominal_posture(robot)  # +30 deg (revolute), mid-range (prismatic), within the limits
        else:
            q = np.asarray(parse_floats(args.q, "--q"), dtype=float)
            if q.shape != (robot.n,):
                raise ValueError(f"--q needs {robot.n} values for {robot.name!r}, got {q.size}")
            for i in np.flatnonzero(~robot.free):
                if q[i] != robot.locked_values[i]:
                    raise ValueError(
                        f"--q gives joint {robot.joint_names[i]!r} = {q[i]:g}, but it is locked at "
                        f"{robot.locked_values[i]:g} (--lock); give the locked value or drop the lock"
                    )
            out = np.flatnonzero((q < robot.lower) | (q > robot.upper))
            if out.size:
                i = int(out[0])
                warnings.warn(
                    f"--q: joint {robot.joint_names[i]!r} = {q[i]:g} is outside its limits "
                    f"[{robot.lower[i]:g}, {robot.upper[i]:g}] (FK and Jacobian shown anyway)",
                    stacklevel=1,
                )
        T, J = robot.fk_and_jacobian(q)
        np.set_printoptions(precision=5, suppress=True, linewidth=120)
        print(robot.describe())
        pris = robot.prismatic
        unit = "deg; m for prismatic joints" if pris.any() else "deg"
        print(f"\nposture q ({unit}): {np.round(np.where(pris, q, np.rad2deg(q)), 4).tolist()}")
        print("\nT_base_tcp (m):")
        print(np.asarray(T) + 0.0)  # + 0.0 turns -0.0 into 0.0
        print(f"\nJ_base ({jacobian_units(robot.joint_names, pris)}):")
        print(np.asarray(J) + 0.0)
        return 0

    return run


def jacobian_units(joint_names: Any, prismatic: Any) -> str:
    """The J_base header's units: per rad/s of a revolute joint, per m/s of a prismatic one."""
    rows = "rows vx vy vz [m/s per rad/s], wx wy wz [rad/s per rad/s]"
    if not any(prismatic):
        return rows
    if all(prismatic):
        return "rows vx vy vz [m/s per m/s], wx wy wz [rad/s per m/s]"
    cols = [f"{i} ({n})" for i, (n, p) in enumerate(zip(joint_names, prismatic, strict=True)) if p]
    return f"{rows}; prismatic column{'s' if len(cols) > 1 else ''} {', '.join(cols)}: [m/s per m/s], [rad/s per m/s]"


def _no_automatic_tip(urdf: str, base_link: str | None, tip_link: str | None) -> bool:
    """Whether the refusal to build the robot is the tip's: no ``tip_link`` given and no automatic
    choice (a tie, or no actuated joint to move), the case the list of candidates explains."""
    from ..model._urdf import tip_candidates_and_why

    if tip_link is not None:
        return False
    try:
        _, chosen, _, _ = tip_candidates_and_why(urdf, base_link)
    except (ValueError, OSError):
        return False
    return chosen is None


def print_tip_candidates(urdf: str, base_link: str | None, tip_link: str | None) -> None:
    """The leaf links a chain from ``base_link`` can end at, with their actuated-joint counts, the
    automatic choice first and gripper/finger leaves marked (:func:`jaxstiff.model._urdf.tip_candidates`).
    Without ``tip_link`` and without an automatic tip: a ValueError after the list, which says why
    and how to pass --tip-link (not the API's error, which would list the candidates again and point
    at `jaxstiff robot`)."""
    from ..model._urdf import tip_candidates_and_why, tip_example

    ranked, chosen, base, why = tip_candidates_and_why(urdf, base_link)
    print(f"candidate tip links below {base!r} (automatic choice first; --tip-link to choose another):")
    width = max(len(c.link) for c in ranked) if ranked else 0
    for c in ranked:
        mark = "*" if c.link == chosen else " "
        note = c.note()
        used = "  <- --tip-link" if c.link == tip_link else ""
        pad = " " if c.joints < 10 else ""  # the counts right-aligned, as "%2d"
        print(f" {mark} {c.link:<{width}}  {pad}{c.count()}{'  (' + note + ')' if note else ''}{used}")
    movable = any(c.moving for c in ranked if c.gripper_joint is None)
    if chosen is None:
        pick = "; pass --tip-link" if movable and tip_link is None else ""
        print(f"   (no automatic choice: {why}{pick})")
    else:
        print(f"   * automatic tip: {chosen!r}")
    print()
    if chosen is None and tip_link is None and movable:
        raise ValueError(
            f"{urdf}: the automatic tip link is ambiguous below {base!r} (candidates listed above): {why}; "
            f"pass --tip-link LINK, e.g. --tip-link {shlex.quote(tip_example(ranked))}"
        )
