"""FK and the geometric Jacobian against independent references (SPEC section 1).

References, none of them the kernel itself: the planar 3R closed form; ``jax.jacfwd`` of FK for
both the linear rows (d p / dq) and the angular rows (vee(dR/dq R^T), since dR/dt = [w]x R);
sixth-order central finite differences of the independent numpy FK in ``tests/helpers.py``; an FK
built straight from randomly drawn URDF parameters (hypothesis); and pytorch-kinematics.
"""

from __future__ import annotations

import math
import os
import tempfile

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from helpers import DATA_DIR, assert_close, numpy_fk
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import jaxstiff
from jaxstiff.model._kinematics import jacobian_tangent

BRANCHED = str(DATA_DIR / "branched_tree.urdf")

_ROBOTS: dict[str, jaxstiff.Robot] = {}


def get_robot(key: str) -> jaxstiff.Robot:
    """The robots every test below runs on, read once per session."""
    if key not in _ROBOTS:
        if key == "lwr":
            r = jaxstiff.Robot.from_urdf("kuka_lwr4")
        elif key == "planar":
            r = jaxstiff.Robot.from_urdf("planar_3r")
        elif key == "branched":
            r = jaxstiff.Robot.from_urdf(BRANCHED, tip_link="tool")
        elif key == "lwr_tcp":  # locked 7th joint and a 4x4 tool offset with a rotation
            X = np.eye(4)
            X[:3, :3] = _rpy(0.3, -0.2, 0.5)
            X[:3, 3] = [0.02, -0.01, 0.12]
            r = jaxstiff.Robot.from_urdf("kuka_lwr4", locked={"lwr_a7": 0.0}, tcp=X)
        else:
            raise KeyError(key)
        _ROBOTS[key] = r
    return _ROBOTS[key]


ROBOT_KEYS = ["lwr", "planar", "branched", "lwr_tcp"]


def random_q(robot: jaxstiff.Robot, size=(), seed=0) -> np.ndarray:
    """Joint values inside the limits (continuous joints: within +-pi), locked joints at their values
    (the kinematics refuses another value for a locked joint)."""
    rng = np.random.default_rng(seed)
    lo = np.maximum(robot.lower, -math.pi)
    hi = np.minimum(robot.upper, math.pi)
    q = rng.uniform(lo, hi, size=tuple(size) + (robot.n,))
    return np.where(robot.free, q, np.nan_to_num(robot.locked_values))


# ------------------------------------------------------------------ independent maths
def _rot_x(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])


