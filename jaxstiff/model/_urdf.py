"""URDF -> chain data (the fields of :class:`jaxstiff.model._chain.Chain`). Safe XML parsing (no entities, no network, no DTD).

The elements a chain needs (links; joints with type, parent, child, origin, axis, limit, mimic) are
read here into :class:`UrdfJoint` records, with the numbers yourdfpy gives bit for bit (origin
``T(xyz) @ R(rpy)``, R = Rz(yaw) Ry(pitch) Rx(roll); ``tests/view/test_startup.py`` checks it):
reading a URDF imports neither yourdfpy nor trimesh (about 2 s), so ``jaxstiff view`` starts fast.

A URDF is untrusted input: the XML is parsed with entity resolution, DTD loading and network
access switched off, and any document that declares a DOCTYPE with entities is refused before
anything expands (billion-laughs and external-entity files are rejected in microseconds).
"""

from __future__ import annotations

import dataclasses
import math
import os
import re
import warnings
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from jaxstiff.model._chain import JOINT_PRISMATIC, JOINT_REVOLUTE, check_locked, mat_to_tuple, snap, tcp_matrix
from jaxstiff.model._shipped import robot_path, shipped_robots
from jaxstiff.runtime._io import check_regular_file
from jaxstiff.runtime._messages import short_list, short_text, suggest

_MOVABLE = {"revolute": JOINT_REVOLUTE, "continuous": JOINT_REVOLUTE, "prismatic": JOINT_PRISMATIC}
_KNOWN = set(_MOVABLE) | {"fixed", "floating", "planar"}
_DOCTYPE = re.compile(rb"<!DOCTYPE", re.IGNORECASE)
_ENTITY = re.compile(rb"<!ENTITY", re.IGNORECASE)


def _read_xml(path: str) -> Any:
    from lxml import etree  # pyright: ignore[reportAttributeAccessIssue]  (lxml ships no stubs for it)

    with open(path, "rb") as fh:
        data = fh.read()
    if _ENTITY.search(data) or _DOCTYPE.search(data):
        raise ValueError(
            f"{path}: the URDF declares a DOCTYPE/XML entities; refused (entities can expand "
            f"without bound or read other files, and URDF never needs them)"
        )
    parser = etree.XMLParser(
        resolve_entities=False, no_network=True, load_dtd=False, huge_tree=False, remove_blank_text=True
    )
    try:
        root = etree.fromstring(data, parser=parser)
    except etree.XMLSyntaxError as exc:
        raise ValueError(f"{path}: malformed XML: {exc}") from None
    if root is None or root.tag != "robot":
        tag = None if root is None else root.tag
        raise ValueError(f"{path}: the root element must be <robot>, got <{tag}>")
    for elem in root.iter():
        # a xacro macro, property or include: read as URDF it would drop the links and joints it makes
        if isinstance(elem.tag, str) and elem.tag.startswith("{") and "xacro" in elem.tag.lower():
            name = elem.tag.rpartition("}")[2]
            raise ValueError(
                f"{path}: a xacro file, not a URDF (<xacro:{name}> at line {elem.sourceline}); expand it "
                f"first, e.g. `xacro {os.path.basename(path)} > robot.urdf` (ROS's xacro package)"
            )
    return root


def _float_attr(path: str, where: str, text: str) -> list[float]:
    try:
        return [float(v) for v in text.split()]
    except ValueError:
        hint = " (a xacro expression: expand the file with xacro first)" if "${" in text or "$(" in text else ""
        raise ValueError(f"{path}: {where}: cannot read numbers from {short_text(text)}{hint}") from None


