"""Generated serial chains as URDF text: hyper-redundant test arms of any length.

:func:`serial_chain_urdf` writes a chain whose every joint has its own (random, unit) axis and a
rotated and offset origin, revolute, continuous and prismatic joints mixed, with now and then a
fixed joint between two movable ones (folded into the next origin when read). Nothing in it is
axis-aligned (unless ``aligned=True``), so the unrolled kinematics kernel cannot drop a single structural zero: the worst
case for its compile time and the case that ``scripts/bench_long_chain.py`` and
``tests/model/test_long_chain.py`` measure and test. Deterministic in ``seed``; every float is
written with ``repr``, so reading the text back gives the drawn numbers bit for bit.

Example:
    >>> from jaxstiff.model._generate import serial_chain_urdf
    >>> text = serial_chain_urdf(3, seed=0)
    >>> text.count('type="prismatic"') + text.count('type="revolute"') + text.count('type="continuous"')
    3
"""

from __future__ import annotations

import os
import tempfile
from collections.abc import Mapping
from typing import Any

import numpy as np

from jaxstiff.model._robot import Robot

__all__ = ["serial_chain_urdf", "serial_chain", "GENERATED_TIP_LINK"]

#: the name of the last link of a generated chain (the default tip; pass it as ``tip_link``)
GENERATED_TIP_LINK = "tip"


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v)


def _floats(v: np.ndarray) -> str:
    return " ".join(repr(float(x)) for x in v)


def _check_args(n: int, prismatic_share: float, fixed_share: float, link_length: float) -> None:
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1:
        raise ValueError(f"n (number of movable joints) must be an integer >= 1, got {n!r}")
    for name, share in (("prismatic_share", prismatic_share), ("fixed_share", fixed_share)):
        if not 0.0 <= share <= 1.0:
            raise ValueError(f"{name} must be in [0, 1], got {share!r}")
    if not link_length > 0.0 or not np.isfinite(link_length):
        raise ValueError(f"link_length must be a positive number of metres, got {link_length!r}")


def serial_chain_urdf(
    n: int,
    seed: int = 0,
    prismatic_share: float = 0.2,
    fixed_share: float = 0.1,
    link_length: float = 0.05,
    aligned: bool = False,
) -> str:
    """URDF text of a serial chain with ``n`` movable joints from ``base`` to :data:`GENERATED_TIP_LINK`.

    Args:
        n: number of movable joints (>= 1).
        seed: seed of the numpy generator that draws the geometry.
        prismatic_share: probability that a movable joint is prismatic (limits [-0.1, 0.1] m);
            the others are revolute (limits [-3, 3] rad) or, one in five, continuous.
        fixed_share: probability that a fixed joint (rotated, offset origin) precedes a movable one.
        link_length: scale of the origin offsets, m (each component uniform in
            [-link_length, link_length], plus ``link_length`` along z), so an n-joint chain spans
            about ``n * link_length`` metres.
        aligned: draw axes from the coordinate axes (+-x, +-y, +-z) and origin angles from multiples
            of pi/2, as in most real arms' URDFs: the structurally sparse case, in which the unrolled
            kernel drops most of its arithmetic (offsets stay random).

    Returns:
        The URDF document (a ``str``); write it to a file and read it with ``Robot.from_urdf``.

    Raises:
        ValueError: ``n`` < 1, or a share outside [0, 1], or a non-positive ``link_length``.
    """
    _check_args(n, prismatic_share, fixed_share, link_length)
    rng = np.random.default_rng(seed)
    links, joints = ['<link name="base"/>'], []
    k = 0  # links made so far after base

    def joint(kind: str, name: str) -> str:
        nonlocal k
        parent = "base" if k == 0 else f"l{k}"
        k += 1
        child = f"l{k}"
        links.append(f'<link name="{child}"/>')
        xyz = rng.uniform(-link_length, link_length, 3) + np.array([0.0, 0.0, link_length])
        rpy = rng.integers(-1, 3, 3) * (np.pi / 2) if aligned else rng.uniform(-np.pi, np.pi, 3)
        text = (
            f'<joint name="{name}" type="{kind}"><parent link="{parent}"/><child link="{child}"/>'
            f'<origin xyz="{_floats(xyz)}" rpy="{_floats(rpy)}"/>'
        )
        if kind != "fixed":
            axis = np.eye(3)[rng.integers(3)] * rng.choice([-1.0, 1.0]) if aligned else _unit(rng.normal(size=3))
            text += f'<axis xyz="{_floats(axis)}"/>'
        if kind == "revolute":
            text += '<limit lower="-3.0" upper="3.0" effort="10" velocity="1"/>'
        elif kind == "prismatic":
            text += '<limit lower="-0.1" upper="0.1" effort="10" velocity="1"/>'
        joints.append(text + "</joint>")
        return child

    for i in range(n):
        if rng.uniform() < fixed_share:
            joint("fixed", f"f{i}")
        u = rng.uniform()
        kind = (
            "prismatic"
            if u < prismatic_share
            else "continuous"
            if u < prismatic_share + 0.2 * (1 - prismatic_share)
            else "revolute"
        )
        joint(kind, f"j{i}")
    # a fixed tool link with a rotated, offset origin
    parent = f"l{k}"
    xyz = rng.uniform(-link_length, link_length, 3)
    rpy = rng.integers(-1, 3, 3) * (np.pi / 2) if aligned else rng.uniform(-np.pi, np.pi, 3)
    links.append(f'<link name="{GENERATED_TIP_LINK}"/>')
    joints.append(
        f'<joint name="tool" type="fixed"><parent link="{parent}"/><child link="{GENERATED_TIP_LINK}"/>'
        f'<origin xyz="{_floats(xyz)}" rpy="{_floats(rpy)}"/></joint>'
    )
    return f'<?xml version="1.0"?>\n<robot name="serial_{n}_{seed}">\n' + "\n".join(links + joints) + "\n</robot>\n"


def serial_chain(n: int, seed: int = 0, locked: Mapping[str, float] | None = None, **kwargs: Any) -> Robot:
    """The :class:`Robot` of :func:`serial_chain_urdf` (``n``, ``seed`` and ``kwargs`` passed on),
    read through a temporary file with ``Robot.from_urdf`` (tip :data:`GENERATED_TIP_LINK`,
    ``locked`` as there: ``{"j3": 0.2}`` locks movable joint 3)."""
    text = serial_chain_urdf(n, seed, **kwargs)
    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, f"serial_{n}_{seed}.urdf")
        with open(path, "w", encoding="utf-8") as fh:
            fh.write(text)
        return Robot.from_urdf(path, tip_link=GENERATED_TIP_LINK, locked=locked)
