"""jaxstiff.sim without MuJoCo: the locked-joint mode, the waypoint sample, the missing-MuJoCo message."""

import subprocess
import sys

import numpy as np
import pytest

import jaxstiff
from jaxstiff.sim._setup import locked_joint_mode, select_waypoints, spring_mask


def test_locked_joint_mode_reads_meta_and_defaults_to_spring():
    assert locked_joint_mode({}) == "spring"  # files written before the option: locked joints kept their springs
    assert locked_joint_mode({"settings": {"task": "full"}}) == "spring"
    assert locked_joint_mode({"settings": {"locked_joints": "rigid"}}) == "rigid"
    assert locked_joint_mode({"settings": {"locked_joints": "spring"}}) == "spring"
    with pytest.raises(ValueError, match="locked_joints"):
        locked_joint_mode({"settings": {"locked_joints": "stiff"}})


def test_spring_mask_follows_the_mode():
    robot = jaxstiff.Robot.from_urdf("kuka_lwr4", locked={"lwr_a7": 0.0})
    assert spring_mask(robot, "rigid").tolist() == [True] * 6 + [False]
    assert spring_mask(robot, "spring").tolist() == [True] * 7


def test_select_waypoints():
    assert select_waypoints(60, 3) == [0, 30, 59]  # round(29.5) = 30 (banker's rounding gives 30 too)
    assert select_waypoints(4, 10) == [0, 1, 2, 3]
    assert select_waypoints(10, [0, -1]) == [0, 9]
    assert select_waypoints(5, None) == [0, 1, 2, 3, 4]
    with pytest.raises(ValueError, match="out of range"):
        select_waypoints(5, [7])


def test_import_and_cli_work_without_mujoco(tmp_path):
    """`import jaxstiff` and the CLI's parser load with MuJoCo hidden; check-sim says how to install it."""
    code = (
        "import sys; sys.modules['mujoco'] = None\n"
        "import jaxstiff, jaxstiff.sim\n"
        "from jaxstiff.cli._main import main\n"
        "assert main(['robot', '--robot', 'planar_3r']) == 0\n"
        f"sys.exit(main(['check-sim', {str(tmp_path / 'r.npz')!r}]))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.returncode == 2, out.stderr
    assert 'pip install "jaxstiff[sim]"' in out.stderr


def testprobe_directions_are_unit_and_span_the_task():
    from jaxstiff.sim._check import probe_directions

    for task, k in (("xy", 2), ("xyz", 3), ("full", 6)):
        axes, extra = probe_directions(task)
        assert axes.shape == (k, 6) and np.linalg.matrix_rank(axes) == k
        assert np.allclose(np.linalg.norm(extra, axis=1), 1.0)


def test_cases_skip_unusable_waypoints(tmp_path):
    """A status 3-5 row holds the reference state, not a solution: check-sim picked such rows and
    reported them as agreeing (found by an independent check). N evenly spaced cases are taken among
    the usable waypoints, a given list loses its unusable entries, and none usable is an error."""
    from jaxstiff.sim import cases_from_result

    robot = jaxstiff.Robot.from_urdf("planar_3r")
    pts = np.c_[np.linspace(1.50, 1.58, 6), np.full(6, 0.5), np.zeros(6)]
    res = jaxstiff.shape(robot, jaxstiff.Path(pts), "f2", 5.0, task="xy")
    fields = {f: getattr(res, f) for f in res.arrays()}
    status = np.array(res.status, copy=True)
    status[0, [0, 2, 5]] = (3, 4, 5)
    bad = jaxstiff.ShapeResult(**(fields | {"status": status, "meta": res.meta}))
    assert [c.label for c in cases_from_result(bad, 6)] == ["b0 p1", "b0 p3", "b0 p4"]
    assert [c.label for c in cases_from_result(bad, 2)] == ["b0 p1", "b0 p4"]
    assert [c.label for c in cases_from_result(bad, [0, 1, 5])] == ["b0 p1"]
    with pytest.raises(ValueError, match="no usable waypoint"):
        cases_from_result(bad, [0, 2])


def test_an_edited_urdf_is_named_before_the_reader_blames_the_result(tmp_path):
    """check-sim with a --urdf whose sha256 differs from the recorded one blamed the result file
    ("the file's robot, tcp or q is not what it claims", found with an edited URDF): the changed
    URDF is now the error's first sentence, and a warning when the file still reads."""
    import pathlib
    import warnings

    from jaxstiff.sim import cases_from_result

    robot = jaxstiff.Robot.from_urdf("planar_3r")
    pts = np.c_[np.linspace(1.50, 1.58, 4), np.full(4, 0.5), np.zeros(4)]
    file = jaxstiff.shape(robot, jaxstiff.Path(pts), "f2", 5.0, task="xy").save(tmp_path / "r.npz")
    text = (pathlib.Path(jaxstiff.__file__).parents[1] / "urdf" / "planar_3r.urdf").read_text()
    edited = tmp_path / "edited.urdf"
    edited.write_text(text.replace('<origin xyz="1 0 0"', '<origin xyz="1.1 0 0"', 1))
    with pytest.raises(ValueError, match=r"r\.npz: the URDF given \(.*edited\.urdf\) differs from the one the result"):
        cases_from_result(file, 2, urdf=edited)
    # view, plot and export read the file the same way (the one reader)
    from jaxstiff.cli import main

    with pytest.raises(ValueError, match=r"r\.npz: the URDF given \(.*edited\.urdf\) differs .*; position: "):
        jaxstiff.ShapeResult.read(file, edited)
    assert main(["export", str(file), "--urdf", str(edited), "--out", str(tmp_path / "x.csv")]) == 2
    assert not (tmp_path / "x.csv").exists()
    comment = tmp_path / "comment.urdf"  # the same robot, other bytes: a warning, the check goes on
    comment.write_text(text + "<!-- copied -->\n")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        assert len(cases_from_result(file, 2, urdf=comment)) == 2
    assert any("differs from the one the result was computed with" in str(w.message) for w in caught)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the file it was computed with: no warning
        same = tmp_path / "same.urdf"
        same.write_text(text)
        assert len(cases_from_result(file, 2, urdf=same)) == 2
