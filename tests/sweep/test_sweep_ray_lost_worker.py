"""A Ray sweep whose worker process is killed mid-chunk (issue 24, item 3): Ray runs the chunk again
on another worker (the task's ``max_retries``), the sweep finishes, and its table equals the
uninterrupted local run's. The fault is real: the test finds a Ray worker process while it runs a
chunk (its process title is ``ray::ray_task``) and sends it SIGKILL; nothing in the package knows
about the test."""

from __future__ import annotations

import os
import signal
import threading
import time

import pandas as pd
import pytest
from helpers import CSC_TOML, REPO_ROOT

from jaxstiff.sweep import run_sweep

TOML = CSC_TOML.replace("n = 20", "n = 400")  # long enough to be killed mid-chunk


def _ray_task_pids() -> list[int]:
    """PIDs of processes whose command line (``/proc/PID/cmdline``, which Ray's process title
    rewrites) is a Ray worker running ``ray_task``."""
    pids = []
    for d in os.listdir("/proc"):
        if not d.isdigit():
            continue
        try:
            with open(f"/proc/{d}/cmdline", "rb") as f:
                cmd = f.read().replace(b"\0", b" ")
        except OSError:  # gone meanwhile
            continue
        if b"ray::ray_task" in cmd:
            pids.append(int(d))
    return pids


def _kill_first_worker(stop: threading.Event, killed: list[int]) -> None:
    while not stop.is_set() and not killed:
        pids = _ray_task_pids()
        if pids:
            time.sleep(0.3)  # inside the chunk (it compiles for seconds), not at its very start
            os.kill(pids[0], signal.SIGKILL)
            killed.append(pids[0])
            return
        time.sleep(0.05)


@pytest.mark.slow
@pytest.mark.filterwarnings("ignore:os.fork:RuntimeWarning")
def test_a_killed_worker_chunk_is_recomputed_and_the_table_is_unchanged(tmp_path, monkeypatch):
    ray = pytest.importorskip("ray")
    cfg = tmp_path / "lost.toml"
    cfg.write_text(TOML, encoding="utf-8")
    local = run_sweep(str(cfg), tmp_path / "local", progress=False, report=False)
    monkeypatch.setenv("RAY_AUTH_MODE", "disabled")  # a local test instance needs no token
    ray.init(
        num_cpus=2,
        include_dashboard=False,
        log_to_driver=False,
        runtime_env={"env_vars": {"PYTHONPATH": str(REPO_ROOT)}},
    )
    stop, killed = threading.Event(), []
    killer = threading.Thread(target=_kill_first_worker, args=(stop, killed), daemon=True)
    killer.start()
    try:
        res = run_sweep(str(cfg), tmp_path / "ray", backend="ray", progress=False, report=False)
    finally:
        stop.set()
        killer.join(timeout=5)
        ray.shutdown()
    assert killed, "no Ray worker was seen running a chunk: the fault was never injected"
    assert sorted(res.computed) == sorted(local.computed)
    pd.testing.assert_frame_equal(
        res.table().reset_index(drop=True), local.table().reset_index(drop=True), check_exact=True
    )
    assert not any(f.startswith(".tmp-") for f in os.listdir(tmp_path / "ray" / "arrays"))


def test_exhausted_retries_say_how_to_finish(monkeypatch, tmp_path, capsys):
    """When Ray gives up on a chunk, the command says so and names --resume (no traceback)."""
    import jaxstiff.sweep._run as run_mod
    from jaxstiff.cli import main
    from jaxstiff.sweep._backends import ChunkLostError

    def lost(*a, **k):
        raise ChunkLostError(
            "chunk 3: its Ray worker died 4 times (WorkerCrashedError); the chunks committed so far "
            "are kept: run the same command with --resume to finish"
        )

    cfg = tmp_path / "lost.toml"
    cfg.write_text(TOML, encoding="utf-8")
    monkeypatch.setattr(run_mod, "run_sweep", lost)
    import jaxstiff.sweep as sweep_pkg

    monkeypatch.setattr(sweep_pkg, "run_sweep", lost)
    assert main(["sweep", str(cfg), "--out", str(tmp_path / "o")]) == 1
    err = capsys.readouterr().err
    assert "jaxstiff: error: chunk 3" in err and "--resume" in err and "Traceback" not in err
