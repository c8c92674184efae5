"""Bad input gets a clear ValueError/FileNotFoundError naming the problem (issue 2, Build item 5).

Every case checks the message: it must name the file, joint, link or value at fault, and come
from jaxstiff, not from lxml, yourdfpy or inside JAX.
"""

from __future__ import annotations

import os
import re

import jax.numpy as jnp
import numpy as np
import pytest
from helpers import DATA_DIR, one_value_range_planar

import jaxstiff

BRANCHED = str(DATA_DIR / "branched_tree.urdf")

LIMIT = '<limit lower="-1" upper="1" effort="1" velocity="1"/>'


def two_joint_urdf(j1: str = "", j2: str = "", extra: str = "") -> str:
    """base -> (j1, revolute) -> l1 -> (j2, revolute) -> l2; ``j1``/``j2`` replace the joint bodies."""
    j1 = j1 or f'<origin xyz="0 0 0.1" rpy="0 0 0"/><axis xyz="0 0 1"/>{LIMIT}'
    j2 = j2 or f'<origin xyz="1 0 0" rpy="0 0 0"/><axis xyz="0 1 0"/>{LIMIT}'
    return f"""<?xml version="1.0"?>
<robot name="two">
  <link name="base"/><link name="l1"/><link name="l2"/>
  <joint name="j1" type="revolute"><parent link="base"/><child link="l1"/>{j1}</joint>
  <joint name="j2" type="revolute"><parent link="l1"/><child link="l2"/>{j2}</joint>
  {extra}
</robot>"""


@pytest.fixture
def write(tmp_path):
    def _write(text: str, name: str = "robot.urdf") -> str:
        path = tmp_path / name
        path.write_text(text)
        return str(path)

    return _write


def raises(exc, *patterns):
    """pytest.raises whose message must contain every pattern (literal text)."""
    return pytest.raises(exc, match=".*".join(re.escape(p) for p in patterns))


# ------------------------------------------------------------------ files and XML
def test_missing_file(tmp_path):
    path = str(tmp_path / "nowhere.urdf")
    with raises(FileNotFoundError, "URDF file not found", path):
        jaxstiff.Robot.from_urdf(path)


def test_unknown_bare_name_lists_the_shipped_robots():
    with raises(FileNotFoundError, "URDF file not found: kuka_lwr5", "kuka_lwr4", "planar_3r"):
        jaxstiff.Robot.from_urdf("kuka_lwr5")
    with raises(FileNotFoundError, "no shipped robot named 'kuka_lwr5'", "kuka_lwr4"):
        jaxstiff.robot_path("kuka_lwr5")


def test_directory_is_not_a_file(tmp_path):
    with raises(ValueError, str(tmp_path), "is not a regular file"):
        jaxstiff.Robot.from_urdf(tmp_path)


@pytest.mark.parametrize("text", ["<robot name='x'><link name='a'></robot>", "", "not xml at all"])
def test_malformed_xml(write, text):
    path = write(text)
    with raises(ValueError, path, "malformed XML"):
        jaxstiff.Robot.from_urdf(path)


def test_root_must_be_robot(write):
    path = write("<sdf><model name='x'/></sdf>")
    with raises(ValueError, path, "root element must be <robot>", "<sdf>"):
        jaxstiff.Robot.from_urdf(path)


def test_a_xacro_file_is_refused_naming_its_first_macro(write):
    """An unexpanded xacro file read as URDF lost the links and joints its macros make (a 7-joint
    arm loaded with 5 joints, no warning); now refused, naming the element and the fix."""
    wrist = (
        two_joint_urdf()
        .replace('<robot name="two">', '<robot name="two" xmlns:xacro="http://www.ros.org/wiki/xacro">')
        .replace(
            "</robot>", '<xacro:include filename="$(find my_pkg)/wrist.xacro"/>\n<xacro:wrist parent="l2"/></robot>'
        )
    )
    path = write(wrist, "arm.urdf.xacro")
    with raises(ValueError, path, "a xacro file, not a URDF", "<xacro:include>", "xacro arm.urdf.xacro > robot.urdf"):
        jaxstiff.Robot.from_urdf(path)
    # the namespace declared but every macro expanded: a URDF like any other
    expanded = two_joint_urdf().replace(
        '<robot name="two">', '<robot name="two" xmlns:xacro="http://www.ros.org/wiki/xacro">'
    )
    assert jaxstiff.Robot.from_urdf(write(expanded, "expanded.urdf")).n == 2