def _check_joint_xml(path: str, elem: Any) -> None:  # noqa: C901 - a flat list of independent checks of one element
    """The joint element checked: name, known type, parent/child, finite origin, axis and limits."""
    name = elem.get("name")
    if not name:
        raise ValueError(f"{path}: a <joint> has no name attribute")
    jtype = elem.get("type")
    if jtype not in _KNOWN:
        raise ValueError(f"{path}: joint {name!r} has unknown type {jtype!r}")
    for tag in ("parent", "child"):
        sub = elem.find(tag)
        if sub is None or not sub.get("link"):
            raise ValueError(f"{path}: joint {name!r} has no <{tag} link=...>")
    origin = elem.find("origin")
    if origin is not None:
        for attr in ("xyz", "rpy"):
            if origin.get(attr) is not None:
                vals = _float_attr(path, f"joint {name!r} origin {attr}", origin.get(attr))
                if len(vals) != 3:
                    raise ValueError(f"{path}: joint {name!r} origin {attr} needs 3 numbers, got [{short_list(vals)}]")
                if not all(math.isfinite(v) for v in vals):
                    raise ValueError(f"{path}: joint {name!r} origin {attr} has NaN or Inf: {vals}")
    axis = elem.find("axis")
    if axis is not None and axis.get("xyz") is not None:
        vals = _float_attr(path, f"joint {name!r} axis", axis.get("xyz"))
        if len(vals) != 3 or not all(math.isfinite(v) for v in vals):
            raise ValueError(f"{path}: joint {name!r} axis must be 3 finite numbers, got {vals}")
    limit = elem.find("limit")
    if limit is not None:
        for attr in ("lower", "upper", "effort", "velocity"):
            if limit.get(attr) is not None:
                vals = _float_attr(path, f"joint {name!r} limit {attr}", limit.get(attr))
                if len(vals) != 1 or math.isnan(vals[0]) or (attr in ("lower", "upper") and math.isinf(vals[0])):
                    raise ValueError(
                        f"{path}: joint {name!r} limit {attr} must be a finite number, got {limit.get(attr)!r}"
                    )


def _resolve_path(path: str | os.PathLike) -> str:
    """The URDF file to read: ``path`` itself, or the shipped robot of that name."""
    if not isinstance(path, (str, os.PathLike)):
        raise TypeError(
            f"a URDF must be given as a file name or a shipped robot's name ({', '.join(shipped_robots())}), "
            f"got {type(path).__name__}"
        )
    path = os.fspath(path)
    if not isinstance(path, str):  # a bytes path
        path = os.fsdecode(path)
    if not os.path.exists(path) and os.sep not in path and not path.endswith(".urdf"):
        try:
            path = robot_path(path)  # a shipped robot's name
        except FileNotFoundError:
            raise FileNotFoundError(
                f"URDF file not found: {path} (nor a shipped robot of that name; shipped robots: "
                f"{', '.join(shipped_robots())})"
            ) from None
    if not os.path.exists(path):
        raise FileNotFoundError(f"URDF file not found: {path}")
    return check_regular_file(path, "URDF file")  # not a folder, FIFO or device


@dataclasses.dataclass(frozen=True)
class UrdfLimit:
    """A ``<limit>``: ``lower`` / ``upper`` (rad or m), None where the attribute is missing."""

    lower: float | None
    upper: float | None


@dataclasses.dataclass(frozen=True)
class UrdfJoint:
    """The fields of a URDF ``<joint>`` a chain needs: ``origin`` a 4x4 transform (None without
    ``<origin>``), ``axis`` (URDF default x), ``limit`` and ``mimic`` (the mimicked joint's name)."""

    name: str
    type: str
    parent: str
    child: str
    origin: np.ndarray | None
    axis: np.ndarray
    limit: UrdfLimit | None
    mimic: str | None


@dataclasses.dataclass(frozen=True)
class UrdfModel:
    """The robot's name, its link names (file order) and its joints (file order)."""

    name: str
    links: list[str]
    joints: list[UrdfJoint]


def urdf_origin(xyz: str, rpy: str) -> np.ndarray:
    """4x4 transform of ``<origin xyz rpy>``: translation xyz, rotation Rz(yaw) Ry(pitch) Rx(roll)."""
    t = [float(v) for v in xyz.split()]
    r, p, y = (float(v) for v in rpy.split())
    sr, sp, sy = math.sin(r), math.sin(p), math.sin(y)
    cr, cp, cy = math.cos(r), math.cos(p), math.cos(y)
    T = np.eye(4)
    T[:3, :3] = [
        [cp * cy, sp * (sr * cy) - cr * sy, sp * (cr * cy) + sr * sy],
        [cp * sy, sp * (sr * sy) + cr * cy, sp * (cr * sy) - sr * cy],
        [-sp, cp * sr, cp * cr],
    ]
    T[:3, 3] = t
    return T


def _joint(elem: Any) -> UrdfJoint:
    """One checked ``<joint>`` element (:func:`_check_joint_xml` ran before)."""
    origin, axis, limit, mimic = (elem.find(t) for t in ("origin", "axis", "limit", "mimic"))
    bound = [None if limit is None or limit.get(a) is None else float(limit.get(a)) for a in ("lower", "upper")]
    return UrdfJoint(
        name=str(elem.get("name")),
        type=str(elem.get("type")),
        parent=str(elem.find("parent").get("link")),
        child=str(elem.find("child").get("link")),
        origin=None if origin is None else urdf_origin(origin.get("xyz", "0 0 0"), origin.get("rpy", "0 0 0")),
        axis=np.array([float(v) for v in (axis.get("xyz", "1 0 0") if axis is not None else "1 0 0").split()]),
        limit=None if limit is None else UrdfLimit(*bound),
        mimic=None if mimic is None else mimic.get("joint"),
    )


