"""RobotSpec: which robot and chain a command works on, with the same defaults everywhere.

The API (``RobotSpec(...).build()``), every command's robot flags (``--robot --base-link
--tip-link --lock --tcp``, :mod:`jaxstiff.cli._common`) and a sweep's ``[robot]`` table all go
through this class, so a shipped robot gets the same locked joints in ``shape``, ``csc``,
``robot`` and ``sweep``.
"""

from __future__ import annotations

import dataclasses
import math
import os
import platform
import sys
from collections.abc import Mapping
from typing import Any

import numpy as np

from jaxstiff.model._chain import tcp_transform as tcp_transform
from jaxstiff.model._robot import Robot
from jaxstiff.model._shipped import robot_path
from jaxstiff.runtime._io import file_sha256
from jaxstiff.settings._base import Settings, setting

__all__ = ["RobotSpec", "tcp_transform", "versions"]

DEFAULT_ROBOT = "kuka_lwr4"  #: the robot every command uses without --robot

#: Joints locked by default, per shipped robot: seed 000 locks the LWR's 7th joint at 0 "so the
#: robot has 6 DOF". A user's own URDF gets no default lock; ``locked={}`` (``--lock none``)
#: frees every joint of a shipped robot too.
DEFAULT_LOCKS: dict[str, dict[str, float]] = {"kuka_lwr4": {"lwr_a7": 0.0}}


def _check_tcp(v: Any) -> str | None:
    if v is None:
        return None
    if isinstance(v, tuple) and len(v) in (3, 6) and all(isinstance(x, float) and math.isfinite(x) for x in v):
        return None
    return "must be 3 values x,y,z (m) or 6 values x,y,z,roll,pitch,yaw (m, rad), all finite"


@dataclasses.dataclass(frozen=True)
class RobotSpec(Settings):
    """A robot and its chain, as the user names it (a file or a shipped name, links, locks, tool).

    Attributes:
        urdf: URDF file or shipped robot name.
        base_link, tip_link: the chain's ends (``None``: :meth:`Robot.from_urdf`'s rules).
        locked: ``{joint: value}`` (rad; m for prismatic joints). ``None``: the shipped robot's
            default (:data:`DEFAULT_LOCKS`; none for other files); ``{}``: every joint free.
        tcp: tool offset after the tip link: ``(x, y, z)`` m, or ``(x, y, z, roll, pitch, yaw)``
            m and rad (URDF's fixed-axis roll-pitch-yaw, R = Rz(yaw) Ry(pitch) Rx(roll)).
    """

    section = "robot"

    urdf: str = setting(DEFAULT_ROBOT, doc="URDF file or shipped robot name")
    base_link: str | None = setting(None, doc="first link of the chain (default: the URDF root)")
    tip_link: str | None = setting(
        None,
        doc="last link of the chain (default: the leaf reached through the most actuated joints, never "
        "through a gripper or finger joint; ties: end-effector names; an error lists the rest)",
    )
    locked: Mapping[str, float] | None = setting(
        None,
        unit="rad (m for prismatic joints)",
        doc="locked joints {name: value}; default: the shipped robot's (kuka_lwr4: lwr_a7=0, as seed 000); {} frees all",
    )
    tcp: tuple[float, ...] | None = setting(
        None, unit="m, rad", doc="tool offset x,y,z[,roll,pitch,yaw] after the tip link", check=_check_tcp
    )

    def __post_init__(self) -> None:
        object.__setattr__(self, "urdf", os.fspath(self.urdf))
        if self.tcp is not None:
            try:
                object.__setattr__(self, "tcp", tuple(float(x) for x in np.asarray(self.tcp, dtype=float).ravel()))
            except (TypeError, ValueError):
                raise ValueError(f"robot.tcp must be numbers x,y,z[,roll,pitch,yaw], got {self.tcp!r}") from None
        if self.locked is not None:
            if not isinstance(self.locked, Mapping):
                raise ValueError(f"robot.locked must be a mapping {{joint: value}}, got {type(self.locked).__name__}")
            object.__setattr__(self, "locked", _FrozenDict(self.locked))
        super().__post_init__()

    def resolved_locks(self) -> dict[str, float]:
        """The locks that apply: the given ones, or the shipped robot's default."""
        if self.locked is not None:
            return dict(self.locked)
        name = shipped_name(self.urdf)
        return dict(DEFAULT_LOCKS.get(name, {})) if name else {}

    def build(self) -> Robot:
        """Read the URDF into a :class:`~jaxstiff.Robot` (errors name the file, link or joint)."""
        locks = self.resolved_locks()
        try:
            return Robot.from_urdf(
                self.urdf,
                base_link=self.base_link,
                tip_link=self.tip_link,
                locked=locks or None,
                tcp=None if self.tcp is None else tcp_transform(self.tcp),
            )
        except ValueError as e:
            if self.locked is None and locks and str(e).startswith("cannot lock joint"):
                # a lock the user never asked for: say where it came from and how to drop it
                given = ", ".join(f"{k}={v:g}" for k, v in locks.items())
                raise ValueError(
                    f"{e}. That lock ({given}) is the shipped robot's default: give other locks, or none "
                    f"(locked={{}}; command line: --lock none)"
                ) from None
            raise

    def meta(self) -> dict[str, Any]:
        out = super().meta()
        out["locked"] = self.resolved_locks()
        out["locked_by_default"] = self.locked is None and bool(out["locked"])
        return out


