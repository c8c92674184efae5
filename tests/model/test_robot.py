"""Robot.from_urdf: the shipped robots against their published facts, chain extraction from trees
(fixed joints folded, tip selection, sub-chains), locks, TCP, and the ``jaxstiff robot`` command."""

from __future__ import annotations

import json
import math
import os
import shutil
import subprocess
import sys
import warnings

import jax.numpy as jnp
import numpy as np
import pytest
from helpers import DATA_DIR, assert_close

import jaxstiff
from jaxstiff.cli import main

BRANCHED = str(DATA_DIR / "branched_tree.urdf")

# KUKA LWR 4 facts (issue 2 / data sheets): d1, d3, d5, flange d7 in m; limits in degrees.
D1, D3, D5, D7 = 0.3105, 0.40, 0.39, 0.078


def test_shipped_robots_are_listed_and_found():
    assert {"kuka_lwr4", "planar_3r"} <= set(jaxstiff.shipped_robots())
    assert jaxstiff.robot_path("kuka_lwr4").endswith("kuka_lwr4.urdf")
    assert jaxstiff.robot_path("planar_3r.urdf") == jaxstiff.robot_path("planar_3r")
    assert os.path.isfile(jaxstiff.robot_path("kuka_lwr4"))


def test_lwr_matches_published_kinematic_facts():
    robot = jaxstiff.Robot.from_urdf("kuka_lwr4")
    assert robot.n == 7 and robot.n_free == 7
    assert robot.joint_names == tuple(f"lwr_a{i}" for i in range(1, 8))
    assert (robot.base_link, robot.tip_link) == ("lwr_base", "lwr_flange")  # default: the deepest leaf
    limits = np.array([170, 120, 170, 120, 170, 120, 170], dtype=float)
    assert_close(np.rad2deg(robot.upper), limits, atol=1e-9)
    assert_close(np.rad2deg(robot.lower), -limits, atol=1e-9)
    # zero posture: straight up, flange at d1 + d3 + d5 + d7, no rotation
    T0 = np.asarray(robot.fk(jnp.zeros(7)))
    T_expected = np.eye(4)
    T_expected[2, 3] = D1 + D3 + D5 + D7
    assert_close(T0, T_expected, atol=1e-12)
    # A2 at +90 deg (about +y) lays the arm along +x at shoulder height
    T = np.asarray(robot.fk(jnp.array([0, math.pi / 2, 0, 0, 0, 0, 0.0])))
    assert_close(T[:3, 3], [D3 + D5 + D7, 0.0, D1], atol=1e-12)
    # A4 at +90 deg (about -y) bends the forearm towards -x above the elbow
    T = np.asarray(robot.fk(jnp.array([0, 0, 0, math.pi / 2, 0, 0, 0.0])))
    assert_close(T[:3, 3], [-(D5 + D7), 0.0, D1 + D3], atol=1e-12)
    # Jacobian column of A2 at zero: y x (p_tcp - p_A2) = (d3 + d5 + d7, 0, 0); all offsets a_i = 0
    J = np.asarray(robot.jacobian(jnp.zeros(7)))
    assert_close(J[:3, 1], [D3 + D5 + D7, 0, 0], atol=1e-12)
    assert_close(J[:3, [0, 2, 4, 6]], np.zeros((3, 4)), atol=1e-12)  # axes through the TCP


def test_planar_3r_is_seed_000s_arm():
    robot = jaxstiff.Robot.from_urdf("planar_3r")
    assert robot.n == 3 and robot.joint_types == (jaxstiff.model.JOINT_REVOLUTE,) * 3
    assert_close(robot.fk(jnp.zeros(3))[:3, 3], [3.0, 0.0, 0.0], atol=1e-15)  # three 1 m links
    assert all(ax == (0.0, 0.0, 1.0) for ax in robot.axes)


