"""``jaxstiff robot``: print a robot's chain, limits, and FK/Jacobian at a posture.

The robot flags are every command's (:func:`~jaxstiff.cli.common.add_robot_flags`): the shipped
kuka_lwr4 has its 7th joint locked at 0 here too, as in ``jaxstiff shape`` (``--lock none`` frees it).
"""

from __future__ import annotations

import argparse
import warnings
from typing import Any

from .common import add_robot_flags, command, parse_floats, robot_spec_from_args


@command("robot", "print a robot's chain, limits, and FK/Jacobian at a posture")
def _add_robot(p: argparse.ArgumentParser) -> Any:
    add_robot_flags(p)
    p.add_argument(
        "--q",
        default=None,
        help="posture, comma-separated rad (m for prismatic joints; default: the nominal posture, mid-range + 30 deg per revolute joint, mid-range for a prismatic one)",
    )

    def run(args: argparse.Namespace) -> int:
        import numpy as np

        from ..runtime.x64 import enable_x64

        enable_x64()
        robot = robot_spec_from_args(args).build()
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
        print("\nJ_base (rows vx vy vz [m/s per rad/s], wx wy wz [rad/s per rad/s]):")
        print(np.asarray(J) + 0.0)
        return 0

    return run
