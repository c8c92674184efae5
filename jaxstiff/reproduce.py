"""``jaxstiff reproduce --out DIR``: run every experiment and write one report (Markdown + PNG).

The experiments are the scripts in the source checkout's ``experiments/`` folder, each runnable
as ``python experiments/NAME.py --out DIR``. By default the reproductions of the seeds run: seed 000
Fig. 2-6 (``fig*``) and the CSC experiments of seed 001 (``csc*``); ``--all`` adds the others
(studies beyond the seeds, which may take much longer), ``--only`` picks by name. They
are run here as **subprocesses**, one after another:

* a failing or hanging experiment (``timeout``) cannot take the others or the report down: it is
  marked failed in the report with the end of its log, and the command exits with code 1;
* each gets a fresh interpreter (no state, JIT caches or x64 flags leak between experiments);
* the scripts stay plain scripts (STYLE.md: each experiment is a short script that calls the
  library), and the library does not import them.

``experiments/`` is not part of the installed package, so ``reproduce`` needs a source checkout: it
looks in ``--experiments DIR``, then ``$JAXSTIFF_EXPERIMENTS``, then ``experiments/`` beside the
package (an editable install or a clone), then ``./experiments``; otherwise it stops with a
message that says so. The shipped sweep ``experiments/sweeps/quick.toml`` runs as one more section
(``--no-sweep`` skips it).

Layout of ``DIR``::

    DIR/report.md            the report: environment, one section per experiment (its summary,
                             tables and figures), the sweep's summary and heat maps
    DIR/figures/NAME/*.png   the figures the report shows
    DIR/runs/NAME/           each experiment's own output folder and log.txt

Experiment contract: a script ``experiments/NAME.py`` accepts ``--out DIR`` (and ``--quick`` if it
has a shorter variant; ``reproduce --quick`` passes it when the script's source mentions it) and
writes PNG figures into DIR, and either a ``summary.md`` (shown verbatim, headings demoted, image
links rewritten) or, without one, what it prints plus small CSV tables and ``*.json`` summaries
(shown as Markdown tables).
"""

from __future__ import annotations

import dataclasses
import datetime
import glob
import os
import platform
import re
import shutil
import subprocess
import sys
import time
from typing import Callable, Sequence

__all__ = ["find_experiments_dir", "discover", "run_reproduce", "ReproduceOutcome", "ExperimentRun"]

#: Order of the report: seed 000 figures 2-6, then CSC, then the rest alphabetically.
ORDER = ("fig2", "fig3", "fig4", "fig5", "fig6", "csc")
_TABLE_MAX_ROWS = 40
_JSON_MAX_ROWS = 60


def find_experiments_dir(explicit: str | os.PathLike | None = None) -> str:
    """The ``experiments/`` folder of a source checkout.

    Raises:
        FileNotFoundError: none found; the message lists where it looked and what to do.
    """
    tried = []
    candidates = []
    if explicit is not None:
        candidates.append(("--experiments", os.fspath(explicit)))
    env = os.environ.get("JAXSTIFF_EXPERIMENTS")
    if env:
        candidates.append(("$JAXSTIFF_EXPERIMENTS", env))
    here = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    candidates.append(("the source checkout", os.path.join(here, "experiments")))
    candidates.append(("the working folder", os.path.join(os.getcwd(), "experiments")))
    for what, path in candidates:
        tried.append(f"{path} ({what})")
        if os.path.isdir(path) and discover(path):
            return os.path.abspath(path)
        if explicit is not None and what == "--experiments":
            raise FileNotFoundError(f"--experiments {path}: not a folder with experiment scripts (NAME.py taking --out)")
    raise FileNotFoundError(
        "jaxstiff reproduce runs the scripts in the experiments/ folder of a source checkout, which is not "
        "part of the installed package; looked in: " + "; ".join(tried)
        + ". Run it from a clone of the repository (pip install -e .), or pass --experiments DIR"
    )


def _is_experiment(path: str) -> bool:
    name = os.path.basename(path)
    if name.startswith("_") or not name.endswith(".py"):
        return False
    try:
        with open(path, encoding="utf-8") as fh:
            src = fh.read()
    except (OSError, UnicodeDecodeError):
        return False
    return "__main__" in src and "--out" in src


def _order_key(name: str) -> tuple:
    for i, prefix in enumerate(ORDER):
        if name.startswith(prefix):
            return (i, name)
    return (len(ORDER), name)


def discover(folder: str, everything: bool = True) -> list[str]:
    """Experiment scripts in ``folder`` (``NAME.py`` with a ``__main__`` block taking ``--out``), report order.

    Args:
        everything: all of them; False: only the reproductions of the seeds (names starting with
            ``fig`` or ``csc``), the default set of ``jaxstiff reproduce``.
    """
    scripts = [p for p in glob.glob(os.path.join(folder, "*.py")) if _is_experiment(p)]
    if not everything:
        scripts = [p for p in scripts if _order_key(os.path.basename(p)[:-3])[0] < len(ORDER)]
    return sorted(scripts, key=lambda p: _order_key(os.path.basename(p)[:-3]))


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


