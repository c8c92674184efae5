"""Numeric flags that scale work are bounded, and refused before the work (issue 42): csc
``--newton`` (1000 compiled for minutes), a sweep's row count (counted from the axis sizes before
any axis is expanded), check-sim's ``--force`` (inf was accepted) and MuJoCo's log file (a
``MUJOCO_LOG.TXT`` was left in the working folder by a force MuJoCo could not integrate)."""

from __future__ import annotations

import os

import numpy as np
import pytest

from jaxstiff.cli import main
from jaxstiff.settings._csc import MAX_NEWTON, CSCSettings


@pytest.mark.parametrize("newton", ["1000", str(MAX_NEWTON + 1), "-1"])
def test_csc_newton_is_bounded_before_any_work(tmp_path, capsys, newton) -> None:
    out = tmp_path / "c.npz"
    argv = ["csc", "--robot", "planar_3r", "--hold", "1,0", "--kxd", "1,1", "--q0", "0.3,0.3,0.3"]
    assert main([*argv, f"--newton={newton}", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert f"--newton must be an integer 0..{MAX_NEWTON}" in err and newton in err
    assert not out.exists()
    assert CSCSettings(newton=MAX_NEWTON).newton == MAX_NEWTON  # the bound itself is allowed


BIG = """
[sweep]
kind = "shape"
[robot]
name = "planar_3r"
[[paths]]
generator = "arc"
center = [[0.0, 0.0, 0.0], [0.1, 0.0, 0.0], [0.2, 0.0, 0.0]]
radius = [1.0]
start_deg = -20.0
end_deg = 20.0
n = 5
[axes]
task = "xy"
ratio = {start = 1.5, stop = 100.0, num = 4000000}
dq_deg = [1.0, 2.0]
"""


def test_sweep_rows_are_counted_before_the_axes_are_expanded(tmp_path, capsys, monkeypatch) -> None:
    import jaxstiff.sweep._axes as axes_mod
    import jaxstiff.sweep._schema as schema_mod

    def expanded(*a, **k):
        raise AssertionError("an axis was expanded before the row count was checked")

    monkeypatch.setattr(schema_mod, "range_values", expanded)
    monkeypatch.setattr(axes_mod, "range_values", expanded)
    cfg = tmp_path / "big.toml"
    cfg.write_text(BIG)
    assert main(["sweep", str(cfg), "--out", str(tmp_path / "o"), "--dry-run"]) == 2
    err = capsys.readouterr().err
    # 4,000,000 ratios x 2 dq x 3 paths = 24,000,000 rows (the product, computed independently here)
    assert f"would expand to {4_000_000 * 2 * 3} rows" in err and "ratio 4000000 x dq_deg 2 x 3 paths" in err
    assert not (tmp_path / "o").exists()


def test_sweep_step_range_is_counted_too(tmp_path, capsys) -> None:
    cfg = tmp_path / "big.toml"
    cfg.write_text(BIG.replace("{start = 1.5, stop = 100.0, num = 4000000}", "{start = 2.0, stop = 4e6, step = 0.5}"))
    assert main(["sweep", str(cfg), "--out", str(tmp_path / "o"), "--dry-run"]) == 2
    n = int(np.floor((4e6 - 2.0) / 0.5)) + 1
    assert f"would expand to {n * 2 * 3} rows" in capsys.readouterr().err


@pytest.mark.parametrize("force", ["inf", "nan", "0", "-5"])
def test_check_sim_force_must_be_finite_and_positive(tmp_path, capsys, force) -> None:
    pytest.importorskip("mujoco")
    assert main(["check-sim", str(tmp_path / "any.npz"), f"--force={force}"]) == 2
    assert "--force must be a positive finite number" in capsys.readouterr().err


def test_mujoco_leaves_no_log_file_and_a_warning_is_a_divergence(tmp_path, monkeypatch) -> None:
    pytest.importorskip("mujoco")
    import jaxstiff
    from jaxstiff.sim import SettleError, SimCase, check_case

    monkeypatch.chdir(tmp_path)
    robot = jaxstiff.Robot.from_urdf("planar_3r")
    case = SimCase(robot, np.deg2rad([75.0, -74.74, -76.30]), np.array([500.0, 300.0, 100.0]), "xy", "rigid", "x")
    with pytest.raises(SettleError, match="MuJoCo: Nan, Inf or huge value"):
        check_case(case, force=1e12)  # MuJoCo resets an unstable state: that must not pass for a settle
    assert os.listdir(tmp_path) == []  # no MUJOCO_LOG.TXT
    import mujoco

    assert getattr(mujoco, "get_mju_user_warning")() is None  # noqa: B009 - the handler is restored (untyped)
