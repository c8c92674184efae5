"""mkdocs hook: the docstrings' cross-reference roles (``:class:`~jaxstiff.Robot```, ``:func:``,
``:mod:``, ``:meth:``, ``:attr:``, ``:data:``, ``:exc:``, ``:obj:``), which the Python handler of
mkdocstrings renders as the raw role text in front of the code, become the code alone: with ``~``
the last component (``Robot``), without it the whole dotted name, as Sphinx shows them. The
docstrings keep the roles (they read well in ``help()`` and editors); the site shows no markup."""

from __future__ import annotations

import re
from typing import Any

ROLES = ("class", "func", "mod", "meth", "attr", "data", "exc", "obj")
_ROLE = re.compile(":(?:" + "|".join(ROLES) + r"):<code>(~?)([^<]*)</code>")


def _code(m: re.Match[str]) -> str:
    name = m.group(2)
    if m.group(1):
        name = name.rsplit(".", 1)[-1]
    return f"<code>{name}</code>"


def strip_roles(html: str) -> str:
    """``html`` with every rendered role reduced to its code (see the module docstring)."""
    return _ROLE.sub(_code, html)


def on_page_content(html: str, **kwargs: Any) -> str:
    return strip_roles(html)
