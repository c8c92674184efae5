"""The kinematics kernel on third-party arms (tests/data/robots, rotated and offset joint frames, fixed
joints, grippers) and the shipped LWR, against references that share nothing with jaxstiff's chain code:

* a numpy product of the URDF's own transforms, read here with ``xml.etree`` (origin xyz/rpy, joint
  axis, revolute/continuous/prismatic motion), and the geometric Jacobian from those frames;
* central finite differences of that numpy FK;
* pytorch-kinematics (its chain built in float64; skipped where it is not installed).

Positions, rotations and Jacobians to 1e-12 in float64, batched (3, 1, 2), random q within the
limits; and a gradient through fk/jacobian against finite differences on a rotated-frame arm.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from helpers import DATA_DIR, assert_close, load_script, numpy_fk

import jaxstiff
from jaxstiff.model._generate import serial_chain
from jaxstiff.model._kinematics import fk_and_jacobian_raw
from jaxstiff.model._kinematics_scan import kernel_for

ROBOTS_DIR = DATA_DIR / "robots"

# (case id, URDF, tip link, kernel the chain is expected to take). Tip links are given explicitly, so
# that the chain does not depend on the automatic tip choice.
ARMS = [
    ("lwr", "kuka_lwr4", None, "unrolled"),
    ("kinova", "kinova_j2s6s200.urdf", "j2s6s200_end_effector", "framed"),
    ("ur10", "ur10.urdf", "tool0", "framed"),
    ("z1", "z1.urdf", "link06", "unrolled"),
    ("z1_gripper", "z1.urdf", "gripperMover", "unrolled"),
    ("talos", "talos_left_arm.urdf", "arm_left_7_link", "unrolled"),
    ("so101", "so101.urdf", "gripper_frame_link", "framed"),
    ("so101_jaw", "so101.urdf", "moving_jaw_so101_v1_link", "framed"),
]
_CACHE: dict[str, jaxstiff.Robot] = {}


def _path(urdf: str) -> str:
    return jaxstiff.robot_path(urdf) if not urdf.endswith(".urdf") else str(ROBOTS_DIR / urdf)


def arm(case: str) -> jaxstiff.Robot:
    if case not in _CACHE:
        _, urdf, tip, _ = next(a for a in ARMS if a[0] == case)
        _CACHE[case] = jaxstiff.Robot.from_urdf(_path(urdf), **({"tip_link": tip} if tip else {}))
    return _CACHE[case]


def random_q(robot: jaxstiff.Robot, shape: tuple[int, ...], seed: int) -> np.ndarray:
    lo, hi = np.maximum(robot.lower, -math.pi), np.minimum(robot.upper, math.pi)
    return np.random.default_rng(seed).uniform(lo, hi, size=shape + (robot.n,))


# ------------------------------------------------------------------ the URDF's own transforms, in numpy
def _rpy_matrix(r: float, p: float, y: float) -> np.ndarray:
    cr, sr, cp, sp, cy, sy = math.cos(r), math.sin(r), math.cos(p), math.sin(p), math.cos(y), math.sin(y)
    Rx = np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]])
    Ry = np.array([[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]])
    Rz = np.array([[cy, -sy, 0], [sy, cy, 0], [0, 0, 1]])
    return Rz @ Ry @ Rx


def _floats(text: str | None, default: str) -> np.ndarray:
    return np.array([float(v) for v in (text or default).split()])


class UrdfChain:
    """The joints from ``base`` to ``tip`` of a URDF file, read with ElementTree."""

    def __init__(self, path: str, base: str, tip: str):
        joints = {}
        for j in ET.parse(path).getroot().findall("joint"):  # (not the transmissions' <joint>)
            child = j.find("child").get("link")  # type: ignore[union-attr]
            joints[child] = j
        chain, link = [], tip
        while link != base:
            j = joints[link]
            chain.append(j)
            link = j.find("parent").get("link")  # type: ignore[union-attr]
        self.joints = []
        for j in reversed(chain):
            o = j.find("origin")
            T = np.eye(4)
            if o is not None:
                T[:3, :3] = _rpy_matrix(*_floats(o.get("rpy"), "0 0 0"))
                T[:3, 3] = _floats(o.get("xyz"), "0 0 0")
            a = j.find("axis")
            axis = _floats(a.get("xyz") if a is not None else None, "1 0 0")
            self.joints.append((j.get("name"), j.get("type"), T, axis / np.linalg.norm(axis)))

    def frames(self, q_by_name: dict[str, float]):
        """TCP pose and, per actuated joint, (type, world axis, world point)."""
        T, out = np.eye(4), []
        for name, kind, origin, axis in self.joints:
            T = T @ origin
            if kind == "fixed":
                continue
            z = T[:3, :3] @ axis
            out.append((kind, z, T[:3, 3].copy()))
            M = np.eye(4)
            if kind == "prismatic":
                M[:3, 3] = axis * q_by_name[name]
            else:
                K = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
                t = q_by_name[name]
                M[:3, :3] = np.eye(3) + math.sin(t) * K + (1 - math.cos(t)) * K @ K
            T = T @ M
        return T, out


def reference(robot: jaxstiff.Robot, urdf: UrdfChain, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    T, frames = urdf.frames(dict(zip(robot.joint_names, q, strict=True)))
    J = np.zeros((6, robot.n))
    for i, (kind, z, p) in enumerate(frames):
        J[:, i] = np.r_[z, 0, 0, 0] if kind == "prismatic" else np.r_[np.cross(z, T[:3, 3] - p), z]
    return T, J


def _urdf_of(case: str) -> UrdfChain:
    robot = arm(case)
    return UrdfChain(robot.source, robot.base_link, robot.tip_link)


# ------------------------------------------------------------------ the tests
@pytest.mark.parametrize("case", [a[0] for a in ARMS])
def test_kernel_equals_the_urdf_product_and_finite_differences(case):
    robot, urdf = arm(case), _urdf_of(case)
    assert kernel_for(robot) == next(a[3] for a in ARMS if a[0] == case)
    q = random_q(robot, (3, 1, 2), seed=1)
    T, J = jaxstiff.fk_and_jacobian(robot, jnp.asarray(q))
    assert T.shape == (3, 1, 2, 4, 4) and J.shape == (3, 1, 2, 6, robot.n)
    for idx in np.ndindex(3, 1, 2):
        T_ref, J_ref = reference(robot, urdf, q[idx])
        assert_close(T[idx], T_ref, rtol=0, atol=1e-12, what=f"{case} T {idx}")
        assert_close(J[idx], J_ref, rtol=0, atol=1e-12, what=f"{case} J {idx}")
    # the linear rows against central differences of the numpy FK (independent of the Jacobian formula)
    h, q0 = 1e-6, q[0, 0, 0]
    for i in range(robot.n):
        e = np.zeros(robot.n)
        e[i] = h
        names = robot.joint_names
        dp = (
            urdf.frames(dict(zip(names, q0 + e, strict=True)))[0]
            - urdf.frames(dict(zip(names, q0 - e, strict=True)))[0]
        )[:3, 3] / (2 * h)
        assert_close(J[0, 0, 0, :3, i], dp, rtol=0, atol=1e-8, what=f"{case} dp/dq{i}")


@pytest.mark.parametrize("case", [a[0] for a in ARMS])
def test_kernel_equals_pytorch_kinematics_in_float64(case, monkeypatch):
    pk = pytest.importorskip("pytorch_kinematics")
    torch = pytest.importorskip("torch")
    import pytorch_kinematics.transforms as tf
    import pytorch_kinematics.urdf as pk_urdf

    def convert_float64(origin):  # pytorch-kinematics' own conversion, without its float32 rounding
        if origin is None:
            return tf.Transform3d(dtype=torch.float64)
        rpy = torch.tensor(origin.rpy, dtype=torch.float64)
        pos = torch.tensor(origin.xyz, dtype=torch.float64)
        return tf.Transform3d(rot=tf.quaternion_from_euler(rpy, "sxyz"), pos=pos, dtype=torch.float64)

    monkeypatch.setattr(pk_urdf, "_convert_transform", convert_float64)
    monkeypatch.setattr(pk.chain.Chain.__init__, "__defaults__", (torch.float64, "cpu"))  # its chain in float64
    robot = arm(case)
    with open(robot.source, "rb") as fh:
        chain = pk.build_serial_chain_from_urdf(fh.read(), robot.tip_link, robot.base_link)
    assert chain.get_joint_parameter_names() == list(robot.joint_names)
    q = random_q(robot, (6,), seed=2)
    J_pk, T_pk = chain.jacobian(torch.tensor(q, dtype=torch.float64), ret_eef_pose=True)
    T, J = jaxstiff.fk_and_jacobian(robot, jnp.asarray(q))
    assert_close(T, T_pk.numpy(), rtol=0, atol=1e-12, what=f"{case} T vs pytorch-kinematics")
    assert_close(J, J_pk.numpy(), rtol=0, atol=1e-12, what=f"{case} J vs pytorch-kinematics")


def test_gradient_through_fk_and_jacobian_matches_finite_differences():
    """jax.grad of a scalar of the pose and the Jacobian on a rotated-frame arm (the framed kernel),
    against central differences of the same function; and finite everywhere."""
    robot = arm("so101")
    rng = np.random.default_rng(4)
    W_T, W_J = rng.normal(size=(4, 4)), rng.normal(size=(6, robot.n))

    def f(q):
        T, J = fk_and_jacobian_raw(robot, q)
        return jnp.sum(T * W_T) + jnp.sum(jnp.tanh(J) * W_J)

    q0 = random_q(robot, (), seed=5)
    g = jax.jit(jax.grad(f))(jnp.asarray(q0))
    assert np.all(np.isfinite(np.asarray(g)))
    f_j = jax.jit(f)
    fd = np.zeros(robot.n)
    for i in range(robot.n):
        e = np.zeros(robot.n)
        e[i] = 1e-6
        fd[i] = (float(f_j(jnp.asarray(q0 + e))) - float(f_j(jnp.asarray(q0 - e)))) / 2e-6
    assert_close(g, fd, rtol=1e-6, atol=1e-7, what="grad vs finite differences")
    # a batch of configurations under vmap: the same gradients row by row
    qb = random_q(robot, (3,), seed=6)
    gb = jax.jit(jax.vmap(jax.grad(f)))(jnp.asarray(qb))
    for k in range(3):
        assert_close(gb[k], jax.grad(f)(jnp.asarray(qb[k])), rtol=1e-12, atol=1e-12, what="vmapped grad")


def test_framed_kernel_with_prismatic_joints_locks_and_a_rotated_tcp():
    """A generated chain with rotated frames, prismatic and continuous joints, a locked joint and a
    rotated tool offset, on the framed kernel, against the chain's numpy product (tests/helpers.py);
    the forced kernels agree with each other; float32 stays float32."""
    base = serial_chain(7, seed=21, locked={"j2": 0.1})
    robot = base.with_tcp([0.03, -0.02, 0.11, 0.4, -0.3, 1.2])
    assert kernel_for(robot) == "framed" and robot.prismatic.any()
    q = np.random.default_rng(8).uniform(-1.0, 1.0, size=(4, robot.n))
    q[:, 2] = 0.1
    T, J = jaxstiff.fk_and_jacobian(robot, jnp.asarray(q))
    for k in range(4):
        assert_close(T[k], numpy_fk(robot, q[k]), rtol=0, atol=1e-12, what=f"T {k}")
    T_s, J_s = jax.jit(lambda x: fk_and_jacobian_raw(robot, x, kernel="scan"))(jnp.asarray(q))
    assert_close(J, J_s, rtol=0, atol=1e-12, what="J framed vs scan")
    p, Jr = jaxstiff.position_and_jacobian(robot, jnp.asarray(q), (0, 1, 2))
    assert_close(p, T[:, :3, 3], rtol=0, atol=1e-15, what="position")  # (another program: rounding may differ)
    assert_close(Jr, J[:, :3], rtol=0, atol=1e-15, what="rows")
    T32 = jaxstiff.fk(robot, jnp.asarray(q, dtype=jnp.float32))
    assert T32.dtype == jnp.float32
    assert_close(T32, T, rtol=0, atol=1e-5, what="float32 vs float64")


def _numpy_frames_jacobian(robot: jaxstiff.Robot, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Pose and geometric Jacobian from plain 4x4 products of the chain's constants (numpy): world
    axis and point of every joint recorded on the way, columns ``[z x (p_tcp - p); z]`` / ``[z; 0]``."""
    T, axes, points = np.eye(4), [], []
    for i in range(robot.n):
        T = T @ robot.origin_matrix(i)
        a = np.asarray(robot.axes[i])
        axes.append(T[:3, :3] @ a)
        points.append(T[:3, 3].copy())
        M = np.eye(4)
        if robot.prismatic[i]:
            M[:3, 3] = a * q[i]
        else:
            K = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
            M[:3, :3] = np.eye(3) + math.sin(q[i]) * K + (1 - math.cos(q[i])) * K @ K
        T = T @ M
    T = T @ robot.tip_matrix
    J = np.zeros((6, robot.n))
    for i, (z, p) in enumerate(zip(axes, points, strict=True)):
        J[:, i] = np.r_[z, 0, 0, 0] if robot.prismatic[i] else np.r_[np.cross(z, T[:3, 3] - p), z]
    return T, J


