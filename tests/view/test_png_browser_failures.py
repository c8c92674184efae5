"""`jaxstiff view --png` when the browser misbehaves: a browser that exits at once, one that never
prints its DevTools address, and one that prints an address nobody answers at. Each ends in one
line `jaxstiff: error: --png: ...` that names the browser and the step, exit status 2, and no
picture; never a Python traceback. The "browsers" are shell scripts: no Chromium is needed."""

from __future__ import annotations

import os
import stat

import pytest

from jaxstiff.cli import main


def _script(path, body: str) -> str:
    path.write_text("#!/bin/sh\n" + body + "\n")
    path.chmod(path.stat().st_mode | stat.S_IXUSR)
    return str(path)


@pytest.mark.parametrize(
    ("body", "timeout", "says"),
    [
        ("exit 1", 30, r"did not start: exit status 1; nothing written"),
        # never prints its address: the deadline ends the start (not "did not start": it was killed)
        ("sleep 600", 3, r"did not finish starting Chromium within 3 s; nothing written"),
        # prints an address at a closed port: the connection's refusal is put in words
        (
            'echo "DevTools listening on ws://127.0.0.1:1/devtools/browser/x" >&2; sleep 600',
            30,
            r"printed the DevTools address ws://127\.0\.0\.1:1/devtools/browser/x, which does not answer",
        ),
    ],
    ids=["exits", "silent", "no-answer"],
)
def test_a_failing_browser_gives_one_line_and_no_picture(shape_file, tmp_path, capsys, body, timeout, says) -> None:
    pytest.importorskip("viser")
    import re

    browser = _script(tmp_path / "browser.sh", body)
    out = str(tmp_path / "v.png")
    rc = main(["view", shape_file, "--png", out, "--browser", browser, "--timeout", str(timeout)])
    err = capsys.readouterr().err
    lines = [ln for ln in err.strip().splitlines() if ln.startswith("jaxstiff")]
    assert rc == 2, err
    assert "Traceback" not in err, err
    assert len(lines) == 1 and lines[0].startswith("jaxstiff: error: --png: "), err
    assert re.search(says, lines[0]), lines[0]
    assert not os.path.exists(out)


@pytest.mark.parametrize(("flag", "name"), [("--html", "v.png"), ("--png", "v.html"), ("--png", "v")])
def test_a_view_file_named_for_another_format_is_refused(shape_file, tmp_path, capsys, flag, name) -> None:
    """`--html v.png` wrote a page into a file named as a picture; now refused before any work."""
    pytest.importorskip("viser")
    out = str(tmp_path / name)
    rc = main(["view", shape_file, flag, out])
    err = capsys.readouterr().err
    assert rc == 2 and f"{flag} {out}: the file is" in err, err
    assert not os.path.exists(out)
