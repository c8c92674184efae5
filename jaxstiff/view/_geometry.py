"""Unit shapes for the viewer's meshes in plain numpy (trimesh, about 2 s to import, is only needed
to read a URDF's link mesh files): :func:`icosphere`, :func:`cylinder` and :func:`capsule`, as (vertices, faces), faces counter-clockwise
seen from outside."""

from __future__ import annotations

import numpy as np

__all__: list[str] = []


def icosphere(subdivisions: int = 3, radius: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """A sphere of ``radius`` from the icosahedron, each face split in four ``subdivisions`` times
    (10 * 4^k + 2 vertices); faces counter-clockwise seen from outside."""
    t = (1.0 + 5.0**0.5) / 2.0
    v = [(-1, t, 0), (1, t, 0), (-1, -t, 0), (1, -t, 0), (0, -1, t), (0, 1, t)]
    v += [(0, -1, -t), (0, 1, -t), (t, 0, -1), (t, 0, 1), (-t, 0, -1), (-t, 0, 1)]
    verts = [np.asarray(p, float) / np.linalg.norm(p) for p in v]
    faces = [(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11), (1, 5, 9), (5, 11, 4), (11, 10, 2)]
    faces += [(10, 7, 6), (7, 1, 8), (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8), (3, 8, 9), (4, 9, 5)]
    faces += [(2, 4, 11), (6, 2, 10), (8, 6, 7), (9, 8, 1)]
    for _ in range(subdivisions):
        mid: dict[tuple[int, int], int] = {}
        new = []
        for a, b, c in faces:
            ab, bc, ca = (_middle(verts, mid, i, j) for i, j in ((a, b), (b, c), (c, a)))
            new += [(a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca)]
        faces = new
    return radius * np.asarray(verts), np.asarray(faces, dtype=np.int64)


def _middle(verts: list[np.ndarray], mid: dict[tuple[int, int], int], i: int, j: int) -> int:
    """The index of the unit vertex halfway between vertices i and j (added once)."""
    key = (min(i, j), max(i, j))
    if key not in mid:
        m = verts[i] + verts[j]
        verts.append(m / np.linalg.norm(m))
        mid[key] = len(verts) - 1
    return mid[key]


def cylinder(radius: float, height: float, sections: int = 12) -> tuple[np.ndarray, np.ndarray]:
    """A closed cylinder along z, centred at the origin (``height`` long), ``sections`` sides."""
    a = 2.0 * np.pi * np.arange(sections) / sections
    ring = np.stack([radius * np.cos(a), radius * np.sin(a)], axis=-1)
    lo = np.column_stack([ring, np.full(sections, -height / 2)])
    hi = np.column_stack([ring, np.full(sections, height / 2)])
    verts = np.vstack([lo, hi, [[0.0, 0.0, -height / 2], [0.0, 0.0, height / 2]]])
    i = np.arange(sections)
    j = (i + 1) % sections
    n, c0, c1 = sections, 2 * sections, 2 * sections + 1
    side = np.concatenate([np.stack([i, j, j + n], -1), np.stack([i, j + n, i + n], -1)])
    caps = np.concatenate([np.stack([np.full(n, c0), j, i], -1), np.stack([np.full(n, c1), i + n, j + n], -1)])
    return verts, np.concatenate([side, caps]).astype(np.int64)


def capsule(length: float, radius: float, sections: int = 16, rings: int = 8) -> tuple[np.ndarray, np.ndarray]:
    """A capsule along z centred at the origin: a cylinder ``length`` long (between the centres of
    its two hemispherical ends) of ``radius``; ``rings`` latitude steps per end."""
    phi = np.linspace(0.0, np.pi / 2, rings + 1)[1:]  # the poles are added apart
    r = np.concatenate([radius * np.sin(phi), radius * np.sin(phi[::-1])])
    z = np.concatenate([length / 2 + radius * np.cos(phi), -length / 2 - radius * np.cos(phi[::-1])])
    a = 2.0 * np.pi * np.arange(sections) / sections
    rings_xyz = np.stack([np.outer(r, np.cos(a)), np.outer(r, np.sin(a)), np.repeat(z[:, None], sections, 1)], -1)
    top, bottom = len(r) * sections, len(r) * sections + 1
    verts = np.vstack([rings_xyz.reshape(-1, 3), [[0.0, 0.0, length / 2 + radius], [0.0, 0.0, -length / 2 - radius]]])
    i = np.arange(sections)
    j = (i + 1) % sections
    faces = [np.stack([np.full(sections, top), i, j], -1)]
    for k in range(len(r) - 1):
        u, d = k * sections, (k + 1) * sections
        faces += [np.stack([u + i, d + i, d + j], -1), np.stack([u + i, d + j, u + j], -1)]
    last = (len(r) - 1) * sections
    faces.append(np.stack([np.full(sections, bottom), last + j, last + i], -1))
    return verts, np.concatenate(faces).astype(np.int64)