@pytest.mark.parametrize("where", ["first", "last", "both"])
def test_framed_kernel_with_a_prismatic_joint_at_either_end(where):
    """The framed kernel's offsets run backward from the tool and its rotation rows forward from the
    base: chains whose first and/or last joint slides (its offset gains ``q e_z`` instead of a turn),
    against numpy products of the chain's constants, at a batch below and above the size where the
    joint cosines come from the polynomial (two programs); fk, jacobian and position_and_jacobian
    agree with fk_and_jacobian."""

    def ends(r):
        return (bool(r.prismatic[0]), bool(r.prismatic[-1]))

    want = {"first": (True, False), "last": (False, True), "both": (True, True)}[where]
    robot = next(
        r
        for r in (serial_chain(6, seed=s, prismatic_share=0.5, fixed_share=0.5) for s in range(200))
        if ends(r) == want
    )
    assert kernel_for(robot) == "framed"
    for batch in (5, 100):
        q = random_q(robot, (batch,), seed=batch)
        T, J = jaxstiff.fk_and_jacobian(robot, jnp.asarray(q))
        for k in (0, batch // 2, batch - 1):
            T_ref, J_ref = _numpy_frames_jacobian(robot, q[k])
            assert_close(T[k], T_ref, rtol=0, atol=1e-12, what=f"{where} T[{k}] of {batch}")
            assert_close(J[k], J_ref, rtol=0, atol=1e-12, what=f"{where} J[{k}] of {batch}")
        assert_close(jaxstiff.fk(robot, jnp.asarray(q)), T, rtol=0, atol=1e-15, what="fk")
        assert_close(jaxstiff.jacobian(robot, jnp.asarray(q)), J, rtol=0, atol=1e-15, what="jacobian")
        p, Jr = jaxstiff.position_and_jacobian(robot, jnp.asarray(q), (1, 5))
        assert_close(p, T[:, :3, 3], rtol=0, atol=1e-15, what="position")
        assert_close(Jr, J[:, [1, 5]], rtol=0, atol=1e-15, what="rows 1, 5")


@pytest.mark.parametrize("case", ["kinova", "ur10", "so101"])
def test_framed_kernel_walks_each_entry_with_less_than_half_the_arithmetic(case):
    """XLA's CPU backend evaluates every stacked output entry on its own, so what a batch costs is the
    arithmetic summed over the entries (``scripts/bench_kinematics.py: entry_ops``, read from the
    traced program). The framed kernel walks each entry by a rotation row forward and the TCP's
    offset backward: less than half what the same chain costs walked as written (the unrolled
    kernel forced on it; the framed walk with world cross products was at 0.74-0.85 of it)."""
    bench = load_script("scripts/bench_kinematics.py")
    robot = arm(case)
    framed, as_written = bench.entry_ops(robot, "framed"), bench.entry_ops(robot, "unrolled")
    assert framed is not None and as_written is not None and framed > 0
    assert framed < 0.5 * as_written, f"{case}: {framed} operations over the entries, walked as written {as_written}"
