"""``jaxstiff robot``: print a robot's chain, limits, and FK/Jacobian at a posture."""

from __future__ import annotations

import argparse
import warnings

from .common import TIP_LINK_HELP, command, parse_floats, parse_locks


@command("robot", "print a robot's chain, limits, and FK/Jacobian at a posture")
def _add_robot(p: argparse.ArgumentParser):
    p.add_argument("--robot", default="kuka_lwr4", help="URDF file or shipped robot name (default: kuka_lwr4)")
    p.add_argument("--base-link", default=None, help="first link of the chain (default: the URDF root)")
    p.add_argument("--tip-link", default=None, help=TIP_LINK_HELP)
    p.add_argument("--lock", action="append", metavar="JOINT=RAD", help="lock a joint at a value (repeatable)")
    p.add_argument("--q", default=None, help="posture, comma-separated rad (m for prismatic joints; default: the nominal posture, mid-range + 30 deg per revolute joint, mid-range for a prismatic one)")

    def run(args) -> int:
        import numpy as np

        from ..model.robot import Robot
        from ..runtime.x64 import enable_x64

        enable_x64()
        robot = Robot.from_urdf(args.robot, base_link=args.base_link, tip_link=args.tip_link, locked=parse_locks(args.lock))
        if args.q is None:
            from ..ik import nominal_posture

            q = nominal_posture(robot)  # +30 deg (revolute), mid-range (prismatic), within the limits
        else:
            q = np.asarray(parse_floats(args.q, "--q"), dtype=float)
            if q.shape != (robot.n,):
                raise ValueError(f"--q needs {robot.n} values for {robot.name!r}, got {q.size}")
            for i in np.flatnonzero(~robot.free):
                if q[i] != robot.locked_values[i]:
                    raise ValueError(f"--q gives joint {robot.joint_names[i]!r} = {q[i]:g}, but it is locked at "
                                     f"{robot.locked_values[i]:g} (--lock); give the locked value or drop the lock")
            out = np.flatnonzero((q < robot.lower) | (q > robot.upper))
            if out.size:
                i = int(out[0])
                warnings.warn(f"--q: joint {robot.joint_names[i]!r} = {q[i]:g} is outside its limits "
                              f"[{robot.lower[i]:g}, {robot.upper[i]:g}] (FK and Jacobian shown anyway)", stacklevel=1)
        T, J = robot.fk_and_jacobian(q)
        np.set_printoptions(precision=5, suppress=True, linewidth=120)
        print(robot.describe())
        pris = robot.prismatic
        unit = "deg; m for prismatic joints" if pris.any() else "deg"
        print(f"\nposture q ({unit}): {np.round(np.where(pris, q, np.rad2deg(q)), 4).tolist()}")
        print("\nT_base_tcp (m):")
        print(np.asarray(T) + 0.0)  # + 0.0 turns -0.0 into 0.0
        print("\nJ_base (rows vx vy vz [m/s per rad/s], wx wy wz [rad/s per rad/s]):")
        print(np.asarray(J) + 0.0)
        return 0

    return run
