"""The numbered scripts in examples/ run, at the tests' tiny size, and write the figure the
documentation's gallery shows (each into a temporary folder, never over the committed ones).

Each script checks its own numbers where it can (05 compares jax.grad with a finite difference,
07 K_T of task "full" with the block of the 6x6 K_C; 01, 02 and 06 re-check their result with
jaxstiff.results.verify); here each must exit 0 and leave a non-empty PNG."""

from __future__ import annotations

import os
import pathlib
import subprocess
import sys

import pytest

ROOT = pathlib.Path(__file__).resolve().parent.parent
EXAMPLES = ROOT / "examples"
GALLERY = ROOT / "docs" / "gallery"
SCRIPTS = sorted(EXAMPLES.glob("[0-9][0-9]_*.py"))

#: the figure each script writes (its gallery picture)
FIGURE = {s.name: s.stem + ".png" for s in SCRIPTS}


def test_examples_are_numbered_and_short():
    assert 5 <= len(SCRIPTS) <= 8, [s.name for s in SCRIPTS]
    assert [s.name[:2] for s in SCRIPTS] == [f"{i:02d}" for i in range(1, len(SCRIPTS) + 1)]
    for s in SCRIPTS:
        assert len(s.read_text(encoding="utf-8").splitlines()) <= 70, f"{s.name} is longer than an example should be"
        assert (GALLERY / FIGURE[s.name]).is_file(), f"the gallery figure of {s.name} is not committed"


@pytest.mark.slow  # each a fresh process that compiles its kernels: 25-135 s on a loaded 2-core machine
@pytest.mark.parametrize("script", SCRIPTS, ids=lambda s: s.name)
def test_example_runs(script, tmp_path):
    env = dict(os.environ, JAXSTIFF_EXAMPLE_SIZE="tiny", JAXSTIFF_EXAMPLE_OUT=str(tmp_path), MPLBACKEND="Agg")
    proc = subprocess.run(
        [sys.executable, script.name], cwd=EXAMPLES, env=env, capture_output=True, text=True, timeout=600
    )
    assert proc.returncode == 0, f"{script.name} failed:\n{proc.stdout[-3000:]}\n{proc.stderr[-3000:]}"
    fig = tmp_path / FIGURE[script.name]
    assert fig.is_file() and fig.stat().st_size > 5000, f"{script.name} wrote no figure {fig.name}"
