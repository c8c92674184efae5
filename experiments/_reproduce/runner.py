"""``jaxstiff reproduce --out DIR``: run every experiment and write one report (Markdown + PNG).

The experiments are the scripts in the source checkout's ``experiments/`` folder, each runnable
as ``python experiments/NAME.py --out DIR``. By default the reproductions of the seeds run: seed 000
Fig. 2-6 (``fig*``), the project's two fidelity studies of them (``task_modes``: which stiffness is
shaped; ``f1_default_path``), the project's own CSC cases of seed 001's method (``csc*``; the seed
has no simulation example) and the MuJoCo check of the stiffness model (``sim*``); ``--all`` adds the others
(studies beyond the seeds, which may take much longer), ``--only`` picks by name. They
are run here as **subprocesses**, one after another:

* a failing or hanging experiment (``timeout``) cannot take the others or the report down: it is
  marked failed in the report with the end of its log, and the command exits with code 1;
* each gets a fresh interpreter (no state, JIT caches or x64 flags leak between experiments);
* the scripts stay plain scripts (each experiment is a short script that calls the
  library), and the library does not import them.

``experiments/`` (this runner included) is not part of the installed package, so ``reproduce``
needs a source checkout: the experiments come from ``--experiments DIR``, then
``$JAXSTIFF_EXPERIMENTS``, then this checkout's ``experiments/``, then ``./experiments``; otherwise
it stops with a message that says so. The shipped sweep ``experiments/sweeps/quick.toml`` runs as one more section
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
import glob
import os
import shutil
import subprocess
import sys
import time
from collections.abc import Callable, Sequence

from _reproduce.report import ExperimentRun, write_report
from jaxstiff.runtime._io import atomic_write_text

__all__ = ["find_experiments_dir", "discover", "run_reproduce", "ReproduceOutcome", "ExperimentRun"]

#: Order of the report: seed 000 figures 2-6, the two fidelity studies of them (which stiffness is
#: shaped; f1 on the default path), then CSC, then the physics check, then the rest alphabetically.
ORDER = ("fig2", "fig3", "fig4", "fig5", "fig6", "task_modes", "f1_default", "csc", "sim")


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
    here = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))  # this checkout's experiments/
    candidates.append(("the source checkout", here))
    candidates.append(("the working folder", os.path.join(os.getcwd(), "experiments")))
    for what, path in candidates:
        tried.append(f"{path} ({what})")
        if os.path.isdir(path) and discover(path):
            return os.path.abspath(path)
        if explicit is not None and what == "--experiments":
            raise FileNotFoundError(
                f"--experiments {path}: not a folder with experiment scripts (NAME.py taking --out)"
            )
    raise FileNotFoundError(
        "jaxstiff reproduce runs the scripts in the experiments/ folder of a source checkout, which is not "
        "part of the installed package; looked in: "
        + "; ".join(tried)
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
        everything: all of them; False: the default set of ``jaxstiff reproduce``: seed 000's figures
            (names starting with ``fig``), the fidelity studies ``task_modes`` and ``f1_default_path``,
            the CSC cases (``csc``) and the physics check (``sim``).
    """
    scripts = [p for p in glob.glob(os.path.join(folder, "*.py")) if _is_experiment(p)]
    if not everything:
        scripts = [p for p in scripts if _order_key(os.path.basename(p)[:-3])[0] < len(ORDER)]
    return sorted(scripts, key=lambda p: _order_key(os.path.basename(p)[:-3]))


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
    if log is None:
        log = lambda s: print(s, file=sys.stderr, flush=True)  # noqa: E731
    exp_dir = find_experiments_dir(experiments_dir)
    repo = os.path.dirname(exp_dir)
    scripts = _select_scripts(exp_dir, only, everything)
    out = os.path.abspath(os.fspath(out))
    runs_dir = os.path.join(out, "runs")
    if not report_only:  # (--report-only reads DIR/runs: a missing one is an error, not a new folder)
        os.makedirs(runs_dir, exist_ok=True)
    t0 = time.perf_counter()
    sweep_cfg = os.path.join(exp_dir, "sweeps", "quick.toml")
    with_sweep = sweep and os.path.isfile(sweep_cfg) and not only
    if report_only:
        runs = _earlier_runs(
            out, [os.path.basename(s)[:-3] for s in scripts] + (["sweep_quick"] if with_sweep else []), log
        )
        wall = sum(r.wall_s for r in runs)
    else:
        runs = _run_experiments(scripts, runs_dir, quick, timeout, repo, log)
        if with_sweep:
            runs.append(_run_quick_sweep(sweep_cfg, runs_dir, timeout, repo, log))
        wall = time.perf_counter() - t0
    report = write_report(out, runs, wall, quick=quick, only=only, everything=everything)
    log(f"wrote {report}")
    return ReproduceOutcome(report=report, runs=runs, wall_s=wall)


