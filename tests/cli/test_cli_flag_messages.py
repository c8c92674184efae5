"""Flag messages an independent tester found wrong: `--lock` split at the last '=' and its unit, a
locked joint that is in the URDF but off the chain, `csc --help`'s segment size from SEGMENT_WORK,
`--q0-deg` limits in degrees, `view --every` < 1 refused, and `export`'s note on a csc file's status
bit mask. Every case stops at argument checking or reads a file built from arrays: no solver runs."""

from __future__ import annotations

import os

import numpy as np
import pytest
from helpers import one_cli_error

import jaxstiff
from jaxstiff.cli import main, parse_locks

DATA = os.path.join(os.path.dirname(__file__), "..", "data")
BRANCHED = os.path.join(DATA, "branched_tree.urdf")
DOCS = os.path.join(os.path.dirname(__file__), "..", "..", "docs")
#: the user documentation that states the csc segment size and the CSV format (moved out of README.md)
CSC_PAGE = os.path.join(DOCS, "csc.md")
CSV_PAGE = os.path.join(DOCS, "howto", "view-plot-export.md")

#: two revolute joints, the first named with an '=' in it (XML allows it)
EQ_URDF = """<?xml version="1.0"?>
<robot name="eq">
  <link name="base"/><link name="l1"/><link name="l2"/>
  <joint name="j=1" type="revolute"><parent link="base"/><child link="l1"/>
    <axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
  <joint name="j2" type="revolute"><parent link="l1"/><child link="l2"/>
    <origin xyz="1 0 0"/><axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
</robot>
"""


def _words(text: str) -> str:
    return " ".join(text.split())


# ------------------------------------------------------------------ 1. --lock NAME=VALUE
def test_lock_splits_at_the_last_equals_sign(tmp_path, capsys):
    assert parse_locks(["j=1=0.1", "j2=-0.2"]) == {"j=1": 0.1, "j2": -0.2}
    urdf = tmp_path / "eq.urdf"
    urdf.write_text(EQ_URDF)
    out = tmp_path / "x.npz"
    base = ["csc", "--robot", str(urdf), "--hold", "1,0", "--kxd", "1000,500", "--out", str(out)]
    # the lock is taken (the robot is built with joint 'j=1' locked); the run stops at --q0's count
    err = one_cli_error(capsys, [*base, "--lock", "j=1=0.1", "--q0", "0.1"])
    assert "--q0 needs 2 values for 'eq' (j=1, j2), got 1" in err, err
    err = one_cli_error(capsys, [*base, "--lock", "j=1=0.1", "--q0", "0.2,0"])
    assert "gives joint 'j=1' 0.2 rad, but it is locked at 0.1 rad" in err, err
    assert not out.exists()


def test_lock_value_that_is_not_a_number_names_both_units(capsys):
    err = one_cli_error(capsys, ["robot", "--robot", BRANCHED, "--tip-link", "tool", "--lock", "j=1=abc"])
    assert "--lock 'j=1=abc': 'abc' is not a number (rad, or m for a prismatic joint)" in err, err
    with pytest.raises(ValueError, match="expects JOINT=RAD"):
        parse_locks(["=0.1"])


# ------------------------------------------------------------------ 2. a joint off the chain
def test_lock_of_a_urdf_joint_off_the_chain_says_so(capsys):
    joint = "side_joint"  # another branch, revolute: a chain through it could lock it
    err = one_cli_error(capsys, ["robot", "--robot", BRANCHED, "--tip-link", "tool", "--lock", f"{joint}=0"])
    assert f"cannot lock joint {joint!r}: it is in the URDF but not on the chain from 'world' to 'tool'" in err
    assert "actuated joints are j1, j2, j3, j4" in err and "unknown" not in err, err


