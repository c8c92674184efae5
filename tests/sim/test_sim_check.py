"""MuJoCo against jaxstiff: small-load stiffness, the CCT term and its sign, locked-joint modes, the CLI.

Independent reference: MuJoCo's own kinematics, joint springs and wrench mapping (jaxstiff.sim
builds the bodies from the parsed chain and reads back only MuJoCo's settled TCP pose).
"""

import json
import os

import numpy as np
import pytest
from helpers import planar_arc_sweep

pytest.importorskip("mujoco", reason='the physics check needs MuJoCo: pip install "jaxstiff[sim]"')

import jaxstiff  # noqa: E402
from jaxstiff.results import ShapeResult  # noqa: E402
from jaxstiff.settings._robot import robot_meta  # noqa: E402
from jaxstiff.sim import SimCase, check_case  # noqa: E402

DATA = os.path.join(os.path.dirname(os.path.dirname(__file__)), "data")
TIGHT = 1e-6  # what the check reaches (docs/notes/sim.md); the CLI's bar is 1e-3


def _assert_agrees(row, cct=True):
    assert row.passed, row
    assert max(row.err_K, row.err_C, row.err_dir) < TIGHT
    if cct:
        assert row.cct_err < TIGHT and row.cct_eq_residual < TIGHT
        # the finite load matters: without the term, or with the seeds' printed sign, the check fails
        assert row.cct_err_none > 5 * row.tol and row.cct_err_wrong > 10 * row.tol


@pytest.mark.slow
def test_planar_3r_seed_posture_and_wrong_cct_sign_fails():
    robot = jaxstiff.Robot.from_urdf("planar_3r")
    q = np.deg2rad([75.0, -74.74, -76.30])  # seed 000, Fig. 2-3
    case = SimCase(robot, q, np.array([500.0, 300.0, 100.0]), "xy", "rigid", "fig2")
    _assert_agrees(check_case(case))
    wrong = check_case(case, cct_sign=-1.0)
    assert not wrong.passed and not wrong.cct_ok and wrong.stiffness_ok
    assert wrong.cct_err > 10 * wrong.tol


@pytest.mark.slow
@pytest.mark.parametrize("task", ["xyz", "full"])
def test_lwr_rigid_and_spring_locked_joint(task):
    robot = jaxstiff.Robot.from_urdf("kuka_lwr4", locked={"lwr_a7": 0.0})
    q = np.array([0.3, 0.5, -0.2, 1.0, 0.4, -0.6, 0.0])
    kj = np.array([80.0, 60.0, 40.0, 30.0, 20.0, 10.0, 5.0])
    rows = {mode: check_case(SimCase(robot, q, kj, task, mode)) for mode in ("rigid", "spring")}
    for row in rows.values():
        _assert_agrees(row)
    diff = np.linalg.norm(rows["spring"].K_meas - rows["rigid"].K_meas, 2) / np.linalg.norm(rows["rigid"].K_meas, 2)
    if task == "full":  # lwr_a7 turns the flange about its own axis: only the held orientation feels its spring
        assert diff > 1e-2
    else:
        assert diff < TIGHT


@pytest.mark.slow
@pytest.mark.parametrize("mode", ["rigid", "spring"])
def test_third_party_tree_with_tip_link_lock_and_rotated_tcp(mode):
    """tests/data/branched_tree.urdf: rpy origins, a tilted axis, a prismatic and a continuous joint,
    an ambiguous tip (tip_link given), j3 locked, a tool offset with rotation."""
    robot = jaxstiff.Robot.from_urdf(
        os.path.join(DATA, "branched_tree.urdf"), tip_link="tool", locked={"j3": 0.4},
        tcp=[0.05, -0.02, 0.1],
    )  # fmt: skip
    q = np.array([0.3, 0.2, 0.4, -0.5])
    kj = np.array([40.0, 900.0, 25.0, 15.0])  # N/m for the prismatic j2
    row = check_case(SimCase(robot, q, kj, "xyz", mode))
    _assert_agrees(row)


