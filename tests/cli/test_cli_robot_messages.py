"""`jaxstiff robot`'s own messages, which an independent tester found wrong: an ambiguous tip ended
with "(`jaxstiff robot X` lists them)" under `jaxstiff robot X` itself, and the "pass --tip-link"
hint was printed although --tip-link was given; mimic joints counted as actuated joints in the
candidate list; the J_base header gave [m/s per rad/s] for a prismatic joint's column. Small
inline URDFs and tests/data; no solver runs."""

from __future__ import annotations

import os
import re

import pytest
from helpers import DATA_DIR, one_cli_error

import jaxstiff
from jaxstiff.cli import main

LIMIT = '<limit lower="-1" upper="1" effort="1" velocity="1"/>'

#: base -(a1)- l1 -(a2)- l2, then two fixed leaves "body" and "link9" (a tie no rule breaks: a
#: Panda-like layout without the name "hand", which ranks as an end-effector name), and two
#: prismatic fingers on the body, the second a mimic of the first
TIED = f"""<?xml version="1.0"?>
<robot name="tied"><link name="base"/><link name="l1"/><link name="l2"/><link name="body"/><link name="link9"/>
  <link name="lf"/><link name="rf"/>
  <joint name="a1" type="revolute"><parent link="base"/><child link="l1"/><axis xyz="0 0 1"/>{LIMIT}</joint>
  <joint name="a2" type="revolute"><parent link="l1"/><child link="l2"/><origin xyz="0.5 0 0"/>
    <axis xyz="0 1 0"/>{LIMIT}</joint>
  <joint name="hand_joint" type="fixed"><parent link="l2"/><child link="body"/><origin xyz="0.3 0 0"/></joint>
  <joint name="joint9" type="fixed"><parent link="l2"/><child link="link9"/><origin xyz="0.2 0 0"/></joint>
  <joint name="finger1" type="prismatic"><parent link="body"/><child link="lf"/><axis xyz="0 1 0"/>{LIMIT}</joint>
  <joint name="finger2" type="prismatic"><parent link="body"/><child link="rf"/><axis xyz="0 -1 0"/>{LIMIT}
    <mimic joint="finger1"/></joint>
</robot>
"""


@pytest.fixture
def tied(tmp_path):
    path = tmp_path / "tied.urdf"
    path.write_text(TIED)
    return str(path)


def test_ambiguous_tip_under_robot_lists_the_candidates_and_does_not_point_at_itself(capsys, tied):
    err = one_cli_error(capsys, ["robot", tied])
    assert "`jaxstiff robot" not in err and "lists them" not in err, err
    assert "the automatic tip link is ambiguous below 'base' (candidates listed above)" in err, err
    assert "leaves 'body', 'link9' each have 2 actuated joints" in err and "e.g. --tip-link body" in err, err
    assert "Candidate tips:" not in err, err  # the list is on stdout, not repeated in the error
    main(["robot", tied])
    out = capsys.readouterr().out
    assert "   body " in out and "   link9 " in out and "(no automatic choice: leaves 'body', 'link9'" in out
    assert "pass --tip-link)" in out
    # the API, and every other command, still names `jaxstiff robot` as the place that lists them
    with pytest.raises(ValueError, match="Candidate tips: .*`jaxstiff robot tied.urdf` lists them"):
        jaxstiff.Robot.from_urdf(tied)


def test_no_tip_link_hint_when_tip_link_was_given(capsys, tied):
    rc = main(["robot", tied, "--tip-link", "body"])
    out = capsys.readouterr().out
    assert rc == 0 and "chain 'base' -> 'body'" in out
    assert re.search(r"^   body\s+2 actuated joints  <- --tip-link$", out, re.MULTILINE), out
    line = next(l for l in out.splitlines() if "no automatic choice" in l)
    assert line.strip() == (
        "(no automatic choice: leaves 'body', 'link9' each have 2 actuated joints and no end-effector name or "
        "gripper rule tells them apart)"
    )


def test_mimic_joints_are_listed_apart(capsys, tied):
    main(["robot", tied, "--tip-link", "body"])
    lines = capsys.readouterr().out.splitlines()
    right = next(l for l in lines if l.startswith("   rf "))
    assert right.split(None, 1)[1] == "2 actuated joints + 1 mimic  (through gripper joint 'finger2')", right
    left = next(l for l in lines if l.startswith("   lf "))
    assert left.split(None, 1)[1] == "3 actuated joints  (through gripper joint 'finger1')", left


def test_jacobian_header_gives_prismatic_columns_their_unit(capsys):
    """branched_tree.urdf's j2 (column 1) is prismatic: its column is m/s (and rad/s) per m/s."""
    assert main(["robot", os.fspath(DATA_DIR / "branched_tree.urdf")]) == 0
    out = capsys.readouterr().out
    header = next(l for l in out.splitlines() if l.startswith("J_base"))
    assert header == (
        "J_base (rows vx vy vz [m/s per rad/s], wx wy wz [rad/s per rad/s]; "
        "prismatic column 1 (j2): [m/s per m/s], [rad/s per m/s]):"
    )
    assert main(["robot", "planar_3r"]) == 0  # no prismatic joint: the header as it was
    out = capsys.readouterr().out
    assert "J_base (rows vx vy vz [m/s per rad/s], wx wy wz [rad/s per rad/s]):" in out.splitlines()


def test_a_urdf_refused_for_another_reason_prints_nothing_before_the_error(capsys, tmp_path):
    # an independent check: a joint with lower > upper printed the candidate-tip table on stdout,
    # then the error; the table stands before an error only where it explains it (an ambiguous tip)
    bad = tmp_path / "badlim.urdf"
    bad.write_text(TIED.replace(LIMIT, '<limit lower="1" upper="-1" effort="1" velocity="1"/>', 1))
    assert main(["robot", str(bad), "--tip-link", "body"]) == 2
    cap = capsys.readouterr()
    assert cap.out == "", cap.out
    assert "joint 'a1' has lower limit 1 > upper limit -1" in cap.err, cap.err
