"""The Markdown of ``jaxstiff reproduce``'s report: one experiment run (:class:`ExperimentRun`),
the section of its output folder (summary, tables, figures), the environment, and the report file."""

from __future__ import annotations

import dataclasses
import datetime
import glob
import os
import platform
import re
import shutil
import sys
from collections.abc import Sequence

from jaxstiff.runtime._io import atomic_write_text

__all__ = ["ExperimentRun", "section", "environment", "write_report"]

_TABLE_MAX_ROWS = 40
_JSON_MAX_ROWS = 60


@dataclasses.dataclass
class ExperimentRun:
    """One experiment's run: ``name``, ``script``, ``out`` folder, exit ``code`` (None if it timed out), ``wall_s``."""

    name: str
    script: str
    out: str
    code: int | None
    wall_s: float
    log: str
    cmd: str = ""

    @property
    def ok(self) -> bool:
        return self.code == 0


def _tail(file: str, n: int = 30) -> str:
    try:
        with open(file, encoding="utf-8", errors="replace") as fh:
            return "".join(fh.readlines()[-n:])
    except OSError:
        return ""


def _csv_table(file: str) -> str | None:
    import csv

    try:
        with open(file, newline="", encoding="utf-8") as fh:
            rows = list(csv.reader(fh))
    except (OSError, UnicodeDecodeError, csv.Error):
        return None
    if not rows or len(rows) > _TABLE_MAX_ROWS + 1 or len(rows[0]) > 16:
        return None
    head = rows[0]
    out = ["| " + " | ".join(head) + " |", "|" + "|".join("---" for _ in head) + "|"]
    for r in rows[1:]:
        cells = []
        for c in r:
            try:
                v = float(c)
                cells.append(f"{v:.4g}" if not c.strip().lstrip("-").isdigit() else c)
            except ValueError:
                cells.append(c.replace("|", "\\|"))
        out.append("| " + " | ".join(cells) + " |")
    return "\n".join(out)


def _flatten(obj: object, prefix: str = "") -> list[tuple[str, object]]:
    """Scalars (and short lists of numbers) of a JSON tree as ``(dotted.key, value)``."""
    out: list[tuple[str, object]] = []
    if isinstance(obj, dict):
        for k, v in obj.items():
            out += _flatten(v, f"{prefix}.{k}" if prefix else str(k))
    elif (
        isinstance(obj, list)
        and len(obj) <= 8
        and all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in obj)
    ):
        out.append((prefix, "[" + ", ".join(f"{x:.4g}" for x in obj) + "]"))
    elif isinstance(obj, list):
        for i, v in enumerate(obj[:8]):
            out += _flatten(v, f"{prefix}[{i}]")
    else:
        out.append((prefix, obj))
    return out


def _json_table(file: str) -> str | None:
    import json

    try:
        with open(file, encoding="utf-8") as fh:
            data = json.load(fh)
    except (OSError, UnicodeDecodeError, ValueError):
        return None
    items = _flatten(data)
    if not items:
        return None
    lines = ["| key | value |", "|---|---|"]
    for k, v in items[:_JSON_MAX_ROWS]:
        if isinstance(v, float):
            v = f"{v:.6g}"
        lines.append(f"| {k} | {str(v).replace('|', chr(92) + '|')} |")
    if len(items) > _JSON_MAX_ROWS:
        lines.append(f"| ... | ({len(items) - _JSON_MAX_ROWS} more in {os.path.basename(file)}) |")
    return "\n".join(lines)


def _printed(log_file: str, n: int = 40) -> str:
    """What the run printed (its log without the command line), last ``n`` lines."""
    try:
        with open(log_file, encoding="utf-8", errors="replace") as fh:
            lines = fh.read().splitlines()
    except OSError:
        return ""
    lines = [ln for ln in lines[1:] if ln.strip()]
    if len(lines) > n:
        lines = [f"... ({len(lines) - n} lines above in log.txt)"] + lines[-n:]
    return "\n".join(lines)


_IMG = re.compile(r"!\[([^\]]*)\]\(([^)\s]+)\)")


_SKIP_TABLES = ("timing.csv", "results.csv")