def test_a_xacro_expression_in_a_number_says_so(write):
    path = write(two_joint_urdf(j1=f'<origin xyz="0 0 ${{l1}}" rpy="0 0 0"/><axis xyz="0 0 1"/>{LIMIT}'))
    with raises(ValueError, "joint 'j1' origin xyz", "${l1}", "a xacro expression"):
        jaxstiff.Robot.from_urdf(path)


BILLION_LAUGHS = """<?xml version="1.0"?>
<!DOCTYPE robot [
  <!ENTITY lol "lol">
  <!ENTITY lol1 "&lol;&lol;&lol;&lol;&lol;&lol;&lol;&lol;&lol;&lol;">
  <!ENTITY lol2 "&lol1;&lol1;&lol1;&lol1;&lol1;&lol1;&lol1;&lol1;&lol1;&lol1;">
  <!ENTITY lol3 "&lol2;&lol2;&lol2;&lol2;&lol2;&lol2;&lol2;&lol2;&lol2;&lol2;">
  <!ENTITY lol4 "&lol3;&lol3;&lol3;&lol3;&lol3;&lol3;&lol3;&lol3;&lol3;&lol3;">
  <!ENTITY lol5 "&lol4;&lol4;&lol4;&lol4;&lol4;&lol4;&lol4;&lol4;&lol4;&lol4;">
  <!ENTITY lol6 "&lol5;&lol5;&lol5;&lol5;&lol5;&lol5;&lol5;&lol5;&lol5;&lol5;">
  <!ENTITY lol7 "&lol6;&lol6;&lol6;&lol6;&lol6;&lol6;&lol6;&lol6;&lol6;&lol6;">
  <!ENTITY lol8 "&lol7;&lol7;&lol7;&lol7;&lol7;&lol7;&lol7;&lol7;&lol7;&lol7;">
  <!ENTITY lol9 "&lol8;&lol8;&lol8;&lol8;&lol8;&lol8;&lol8;&lol8;&lol8;&lol8;">
]>
<robot name="&lol9;"><link name="a"/><link name="b"/>
  <joint name="j" type="continuous"><parent link="a"/><child link="b"/></joint></robot>
"""


def test_billion_laughs_is_refused_without_expanding(write):
    """10^9 'lol's would need gigabytes; the guard refuses the DOCTYPE before any expansion."""
    path = write(BILLION_LAUGHS)
    with raises(ValueError, path, "DOCTYPE/XML entities; refused"):
        jaxstiff.Robot.from_urdf(path)


@pytest.mark.parametrize(
    "doctype",
    [
        '<!DOCTYPE robot [<!ENTITY xxe SYSTEM "file://{secret}">]>',
        '<!DOCTYPE robot SYSTEM "file://{secret}">',
        '<!DOCTYPE robot [<!ENTITY % p SYSTEM "file://{secret}"> %p;]>',
    ],
    ids=["external-entity", "external-dtd", "parameter-entity"],
)
def test_external_entities_are_refused_and_never_read(write, tmp_path, doctype):
    secret = tmp_path / "secret.txt"
    secret.write_text("TOP-SECRET-CONTENT")
    text = (
        '<?xml version="1.0"?>' + doctype.format(secret=secret) + '<robot name="&xxe;"><link name="a"/>'
        '<link name="b"/><joint name="j" type="continuous"><parent link="a"/><child link="b"/></joint></robot>'
    )
    path = write(text)
    with raises(ValueError, path, "refused") as info:
        jaxstiff.Robot.from_urdf(path)
    assert "TOP-SECRET" not in str(info.value)