def _rot_y(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


def _rot_z(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


def _rpy(r, p, y):
    """URDF rpy: fixed-axis roll about x, then pitch about y, then yaw about z."""
    return _rot_z(y) @ _rot_y(p) @ _rot_x(r)


def _vee(W):
    return np.array([W[2, 1], W[0, 2], W[1, 0]])


def fd6(f, x, h=1e-3):
    """Sixth-order central differences of f: R^n -> array, returns (*f.shape, n).

    Truncation error ~ h^6 and round-off ~ 1e-16 / h: about 1e-13 at h = 1e-3, which is what a
    1e-12 comparison needs (second-order differences stop near 1e-10).
    """
    x = np.asarray(x, dtype=float)
    weights = {1: 45.0, 2: -9.0, 3: 1.0}
    cols = []
    for i in range(x.size):
        acc = 0.0
        for k, w in weights.items():
            e = np.zeros_like(x)
            e[i] = k * h
            acc = acc + w * (np.asarray(f(x + e)) - np.asarray(f(x - e)))
        cols.append(acc / (60.0 * h))
    return np.stack(cols, axis=-1)


def jacobian_from_pose_derivative(T, dT):
    """Geometric Jacobian (6, n) from T (4, 4) and dT/dq (4, 4, n): [dp/dq; vee(dR/dq R^T)]."""
    R = T[:3, :3]
    n = dT.shape[-1]
    J = np.zeros((6, n))
    for i in range(n):
        J[:3, i] = dT[:3, 3, i]
        J[3:, i] = _vee(dT[:3, :3, i] @ R.T)
    return J


def planar_3r_closed_form(q):
    """Seed 000 Fig. 2: links of 1 m, all axes along z. Returns T (4, 4) and J (6, 3)."""
    c = np.cumsum(q)
    T = np.eye(4)
    T[:2, :2] = [[np.cos(c[-1]), -np.sin(c[-1])], [np.sin(c[-1]), np.cos(c[-1])]]
    T[0, 3], T[1, 3] = np.cos(c).sum(), np.sin(c).sum()
    J = np.zeros((6, 3))
    for i in range(3):
        J[0, i] = -np.sin(c[i:]).sum()
        J[1, i] = np.cos(c[i:]).sum()
        J[5, i] = 1.0
    return T, J


# ------------------------------------------------------------------ closed form, autodiff, FD
def test_planar_3r_closed_form():
    robot = get_robot("planar")
    qs = np.random.default_rng(0).uniform(-math.pi, math.pi, size=(32, 3))
    qs[0] = 0.0
    qs[1] = [0.0, math.pi, 0.0]  # folded back: a singular posture
    T, J = jaxstiff.fk_and_jacobian(robot, jnp.asarray(qs))
    for k, q in enumerate(qs):
        Tc, Jc = planar_3r_closed_form(q)
        assert_close(T[k], Tc, rtol=0, atol=1e-12, what=f"T at {q}")
        assert_close(J[k], Jc, rtol=0, atol=1e-12, what=f"J at {q}")


@pytest.mark.parametrize("key", ROBOT_KEYS)
def test_jacobian_matches_jacfwd_of_fk(key):
    """Position rows = d p / dq and orientation rows = vee(dR/dq R^T), both from autodiff of fk."""
    robot = get_robot(key)
    dfk = jax.jit(jax.jacfwd(lambda x: jaxstiff.fk(robot, x)))
    for q in random_q(robot, (4,), seed=1):
        q = jnp.asarray(q)
        T = np.asarray(jaxstiff.fk(robot, q))
        J_ref = jacobian_from_pose_derivative(T, np.asarray(dfk(q)))
        assert_close(jaxstiff.jacobian(robot, q), J_ref, rtol=0, atol=1e-12, what=f"{key} J vs jacfwd")


@pytest.mark.parametrize("key", ROBOT_KEYS)
def test_fk_and_jacobian_match_numpy_fk_and_finite_differences(key):
    """FK vs the independent numpy chain; J vs 6th-order central differences of that chain."""
    robot = get_robot(key)
    for q in random_q(robot, (3,), seed=2):
        T, J = jaxstiff.fk_and_jacobian(robot, jnp.asarray(q))
        T_np = numpy_fk(robot, q)
        assert_close(T, T_np, rtol=0, atol=1e-12, what=f"{key} FK vs numpy")
        J_fd = jacobian_from_pose_derivative(T_np, fd6(lambda x: numpy_fk(robot, x), q))
        assert_close(J, J_fd, rtol=0, atol=1e-12, what=f"{key} J vs finite differences")


def test_separate_and_fused_calls_agree():
    robot = get_robot("branched")
    q = jnp.asarray(random_q(robot, (5,), seed=3))
    T, J = jaxstiff.fk_and_jacobian(robot, q)
    assert_close(jaxstiff.fk(robot, q), T, rtol=0, atol=1e-14)
    assert_close(jaxstiff.jacobian(robot, q), J, rtol=0, atol=1e-14)
    assert_close(robot.fk(q), T, rtol=0, atol=1e-14)
    assert_close(robot.jacobian(q), J, rtol=0, atol=1e-14)
    rows = (0, 1, 5)
    p, Js = jaxstiff.position_and_jacobian(robot, q, rows)
    assert_close(p, T[..., :3, 3], rtol=0, atol=1e-14)
    assert_close(Js, J[..., rows, :], rtol=0, atol=1e-14)


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_cos_sin_polynomial_is_accurate_and_has_exact_derivative(dtype):
    """The kernel's own cos/sin (used for CPU batches) vs numpy in extended precision: <= 2 ulp."""
    from jaxstiff.model._kinematics import cos_sin

    rng = np.random.default_rng(11)
    x = np.concatenate(
        [
            np.linspace(-10.0, 10.0, 20001),
            rng.uniform(-1e3, 1e3, 20000),
            np.arange(-8, 9) * (np.pi / 4),  # octant boundaries, where the reduction switches
            [0.0, -0.0, 1e-30, 3e3, -3e3],
        ]
    ).astype(dtype)
    c, s = jax.jit(cos_sin)(jnp.asarray(x))
    assert c.dtype == dtype and s.dtype == dtype
    xl = x.astype(np.longdouble)
    ulp = np.spacing(np.ones((), dtype)).astype(np.longdouble)  # ulp at 1; |cos|, |sin| <= 1
    assert np.max(np.abs(np.asarray(c, np.longdouble) - np.cos(xl))) <= 2 * ulp
    assert np.max(np.abs(np.asarray(s, np.longdouble) - np.sin(xl))) <= 2 * ulp
    assert float(c[x == 0][0]) == 1.0 and float(s[x == 0][0]) == 0.0
    c_bad, s_bad = cos_sin(jnp.asarray([np.nan, np.inf, -np.inf], dtype=dtype))
    assert np.all(np.isnan(c_bad)) and np.all(np.isnan(s_bad))
    xs = jnp.asarray(x[:500])
    dc = jax.vmap(jax.grad(lambda t: cos_sin(t)[0]))(xs)
    ds = jax.vmap(jax.grad(lambda t: cos_sin(t)[1]))(xs)
    assert_close(dc, -np.sin(np.asarray(xs, float)), rtol=0, atol=4 * float(ulp))
    assert_close(ds, np.cos(np.asarray(xs, float)), rtol=0, atol=4 * float(ulp))


@pytest.mark.slow
@pytest.mark.parametrize("dtype", [jnp.float32, jnp.float64])
def test_large_batches_match_numpy_and_autodiff(dtype):
    """Batches of >= 64 take the polynomial cos/sin path on the CPU: same answers, same dtype."""
    from jaxstiff.model._kinematics import POLY_MIN_BATCH

    robot = get_robot("branched")
    q64 = random_q(robot, (2, 3 * POLY_MIN_BATCH), seed=12)
    q = jnp.asarray(q64, dtype=dtype)
    T, J = jaxstiff.fk_and_jacobian(robot, q)
    assert T.dtype == dtype and J.dtype == dtype
    tol = 1e-12 if dtype == jnp.float64 else 2e-5
    q_used = np.asarray(q, dtype=float)
    assert_close(T, numpy_fk_batch(robot, q_used), rtol=0, atol=tol, what="FK vs numpy")
    if dtype == jnp.float64:  # d T / d q_i for the whole batch, by forward-mode autodiff of fk
        tangent = jax.jit(lambda x, e: jax.jvp(lambda y: jaxstiff.fk(robot, y), (x,), (e,))[1])
        for i in range(robot.n):
            dT = tangent(q, jnp.zeros_like(q).at[..., i].set(1.0))
            dT, Tn = np.asarray(dT), np.asarray(T)
            w = np.einsum("...ij,...kj->...ik", dT[..., :3, :3], Tn[..., :3, :3])
            J_ref = np.concatenate([dT[..., :3, 3], np.stack([w[..., 2, 1], w[..., 0, 2], w[..., 1, 0]], -1)], -1)
            assert_close(J[..., :, i], J_ref, rtol=0, atol=1e-12, what=f"column {i} vs jvp")

        # reverse mode through the polynomial path == per-configuration grads (vmap traces one
        # configuration at a time, so those take XLA's sin/cos)
        def loss(x):
            T_, J_ = jaxstiff.fk_and_jacobian(robot, x)
            return jnp.sum(J_**2) + jnp.sum(T_[..., :3, :] ** 3)

        g_batch = jax.grad(loss)(q)
        g_each = jax.vmap(jax.grad(loss))(q.reshape(-1, robot.n)).reshape(q.shape)
        assert_close(g_batch, g_each, rtol=0, atol=1e-12, what="grad, batch vs per configuration")


# ------------------------------------------------------------------ locked joints, TCP
def test_locked_joints_keep_kinematics_and_columns():
    """Locking changes which joints are free, not the chain: same FK/J, n columns, free mask."""
    free = get_robot("lwr")
    locked = jaxstiff.Robot.from_urdf("kuka_lwr4", locked={"lwr_a7": 0.0, "lwr_a3": 0.25})
    assert locked.n == 7 and locked.n_free == 5
    assert locked.free.tolist() == [True, True, False, True, True, True, False]
    assert_close(locked.locked_values[[2, 6]], [0.25, 0.0])
    assert free.with_locked({"lwr_a7": 0.0, "lwr_a3": 0.25}) == locked
    q = random_q(free, (4,), seed=4)
    q[:, 2], q[:, 6] = 0.25, 0.0
    T0, J0 = jaxstiff.fk_and_jacobian(free, jnp.asarray(q))
    T1, J1 = jaxstiff.fk_and_jacobian(locked, jnp.asarray(q))
    assert J1.shape == (4, 6, 7)
    assert_close(T1, T0, rtol=0, atol=1e-15)
    assert_close(J1, J0, rtol=0, atol=1e-15)


@pytest.mark.parametrize("as_matrix", [False, True])
def test_tcp_offset(as_matrix):
    """T_tcp = T_flange X; v_tcp = v_flange + w x (p_tcp - p_flange), w unchanged (rigid body)."""
    flange = get_robot("lwr")
    X = np.eye(4)
    X[:3, 3] = [0.05, -0.02, 0.15]
    if as_matrix:
        X[:3, :3] = _rpy(0.2, 0.1, -0.4)
    tool = jaxstiff.Robot.from_urdf("kuka_lwr4", tcp=X if as_matrix else X[:3, 3])
    q = jnp.asarray(random_q(flange, (6,), seed=5))
    T0, J0 = map(np.asarray, jaxstiff.fk_and_jacobian(flange, q))
    T1, J1 = map(np.asarray, jaxstiff.fk_and_jacobian(tool, q))
    assert_close(T1, T0 @ X, rtol=0, atol=1e-13, what="tcp pose")
    r = T1[:, :3, 3] - T0[:, :3, 3]
    assert_close(J1[:, 3:], J0[:, 3:], rtol=0, atol=1e-13, what="angular rows")
    v_expected = J0[:, :3] + np.cross(J0[:, 3:], r[:, :, None], axisa=1, axisb=1, axisc=1)
    assert_close(J1[:, :3], v_expected, rtol=0, atol=1e-13, what="linear rows")
    # with_tcp appends the same offset
    assert flange.with_tcp(X if as_matrix else X[:3, 3]).tip == tool.tip


# ------------------------------------------------------------------ shapes, dtypes, compilation
@pytest.mark.parametrize("batch", [(), (1,), (3, 1, 2)])
def test_batch_shapes(batch):
    robot = get_robot("branched")
    q = random_q(robot, batch, seed=6)
    T, J = jaxstiff.fk_and_jacobian(robot, jnp.asarray(q))
    assert T.shape == batch + (4, 4) and J.shape == batch + (6, robot.n)
    assert jaxstiff.fk(robot, jnp.asarray(q)).shape == batch + (4, 4)
    assert jaxstiff.jacobian(robot, jnp.asarray(q)).shape == batch + (6, robot.n)
    p, Jxy = jaxstiff.position_and_jacobian(robot, jnp.asarray(q), (0, 1))
    assert p.shape == batch + (3,) and Jxy.shape == batch + (2, robot.n)
    for idx in np.ndindex(*batch):
        T1, J1 = jaxstiff.fk_and_jacobian(robot, jnp.asarray(q[idx]))
        assert_close(T[idx], T1, rtol=0, atol=1e-14)
        assert_close(J[idx], J1, rtol=0, atol=1e-14)
    assert_close(T, numpy_fk_batch(robot, q), rtol=0, atol=1e-12)


def numpy_fk_batch(robot, q):
    q = np.asarray(q)
    out = np.zeros(q.shape[:-1] + (4, 4))
    for idx in np.ndindex(*q.shape[:-1]):
        out[idx] = numpy_fk(robot, q[idx])
    return out


@pytest.mark.parametrize("dtype", [jnp.float32, jnp.float64])
def test_dtype_is_kept(dtype):
    robot = get_robot("branched")
    q64 = random_q(robot, (5,), seed=7)
    q = jnp.asarray(q64, dtype=dtype)
    T, J = jaxstiff.fk_and_jacobian(robot, q)
    outs = [T, J, jaxstiff.fk(robot, q), jaxstiff.jacobian(robot, q), *jaxstiff.position_and_jacobian(robot, q)]
    assert all(o.dtype == dtype for o in outs), [o.dtype for o in outs]
    tol = 2e-5 if dtype == jnp.float32 else 1e-12
    assert_close(T, numpy_fk_batch(robot, np.asarray(q, dtype=float)), rtol=0, atol=tol)


class CountCompilations:
    """Counts XLA backend compilations (jax.monitoring events) inside a ``with`` block."""

    EVENT = "/jax/core/compile/backend_compile_duration"

    def __enter__(self):
        self.count = 0
        jax.monitoring.register_event_duration_secs_listener(self._listen)
        return self

    def _listen(self, name, duration, **kwargs):
        if name == self.EVENT:
            self.count += 1

    def __exit__(self, *exc):
        jax.monitoring.unregister_event_duration_listener(self._listen)


def test_second_call_with_same_shapes_does_not_recompile():
    robot = get_robot("lwr")
    again = jaxstiff.Robot.from_urdf("kuka_lwr4")  # an equal robot, read again
    assert again == robot and hash(again) == hash(robot)
    q = random_q(robot, (11, 7), seed=8)  # a shape no other test uses
    q1, q2, q3 = (jnp.asarray(q + d) for d in (0.0, 0.1, -0.1))
    for f in (jaxstiff.fk, jaxstiff.jacobian, jaxstiff.fk_and_jacobian):
        with CountCompilations() as first:
            jax.block_until_ready(f(robot, q1))
        size = f._cache_size()
        with CountCompilations() as later:
            jax.block_until_ready(f(robot, q2))  # new values, same shape and dtype
            jax.block_until_ready(f(again, q3))
        assert first.count >= 1, "the counter must see the first compilation"
        assert later.count == 0, f"{f.__name__} recompiled for the same shapes"
        assert f._cache_size() == size
    with CountCompilations() as methods:  # the Robot methods (numpy input) reach the same kernel
        robot.fk(q)
        robot.fk_and_jacobian(q)
    assert methods.count == 0


def test_composes_with_jit_vmap_and_grad():
    robot = get_robot("lwr")
    q = jnp.asarray(random_q(robot, (4,), seed=9))
    T_vmap = jax.vmap(lambda x: jaxstiff.fk(robot, x))(q)
    assert_close(T_vmap, jaxstiff.fk(robot, q), rtol=0, atol=1e-14)
    f = jax.jit(lambda x: jnp.sum(jaxstiff.jacobian(robot, x) ** 2))
    g = jax.grad(f)(q[0])
    g_fd = fd6(lambda x: float(f(jnp.asarray(x))), np.asarray(q[0]))
    assert_close(g, g_fd, rtol=0, atol=1e-10)


def test_values_and_gradients_finite_at_singular_postures():
    """q = 0 stretches the LWR straight up (rank-deficient J); FK and J are smooth there."""
    robot = get_robot("lwr")

    def loss(x):
        T, J = jaxstiff.fk_and_jacobian(robot, x)
        return jnp.sum(T) + jnp.sum(J**2) + jnp.linalg.det(J[:6, :6] @ J[:6, :6].T)

    for q in (jnp.zeros(7), jnp.array([0.0, 0.0, 0.0, 0.0, 0.0, 0.0, math.pi])):
        T, J = jaxstiff.fk_and_jacobian(robot, q)
        assert np.all(np.isfinite(T)) and np.all(np.isfinite(J))
        assert np.linalg.matrix_rank(np.asarray(J), tol=1e-9) < 6
        g = jax.grad(loss)(q)
        assert np.all(np.isfinite(np.asarray(g)))


# ------------------------------------------------------------------ pytorch-kinematics
PK_CASES = [
    ("kuka_lwr4", "lwr_flange", "lwr_base"),
    ("planar_3r", "tool", "base"),
    (BRANCHED, "tool", "world"),
    (BRANCHED, "side_link", "world"),
]


@pytest.mark.slow
@pytest.mark.parametrize("urdf,tip,base", PK_CASES, ids=["lwr", "planar", "branched-tool", "branched-side"])
def test_matches_pytorch_kinematics(urdf, tip, base):
    """FK and J vs pytorch-kinematics' ``jacobian(th, ret_eef_pose=True)`` to 1e-6.

    pytorch-kinematics parses URDF numbers into float32 tensors, so even with its chain moved
    to float64 its constant transforms carry ~1e-7 relative error: it cannot agree closer.
    """
    pk = pytest.importorskip("pytorch_kinematics")
    torch = pytest.importorskip("torch")
    path = jaxstiff.robot_path(urdf) if not os.path.isabs(urdf) else urdf
    with open(path) as fh:
        chain = pk.build_serial_chain_from_urdf(fh.read(), tip, base).to(dtype=torch.float64)
    robot = jaxstiff.Robot.from_urdf(path, base_link=base, tip_link=tip)
    assert tuple(chain.get_joint_parameter_names()) == robot.joint_names
    q = random_q(robot, (64,), seed=10)
    J_pk, T_pk = chain.jacobian(torch.tensor(q), ret_eef_pose=True)
    T, J = jaxstiff.fk_and_jacobian(robot, jnp.asarray(q))
    assert_close(T, T_pk.numpy(), rtol=0, atol=1e-6, what="FK vs pytorch-kinematics")
    assert_close(J, J_pk.numpy(), rtol=0, atol=1e-6, what="J vs pytorch-kinematics")


# ------------------------------------------------------------------ property test: random chains
@st.composite
def random_chains(draw):
    """A list of joints: (type, xyz, rpy, unit axis), with fixed joints sprinkled in."""
    finite = st.floats(-1.0, 1.0, allow_nan=False)
    angle = st.floats(-math.pi, math.pi, allow_nan=False)
    joints = []
    for _ in range(draw(st.integers(1, 6))):
        kind = draw(st.sampled_from(["revolute", "prismatic", "continuous", "fixed"]))
        xyz = [draw(finite) * 0.5 for _ in range(3)]
        rpy = [draw(angle) for _ in range(3)]
        v = np.array([draw(finite) for _ in range(3)])
        if np.linalg.norm(v) < 0.1:
            v = np.array([0.0, 0.0, 1.0])
        joints.append((kind, xyz, rpy, (v / np.linalg.norm(v)).tolist()))
    if all(j[0] == "fixed" for j in joints):
        joints.append(("revolute", [0.0, 0.0, 0.3], [0.0, 0.0, 0.0], [1.0, 0.0, 0.0]))
    return joints


def _chain_urdf(joints) -> str:
    links = "".join(f'<link name="l{i}"/>' for i in range(len(joints) + 1))
    body = []
    for i, (kind, xyz, rpy, axis) in enumerate(joints):
        limit = '<limit lower="-3" upper="3" effort="1" velocity="1"/>' if kind in ("revolute", "prismatic") else ""
        body.append(
            f'<joint name="j{i}" type="{kind}"><parent link="l{i}"/><child link="l{i + 1}"/>'
            f'<origin xyz="{" ".join(map(repr, xyz))}" rpy="{" ".join(map(repr, rpy))}"/>'
            f'<axis xyz="{" ".join(map(repr, axis))}"/>{limit}</joint>'
        )
    return f'<?xml version="1.0"?><robot name="random">{links}{"".join(body)}</robot>'


def _fk_from_parameters(joints, q):
    """FK straight from the drawn URDF numbers (not from the parsed Robot)."""
    T = np.eye(4)
    k = 0
    for kind, xyz, rpy, axis in joints:
        O = np.eye(4)
        O[:3, :3] = _rpy(*rpy)
        O[:3, 3] = xyz
        T = T @ O
        if kind == "fixed":
            continue
        M = np.eye(4)
        a = np.asarray(axis)
        if kind == "prismatic":
            M[:3, 3] = a * q[k]
        else:  # Rodrigues
            K = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
            M[:3, :3] = np.eye(3) + math.sin(q[k]) * K + (1 - math.cos(q[k])) * K @ K
        T = T @ M
        k += 1
    return T


@pytest.mark.slow
@settings(max_examples=20, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(joints=random_chains(), seed=st.integers(0, 2**31 - 1))
def test_random_chains_match_numpy_fk_and_finite_differences(joints, seed):
    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "random.urdf")
        with open(path, "w") as fh:
            fh.write(_chain_urdf(joints))
        robot = jaxstiff.Robot.from_urdf(path, tip_link=f"l{len(joints)}")
    n_movable = sum(j[0] != "fixed" for j in joints)
    assert robot.n == n_movable
    q = np.random.default_rng(seed).uniform(-3.0, 3.0, size=robot.n)
    T, J = jaxstiff.fk_and_jacobian(robot, jnp.asarray(q))
    assert_close(T, numpy_fk(robot, q), rtol=0, atol=1e-12, what="FK vs helpers.numpy_fk")
    assert_close(T, _fk_from_parameters(joints, q), rtol=0, atol=1e-12, what="FK vs URDF numbers")
    T_fd = fd6(lambda x: _fk_from_parameters(joints, x), q)
    J_fd = jacobian_from_pose_derivative(_fk_from_parameters(joints, q), T_fd)
    assert_close(J, J_fd, rtol=0, atol=1e-10, what="J vs finite differences")


@pytest.mark.slow
@settings(max_examples=15, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(joints=random_chains(), seed=st.integers(0, 2**31 - 1))
def test_jacobian_tangent_matches_autodiff_on_random_chains(joints, seed):
    """The closed-form derivative of J (from J alone) against forward-mode autodiff through the
    chain, revolute, prismatic and fixed joints mixed."""
    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "random.urdf")
        with open(path, "w") as fh:
            fh.write(_chain_urdf(joints))
        robot = jaxstiff.Robot.from_urdf(path, tip_link=f"l{len(joints)}")
    rng = np.random.default_rng(seed)
    q = jnp.asarray(rng.uniform(-3.0, 3.0, size=robot.n))
    qd = jnp.asarray(rng.normal(size=robot.n))
    T, J = jaxstiff.fk_and_jacobian(robot, q)
    (_, J_ad), (dT, dJ_ad) = jax.jvp(lambda x: jaxstiff.fk_and_jacobian(robot, x), (q,), (qd,))
    dp, dJ, omega = jacobian_tangent(J, qd)
    assert_close(dp, dT[:3, 3], rtol=0, atol=1e-12, what="dp")
    assert_close(dJ, dJ_ad, rtol=0, atol=1e-12, what="dJ")
    # omega: dR = [omega]x R
    assert_close(
        dT[:3, :3],
        np.cross(np.asarray(omega)[:, None], np.asarray(T[:3, :3]), axis=0),
        rtol=0,
        atol=1e-12,
        what="omega",
    )


@pytest.mark.parametrize("n", [1, 2, 7, 40])  # 40: above the unrolled range, jnp.cumsum is used
@pytest.mark.parametrize("reverse", [False, True])
@pytest.mark.parametrize("exclusive", [False, True])
def test_running_sum_matches_numpy_cumsum(n, reverse, exclusive):
    """The unrolled running sum of the Jacobian's closed-form derivative against numpy's cumsum,
    forward/backward, inclusive/exclusive, on a batch; its transpose (reverse mode) against the
    matrix of the linear map."""
    x = np.random.default_rng(n).normal(size=(4, 3, n))
    want = np.flip(np.cumsum(np.flip(x, -1), -1), -1) if reverse else np.cumsum(x, -1)
    if exclusive:
        want = want - x
    from jaxstiff.model._kinematics import running_sum

    f = jax.jit(lambda a: running_sum(a, reverse=reverse, exclusive=exclusive))
    assert_close(f(jnp.asarray(x)), want, rtol=1e-14, atol=1e-14, what="running sum")
    k = np.arange(n)
    L = (k[None, :] >= k[:, None]) if reverse else (k[None, :] <= k[:, None])  # out_i = sum_k L_ik x_k
    if exclusive:
        L = L & (k[None, :] != k[:, None])
    ct = np.random.default_rng(n + 1).normal(size=x.shape)
    assert_close(
        jax.vjp(f, jnp.asarray(x))[1](jnp.asarray(ct))[0], ct @ L.astype(float), rtol=1e-14, atol=1e-14, what="VJP"
    )


# ------------------------------------------------------------------ the host (numpy) Jacobian (jaxstiff.model._host)
@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(joints=random_chains(), seed=st.integers(0, 2**31 - 1))
def test_host_jacobian_matches_finite_differences_on_random_chains(joints, seed):
    """The numpy Jacobian of the task rank check against finite differences of an FK built from
    the drawn URDF numbers, revolute, prismatic, continuous and fixed joints mixed."""
    from jaxstiff.model._host import position_jacobian

    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "random.urdf")
        with open(path, "w") as fh:
            fh.write(_chain_urdf(joints))
        robot = jaxstiff.Robot.from_urdf(path, tip_link=f"l{len(joints)}")
    q = np.random.default_rng(seed).uniform(-3.0, 3.0, size=(2, robot.n))
    J = position_jacobian(robot, q)
    assert J.shape == (2, 6, robot.n)
    for b in range(2):
        T_fd = fd6(lambda x: _fk_from_parameters(joints, x), q[b])
        J_fd = jacobian_from_pose_derivative(_fk_from_parameters(joints, q[b]), T_fd)
        assert_close(J[b], J_fd, rtol=0, atol=1e-10, what="host J vs finite differences")


@pytest.mark.parametrize("key", ROBOT_KEYS)
def test_host_jacobian_matches_the_kernel(key):
    from jaxstiff.model._host import position_jacobian

    robot = get_robot(key)
    q = random_q(robot, (5,), seed=3)
    assert_close(position_jacobian(robot, q), jaxstiff.jacobian(robot, jnp.asarray(q)), rtol=0, atol=1e-12, what="J")


@pytest.mark.parametrize("rows", [(0, 1), (0, 1, 2), (3, 5), (0, 1, 2, 3, 4, 5)])
def test_gradient_of_the_jacobian_alone_through_a_jit_under_vmap(rows):
    """A pattern the batch solvers use: a jitted function returning (p, J), only one of them read,
    its gradient inside vmap inside grad inside vmap, against the same through fk_and_jacobian (a
    closed-form custom JVP with the row subset inside it traced wrong shapes here with JAX 0.10:
    docs/notes/speed.md, 2026-12-03 fourth session)."""
    robot = get_robot("planar")
    Q = jnp.asarray(np.random.default_rng(3).uniform(-1.0, 1.0, (2, 4, robot.n)))
    for k in (0, 1):
        g = jax.jit(lambda q: jaxstiff.position_and_jacobian(robot, q, rows))
        g_ref = jax.jit(
            lambda q: (lambda T, J: (T[..., :3, 3], J[..., list(rows), :]))(*jaxstiff.fk_and_jacobian(robot, q))
        )

        def outer(fn):
            f = lambda q: jnp.sum(jnp.sin(fn(q)[k]))  # noqa: E731,B023
            return jax.vmap(jax.grad(lambda Qb: jnp.sum(jax.vmap(f)(Qb))))(Q)

        assert_close(outer(g), outer(g_ref), rtol=0, atol=1e-12, what=f"output {k}")