def parse_urdf_model(path: str) -> UrdfModel:
    """The checked XML of ``path`` read into a :class:`UrdfModel`."""
    root = _read_xml(path)
    for elem in root.findall("joint"):
        _check_joint_xml(path, elem)
    for elem in root.findall("link"):
        if not elem.get("name"):
            raise ValueError(f"{path}: a <link> has no name attribute")
    # URDF requires <robot name=...>; the name is only a label here: the file's name stands in for it
    name = root.get("name") or os.path.splitext(os.path.basename(path))[0]
    links = [str(link.get("name")) for link in root.findall("link")]
    return UrdfModel(name, links, [_joint(j) for j in root.findall("joint")])


@dataclasses.dataclass(frozen=True)
class _Tree:
    """The URDF's link tree: link names in file order, each child link's joint, each link's child joints."""

    links: list[str]
    parent_joint: dict[str, Any]
    children: dict[str, list[Any]]

    def below(self, link: str) -> list[str]:
        """Every link below ``link`` (depth first, file order among siblings)."""
        out, stack = [], [j.child for j in reversed(self.children[link])]
        while stack:
            l = stack.pop()
            out.append(l)
            stack.extend(j.child for j in reversed(self.children[l]))
        return out

    def chain_below(self, link: str) -> list[Any]:
        """Every joint below ``link``."""
        out, stack = [], [link]
        while stack:
            for j in self.children[stack.pop()]:
                out.append(j)
                stack.append(j.child)
        return out

    def chain_to(self, base_link: str, tip: str) -> list[Any]:
        """The joints from ``base_link`` down to ``tip`` (base first), or [] if ``tip`` is not below it."""
        chain, link, seen = [], tip, set()
        while link != base_link:
            if link in seen or link not in self.parent_joint:
                return []
            seen.add(link)
            j = self.parent_joint[link]
            chain.append(j)
            link = j.parent
        return chain[::-1]


def _link_tree(path: str, model: UrdfModel) -> _Tree:
    """The link tree of ``model``; a ValueError for duplicate names, unknown links, or a link with two parents."""
    links = list(model.links)
    if len(set(links)) != len(links):
        dup = sorted({l for l in links if links.count(l) > 1})
        raise ValueError(f"{path}: duplicate link names: {short_list(dup)}")
    joints = {j.name: j for j in model.joints}
    if len(joints) != len(model.joints):
        names = [j.name for j in model.joints]
        raise ValueError(
            f"{path}: duplicate joint names: {short_list(sorted({n for n in names if names.count(n) > 1}))}"
        )
    link_set = set(links)
    parent_joint: dict[str, Any] = {}
    children: dict[str, list[Any]] = {l: [] for l in links}
    for j in model.joints:
        for which, link in (("parent", j.parent), ("child", j.child)):
            if link not in link_set:
                raise ValueError(f"{path}: joint {j.name!r} names unknown {which} link {link!r}")
        if j.child in parent_joint:
            raise ValueError(f"{path}: link {j.child!r} is the child of two joints; a URDF must be a tree")
        parent_joint[j.child] = j
        children[j.parent].append(j)
    return _Tree(links, parent_joint, children)


def _pick_base(path: str, tree: _Tree, base_link: str | None) -> str:
    """``base_link`` checked, or the tree's only root link."""
    roots = [l for l in tree.links if l not in tree.parent_joint]
    if not tree.links:
        raise ValueError(f"{path}: the URDF has no <link> (and no <joint>): no robot to read")
    if not roots:
        raise ValueError(f"{path}: the joints form a loop; no root link")
    if base_link is None:
        if len(roots) != 1:
            raise ValueError(
                f"{path}: several root links ({short_list(roots)}); choose one with base_link= (--base-link)"
            )
        return roots[0]
    if base_link not in tree.links:
        raise ValueError(
            f"{path}: unknown base link {base_link!r}{suggest(base_link, tree.links)}; links: "
            f"{short_list(tree.links, limit=TIP_LIST_LIMIT)}"
        )
    return base_link