def test_undeclared_entity_is_malformed_not_resolved(write):
    path = write(two_joint_urdf().replace('name="two"', 'name="&xxe;"'))
    with raises(ValueError, path, "malformed XML"):
        jaxstiff.Robot.from_urdf(path)


# ------------------------------------------------------------------ tree structure, links
def test_unknown_base_link():
    with raises(ValueError, "unknown base link 'shoulder'", "links: world"):
        jaxstiff.Robot.from_urdf(BRANCHED, base_link="shoulder", tip_link="tool")


def test_unknown_tip_link():
    with raises(ValueError, "unknown tip link 'gripper'", "tool"):
        jaxstiff.Robot.from_urdf(BRANCHED, tip_link="gripper")


def test_no_path_between_base_and_tip():
    with raises(ValueError, "no kinematic chain from base link 'side_link' to tip link 'tool'"):
        jaxstiff.Robot.from_urdf(BRANCHED, base_link="side_link", tip_link="tool")
    with raises(ValueError, "no kinematic chain from base link 'link_4' to tip link 'link_1'", "below the base"):
        jaxstiff.Robot.from_urdf(BRANCHED, base_link="link_4", tip_link="link_1")


def test_ambiguous_tip(write):
    """Two leaves through the same four joints, neither an end-effector name nor a sensor's frame
    ('tool' renamed 'probe', 'camera' renamed 'bracket'): the error lists both (with "tool" the
    name breaks the tie, and a "camera" yields to any other leaf: test_tip_rules.py)."""
    with open(BRANCHED) as fh:
        text = fh.read()
    path = write(text.replace('"tool"', '"probe"').replace('"camera"', '"bracket"'))
    with raises(
        ValueError,
        "tip link is ambiguous below 'world'",
        "leaves 'bracket', 'probe' each have 4 actuated joints",
        "pass tip_link (command line: --tip-link)",
        "Candidate tips: 'bracket' (4 actuated joints); 'probe' (4 actuated joints); 'side_link'",
    ):
        jaxstiff.Robot.from_urdf(path)
    # the camera kept: a sensor's frame is no tip where another leaf has as many joints
    assert jaxstiff.Robot.from_urdf(write(text.replace('"tool"', '"probe"'), "cam.urdf")).tip_link == "probe"


def test_chain_without_actuated_joints():
    with raises(ValueError, "chain 'link_3' -> 'link_3b' has no actuated joint"):
        jaxstiff.Robot.from_urdf(BRANCHED, base_link="link_3", tip_link="link_3b")
    with raises(ValueError, "no actuated joint below base link 'link_4'"):
        jaxstiff.Robot.from_urdf(BRANCHED, base_link="link_4")


@pytest.mark.parametrize(
    "extra,message",
    [
        ('<link name="l1"/>', "duplicate link names: l1"),
        (
            '<link name="l3"/><joint name="j2" type="fixed"><parent link="l2"/><child link="l3"/></joint>',
            "duplicate joint names: j2",
        ),
        (
            '<link name="l3"/><joint name="j3" type="fixed"><parent link="base"/><child link="l2"/></joint>',
            "link 'l2' is the child of two joints",
        ),
        (
            '<joint name="j3" type="fixed"><parent link="l2"/><child link="ghost"/></joint>',
            "joint 'j3' names unknown child link 'ghost'",
        ),
        ('<joint name="j3" type="fixed"><parent link="l2"/></joint>', "joint 'j3' has no <child link=...>"),
        (
            '<joint name="j3" type="ball"><parent link="l2"/><child link="l2"/></joint>',
            "joint 'j3' has unknown type 'ball'",
        ),
    ],
    ids=["duplicate-link", "duplicate-joint", "two-parents", "unknown-link", "no-child", "unknown-type"],
)
def test_broken_trees(write, extra, message):
    path = write(two_joint_urdf(extra=extra))
    with raises(ValueError, path, message):
        jaxstiff.Robot.from_urdf(path)


