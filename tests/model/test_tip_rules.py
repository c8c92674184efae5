"""The automatic tip link (jaxstiff.model._urdf.tip_candidates): on every URDF of the repository the
expected tip, read off each file's tree by hand (not from the code), and the rules one at a time on
small trees: gripper joints are cut off (by name, by the parallel-jaw rule, mimic joints of a
gripper), most actuated joints, finger parts yield, end-effector names break ties, the rest is an
error that lists every candidate; unknown links get a "did you mean" and every link below the base;
``jaxstiff robot URDF`` lists the candidates, the automatic one first, grippers marked."""

from __future__ import annotations

import re

import pytest
from helpers import DATA_DIR

import jaxstiff
from jaxstiff.cli import main
from jaxstiff.model._urdf import tip_candidates

ROBOTS = DATA_DIR / "robots"

#: (file, expected tip, its actuated joints), from reading each file's tree:
EXPECTED = [
    # 6 arm joints; the end effector and two finger tips hang off link_6 through fixed joints; the
    # finger tips (fixed joints named "finger") yield to the end effector
    (ROBOTS / "kinova_j2s6s200.urdf", "j2s6s200_end_effector", 6),
    # 5 arm joints (the wrist_roll turns "gripper_link"); the jaw joint "gripper" is cut off, leaving
    # the fixed gripper_frame_link
    (ROBOTS / "so101.urdf", "gripper_frame_link", 5),
    # arm_left_2..7 (6 joints); gripper_left_joint and the mimic joints of the gripper are cut off;
    # the fixed chain ft -> tool -> gripper_left_base_link is what is left
    (ROBOTS / "talos_left_arm.urdf", "gripper_left_base_link", 6),
    # ee_link and tool0 both hang off wrist_3_link: "tool" ranks before "ee"
    (ROBOTS / "ur10.urdf", "tool0", 6),
    # joint1..6; jointGripper is cut off, leaving the fixed gripperStator
    (ROBOTS / "z1.urdf", "gripperStator", 6),
    # the shipped and test robots keep the tips they had (a changed tip changes results)
    ("kuka_lwr4", "lwr_flange", 7),
    ("planar_3r", "tool", 3),
    ("planar_4r", "tool", 4),
    (DATA_DIR / "panda_like.urdf", "flange", 7),
    (DATA_DIR / "planar_4r_tight_limits.urdf", "tool", 4),
    # camera and tool tie on 4 joints (was an error): the end-effector name "tool" decides
    (DATA_DIR / "branched_tree.urdf", "tool", 4),
]


@pytest.mark.parametrize(
    "urdf,tip,n", EXPECTED, ids=lambda v: getattr(v, "name", v) if not isinstance(v, int) else None
)
def test_every_repository_urdf_gets_the_expected_tip(urdf, tip, n):
    robot = jaxstiff.Robot.from_urdf(str(urdf))
    assert robot.tip_link == tip and robot.n == n
    ranked, chosen, _ = tip_candidates(str(urdf))
    assert chosen == tip and ranked[0].link == tip


LIMIT = '<limit lower="-1" upper="1" effort="1" velocity="1"/>'


def arm(extra: str, hand: str = "hand", name: str = "arm") -> str:
    """base -(a1)- l1 -(a2)- l2 -(fixed)- ``hand``; ``extra`` hangs more off the hand."""
    return f"""<robot name="{name}"><link name="base"/><link name="l1"/><link name="l2"/><link name="{hand}"/>
    <joint name="a1" type="revolute"><parent link="base"/><child link="l1"/><axis xyz="0 0 1"/>{LIMIT}</joint>
    <joint name="a2" type="revolute"><parent link="l1"/><child link="l2"/><origin xyz="0.5 0 0"/>
      <axis xyz="0 1 0"/>{LIMIT}</joint>
    <joint name="mount" type="fixed"><parent link="l2"/><child link="{hand}"/><origin xyz="0.4 0 0"/></joint>
    {extra}</robot>"""