#: words that make a joint a gripper joint when its name contains one (any case, as substrings)
GRIPPER_WORDS = ("gripper", "finger", "jaw", "claw", "thumb", "knuckle", "hand")
#: ... and when its child link's name does: the parts of a finger (a wrist joint's child link is
#: often called "gripper_link" or "hand": the body the wrist turns, not a finger)
FINGER_WORDS = ("finger", "jaw", "claw", "thumb", "knuckle")
#: end-effector names that break a tie between candidate tips, best first (lower-case substrings of
#: the link name; ``ee`` only as a whole word: ``ee_link``, ``right_ee``, not ``knee``); ``hand`` last:
#: the gripper's body, where a bare flange link beside it has no such name (Franka's ``panda_hand``
#: against ``panda_link9``)
TIP_NAME_TIERS = (("tcp",), ("tool",), ("end_effector", "endeffector", "eef", "ee"), ("flange",), ("hand",))
#: words of a sensor's frame (whole words of the link name, any case): such a leaf is no end effector
#: whatever else its name says (Baxter's ``left_hand_camera``, ``left_hand_range`` beside the
#: ``left_gripper`` it is mounted on) and yields to any other leaf with as many joints
SENSOR_WORDS = ("camera", "cam", "sensor", "imu", "lidar", "laser", "range", "sonar", "depth", "optical", "rgb")
_SENSOR_RE = re.compile(r"(^|[^a-z])(" + "|".join(SENSOR_WORDS) + r")([^a-z]|$)")
_GRIPPER_RE = re.compile("|".join(GRIPPER_WORDS), re.IGNORECASE)
_FINGER_RE = re.compile("|".join(FINGER_WORDS), re.IGNORECASE)


def _is_sensor(link: str) -> bool:
    """The link's name has a :data:`SENSOR_WORDS` word (``left_hand_camera_axis``, ``imu_link``)."""
    return bool(_SENSOR_RE.search(link.lower()))


def _name_tier(link: str) -> int:
    """The link's rank in :data:`TIP_NAME_TIERS` (0 best); ``len(TIP_NAME_TIERS)``: not an
    end-effector name (a sensor's frame never is one, :data:`SENSOR_WORDS`)."""
    low = link.lower()
    if _is_sensor(link):
        return len(TIP_NAME_TIERS)
    for tier, words in enumerate(TIP_NAME_TIERS):
        if any(re.search(r"(^|[^a-z])ee([^a-z]|$)", low) if w == "ee" else w in low for w in words):
            return tier
    return len(TIP_NAME_TIERS)


@dataclasses.dataclass(frozen=True)
class TipCandidate:
    """A leaf link the chain could end at (:func:`tip_candidates`).

    Attributes:
        link: the leaf link.
        joints: actuated joints between the base link and it that a chain holds (revolute,
            continuous, prismatic; mimic joints not counted).
        mimic: revolute, continuous or prismatic mimic joints between the base link and it (a chain
            cannot hold one; the rule counts them with ``joints``: :attr:`moving`).
        gripper_joint: the first gripper joint on its chain (:func:`is_gripper_joint`), or None.
        finger: a link or fixed joint after its last actuated joint is named like a finger part
            (:data:`FINGER_WORDS`: a finger tip fixed to the hand).
        blocked_by: a mimic, floating or planar joint on its chain (no chain can run through it), or None.
        name_tier: its rank among end-effector names (:data:`TIP_NAME_TIERS`; their count: none).
        sensor: its name is a sensor frame's (:data:`SENSOR_WORDS`).
    """

    link: str
    joints: int
    mimic: int
    gripper_joint: str | None
    finger: bool
    blocked_by: str | None
    name_tier: int
    sensor: bool = False

    @property
    def moving(self) -> int:
        """The joints that move between the base link and the leaf: ``joints`` + ``mimic`` (the
        count the tip rule compares)."""
        return self.joints + self.mimic

    def count(self) -> str:
        """``"6 actuated joints"``, ``"6 actuated joints + 2 mimic"``: the listing's count."""
        s = "" if self.joints == 1 else "s"
        return f"{self.joints} actuated joint{s}" + (f" + {self.mimic} mimic" if self.mimic else "")

    def note(self) -> str:
        """What the listing says about the candidate besides its joint count."""
        parts = []
        if self.gripper_joint is not None:
            parts.append(f"through gripper joint {self.gripper_joint!r}")
        elif self.blocked_by is not None:
            parts.append(f"behind joint {self.blocked_by!r} (mimic, floating or planar: no chain through it)")
        if self.finger and self.gripper_joint is None:
            parts.append("finger part")
        if self.name_tier < len(TIP_NAME_TIERS):
            parts.append("end-effector name")
        if self.sensor:
            parts.append("sensor frame")
        return "; ".join(parts)


