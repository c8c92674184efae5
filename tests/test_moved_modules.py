"""Former module paths (``jaxstiff.MOVED``) still import, as the new module itself, with a
DeprecationWarning naming the new path (for a private module: the public package that is its way
in); the new module keeps its own name and spec. Names a module no longer exports
(``jaxstiff.shaping``'s former list) still resolve, with a DeprecationWarning. The implementation
modules of the public packages became private (``jaxstiff.model.chain`` -> ``jaxstiff.model._chain``):
every former path imports, warns naming its package, and has every name it had."""

from __future__ import annotations

import importlib
import json
import pathlib
import subprocess
import sys
import warnings

import pytest

import jaxstiff


@pytest.mark.parametrize("old, new", sorted(jaxstiff.MOVED.items()))
def test_old_path_imports_the_new_module_with_a_warning(old, new):
    sys.modules.pop(old, None)
    public = jaxstiff._WAY_IN.get(new, new.split("._")[0])  # jaxstiff.shaping._steps -> jaxstiff.shaping
    with pytest.warns(DeprecationWarning, match=f"import {public} instead") as rec:
        mod = importlib.import_module(old)
    assert mod is importlib.import_module(new)
    assert mod.__name__ == new and mod.__spec__.name == new  # the alias does not rename it
    assert any(r.filename == __file__ for r in rec)  # the warning points at the importing line
    sys.modules.pop(old, None)


def test_no_shim_file_is_left():
    for old in jaxstiff.MOVED:
        sys.modules.pop(old, None)  # else find_spec answers the module's own spec (a former subpackage)
        with warnings.catch_warnings():  # find_spec imports the parent: a former subpackage warns
            warnings.simplefilter("ignore", DeprecationWarning)
            assert importlib.util.find_spec(old).origin is None, old  # answered by the hook, no file


def test_from_import_of_an_old_path_in_a_fresh_process():
    code = "from jaxstiff.robot import Robot; import jaxstiff.model._robot as m; assert Robot is m.Robot"
    out = subprocess.run(
        [sys.executable, "-W", "error::DeprecationWarning", "-c", code], capture_output=True, text=True
    )
    assert out.returncode != 0 and "import jaxstiff.model instead" in out.stderr
    ok = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert ok.returncode == 0, ok.stderr


def test_the_ellipsoid_paths_name_the_top_level_where_its_names_are_public():
    for old in ("jaxstiff.ellipsoid", "jaxstiff.stiffness.ellipsoid"):
        sys.modules.pop(old, None)
        with pytest.warns(DeprecationWarning, match=f"module {old} is deprecated; import jaxstiff instead"):
            mod = importlib.import_module(old)
        assert all(getattr(jaxstiff, n) is getattr(mod, n) for n in ("Ellipsoid", "ellipsoid", "orientation_error"))
        sys.modules.pop(old, None)


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
        ("SolveRequest", "jaxstiff.solvers._base"),
        ("SolverInterrupted", "jaxstiff.solvers._base"),
        ("options_for_solver", "jaxstiff.solvers._base"),
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

    import jaxstiff.shaping as shaping

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert all(getattr(shaping, n) is not None for n in shaping.__all__)
    assert shaping.shape is jaxstiff.shape
    with pytest.raises(AttributeError, match="no attribute 'no_such_name'"):
        shaping.no_such_name  # noqa: B018 - the attribute read is the test


# --- the implementation modules made private: every former path is answered -------------------

#: every implementation module of the public packages as it was before it became private
#: (``jaxstiff.<package>.<name>``, and ``jaxstiff.solvers.<subpackage>[.<module>]``), with the public
#: names it defined or listed in ``__all__``: read from the source tree of that time, not from the
#: code under test
_FORMER = json.loads((pathlib.Path(__file__).parent / "data" / "former_modules.json").read_text())
#: names of a former module withdrawn later, each with why: greedy SLSQP's starts inside an
#: off-target waypoint's box changed no in-target share on five arms at 1.1-3x the time
#: (docs/notes/solvers.md)
WITHDRAWN = {"jaxstiff.solvers.greedy": {"BOX_STARTS", "box_starts"}}
FORMER_MODULES = {old: [n for n in names if n not in WITHDRAWN.get(old, ())] for old, names in _FORMER.items()}
PACKAGES = sorted({".".join(old.split(".")[:2]) for old in FORMER_MODULES})


#: former modules whose code later moved to another private module (listed in jaxstiff.MOVED by hand):
#: pgd's waypoint operations, which greedy SLSQP's target step shares, now sit below both
RELOCATED = {"jaxstiff.solvers.pgd.ops": "jaxstiff.solvers._problem.ops"}


