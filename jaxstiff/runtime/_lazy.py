"""Lazy public names of a package (PEP 562), one mechanism for ``jaxstiff`` and ``jaxstiff.model``:
a name is imported from its module the first time it is used and then kept in the package, so
importing the package imports neither JAX nor the solvers (``jaxstiff view`` starts without them)."""

from __future__ import annotations

import importlib
import importlib.util
from collections.abc import Callable, Mapping, MutableMapping
from typing import Any

from ._moved import former_names

__all__: list[str] = []


def lazy_exports(
    package: str,
    namespace: MutableMapping[str, Any],
    sources: Mapping[str, tuple[str, ...]],
    former: Mapping[str, str] | None = None,
) -> tuple[Callable[[str], Any], Callable[[], list[str]]]:
    """The module-level ``__getattr__`` and ``__dir__`` of ``package``.

    Args:
        package: the package's ``__name__`` (relative module names are resolved against it).
        namespace: the package's ``globals()``; a loaded name is stored there (``__getattr__`` is
            then not called again for it).
        sources: module (relative, e.g. ``"._robot"``) -> the public names it defines.
        former: names the package no longer exports -> the module that defines each, answered
            with a ``DeprecationWarning`` (:func:`jaxstiff.runtime._moved.former_names`).

    Returns:
        ``(__getattr__, __dir__)``; an unknown name raises ``AttributeError`` as a module would.
    """
    where = {name: module for module, names in sources.items() for name in names}
    deprecated = former_names(package, former or {})

    def getattr_(name: str) -> Any:
        module = where.get(name)
        if former and name in former:
            return deprecated(name)
        if module is None:
            # a submodule not imported yet (``jaxstiff.paths.line(...)`` right after ``import jaxstiff``)
            if not name.startswith("_") and importlib.util.find_spec(f"{package}.{name}") is not None:
                sub = importlib.import_module(f"{package}.{name}")
                namespace[name] = sub
                return sub
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(module, package), name)
        namespace[name] = value
        return value

    def dir_() -> list[str]:
        return sorted(set(namespace) | set(where) | set(namespace.get("__all__", ())))

    return getattr_, dir_