def test_several_roots_need_a_base_link(write):
    path = write(two_joint_urdf(extra='<link name="floating_box"/>'))
    with raises(ValueError, "several root links", "floating_box", "choose one with base_link= (--base-link)"):
        jaxstiff.Robot.from_urdf(path)
    assert jaxstiff.Robot.from_urdf(path, base_link="base").n == 2


# ------------------------------------------------------------------ joint contents
@pytest.mark.parametrize(
    "j2,message",
    [
        (f'<axis xyz="0 0 0"/>{LIMIT}', "joint 'j2' has a zero or non-finite axis [0.0, 0.0, 0.0]"),
        (f'<axis xyz="0 nan 1"/>{LIMIT}', "joint 'j2' axis must be 3 finite numbers"),
        (f'<axis xyz="0 1"/>{LIMIT}', "joint 'j2' axis must be 3 finite numbers, got [0.0, 1.0]"),
        (f'<axis xyz="0 one 0"/>{LIMIT}', "joint 'j2' axis: cannot read numbers from '0 one 0'"),
        (f'<origin xyz="1 NaN 0"/><axis xyz="0 0 1"/>{LIMIT}', "joint 'j2' origin xyz has NaN or Inf"),
        (f'<origin xyz="1 0 0" rpy="0 inf 0"/><axis xyz="0 0 1"/>{LIMIT}', "joint 'j2' origin rpy has NaN or Inf"),
        (f'<origin xyz="1 0 1e999"/><axis xyz="0 0 1"/>{LIMIT}', "joint 'j2' origin xyz has NaN or Inf"),
        (f'<origin xyz="1 0"/><axis xyz="0 0 1"/>{LIMIT}', "joint 'j2' origin xyz needs 3 numbers"),
        (
            '<axis xyz="0 0 1"/><limit lower="nan" upper="1" effort="1" velocity="1"/>',
            "joint 'j2' limit lower must be a finite number, got 'nan'",
        ),
        (
            '<axis xyz="0 0 1"/><limit lower="-1" upper="inf" effort="1" velocity="1"/>',
            "joint 'j2' limit upper must be a finite number, got 'inf'",
        ),
        (
            '<axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="NaN" velocity="1"/>',
            "joint 'j2' limit effort must be a finite number",
        ),
        (
            '<axis xyz="0 0 1"/><limit lower="1" upper="-1" effort="1" velocity="1"/>',
            "joint 'j2' has lower limit 1 > upper limit -1",
        ),
        ('<axis xyz="0 0 1"/>', "revolute joint 'j2' has no <limit>; URDF requires one"),
    ],
    ids=[
        "zero-axis",
        "nan-axis",
        "short-axis",
        "text-axis",
        "nan-xyz",
        "inf-rpy",
        "overflow-xyz",
        "short-xyz",
        "nan-lower",
        "inf-upper",
        "nan-effort",
        "lower>upper",
        "no-limit",
    ],
)
def test_bad_joint_numbers(write, j2, message):
    path = write(two_joint_urdf(j2=j2))
    with raises(ValueError, path, message):
        jaxstiff.Robot.from_urdf(path)


def test_a_prismatic_joint_without_limit_gets_no_revolute_hint(write):
    path = write(
        two_joint_urdf(j2='<axis xyz="1 0 0"/>').replace('name="j2" type="revolute"', 'name="j2" type="prismatic"')
    )
    with pytest.raises(ValueError, match=r"prismatic joint 'j2' has no <limit>; URDF requires one$"):
        jaxstiff.Robot.from_urdf(path)


def test_a_robot_without_a_name_attribute_is_read_under_its_file_name(write):
    """<robot> without name= (URDF requires it, yourdfpy raised a bare KeyError): the name is only
    a label, so the file's name stands in; the kinematics are those of the named file."""
    named = jaxstiff.Robot.from_urdf(write(two_joint_urdf(), "named.urdf"))
    robot = jaxstiff.Robot.from_urdf(write(two_joint_urdf().replace('<robot name="two">', "<robot>"), "anon.urdf"))
    assert robot.name == "anon" and robot.joint_names == ("j1", "j2")
    q = np.array([0.3, -0.7])
    np.testing.assert_array_equal(np.asarray(robot.fk(q)), np.asarray(named.fk(q)))