def test_withdrawn_names_are_gone_and_were_there():
    for old, names in WITHDRAWN.items():
        assert names <= set(_FORMER[old])
        mod = importlib.import_module(private_path(old))
        assert not [n for n in names if hasattr(mod, n)]


def private_path(old: str) -> str:
    """Where a former module's code lives: its name under the package made private
    (``jaxstiff.model.chain`` -> ``jaxstiff.model._chain``, ``jaxstiff.solvers.pgd.batch`` ->
    ``jaxstiff.solvers._pgd.batch``: the subpackage is private, its modules keep their names),
    or where :data:`RELOCATED` says it went."""
    if old in RELOCATED:
        return RELOCATED[old]
    parts = old.split(".")
    parts[2] = "_" + parts[2]
    return ".".join(parts)


def test_every_former_implementation_module_is_in_the_table():
    missing = sorted(set(FORMER_MODULES) - set(jaxstiff.MOVED))
    assert not missing, missing
    for old in FORMER_MODULES:
        new = private_path(old)
        assert jaxstiff.MOVED[old] == new  # the private module of the same name
        origin = importlib.util.find_spec(new).origin
        tail = new.split(".", 2)[2].replace(".", "/")  # _chain, _pgd/batch, _pgd (a package)
        assert origin.endswith((f"{tail}.py", f"{tail}/__init__.py")), (old, origin)


@pytest.mark.parametrize("old", sorted(FORMER_MODULES))
def test_former_module_imports_warns_and_has_every_name(old):
    new = private_path(old)
    package = ".".join(old.split(".")[:2])
    way_in = jaxstiff._WAY_IN.get(new, package)  # the ellipsoid: the top level
    parent = old.rpartition(".")[0]
    if parent != package:  # a module of a former subpackage: the subpackage's path first (it warns too)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", DeprecationWarning)
            importlib.import_module(parent)
    sys.modules.pop(old, None)
    with pytest.warns(DeprecationWarning, match=rf"module {old} is deprecated; import {way_in} instead") as rec:
        mod = importlib.import_module(old)
    assert any(new in str(r.message) and r.filename == __file__ for r in rec)
    assert mod.__name__ == new and mod is importlib.import_module(new)  # one module, not a second copy
    lost = [n for n in FORMER_MODULES[old] if not hasattr(mod, n)]
    assert not lost, f"{old} lost {lost}"
    sys.modules.pop(old, None)