@dataclasses.dataclass
class ReproduceOutcome:
    """What :func:`run_reproduce` did: the report file, the runs, the total wall time."""

    report: str
    runs: list[ExperimentRun]
    wall_s: float

    @property
    def ok(self) -> bool:
        return all(r.ok for r in self.runs)


def _run_one(script: str, out: str, quick: bool, timeout: float | None, repo: str) -> ExperimentRun:
    name = os.path.basename(script)[:-3]
    os.makedirs(out, exist_ok=True)
    with open(script, encoding="utf-8") as fh:
        src = fh.read()
    cmd = [sys.executable, script, "--out", out]
    if quick and "--quick" in src:
        cmd.append("--quick")
    env = dict(os.environ)
    env["PYTHONPATH"] = repo + (os.pathsep + env["PYTHONPATH"] if env.get("PYTHONPATH") else "")
    env.setdefault("MPLBACKEND", "Agg")
    log_file = os.path.join(out, "log.txt")
    t0 = time.perf_counter()
    with open(log_file, "w", encoding="utf-8") as log:
        log.write("$ " + " ".join(cmd) + "\n")
        log.flush()
        try:
            p = subprocess.run(cmd, cwd=repo, env=env, stdout=log, stderr=subprocess.STDOUT, timeout=timeout)
            code: int | None = p.returncode
        except subprocess.TimeoutExpired:
            code = None
            log.write(f"\n[reproduce] timed out after {timeout} s\n")
    shown = ["python", os.path.relpath(script, repo), "--out", "DIR"] + cmd[4:]
    return ExperimentRun(name, script, out, code, time.perf_counter() - t0, log_file, " ".join(shown))


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


def _flatten(obj, prefix: str = "") -> list[tuple[str, object]]:
    """Scalars (and short lists of numbers) of a JSON tree as ``(dotted.key, value)``."""
    out: list[tuple[str, object]] = []
    if isinstance(obj, dict):
        for k, v in obj.items():
            out += _flatten(v, f"{prefix}.{k}" if prefix else str(k))
    elif isinstance(obj, list) and len(obj) <= 8 and all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in obj):
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


def _section(run_name: str, folder: str, fig_dir: str, report_dir: str, note: str = "", log: str = "") -> list[str]:
    """Markdown of one experiment's output folder; copies its PNGs to ``fig_dir``."""
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

        def relink(m):
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


def _environment() -> list[str]:
    import jax
    import numpy as np
    import scipy

    from jaxstiff.runtime.version import __version__

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