def test_bad_numbers_in_a_fixed_joint_outside_the_chain(write):
    """NaN anywhere in the file is refused, even on a joint the chain does not use."""
    path = write(
        two_joint_urdf(
            extra='<link name="s"/><joint name="cam" type="fixed"><parent link="l1"/>'
            '<child link="s"/><origin xyz="0 0 nan"/></joint>'
        )
    )
    with raises(ValueError, "joint 'cam' origin xyz has NaN or Inf"):
        jaxstiff.Robot.from_urdf(path, tip_link="l2")


def test_mimic_joint_in_the_chain_is_refused_by_name(write):
    path = write(
        two_joint_urdf(j2=f'<origin xyz="1 0 0"/><axis xyz="0 0 1"/>{LIMIT}<mimic joint="j1" multiplier="2"/>')
    )
    with raises(
        ValueError,
        path,
        "joint 'j2' mimics joint 'j1'",
        "not supported",
        "locking it does not help",
        "choose a tip link above it",
        "--tip-link",
    ):
        jaxstiff.Robot.from_urdf(path)
    with raises(ValueError, "joint 'j2' mimics joint 'j1'"):  # the hint is right: a lock does not help
        jaxstiff.Robot.from_urdf(path, locked={"j2": 0.0})
    # a chain that stops before the mimic joint is fine
    assert jaxstiff.Robot.from_urdf(path, tip_link="l1").joint_names == ("j1",)


@pytest.mark.parametrize("kind", ["floating", "planar"])
def test_floating_and_planar_joints_are_refused_by_name(write, kind):
    path = write(two_joint_urdf().replace('name="j2" type="revolute"', f'name="j2" type="{kind}"'))
    with raises(ValueError, path, f"joint 'j2' is {kind}", "only revolute, continuous, prismatic and fixed"):
        jaxstiff.Robot.from_urdf(path)


# ------------------------------------------------------------------ locks, TCP
def test_locked_value_outside_limits():
    with raises(ValueError, "locked value 3 of joint 'lwr_a2' is outside its limits [-2.0944, 2.0944]"):
        jaxstiff.Robot.from_urdf("kuka_lwr4", locked={"lwr_a2": 3.0})


@pytest.mark.parametrize(
    "locked,message",
    [
        (
            {"lwr_a8": 0.0},
            "cannot lock unknown joint 'lwr_a8' (did you mean 'lwr_a7'?); actuated joints of the chain: lwr_a1",
        ),
        ({"lwr_a_3": 0.0}, "cannot lock unknown joint 'lwr_a_3' (did you mean 'lwr_a3'?)"),
        ({"lwr_a7": float("nan")}, "locked value of joint 'lwr_a7' must be finite, got nan"),
        ({"lwr_a7": "zero"}, "locked value of joint 'lwr_a7' must be a number, got 'zero'"),
        ([("lwr_a7", 0.0)], "locked must be a mapping"),
        # the fixed joint between lwr_link_7 and lwr_flange: it is in the URDF, and on the chain
        ({"lwr_flange_joint": 0.0}, "cannot lock joint 'lwr_flange_joint': it is a fixed joint (it never moves"),
    ],
)
def test_bad_locks(locked, message):
    with raises(ValueError, message):
        jaxstiff.Robot.from_urdf("kuka_lwr4", locked=locked)