def test_lock_of_a_fixed_joint_says_it_is_fixed(capsys):
    """camera_joint is fixed (on another branch): no chain through it can lock it, so the advice
    to choose --base-link / --tip-link for a chain through it was wrong."""
    err = one_cli_error(capsys, ["robot", "--robot", BRANCHED, "--tip-link", "tool", "--lock", "camera_joint=0"])
    assert "cannot lock joint 'camera_joint': it is a fixed joint (it never moves, so there is nothing to lock)" in err
    assert "j1, j2, j3, j4" in err and "--tip-link" not in err and "unknown" not in err, err


def test_lock_of_a_joint_unknown_to_the_urdf_still_says_unknown(capsys):
    err = one_cli_error(capsys, ["robot", "--robot", BRANCHED, "--tip-link", "tool", "--lock", "elbow=0"])
    assert "cannot lock unknown joint 'elbow'; actuated joints of the chain: j1, j2, j3, j4" in err, err
    err = one_cli_error(capsys, ["robot", "--robot", BRANCHED, "--tip-link", "tool", "--lock", "jj3=0"])
    assert "cannot lock unknown joint 'jj3' (did you mean 'j3'?)" in err, err
    with pytest.raises(ValueError, match="not on the chain from 'world' to 'side_link'"):  # the API too
        jaxstiff.Robot.from_urdf(BRANCHED, tip_link="side_link", locked={"j2": 0.1})


# ------------------------------------------------------------------ 3. csc --help: SEGMENT_WORK
def test_csc_help_states_segment_work_from_the_constant(capsys, monkeypatch):
    import jaxstiff.cli._csc as cli_csc

    assert cli_csc.power_of_ten_text(cli_csc.SEGMENT_WORK) == "5 x 10^4"
    with pytest.raises(SystemExit):
        main(["csc", "--help"])
    assert "(paths x steps over 5 x 10^4) runs in segments" in _words(capsys.readouterr().out)
    assert "than 5 x 10^4 rollout-steps (paths x steps) goes in segments" in _words(open(CSC_PAGE).read())
    monkeypatch.setattr(cli_csc, "SEGMENT_WORK", 200_000)  # the help follows the constant
    with pytest.raises(SystemExit):
        main(["csc", "--help"])
    assert "(paths x steps over 2 x 10^5) runs in segments" in _words(capsys.readouterr().out)
    assert [cli_csc.power_of_ten_text(n) for n in (10_000, 15_000, 12_345, 300)] == [
        "10^4",
        "1.5 x 10^4",
        "12,345",
        "300",
    ]


# ------------------------------------------------------------------ 4. csc --q0 / --q0-deg limits
@pytest.mark.parametrize(
    "robot, q0, message",
    [
        (
            ["planar_3r"],
            ["--q0-deg", "30,60,400"],
            "--q0-deg: joint 'joint_3' (q0[2]) = 400 deg is outside its limits [-180, 180] deg",
        ),
        (
            ["planar_3r"],
            ["--q0-deg", "-181,60,30"],
            "--q0-deg: joint 'joint_1' (q0[0]) = -181 deg is outside its limits [-180, 180] deg",
        ),
        (
            ["planar_3r"],
            ["--q0", "0.5,1,7"],
            "--q0: joint 'joint_3' (q0[2]) = 7 rad is outside its limits [-3.14159, 3.14159] rad",
        ),
        (  # a prismatic joint's value is a length, with either flag
            [BRANCHED, "--tip-link", "tool"],
            ["--q0-deg", "30,0.7,0,0"],
            "--q0-deg: joint 'j2' (q0[1]) = 0.7 m is outside its limits [0, 0.5] m",
        ),
    ],
)
def test_csc_q0_outside_limits_in_the_flags_unit(tmp_path, capsys, robot, q0, message):
    out = tmp_path / "x.npz"
    hold, kxd = ("1.5,0", "3000,1000") if robot == ["planar_3r"] else ("0.5,0,0.5", "3000,1000,2000")
    err = one_cli_error(capsys, ["csc", "--robot", *robot, "--hold", hold, "--kxd", kxd, *q0, "--out", str(out)])
    assert err == f"jaxstiff: error: {message}", err
    assert not out.exists()