def _gripper_named(j: UrdfJoint) -> bool:
    """The joint's name contains a :data:`GRIPPER_WORDS` word, or its child link's a :data:`FINGER_WORDS` one."""
    return bool(_GRIPPER_RE.search(j.name) or _FINGER_RE.search(j.child))


def is_gripper_joint(j: UrdfJoint, below: Sequence[UrdfJoint] = (), siblings: Sequence[UrdfJoint] = ()) -> bool:
    """A joint of a gripper or hand, which the automatic tip never runs through (see
    :func:`tip_candidates`): an actuated or mimic joint whose name contains one of
    :data:`GRIPPER_WORDS` (``gripper``, ``finger``, ``jaw``, ``hand`` ...) or whose child link's
    name contains one of :data:`FINGER_WORDS` (``finger``, ``jaw`` ...), and below which every
    actuated joint is named so too (``below``: the joints of its subtree; an arm joint that happens
    to be called "hand" keeps the arm below it); or a prismatic joint with no actuated joint below
    it and another prismatic joint beside it at its parent link (``siblings``): the jaws of a
    parallel gripper, whatever their names. A prismatic joint beside revolute ones only (Fetch's
    torso cover "bellows_joint" next to its head and shoulder joints) is an axis like any other."""
    movable = j.type in _MOVABLE or j.mimic is not None
    moving_below = [k for k in below if k.type in _MOVABLE]
    if movable and _gripper_named(j) and all(_gripper_named(k) or k.mimic is not None for k in moving_below):
        return True
    return j.type == "prismatic" and not moving_below and any(s is not j and s.type == "prismatic" for s in siblings)


def _leaves_below(tree: _Tree, base_link: str, cut: set[str]) -> list[str]:
    """Leaf links below ``base_link`` in file order, the joints named in ``cut`` and their subtrees left out."""
    below, stack = [], [base_link]
    while stack:
        link = stack.pop()
        kids = [j for j in tree.children[link] if j.name not in cut]
        if not kids and link != base_link:
            below.append(link)
        stack.extend(j.child for j in reversed(kids))
    order = {l: i for i, l in enumerate(tree.links)}
    return sorted(below, key=order.__getitem__)


def _gripper_joints(tree: _Tree, base_link: str) -> set[str]:
    """Names of the gripper joints below ``base_link`` (:func:`is_gripper_joint`)."""
    out, stack = set(), [base_link]
    while stack:
        link = stack.pop()
        kids = tree.children[link]
        for j in kids:
            if is_gripper_joint(j, tree.chain_below(j.child), kids):
                out.add(j.name)
            stack.append(j.child)
    return out


def _candidate(tree: _Tree, base_link: str, leaf: str, grippers: set[str]) -> TipCandidate:
    chain = tree.chain_to(base_link, leaf)
    last = max((i for i, j in enumerate(chain) if j.type in _MOVABLE), default=-1)
    tail = chain[last + 1 :]
    finger = any(_FINGER_RE.search(j.name) or _FINGER_RE.search(j.child) for j in tail)
    return TipCandidate(
        link=leaf,
        joints=sum(j.type in _MOVABLE and j.mimic is None for j in chain),
        mimic=sum(j.type in _MOVABLE and j.mimic is not None for j in chain),
        gripper_joint=next((j.name for j in chain if j.name in grippers), None),
        finger=bool(finger),
        blocked_by=next((j.name for j in chain if _unsupported(j)), None),
        name_tier=_name_tier(leaf),
        sensor=_is_sensor(leaf),
    )


def _rank(c: TipCandidate) -> tuple:
    return (c.gripper_joint is not None, c.blocked_by is not None, -c.moving, c.finger, c.sensor, c.name_tier, c.link)