#: a Panda-like hand on two_joint_urdf: a fixed joint j8 on the chain to "hand", a fixed joint j9
#: off it, and two prismatic fingers, finger2 a mimic of finger1
HAND = f"""<link name="hand"/><joint name="j8" type="fixed"><parent link="l2"/><child link="hand"/>
  <origin xyz="0.1 0 0"/></joint>
  <link name="l9"/><joint name="j9" type="fixed"><parent link="l1"/><child link="l9"/></joint>
  <link name="lf"/><joint name="finger1" type="prismatic"><parent link="hand"/><child link="lf"/>
    <axis xyz="0 1 0"/>{LIMIT}</joint>
  <link name="rf"/><joint name="finger2" type="prismatic"><parent link="hand"/><child link="rf"/>
    <axis xyz="0 -1 0"/>{LIMIT}<mimic joint="finger1"/></joint>"""


@pytest.mark.parametrize(
    "joint,parts,not_said",
    [
        # a fixed joint on the chain was "unknown"; one off the chain got "choose base_link / tip_link
        # for a chain through it", which no chain has: both are fixed, nothing to lock
        (
            "j8",
            ["cannot lock joint 'j8': it is a fixed joint (it never moves, so there is nothing to lock)"],
            "unknown",
        ),
        ("j9", ["cannot lock joint 'j9': it is a fixed joint", "actuated joints can be locked: j1, j2"], "tip_link"),
        ("finger2", ["cannot lock joint 'finger2': it mimics joint 'finger1'", "no chain can hold"], "tip_link"),
        # an actuated joint on another branch keeps its advice
        ("finger1", ["cannot lock joint 'finger1': it is in the URDF but not on the chain", "--tip-link"], "unknown"),
        # near misses: the chain's joints first, then the URDF's others
        ("j_2", ["cannot lock unknown joint 'j_2' (did you mean 'j2'?); actuated joints of the chain: j1, j2"], "j9"),
        ("fnger1", ["cannot lock unknown joint 'fnger1' (did you mean 'finger1'?)"], "finger2"),
    ],
)
def test_lock_messages_name_fixed_and_mimic_joints_and_near_misses(write, joint, parts, not_said):
    path = write(two_joint_urdf(extra=HAND))
    with pytest.raises(ValueError) as e:
        jaxstiff.Robot.from_urdf(path, tip_link="hand", locked={joint: 0.0})
    msg = str(e.value)
    assert all(p in msg for p in parts) and not_said not in msg, msg
    if joint == "j_2":  # the same check on a built robot (Chain.with_locked)
        with raises(ValueError, "cannot lock unknown joint 'j_2' (did you mean 'j2'?)"):
            jaxstiff.Robot.from_urdf(path, tip_link="hand").with_locked({"j_2": 0.0})


@pytest.mark.parametrize(
    "tcp,message",
    [
        ([0.0, 0.1], "tcp must be a 3-vector (m), a 6-vector x,y,z,roll,pitch,yaw (m, rad) or a 4x4 transform"),
        ("0 0 0.1", "tcp must be a 3-vector (m), a 6-vector x,y,z,roll,pitch,yaw (m, rad) or a 4x4 transform"),
        ([0.0, np.nan, 0.1], "tcp contains NaN or Inf"),
        (np.diag([2.0, 1.0, 1.0, 1.0]), "orthonormal rotation block"),
    ],
)
def test_bad_tcp(tcp, message):
    with raises(ValueError, message):
        jaxstiff.Robot.from_urdf("kuka_lwr4", tcp=tcp)


def test_tcp_six_values_as_the_command_line_takes_them():
    """Robot.from_urdf takes tcp=(x, y, z, roll, pitch, yaw) like --tcp: the same tip transform as
    the 4x4 built independently here, R = Rz(yaw) Ry(pitch) Rx(roll)."""
    x, y, z, r, p, w = 0.01, -0.02, 0.1, 0.3, -0.2, 0.5

    def rot(axis, a):
        c, s = np.cos(a), np.sin(a)
        i, j = [(1, 2), (0, 2), (0, 1)][axis]
        R = np.eye(3)
        R[i, i], R[j, j] = c, c
        R[i, j], R[j, i] = (-s, s) if axis != 1 else (s, -s)
        return R

    T = np.eye(4)
    T[:3, :3] = rot(2, w) @ rot(1, p) @ rot(0, r)
    T[:3, 3] = [x, y, z]
    six = jaxstiff.Robot.from_urdf("kuka_lwr4", tcp=(x, y, z, r, p, w))
    mat = jaxstiff.Robot.from_urdf("kuka_lwr4", tcp=T)
    np.testing.assert_allclose(six.tip_matrix, mat.tip_matrix, atol=1e-15)


