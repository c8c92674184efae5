"""The small pieces every experiment script shares: its ``--out`` parser and its summary tables
(Markdown, plain text, CSV)."""

from __future__ import annotations

import argparse
import csv
import os
from collections.abc import Sequence
from typing import IO

from jaxstiff.runtime._io import atomic_write

__all__ = ["experiment_parser", "markdown_table", "text_table", "save_table_csv"]


def experiment_parser(name: str, description: str) -> argparse.ArgumentParser:
    """The command line of an experiment script ``experiments/NAME.py``, with its ``--out DIR`` option.

    ``--out`` defaults to ``out/NAME`` (the contract of ``jaxstiff reproduce``: every experiment takes
    ``--out DIR``). The description is shown as written (line breaks kept).

    Example:
        >>> ap = plots.experiment_parser("fig2_cms", "Seed 000 Fig. 2")
        >>> ap.parse_args([]).out
        'out/fig2_cms'
    """
    ap = argparse.ArgumentParser(description=description, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument(
        "--out", default=os.path.join("out", name), help=f"output folder (default {os.path.join('out', name)})"
    )
    return ap


def markdown_table(rows: Sequence[dict]) -> list[str]:
    """Lines of a Markdown table of ``rows`` (dicts of strings with the same keys; the header is the first row's keys).


    Example:
        >>> plots.markdown_table([{"k": "1", "ratio": "2.5"}])
        ['| k | ratio |', '|---|---|', '| 1 | 2.5 |']

    Raises:
        ValueError: no rows.
    """
    if not rows:
        raise ValueError("markdown_table: no rows")
    header = list(rows[0])
    return [
        "| " + " | ".join(header) + " |",
        "|" + "---|" * len(header),
        *("| " + " | ".join(row[h] for h in header) + " |" for row in rows),
    ]


def text_table(rows: Sequence[dict], width: int, sep: str = " ") -> list[str]:
    """Lines of a plain-text table of ``rows`` (dicts of strings): the header, then one line a row,
    every cell right-aligned in ``width`` characters, cells joined by ``sep``.

    Example:
        >>> plots.text_table([{"k": "1", "ratio": "2.5"}], width=6)
        ['     k  ratio', '     1    2.5']

    Raises:
        ValueError: no rows.
    """
    if not rows:
        raise ValueError("text_table: no rows")
    header = list(rows[0])
    return [
        sep.join(f"{h:>{width}s}" for h in header),
        *(sep.join(f"{row[h]:>{width}s}" for h in header) for row in rows),
    ]


def save_table_csv(rows: Sequence[dict], file: str | os.PathLike) -> str:
    """Write ``rows`` (dicts with the same keys) as CSV with a header line to ``file``, atomically.

    Raises:
        ValueError: no rows.
        FileNotFoundError: the target folder does not exist.
    """
    if not rows:
        raise ValueError(f"save_table_csv: no rows to write to {os.fspath(file)}")

    def write(fh: IO) -> None:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)

    return atomic_write(file, write)
