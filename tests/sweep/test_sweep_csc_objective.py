"""A csc sweep's ``objective`` and ``locked_joints`` axes (issue 21): accepted as axes like the
other csc keys, defaults from CSCSettings, recorded in the chunk meta and the table, checked."""

from __future__ import annotations

import json
import os

import numpy as np
import pytest

from jaxstiff.settings import CSCSettings
from jaxstiff.sweep import run_sweep
from jaxstiff.sweep._config import AXES, SweepConfigError, parse_config


def _cfg(**axes) -> dict:
    return {
        "sweep": {"kind": "csc", "name": "csc-objective", "chunk_size": 4},
        "robot": {"name": "planar_4r", "locked": {"joint_4": 0.2}},
        "paths": [{"generator": "point", "point": [[1.2, 1.0, 0.0]], "n": 6}],
        "axes": {"task": "xy", "step": "constant", "beta": 0.002, **axes},
    }


def test_axes_defaults_come_from_the_settings():
    d = CSCSettings()
    assert AXES["csc"]["objective"].default == d.objective == "offdiag"
    assert AXES["csc"]["locked_joints"].default == d.locked_joints == "rigid"
    assert AXES["csc"]["objective"].static and AXES["csc"]["locked_joints"].static


def test_bad_values_name_the_key(tmp_path):
    with pytest.raises(SweepConfigError, match=r"axes\.objective"):
        parse_config(_cfg(objective="frob"), base_dir=tmp_path)
    with pytest.raises(SweepConfigError, match=r"axes\.locked_joints"):
        parse_config(_cfg(locked_joints=["rigid", "stiff"]), base_dir=tmp_path)


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    out = tmp_path_factory.mktemp("csc-objective") / "run"
    axes = {"objective": ["offdiag", "frobenius"], "locked_joints": ["rigid", "spring"]}
    return run_sweep(_cfg(**axes), out, progress=False, report=False)


def _rows(run) -> list[tuple]:
    out = []
    for row in run.table().itertuples():
        with np.load(os.path.join(run.out, row.result_file), allow_pickle=False) as z:
            st = json.loads(str(z["meta"]))["static"]
            out.append((row, st, z["kj"][row.result_index], z["u"][row.result_index]))
    return out


@pytest.mark.slow
def test_sweep_records_objective_and_locked_joints(run):
    df = run.table()
    want = sorted((o, lj) for o in ("offdiag", "frobenius") for lj in ("rigid", "spring"))
    assert sorted(zip(df["objective"], df["locked_joints"], strict=True)) == want
    assert sorted((st["objective"], st["locked_joints"]) for _, st, _, _ in _rows(run)) == want
    for row, st, _, _ in _rows(run):
        assert (st["objective"], st["locked_joints"]) == (row.objective, row.locked_joints)


@pytest.mark.slow
def test_sweep_rollouts_use_locked_joints(run):
    for row, _, kj, _ in _rows(run):
        # the locked joint 4: no spring when rigid (kj +inf, infinite stiffness), its clipped spring otherwise
        assert np.all(np.isposinf(kj[:, 3])) if row.locked_joints == "rigid" else np.all(kj[:, 3] > 0.0)


@pytest.mark.slow
def test_sweep_rollouts_use_objective(tmp_path):
    """The objective reaches the rollouts: on the unlocked planar 4R (task xy: a 2-D null space) the
    offdiag and frobenius rows move differently, and each row equals the API's rollout with the
    same objective (an independent call). With joint 4 locked the null space is 1-D, and a constant
    null step of length beta moves the same way for both objectives whenever their projected
    gradients agree in sign: equal rows there are not a bug (the old xfail of this test)."""
    import jaxstiff

    cfg = _cfg(objective=["offdiag", "frobenius"])
    cfg["robot"] = {"name": "planar_4r", "locked": {}}
    run = run_sweep(cfg, tmp_path / "run", progress=False, report=False)
    robot = jaxstiff.Robot.from_urdf("planar_4r", locked={})
    q_by = {}
    for row in run.table().itertuples():
        with np.load(os.path.join(run.out, row.result_file), allow_pickle=False) as z:
            i = row.result_index
            q, K_xd, q0 = z["q"][i], z["K_xd"][i], z["q0"][i]
        ref = jaxstiff.csc_rollout(
            robot, np.tile([1.2, 1.0], (6, 1)), K_xd, q0, 0.002, task="xy", step="constant", objective=row.objective
        )
        np.testing.assert_allclose(q, np.asarray(ref.q), atol=1e-5)
        q_by[row.objective] = q
    assert np.abs(q_by["offdiag"] - q_by["frobenius"]).max() > 1e-4
