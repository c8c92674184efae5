"""The one result-file reader at its full level on what issue 42 left: the recorded rate limits
re-checked (a file whose q or kj steps further between waypoints than its meta's dq / dk is
refused, naming the path, waypoint and joint), and a real sweep row read through it (the array
file, its robot and FK, the row against the file), a tampered one refused."""

from __future__ import annotations

import json
import os
import shutil

import numpy as np
import pytest
from helpers import planar_arc_sweep, tamper_result

import jaxstiff
from jaxstiff.results._reader import ResultFileError, read_result
from jaxstiff.sweep import run_sweep
from jaxstiff.sweep._stored import read_sweep_row

Q_START = [0.3, 0.5, -0.2, -1.2, 0.4, 0.6, 0.0]  # the LWR, lwr_a7 locked at 0


@pytest.fixture(scope="module")
def lwr_file(tmp_path_factory) -> str:
    """A real shape result of the shipped LWR: 4 waypoints along 6 cm, dq = 0.2 rad per waypoint."""
    robot = jaxstiff.Robot.from_urdf("kuka_lwr4", locked={"lwr_a7": 0.0})
    q = np.asarray(Q_START)
    p = np.asarray(jaxstiff.fk(robot, q))[:3, 3]
    pts = p + np.c_[np.linspace(0.0, 0.06, 4), np.zeros(4), np.zeros(4)]
    res = jaxstiff.shape(robot, jaxstiff.Path(pts), "f2", 3.0, task="xyz", solver="slsqp", q0=q, dq=0.2)
    assert (res.status == 0).all()
    return res.save(str(tmp_path_factory.mktemp("rates") / "lwr.npz"))


def test_real_file_keeps_its_rate_limits_and_is_read(lwr_file) -> None:
    rf = read_result(lwr_file)
    q, kj = rf.arrays["q"][0], rf.arrays["kj"][0]
    kj = kj[:, np.isfinite(kj).all(axis=0)]  # (the rigid locked joint, kj = +inf, has no stiffness step)
    lim = rf.meta["limits"]
    # independent of the reader: the steps between waypoints, in numpy
    assert np.abs(np.diff(q, axis=0)).max() <= np.max(lim["dq"]) + 1e-9
    assert np.abs(np.diff(kj, axis=0)).max() <= np.max(lim["dk"]) + 1e-9


def test_q_jumping_more_than_dq_is_refused(lwr_file, tmp_path) -> None:
    with np.load(lwr_file) as z:
        q = z["q"][0]
    steps = np.abs(np.diff(q, axis=0))  # (P - 1, n)
    p, j = np.unravel_index(int(np.argmax(steps)), steps.shape)
    tight = float(steps[p, j]) / 2  # the file claims a limit its q does not keep (by the largest step)
    others = np.abs(np.diff(q, axis=0))
    assert (others > tight).any()

    def claim(m):
        m["limits"]["dq"] = tight

    f = tamper_result(lwr_file, str(tmp_path / "jump.npz"), meta=claim)
    with pytest.raises(ResultFileError) as exc:
        read_result(f)
    msg = str(exc.value)
    first = np.argwhere(others > tight)[0]  # the first step over the claimed limit, in waypoint order
    robot_joints = read_result(lwr_file).chain.joint_names
    assert msg.startswith(f"{f}: q: path 0, waypoint {first[0] + 1}, joint {robot_joints[first[1]]}:"), msg
    assert "limits.dq" in msg and "\n" not in msg


def test_kj_stepping_more_than_dk_and_the_first_waypoint(lwr_file, tmp_path) -> None:
    with np.load(lwr_file) as z:
        kj, q, q0 = z["kj"][0], z["q"][0], z["q0"][0]
    dk = np.abs(np.diff(kj[:, :6], axis=0)).max()  # (the free joints; lwr_a7 is rigid, kj = +inf)

    def claim(m):
        m["limits"]["dk"] = [float(dk / 3)] * kj.shape[-1]  # (n values)

    f = tamper_result(lwr_file, str(tmp_path / "dk.npz"), meta=claim)
    with pytest.raises(ResultFileError, match=r": kj: path 0, waypoint \d, joint lwr_a\d: .*limits\.dk"):
        read_result(f)

    # first_rate_limit claimed: waypoint 0 is then held to dq from q0 (here it moved further)
    step0 = np.abs(q[0] - q0).max()
    if step0 > 0:

        def first(m):
            m["limits"]["first_rate_limit"] = True
            m["limits"]["dq"] = float(step0 / 2)

        with np.load(lwr_file) as z:
            steps = np.abs(np.diff(z["q"][0], axis=0)).max()
        if steps <= step0 / 2:  # only waypoint 0 breaks the claimed limit
            f = tamper_result(lwr_file, str(tmp_path / "first.npz"), meta=first)
            with pytest.raises(ResultFileError, match=r"waypoint 0, .* from the start state \(q0\)"):
                read_result(f)


