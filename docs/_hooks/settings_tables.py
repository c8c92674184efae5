"""mkdocs hook: a line ``<!-- settings-table: module.Class -->`` in a page becomes the table of that
settings class's fields (name, default, unit, meaning), read from the fields themselves
(:meth:`jaxstiff.settings._base.Settings.fields_info`): the one place a setting is written."""

from __future__ import annotations

import importlib
import re
from typing import Any

_MARK = re.compile(r"^<!-- settings-table: ([\w.]+) -->$", re.M)


def _table(path: str) -> str:
    module, _, name = path.rpartition(".")
    cls = getattr(importlib.import_module(module), name)
    rows = ["| setting | default | unit | meaning |", "| --- | --- | --- | --- |"]
    for f in cls.fields_info():
        doc = f.doc.replace("|", "\\|")
        if f.choices:
            doc += f" (one of {', '.join(f'`{c}`' for c in f.choices)})"
        rows.append(f"| `{f.name}` | `{f.default!r}` | {f.unit} | {doc} |")
    return "\n".join(rows)


def on_page_markdown(markdown: str, **kwargs: Any) -> str:
    return _MARK.sub(lambda m: _table(m.group(1)), markdown)