def test_csc_q0_limit_message_tells_value_and_limit_apart():
    """A value just past a limit is shown with the digits that tell them apart."""
    from jaxstiff.cli._csc import check_q0_limits

    robot = jaxstiff.Robot.from_urdf(BRANCHED, tip_link="tool")
    typed = np.array([2.5 + 1e-7, 0.1, 0.0, 0.0])
    with pytest.raises(ValueError, match=r"= 2\.5000001 rad is outside its limits \[-2\.5, 2\.5\] rad"):
        check_q0_limits(robot, typed, "--q0", typed)
    check_q0_limits(robot, np.array([2.5 + 1e-10, 0.1, 0.0, 0.0]), "--q0", typed)  # the library's slack: accepted


# ------------------------------------------------------------------ 6. the documentation's CSV section
# (5. view --every and the export of a csc file: tests/view/test_export_and_cli.py)
def test_docs_csv_section_tells_shape_and_csc_status_apart():
    text = _words(open(CSV_PAGE).read())
    assert "From a shape file, command the arm with `kj_scaled` (after CMS), and only rows with status 0-2" in text
    assert "In a csc file `status` is a bit mask, not those codes" in text


def test_csc_steps_with_a_path_is_refused(tmp_path, capsys):
    """--steps sets the length of a --hold; with --path it used to be ignored without a word."""
    path = tmp_path / "p.csv"
    jaxstiff.Path(np.array([[1.5, 0.0, 0.0], [1.49, 0.01, 0.0], [1.48, 0.02, 0.0]])).to_csv(path)
    out = tmp_path / "x.npz"
    base = ["csc", "--robot", "planar_3r", "--path", str(path), "--kxd", "3000,1000@30", "--q0-deg", "30,60,-60"]
    err = one_cli_error(capsys, [*base, "--steps", "10", "--out", str(out)])
    assert (
        err
        == "jaxstiff: error: --steps applies to --hold; a --path has one step per row (repeat a row to hold it still)"
    )
    assert not out.exists()


# ------------------------------------------------------------------ shape --help: which task a contact wants
def test_shape_help_says_which_task_a_contact_with_a_turning_tool_wants(capsys):
    """Issue 40: task full shapes the stiffness with the tool's orientation held; a user who shapes
    contact with a tool free to turn wants xyz, and --help says so, naming the docs section."""
    with pytest.raises(SystemExit):
        main(["shape", "--help"])
    text = _words(capsys.readouterr().out)
    assert "orientation HELD" in text and "FREE TO TURN" in text
    assert "shaping contact with a tool that may turn wants xyz" in text
    assert (
        "Which stiffness is shaped?" in text
        and "Which stiffness is shaped?" in open(os.path.join(DOCS, "concepts.md")).read()
    )


def test_kxd_matrix_form_that_is_not_symmetric_says_how_it_was_read():
    # an independent check: "--kxd 3000,1000,2000,500" (meant as something else) said only "the
    # matrix (row by row) is not symmetric", not that 4 numbers are read as a 2x2 matrix
    from jaxstiff.cli._csc_flags import parse_kxd

    with pytest.raises(ValueError) as e:
        parse_kxd("3000,1000,2000,500")
    msg = str(e.value)
    assert "4 numbers are read as a 2x2 matrix, row by row" in msg, msg
    assert "row 1, column 2: 1000; row 2, column 1: 2000" in msg, msg
    assert "2 numbers are the diagonal, 4 the whole matrix" in msg, msg
    np.testing.assert_array_equal(parse_kxd("3000,500,500,1000"), [[3000.0, 500.0], [500.0, 1000.0]])


def test_kxd_zero_is_refused_without_calling_it_not_semi_definite():
    # a zero matrix is positive semi-definite: the refusal is for having no stiffness at all
    from jaxstiff.cli._csc_flags import parse_kxd

    with pytest.raises(ValueError, match=r"positive semi-definite and not zero .*every eigenvalue is below"):
        parse_kxd("0,0,0")
