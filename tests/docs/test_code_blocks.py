"""Every ```python block of README.md and of the user documentation runs, as a reader runs it, and
every ``jaxstiff ...`` line of their shell blocks is one the command-line parser takes.

A page's blocks run one after another in one fresh interpreter (a later block may use an earlier
one's names, as a reader's session would), in a scratch folder that sees the checkout's shipped
folders (``tests/data/robots/...``, ``experiments/...``: the paths the pages name), so that what a
block writes (``shape.npz``, ``my_path.csv``) lands there, not in the checkout. A block that
raises fails the page with the block's line. The pages' own words on their output are not checked
here; the numbers they quote come from the benchmarks and notes.

The developer notes (docs/notes), the papers' formulas (SPEC.md, DESIGN.md) and the generated
pages (docs/reproduce, docs/api) are left out: they are not code a reader is asked to run."""

from __future__ import annotations

import json
import os
import pathlib
import re
import subprocess
import sys

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]
#: not pages a reader runs code from
_SKIP = ("docs/notes/", "docs/reproduce/", "docs/api/", "docs/SPEC.md", "docs/DESIGN.md")
#: pages whose blocks take more than half a minute on a 2-core CPU (a sweep)
_LONG = ("docs/howto/sweeps.md",)
#: what a page's reader made with a command before its first block (the page says so), as Python
_BEFORE = {
    # shape.npz, the README's main job (`jaxstiff shape`)
    "docs/howto/physics-check.md": (
        "import jaxstiff\n"
        "robot = jaxstiff.Robot.from_urdf('kuka_lwr4', locked={'lwr_a7': 0.0})\n"
        "jaxstiff.shape(robot, jaxstiff.default_path(), 'f2', 5.0).save('shape.npz')\n"
    ),
}
_BLOCK = re.compile(r"^```python\n(.*?)^```", re.S | re.M)


def _user_pages() -> list[str]:
    """README.md and the user documentation's pages (not those of :data:`_SKIP`), repository-relative."""
    pages = ["README.md"] + sorted(str(p.relative_to(ROOT)) for p in (ROOT / "docs").rglob("*.md"))
    return [p for p in pages if not p.startswith(_SKIP)]


def _pages() -> list[str]:
    return [p for p in _user_pages() if _BLOCK.search((ROOT / p).read_text(encoding="utf-8"))]


def blocks(text: str) -> list[tuple[int, str]]:
    """``(line, code)`` of each ```python block of ``text`` (line: the block's fence, 1-based)."""
    return [(text[: m.start()].count("\n") + 1, m.group(1)) for m in _BLOCK.finditer(text)]


_RUNNER = r"""
import json, sys, traceback
ns = {"__name__": "__main__"}
for line, code in json.loads(sys.stdin.read()):
    try:
        exec(compile(code, "block at line %d" % line, "exec"), ns)
    except BaseException:
        print("BLOCK-FAILED %d" % line)
        traceback.print_exc()
        sys.exit(1)
"""


def test_blocks_are_found_and_a_failing_block_is_named(tmp_path):
    text = "x\n```python\na = 1\n```\ntext\n```bash\nls\n```\n```python\nraise ValueError(a)\n```\n"
    found = blocks(text)
    assert found == [(2, "a = 1\n"), (9, "raise ValueError(a)\n")]
    out = subprocess.run(
        [sys.executable, "-c", _RUNNER], input=json.dumps(found), cwd=tmp_path, capture_output=True, text=True
    )
    assert out.returncode == 1 and "BLOCK-FAILED 9" in out.stdout and "ValueError: 1" in out.stderr


@pytest.mark.parametrize("page", [pytest.param(p, marks=pytest.mark.slow) if p in _LONG else p for p in _pages()])
def test_page_code_runs(page, tmp_path):
    found = blocks((ROOT / page).read_text(encoding="utf-8"))
    if page in _BEFORE:
        found.insert(0, (0, _BEFORE[page]))
    for name in ("tests", "urdf", "experiments", "examples"):  # the shipped paths the pages name
        if (ROOT / name).exists():
            (tmp_path / name).symlink_to(ROOT / name, target_is_directory=True)
    env = dict(os.environ, MPLBACKEND="Agg")  # jaxstiff as installed, as a reader has it
    out = subprocess.run(
        [sys.executable, "-c", _RUNNER],
        input=json.dumps(found),
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=900,
        env=env,
    )
    assert out.returncode == 0, f"{page}: {out.stdout[-400:]}\n{out.stderr[-3000:]}"


_SHELL = re.compile(r"^```(?:bash|sh|console)\n(.*?)^```", re.S | re.M)


def command_lines(text: str) -> list[tuple[int, str]]:
    """``(line, command)`` of each ``jaxstiff ...`` command in the shell blocks of ``text``: a
    backslash continues a line, a ``#`` starts a comment, ``[...]`` marks an optional part (left
    out)."""
    out = []
    for m in _SHELL.finditer(text):
        first = text[: m.start()].count("\n") + 2
        lines = m.group(1).splitlines()
        i = 0
        while i < len(lines):
            start, cmd = first + i, lines[i]
            while cmd.rstrip().endswith("\\") and i + 1 < len(lines):
                i += 1
                cmd = cmd.rstrip()[:-1].rstrip() + " " + lines[i].strip()
            i += 1
            cmd = re.sub(r"\[[^\]]*\]", "", cmd.split(" #", 1)[0]).strip()
            if cmd.startswith("jaxstiff "):
                out.append((start, cmd))
    return out


def _command_pages() -> list[str]:
    return [p for p in _user_pages() if command_lines((ROOT / p).read_text(encoding="utf-8"))]


def test_command_lines_are_found_joined_and_trimmed():
    text = "```bash\njaxstiff a --x 1 \\\n  --y 2   # note\nls\njaxstiff b [--z 3]\n```\n"
    assert command_lines(text) == [(2, "jaxstiff a --x 1 --y 2"), (5, "jaxstiff b")]
    from jaxstiff.cli._main import build_parser

    with pytest.raises(SystemExit):  # what the page test reports: a flag the command does not have
        build_parser().parse_args(["shape", "--no-such-flag", "1"])


@pytest.mark.parametrize("page", _command_pages())
def test_page_commands_parse(page, capsys):
    """Each documented ``jaxstiff`` command line is one the command-line parser takes: its flags,
    their values' form and the subcommand exist (what a renamed or removed flag would break)."""
    import shlex

    from jaxstiff.cli._main import build_parser

    parser = build_parser()
    for line, cmd in command_lines((ROOT / page).read_text(encoding="utf-8")):
        try:
            parser.parse_args(shlex.split(cmd)[1:])
        except SystemExit as e:
            err = capsys.readouterr().err.strip().splitlines()
            raise AssertionError(f"{page}:{line}: {cmd!r} is refused: {err[-1] if err else e}") from None
