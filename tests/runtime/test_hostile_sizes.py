"""Plans that cannot fit are refused before any work, with the estimate, the limit and the knob
(issue 24, finding 3): path generators, `jaxstiff csc --steps`, sweep paths (also --dry-run),
sweep chunks, shape; what is streamed (csc segments, sweep chunks) is estimated per piece."""

from __future__ import annotations

import copy
import re

import numpy as np
import pytest

from jaxstiff import paths as P
from jaxstiff.cli import main
from jaxstiff.runtime._plan_size import (
    MEMORY_LIMIT_ENV,
    PlanTooLargeError,
    available_memory_bytes,
    check_plan_size,
    format_bytes,
)
from jaxstiff.sweep._config import SweepConfigError, parse_config

HUGE = 10**12  # the audit's count: 14.6 TiB and more


def _meminfo_available() -> float:
    with open("/proc/meminfo", encoding="ascii") as fh:
        for line in fh:
            if line.startswith("MemAvailable:"):
                return float(line.split()[1]) * 1024
    raise AssertionError("no MemAvailable")


def test_check_plan_size_message_and_limit(monkeypatch):
    monkeypatch.delenv(MEMORY_LIMIT_ENV, raising=False)
    with pytest.raises(PlanTooLargeError) as e:
        check_plan_size("things: n = 1000 items", 1000, 10, "--n", limit_bytes=9_999)
    msg = str(e.value)
    assert "10 kB of memory (10 B each); 10 kB is available" in msg  # (9999 B shows as 10 kB)
    assert "lower --n" in msg and msg.startswith("things: n = 1000 items need about 10 kB")
    assert (e.value.estimate_bytes, e.value.limit_bytes, e.value.key_or_flag) == (10_000.0, 9_999.0, "--n")
    assert check_plan_size("ok", 1000, 10, "--n", limit_bytes=10_000) == 10_000.0  # at the limit: accepted
    assert isinstance(e.value, ValueError)  # the command line's exit 2
    # the default limit is the kernel's MemAvailable (within what moved meanwhile)
    assert abs(available_memory_bytes() - _meminfo_available()) < 0.2 * _meminfo_available()
    monkeypatch.setenv(MEMORY_LIMIT_ENV, "2k")
    assert available_memory_bytes() == 2000.0
    with pytest.raises(PlanTooLargeError, match=f"2 kB is the limit set by {MEMORY_LIMIT_ENV}"):
        check_plan_size("x", 3, 1000, "k")
    monkeypatch.setenv(MEMORY_LIMIT_ENV, "lots")
    with pytest.raises(ValueError, match=MEMORY_LIMIT_ENV):
        available_memory_bytes()


def test_format_bytes():
    assert [format_bytes(x) for x in (512, 1.5e3, 14.6e12, 2e15)] == ["512 B", "1.5 kB", "14.6 TB", "2 PB"]


@pytest.mark.parametrize(
    "make",
    [
        lambda n: P.line([0, 0, 0], [1, 0, 0], n),
        lambda n: P.arc([0, 0, 0], 1.0, 0, 90, n),
        lambda n: P.circle([0, 0, 0], 1.0, n),
        lambda n: P.half_sine([0, 0, 0], [1, 0, 0], 0.1, n),
        lambda n: P.spline([[0, 0, 0], [1, 0, 0], [1, 1, 0]], n),
        lambda n: P.ellipse_arc([0, 0, 0], 1.0, 0.5, 0, 90, n),
        lambda n: P.default_path(n),
    ],
)
def test_generators_refuse_sizes_that_cannot_fit(make):
    with pytest.raises(PlanTooLargeError, match=r"n = 1000000000000 waypoints need about .* [TP]B of memory.*lower n"):
        make(HUGE)
    assert make(5).P == 5  # (a small n still works)


def test_ellipse_arc_counts_its_fine_grid(monkeypatch):
    # 4096 grid steps per waypoint: 1000 waypoints need ~200 MB, more than a 100 MB limit
    monkeypatch.setenv(MEMORY_LIMIT_ENV, "100M")
    with pytest.raises(PlanTooLargeError, match="ellipse_arc: n = 1000 waypoints"):
        P.ellipse_arc([0, 0, 0], 1.0, 0.5, 0, 90, 1000)
    assert P.line([0, 0, 0], [1, 0, 0], 1000).P == 1000  # 160 kB


def _sweep(n) -> dict:
    return {
        "sweep": {"kind": "shape", "name": "t", "chunk_size": 3},
        "robot": {"name": "planar_3r"},
        "paths": [{"generator": "line", "start": [1.0, 0.5, 0.0], "end": [1.2, 0.5, 0.0], "n": n}],
        "axes": {"task": "xy", "ratio": [2.0, 3.0]},
    }


@pytest.mark.parametrize("n", [HUGE, [3, HUGE], {"start": 5_000_000, "stop": 5_000_199, "step": 1}])
def test_sweep_paths_refused_with_key(n, monkeypatch):
    if isinstance(n, dict):  # 200 paths of 5e6 waypoints: each one fits, all together not
        monkeypatch.setenv(MEMORY_LIMIT_ENV, "100G")
    with pytest.raises(SweepConfigError) as e:
        parse_config(_sweep(n))
    assert e.value.key == "paths[0].n"
    assert re.search(r"need about [\d.]+ [GTP]B of memory .* lower paths\[0\]\.n", str(e.value))


