"""`jaxstiff csc --objective` and `--locked-joints` (issue 21): accepted, used and recorded in meta."""

from __future__ import annotations

import json

import numpy as np
import pytest

import jaxstiff
from jaxstiff.cli import main as cli_main

LWR = jaxstiff.Robot.from_urdf("kuka_lwr4", locked={"lwr_a7": 0.0})
Q_DEG = "20,40,-30,-70,25,50,0"


def _run(tmp_path, *flags: str) -> tuple[int, dict, dict]:
    q = np.deg2rad([float(v) for v in Q_DEG.split(",")])
    hold = ",".join(repr(float(v)) for v in np.asarray(LWR.fk(q))[:3, 3])
    out = tmp_path / f"r{len(list(tmp_path.iterdir()))}.npz"
    base = ["csc", "--robot", "kuka_lwr4", "--hold", hold, "--kxd", "3000,1000,2000@30", "--steps", "3"]
    rc = cli_main(base + ["--q0-deg", Q_DEG, "--step", "constant", "--beta", "1e-3", *flags, "--out", str(out)])
    if rc != 0:
        return rc, {}, {}
    with np.load(out) as f:
        return rc, json.loads(str(f["meta"])), {k: f[k] for k in f.files if k != "meta"}


@pytest.mark.slow
def test_cli_objective_and_locked_joints(tmp_path, capsys):
    rc, meta, arrays = _run(tmp_path)
    assert rc == 0 and meta["settings"]["objective"] == "offdiag" and meta["settings"]["locked_joints"] == "rigid"
    assert np.all(np.isposinf(arrays["kj"][..., 6]))  # lwr_a7 locked by default, rigid: no spring (kj +inf)
    assert "objective offdiag" in capsys.readouterr().out
    rc, meta, arrays = _run(tmp_path, "--objective", "frobenius", "--locked-joints", "spring")
    assert rc == 0 and meta["settings"]["objective"] == "frobenius" and meta["settings"]["locked_joints"] == "spring"
    assert np.all(arrays["kj"][..., 6] > 0.0)
    out = capsys.readouterr().out
    assert "objective frobenius" in out and "lwr_a7: spring" in out


@pytest.mark.parametrize("flag,value", [("--objective", "frob"), ("--locked-joints", "stiff")])
def test_cli_bad_choice_is_a_usage_error(tmp_path, capsys, flag, value):
    argv = "csc --robot planar_3r --hold 1,1 --kxd 3000,1000 --q0 0.1,0.2,0.3".split()
    with pytest.raises(SystemExit) as e:
        cli_main(argv + [flag, value, "--out", str(tmp_path / "x.npz")])
    assert e.value.code == 2 and flag in capsys.readouterr().err and not (tmp_path / "x.npz").exists()


@pytest.mark.parametrize(
    "settings,expected",
    [
        ({"beta": -1.0}, "--beta must be a finite number >= 0, got -1.0 (1 (adaptive) or rad per step"),
        ({"kmin": 10.0, "kmax": 5.0}, "--kmax (5) must be above --kmin (10) (Nm/rad)"),
        ({"damping": -1.0}, "--damping must be a finite number >= 0, got -1.0"),
        ({"kmin": -3.0}, "--kmin must be a finite number > 0, got -3.0 (Nm/rad)"),
    ],
)
def test_csc_settings_errors_read_as_flags(settings, expected):
    """A settings error in `jaxstiff csc` names the flag, keeps values where they are and moves the
    unit to the end; it read '--beta or rad per step (constant; ...)) must be ... (1 (adaptive)' and
    '--kmax must be >= --kmin (Nm/rad) (5)' when units held parentheses or values looked like units;
    dimensionless fields ('1') show no unit."""
    from jaxstiff.cli._csc_flags import flag_message
    from jaxstiff.settings import CSCSettings

    with pytest.raises(ValueError) as e:
        CSCSettings(**settings)
    msg = flag_message(str(e.value))
    assert msg.startswith(expected), msg
    assert "csc." not in msg and not msg.endswith("(1)"), msg
