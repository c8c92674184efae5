"""`jaxstiff view` starts without JAX, yourdfpy or trimesh: the loading path leaves them out of
sys.modules (a fresh interpreter), the URDF reader gives yourdfpy's numbers bit for bit, the numpy
shapes that replace trimesh's are closed and outward, csc ellipsoids sit side by side, and the
plot command's --waypoints pick list (issue 22)."""

from __future__ import annotations

import glob
import json
import os
import subprocess
import sys

import numpy as np
import pytest
from viewer_files import DATA, make_shape_result

from jaxstiff.cli._plot import parse_waypoints
from jaxstiff.model._urdf import parse_urdf_model as parse_model
from jaxstiff.view._data import load_view_data
from jaxstiff.view._geometry import capsule, cylinder, icosphere

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

_LOAD = """
import json, sys
from jaxstiff.cli._main import build_parser
from jaxstiff.view._data import load_view_data
from jaxstiff.view._app import Viewer
build_parser("view")
data = load_view_data(sys.argv[1])

class Server:  # the scene built against a recorder: no port, same calls as viser's
    def __getattr__(self, name):
        return self
    def __call__(self, *a, **k):
        return self
    def __setattr__(self, name, value):
        pass

Viewer(Server(), data)
heavy = ("jax", "yourdfpy", "trimesh", "scipy", "jaxstiff.solvers", "jaxstiff.shaping")
print(json.dumps({m: m in sys.modules for m in heavy}))
"""


def test_view_loading_imports_no_jax(tmp_path, lwr) -> None:
    f = make_shape_result(lwr, 1, 5).save(str(tmp_path / "s.npz"))
    out = subprocess.run([sys.executable, "-c", _LOAD, f], capture_output=True, text=True, check=True)
    loaded = json.loads(out.stdout.strip().splitlines()[-1])
    assert not any(loaded.values()), loaded  # jax included: model/ and chain.py load it lazily


def _urdfs() -> list[str]:
    shipped = glob.glob(os.path.join(REPO, "urdf", "*.urdf"))
    return sorted(
        shipped
        + glob.glob(os.path.join(DATA, "*.urdf"))
        + glob.glob(os.path.join(REPO, "tests", "**", "*.urdf"), recursive=True)
    )


@pytest.mark.parametrize("file", _urdfs(), ids=os.path.basename)
def test_urdf_reader_matches_yourdfpy(file: str) -> None:
    """Every joint field the chain uses, bit for bit against yourdfpy's parser (the former reader)."""
    yourdfpy = pytest.importorskip("yourdfpy")
    from lxml import etree

    try:
        ours = parse_model(file)
    except ValueError:
        pytest.skip("a URDF the reader refuses (tests/model checks the message)")
    root = etree.parse(file).getroot()
    if not root.get("name"):
        root.set("name", ours.name)
    ref = yourdfpy.URDF._parse_robot(root)
    assert ours.links == [link.name for link in ref.links]
    assert len(ours.joints) == len(ref.joints)
    for a, b in zip(ours.joints, ref.joints, strict=True):
        assert (a.name, a.type, a.parent, a.child) == (b.name, b.type, b.parent, b.child)
        assert (a.origin is None) == (b.origin is None)
        if a.origin is not None:
            assert np.array_equal(a.origin, b.origin), (a.name, a.origin - b.origin)
        assert np.array_equal(a.axis, b.axis)
        assert (a.limit is None) == (b.limit is None)
        if a.limit is not None:
            assert (a.limit.lower, a.limit.upper) == (b.limit.lower, b.limit.upper)
        assert a.mimic == (None if b.mimic is None else b.mimic.joint)


def _volume(v: np.ndarray, f: np.ndarray) -> float:
    """Signed volume by the divergence theorem: positive when the faces wind outwards."""
    a, b, c = v[f[:, 0]], v[f[:, 1]], v[f[:, 2]]
    return float(np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6.0)


def test_numpy_shapes_closed_outward() -> None:
    for (v, f), exact, tol in (
        (icosphere(3, 0.5), 4 / 3 * np.pi * 0.5**3, 0.02),
        (cylinder(0.1, 0.4, 48), np.pi * 0.01 * 0.4, 0.01),
        (capsule(0.3, 0.05, 32, 16), np.pi * 0.0025 * 0.3 + 4 / 3 * np.pi * 0.05**3, 0.01),
    ):
        edges = np.sort(np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]), axis=1)
        _, counts = np.unique(edges, axis=0, return_counts=True)
        assert np.all(counts == 2)  # closed: every edge has two faces
        assert abs(_volume(v, f) - exact) < tol * exact  # outward, and the right size


def test_csc_ellipsoids_side_by_side(csc_file) -> None:
    viser = pytest.importorskip("viser")
    from jaxstiff.view._kinematics import ellipsoid_axes
    from jaxstiff.view._scene import Scene

    data = load_view_data(csc_file)
    server = viser.ViserServer(host="127.0.0.1", port=8094, verbose=False)
    try:
        scene = Scene(server, data)
        scene.show(1, 5)
        tcp = scene.frames[1][1, 5, :3, 3]
        real, want = np.asarray(scene.handles["ellipsoid"].position), np.asarray(scene.handles["desired"].position)
        np.testing.assert_allclose(real, tcp, atol=1e-12)
        assert data.K_desired is not None
        reach = sum(float(ellipsoid_axes(K)[0][..., 0].max()) for K in (data.K, data.K_desired)) / scene.n_per_m
        assert np.linalg.norm(want - real) > reach  # apart, never overlapping, at any step
    finally:
        server.stop()
    lines = dict(data.info(1, 5))
    assert lines["u"] == "3 Nm/rad" and lines["|K_xd - K_C|_F"] == "4 N/m"


def test_waypoint_picks() -> None:
    assert parse_waypoints("5", 12) == [0, 5, 10]
    assert parse_waypoints("20,0,10,10", 30) == [0, 10, 20]
    with pytest.raises(ValueError, match="index 30 is out of range.*0..29"):
        parse_waypoints("0,30", 30)
    with pytest.raises(ValueError, match="index -1"):
        parse_waypoints("-1,3", 30)
    for bad in ("0", "x", ""):
        with pytest.raises(ValueError, match="--waypoints"):
            parse_waypoints(bad, 30)


def test_lazy_public_names() -> None:
    """``import jaxstiff`` names every public name in ``__all__`` and ``dir()``, and each resolves."""
    import jaxstiff

    assert set(jaxstiff.__all__) <= set(dir(jaxstiff))
    assert all(getattr(jaxstiff, name) is not None for name in jaxstiff.__all__)
    assert callable(jaxstiff.ellipsoid) and jaxstiff.Robot.__name__ == "Robot"
    with pytest.raises(AttributeError, match="no attribute 'nope'"):
        _ = jaxstiff.nope  # pyright: ignore[reportAttributeAccessIssue]
    import jaxstiff.model as model  # the same mechanism (jaxstiff.runtime._lazy)

    assert set(model.__all__) <= set(dir(model)) and model.Robot is jaxstiff.Robot
    with pytest.raises(AttributeError, match="module 'jaxstiff.model' has no attribute 'nope'"):
        _ = model.nope  # pyright: ignore[reportAttributeAccessIssue]
