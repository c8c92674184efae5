"""Long chains (issue 24, finding 2): the scan over joints against the unrolled kernel and against an
independent numpy FK (helpers.numpy_fk: 4x4 products), on generated chains with random axes, rotated
and offset origins, revolute, continuous and prismatic joints, fixed joints folded in, locked joints.
No timing here: ``scripts/bench_long_chain.py`` measures compile and run time."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from helpers import assert_close, numpy_fk

import jaxstiff
from jaxstiff.model._generate import GENERATED_TIP_LINK, serial_chain, serial_chain_urdf
from jaxstiff.model._kinematics import fk_and_jacobian_raw, jacobian_tangent
from jaxstiff.model._kinematics_scan import FRAMED_MAX_JOINTS, UNROLL_MAX_JOINTS, kernel_for, uses_scan


def _q(robot: jaxstiff.Robot, size: tuple[int, ...], seed: int) -> np.ndarray:
    """Random joint values within (-1, 1) rad or (-0.1, 0.1) m, locked joints at their values."""
    rng = np.random.default_rng(seed)
    q = rng.uniform(-1.0, 1.0, size + (robot.n,)) * np.where(robot.prismatic, 0.1, 1.0)
    return np.where(robot.free, q, np.nan_to_num(robot.locked_values))


def _locked(n: int, seed: int, aligned: bool = False) -> jaxstiff.Robot:
    """A generated chain with its third joint and, if there is one, its first prismatic joint locked."""
    free = serial_chain(n, seed, aligned=aligned)
    locks = {free.joint_names[2]: 0.4}
    prismatic = [name for name, p in zip(free.joint_names, free.prismatic, strict=True) if p]
    if prismatic:
        locks[prismatic[0]] = -0.05
    return serial_chain(n, seed, locked=locks, aligned=aligned)


def _numpy_jacobian(robot: jaxstiff.Robot, q: np.ndarray, h: float = 1e-6) -> np.ndarray:
    """Geometric Jacobian from central differences of numpy_fk: ``[dp; vee(dR R^T)]`` per joint."""
    T = numpy_fk(robot, q)
    J = np.zeros((6, robot.n))
    for i in range(robot.n):
        e = np.zeros(robot.n)
        e[i] = h
        dT = (numpy_fk(robot, q + e) - numpy_fk(robot, q - e)) / (2 * h)
        W = dT[:3, :3] @ T[:3, :3].T
        J[:3, i] = dT[:3, 3]
        J[3:, i] = [W[2, 1], W[0, 2], W[1, 0]]
    return J


def _check_against_unrolled(robot: jaxstiff.Robot, q: np.ndarray) -> None:
    unrolled = jax.jit(lambda x: fk_and_jacobian_raw(robot, x, kernel="unrolled"))
    scan = jax.jit(lambda x: fk_and_jacobian_raw(robot, x, kernel="scan"))
    framed = jax.jit(lambda x: fk_and_jacobian_raw(robot, x, kernel="framed"))
    for qi in q:  # one configuration per call: the unrolled kernel compiles fastest unbatched
        T_u, J_u = unrolled(jnp.asarray(qi))
        T_s, J_s = scan(jnp.asarray(qi))
        assert_close(T_s, T_u, rtol=0, atol=1e-12, what="T scan vs unrolled")
        assert_close(J_s, J_u, rtol=0, atol=1e-12, what="J scan vs unrolled")
        assert_close(T_s, numpy_fk(robot, qi), rtol=0, atol=1e-12, what="T scan vs numpy_fk")
        if robot.n <= FRAMED_MAX_JOINTS:  # the joint-axis-frame kernel too
            T_f, J_f = framed(jnp.asarray(qi))
            assert_close(T_f, T_u, rtol=0, atol=1e-12, what="T framed vs unrolled")
            assert_close(J_f, J_u, rtol=0, atol=1e-12, what="J framed vs unrolled")
    T_b, J_b = scan(jnp.asarray(q))  # the batched scan equals its own single calls
    for k, qi in enumerate(q):
        T_s, J_s = scan(jnp.asarray(qi))
        assert_close(T_b[k], T_s, rtol=0, atol=1e-14, what="batched scan")
        assert_close(J_b[k], J_s, rtol=0, atol=1e-14, what="batched scan J")


def test_generated_chain_has_every_joint_type_and_is_deterministic():
    robot = serial_chain(30, seed=3)
    assert robot.n == 30
    assert robot.prismatic.any() and (~robot.prismatic).any()
    assert np.isinf(robot.lower).any() and np.isfinite(robot.lower).any()  # continuous and revolute
    text = serial_chain_urdf(30, seed=3)
    assert 'type="fixed"' in text.replace('name="tool" type="fixed"', "")  # a fixed joint inside the chain
    assert text == serial_chain_urdf(30, seed=3) != serial_chain_urdf(30, seed=4)
    with pytest.raises(ValueError, match="n .* must be an integer >= 1"):
        serial_chain_urdf(0)
    with pytest.raises(ValueError, match="prismatic_share"):
        serial_chain_urdf(3, prismatic_share=1.5)


@pytest.mark.parametrize("aligned", [pytest.param(False, marks=pytest.mark.slow), True])
def test_scan_equals_unrolled_at_7_joints(aligned):
    robot = _locked(7, 11, aligned)
    assert robot.n_free < robot.n
    _check_against_unrolled(robot, _q(robot, (3,), seed=1))


@pytest.mark.slow
def test_scan_equals_unrolled_at_30_joints():
    # axis-aligned: a dense chain this long takes minutes to compile unrolled (docs/notes/model.md)
    robot = _locked(30, 5, aligned=True)
    assert uses_scan(robot) and not uses_scan(serial_chain(UNROLL_MAX_JOINTS, seed=5, aligned=True))
    # a chain with rotated frames runs unrolled in joint-axis frames up to FRAMED_MAX_JOINTS, then as the scan
    assert kernel_for(serial_chain(FRAMED_MAX_JOINTS, seed=5)) == "framed"
    assert uses_scan(serial_chain(FRAMED_MAX_JOINTS + 1, seed=5))
    _check_against_unrolled(robot, _q(robot, (2,), seed=2))
    # the public entry points pick the scan here and agree with the forced kernels
    q = jnp.asarray(_q(robot, (4,), seed=3))
    T, J = jaxstiff.fk_and_jacobian(robot, q)
    T_u, J_u = jax.jit(lambda x: fk_and_jacobian_raw(robot, x, kernel="unrolled"))(q[0])
    assert_close(T[0], T_u, rtol=0, atol=1e-12, what="public T vs unrolled")
    assert_close(J[0], J_u, rtol=0, atol=1e-12, what="public J vs unrolled")


def test_public_functions_agree_on_a_long_chain():
    """fk, jacobian, fk_and_jacobian and position_and_jacobian (row subsets) on the scan path, and
    float32 in -> float32 out."""
    robot = _locked(40, 8)
    assert uses_scan(robot)
    q = jnp.asarray(_q(robot, (2, 3), seed=4))
    T, J = jaxstiff.fk_and_jacobian(robot, q)
    assert T.shape == (2, 3, 4, 4) and J.shape == (2, 3, 6, robot.n)
    assert_close(jaxstiff.fk(robot, q), T, rtol=0, atol=0, what="fk")
    assert_close(jaxstiff.jacobian(robot, q), J, rtol=0, atol=0, what="jacobian")
    p, Jr = jaxstiff.position_and_jacobian(robot, q, (0, 2, 4))
    assert_close(p, T[..., :3, 3], rtol=0, atol=0, what="position")
    assert_close(Jr, J[..., (0, 2, 4), :], rtol=0, atol=0, what="rows")
    assert_close(T[..., 3, :], np.broadcast_to([0.0, 0.0, 0.0, 1.0], (2, 3, 4)), rtol=0, atol=0, what="last row")
    T32 = jaxstiff.fk(robot, q.astype(jnp.float32))
    assert T32.dtype == jnp.float32
    assert_close(T32, T, rtol=0, atol=1e-4, what="float32")


def test_scan_matches_numpy_fk_and_finite_differences_at_120_joints():
    robot = _locked(120, 2)
    q = _q(robot, (3,), seed=5)
    T, J = jaxstiff.fk_and_jacobian(robot, jnp.asarray(q))
    for k in range(3):
        assert_close(T[k], numpy_fk(robot, q[k]), rtol=0, atol=1e-12, what=f"T vs numpy_fk, config {k}")
    assert_close(J[0], _numpy_jacobian(robot, q[0]), rtol=0, atol=1e-7, what="J vs finite differences of numpy_fk")


def test_scan_derivatives_match_the_closed_form_tangent():
    """Forward-mode autodiff through the scan against the closed-form derivative of J (from J alone),
    and reverse mode runs (finite gradient of a scalar of the pose)."""
    robot = serial_chain(50, seed=9)
    rng = np.random.default_rng(6)
    q, qd = jnp.asarray(_q(robot, (), seed=6)), jnp.asarray(rng.normal(size=robot.n))
    f = jax.jit(lambda x: fk_and_jacobian_raw(robot, x))
    T, J = f(q)
    (_, _), (dT, dJ_ad) = jax.jvp(f, (q,), (qd,))
    dp, dJ, _ = jacobian_tangent(J, qd)
    assert_close(dp, dT[:3, 3], rtol=0, atol=1e-12, what="dp")
    assert_close(dJ, dJ_ad, rtol=0, atol=1e-11, what="dJ")
    g = jax.grad(lambda x: jnp.sum(f(x)[0][:3, 3] ** 2))(q)
    assert_close(g, 2.0 * np.asarray(T[:3, 3]) @ np.asarray(J[:3]), rtol=0, atol=1e-11, what="grad |p|^2")


@pytest.mark.slow
def test_300_joint_chain_compiles_and_runs():
    robot = serial_chain(300, seed=1)
    q = _q(robot, (2,), seed=7)
    T, J = jaxstiff.fk_and_jacobian(robot, jnp.asarray(q))
    assert T.shape == (2, 4, 4) and J.shape == (2, 6, 300)
    assert np.all(np.isfinite(np.asarray(J)))
    assert_close(T[1], numpy_fk(robot, q[1]), rtol=0, atol=1e-12, what="T vs numpy_fk at 300 joints")
    assert GENERATED_TIP_LINK == robot.tip_link