def _result_file(path, robot, q, kj, task, locked_joints):
    """A result file as the readers accept it: positions the FK of q, the axis ratio that of (q, kj)
    with the task, rate limits its steps keep (jaxstiff.results._reader checks all three),
    placeholders elsewhere."""
    from jaxstiff.results._numpy_check import np_alpha_ratio, np_fk_position, np_translational_stiffness

    B, P, n = q.shape
    zeros = np.zeros((B, P))
    meta = {
        "robot": robot_meta(robot), "task": task, "settings": {"task": task}, "criterion": "f2", "ratio": 3.0,
        "cms": {"target_volume": 1e6, "target_major": None},
        "limits": {"kmin": 1.0, "kmax": 1000.0, "dq": 4.0, "dk": 1000.0, "first_rate_limit": False},
    }  # fmt: skip
    if locked_joints is not None:
        meta["settings"]["locked_joints"] = locked_joints
    position = np.stack([np_fk_position(robot, q[b]) for b in range(B)])
    direction = np.zeros((B, P, 3)) + [1.0, 0.0, 0.0]
    K = np.stack([[np_translational_stiffness(robot, q[b, p], kj[b, p], task) for p in range(P)] for b in range(B)])
    alpha, ratio = np_alpha_ratio(K, direction)
    res = ShapeResult(
        joint_names=np.array(robot.joint_names), q=q, kj=kj, cms=zeros + 1, kj_scaled=kj, target=position,
        direction=direction, position=position, pos_error=zeros, alpha_deg=alpha, ratio=ratio,
        criterion=zeros, status=zeros.astype(int), q0=q[:, 0], kj0=kj[:, 0], solver_code=zeros.astype(int),
        nit=zeros.astype(int), nfev=zeros.astype(int), time_s=zeros, meta=meta,
    )  # fmt: skip
    return res.save(path)


def test_cli_check_sim_table_json_and_errors(tmp_path, capsys):
    from jaxstiff.cli import main

    robot = jaxstiff.Robot.from_urdf("planar_3r")
    q = np.deg2rad([[[75.0, -74.74, -76.30], [60.0, -50.0, -60.0], [40.0, 30.0, -90.0]]])
    kj = np.array([[[500.0, 300.0, 100.0], [50.0, 30.0, 10.0], [5.0, 80.0, 20.0]]])
    f = _result_file(tmp_path / "r.npz", robot, q, kj, "xy", None)
    out = tmp_path / "check.json"
    assert main(["check-sim", f, "--waypoints", "0,2", "--json", str(out)]) == 0
    text = capsys.readouterr().out
    assert "| planar_3r | b0 p0 | xy | spring |" in text and "b0 p1" not in text and "2/2 waypoints agree" in text
    data = json.loads(out.read_text())
    assert data["passed"] and [r["label"] for r in data["rows"]] == ["b0 p0", "b0 p2"]
    assert data["worst"]["err_K"] < TIGHT and data["worst"]["cct_err_wrong_min"] > 1e-2
    # an impossible tolerance: the check reports the misses and exits 1
    assert main(["check-sim", f, "--waypoints", "1", "--no-cct", "--tol", "1e-15"]) == 1
    assert "miss the tolerance" in capsys.readouterr().out
    # input errors: exit 2 with one line naming the problem
    assert main(["check-sim", str(tmp_path / "nope.npz")]) == 2
    assert "result file not found" in capsys.readouterr().err
    (tmp_path / "t.csv").write_text("x,y,z\n1,2,3\n")
    assert main(["check-sim", str(tmp_path / "t.csv")]) == 2
    assert main(["check-sim", f, "--waypoints", "1.5"]) == 2
    assert "--waypoints" in capsys.readouterr().err


@pytest.mark.slow
def test_cli_on_a_real_shape_result_with_rigid_lock_recorded(tmp_path):
    """`jaxstiff shape` output for the LWR (task full, lwr_a7 locked) checked end to end; the
    locked-joint mode read from meta decides the MuJoCo model and the prediction alike."""
    from jaxstiff.cli import main

    f = str(tmp_path / "shape.npz")
    robot = jaxstiff.Robot.from_urdf("kuka_lwr4", locked={"lwr_a7": 0.0})
    res = jaxstiff.shape(robot, jaxstiff.default_path(n=3), "f2", 3.0, task="full")
    res.save(f)
    assert main(["check-sim", f, "--waypoints", "2"]) == 0
    # the same postures recorded as rigid-lock: lwr_a7's spring (kj ~ 50 Nm/rad) leaves the model
    rigid = _result_file(tmp_path / "rigid.npz", robot, res.q, res.kj, "full", "rigid")
    assert main(["check-sim", rigid, "--waypoints", "2", "--json", str(tmp_path / "j.json")]) == 0
    data = json.loads((tmp_path / "j.json").read_text())
    assert {r["locked_joints"] for r in data["rows"]} == {"rigid"}


@pytest.mark.parametrize("task", ["xyz", "full"])
def test_both_modes_measured_whatever_the_task(task):
    """Issue 40: check-sim measures the stiffness a force meets with the tool free to turn and with its
    orientation held, for either task; both against an independent numpy computation (Jacobian from
    finite differences of a numpy FK, plain inverses), not only against jaxstiff's prediction."""
    from helpers import numpy_held_and_free, numpy_jacobian

    robot = jaxstiff.Robot.from_urdf("kuka_lwr4", locked={"lwr_a7": 0.0})
    q = np.array([0.3, 0.5, -0.2, 1.0, 0.4, -0.6, 0.0])
    kj = np.array([80.0, 60.0, 40.0, 30.0, 20.0, 10.0, np.inf])
    row = check_case(SimCase(robot, q, kj, task, "rigid"), cct=False)
    assert row.passed and row.err_free < TIGHT and row.err_held < TIGHT
    held_n, free_n = numpy_held_and_free(numpy_jacobian(robot, q), kj)
    assert np.linalg.norm(row.K_free_meas - free_n, 2) < 1e-5 * np.linalg.norm(free_n, 2)
    assert np.linalg.norm(row.K_held_meas - held_n, 2) < 1e-5 * np.linalg.norm(held_n, 2)
    # the task's own K_T is one of the two
    assert np.allclose(row.K_meas, row.K_held_meas if task == "full" else row.K_free_meas, rtol=1e-12)
    # free is softer: the two differ by far more than the measurement error
    assert np.linalg.norm(row.K_held_meas - row.K_free_meas, 2) > 1e-2 * np.linalg.norm(held_n, 2)