def test_branched_tree_chain_folds_fixed_joints_and_reads_joint_kinds():
    robot = jaxstiff.Robot.from_urdf(BRANCHED, tip_link="tool")
    assert robot.joint_names == ("j1", "j2", "j3", "j4")  # mount, elbow_offset, tool_joint folded
    R, P = jaxstiff.model.JOINT_REVOLUTE, jaxstiff.model.JOINT_PRISMATIC
    assert robot.joint_types == (R, P, R, R)
    assert robot.lower.tolist()[:2] == [-2.5, 0.0] and robot.upper.tolist()[:2] == [2.5, 0.5]
    assert robot.lower[2] == -math.inf and robot.upper[2] == math.inf  # continuous
    assert_close(robot.axes[0], [0.0, 0.6, 0.8], atol=1e-15)
    assert (robot.base_link, robot.tip_link) == ("world", "tool")


def test_sub_chains_compose():
    """T_world_tool(q) = T_world_link2(q1, q2) @ T_link2_tool(q3, q4): three independent parses."""
    full = jaxstiff.Robot.from_urdf(BRANCHED, tip_link="tool")
    head = jaxstiff.Robot.from_urdf(BRANCHED, tip_link="link_2")
    tail = jaxstiff.Robot.from_urdf(BRANCHED, base_link="link_2", tip_link="tool")
    assert head.joint_names == ("j1", "j2") and tail.joint_names == ("j3", "j4")
    q = np.random.default_rng(0).uniform(-1, 1, size=(5, 4))
    q[:, 1] = np.abs(q[:, 1]) * 0.5
    T = np.asarray(full.fk(q))
    assert_close(T, np.asarray(head.fk(q[:, :2])) @ np.asarray(tail.fk(q[:, 2:])), atol=1e-13)
    side = jaxstiff.Robot.from_urdf(BRANCHED, tip_link="side_link")
    assert side.joint_names == ("j1", "side_joint")


def test_default_tip_is_the_unique_leaf_with_most_actuated_joints(tmp_path):
    """A fixed sensor branch is not a candidate when an arm branch has more actuated joints."""
    urdf = tmp_path / "arm_with_sensor.urdf"
    urdf.write_text(
        """<robot name="arm"><link name="b"/><link name="l1"/><link name="l2"/><link name="cam"/><link name="ee"/>
        <joint name="a" type="revolute"><parent link="b"/><child link="l1"/><axis xyz="0 0 1"/>
          <limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
        <joint name="cam_mount" type="fixed"><parent link="l1"/><child link="cam"/><origin xyz="0 0.1 0"/></joint>
        <joint name="b2" type="revolute"><parent link="l1"/><child link="l2"/><origin xyz="1 0 0"/>
          <axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
        <joint name="flange" type="fixed"><parent link="l2"/><child link="ee"/><origin xyz="0.5 0 0"/></joint>
        </robot>"""
    )
    robot = jaxstiff.Robot.from_urdf(urdf)
    assert robot.tip_link == "ee" and robot.joint_names == ("a", "b2")
    assert_close(robot.fk(jnp.zeros(2))[:3, 3], [1.5, 0, 0], atol=1e-15)
    # BRANCHED's "tool" and "camera" tie on joints; the end-effector name picks "tool" (test_tip_rules.py)
    assert jaxstiff.Robot.from_urdf(BRANCHED).tip_link == "tool"


def test_robot_is_static_hashable_and_equal_across_reads():
    a = jaxstiff.Robot.from_urdf("kuka_lwr4", locked={"lwr_a7": 0.0}, tcp=[0, 0, 0.1])
    b = jaxstiff.Robot.from_urdf(jaxstiff.robot_path("kuka_lwr4"), locked={"lwr_a7": 0.0}, tcp=[0, 0, 0.1])
    assert a == b and hash(a) == hash(b)
    assert a != jaxstiff.Robot.from_urdf("kuka_lwr4")
    assert a.with_locked(None).free.all()
    assert a.tip_matrix[2, 3] == pytest.approx(D7 + 0.1)


def test_describe_lists_the_chain():
    text = jaxstiff.Robot.from_urdf(BRANCHED, tip_link="tool", locked={"j4": 0.5}).describe()
    for word in (
        "j1",
        "j2",
        "j3",
        "j4",
        "prismatic",
        "revolute",
        "continuous",
        "locked at 0.5 rad",
        "'world' -> 'tool'",
    ):
        assert word in text, word