def run_reproduce(
    out: str | os.PathLike,
    *,
    quick: bool = False,
    only: Sequence[str] | None = None,
    experiments_dir: str | os.PathLike | None = None,
    timeout: float | None = 900.0,
    sweep: bool = True,
    everything: bool = False,
    report_only: bool = False,
    log: Callable[[str], None] | None = None,
) -> ReproduceOutcome:
    """Run the experiments (and the quick sweep) and write ``DIR/report.md``.

    Args:
        out: output folder (created; earlier runs' files in it are replaced).
        quick: pass ``--quick`` to the experiments that have it.
        only: run only the experiments whose names start with one of these (e.g. ``["fig4", "csc"]``).
        experiments_dir: the experiments folder (default: see :func:`find_experiments_dir`).
        timeout: seconds per experiment (None: no limit).
        sweep: also run ``experiments/sweeps/quick.toml``.
        everything: run every experiment script, not only the seed reproductions (``fig*``,
            ``csc*``); the others (e.g. the solver quality study) may take much longer.
        report_only: run nothing; rebuild ``report.md`` from the runs already in ``DIR/runs``.
        log: one-line progress messages (default: stderr).

    Returns:
        :class:`ReproduceOutcome`; ``.ok`` is False if any experiment failed (the report is written anyway).

    Raises:
        FileNotFoundError: no experiments folder (not a source checkout).
        ValueError: ``only`` matches no experiment.
    """
    from jaxstiff.sweep.store import atomic_write_text

    if log is None:
        log = lambda s: print(s, file=sys.stderr, flush=True)  # noqa: E731
    exp_dir = find_experiments_dir(experiments_dir)
    repo = os.path.dirname(exp_dir)
    scripts = discover(exp_dir, everything=everything or bool(only))
    if only:
        scripts = [s for s in scripts if any(os.path.basename(s).startswith(o) for o in only)]
        if not scripts:
            raise ValueError(f"--only {' '.join(only)}: no experiment matches; experiments: "
                             + ", ".join(os.path.basename(s)[:-3] for s in discover(exp_dir)))
    out = os.path.abspath(os.fspath(out))
    runs_dir, figs_dir = os.path.join(out, "runs"), os.path.join(out, "figures")
    os.makedirs(runs_dir, exist_ok=True)
    t0 = time.perf_counter()
    runs: list[ExperimentRun] = []
    sweep_cfg = os.path.join(exp_dir, "sweeps", "quick.toml")
    with_sweep = sweep and os.path.isfile(sweep_cfg) and not only
    if report_only:
        for name in [os.path.basename(s)[:-3] for s in scripts] + (["sweep_quick"] if with_sweep else []):
            r = _load_status(os.path.join(runs_dir, name))
            if r is None:
                log(f"{name}: no earlier run in {runs_dir}; left out")
            else:
                runs.append(r)
        if not runs:
            raise ValueError(f"--report-only: no runs in {runs_dir}; run jaxstiff reproduce --out {out} first")
        scripts = []
    for i, s in enumerate(scripts):
        name = os.path.basename(s)[:-3]
        log(f"[{i + 1}/{len(scripts)}] {name} ...")
        dest = os.path.join(runs_dir, name)
        if os.path.isdir(dest):
            shutil.rmtree(dest)
        r = _run_one(s, dest, quick, timeout, repo)
        _save_status(r)
        runs.append(r)
        log(f"[{i + 1}/{len(scripts)}] {name}: {'ok' if r.ok else 'FAILED' if r.code is not None else 'TIMED OUT'} "
            f"in {r.wall_s:.1f} s")
    if with_sweep and not report_only:
        log("sweep quick.toml ...")
        dest = os.path.join(runs_dir, "sweep_quick")
        if os.path.isdir(dest):
            shutil.rmtree(dest)
        r = _run_sweep(sweep_cfg, dest, timeout, repo)
        _save_status(r)
        runs.append(r)
        log(f"sweep quick.toml: {'ok' if r.ok else 'FAILED'} in {r.wall_s:.1f} s")
    wall = time.perf_counter() - t0 if not report_only else sum(r.wall_s for r in runs)

    if os.path.isdir(figs_dir):
        shutil.rmtree(figs_dir)
    md = ["# jaxstiff: reproduction report", ""]
    md += [
        ("The experiments " + ", ".join(f"`{o}*`" for o in only) if only else
         "Every experiment of the repository" if everything else "The reproductions of the seeds (fig*, csc*)")
        + ", run by `jaxstiff reproduce" + (" --quick" if quick else "")
        + (" --only " + " ".join(only) if only else "") + (" --all" if everything and not only else "")
        + "` as its own process; each section shows what the experiment "
        "wrote (its summary, tables and figures).", "",
    ]
    md += _environment()
    md += [f"- total wall time: {wall:.0f} s", "", "| experiment | status | wall time (s) |", "|---|---|---|"]
    for r in runs:
        status = "ok" if r.ok else ("timed out" if r.code is None else f"FAILED (exit {r.code})")
        md.append(f"| [{r.name}](#{r.name.replace('_', '-').lower()}) | {status} | {r.wall_s:.1f} |")
    md.append("")
    for r in runs:
        md += [f"## {r.name}", ""]
        what = r.cmd
        if not r.ok:
            md += [f"**{'timed out' if r.code is None else f'failed with exit code {r.code}'}**; end of its log:", "",
                   "```", _tail(r.log).rstrip(), "```", ""]
        md += _section(r.name, r.out, os.path.join(figs_dir, r.name), out, note=f"`{what}` ({r.wall_s:.1f} s)",
                       log=r.log if r.ok else "")
    report = os.path.join(out, "report.md")
    atomic_write_text(report, "\n".join(md) + "\n")
    log(f"wrote {report}")
    return ReproduceOutcome(report=report, runs=runs, wall_s=wall)


_STATUS = ".reproduce.json"


def _save_status(r: ExperimentRun) -> None:
    import json

    from jaxstiff.sweep.store import atomic_write_text

    atomic_write_text(os.path.join(r.out, _STATUS), json.dumps(dataclasses.asdict(r), indent=1))


def _load_status(folder: str) -> ExperimentRun | None:
    import json

    try:
        with open(os.path.join(folder, _STATUS), encoding="utf-8") as fh:
            return ExperimentRun(**json.load(fh))
    except (OSError, ValueError, TypeError):
        return None


def _run_sweep(config: str, out: str, timeout: float | None, repo: str) -> ExperimentRun:
    """The quick sweep as a subprocess too (same isolation as the experiments)."""
    os.makedirs(os.path.dirname(out), exist_ok=True)
    cmd = [sys.executable, "-c", "import sys; from jaxstiff.cli import main; sys.exit(main())",
           "sweep", config, "--out", out, "--no-progress"]
    env = dict(os.environ)
    env["PYTHONPATH"] = repo + (os.pathsep + env["PYTHONPATH"] if env.get("PYTHONPATH") else "")
    log_file = out + ".log"
    t0 = time.perf_counter()
    with open(log_file, "w", encoding="utf-8") as log:
        log.write("$ " + " ".join(cmd) + "\n")
        log.flush()
        try:
            code: int | None = subprocess.run(cmd, cwd=repo, env=env, stdout=log, stderr=subprocess.STDOUT, timeout=timeout).returncode
        except subprocess.TimeoutExpired:
            code = None
    os.makedirs(out, exist_ok=True)
    shutil.move(log_file, os.path.join(out, "log.txt"))
    log_file = os.path.join(out, "log.txt")
    return ExperimentRun("sweep_quick", config, out, code, time.perf_counter() - t0, log_file,
                         f"jaxstiff sweep {os.path.relpath(config, repo)} --out DIR")
