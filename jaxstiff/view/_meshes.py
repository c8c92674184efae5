"""Link meshes of a URDF for the viewer: which ``<visual><mesh>`` files resolve, and where they sit.

A link's visual is drawn where the link is: the base link at the base frame, the child link of
actuated joint i at that joint's moving frame (:func:`jaxstiff.view._kinematics.link_frames`), links
hung on fixed joints at their parent's frame times the fixed origin. Mesh files are looked up as
``package://PKG/rel`` (tried under the URDF's folder and up to three folders above, with and
without ``PKG``), ``file://abs`` or a path relative to the URDF. When a URDF names meshes that do
not resolve (or trimesh cannot read them), the viewer draws the chain as capsules and warns once.

The URDF has already been read by :meth:`jaxstiff.Robot.from_urdf`, which refuses DOCTYPE and
entity declarations; here only ``<link>``/``<joint>`` elements are read.
"""

from __future__ import annotations

import dataclasses
import math
import os
import xml.etree.ElementTree as ET
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from jaxstiff.model._chain import Chain

__all__ = ["LinkMesh", "origin_matrix"]


@dataclasses.dataclass(frozen=True)
class LinkMesh:
    """One visual mesh: ``anchor`` -1 (base frame) or the joint whose moving frame carries it, the
    constant transform from that frame to the mesh, and its vertices (m) and faces."""

    link: str
    anchor: int
    offset: np.ndarray
    vertices: np.ndarray
    faces: np.ndarray


def origin_matrix(elem: ET.Element | None) -> np.ndarray:
    """4x4 transform of a URDF ``<origin xyz rpy>`` (URDF roll-pitch-yaw: R = Rz(y) Ry(p) Rx(r))."""
    T = np.eye(4)
    if elem is None:
        return T
    x = [float(v) for v in (elem.get("xyz") or "0 0 0").split()]
    r, p, y = (float(v) for v in (elem.get("rpy") or "0 0 0").split())
    cr, sr, cp, sp, cy, sy = math.cos(r), math.sin(r), math.cos(p), math.sin(p), math.cos(y), math.sin(y)
    T[:3, :3] = [
        [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
        [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
        [-sp, cp * sr, cp * cr],
    ]
    T[:3, 3] = x
    return T


def _candidates(filename: str, urdf_dir: str) -> list[str]:
    if filename.startswith("file://"):
        return [filename[len("file://") :]]
    if filename.startswith("package://"):
        rest = filename[len("package://") :]
        pkg, _, rel = rest.partition("/")
        out = []
        d = urdf_dir
        for _ in range(4):
            out += [os.path.join(d, pkg, rel), os.path.join(d, rel)]
            d = os.path.dirname(d)
        return out
    return [filename if os.path.isabs(filename) else os.path.join(urdf_dir, filename)]


def _link_of(joint: ET.Element, tag: str) -> str | None:
    elem = joint.find(tag)
    return None if elem is None else elem.get("link")


def _anchors(root: ET.Element, chain: Chain) -> dict[str, tuple[int, np.ndarray]]:
    """link -> (anchor joint index or -1, constant offset) for every link reachable from the base."""
    placed: dict[str, tuple[int, np.ndarray]] = {chain.base_link: (-1, np.eye(4))}
    index = {name: i for i, name in enumerate(chain.joint_names)}
    joints = root.findall("joint")
    changed = True
    while changed:
        changed = False
        for j in joints:
            parent, child = _link_of(j, "parent"), _link_of(j, "child")
            if parent not in placed or child in placed or child is None:
                continue
            if j.get("type") == "fixed":
                a, T = placed[parent]
                placed[child] = (a, T @ origin_matrix(j.find("origin")))
                changed = True
            elif j.get("name") in index:
                placed[child] = (index[str(j.get("name"))], np.eye(4))
                changed = True
    return placed


def urdf_meshes(chain: Chain) -> tuple[list[LinkMesh], list[str]]:
    """The resolvable visual meshes of the chain's links, and the mesh files that did not resolve
    (as named in the URDF) or were found but cannot be drawn (named with the file and why).

    Returns ``([], [])`` for a URDF without meshes (the shipped ones) or a chain built in code.
    """
    src = chain.source
    if not src or not os.path.isfile(src):
        return [], []
    root = ET.parse(src).getroot()
    placed = _anchors(root, chain)
    found: list[LinkMesh] = []
    missing: list[str] = []
    for link in root.findall("link"):
        name = str(link.get("name"))
        for visual in link.findall("visual"):
            mesh = visual.find("geometry/mesh")
            if mesh is None or name not in placed:
                continue
            filename = str(mesh.get("filename") or "")
            path = next(
                (c for c in _candidates(filename, os.path.dirname(os.path.abspath(src))) if os.path.isfile(c)), None
            )
            loaded = _load(path) if path else "not found"
            if isinstance(loaded, str):
                missing.append(filename if path is None else f"{filename} ({path}: {loaded})")
                continue
            scale = np.asarray([float(v) for v in (mesh.get("scale") or "1 1 1").split()])
            a, T = placed[name]
            found.append(LinkMesh(name, a, T @ origin_matrix(visual.find("origin")), loaded[0] * scale, loaded[1]))
    return found, missing


def _load(path: str) -> tuple[np.ndarray, np.ndarray] | str:
    """The mesh's (vertices, faces), or why it cannot be drawn (a file trimesh cannot read, or one
    without faces: the capsules stand in)."""
    try:
        import trimesh

        m = trimesh.load(path, force="mesh")
        v, f = np.asarray(m.vertices, dtype=float), np.asarray(m.faces, dtype=np.int64)  # pyright: ignore[reportAttributeAccessIssue]
    except Exception as e:  # noqa: BLE001 - any reader failure: the file is there but unreadable
        return f"found, but it cannot be read as a mesh ({type(e).__name__})"
    if f.ndim != 2 or f.shape[0] == 0 or v.ndim != 2 or v.shape[0] == 0 or not np.all(np.isfinite(v)):
        return "found, but it holds no drawable mesh (no faces, or non-finite vertices)"
    return v, f