def test_empty_limit_range_warns_with_the_joint_name(tmp_path):
    """URDF defaults a missing lower/upper to 0; a [0, 0] range freezes the joint: say so."""
    urdf = tmp_path / "nolimits.urdf"
    urdf.write_text(
        """<robot name="r"><link name="a"/><link name="b"/>
        <joint name="elbow" type="revolute"><parent link="a"/><child link="b"/><axis xyz="0 0 1"/>
          <limit effort="1" velocity="1"/></joint></robot>"""
    )
    with pytest.warns(UserWarning, match=r"joint 'elbow'.*empty range \[0, 0\].*omits lower and upper"):
        robot = jaxstiff.Robot.from_urdf(urdf)
    assert robot.lower.tolist() == [0.0] and robot.upper.tolist() == [0.0]


# ------------------------------------------------------------------ the `jaxstiff robot` command
def _matrix_after(text: str, header: str, rows: int) -> np.ndarray:
    lines = text.splitlines()
    i = next(k for k, line in enumerate(lines) if line.startswith(header))
    body = " ".join(lines[i + 1 : i + 1 + rows]).replace("[", " ").replace("]", " ")
    return np.array(body.split(), dtype=float).reshape(rows, -1)


def test_cli_robot_prints_chain_pose_and_jacobian(capsys):
    assert main(["robot", "--robot", "planar_3r", "--q", "0,0,0"]) == 0
    out = capsys.readouterr().out
    assert "joint_1" in out and "joint_3" in out
    T = _matrix_after(out, "T_base_tcp", 4)
    assert_close(T, [[1, 0, 0, 3], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]], atol=1e-5)
    J = _matrix_after(out, "J_base", 6)
    assert_close(J[1], [3, 2, 1], atol=1e-5)  # vy = sum of the lever arms


def test_cli_robot_default_and_locks(capsys):
    assert main(["robot", "--lock", "lwr_a7=0"]) == 0
    out = capsys.readouterr().out
    assert "kuka_lwr4" in out and "locked at 0" in out and "(6 free)" in out


@pytest.mark.parametrize(
    "argv,message",
    [
        (["robot", "--robot", "no_such_robot.urdf"], "URDF file not found"),
        (["robot", "--q", "0,0"], "needs 7 values"),
        (["robot", "--lock", "lwr_a7"], "JOINT=RAD"),
        (["robot", "--lock", "lwr_a7=3.5"], "outside its limits"),
        (["robot", "--tip-link", "nowhere"], "unknown tip link 'nowhere'"),
        (["robot", "--robot", "planar_3r", "--q", "1,a,0"], "--q: expected comma-separated numbers"),  # was a traceback
        (["robot", "--robot", "planar_3r", "--lock", "joint_1=0.5", "--q", "0,0,0"], "locked at 0.5"),  # was ignored
        (["robot", "--lock", "lwr_a7=0", "--lock", "lwr_a7=1"], "joint 'lwr_a7' is given twice"),
    ],
)
def test_cli_robot_errors_are_one_line(argv, message, capsys):
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("jaxstiff: error:") and message in err and "\n" not in err


def test_cli_robot_warns_for_a_posture_outside_the_limits(capsys):
    assert main(["robot", "--robot", "planar_3r", "--q", "0,10,0"]) == 0
    err = capsys.readouterr().err
    assert "outside its limits" in err and "joint_2" in err


@pytest.mark.slow
def test_console_script_runs():
    exe = shutil.which("jaxstiff")
    cmd = [exe, "robot"] if exe else [sys.executable, "-m", "jaxstiff.cli", "robot"]
    res = subprocess.run(cmd, capture_output=True, text=True, timeout=120)
    assert res.returncode == 0, res.stderr
    assert "lwr_a7" in res.stdout and "T_base_tcp" in res.stdout


