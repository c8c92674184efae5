"""The ``[robot]`` table of a sweep config: the robot it names and its normalised, hashed form."""

from __future__ import annotations

import os
from collections.abc import Mapping
from typing import Any

import numpy as np

from jaxstiff.sweep._schema import RobotTable, SweepConfigError, suggest, validate

__all__: list[str] = []


def build_robot(cfg: Mapping[str, Any], base_dir: str, source: str = "") -> tuple[Any, dict]:
    """``(Robot, normalised spec)`` of the ``[robot]`` table, through :class:`~jaxstiff.settings.RobotSpec`
    (a shipped robot gets its default locks, as in every command: kuka_lwr4 locks lwr_a7 = 0)."""
    from jaxstiff.model._robot import Robot
    from jaxstiff.model._shipped import robot_path, shipped_robots
    from jaxstiff.runtime._io import check_regular_file, file_sha256
    from jaxstiff.settings._robot import RobotSpec

    if "robot" not in cfg:
        raise SweepConfigError("robot", "missing table [robot] (give name = a shipped robot, or urdf = a file)", source)
    tbl = validate(RobotTable, cfg["robot"], "robot", source)
    if tbl.name is not None:
        shipped = shipped_robots()
        if tbl.name.removesuffix(".urdf") not in shipped:
            raise SweepConfigError(
                "robot.name",
                f"unknown robot {tbl.name!r}{suggest(tbl.name, shipped)}; shipped robots: {', '.join(shipped)}",
                source,
            )
        urdf = robot_path(tbl.name)
    else:
        given = str(tbl.urdf)
        urdf = given if os.path.isabs(given) else os.path.join(base_dir, given)
        try:
            check_regular_file(urdf, "URDF")
        except (FileNotFoundError, ValueError) as exc:
            raise SweepConfigError("robot.urdf", str(exc), source) from None
    matrix = tbl.tcp is not None and isinstance(tbl.tcp[0], list)  # a 4x4 transform (RobotSpec takes 3 or 6 values)
    try:
        spec = RobotSpec(
            urdf=urdf,
            base_link=tbl.base_link,
            tip_link=tbl.tip_link,
            locked=tbl.locked,
            tcp=None if tbl.tcp is None or matrix else tuple(tbl.tcp),
        )
        locks = spec.resolved_locks()
        if tbl.tcp is None or len(tbl.tcp) == 3 or matrix:  # (the file's tcp as given, as before)
            robot = Robot.from_urdf(
                urdf,
                base_link=tbl.base_link,
                tip_link=tbl.tip_link,
                locked=locks or None,
                tcp=None if tbl.tcp is None else np.asarray(tbl.tcp),
            )
        else:
            robot = spec.build()
    except (ValueError, FileNotFoundError) as exc:
        text = str(exc)
        key = (
            "robot.locked"
            if tbl.locked and "lock" in text.lower()
            else "robot.tcp"
            if tbl.tcp is not None and text.startswith(("tcp", "robot.tcp"))
            else "robot"
        )
        raise SweepConfigError(key, text, source) from None
    out = dict(cfg["robot"])
    if tbl.locked is None and locks:  # the shipped robot's default locks (recorded: they change results)
        out.update(locked=locks, locked_by_default=True)
    out.update(urdf_file=os.path.abspath(urdf), urdf_sha256=file_sha256(urdf))
    return robot, out
