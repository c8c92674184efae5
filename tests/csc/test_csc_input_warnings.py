"""CSC input checks and warnings found with third-party arms: task xy on a spatial arm (refused, as
``shape`` refuses it), the adaptive step on a held point and an arm with no null space (a
:class:`jaxstiff.csc.CSCWarning`, once per call, API and command line), the K_xd / path messages
(plain indices), and the units printed for a 6x6 K_xd. Robots: the shipped urdf/ files."""

from __future__ import annotations

import re
import warnings

import numpy as np
import pytest

import jaxstiff
from jaxstiff import csc
from jaxstiff.cli import main as cli_main

LWR_Q0 = np.array([0.3, 0.5, 0.0, -1.2, 0.0, 0.6, 0.0])
K3 = np.diag([2000.0, 1000.0, 500.0])


def _lwr(locked: bool = False) -> jaxstiff.Robot:
    return jaxstiff.Robot.from_urdf("kuka_lwr4", locked={"lwr_a7": 0.0} if locked else None)


def _held(robot: jaxstiff.Robot, q0: np.ndarray, T: int, d: int = 3) -> np.ndarray:
    return np.tile(np.asarray(robot.fk(q0))[:d, 3], (T, 1))


def _csc_warnings(fn):
    with warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        out = fn()
    return out, [str(x.message) for x in w if issubclass(x.category, csc.CSCWarning)]


# --- 1. task xy on an arm whose joints move the TCP along z ------------------------------------


def test_task_xy_on_a_spatial_arm_is_refused():
    robot = _lwr()
    pts = _held(robot, LWR_Q0, 3)
    with pytest.raises(ValueError, match=r"task 'xy' is for planar arms.*three --kxd values.*planar arm"):
        jaxstiff.csc_rollout(robot, pts, np.diag([2000.0, 1000.0]), LWR_Q0)
    with pytest.raises(ValueError, match="task 'xy' is for planar arms"):
        jaxstiff.csc_rollout(robot, pts, K3[:2, :2], LWR_Q0, task="xy")


def test_cli_task_xy_on_a_spatial_arm_is_refused(tmp_path, capsys):
    out = tmp_path / "r.npz"
    hold = ",".join(f"{v:.6f}" for v in _held(_lwr(True), LWR_Q0, 1)[0])
    q0 = ",".join(map(str, LWR_Q0))
    rc = cli_main(
        ["csc", "--robot", "kuka_lwr4", "--hold", hold, "--kxd", "2000,1000", "--q0", q0, "--steps", "3"]
        + ["--out", str(out)]
    )
    err = capsys.readouterr().err
    assert rc == 2 and not out.exists()
    assert err.startswith("jaxstiff: error: task 'xy' is for planar arms") and "three --kxd values" in err
    assert "is ignored" not in err  # refused before the z warning of task xy


def test_task_xy_on_a_planar_arm_still_runs():
    robot = jaxstiff.Robot.from_urdf("planar_4r")
    q0 = np.deg2rad([40.0, -30.0, -30.0, -20.0])
    r = jaxstiff.csc_rollout(robot, _held(robot, q0, 3, 2), np.diag([2000.0, 1000.0]), q0, 1e-3, step="constant")
    assert r.q.shape == (3, 4)


# --- 2. the adaptive step on a held point: the library warns, once per call ---------------------


def test_adaptive_step_on_a_held_point_warns_once_per_call():
    robot = _lwr()
    pts = _held(robot, LWR_Q0, 6)
    _, msgs = _csc_warnings(lambda: jaxstiff.csc_rollout(robot, pts, K3, LWR_Q0))
    assert len(msgs) == 1 and "step 'adaptive' on a held point" in msgs[0] and "step 'constant'" in msgs[0]
    # segmented: one warning for the whole call, not one per segment
    _, msgs = _csc_warnings(lambda: csc.csc_rollout_segments(robot, pts, K3, LWR_Q0, segment_steps=2))
    assert len(msgs) == 1
    # the constant step, or a path that moves: no warning
    _, msgs = _csc_warnings(lambda: jaxstiff.csc_rollout(robot, pts, K3, LWR_Q0, 1e-3, step="constant"))
    assert msgs == []
    moving = pts + np.linspace(0.0, 0.01, 6)[:, None] * np.array([1.0, 0.0, 0.0])
    _, msgs = _csc_warnings(lambda: jaxstiff.csc_rollout(robot, moving, K3, LWR_Q0))
    assert msgs == []