def _tip_choice(tree: _Tree, base_link: str) -> tuple[list[TipCandidate], str | None, str]:
    """The candidate tips (the automatic choice first, then by :func:`_rank`), the automatic tip
    (None when there is none) and, when there is none, why (an error message's middle part)."""
    grippers = _gripper_joints(tree, base_link)
    arm = _leaves_below(tree, base_link, grippers)  # the leaves once the gripper is cut off
    every = _leaves_below(tree, base_link, set())
    cands = {l: _candidate(tree, base_link, l, grippers) for l in dict.fromkeys(arm + every)}
    if not any(cands[l].moving and cands[l].gripper_joint is None for l in arm):
        # only gripper joints move (a gripper on its own): the rule falls back to every leaf
        grippers, cands = set(), {l: _candidate(tree, base_link, l, set()) for l in every}
    pool = [c for c in cands.values() if c.gripper_joint is None]
    usable = [c for c in pool if c.blocked_by is None and c.moving]
    ranked = sorted(cands.values(), key=_rank)
    if not usable:  # every chain runs through a mimic, floating or planar joint: building it names that joint
        usable = pool
    top = max((c.moving for c in usable), default=0)
    if top == 0:
        return ranked, None, f"no actuated joint below base link {base_link!r}; nothing to move"
    rivals = [c for c in pool if c.blocked_by is not None and c.moving >= top and c not in usable]
    best = sorted((c for c in usable if c.moving == top), key=_rank)
    if rivals:
        why = ", ".join(
            f"{c.link!r} (behind {_blocker_kind(tree, str(c.blocked_by))} joint {c.blocked_by!r})" for c in rivals
        )
        return (
            ranked,
            None,
            f"{short_list(repr(c.link) for c in best)} has the most actuated joints ({top}) of the leaves a "
            f"chain can end at, but {why} has as many; a chain cannot end behind such a joint, so the default would "
            f"silently pick the other branch",
        )
    if any(not c.finger for c in best):
        best = [c for c in best if not c.finger]
    if any(not c.sensor for c in best):
        best = [c for c in best if not c.sensor]
    tier = min(c.name_tier for c in best)
    best = [c for c in best if c.name_tier == tier]
    if len(best) != 1:
        return (
            ranked,
            None,
            f"leaves {short_list(repr(c.link) for c in best)} each have {top} actuated joints and no end-effector "
            f"name or gripper rule tells them apart",
        )
    chosen = best[0]
    return [chosen] + [c for c in ranked if c is not chosen], chosen.link, ""


def _blocker_kind(tree: _Tree, name: str) -> str:
    j = next(j for js in tree.children.values() for j in js if j.name == name)
    return "mimic" if j.mimic is not None else j.type


def tip_candidates(path: str | os.PathLike, base_link: str | None = None) -> tuple[list[TipCandidate], str | None, str]:
    """The leaf links a chain from ``base_link`` (default: the root) can end at, the automatic
    choice first; the automatic tip link (None when the rule leaves a tie; the error of
    :meth:`~jaxstiff.Robot.from_urdf` then lists them); and the base link. ``jaxstiff robot URDF``
    prints them.

    The rule (deterministic; the order of the URDF file does not matter):

    1. **Gripper joints are cut off.** A joint is a gripper joint (:func:`is_gripper_joint`) when it
       is actuated or a mimic joint, its name contains ``gripper``, ``finger``, ``jaw``, ``claw``,
       ``thumb``, ``knuckle`` or ``hand`` (or its child link's name one of the finger words, not
       ``gripper``/``hand``: a wrist turns a "gripper_link"), and every actuated joint below it is
       named so too; or when it is a prismatic joint with no actuated joint below it and another
       prismatic joint beside it at the same parent link (the jaws of a parallel gripper; a
       prismatic joint beside revolute joints only is an arm axis). The leaves of the tree without
       those joints' subtrees are the candidates; a leaf behind a gripper joint is listed but never
       chosen (unless nothing but gripper joints moves, when every leaf competes as if there were
       no gripper).
    2. **Most actuated joints** between the base link and the leaf wins.
    3. A leaf behind a mimic, floating or planar joint cannot end a chain; when it has as many
       actuated joints (its mimic joints included: :attr:`TipCandidate.moving`) as the best other
       leaf, the choice is left to the user (an error).
    4. Ties: a leaf whose last fixed links or joints are named like a finger part (a finger tip on
       a fixed joint: :data:`FINGER_WORDS`) yields to one that is not, and so does a sensor's frame
       (``camera``, ``imu``, ``range``, ...: :data:`SENSOR_WORDS`); then end-effector names decide, best first:
       ``tcp``, ``tool`` (``tool0``), ``end_effector`` / ``eef`` / ``ee`` (``ee_link``), ``flange``,
       ``hand`` (Franka's ``panda_hand``).
    5. Still tied: no automatic tip (an error that lists the tied leaves).
    """
    ranked, chosen, base, _ = tip_candidates_and_why(path, base_link)
    return ranked, chosen, base


def tip_candidates_and_why(
    path: str | os.PathLike, base_link: str | None = None
) -> tuple[list[TipCandidate], str | None, str, str]:
    """:func:`tip_candidates` and, where there is no automatic tip, why (else "")."""
    path = _resolve_path(path)
    model = parse_urdf_model(path)
    tree = _link_tree(path, model)
    base = _pick_base(path, tree, base_link)
    ranked, chosen, why = _tip_choice(tree, base)
    return ranked, chosen, base, why