def test_sweep_point_generator_refused():
    cfg = _sweep(3)
    cfg["paths"] = [{"generator": "point", "point": [1.2, 1.0, 0.0], "n": HUGE}]
    with pytest.raises(SweepConfigError, match=r"paths\[0\]\.n: .*need about"):
        parse_config(cfg)


def test_sweep_chunks_are_streamed_not_refused(monkeypatch):
    """8 rows x 3 waypoints do not fit in 4 kB, one chunk of 3 rows does: accepted; a chunk over
    the limit is refused naming sweep.chunk_size."""
    cfg = _sweep(3)
    cfg["axes"]["ratio"] = [2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0]
    monkeypatch.setenv(MEMORY_LIMIT_ENV, "4k")
    plan = parse_config(cfg)
    assert plan.n_rows == 8 and len(plan.chunks) == 3
    big = copy.deepcopy(cfg)
    big["sweep"]["chunk_size"] = 8
    with pytest.raises(SweepConfigError) as e:
        parse_config(big)
    assert e.value.key == "sweep.chunk_size" and "lower sweep.chunk_size" in str(e.value)


def test_cli_sweep_dry_run_refuses_cleanly(tmp_path, capsys):
    cfg = tmp_path / "s.toml"
    cfg.write_text(
        '[sweep]\nkind = "shape"\n[robot]\nname = "planar_3r"\n[[paths]]\ngenerator = "line"\n'
        f'start = [1.0, 0.5, 0.0]\nend = [1.2, 0.5, 0.0]\nn = {HUGE}\n[axes]\ntask = "xy"\nratio = [2.0]\n'
    )
    for extra in (["--dry-run"], []):
        assert main(["sweep", str(cfg), "--out", str(tmp_path / "o"), *extra]) == 2
        err = capsys.readouterr().err
        assert "paths[0].n" in err and "need about" in err and "Traceback" not in err and "MemoryError" not in err


CSC = ["csc", "--robot", "planar_3r", "--kxd", "3000,1000@30", "--q0-deg", "75,-74.74,-76.30"]


def test_cli_csc_steps_refused_before_work(tmp_path, capsys):
    out = tmp_path / "h.npz"
    rc = main(
        [*CSC, "--hold", "1.5,0", "--step", "constant", "--beta", "2e-3", "--steps", str(HUGE), "--out", str(out)]
    )
    err = capsys.readouterr().err
    assert rc == 2 and not out.exists()
    assert re.search(r"1 rollout\(s\) x 1000000000000 steps .* need about [\d.]+ [TP]B of memory.*lower --steps", err)


def test_cli_csc_streamed_steps_are_not_refused(monkeypatch):
    """More steps than one segment holds are fine when the result fits: the estimate is the
    result rows (which the file holds whole), not the work, which goes in segments."""
    from jaxstiff.cli._common import check_rollout_size, rollout_row_bytes
    from jaxstiff.cli._csc import SEGMENT_WORK

    assert rollout_row_bytes(3, "xy") == 2 * 8 * (6 + 4 + 3 + 2 + 7) + 16  # independent count of the arrays
    monkeypatch.setenv(MEMORY_LIMIT_ENV, str(4 * SEGMENT_WORK * rollout_row_bytes(3, "xy")))
    check_rollout_size(1, 3 * SEGMENT_WORK, 3, "xy", "--steps")  # 3 segments: accepted
    with pytest.raises(PlanTooLargeError, match="lower --steps"):
        check_rollout_size(1, 5 * SEGMENT_WORK, 3, "xy", "--steps")


def test_shape_refuses_a_plan_that_cannot_fit(monkeypatch):
    from jaxstiff import shape
    from jaxstiff.model import Robot

    robot = Robot.from_urdf("planar_3r")
    path = P.Path(np.c_[np.linspace(1.0, 1.2, 50), np.full(50, 0.5), np.zeros(50)])
    monkeypatch.setenv(MEMORY_LIMIT_ENV, "10k")  # 50 waypoints x (about 1 kB) do not fit
    with pytest.raises(PlanTooLargeError, match=r"shape: 1 path\(s\) x 50 waypoints \(3 joints"):
        shape(robot, path, task="xy")


def test_shape_names_the_starts_when_they_make_the_plan_too_large(tmp_path, capsys, monkeypatch):
    """`--starts 10000000` was refused with "lower the number of waypoints (--path rows) or paths":
    the flag that made it too large was not named. And `--solver slsqp --starts 10^8` got that
    memory message before its own "single-start" one."""
    monkeypatch.setenv(MEMORY_LIMIT_ENV, "1M")
    out = str(tmp_path / "o.npz")
    for argv, knob in (
        (["--solver", "pgd", "--starts", "100000"], "lower starts (--starts), or the number of waypoints"),
        (["--first-starts", "100000"], "lower first_starts (--first-starts), or the number of waypoints"),
        (["--solver", "slsqp", "--starts", "100000"], "solver 'slsqp' is single-start (starts=1); got starts=100000"),
    ):
        assert main(["shape", "--quiet", "--out", out, *argv]) == 2
        assert knob in capsys.readouterr().err