def jaw(name: str, child: str, parent: str = "hand", mimic: str = "", kind: str = "prismatic") -> str:
    return (
        f'<link name="{child}"/><joint name="{name}" type="{kind}"><parent link="{parent}"/><child link="{child}"/>'
        f'<origin xyz="0.05 0 0"/><axis xyz="0 1 0"/>{LIMIT}{mimic}</joint>'
    )


@pytest.fixture
def write(tmp_path):
    def _write(text: str, name: str = "robot.urdf") -> str:
        p = tmp_path / name
        p.write_text(text)
        return str(p)

    return _write


def test_panda_style_fingers_are_cut_off(write):
    """The Panda's hand: two prismatic finger joints, the second a mimic of the first. The tip used
    to be an error offering the finger as example; now it is the hand."""
    fingers = jaw("panda_finger_joint1", "leftfinger") + jaw(
        "panda_finger_joint2", "rightfinger", mimic='<mimic joint="panda_finger_joint1"/>'
    )
    r = jaxstiff.Robot.from_urdf(write(arm(fingers)))
    assert r.tip_link == "hand" and r.joint_names == ("a1", "a2")
    # with a TCP frame on the hand (newer Panda URDFs), the TCP link: most joints tie, "tcp" ranks first
    r = jaxstiff.Robot.from_urdf(
        write(
            arm(
                fingers + '<link name="hand_tcp"/><joint name="tcp_joint" type="fixed"><parent link="hand"/>'
                '<child link="hand_tcp"/><origin xyz="0.1 0 0"/></joint>'
            )
        )
    )
    assert r.tip_link == "hand_tcp"


def test_the_hand_wins_over_a_bare_link_beside_it(write):
    """Franka's own URDF hangs a bare ``panda_link9`` (a fixed point 2 cm out) beside ``panda_hand``
    off the last link: both leaves have every joint and, before ``hand`` was an end-effector name,
    neither name broke the tie (an error). A tool or flange name still ranks first."""
    fingers = jaw("panda_finger_joint1", "panda_leftfinger", parent="panda_hand") + jaw(
        "panda_finger_joint2", "panda_rightfinger", parent="panda_hand", mimic='<mimic joint="panda_finger_joint1"/>'
    )
    link9 = '<link name="panda_link9"/><joint name="panda_joint9" type="fixed"><parent link="l2"/><child link="panda_link9"/><origin xyz="0 0 0.02"/></joint>'
    r = jaxstiff.Robot.from_urdf(write(arm(fingers + link9, hand="panda_hand")))
    assert r.tip_link == "panda_hand" and r.joint_names == ("a1", "a2")
    r = jaxstiff.Robot.from_urdf(write(arm(fingers + link9.replace("panda_link9", "panda_flange"), hand="panda_hand")))
    assert r.tip_link == "panda_flange"


def test_a_sensor_frame_is_no_end_effector(write):
    """Baxter hangs ``left_hand_camera``, ``left_hand_camera_axis`` and ``left_hand_range`` beside
    its ``left_gripper``: "hand" made the sensor frames end-effector names, and the automatic tip
    (or the ambiguity error's example) was a camera. A sensor's frame now yields to any other leaf
    with as many joints, and is never an end-effector name."""

    def fixed(link: str, parent: str = "l2") -> str:
        return f'<link name="{link}"/><joint name="{link}_joint" type="fixed"><parent link="{parent}"/><child link="{link}"/></joint>'

    sensors = fixed("wrist_hand_camera") + fixed("wrist_hand_camera_axis") + fixed("wrist_hand_range")
    r = jaxstiff.Robot.from_urdf(write(arm(sensors, hand="wrist_gripper")))
    assert r.tip_link == "wrist_gripper"
    ranked, chosen, _ = tip_candidates(write(arm(sensors, hand="imu_link")))
    by_link = {c.link: c for c in ranked}
    assert by_link["wrist_hand_camera"].sensor and "end-effector name" not in by_link["wrist_hand_camera"].note()
    assert "sensor frame" in by_link["wrist_hand_range"].note()
    assert chosen is None  # only sensor frames: still a tie for the user, not a camera chosen