# ------------------------------------------------------------------ q at the call
@pytest.fixture(scope="module")
def lwr():
    return jaxstiff.Robot.from_urdf("kuka_lwr4")


@pytest.mark.parametrize("call", ["method", "function"])
@pytest.mark.parametrize("shape", [(6,), (2, 8), ()])
def test_q_of_wrong_shape(lwr, call, shape):
    q = jnp.zeros(shape)
    f = lwr.fk_and_jacobian if call == "method" else (lambda x: jaxstiff.fk_and_jacobian(lwr, x))
    with raises(ValueError, "q must have shape (..., 7)", f"got {tuple(shape)}" if call == "function" else "got shape"):
        f(q)


@pytest.mark.parametrize("call", ["method", "function"])
@pytest.mark.parametrize("dtype", [jnp.int32, jnp.bool_, jnp.complex64])
def test_q_of_wrong_dtype(lwr, call, dtype):
    q = jnp.zeros(7, dtype=dtype)
    f = lwr.fk if call == "method" else (lambda x: jaxstiff.jacobian(lwr, x))
    with raises(ValueError, "q must have a floating dtype"):
        f(q)


def test_q_with_nan_or_inf_at_the_boundary(lwr):
    with raises(ValueError, "q contains NaN or Inf: q[2] = nan (joint 'lwr_a3' of robot"):
        lwr.fk(np.array([0, 0, np.nan, 0, 0, 0, 0.0]))
    with raises(ValueError, "q contains NaN or Inf: q[1, 6] = inf (joint 'lwr_a7'"):
        lwr.jacobian(np.array([[0.0] * 7, [0.0] * 6 + [np.inf]]))
    # the jitted functions check shapes, not values: NaN in, NaN out (documented)
    assert np.all(np.isnan(np.asarray(jaxstiff.fk(lwr, jnp.array([0, 0, np.nan, 0, 0, 0, 0.0])))[:3, 3]))
    with raises(ValueError, "q must be an array of numbers of shape (..., 7)"):
        lwr.jacobian("0 0 0 0 0 0 0")


def test_robot_argument_must_be_a_robot():
    with raises(TypeError, "robot must be a jaxstiff.Robot, got str"):
        jaxstiff.fk("kuka_lwr4", jnp.zeros(7))


@pytest.mark.parametrize("rows", [(6,), (), (0, -1), (0.0, 1)])
def test_position_and_jacobian_rows_are_checked(lwr, rows):
    with raises(ValueError, "rows must be a non-empty tuple of Jacobian row indices in 0..5"):
        jaxstiff.position_and_jacobian(lwr, jnp.zeros(7), rows)


def test_cli_prints_a_urdf_warning_as_one_line(write, capsys):
    """A joint with an empty range warns (UserWarning from Python); the command line prints it as
    one 'jaxstiff: warning:' line like its other warnings, without Python's file:line and source."""
    from jaxstiff.cli import main as cli_main

    path = write(two_joint_urdf(j2='<origin xyz="1 0 0"/><axis xyz="0 0 1"/><limit effort="1" velocity="1"/>'))
    with pytest.warns(UserWarning, match="empty range"):  # the Python API keeps a real warning
        jaxstiff.Robot.from_urdf(path)
    rc = cli_main(
        [
            "csc",
            "--robot",
            path,
            "--hold",
            "1,0",
            "--kxd",
            "bad",
            "--q0",
            "0,0",
            "--out",
            os.path.join(os.path.dirname(path), "r.npz"),
        ]
    )
    err = capsys.readouterr().err
    assert rc == 2 and "jaxstiff: error:" in err
    lines = [ln for ln in err.splitlines() if "empty range" in ln]
    assert len(lines) == 1 and lines[0].startswith("jaxstiff: warning: ") and path in lines[0], err
    assert "UserWarning" not in err and ".py:" not in err, err


