"""Former module paths, answered in one place: ``import jaxstiff.robot`` (a path from before the
package layout) or ``import jaxstiff.model.chain`` (an implementation module before it became the
private ``jaxstiff.model._chain``) imports the module where the code lives now, under both names,
with a ``DeprecationWarning`` naming the way in. No shim files: the table is :data:`jaxstiff.MOVED`,
its entries for the private modules made by :func:`private_module_paths`. Standard library only."""

from __future__ import annotations

import importlib
import importlib.abc
import importlib.machinery
import os
import sys
import warnings
from collections.abc import Callable, Iterable, Mapping
from types import ModuleType
from typing import Any

__all__ = ["former_module", "former_names", "install_moved_modules", "keep_public_names", "private_module_paths"]


class _Alias(importlib.abc.Loader):
    def __init__(self, old: str, new: str, public: str):
        self.old, self.new, self.public = old, new, public

    def create_module(self, spec: importlib.machinery.ModuleSpec) -> ModuleType:
        public = self.public
        where = "" if public == self.new else f" (its code is now the private module {self.new})"
        warnings.warn(
            f"module {self.old} is deprecated; import {public} instead{where}",
            DeprecationWarning,
            stacklevel=_importer(),
        )
        module = importlib.import_module(self.new)
        self._spec = module.__spec__
        return module

    def exec_module(self, module: ModuleType) -> None:
        """Nothing to run (the module is the new one, already executed): its own ``__spec__``,
        which the import system has just replaced by the alias's, is put back."""
        module.__spec__ = self._spec


def _public_part(module: str) -> str:
    """The module's path up to its first private part: ``jaxstiff.shaping._steps`` ->
    ``jaxstiff.shaping``, the package that is the way in to a private module's code."""
    parts = module.split(".")
    for i, part in enumerate(parts):
        if part.startswith("_"):
            return ".".join(parts[:i])
    return module


#: files whose frames stand between an import and the code that asked for it
_PASSING = (
    os.path.join("importlib", "__init__.py"),
    os.path.join(os.path.dirname(__file__), "_lazy.py"),
    os.path.abspath(__file__),
)


def _importer() -> int:
    """The ``stacklevel`` (seen from :meth:`_Alias.create_module`) of the line that imports: the
    first frame that is neither the import machinery (whose frames ``warnings`` does not count),
    ``importlib.import_module`` nor a package's attribute access (lazy names, former modules)."""
    level, f = 1, sys._getframe(2)
    while f is not None:
        name = f.f_code.co_filename
        if not ("importlib" in name and "_bootstrap" in name):
            level += 1
            if not name.endswith(_PASSING):
                return level
        f = f.f_back
    return level


class _MovedFinder(importlib.abc.MetaPathFinder):
    def __init__(self, moved: Mapping[str, str], way_in: Mapping[str, str]):
        self.moved, self.way_in = dict(moved), dict(way_in)

    def find_spec(self, name: str, path: Any = None, target: Any = None) -> importlib.machinery.ModuleSpec | None:
        new = self.moved.get(name)
        if new is None:
            return None
        return importlib.machinery.ModuleSpec(name, _Alias(name, new, self.way_in.get(new, _public_part(new))))


def install_moved_modules(moved: Mapping[str, str], way_in: Mapping[str, str] | None = None) -> None:
    """Answer every former module path of ``moved`` (old -> new full names). The warning names the
    public package that is the way in to the new module: the path up to its first private part,
    or ``way_in[new]`` where the names are public elsewhere. Idempotent."""
    for f in sys.meta_path:
        if isinstance(f, _MovedFinder):
            f.moved.update(moved)
            f.way_in.update(way_in or {})
            return
    # first: a former module inside a former package path (jaxstiff.solvers.pgd.batch) would
    # otherwise be found by the path finder in the package's folder and run a second time
    sys.meta_path.insert(0, _MovedFinder(moved, way_in or {}))


