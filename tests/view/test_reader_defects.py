"""Issue 42 item 4, "readers do not check what they read": one test per defect of the list. Each
tampered file was exported, viewed and physics-checked as if it were right (or refused by some
readers only); now every reader goes through :func:`jaxstiff.results._reader.read_result` and each
command ends in exit 2 with one line naming what disagrees, and writes nothing.
"""

from __future__ import annotations

import os

import numpy as np
import pytest
from helpers import tamper_result

import jaxstiff
from jaxstiff.cli import main
from jaxstiff.model import robot_path
from jaxstiff.runtime._io import file_sha256


def _refused(argv: list[str], capsys, *words: str) -> str:
    """``jaxstiff ARGV`` exits 2 with one line on stderr holding ``words``; returns the line."""
    capsys.readouterr()
    assert main(argv) == 2, argv
    err = [ln for ln in capsys.readouterr().err.strip().splitlines() if ln]
    assert len(err) == 1 and err[0].startswith("jaxstiff: error: "), err
    for w in words:
        assert w in err[0], (w, err[0])
    return err[0]


def _all_refuse(f: str, tmp_path, capsys, *words: str, plot: bool = True) -> None:
    """export, view --html, plot and verify() all refuse ``f``, and nothing is written."""
    _refused(["export", f, "--csv", str(tmp_path / "out.csv")], capsys, *words)
    _refused(["view", f, "--html", str(tmp_path / "out.html")], capsys, *words)
    if plot:
        _refused(["plot", f, "--out", str(tmp_path / "out.png")], capsys, *words)
    if "K_C" not in np.load(f).files:
        with pytest.raises(ValueError) as exc:
            jaxstiff.results.verify(f)
        assert all(w in str(exc.value) for w in words), str(exc.value)
    assert not [p for p in os.listdir(tmp_path) if p.startswith("out.")]


def test_defect_another_robot_with_its_correct_hash(shape_file, tmp_path, capsys) -> None:
    from jaxstiff.settings._robot import robot_meta

    planar = robot_path("planar_3r")
    record = robot_meta(jaxstiff.Robot.from_urdf("planar_3r"))  # its whole record, hash included

    def other(m):
        m["robot"].update(urdf=planar, sha256=file_sha256(planar), name="planar_3r")

    f = tamper_result(shape_file, str(tmp_path / "other.npz"), meta=other)
    _all_refuse(f, tmp_path, capsys, "other.npz", "meta robot", "lwr_base")
    f = tamper_result(shape_file, str(tmp_path / "other2.npz"), meta=lambda m: m.update(robot=record))
    _all_refuse(f, tmp_path, capsys, "other2.npz", "meta robot.joint_names", "7 joint names")
    pytest.importorskip("mujoco")  # check-sim said "3/3 agree" on the wrong robot
    _refused(["check-sim", f, "--waypoints", "1"], capsys, "meta robot.joint_names")


def test_defect_tcp_moved_half_a_metre(shape_file, tmp_path, capsys) -> None:
    def moved(m, both=False):
        tcp = np.asarray(m["robot"]["tcp"] if m["robot"]["tcp"] is not None else np.eye(4), float)
        tcp[0, 3] += 0.5
        m["robot"]["tcp"] = tcp.tolist()
        if both:  # the tip transform made to agree: only FK of the stored q can tell
            tip = np.asarray(m["robot"]["tip_transform"], float)
            shift = np.eye(4)
            shift[0, 3] = 0.5
            m["robot"]["tip_transform"] = (tip @ shift).tolist()

    f = tamper_result(shape_file, str(tmp_path / "tcp.npz"), meta=moved)
    _all_refuse(f, tmp_path, capsys, "robot.tip_transform", plot=False)
    f = tamper_result(shape_file, str(tmp_path / "tcp2.npz"), meta=lambda m: moved(m, True))
    line = _refused(["export", f, "--csv", str(tmp_path / "out.csv")], capsys, "position", "FK of the stored q")
    assert "0.5" in line


@pytest.mark.parametrize("task", ["xy", "xyz"])
def test_defect_another_task(shape_file, tmp_path, capsys, task) -> None:
    # the fixture was solved for task "full"; the settings record changed with it
    def other(m):
        m["task"] = task
        m.setdefault("settings", {})["task"] = task

    f = tamper_result(shape_file, str(tmp_path / "task.npz"), meta=other)
    _all_refuse(f, tmp_path, capsys, "meta task", repr(task), plot=False)


def test_defect_joint_names_permuted(shape_file, tmp_path, capsys) -> None:
    def permute(a):
        a["joint_names"] = a["joint_names"][::-1].copy()

    def permute_meta(m):
        m["robot"]["joint_names"] = m["robot"]["joint_names"][::-1]

    f = tamper_result(shape_file, str(tmp_path / "names.npz"), arrays=permute, meta=permute_meta)
    _all_refuse(f, tmp_path, capsys, "joint_names", "chain order", plot=False)


def test_defect_a_locked_joint_that_moved(shape_file, tmp_path, capsys) -> None:
    def moved(a):
        a["q"][..., 6] += 0.2  # lwr_a7, locked at 0 (its axis through the TCP: the position is the same)

    f = tamper_result(shape_file, str(tmp_path / "locked.npz"), arrays=moved)
    _all_refuse(f, tmp_path, capsys, "locked joint lwr_a7", plot=False)
    f = tamper_result(
        shape_file, str(tmp_path / "locked2.npz"), meta=lambda m: m["robot"].update(locked={"lwr_a7": 0.3})
    )
    _refused(["export", f, "--csv", str(tmp_path / "out.csv")], capsys, "locked joint lwr_a7", "0.3")