def test_cli_prints_held_and_free(tmp_path, capsys):
    from jaxstiff.cli import main

    robot = jaxstiff.Robot.from_urdf("kuka_lwr4", locked={"lwr_a7": 0.0})
    q = np.array([[[0.3, 0.5, -0.2, 1.0, 0.4, -0.6, 0.0]]])
    kj = np.array([[[80.0, 60.0, 40.0, 30.0, 20.0, 10.0, np.inf]]])
    f = _result_file(tmp_path / "r.npz", robot, q, kj, "xyz", "rigid")
    out = tmp_path / "check.json"
    assert main(["check-sim", f, "--waypoints", "1", "--no-cct", "--json", str(out)]) == 0
    text = capsys.readouterr().out
    assert "held eig. measured (N/m)" in text and "free eig. measured (N/m)" in text
    assert "tool's orientation held" in text and "free to turn" in text
    row = json.loads(out.read_text())["rows"][0]
    assert row["err_held"] < TIGHT and row["err_free"] < TIGHT
    assert np.allclose(row["K_free_meas"], row["K_meas"])  # task xyz shapes the free one


def test_cli_check_sim_reads_a_sweep_row(tmp_path, capsys, monkeypatch):
    """`check-sim DIR --row K` failed with "unrecognized arguments: --row" while view/plot/export
    read a sweep row that way: it checks the row's path (the row's own path, not the chunk's first)."""
    from jaxstiff.cli import main
    from jaxstiff.sim._setup import sweep_row_result
    from jaxstiff.sweep import run_sweep

    monkeypatch.setenv("JAXSTIFF_COMPILE_CACHE", "0")
    cfg = planar_arc_sweep("rows", {"task": "xy", "criterion": "f2", "ratio": 2.0})
    out = tmp_path / "sw"
    run_sweep(cfg, out, progress=False, report=False)
    one = sweep_row_result(out, 1)
    assert one.B == 1 and np.allclose(np.linalg.norm(one.target[0, :, :2], axis=-1), 2.0)  # row 1: radius 2.0
    js = tmp_path / "row.json"
    assert main(["check-sim", str(out), "--row", "1", "--waypoints", "2", "--json", str(js)]) == 0
    assert "2/2 waypoints agree" in capsys.readouterr().out
    assert json.loads(js.read_text())["passed"]
    assert main(["check-sim", str(out)]) == 2
    assert "is a sweep folder: pick one of its rows with --row" in capsys.readouterr().err
    assert main(["check-sim", str(out), "--row", "7"]) == 2
    assert "no sweep row 7" in capsys.readouterr().err


def test_cli_says_how_many_waypoints_it_leaves_out_as_unusable(tmp_path, capsys):
    """`--waypoints 10` on a path of 20 with 13 unusable printed "7/7 waypoints agree" and nothing
    of the 13 (found by a newcomer trial): the command says how many it leaves out."""
    from jaxstiff.cli import main

    robot = jaxstiff.Robot.from_urdf("planar_3r")
    q = np.deg2rad([[[75.0, -74.74, -76.30], [60.0, -50.0, -60.0], [40.0, 30.0, -90.0]]])
    kj = np.array([[[500.0, 300.0, 100.0], [50.0, 30.0, 10.0], [5.0, 80.0, 20.0]]])
    res = ShapeResult.load(_result_file(tmp_path / "r.npz", robot, q, kj, "xy", None))
    status = np.array(res.status, copy=True)
    status[0, 1] = 3
    fields = {f: getattr(res, f) for f in res.arrays()} | {"status": status, "meta": res.meta}
    f = ShapeResult(**fields).save(tmp_path / "one_unusable.npz")
    capsys.readouterr()
    assert main(["check-sim", f, "--waypoints", "3", "--no-cct"]) == 0
    out = capsys.readouterr().out
    assert "1 of 3 waypoints have no usable solution (status 3-5) and are not checked" in out, out
    assert "2/2 waypoints agree" in out, out
    assert main(["check-sim", str(tmp_path / "r.npz"), "--waypoints", "3", "--no-cct"]) == 0
    assert "no usable solution" not in capsys.readouterr().out