def _pick_tip(path: str, tree: _Tree, base_link: str, tip_link: str | None) -> str:
    """``tip_link`` checked, or the automatic tip (:func:`tip_candidates`' rule)."""
    if tip_link is not None:
        if tip_link not in tree.links:
            ranked, _, _ = _tip_choice(tree, base_link)
            below = [c.link for c in ranked] + [l for l in tree.below(base_link) if l not in {c.link for c in ranked}]
            raise ValueError(
                f"{path}: unknown tip link {tip_link!r}{suggest(tip_link, tree.links)}; the links below {base_link!r} "
                f"(candidate tips first): {short_list(below, limit=TIP_LIST_LIMIT)}"
            )
        return tip_link
    ranked, chosen, why = _tip_choice(tree, base_link)
    if chosen is not None:
        return chosen
    if not any(c.moving for c in ranked if c.gripper_joint is None):
        raise ValueError(f"{path}: {why}")
    listed = "; ".join(
        f"{c.link!r} ({c.count()}{', ' + c.note() if c.note() else ''})" for c in ranked[:TIP_LIST_LIMIT]
    )
    more = f"; ... and {len(ranked) - TIP_LIST_LIMIT} more" if len(ranked) > TIP_LIST_LIMIT else ""
    example = tip_example(ranked)
    raise ValueError(
        f"{path}: the tip link is ambiguous below {base_link!r}: {why}; pass tip_link (command line: --tip-link), "
        f"e.g. {example!r}. Candidate tips: {listed}{more} (`jaxstiff robot {os.path.basename(path)}` lists them)"
    )


def tip_example(ranked: Sequence[TipCandidate]) -> str:
    """The candidate an ambiguous-tip message offers as an example: the first a chain can end at."""
    return next((c.link for c in ranked if c.gripper_joint is None and c.blocked_by is None), ranked[0].link)


#: candidate tips and links an error lists before "... and N more"
TIP_LIST_LIMIT = 50


def _not_lockable(j: Any) -> str:
    """Why no chain can hold ``j`` as a joint, so locking it means nothing (the rest of a
    ``cannot lock joint 'x': ...`` message), or "" for an actuated joint."""
    if j.type == "fixed":
        return "it is a fixed joint (it never moves, so there is nothing to lock)"
    if j.mimic is not None:
        return f"it mimics joint {j.mimic!r} (its value follows {j.mimic!r}; no chain can hold a mimic joint)"
    if j.type in ("floating", "planar"):
        return f"it is a {j.type} joint, which no chain can hold"
    return ""


def _unsupported(j: Any) -> bool:
    """A joint a chain cannot hold: a mimic, floating or planar joint."""
    return j.mimic is not None or j.type in ("floating", "planar")


def _check_chain_joint(path: str, j: Any) -> None:
    """Refuse a mimic, floating or planar joint on the chain."""
    if j.mimic is not None:
        raise ValueError(
            f"{path}: joint {j.name!r} mimics joint {j.mimic!r}; mimic joints in the chain "
            f"are not supported (its value is tied to {j.mimic!r}, so locking it does not help): "
            f"choose a tip link above it (tip_link, command line: --tip-link)"
        )
    if j.type in ("floating", "planar"):
        raise ValueError(
            f"{path}: joint {j.name!r} is {j.type}; only revolute, continuous, prismatic and fixed joints are supported: "
            f"choose a base link below it ({j.child!r} or further down; base_link, command line: --base-link) "
            "or a tip link above it (tip_link, --tip-link)"
        )


def _unit_axis(path: str, j: Any) -> tuple[float, ...]:
    """The joint's axis scaled to unit length (URDF default: x)."""
    axis = np.asarray(j.axis if j.axis is not None else (1.0, 0.0, 0.0), dtype=float)
    norm = float(np.linalg.norm(axis))
    if not np.all(np.isfinite(axis)) or norm < 1e-12:
        raise ValueError(f"{path}: joint {j.name!r} has a zero or non-finite axis {axis.tolist()}")
    return tuple(float(a) for a in axis / norm)


# The empty-range warning points at the caller of Robot.from_urdf: this frame, _chain_fields,
# parse_urdf_chain, Robot.from_urdf, then its caller.
_WARN_STACKLEVEL = 5