@pytest.mark.parametrize("dtype", [np.int64, np.bool_, np.complex128, np.float16])
def test_defect_q_of_another_dtype(shape_file, csc_file, tmp_path, capsys, dtype) -> None:
    for src in (shape_file, csc_file):

        def cast(a):
            a["q"] = a["q"].astype(dtype)

        f = tamper_result(src, str(tmp_path / "dtype.npz"), arrays=cast)
        _all_refuse(f, tmp_path, capsys, "q: expected float32 or float64", np.dtype(dtype).name, plot=False)


def test_defect_stored_positions_not_the_fk_of_q(shape_file, csc_file, tmp_path, capsys) -> None:
    from jaxstiff.view._data import check_positions, load_view_data

    assert check_positions(load_view_data(shape_file)) < 1e-9
    for src in (shape_file, csc_file):

        def shifted(a):
            a["position"] = a["position"] + 0.06
            if "pos_error" in a:
                a["target"] = a["target"] + 0.06  # |position - target| kept: only FK can tell

        f = tamper_result(src, str(tmp_path / "pos.npz"), arrays=shifted)
        _all_refuse(f, tmp_path, capsys, "position", "FK of the stored q", plot=False)


def test_defect_csc_file_with_6_of_7_q_columns(csc_file, tmp_path, capsys) -> None:
    def drop(a):
        a["q"] = a["q"][..., :6].copy()

    f = tamper_result(csc_file, str(tmp_path / "six.npz"), arrays=drop)
    _all_refuse(f, tmp_path, capsys, "q", "shape", plot=False)


@pytest.mark.parametrize(
    "key, value", [("q", np.nan), ("kj", -5.0), ("kj", 0.0), ("kj", np.nan), ("kj_scaled", 0.0), ("kj0", -1.0)]
)
def test_defect_nan_q_or_bad_stiffness_in_a_status_0_row(shape_file, tmp_path, capsys, key, value) -> None:
    def bad(a):
        a[key].reshape(-1)[1] = value  # waypoint 0 (status 0), joint 1

    f = tamper_result(shape_file, str(tmp_path / "bad.npz"), arrays=bad)
    _all_refuse(f, tmp_path, capsys, f" {key}: expected", plot=False)


def test_defect_bad_stiffness_in_a_csc_file(csc_file, tmp_path, capsys) -> None:
    for value in (np.nan, -5.0, 0.0):

        def bad(a, value=value):
            a["kj"].reshape(-1)[1] = value

        f = tamper_result(csc_file, str(tmp_path / "bad.npz"), arrays=bad)
        _refused(["export", f, "--csv", str(tmp_path / "out.csv")], capsys, "kj: expected stiffness > 0")
        assert not os.path.exists(tmp_path / "out.csv")


@pytest.mark.parametrize("axis", [0, 1])
def test_defect_no_paths_or_no_waypoints(shape_file, csc_file, tmp_path, capsys, axis) -> None:
    # B = 0 or P = 0 gave a header-only CSV and exit 0
    for src in (shape_file, csc_file):

        def empty(a):
            for k, v in a.items():
                if k not in ("joint_names", "K_xd") and v.ndim > axis and not (k == "q0" and v.ndim == 1):
                    if k in ("u_start", "frobenius_start") and axis == 1:
                        continue
                    a[k] = np.take(v, [], axis=axis)

        f = tamper_result(src, str(tmp_path / "empty.npz"), arrays=empty)
        _refused(["export", f, "--csv", str(tmp_path / "out.csv")], capsys, " q: expected shape")
        assert not os.path.exists(tmp_path / "out.csv")


def test_readers_agree_on_a_tampered_file(shape_file, tmp_path, capsys) -> None:
    """plot and verify() refused some of these while export and view took them: now one reader,
    one message (the same line from every command)."""

    def lie(m):
        m["robot"]["name"] = "planar_3r"

    f = tamper_result(shape_file, str(tmp_path / "lie.npz"), meta=lie)
    lines = {
        _refused(["export", f, "--csv", str(tmp_path / "out.csv")], capsys),
        _refused(["view", f, "--html", str(tmp_path / "out.html")], capsys),
        _refused(["plot", f, "--out", str(tmp_path / "out.png")], capsys),
    }
    with pytest.raises(ValueError) as exc:
        jaxstiff.results.verify(f)
    assert lines == {f"jaxstiff: error: {exc.value}"}
    assert "meta robot.name" in str(exc.value) and "'planar_3r'" in str(exc.value)


def test_defect_one_nan_waypoint_is_named_not_an_eigenvalue_error(shape_file, tmp_path, capsys) -> None:
    """Issue 42 item 5: one NaN waypoint broke the whole view with "Eigenvalues did not converge".
    A file may hold NaN q at a waypoint that is not usable (status 4, non-finite); view and plot
    now name it, export writes it (its status column says what it is)."""

    def nan_waypoint(a):
        a["status"][0, 3] = 4
        a["q"][0, 3, :6] = np.nan  # (the free joints; lwr_a7 keeps its locked value)

    f = tamper_result(shape_file, str(tmp_path / "nan.npz"), arrays=nan_waypoint)
    words = ("nan.npz: path 0, waypoint 3 (status 4): non-finite joint values", "jaxstiff export")
    _refused(["view", f, "--html", str(tmp_path / "out.html")], capsys, *words)
    _refused(["plot", f, "--out", str(tmp_path / "out.png")], capsys, *words)
    assert not [p for p in os.listdir(tmp_path) if p.startswith("out.")]
    assert main(["export", f, "--csv", str(tmp_path / "x.csv")]) == 0
    rows = open(tmp_path / "x.csv").read().splitlines()
    assert len(rows) == 1 + 8 and rows[4].endswith(",4") and "nan" in rows[4].lower()