def test_from_imports_of_former_modules_in_a_fresh_process():
    """``from jaxstiff.<package>.<name> import X`` for a name of every former module, in a process
    that has imported nothing else: the warning once per module, the object the private module has."""
    picks = {old: names[0] for old, names in FORMER_MODULES.items() if names}
    lines = [f"from {old} import {n} as v{i}" for i, (old, n) in enumerate(sorted(picks.items()))]
    checks = [
        f"assert v{i} is importlib.import_module({private_path(old)!r}).{n}"
        for i, (old, n) in enumerate(sorted(picks.items()))
    ]
    code = "\n".join(
        ["import importlib, warnings", "with warnings.catch_warnings(record=True) as rec:"]
        + ["    warnings.simplefilter('always')"]
        + [f"    {line}" for line in lines]
        + checks
        + ["moved = [str(r.message).split()[1] for r in rec if r.category is DeprecationWarning]", "print(len(moved))"]
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr[-3000:]
    assert int(out.stdout) == len(picks)  # one warning a module


@pytest.mark.parametrize("package", PACKAGES)
def test_former_module_read_as_an_attribute_of_its_package(package):
    """``jaxstiff.csc.rollout`` worked before the rename where the package had imported the
    module; it still does, through the package's ``__getattr__`` (lazy packages: their lazy
    lookup), with the warning of the import hook."""
    pkg = importlib.import_module(package)
    old = next(o for o in sorted(FORMER_MODULES) if o.rpartition(".")[0] == package)
    name = old.rpartition(".")[2]
    if name in getattr(pkg, "__all__", ()):
        pytest.skip(f"{name} is a public name of {package}")
    sys.modules.pop(old, None)
    vars(pkg).pop(name, None)
    with pytest.warns(DeprecationWarning, match=f"module {old} is deprecated"):
        mod = getattr(pkg, name)
    assert mod is importlib.import_module(f"{package}._{name}")
    sys.modules.pop(old, None)
    vars(pkg).pop(name, None)
    with pytest.raises(AttributeError, match="no attribute 'no_such_module'"):
        pkg.no_such_module  # noqa: B018 - the attribute read is the test


def test_the_entry_point_main_survives_the_former_module_of_its_name():
    """``jaxstiff.cli.main`` is the command's entry point (pyproject's ``jaxstiff.cli:main``) and
    was a module's path: importing the path must leave the function in place."""
    import jaxstiff.cli

    sys.modules.pop("jaxstiff.cli.main", None)
    with pytest.warns(DeprecationWarning, match="module jaxstiff.cli.main is deprecated; import jaxstiff.cli instead"):
        from jaxstiff.cli.main import build_parser
    assert callable(jaxstiff.cli.main) and jaxstiff.cli.main.__name__ == "main"
    assert build_parser is jaxstiff.cli.build_parser
    sys.modules.pop("jaxstiff.cli.main", None)
    out = subprocess.run([sys.executable, "-m", "jaxstiff.cli", "--version"], capture_output=True, text=True)
    assert out.returncode == 0 and out.stdout.strip(), out.stderr


@pytest.mark.parametrize(
    "package, name, home",
    [
        ("jaxstiff.model", "jacobian_tangent", "jaxstiff.model._kinematics"),
        ("jaxstiff.sweep", "start_posture_and_error", "jaxstiff.sweep._run"),
        ("jaxstiff.sweep", "compute_chunk", "jaxstiff.sweep._run"),
        ("jaxstiff.sweep", "IK_TOL_M", "jaxstiff.sweep._run"),
    ],
)
def test_names_a_package_no_longer_exports_resolve_with_a_warning(package, name, home):
    pkg = importlib.import_module(package)
    assert name not in pkg.__all__
    vars(pkg).pop(name, None)
    with pytest.warns(DeprecationWarning, match=f"{package}.{name} is deprecated.*{home}") as rec:
        value = getattr(pkg, name)
    assert value is getattr(importlib.import_module(home), name)
    assert len(rec) == 1 and rec[0].filename == __file__  # past a lazy package's __getattr__ too


@pytest.mark.parametrize("package", ["jaxstiff", *PACKAGES])
def test_every_exported_name_resolves_without_a_warning(package):

    pkg = importlib.import_module(package)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for name in getattr(pkg, "__all__", ()):
            assert getattr(pkg, name) is not None, name


def test_the_public_surface_stays_small():
    """About 60 names at the top level at most; every public package lists what it exports once
    (its ``__all__`` or its ``X as X`` re-exports) and has no public module left."""
    assert len(jaxstiff.__all__) <= 60
    for package in PACKAGES:
        folder = pathlib.Path(importlib.import_module(package).__file__).parent
        public_modules = [p.name for p in folder.glob("*.py") if not p.name.startswith("_")]
        public_modules += [p.name for p in folder.glob("*/__init__.py") if not p.parent.name.startswith("_")]
        assert not public_modules, (package, public_modules)


def test_a_module_of_a_former_subpackage_is_the_private_one_not_a_copy():
    """``import jaxstiff.solvers.pgd.batch`` (a module of a subpackage made private) in a fresh
    process: both former paths warn, naming jaxstiff.solvers, and give the modules of
    ``jaxstiff.solvers._pgd``; the module is not loaded a second time from the private folder
    under its old name (its compiled-program cache and option tables would be split in two)."""
    code = (
        "import sys, warnings\n"
        "with warnings.catch_warnings(record=True) as rec:\n"
        "    warnings.simplefilter('always')\n"
        "    import jaxstiff.solvers.pgd.batch as b\n"
        "    from jaxstiff.solvers.problem.box import Limits\n"
        "import jaxstiff.solvers._pgd.batch as b2, jaxstiff.solvers as s\n"
        "assert b is b2 and sys.modules['jaxstiff.solvers.pgd'] is sys.modules['jaxstiff.solvers._pgd']\n"
        "assert Limits is s.Limits\n"
        "mods = {id(m): m for m in list(sys.modules.values())}  # an alias is the same module\n"
        "files = [m.__file__ for m in mods.values() if getattr(m, '__file__', None)]\n"
        "assert len(files) == len(set(files)), 'a module loaded twice'\n"
        "for r in rec:\n"
        "    print(r.message)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr[-3000:]
    lines = out.stdout.splitlines()
    assert [line.split()[1] for line in lines] == [
        "jaxstiff.solvers.pgd",
        "jaxstiff.solvers.pgd.batch",
        "jaxstiff.solvers.problem",
        "jaxstiff.solvers.problem.box",
    ], lines
    assert all("import jaxstiff.solvers instead" in line for line in lines), lines
