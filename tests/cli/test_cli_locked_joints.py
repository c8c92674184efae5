"""`jaxstiff shape --locked-joints`, `--lock`'s help, and the same choice through the API, the CLI and
a sweep (the same arrays, the same meta record; SPEC section 1, issue 21)."""

import numpy as np
import pytest

import jaxstiff
from jaxstiff.cli import main
from jaxstiff.sweep import run_sweep
from jaxstiff.sweep._config import SweepConfigError, parse_config

LOCK = {"lwr_a7": 0.0}


def _head(k=2):
    p = jaxstiff.default_path()
    return jaxstiff.Path(p.points[:k], p.directions[:k], name="head")


def test_help_says_locked_joints_are_rigid(capsys):
    with pytest.raises(SystemExit):
        main(["shape", "--help"])
    out = " ".join(capsys.readouterr().out.split())
    assert "--locked-joints {rigid,spring}" in out
    assert "it is rigid (no spring, no stiffness variable; '--locked-joints spring' keeps its spring)" in out


def test_bad_choice_and_kj0_length_are_refused(tmp_path, capsys):
    out = tmp_path / "x.npz"
    with pytest.raises(SystemExit) as e:
        main(["shape", "--locked-joints", "stiff", "--out", str(out)])
    assert e.value.code == 2 and not out.exists()
    capsys.readouterr()
    assert main(["shape", "--kj0", "1,2,3", "--out", str(out)]) == 2
    assert "--kj0 needs 1 or 7 values or 6 (one per free joint" in capsys.readouterr().err
    assert not out.exists()


def test_sweep_key_is_checked():
    base = {
        "sweep": {"kind": "shape", "name": "lk"},
        "robot": {"name": "kuka_lwr4", "locked": LOCK},
        "paths": [{"generator": "default", "n": 2}],
    }
    plan = parse_config({**base, "axes": {"locked_joints": ["rigid", "spring"]}})
    assert sorted({plan.row_settings(r)["locked_joints"] for r in range(2)}) == ["rigid", "spring"]
    assert parse_config(base).row_settings(0)["locked_joints"] == "rigid"  # the default
    with pytest.raises(SweepConfigError, match="locked_joints"):
        parse_config({**base, "axes": {"locked_joints": "stiff"}})


@pytest.mark.slow
def test_api_cli_and_sweep_give_the_same_choice(tmp_path):
    path = _head(2)
    csv = tmp_path / "p.csv"
    path.to_csv(csv)
    robot = jaxstiff.Robot.from_urdf("kuka_lwr4", locked=LOCK)
    sweep = run_sweep(
        {
            "sweep": {"kind": "shape", "name": "lk", "chunk_size": 2},
            "robot": {"name": "kuka_lwr4", "locked": LOCK},
            "paths": [{"file": str(csv)}],
            "axes": {"solver": "slsqp", "first_starts": 1, "locked_joints": ["rigid", "spring"]},
        },
        tmp_path / "sweep",
        progress=False,
    )
    df = sweep.table()
    for mode in ("rigid", "spring"):
        api = jaxstiff.shape(robot, path, "f2", 5.0, locked_joints=mode, first_starts=1)
        out = tmp_path / f"{mode}.npz"
        argv = ["shape", "--path", str(csv), "--locked-joints", mode, "--first-starts", "1", "--quiet"]
        assert main([*argv, "--out", str(out)]) == 0
        cli = jaxstiff.ShapeResult.load(out)
        row = df[df["locked_joints"] == mode].iloc[0]
        sw = jaxstiff.ShapeResult.load(tmp_path / "sweep" / row["result_file"])
        for res in (api, cli, sw):
            assert res.meta["settings"]["locked_joints"] == mode
            assert np.all(res.kj[..., 6] == np.inf) == (mode == "rigid")
        np.testing.assert_array_equal(cli.kj, api.kj)
        np.testing.assert_array_equal(cli.q, api.q)
        b = int(row["result_index"])
        np.testing.assert_allclose(sw.q[b], api.q[0], rtol=0, atol=1e-12)
        np.testing.assert_allclose(sw.kj[b], api.kj[0], rtol=0, atol=1e-9)
