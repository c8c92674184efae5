"""Count the assertions in a test tree, statically (standard library only; ast based).

Usage: python scripts/count_assertions.py [PATH ...] [--json]

Every ``*.py`` file under each PATH (default ``tests``) is parsed, never imported: test modules,
``conftest.py`` files and helper modules alike, so moving a helper from a test module into a
fixture or a helper module keeps the count. ``__pycache__`` and dot-folders are skipped; a file
that does not parse is listed and left out.

What counts as one assertion (each occurrence in the source, wherever it is: test functions,
fixtures, helpers, loops; a line in a loop counts once):

* an ``assert`` statement;
* a call of ``pytest.raises`` or ``pytest.warns`` (``with pytest.raises(...):`` and the call form
  ``pytest.raises(E, f, ...)`` alike), also under a name imported from pytest
  (``from pytest import raises``, ``import pytest as pt``); a test file's own wrapper (``def
  raises(...): return pytest.raises(...)``) counts once, where it calls pytest, not per use;
* a call whose function name starts with ``assert_``: ``np.testing.assert_allclose``,
  ``assert_array_equal``, a helper's ``assert_close`` (the attribute name or the bare name).

Counts are printed per folder (the folder that holds the file, relative to the current folder)
and in total.
"""

from __future__ import annotations

import argparse
import ast
import json
import pathlib
import sys
from collections import Counter

PYTEST_CHECKS = {"raises", "warns"}


def _pytest_names(tree: ast.AST) -> tuple[set[str], set[str]]:
    """Names bound to the pytest module, and names bound to pytest.raises / pytest.warns."""
    modules, checks = {"pytest"}, set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for a in node.names:
                if a.name == "pytest":
                    modules.add(a.asname or a.name)
        elif isinstance(node, ast.ImportFrom) and node.module == "pytest":
            for a in node.names:
                if a.name in PYTEST_CHECKS:
                    checks.add(a.asname or a.name)
    return modules, checks


def count_file(tree: ast.AST) -> Counter:
    """Assertions of one parsed file, by kind: "assert", "pytest.raises/warns", "assert_*()"."""
    modules, checks = _pytest_names(tree)
    n: Counter = Counter()
    for node in ast.walk(tree):
        if isinstance(node, ast.Assert):
            n["assert"] += 1
        elif isinstance(node, ast.Call):
            f = node.func
            if isinstance(f, ast.Attribute):
                if isinstance(f.value, ast.Name) and f.value.id in modules and f.attr in PYTEST_CHECKS:
                    n["pytest.raises/warns"] += 1
                elif f.attr.startswith("assert_"):
                    n["assert_*()"] += 1
            elif isinstance(f, ast.Name):
                if f.id in checks:
                    n["pytest.raises/warns"] += 1
                elif f.id.startswith("assert_"):
                    n["assert_*()"] += 1
    return n


def python_files(root: pathlib.Path):
    if root.is_file():
        yield root
        return
    for p in sorted(root.rglob("*.py")):
        if any(part.startswith(".") or part == "__pycache__" for part in p.relative_to(root).parts):
            continue
        yield p


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("paths", nargs="*", default=["tests"], help="files or folders (default: tests)")
    ap.add_argument("--json", action="store_true", help="print the counts as JSON")
    args = ap.parse_args(argv)

    per_folder: dict[str, Counter] = {}
    unparsed = []
    for root in map(pathlib.Path, args.paths):
        if not root.exists():
            ap.error(f"no such file or folder: {root}")
        for p in python_files(root):
            try:
                tree = ast.parse(p.read_text(encoding="utf-8"), filename=str(p))
            except (SyntaxError, UnicodeDecodeError) as e:
                unparsed.append(f"{p}: {e}")
                continue
            per_folder.setdefault(p.parent.as_posix(), Counter()).update(count_file(tree))

    total: Counter = sum(per_folder.values(), Counter())
    if args.json:
        out = {
            "total": sum(total.values()),
            "by_kind": dict(total),
            "folders": {k: sum(v.values()) for k, v in sorted(per_folder.items())},
            "unparsed": unparsed,
        }
        print(json.dumps(out, indent=2))
    else:
        for folder, c in sorted(per_folder.items()):
            print(f"{sum(c.values()):6d}  {folder}")
        kinds = ", ".join(f"{k} {v}" for k, v in sorted(total.items()))
        print(f"{sum(total.values()):6d}  total ({kinds})")
        for u in unparsed:
            print(f"not parsed: {u}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