def test_parallel_jaws_are_cut_off_whatever_their_names(write):
    """Two prismatic joints side by side at the end of the chain, named j3 and j4: a parallel gripper."""
    r = jaxstiff.Robot.from_urdf(write(arm(jaw("j3", "left") + jaw("j4", "right"))))
    assert r.tip_link == "hand" and r.n == 2
    # one prismatic joint alone at the end is an axis of the arm (a lift), not a jaw
    r = jaxstiff.Robot.from_urdf(write(arm(jaw("j3", "slider"))))
    assert r.tip_link == "slider" and r.n == 3


def test_a_prismatic_joint_beside_revolute_ones_is_not_a_jaw(write):
    """Fetch: the torso cover "bellows_joint" (prismatic, nothing below it) hangs off the torso
    beside the head and shoulder joints (revolute). It was cut off as a gripper joint ("any actuated
    joint beside it"); the jaws of a parallel gripper are two prismatic joints side by side."""
    cover = jaw("bellows_joint", "bellows_link", parent="base") + jaw(
        "head_pan", "head", parent="base", kind="revolute"
    )
    ranked, chosen, _ = tip_candidates(write(arm(cover)))
    by_link = {c.link: c for c in ranked}
    assert chosen == "hand" and by_link["bellows_link"].gripper_joint is None
    assert by_link["bellows_link"].joints == 1 and by_link["bellows_link"].note() == ""
    # and a prismatic joint beside a revolute one at the hand is an arm axis too: the tie is the user's
    with pytest.raises(ValueError, match="leaves 'slider', 'twister' each have 3 actuated joints"):
        jaxstiff.Robot.from_urdf(write(arm(jaw("j3", "slider") + jaw("j4", "twister", kind="revolute"))))


def test_mimic_joints_are_counted_apart(write):
    """A leaf behind a mimic joint: the chain cannot hold the mimic joint, so it is not one of the
    "actuated joints" the listing states; the listing adds "+ N mimic" (the rule still compares
    every moving joint: :attr:`TipCandidate.moving`)."""
    fingers = jaw("panda_finger_joint1", "leftfinger") + jaw(
        "panda_finger_joint2", "rightfinger", mimic='<mimic joint="panda_finger_joint1"/>'
    )
    ranked, chosen, _ = tip_candidates(write(arm(fingers)))
    by_link = {c.link: c for c in ranked}
    assert chosen == "hand"
    left, right = by_link["leftfinger"], by_link["rightfinger"]
    assert (left.joints, left.mimic, left.count()) == (3, 0, "3 actuated joints")
    assert (right.joints, right.mimic, right.moving) == (2, 1, 3)
    assert right.count() == "2 actuated joints + 1 mimic"
    with pytest.raises(ValueError, match="mimics joint 'panda_finger_joint1'; mimic joints in the chain"):
        jaxstiff.Robot.from_urdf(write(arm(fingers)), tip_link="rightfinger")


def test_a_revolute_gripper_joint_is_cut_off_by_name(write):
    """A Z1-style gripper: one revolute joint named like a gripper after the arm."""
    r = jaxstiff.Robot.from_urdf(write(arm(jaw("jointGripper", "mover", kind="revolute"))))
    assert r.tip_link == "hand" and r.n == 2
    # an arm joint whose name happens to contain "hand" but which carries more arm is not a gripper
    more = jaw("hand_roll", "wrist", kind="revolute") + jaw("a3", "flange", parent="wrist", kind="revolute")
    r = jaxstiff.Robot.from_urdf(write(arm(more)))
    assert r.tip_link == "flange" and r.joint_names == ("a1", "a2", "hand_roll", "a3")


def test_a_gripper_alone_still_gets_a_tip(write):
    """Nothing but gripper joints move: the rule falls back to every leaf (most joints)."""
    text = f"""<robot name="g"><link name="palm"/><link name="f1"/><link name="f2"/>
    <joint name="finger_1" type="revolute"><parent link="palm"/><child link="f1"/><axis xyz="0 0 1"/>{LIMIT}</joint>
    <joint name="finger_2" type="revolute"><parent link="f1"/><child link="f2"/><origin xyz="0.03 0 0"/>
      <axis xyz="0 0 1"/>{LIMIT}</joint></robot>"""
    assert jaxstiff.Robot.from_urdf(write(text)).tip_link == "f2"