@pytest.mark.slow
def test_pickled_robot_equals_and_hashes_like_a_fresh_read():
    """The cached hash must not travel: string hashes differ between processes (ray, sweeps)."""
    code = (
        "import pickle, sys, jaxstiff; r = jaxstiff.Robot.from_urdf('kuka_lwr4', locked={'lwr_a7': 0.0}); "
        "hash(r); sys.stdout.buffer.write(pickle.dumps(r))"
    )
    env = dict(os.environ, PYTHONHASHSEED="12345")
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, timeout=120, env=env)
    assert res.returncode == 0, res.stderr.decode()
    import pickle

    remote = pickle.loads(res.stdout)
    local = jaxstiff.Robot.from_urdf("kuka_lwr4", locked={"lwr_a7": 0.0})
    assert remote == local and hash(remote) == hash(local)
    assert {local: 1}[remote] == 1
    assert "_hash" not in local.__getstate__()


def test_prismatic_joints_get_lengths_not_degrees():
    """A prismatic joint's value is a length: the nominal posture puts it at mid-range (not
    mid-range + 30 deg read as 0.52 m, which the clip sent to its limit), `csc --q0-deg` leaves its
    entry in metres, and `shape --dq-m` sets its rate limit apart from --dq-deg."""
    from jaxstiff.cli._shape import rate_limits
    from jaxstiff.ik import nominal_posture

    robot = jaxstiff.Robot.from_urdf(BRANCHED, tip_link="tool")
    pris = np.asarray(robot.joint_types) == jaxstiff.model.JOINT_PRISMATIC
    assert pris.tolist() == [False, True, False, False]
    assert robot.prismatic.tolist() == pris.tolist()
    lo, hi = robot.lower, robot.upper
    q = nominal_posture(robot)
    assert q[1] == pytest.approx(0.5 * (lo[1] + hi[1]), abs=1e-15)
    fin = np.isfinite(lo) & np.isfinite(hi) & ~pris
    np.testing.assert_allclose(
        q[fin], np.clip(0.5 * (lo[fin] + hi[fin]) + np.deg2rad(30.0), lo[fin], hi[fin]), atol=1e-15
    )
    np.testing.assert_array_equal(rate_limits(robot, 2.0, None), np.full(4, np.deg2rad(2.0)))
    np.testing.assert_array_equal(
        rate_limits(robot, 2.0, 0.01), [np.deg2rad(2.0), 0.01, np.deg2rad(2.0), np.deg2rad(2.0)]
    )
    assert rate_limits(jaxstiff.Robot.from_urdf("planar_3r"), 2.0, 0.01) == np.deg2rad(2.0)  # no prismatic joint


@pytest.mark.slow
def test_csc_cli_reads_and_prints_prismatic_joints_in_metres(tmp_path, capsys):
    robot = jaxstiff.Robot.from_urdf(BRANCHED, tip_link="tool")
    q_deg = [10.0, 0.2, 20.0, 30.0]  # the prismatic joint (second) at 0.2 m
    q0 = np.array([np.deg2rad(10.0), 0.2, np.deg2rad(20.0), np.deg2rad(30.0)])
    x = ",".join(repr(float(v)) for v in np.asarray(robot.fk(q0))[:3, 3])
    out = tmp_path / "c.npz"
    rc = main(
        [
            "csc",
            "--robot",
            BRANCHED,
            "--tip-link",
            "tool",
            "--hold",
            x,
            "--kxd",
            "3000,1000,2000",
            "--q0-deg",
            ",".join(map(str, q_deg)),
            "--steps",
            "2",
            "--out",
            str(out),
        ]
    )
    cap = capsys.readouterr()
    text, err = cap.out, cap.err
    assert rc == 0
    with np.load(out) as f:
        np.testing.assert_allclose(f["q0"], q0, rtol=0, atol=1e-15)
    assert "final q (deg; m for prismatic joints)" in text
    line = next(ln for ln in text.splitlines() if "final q" in ln)
    vals = [float(v) for v in line.split(":", 1)[1].strip(" []").split(",")]
    assert abs(vals[1] - 0.2) < 0.05 and abs(vals[0] - 10.0) < 5.0, line  # metres and degrees, near the start
    # the file's units say so per joint (meta said "rad" and "Nm/rad" for every joint)
    with np.load(out) as f:
        units = json.loads(str(f["meta"]))["units"]
    assert units["q"] == ["rad", "m", "rad", "rad"] and units["kj"] == ["Nm/rad", "N/m", "Nm/rad", "Nm/rad"]
    assert {"frobenius", "target", "isotropy", "u_start", "K_C"} <= set(units)
    # --hold without --step takes the constant step (the adaptive one's null step is beta |dq_P| = 0:
    # it would not move), so no warning about the adaptive step; the file records the rule it ran
    assert "step 'adaptive' on a held point" not in err, err
    with np.load(out) as f:
        assert json.loads(str(f["meta"]))["settings"]["step"] == "constant"
    # `jaxstiff robot` shows its default posture within the limits, the prismatic joint in metres
    assert main(["robot", "--robot", BRANCHED, "--tip-link", "tool"]) == 0
    text = capsys.readouterr().out
    line = next(ln for ln in text.splitlines() if ln.startswith("posture q"))
    assert "(deg; m for prismatic joints)" in line
    vals = np.array([float(v) for v in line.split(":", 1)[1].strip(" []").split(",")])
    assert robot.lower[1] <= vals[1] <= robot.upper[1] and vals[1] == pytest.approx(
        0.5 * (robot.lower[1] + robot.upper[1])
    )