def test_a_within_tolerance_step_is_accepted(lwr_file, tmp_path) -> None:
    with np.load(lwr_file) as z:
        steps = np.abs(np.diff(z["q"][0], axis=0))

    def exact(m):  # the limit the file's largest step just meets
        m["limits"]["dq"] = float(steps.max())

    read_result(tamper_result(lwr_file, str(tmp_path / "exact.npz"), meta=exact))


# ---------------------------------------------------------------------- a real sweep row
SWEEP = planar_arc_sweep("reader-row", {"task": "xy", "criterion": "f2", "ratio": [2.0, 3.0], "first_starts": 2})


@pytest.fixture(scope="module")
def sweep_folder(tmp_path_factory) -> str:
    out = str(tmp_path_factory.mktemp("reader-sweep") / "run")
    run_sweep(SWEEP, out, progress=False, report=False, compile_cache=False)
    return out


def test_real_sweep_row_read_through_the_reader(sweep_folder) -> None:
    rows = json.load(open(os.path.join(sweep_folder, "chunks", "chunk-000000.json")))["rows"]
    for row in rows:
        rf, i = read_sweep_row(sweep_folder, row["row_id"])
        assert rf.file == os.path.join(sweep_folder, row["result_file"]) and i == row["result_index"]
        # the stored positions are the FK of the stored q: independent JAX FK of the shipped arm
        robot = jaxstiff.Robot.from_urdf("planar_3r")
        pos = np.asarray(jaxstiff.fk(robot, rf.arrays["q"][i]))[..., :3, 3]
        np.testing.assert_allclose(pos, rf.arrays["position"][i], atol=1e-9)
        assert rf.task == "xy" and rf.meta["sweep"]["row_ids"][i] == row["row_id"]
        assert (
            float(rf.meta["ratio"] if not isinstance(rf.meta["ratio"], list) else rf.meta["ratio"][i]) == row["ratio"]
        )


def _copy(folder: str, tmp_path) -> str:
    dst = str(tmp_path / "copy")
    shutil.copytree(folder, dst)
    return dst


def test_tampered_sweep_rows_are_refused(sweep_folder, tmp_path) -> None:
    # the array file claims another URDF hash
    d = _copy(sweep_folder, tmp_path)
    arr = os.path.join(d, "arrays", "chunk-000000-0.npz")
    tamper_result(arr, arr, meta=lambda m: m["robot"].__setitem__("sha256", "0" * 64))
    with pytest.raises(ValueError, match=r"sha256 differs") as e:
        read_sweep_row(d, 0)
    # the way back is named (a tester locked out by an edited URDF found no hint)
    assert "Restore the file the result was computed with (or give it with --urdf FILE" in str(e.value)
    shutil.rmtree(d)

    # q of the row's path moved: the FK of the stored q is not the stored position
    d = _copy(sweep_folder, tmp_path)
    arr = os.path.join(d, "arrays", "chunk-000000-0.npz")
    tamper_result(arr, arr, arrays=lambda a: a.__setitem__("q", a["q"] + np.r_[0.0, 0.01, 0.0]))
    with pytest.raises(ResultFileError, match=r"chunk-000000-0\.npz: position: .*FK of the stored q"):
        read_sweep_row(d, 0)
    shutil.rmtree(d)

    # the rows file reports another share of waypoints in target than its arrays give
    d = _copy(sweep_folder, tmp_path)
    rows_file = os.path.join(d, "chunks", "chunk-000000.json")
    rec = json.load(open(rows_file))
    rec["rows"][0]["share_both"] = 1.0 - rec["rows"][0]["share_both"] if rec["rows"][0]["share_both"] != 0.5 else 0.0
    json.dump(rec, open(rows_file, "w"))
    with pytest.raises(ResultFileError, match=r"chunk-000000\.json: row 0 share_both: expected .*recomputed from"):
        read_sweep_row(d, 0)
    # ... and resuming the sweep refuses it the same way, naming the file to delete
    with pytest.raises(ValueError, match=r"share_both.*delete .*chunk-000000\.json to recompute chunk 0"):
        run_sweep(SWEEP, d, resume=True, progress=False, report=False, compile_cache=False)
