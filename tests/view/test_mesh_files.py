"""Link mesh files that are found but cannot be drawn (a corrupt or empty file) are reported as
such and left to the capsules, like missing ones: before, trimesh read random bytes as a mesh with
no faces, the link was "drawn" as nothing, and no warning said so."""

from __future__ import annotations

import os

import pytest

import jaxstiff
from jaxstiff.view._meshes import urdf_meshes

HERE = os.path.dirname(__file__)
TRIANGLE_STL = """solid t
facet normal 0 0 1
outer loop
vertex 0 0 0
vertex 0.1 0 0
vertex 0 0.1 0
endloop
endfacet
endsolid t
"""


def test_a_corrupt_mesh_is_named_with_its_file_and_a_missing_one_by_its_name(tmp_path):
    pytest.importorskip("trimesh")
    with open(os.path.join(HERE, "data", "arm4_missing_meshes.urdf")) as f:
        text = f.read()
    text = text.replace("package://arm4_description/meshes/base.stl", "meshes/base.stl")
    text = text.replace("package://arm4_description/meshes/l1.stl", "meshes/l1.stl")
    (tmp_path / "meshes").mkdir()
    (tmp_path / "meshes" / "base.stl").write_text(TRIANGLE_STL)
    (tmp_path / "meshes" / "l1.stl").write_bytes(bytes(range(256)) * 2)  # not a mesh
    urdf = tmp_path / "arm.urdf"
    urdf.write_text(text)
    found, missing = urdf_meshes(jaxstiff.Robot.from_urdf(str(urdf)))
    assert [m.link for m in found] == ["base"] and found[0].faces.shape == (1, 3)
    assert len(missing) == 2
    corrupt, absent = missing
    assert corrupt.startswith("meshes/l1.stl (") and str(tmp_path / "meshes" / "l1.stl") in corrupt
    assert "found, but" in corrupt
    assert absent == "package://arm4_description/meshes/l2.dae"
