"""README.md and every docstring in jaxstiff/ teach; they keep no work-log history.

Dates, issue numbers, session numbers and "stop N" belong in docs/benchmarks.md (measured numbers
with their date and machine) or in docs/notes/ (the decision notes), not in the text a user reads
first. Each hit is named by file, line (README) or docstring owner, and the offending words."""

from __future__ import annotations

import ast
import pathlib
import re

import pytest

ROOT = pathlib.Path(__file__).resolve().parent.parent
PACKAGE = ROOT / "jaxstiff"

#: work-log words: a date, "issue 21", "session" (the notes' "ninth session"), "stop 3"
HISTORY = re.compile(r"20\d\d-\d\d-\d\d|\bissue \d+|\bsession|\bstop \d+", re.IGNORECASE)


def history_hits(text: str) -> list[str]:
    """The work-log words in ``text`` (empty: clean)."""
    return [m.group(0) for m in HISTORY.finditer(text)]


def docstrings(source: str) -> list[tuple[str, int, str]]:
    """``(owner, line, docstring)`` of the module and every class and function in ``source``."""
    tree = ast.parse(source)
    found = []
    for node in ast.walk(tree):
        if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)):
            doc = ast.get_docstring(node, clean=False)
            if doc:
                owner = "module" if isinstance(node, ast.Module) else node.name
                line = 1 if isinstance(node, ast.Module) else node.lineno
                found.append((owner, line, doc))
    return found


def test_the_pattern_catches_each_kind_of_history():
    """The check can fail: each kind of work-log phrase is caught, plain prose is not."""
    for text in ("measured 2026-12-03", "the behaviour before issue 21", "ninth session", "stop 3 of the run"):
        assert history_hits(text), text
    for text in ("S0-10 ... S0-14", "(..., 6, n) in Nm/rad", "obsessions, a tissue", "nonstop 3"):
        assert not history_hits(text), text


def test_readme_has_no_work_log_history():
    bad = [
        f"README.md:{i}: {hits}"
        for i, line in enumerate((ROOT / "README.md").read_text(encoding="utf-8").splitlines(), 1)
        if (hits := history_hits(line))
    ]
    assert not bad, "work-log history in README.md (move it to docs/benchmarks.md or docs/notes/):\n" + "\n".join(bad)


@pytest.mark.parametrize("module", sorted(PACKAGE.rglob("*.py")), ids=lambda p: str(p.relative_to(ROOT)))
def test_docstrings_have_no_work_log_history(module):
    bad = [
        f"{module.relative_to(ROOT)}:{line} ({owner}): {hits}"
        for owner, line, doc in docstrings(module.read_text(encoding="utf-8"))
        if (hits := history_hits(doc))
    ]
    assert not bad, "work-log history in docstrings (move it to docs/benchmarks.md or docs/notes/):\n" + "\n".join(bad)