@pytest.mark.parametrize("command", ["shape", "csc"])
def test_out_must_be_a_file_name_checked_before_any_work(tmp_path, capsys, monkeypatch, command):
    """--out "" wrote a hidden './.npz'; --out naming a folder failed only after the solve with an
    internal temporary name. Both are refused up front, and nothing is written."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "adir.npz").mkdir()
    args = {
        "shape": ["shape", "--robot", "planar_3r", "--task", "xy", "--quiet"],
        "csc": ["csc", "--robot", "planar_3r", "--hold", "1.2,1.0", "--kxd", "3000,1000", "--q0", "0.3,0.3,0.3"],
    }[command]
    for out, match in (
        ("", "expected a file name like result.npz, got ''"),
        ("adir.npz", "adir.npz is a folder"),
        ("adir", "adir.npz is a folder"),
        ("sub/", "expected a file name"),
    ):
        assert main(args + ["--out", out]) == 2
        err = capsys.readouterr().err
        assert match in err and "Traceback" not in err and ".tmp" not in err, err
    assert sorted(os.listdir(tmp_path)) == ["adir.npz"] and os.listdir(tmp_path / "adir.npz") == []


def test_repr_is_one_short_line_with_name_joints_links_and_locks():
    robot = jaxstiff.Robot.from_urdf("kuka_lwr4", locked={"lwr_a7": 0.0})
    text = repr(robot)
    assert "\n" not in text and len(text) < 200
    for part in ("kuka_lwr4", "7 joints", "lwr_a1", "lwr_a7", "lwr_flange", "lwr_a7=0"):
        assert part in text, part
    assert "lwr_a4" not in text  # joint names past four are abbreviated
    free = jaxstiff.Robot.from_urdf("planar_3r")
    assert "locked: none" in repr(free) and "joint_1, joint_2, joint_3" in repr(free)
    assert hash(robot) == hash(jaxstiff.Robot.from_urdf("kuka_lwr4", locked={"lwr_a7": 0.0}))  # identity untouched


def test_float64_values_without_x64_warn_once_and_give_float32(monkeypatch):
    import jax

    from jaxstiff.model import _kinematics as kinematics

    robot = jaxstiff.Robot.from_urdf("planar_3r")
    monkeypatch.setattr(kinematics, "_warned_float32", False)
    with jax.enable_x64(False):
        with pytest.warns(UserWarning, match=r"x64 mode is off.*float32.*jax_enable_x64"):
            T = robot.fk(np.zeros(3))
        assert T.dtype == np.float32
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            robot.fk(np.zeros(3))  # once per process
            monkeypatch.setattr(kinematics, "_warned_float32", False)
            jaxstiff.fk(robot, np.zeros(3, dtype=np.float32))  # float32 asked for: no warning
    with jax.enable_x64(True), warnings.catch_warnings():
        warnings.simplefilter("error")
        assert jaxstiff.fk(robot, np.zeros(3)).dtype == np.float64  # x64 on: float64, no warning