def test_still_ambiguous_lists_every_candidate(write):
    left = jaw("l_joint", "left_end", kind="revolute")
    right = jaw("r_joint", "right_end", kind="revolute")
    with pytest.raises(ValueError) as e:
        jaxstiff.Robot.from_urdf(write(arm(left + right)))
    msg = str(e.value)
    assert "tip link is ambiguous below 'base': leaves 'left_end', 'right_end' each have 3 actuated joints" in msg
    assert "Candidate tips: 'left_end' (3 actuated joints); 'right_end' (3 actuated joints)" in msg
    assert "--tip-link" in msg


def test_unknown_tip_link_suggests_and_lists_every_link():
    """TALOS has 17 links below its base: the error names all of them (the candidate tips first)
    and the near miss."""
    path = str(ROBOTS / "talos_left_arm.urdf")
    with pytest.raises(ValueError) as e:
        jaxstiff.Robot.from_urdf(path, tip_link="arm_left_7_lnk")
    msg = str(e.value)
    assert "unknown tip link 'arm_left_7_lnk' (did you mean 'arm_left_7_link'?)" in msg
    listed = msg.split("(candidate tips first): ")[1]
    with open(path) as fh:
        links = set(re.findall(r'<link name="([^"]+)"', fh.read())) - {"arm_left_1_link"}
    assert set(listed.split(", ")) == links and listed.startswith("gripper_left_base_link, ")
    with pytest.raises(ValueError, match=r"unknown base link 'arm_left_2_lnk' \(did you mean 'arm_left_2_link'\?\)"):
        jaxstiff.Robot.from_urdf(path, base_link="arm_left_2_lnk")


def test_robot_command_lists_candidates_first_the_automatic_one(capsys):
    rc = main(["robot", str(ROBOTS / "z1.urdf")])
    out = capsys.readouterr().out.splitlines()
    assert rc == 0
    i = out.index("candidate tip links below 'world' (automatic choice first; --tip-link to choose another):")
    assert re.fullmatch(r" \* gripperStator\s+6 actuated joints", out[i + 1])
    assert re.fullmatch(r"   gripperMover\s+7 actuated joints  \(through gripper joint 'jointGripper'\)", out[i + 2])
    assert "chain 'world' -> 'gripperStator'" in "\n".join(out)
    rc = main(["robot", str(ROBOTS / "kinova_j2s6s200.urdf")])
    out = capsys.readouterr().out
    assert re.search(r" \* j2s6s200_end_effector\s+6 actuated joints  \(end-effector name\)", out)
    assert re.search(r"   j2s6s200_link_finger_tip_1\s+6 actuated joints  \(finger part\)", out)


def test_robot_command_says_why_there_is_no_automatic_tip(write, capsys):
    """`jaxstiff robot` on a file without an automatic tip printed "the rule leaves a tie" whatever
    the reason, also for a chain of fixed joints with one leaf; it now prints the rule's reason."""
    left = jaw("l_joint", "left_end", kind="revolute")
    right = jaw("r_joint", "right_end", kind="revolute")
    rc = main(["robot", write(arm(left + right))])
    out = capsys.readouterr()
    assert rc == 2
    assert "(no automatic choice: leaves 'left_end', 'right_end' each have 3 actuated joints" in out.out
    assert "pass --tip-link)" in out.out
    fixed = """<?xml version="1.0"?><robot name="fixed"><link name="base"/><link name="l1"/>
      <joint name="j1" type="fixed"><parent link="base"/><child link="l1"/></joint></robot>"""
    rc = main(["robot", write(fixed)])
    out = capsys.readouterr()
    assert rc == 2 and "(no automatic choice: no actuated joint below base link 'base'; nothing to move)" in out.out
    assert "tie" not in out.out
