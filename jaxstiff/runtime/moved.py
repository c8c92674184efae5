"""Former module paths, answered in one place: ``import jaxstiff.robot`` (a path from before the
package layout) imports the module where the code lives now, under both names, with a
``DeprecationWarning`` naming the new path. No shim files: the table is :data:`jaxstiff.MOVED`.
Standard library only."""

from __future__ import annotations

import importlib
import importlib.abc
import importlib.machinery
import os
import sys
import warnings
from collections.abc import Mapping
from types import ModuleType
from typing import Any

__all__ = ["install_moved_modules"]


class _Alias(importlib.abc.Loader):
    def __init__(self, old: str, new: str):
        self.old, self.new = old, new

    def create_module(self, spec: importlib.machinery.ModuleSpec) -> ModuleType:
        warnings.warn(
            f"module {self.old} is deprecated; import {self.new} instead", DeprecationWarning, stacklevel=_importer()
        )
        module = importlib.import_module(self.new)
        self._spec = module.__spec__
        return module

    def exec_module(self, module: ModuleType) -> None:
        """Nothing to run (the module is the new one, already executed): its own ``__spec__``,
        which the import system has just replaced by the alias's, is put back."""
        module.__spec__ = self._spec


#: files whose frames stand between an import and the code that asked for it
_PASSING = (os.path.join("importlib", "__init__.py"), os.path.join(os.path.dirname(__file__), "lazy.py"))


def _importer() -> int:
    """The ``stacklevel`` (seen from :meth:`_Alias.create_module`) of the line that imports: the
    first frame that is neither the import machinery (whose frames ``warnings`` does not count),
    ``importlib.import_module`` nor the package's lazy attribute access."""
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
    def __init__(self, moved: Mapping[str, str]):
        self.moved = dict(moved)

    def find_spec(self, name: str, path: Any = None, target: Any = None) -> importlib.machinery.ModuleSpec | None:
        new = self.moved.get(name)
        if new is None:
            return None
        return importlib.machinery.ModuleSpec(name, _Alias(name, new))


def install_moved_modules(moved: Mapping[str, str]) -> None:
    """Answer every former module path of ``moved`` (old -> new full names). Idempotent."""
    for f in sys.meta_path:
        if isinstance(f, _MovedFinder):
            f.moved.update(moved)
            return
    sys.meta_path.append(_MovedFinder(moved))
