"""The installed package is what the source tree holds: every subpackage is listed for setuptools
(a non-editable install, as CI and users make, would silently leave a missing one out), and the
shipped robots install as data."""

from __future__ import annotations

import pathlib
import sys

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

ROOT = pathlib.Path(__file__).resolve().parents[1]  # the repository


def test_every_subpackage_is_listed_in_pyproject():
    listed = set(tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]["packages"])
    on_disk = {".".join(p.parent.relative_to(ROOT).parts) for p in (ROOT / "jaxstiff").rglob("__init__.py")}
    assert on_disk - listed == set(), f"subpackages missing from pyproject.toml's packages: {sorted(on_disk - listed)}"
    assert listed - on_disk == {"jaxstiff.urdf"}, (
        f"listed but not in the tree: {sorted(listed - on_disk - {'jaxstiff.urdf'})}"
    )


def test_shipped_robots_are_package_data():
    cfg = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]
    assert cfg["package-dir"]["jaxstiff.urdf"] == "urdf"
    assert "*.urdf" in cfg["package-data"]["jaxstiff.urdf"]
    assert sorted(p.stem for p in (ROOT / "urdf").glob("*.urdf")), "no URDF shipped"