def _limits(path: str, j: Any) -> tuple[float, float]:
    """``(lower, upper)`` of an actuated joint (rad or m); continuous joints get ``(-inf, inf)``."""
    if j.type == "continuous":
        return -math.inf, math.inf
    if j.limit is None:
        raise ValueError(
            f"{path}: {j.type} joint {j.name!r} has no <limit>; URDF requires one"
            + (' (use type="continuous" for an unlimited revolute joint)' if j.type == "revolute" else "")
        )
    # URDF spec (and urdfdom): a missing lower/upper attribute defaults to 0.
    lo = 0.0 if j.limit.lower is None else float(j.limit.lower)
    hi = 0.0 if j.limit.upper is None else float(j.limit.upper)
    if lo > hi:
        raise ValueError(f"{path}: joint {j.name!r} has lower limit {lo:g} > upper limit {hi:g}")
    if lo == hi:
        missing = [a for a in ("lower", "upper") if getattr(j.limit, a) is None]
        why = f" (<limit> omits {' and '.join(missing)}, which URDF defaults to 0)" if missing else ""
        warnings.warn(
            f"{os.path.abspath(path)}: {j.type} joint {j.name!r} has an empty range [{lo:g}, {hi:g}]{why}; "
            f"it cannot move within its limits (lock it, or give it real limits or type "
            f'"continuous")',
            UserWarning,
            stacklevel=_WARN_STACKLEVEL,
        )
    return lo, hi


def _chain_fields(path: str, chain: list[Any]) -> dict[str, Any]:
    """Per-actuated-joint fields of the chain, fixed joints folded into the next origin (or the tip)."""
    names, types, origins, axes, lower, upper = [], [], [], [], [], []
    pending = np.eye(4)
    for j in chain:
        T = np.eye(4) if j.origin is None else np.asarray(j.origin, dtype=float)
        _check_chain_joint(path, j)
        if j.type == "fixed":
            pending = pending @ T
            continue
        axis = _unit_axis(path, j)
        lo, hi = _limits(path, j)
        names.append(j.name)
        types.append(_MOVABLE[j.type])
        origins.append(mat_to_tuple(pending @ T))
        axes.append(axis)
        lower.append(lo)
        upper.append(hi)
        pending = np.eye(4)
    return dict(names=names, types=types, origins=origins, axes=axes, lower=lower, upper=upper, after_tip=pending)


def parse_urdf_chain(
    path: str | os.PathLike,
    base_link: str | None = None,
    tip_link: str | None = None,
    locked: Mapping[str, float] | None = None,
    tcp: Sequence[float] | np.ndarray | None = None,
) -> dict:
    """The fields of a :class:`~jaxstiff.model._chain.Chain` for the chain ``base_link`` -> ``tip_link``
    of the URDF ``path`` (a file, or a shipped robot's name). Arguments and errors: see
    :meth:`jaxstiff.model._robot.Robot.from_urdf`."""
    path = _resolve_path(path)
    model = parse_urdf_model(path)
    tree = _link_tree(path, model)
    base_link = _pick_base(path, tree, base_link)
    tip_link = _pick_tip(path, tree, base_link, tip_link)
    chain = tree.chain_to(base_link, tip_link) if tip_link != base_link else []
    if not chain:
        raise ValueError(
            f"{path}: no kinematic chain from base link {base_link!r} to tip link {tip_link!r} "
            f"(the tip must lie below the base in the URDF tree)"
        )
    f = _chain_fields(path, chain)
    names = f["names"]
    if not names:
        raise ValueError(f"{path}: the chain {base_link!r} -> {tip_link!r} has no actuated joint")

    tip = f["after_tip"] @ tcp_matrix(tcp)
    axes = [tuple(snap(a) for a in ax) for ax in f["axes"]]
    on_chain = {j.name for j in chain}
    off_chain = {j.name for j in model.joints if j.name not in on_chain}
    lock_values = check_locked(
        tuple(names),
        f["lower"],
        f["upper"],
        locked,
        off_chain=off_chain,
        ends=(base_link, tip_link),
        cannot_move={j.name: why for j in model.joints if (why := _not_lockable(j))},
    )
    return dict(
        name=model.name or os.path.basename(path),
        joint_names=tuple(names),
        joint_types=tuple(f["types"]),
        origins=tuple(f["origins"]),
        axes=tuple(axes),
        tip=mat_to_tuple(tip),
        lower_limits=tuple(f["lower"]),
        upper_limits=tuple(f["upper"]),
        locked=lock_values,
        base_link=base_link,
        tip_link=tip_link,
        source=os.path.abspath(path),
    )
