"""Former module paths (``jaxstiff.MOVED``) still import, as the new module itself, with a
DeprecationWarning naming the new path; the new module keeps its own name and spec."""

from __future__ import annotations

import importlib
import subprocess
import sys

import pytest

import jaxstiff


@pytest.mark.parametrize("old, new", sorted(jaxstiff.MOVED.items()))
def test_old_path_imports_the_new_module_with_a_warning(old, new):
    sys.modules.pop(old, None)
    with pytest.warns(DeprecationWarning, match=f"import {new} instead") as rec:
        mod = importlib.import_module(old)
    assert mod is importlib.import_module(new)
    assert mod.__name__ == new and mod.__spec__.name == new  # the alias does not rename it
    assert any(r.filename == __file__ for r in rec)  # the warning points at the importing line
    sys.modules.pop(old, None)


def test_no_shim_file_is_left():
    for old in jaxstiff.MOVED:
        assert importlib.util.find_spec(old).origin is None, old  # answered by the hook, no file


def test_from_import_of_an_old_path_in_a_fresh_process():
    code = "from jaxstiff.robot import Robot; import jaxstiff.model.robot as m; assert Robot is m.Robot"
    out = subprocess.run(
        [sys.executable, "-W", "error::DeprecationWarning", "-c", code], capture_output=True, text=True
    )
    assert out.returncode != 0 and "import jaxstiff.model.robot instead" in out.stderr
    ok = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert ok.returncode == 0, ok.stderr


def test_importing_a_former_path_keeps_the_public_name_of_the_same_name():
    """jaxstiff.ellipsoid is a public function and a former module path: importing the path must
    not replace the function (a later test in the same process once found a module there)."""
    sys.modules.pop("jaxstiff.ellipsoid", None)
    with pytest.warns(DeprecationWarning):
        from jaxstiff.ellipsoid import Ellipsoid  # noqa: F401 - the import is the test
    assert callable(jaxstiff.ellipsoid)
    sys.modules.pop("jaxstiff.ellipsoid", None)
    with pytest.warns(DeprecationWarning):
        importlib.import_module("jaxstiff.ellipsoid")
    assert callable(jaxstiff.ellipsoid) and jaxstiff.ellipsoid.__name__ == "ellipsoid"
    assert jaxstiff.ellipsoid is importlib.import_module("jaxstiff.stiffness.ellipsoid").ellipsoid
    sys.modules.pop("jaxstiff.ellipsoid", None)