def test_cli_hold_adaptive_warns_once(tmp_path, capsys):
    x = np.asarray(jaxstiff.Robot.from_urdf("planar_3r").fk(np.deg2rad([75.0, -74.74, -76.30])))[:2, 3]
    argv = ["csc", "--robot", "planar_3r", "--hold", f"{x[0]:.8f},{x[1]:.8f}", "--kxd", "3000,1000@30"]
    argv += ["--q0-deg", "75,-74.74,-76.30", "--steps", "20", "--step", "adaptive", "--out", str(tmp_path / "r.npz")]
    assert cli_main(argv) == 0
    err = capsys.readouterr().err
    assert err.count("on a held point") == 1, err


# --- 3. K_xd / path messages name the first offending index as plain ints ----------------------


def test_kxd_and_path_messages_name_the_first_bad_index():
    robot = _lwr()
    T = 8
    pts = _held(robot, LWR_Q0, T) + np.linspace(0, 0.01, T)[:, None]
    K = np.broadcast_to(K3, (T, 3, 3)).copy()
    cases = []
    Ki = K.copy()
    Ki[5] = -K3
    cases.append(
        (
            Ki,
            pts,
            "K_xd must be symmetric positive semi-definite and not zero (a stiffness, N/m): eigenvalues -2000 to -500 (K_xd[5]), "
            "a desired stiffness is >= 0 along every axis (a spring pulls back; a negative one pushes away); "
            "K_xd[5] = [[-2000, 0, 0], [0, -1000, 0], [0, 0, -500]]",
        )
    )
    Ks = K.copy()
    Ks[4, 0, 1] += 100.0
    cases.append((Ks, pts, "K_xd must be symmetric (max |K - K^T| = 100; first at K_xd[4])"))
    Kn = K.copy()
    Kn[3, 1, 1] = np.nan
    cases.append((Kn, pts, "K_xd contains NaN or Inf (first at K_xd[3])"))
    pn = pts.copy()
    pn[6, 2] = np.inf
    cases.append((K, pn, "path contains NaN or Inf (first at path[6], waypoint 6)"))
    for Kx, p, msg in cases:
        with pytest.raises(ValueError, match=re.escape(msg) + "$"):
            jaxstiff.csc_rollout(robot, p, Kx, LWR_Q0)
    with pytest.raises(ValueError, match=re.escape("path contains NaN or Inf (first at path[1, 6], waypoint 6)")):
        jaxstiff.csc_rollout(robot, np.stack([pts, pn]), K3, LWR_Q0)


# --- 4 and 5. a 6x6 K_xd's units; no null space for the task ------------------------------------


def test_no_null_space_warns_once():
    robot = _lwr(locked=True)  # 6 free joints, 6 rows of task full
    pts = _held(robot, LWR_Q0, 4) + np.linspace(0, 0.005, 4)[:, None]
    K6 = np.diag([2000.0, 1000.0, 500.0, 50.0, 50.0, 50.0])
    _, msgs = _csc_warnings(lambda: jaxstiff.csc_rollout(robot, pts, K6, LWR_Q0))
    assert len(msgs) == 1 and "no null space" in msgs[0] and "6 free joints for the 6 rows of task 'full'" in msgs[0]
    _, msgs = _csc_warnings(lambda: jaxstiff.csc_rollout(_lwr(), pts, K6, LWR_Q0))  # 7 joints: redundant
    assert msgs == []


def test_cli_full_task_prints_block_units_and_no_null_space_note(tmp_path, capsys):
    hold = ",".join(f"{v:.8f}" for v in _held(_lwr(True), LWR_Q0, 1)[0])
    q0 = ",".join(map(str, LWR_Q0))
    argv = ["csc", "--robot", "kuka_lwr4", "--hold", hold, "--kxd", "2000,1000,500,50,50,50", "--q0", q0]
    assert cli_main([*argv, "--steps", "3", "--out", str(tmp_path / "r.npz")]) == 0
    cap = capsys.readouterr()
    assert "K_xd (N/m)" not in cap.out and "[[N/m, N/rad], [Nm/m, Nm/rad]]" in cap.out
    assert cap.err.count("no null space") == 1, cap.err


def test_cli_help_states_the_6x6_units(capsys):
    with pytest.raises(SystemExit):
        cli_main(["csc", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert "[[N/m, N/rad], [Nm/m, Nm/rad]]" in text
