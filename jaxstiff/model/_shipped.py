"""The robot descriptions shipped with jaxstiff (the top-level ``urdf/`` folder, installed as
``jaxstiff.urdf``)."""

from __future__ import annotations

import importlib.resources
import pathlib

__all__ = ["robot_path", "shipped_robots"]


def robot_path(name: str) -> str:
    """Path of a robot description shipped with jaxstiff (``"kuka_lwr4"``, ``"planar_3r"``, ...).

    Args:
        name: file stem (``"kuka_lwr4"``) or file name (``"kuka_lwr4.urdf"``).

    Raises:
        FileNotFoundError: no shipped robot of that name; the message lists the shipped ones.
    """
    if not isinstance(name, str):
        raise TypeError(f"robot_path: name must be a str, like 'kuka_lwr4', got {name!r}")
    stem = name[:-5] if name.endswith(".urdf") else name
    candidate = _urdf_dir() / f"{stem}.urdf"
    if not candidate.is_file():
        raise FileNotFoundError(f"no shipped robot named {name!r}; shipped robots: {', '.join(shipped_robots())}")
    return str(candidate)


def shipped_robots() -> list[str]:
    """Names of the robot descriptions shipped in ``urdf/``."""
    return sorted(p.name[:-5] for p in _urdf_dir().iterdir() if p.name.endswith(".urdf"))


def _urdf_dir():
    """The shipped ``urdf/`` folder: beside the package in a source checkout, else installed data."""
    here = pathlib.Path(__file__).resolve().parents[2] / "urdf"
    if (here / "kuka_lwr4.urdf").is_file():
        return here
    return importlib.resources.files("jaxstiff.urdf")