def test_many_unconnected_links_give_a_short_message(tmp_path):
    """200,000 unconnected links (the audit used 2,000,000: a 22.9 MB one-line error): the message
    names a few roots and the count, and stays short."""
    f = tmp_path / "many.urdf"
    links = "".join(f'<link name="l{i}"/>' for i in range(200_000))
    f.write_text(f'<robot name="many">{links}</robot>')
    with pytest.raises(ValueError) as e:
        jaxstiff.Robot.from_urdf(str(f))
    msg = str(e.value)
    assert "several root links (l0, l1" in msg and "(200000 in all)" in msg and len(msg) < 2000, msg[:300]


def test_fifo_is_not_a_regular_file(tmp_path):
    fifo = tmp_path / "robot.urdf"
    os.mkfifo(fifo)
    with raises(ValueError, str(fifo), "is not a regular file: it is a FIFO"):
        jaxstiff.Robot.from_urdf(str(fifo))


def test_a_leaf_behind_a_mimic_joint_is_never_the_default_tip(write):
    # an independent check: the default tip was the side branch with the most joints, through a mimic
    # joint, and the error was about the mimic joint although the main chain was fine
    side = (
        f'<link name="s1"/><link name="s2"/>'
        f'<joint name="m1" type="revolute"><parent link="l1"/><child link="s1"/><origin xyz="0 1 0"/>'
        f'<axis xyz="0 0 1"/>{LIMIT}<mimic joint="j1"/></joint>'
        f'<joint name="m2" type="revolute"><parent link="s1"/><child link="s2"/><origin xyz="1 0 0"/>'
        f'<axis xyz="0 0 1"/>{LIMIT}</joint>'
    )
    path = write(two_joint_urdf(extra=side))
    with raises(ValueError, "tip link is ambiguous", "'s2' (behind mimic joint 'm1')", "--tip-link"):
        jaxstiff.Robot.from_urdf(path)
    assert jaxstiff.Robot.from_urdf(path, tip_link="l2").joint_names == ("j1", "j2")


def test_a_floating_joint_names_the_base_link_to_choose(write):
    path = write(two_joint_urdf().replace('name="j1" type="revolute"', 'name="j1" type="floating"'))
    with raises(ValueError, "joint 'j1' is floating", "choose a base link below it ('l1'", "--base-link"):
        jaxstiff.Robot.from_urdf(path)


def test_a_command_that_reads_the_urdf_twice_warns_once(tmp_path, monkeypatch, capsys):
    """`jaxstiff csc --robot one.urdf` (a relative path) printed the empty-range warning twice, once
    with the path as given and once made absolute (the command reads the robot for its checks and
    again for its run). The warning names the absolute path and a command prints each once."""
    from jaxstiff.cli import main as cli_main

    one_value_range_planar(tmp_path, "one.urdf")
    monkeypatch.chdir(tmp_path)
    with pytest.warns(UserWarning, match="empty range"):
        robot = jaxstiff.Robot.from_urdf("one.urdf")
    x, y = np.asarray(robot.fk(np.array([0.4, 0.8, -0.6, 0.9])))[:2, 3]
    argv = ["csc", "--robot", "one.urdf", "--hold", f"{float(x)!r},{float(y)!r}", "--steps", "3", "--kxd", "3000,1000"]
    rc = cli_main([*argv, "--q0", "0.4,0.8,-0.6,0.9", "--out", "r.npz"])
    err = capsys.readouterr().err
    lines = [ln for ln in err.splitlines() if "empty range" in ln]
    assert len(lines) == 1, err
    assert lines[0].startswith(f"jaxstiff: warning: {tmp_path / 'one.urdf'}: revolute joint 'a3'"), lines[0]
    assert rc == 0, err