class _FrozenDict(dict):
    """A dict that hashes (settings are frozen and hashable) and refuses changes."""

    def __hash__(self) -> int:  # type: ignore[override]
        return hash(tuple(sorted(self.items())))

    def _refuse(self, *_a: Any, **_k: Any) -> None:
        raise TypeError("settings are frozen: use .replace(locked={...})")

    __setitem__ = __delitem__ = update = pop = popitem = clear = setdefault = _refuse  # type: ignore[assignment]


def shipped_name(urdf: str) -> str | None:
    """The shipped robot a name or file refers to (``"kuka_lwr4"``), or None."""
    for name in DEFAULT_LOCKS:
        try:
            shipped = robot_path(name)
        except FileNotFoundError:  # pragma: no cover - a broken install
            continue
        if urdf in (name, f"{name}.urdf"):
            return name
        try:
            if os.path.isfile(urdf) and os.path.samefile(urdf, shipped):
                return name
        except OSError:
            continue
    return None


def robot_meta(robot: Robot) -> dict[str, Any]:
    """The ``meta["robot"]`` record of a result file: enough to rebuild the chain from the URDF."""
    src = robot.source
    meta: dict[str, Any] = {
        "name": robot.name,
        "urdf": os.path.abspath(src) if src else "",
        "sha256": file_sha256(src) if src and os.path.isfile(src) else "",
        "base_link": robot.base_link,
        "tip_link": robot.tip_link,
        "locked": {nm: v for nm, v in zip(robot.joint_names, robot.locked, strict=True) if v is not None},
        "joint_names": list(robot.joint_names),
        "lower": robot.lower.tolist(),
        "upper": robot.upper.tolist(),
        "tip_transform": robot.tip_matrix.tolist(),
    }
    tcp = None
    if src and os.path.isfile(src):
        try:
            bare = Robot.from_urdf(src, base_link=robot.base_link or None, tip_link=robot.tip_link or None)
            tcp = np.linalg.solve(bare.tip_matrix, robot.tip_matrix)
            tcp[np.abs(tcp) < 1e-15] = 0.0
            # 15 significant digits: the solve's round-off goes (0.09999999999999996 -> 0.1, as given)
            tcp = np.array([[float(f"{x:.15g}") for x in row] for row in tcp])
            tcp[3] = [0.0, 0.0, 0.0, 1.0]
        except (ValueError, FileNotFoundError):
            tcp = None
    meta["tcp"] = None if tcp is None else tcp.tolist()
    return meta


def versions() -> dict[str, str]:
    """Versions of jaxstiff and the libraries that shape its numbers (``meta["versions"]``)."""
    import jax
    import scipy

    from jaxstiff.runtime._version import __version__

    return {
        "jaxstiff": __version__,
        "jax": jax.__version__,
        "numpy": np.__version__,
        "scipy": scipy.__version__,
        "python": sys.version.split()[0],
        "platform": platform.platform(),
    }