def private_module_paths(root: str, folder: str, packages: Iterable[str]) -> dict[str, str]:
    """The former path of every private implementation module of ``packages`` (subpackages of
    ``root``, whose folder is ``folder``): ``jaxstiff.model._chain`` was ``jaxstiff.model.chain``.
    A private subpackage and its modules, one level down, likewise: ``jaxstiff.solvers._pgd`` was
    ``jaxstiff.solvers.pgd``, ``jaxstiff.solvers._pgd.batch`` was ``jaxstiff.solvers.pgd.batch``.
    Read from the folders (a listing each, no import): a module made private later is answered too."""
    moved = {}
    for package in packages:
        where = os.path.join(folder, package)
        for entry in sorted(os.listdir(where)):
            name, ext = os.path.splitext(entry)
            if not name.startswith("_") or name.startswith("__"):
                continue
            old, new = f"{root}.{package}.{name[1:]}", f"{root}.{package}.{name}"
            if ext == ".py":
                moved[old] = new
            elif not ext and os.path.isfile(os.path.join(where, entry, "__init__.py")):
                moved[old] = new
                for sub in sorted(os.listdir(os.path.join(where, entry))):
                    subname, subext = os.path.splitext(sub)
                    if subext == ".py" and subname != "__init__":
                        moved[f"{old}.{subname}"] = f"{new}.{subname}"
    return moved


def former_module(package: str, name: str) -> ModuleType | None:
    """The former module ``package.name`` (a path of :data:`jaxstiff.MOVED`) imported through the
    hook, which warns, or None where it is not one: ``jaxstiff.csc.rollout`` read as an attribute
    of the package, as it was before the module became private."""
    for f in sys.meta_path:
        if isinstance(f, _MovedFinder) and f"{package}.{name}" in f.moved:
            return importlib.import_module(f"{package}.{name}")
    return None


def keep_public_names(package: ModuleType, moved: Mapping[str, str], public: Iterable[str]) -> None:
    """Keep a public name of ``package`` when a former module path of the same name is imported.

    ``import jaxstiff.ellipsoid`` (a former path) makes the import system set the attribute
    ``jaxstiff.ellipsoid`` to the module, which would replace the public function of that name for
    the whole process. The package's module class ignores exactly that assignment: the function
    stays, ``from jaxstiff.ellipsoid import Ellipsoid`` still works (through ``sys.modules``).
    """
    names = set(public)
    guarded = {}
    for old, new in moved.items():
        parent, _, name = old.rpartition(".")
        if parent == package.__name__ and name in names:
            guarded[name] = new
    if not guarded:
        return

    class _Package(type(package)):  # type: ignore[misc]
        def __setattr__(self, name: str, value: Any) -> None:
            if isinstance(value, ModuleType) and guarded.get(name) == value.__name__:
                return  # a former module path's import: the public name stays
            super().__setattr__(name, value)

    package.__class__ = _Package


def former_names(module: str, moved: Mapping[str, str]) -> Callable[[str], Any]:
    """A module-level ``__getattr__`` for ``module`` that answers names it no longer exports
    (``moved``: name -> the module that defines it) with a ``DeprecationWarning`` naming where the
    name lives, and its former submodules (:func:`former_module`; the import hook warns); any other
    name is an ``AttributeError`` as usual. The warning points at the line that reads the name
    (``from m import X`` reads it from C, ``m.X`` from the caller's frame)."""

    def __getattr__(name: str) -> Any:
        where = moved.get(name)
        if where is None:
            sub = former_module(module, name)
            if sub is None:
                raise AttributeError(f"module {module!r} has no attribute {name!r}")
            return sub
        # the frame that reads the name, past a package's lazy __getattr__ that passed it on
        f, level = sys._getframe(1), 2
        while f.f_back is not None and f.f_code.co_filename.endswith(_PASSING):
            f, level = f.f_back, level + 1
        # ``from m import X`` asks twice: the import system's hasattr (_handle_fromlist), then the
        # import itself; the warning is given once, by the second
        if f.f_code.co_name != "_handle_fromlist":
            private = _public_part(where) != where
            hint = "an internal name now, in the private module" if private else "import it from"
            warnings.warn(f"{module}.{name} is deprecated: {hint} {where}", DeprecationWarning, stacklevel=level)
        return getattr(importlib.import_module(where), name)

    return __getattr__
