"""The list of long tests that ``tests/conftest.py`` starts first names tests that exist: a renamed
or removed test would silently drop out of the ordering (and a worker could be left with a long
test at the end of the run)."""

from __future__ import annotations

import ast
import os

import pytest

TESTS = os.path.dirname(os.path.abspath(__file__))


def _longest() -> tuple[str, ...]:
    """``_LONGEST`` as written in tests/conftest.py (read from the file: ``import conftest`` can
    find another directory's conftest module first)."""
    tree = ast.parse(open(os.path.join(TESTS, "conftest.py"), encoding="utf-8").read())
    for node in tree.body:
        if isinstance(node, ast.Assign) and any(getattr(t, "id", None) == "_LONGEST" for t in node.targets):
            return tuple(ast.literal_eval(node.value))
    raise AssertionError("tests/conftest.py has no _LONGEST")


_LONGEST = _longest()


@pytest.mark.parametrize("entry", _LONGEST)
def test_each_long_test_named_first_exists(entry):
    file, _, name = entry.partition("::")
    path = os.path.join(TESTS, file)
    assert os.path.isfile(path), f"tests/conftest.py _LONGEST names {file}, which does not exist"
    if name:
        tree = ast.parse(open(path, encoding="utf-8").read())
        names = {n.name for n in ast.walk(tree) if isinstance(n, ast.FunctionDef)}
        assert name in names, f"tests/conftest.py _LONGEST names {entry}, but {file} has no test {name!r}"
