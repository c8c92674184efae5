"""Former module paths (``jaxstiff.MOVED``) still import, as the new module itself, with a
DeprecationWarning naming the new path (for a private module: the public package that is its way
in); the new module keeps its own name and spec. Names a module no longer exports
(``jaxstiff.shaping``'s former list) still resolve, with a DeprecationWarning."""

from __future__ import annotations

import importlib
import subprocess
import sys

import pytest

import jaxstiff


@pytest.mark.parametrize("old, new", sorted(jaxstiff.MOVED.items()))
def test_old_path_imports_the_new_module_with_a_warning(old, new):
    sys.modules.pop(old, None)
    public = new.split("._")[0]  # jaxstiff.shaping._steps -> jaxstiff.shaping
    with pytest.warns(DeprecationWarning, match=f"import {public} instead") as rec:
        mod = importlib.import_module(old)
    assert mod is importlib.import_module(new)
    assert mod.__name__ == new and mod.__spec__.name == new  # the alias does not rename it
    assert any(r.filename == __file__ for r in rec)  # the warning points at the importing line
    sys.modules.pop(old, None)


def test_no_shim_file_is_left():
    for old in jaxstiff.MOVED:
        assert importlib.util.find_spec(old).origin is None, old  # answered by the hook, no file


def test_from_import_of_an_old_path_in_a_fresh_process():
    code = "from jaxstiff.robot import Robot; import jaxstiff.model._robot as m; assert Robot is m.Robot"
    out = subprocess.run(
        [sys.executable, "-W", "error::DeprecationWarning", "-c", code], capture_output=True, text=True
    )
    assert out.returncode != 0 and "import jaxstiff.model._robot instead" in out.stderr
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
    assert jaxstiff.ellipsoid is importlib.import_module("jaxstiff.stiffness._ellipsoid").ellipsoid
    sys.modules.pop("jaxstiff.ellipsoid", None)


def test_shaping_modules_moved_into_the_package():
    """The pipeline's former top-level modules are the package's private steps: every name an old
    import took from them is still there, and the warning names the package, not the private file."""
    assert jaxstiff.MOVED["jaxstiff.shaping_steps"] == "jaxstiff.shaping._steps"
    assert jaxstiff.MOVED["jaxstiff.shaping_inputs"] == "jaxstiff.shaping._inputs"
    for old in ("jaxstiff.shaping_steps", "jaxstiff.shaping_inputs"):
        sys.modules.pop(old, None)
    code = (
        "import warnings; warnings.simplefilter('error', DeprecationWarning)\n"
        "try:\n    import jaxstiff.shaping_steps\nexcept DeprecationWarning as e:\n    print(e)\n"
        "warnings.simplefilter('ignore', DeprecationWarning)\n"
        "from jaxstiff.shaping_steps import array_units, report_at_solution, ShapeInputs\n"
        "from jaxstiff.shaping_inputs import check_inputs, make_start_states, FIRST_STARTS_SEED\n"
        "import jaxstiff.shaping._steps as s, jaxstiff.shaping._inputs as i\n"
        "assert array_units is s.array_units and check_inputs is i.check_inputs and ShapeInputs is i.ShapeInputs\n"
        "print('ok')\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    first, ok = out.stdout.splitlines()
    assert first.startswith("module jaxstiff.shaping_steps is deprecated; import jaxstiff.shaping instead"), first
    assert "jaxstiff.shaping._steps" in first and ok == "ok"


@pytest.mark.parametrize(
    "name, home",
    [
        ("check_inputs", "jaxstiff.shaping._inputs"),
        ("make_start_states", "jaxstiff.shaping._inputs"),
        ("first_start_rng", "jaxstiff.shaping._inputs"),
        ("FIRST_STARTS_SEED", "jaxstiff.shaping._inputs"),
        ("INLINE_SETTINGS", "jaxstiff.shaping._shape"),
        ("cpu_async_dispatch", "jaxstiff.shaping._shape"),
        ("SolveRequest", "jaxstiff.solvers.base"),
        ("SolverInterrupted", "jaxstiff.solvers.base"),
        ("options_for_solver", "jaxstiff.solvers.base"),
    ],
)
def test_former_names_of_shaping_resolve_with_a_warning(name, home):
    import jaxstiff.shaping as shaping

    assert name not in shaping.__all__
    with pytest.warns(DeprecationWarning, match=f"jaxstiff.shaping.{name} is deprecated.*{home}") as rec:
        value = getattr(shaping, name)
    assert value is getattr(importlib.import_module(home), name)
    assert len(rec) == 1 and rec[0].filename == __file__  # once, at the line that asked
    with pytest.warns(DeprecationWarning) as rec:
        exec(f"from jaxstiff.shaping import {name}", {})
    assert len(rec) == 1  # from-import asks twice (hasattr, then the import): one warning


def test_the_shaping_package_exports_what_is_called_and_no_more():
    """Every name of jaxstiff.shaping.__all__ resolves without a warning; an unknown name is an
    AttributeError, not a warning."""
    import warnings

    import jaxstiff.shaping as shaping

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert all(getattr(shaping, n) is not None for n in shaping.__all__)
    assert shaping.shape is jaxstiff.shape
    with pytest.raises(AttributeError, match="no attribute 'no_such_name'"):
        shaping.no_such_name  # noqa: B018 - the attribute read is the test