def _select_scripts(exp_dir: str, only: Sequence[str] | None, everything: bool) -> list[str]:
    """The experiment scripts to run: the seed reproductions, all (``everything``), or those ``only`` names."""
    scripts = discover(exp_dir, everything=everything or bool(only))
    if only:
        scripts = [s for s in scripts if any(os.path.basename(s).startswith(o) for o in only)]
        if not scripts:
            raise ValueError(
                f"--only {' '.join(only)}: no experiment matches; experiments: "
                + ", ".join(os.path.basename(s)[:-3] for s in discover(exp_dir))
            )
    return scripts


def _earlier_runs(out: str, names: list[str], log: Callable[[str], None]) -> list[ExperimentRun]:
    """The runs ``names`` already in ``out/runs`` (``--report-only``); missing ones are logged and left out."""
    runs_dir = os.path.join(out, "runs")
    runs = []
    for name in names:
        r = _load_status(os.path.join(runs_dir, name))
        if r is None:
            log(f"{name}: no earlier run in {runs_dir}; left out")
        else:
            runs.append(r)
    if not runs:
        raise ValueError(f"--report-only: no runs in {runs_dir}; run jaxstiff reproduce --out {out} first")
    return runs


def _run_experiments(
    scripts: list[str], runs_dir: str, quick: bool, timeout: float | None, repo: str, log: Callable[[str], None]
) -> list[ExperimentRun]:
    """Run each script into a fresh ``runs_dir/NAME``, one after another."""
    runs = []
    for i, s in enumerate(scripts):
        name = os.path.basename(s)[:-3]
        log(f"[{i + 1}/{len(scripts)}] {name} ...")
        dest = os.path.join(runs_dir, name)
        if os.path.isdir(dest):
            shutil.rmtree(dest)
        r = _run_one(s, dest, quick, timeout, repo)
        _save_status(r)
        runs.append(r)
        log(
            f"[{i + 1}/{len(scripts)}] {name}: {'ok' if r.ok else 'FAILED' if r.code is not None else 'TIMED OUT'} "
            f"in {r.wall_s:.1f} s"
        )
    return runs


def _run_quick_sweep(
    sweep_cfg: str, runs_dir: str, timeout: float | None, repo: str, log: Callable[[str], None]
) -> ExperimentRun:
    """Run ``experiments/sweeps/quick.toml`` into a fresh ``runs_dir/sweep_quick``."""
    log("sweep quick.toml ...")
    dest = os.path.join(runs_dir, "sweep_quick")
    if os.path.isdir(dest):
        shutil.rmtree(dest)
    r = _run_sweep(sweep_cfg, dest, timeout, repo)
    _save_status(r)
    log(f"sweep quick.toml: {'ok' if r.ok else 'FAILED'} in {r.wall_s:.1f} s")
    return r


_STATUS = ".reproduce.json"


def _save_status(r: ExperimentRun) -> None:
    import json

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
    cmd = [
        sys.executable,
        "-c",
        "import sys; from jaxstiff.cli import main; sys.exit(main())",
        "sweep",
        config,
        "--out",
        out,
        "--no-progress",
    ]
    env = dict(os.environ)
    env["PYTHONPATH"] = repo + (os.pathsep + env["PYTHONPATH"] if env.get("PYTHONPATH") else "")
    log_file = out + ".log"
    t0 = time.perf_counter()
    with open(log_file, "w", encoding="utf-8") as log:
        log.write("$ " + " ".join(cmd) + "\n")
        log.flush()
        try:
            code: int | None = subprocess.run(
                cmd, cwd=repo, env=env, stdout=log, stderr=subprocess.STDOUT, timeout=timeout
            ).returncode
        except subprocess.TimeoutExpired:
            code = None
    os.makedirs(out, exist_ok=True)
    shutil.move(log_file, os.path.join(out, "log.txt"))
    log_file = os.path.join(out, "log.txt")
    return ExperimentRun(
        "sweep_quick",
        config,
        out,
        code,
        time.perf_counter() - t0,
        log_file,
        f"jaxstiff sweep {os.path.relpath(config, repo)} --out DIR",
    )