def section(run_name: str, folder: str, fig_dir: str, report_dir: str, note: str = "", log: str = "") -> list[str]:  # noqa: C901 - one report section assembled in order, each part a few lines
    """Markdown lines of one experiment's output folder ``folder``; copies its PNGs to ``fig_dir``
    (links relative to ``report_dir``). ``note`` goes first; ``log``: the run's log, shown when the
    experiment wrote no ``summary.md``."""
    md: list[str] = []
    if note:
        md += [note, ""]
    summary = os.path.join(folder, "summary.md")
    has_summary = os.path.isfile(summary)
    # an experiment's own summary.md says what matters; otherwise show what it printed and its tables
    printed = _printed(log) if log and not has_summary else ""
    if printed:
        md += ["What it printed:", "", "```text", printed, "```", ""]
    os.makedirs(fig_dir, exist_ok=True)
    pngs = sorted(glob.glob(os.path.join(folder, "**", "*.png"), recursive=True))
    copied: dict[str, str] = {}
    for p in pngs:
        rel = os.path.relpath(p, folder)
        dest = os.path.join(fig_dir, rel.replace(os.sep, "_"))
        shutil.copyfile(p, dest)
        copied[os.path.normpath(rel)] = os.path.relpath(dest, report_dir).replace(os.sep, "/")
    shown = set()
    if has_summary:
        text = open(summary, encoding="utf-8", errors="replace").read()

        def relink(m: re.Match) -> str:
            target = os.path.normpath(m.group(2))
            if target in copied:
                shown.add(target)
                return f"![{m.group(1)}]({copied[target]})"
            return m.group(0)

        text = _IMG.sub(relink, text)
        # the experiment's own headings go below the report's section heading: top level -> ###
        levels = [len(h) for h in re.findall(r"^(#+)\s", text, flags=re.M)]
        shift = 3 - min(levels) if levels else 0
        text = re.sub(r"^(#+)(?=\s)", lambda m: "#" * max(1, min(6, len(m.group(1)) + shift)), text, flags=re.M)
        md += [text.strip(), ""]
    for csvf in sorted(glob.glob(os.path.join(folder, "*.csv"))) if not has_summary else []:
        if os.path.basename(csvf) in _SKIP_TABLES:
            continue
        tbl = _csv_table(csvf)
        if tbl:
            md += [f"**{os.path.basename(csvf)}**", "", tbl, ""]
    for jf in sorted(glob.glob(os.path.join(folder, "*.json"))) if not has_summary else []:
        if os.path.basename(jf) in ("manifest.json", "plan.json"):
            continue
        tbl = _json_table(jf)
        if tbl:
            md += [f"<details><summary>{os.path.basename(jf)}</summary>", "", tbl, "", "</details>", ""]
    for rel, link in copied.items():
        if rel not in shown:
            md += [f"![{run_name}: {rel}]({link})", ""]
    if not pngs and len(md) <= 2:
        md += ["(no figures or tables written)", ""]
    return md


def environment() -> list[str]:
    """Markdown list lines: date (UTC), versions, machine and JAX devices."""
    import jax
    import numpy as np
    import scipy

    from jaxstiff.runtime._version import __version__

    try:
        devices = ", ".join(sorted({d.platform for d in jax.devices()})) + f" x{jax.device_count()}"
    except RuntimeError:
        devices = "?"
    cpu = platform.processor() or platform.machine()
    return [
        f"- date: {datetime.datetime.now(datetime.timezone.utc).isoformat(timespec='seconds')}",
        f"- jaxstiff {__version__}, jax {jax.__version__}, numpy {np.__version__}, scipy {scipy.__version__}, "
        f"python {sys.version.split()[0]}",
        f"- machine: {platform.platform()}, {cpu}, {os.cpu_count()} CPUs; JAX devices: {devices}",
    ]


def _intro(quick: bool, only: Sequence[str] | None, everything: bool) -> list[str]:
    """The report's title and the sentence that says which experiments ran and how."""
    return [
        "# jaxstiff: reproduction report",
        "",
        (
            "The experiments " + ", ".join(f"`{o}*`" for o in only)
            if only
            else "Every experiment of the repository"
            if everything
            else "The reproductions of seed 000's figures (fig*), the project's two fidelity studies of them "
            "(task_modes: which stiffness is shaped; f1_default_path), the project's own CSC cases on seed 001's "
            "method (csc*) and the physics check (sim*)"
        )
        + ", run by `jaxstiff reproduce"
        + (" --quick" if quick else "")
        + (" --only " + " ".join(only) if only else "")
        + (" --all" if everything and not only else "")
        + "` as its own process; each section shows what the experiment "
        "wrote (its summary, tables and figures).",
        "",
    ]


def write_report(
    out: str, runs: list[ExperimentRun], wall: float, *, quick: bool, only: Sequence[str] | None, everything: bool
) -> str:
    """Write ``out/report.md`` (and ``out/figures/``, replaced) for ``runs``; returns the report's path.

    Args:
        out: the output folder of ``jaxstiff reproduce``.
        runs: the runs in report order.
        wall: total wall time (s).
        quick, only, everything: how the runs were made (named in the report's first sentence).
    """
    figs_dir = os.path.join(out, "figures")
    if os.path.isdir(figs_dir):
        shutil.rmtree(figs_dir)
    md = _intro(quick, only, everything)
    md += environment()
    md += [f"- total wall time: {wall:.0f} s", "", "| experiment | status | wall time (s) |", "|---|---|---|"]
    for r in runs:
        status = "ok" if r.ok else ("timed out" if r.code is None else f"FAILED (exit {r.code})")
        md.append(f"| [{r.name}](#{r.name.lower()}) | {status} | {r.wall_s:.1f} |")
    md.append("")
    for r in runs:
        md += [f"## {r.name}", ""]
        what = r.cmd
        if not r.ok:
            md += [
                f"**{'timed out' if r.code is None else f'failed with exit code {r.code}'}**; end of its log:",
                "",
                "```",
                _tail(r.log).rstrip(),
                "```",
                "",
            ]
        md += section(
            r.name,
            r.out,
            os.path.join(figs_dir, r.name),
            out,
            note=f"`{what}` ({r.wall_s:.1f} s)",
            log=r.log if r.ok else "",
        )
    report = os.path.join(out, "report.md")
    atomic_write_text(report, "\n".join(md) + "\n")
    return report
