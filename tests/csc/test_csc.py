"""Configuration-based Stiffness Control rollout (jaxstiff.csc, seed 001, SPEC section 6).

References outside the code under test: the planar 3R arm in closed form (numpy FK, Jacobian and
u(q)), the numpy chain of tests/helpers.py for the LWR, the start value u = 5995 of the project's planar hold case, central
finite differences, and separate (unbatched) rollouts. The tests share compiled programs (same
robot, settings and shapes) to keep the file fast: XLA compiles each distinct rollout once.
"""

from __future__ import annotations

import dataclasses
import json
import math
import re

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from helpers import DATA_DIR, assert_close, central_diff, numpy_fk, one_value_range_planar

import jaxstiff
from jaxstiff import csc
from jaxstiff.cli import main as cli_main
from jaxstiff.csc import _algebra as algebra
from jaxstiff.csc import _measures as measures
from jaxstiff.csc import _offdiag as offdiag
from jaxstiff.csc import _pose as pose
from jaxstiff.csc import _projections as projections
from jaxstiff.csc import _result as result
from jaxstiff.csc import _rollout as rollout

DATA = DATA_DIR

PLANAR = jaxstiff.Robot.from_urdf("planar_3r")
Q_SEED = np.deg2rad([75.0, -74.74, -76.30])  # seed 000 Fig. 2 posture, the start of the project's planar hold case


def rot2(deg: float) -> np.ndarray:
    c, s = math.cos(math.radians(deg)), math.sin(math.radians(deg))
    return np.array([[c, -s], [s, c]])


K_SEED = rot2(30.0) @ np.diag([3000.0, 1000.0]) @ rot2(30.0).T  # N/m


# ---------------------------------------------------------------- planar 3R in closed form (numpy)
def planar_fk(q) -> np.ndarray:
    c = np.cumsum(np.asarray(q, float), axis=-1)
    return np.stack([np.cos(c).sum(-1), np.sin(c).sum(-1)], axis=-1)


def planar_J(q) -> np.ndarray:
    c = np.cumsum(np.asarray(q, float))
    J = np.zeros((2, 3))
    for i in range(3):
        J[0, i] = -np.sin(c[i:]).sum()
        J[1, i] = np.cos(c[i:]).sum()
    return J


def u_numpy(J, K) -> float:
    Kq = J.T @ K @ J
    iu = np.triu_indices(Kq.shape[0], 1)
    return float(np.sqrt(np.sum(Kq[iu] ** 2)))


X_SEED = planar_fk(Q_SEED)


@pytest.fixture(scope="module")
def hold():
    """The project's planar hold case (seed 001 has no example): 1000 constant steps of 2e-3 rad from the seed posture."""
    return jaxstiff.csc_rollout(PLANAR, np.tile(X_SEED, (1000, 1)), K_SEED, Q_SEED, 2e-3, step="constant")


# ---------------------------------------------------------------- the seed's hold case
def test_seed_start_value_is_5995(hold):
    u0 = u_numpy(planar_J(Q_SEED), K_SEED)
    assert abs(u0 - 5995.0) < 1.0  # independent reproduction of the seed's setup: 5995
    assert_close(hold.u_start, u0, rtol=1e-12, what="u_start vs closed form")


def test_hold_u_falls_by_half_and_matches_closed_form(hold):
    q = np.asarray(hold.q)
    assert q.shape == (1000, 3)
    u_cf = np.array([u_numpy(planar_J(qk), K_SEED) for qk in q])
    assert_close(hold.u, u_cf, rtol=1e-11, what="u along the rollout vs closed form")
    assert u_cf[-1] <= 0.5 * 5995.0, u_cf[-1]


def test_hold_drift_below_1e6_m_over_1000_steps(hold):
    drift = np.linalg.norm(planar_fk(np.asarray(hold.q)) - X_SEED, axis=-1)
    assert drift.max() <= 1e-6, drift.max()
    assert_close(hold.tracking_error, drift, rtol=1e-6, atol=1e-12, what="reported tracking error")
    assert np.all(np.asarray(hold.status) == csc.STATUS_OK)


def test_small_constant_step_never_increases_u(hold):
    q = np.vstack([Q_SEED, np.asarray(hold.q)])
    u = np.array([u_numpy(planar_J(qk), K_SEED) for qk in q])
    assert np.max(np.diff(u)) <= 1e-6 * u[0], np.max(np.diff(u))
    # each null step is beta = 2e-3 rad long (constant step), up to the closed-loop correction
    assert_close(hold.null_step, np.full(1000, 2e-3), rtol=1e-9, what="null step length")


def test_realised_stiffness_matches_numpy(hold):
    k = 500
    J = planar_J(np.asarray(hold.q[k]))
    kj = np.clip(np.diag(J.T @ K_SEED @ J), 1.0, np.inf)
    K_C = np.linalg.inv(J @ np.diag(1.0 / kj) @ J.T)
    assert_close(hold.kj[k], kj, rtol=1e-12, what="kj")
    assert_close(hold.K_C[k], K_C, rtol=1e-9, what="K_C")
    assert_close(hold.frobenius[k], np.linalg.norm(K_SEED - K_C), rtol=1e-9, what="Frobenius")


# ---------------------------------------------------------------- null-space step, first order
def test_null_direction_does_not_move_tcp_to_first_order():
    dqN, u, _ = csc.null_space_direction(PLANAR, jnp.asarray(Q_SEED), jnp.asarray(K_SEED))
    dqN = np.asarray(dqN)
    d = dqN / np.linalg.norm(dqN)
    assert np.linalg.norm(planar_J(Q_SEED) @ d) < 1e-12
    disp = [np.linalg.norm(planar_fk(Q_SEED - h * d) - X_SEED) for h in (1e-2, 1e-3)]
    assert 70.0 < disp[0] / disp[1] < 130.0, disp  # second order: 10x smaller step, 100x less motion
    # and -dq_N lowers u (to first order at the rate |dq_N| . d)
    h = 1e-4
    du = u_numpy(planar_J(Q_SEED - h * d), K_SEED) - float(u)
    assert du < 0 and abs(du / h + np.linalg.norm(dqN)) < 1e-3 * np.linalg.norm(dqN)


def test_null_direction_lwr_locked_joint():
    robot = jaxstiff.Robot.from_urdf("kuka_lwr4", locked={"lwr_a7": 0.0})
    q = np.deg2rad([20.0, 40.0, -30.0, -70.0, 25.0, 50.0, 0.0])
    K = np.diag([3000.0, 1000.0, 2000.0])
    dqN, _, _ = csc.null_space_direction(robot, jnp.asarray(q), jnp.asarray(K))
    d = np.asarray(dqN) / np.linalg.norm(dqN)
    assert d[6] == 0.0  # the locked joint does not take part
    x0 = numpy_fk(robot, q)[:3, 3]
    disp = [np.linalg.norm(numpy_fk(robot, q - h * d)[:3, 3] - x0) for h in (1e-2, 1e-3)]
    assert 70.0 < disp[0] / disp[1] < 130.0, disp


@pytest.mark.parametrize("m", [2, 3, 6])
def test_small_det_and_inverse_with_their_jvps_match_numpy(m):
    """The rollout's closed-form det / SPD inverse (custom JVPs from the primal pass) against numpy
    values and central differences of numpy's det and inv, on a batch of random SPD matrices."""
    rng = np.random.default_rng(7 + m)
    X = rng.normal(size=(4, m, m))
    A = X @ np.swapaxes(X, -1, -2) + 0.5 * np.eye(m)
    dA = rng.normal(size=(4, m, m))
    dA = dA + np.swapaxes(dA, -1, -2)
    det, ddet = jax.jvp(algebra.det_small, (jnp.asarray(A),), (jnp.asarray(dA),))
    inv, dinv = jax.jvp(algebra.spd_inverse, (jnp.asarray(A),), (jnp.asarray(dA),))
    h = 1e-6
    assert_close(det, np.linalg.det(A), rtol=1e-12, atol=0, what="det")
    assert_close(inv, np.linalg.inv(A), rtol=1e-10, atol=1e-12, what="inverse")
    fd_det = (np.linalg.det(A + h * dA) - np.linalg.det(A - h * dA)) / (2 * h)
    fd_inv = (np.linalg.inv(A + h * dA) - np.linalg.inv(A - h * dA)) / (2 * h)
    assert_close(ddet, fd_det, rtol=1e-6, atol=1e-8 * np.max(np.abs(fd_det)), what="d det")
    assert_close(dinv, fd_inv, rtol=1e-6, atol=1e-8 * np.max(np.abs(fd_inv)), what="d inverse")
    # reverse mode goes through the same rules (transposed): grad of a scalar of both
    f = lambda a: jnp.sum(algebra.spd_inverse(a) * dA) + algebra.det_small(a).sum()
    g = np.asarray(jax.grad(f)(jnp.asarray(A)))
    fd = np.array(
        [
            (float(f(jnp.asarray(A + h * E))) - float(f(jnp.asarray(A - h * E)))) / (2 * h)
            for E in np.eye(m * m).reshape(m * m, m, m)[:, None].repeat(4, 1)
        ]
    ).reshape(m, m)
    assert_close(g.sum(0), fd, rtol=1e-6, atol=1e-8 * np.max(np.abs(fd)), what="grad")


@pytest.mark.parametrize("name,task,m", [("planar_3r", "xy", 2), ("kuka_lwr4", "full", 6)])
def test_closed_form_gradient_of_u_equals_autodiff(name, task, m):
    robot = jaxstiff.Robot.from_urdf(name)
    rng = np.random.default_rng(3)
    q = jnp.asarray(rng.uniform(-2, 2, size=(5, robot.n)))
    X = rng.normal(size=(m, m))
    K = jnp.asarray(X @ X.T * 1000.0)
    rows = jaxstiff.stiffness.TASK_ROWS[task]
    u, g = csc.offdiag_gradient(robot, q, K, task)
    ref = jax.jit(jax.vmap(jax.grad(lambda x: jaxstiff.offdiag(jaxstiff.position_and_jacobian(robot, x, rows)[1], K))))(
        q
    )
    assert_close(g, ref, rtol=1e-10, atol=1e-9 * float(jnp.max(jnp.abs(ref))), what="grad u")


@pytest.mark.slow
@pytest.mark.parametrize("task", ["xy", "xyz", "full"])
def test_offdiag_value_and_grad_derivatives_equal_autodiff(task):
    """(u, grad u) carry a hand-written VJP (and its transpose as JVP); both equal plain autodiff
    of the same forward formulas, also at u = 0 (K_xd diagonal, J with orthogonal columns)."""
    rows = jaxstiff.stiffness.TASK_ROWS[task]
    m, n = len(rows), 7
    rng = np.random.default_rng(11)
    cases = []
    for _ in range(3):
        X = rng.normal(size=(m, m))
        cases.append((rng.normal(size=(6, n)), X @ X.T * 1000.0))
    J0 = np.zeros((6, n))
    J0[:m, :m] = np.eye(m)
    cases.append((J0, np.diag(np.arange(1.0, m + 1.0)) * 1000.0))  # u = 0
    for J6, K in cases:
        J6, K = jnp.asarray(J6), jnp.asarray(K)
        ub, gb = jnp.asarray(rng.normal()), jnp.asarray(rng.normal(size=n))
        dJ, dK = jnp.asarray(rng.normal(size=(6, n))), jnp.asarray(rng.normal(size=(m, m)))
        plain = lambda a, b: offdiag.offdiag_forward(a, b, rows)[:2]  # noqa: E731
        ours = lambda a, b: offdiag.offdiag_value_and_grad(a, b, rows)  # noqa: E731
        got_v, want_v = jax.vjp(ours, J6, K)[1]((ub, gb)), jax.vjp(plain, J6, K)[1]((ub, gb))
        got_t, want_t = jax.jvp(ours, (J6, K), (dJ, dK))[1], jax.jvp(plain, (J6, K), (dJ, dK))[1]
        for a, b, what in zip((*got_v, *got_t), (*want_v, *want_t), ("J6 bar", "K bar", "du", "dg"), strict=True):
            b = np.asarray(b)
            assert np.all(np.isfinite(np.asarray(a))), what
            assert_close(a, b, rtol=1e-10, atol=1e-12 * (1.0 + np.max(np.abs(b))), what=what)


def _plain_projections(Jf, dx, vs, nu0, damping):
    """The CSC step's projections written directly (autodiff reference for the hand-written VJP)."""
    Ainv, nu, _ = projections.damped_inverse(Jf, nu0, damping)
    pinv = lambda v: algebra.mtv(Jf, algebra.mv(Ainv, v))  # noqa: E731
    return pinv(dx), tuple(v - pinv(algebra.mv(Jf, v)) for v in vs), nu


@pytest.mark.slow
@pytest.mark.parametrize("m,n", [(2, 3), (3, 7), (6, 7)])
@pytest.mark.parametrize("case", ["regular", "near_singular"])
def test_damped_projections_vjp_and_jvp_equal_autodiff(m, n, case):
    """J+ dx, (I - J+ J) v and the isotropy with their hand-written VJP (and the JVP that is its
    transpose) equal autodiff of the plain formulas, also inside the damping band (nu < nu_th),
    where the damping rule's chain (trace, determinant, threshold) contributes; and their
    cotangents reach every input, nu0 and damping included."""
    rng = np.random.default_rng(10 * m + n)
    J = rng.normal(size=(m, n))
    if case == "near_singular":
        J[1] = J[0] * 0.999 + 1e-3 * rng.normal(size=n)
    args = (
        jnp.asarray(J),
        jnp.asarray(rng.normal(size=m)),
        (jnp.asarray(rng.normal(size=n)), jnp.asarray(rng.normal(size=n))),
        jnp.asarray(1e-2),
        jnp.asarray(0.1),
    )
    _, _, nu = jax.jit(projections.damped_projections)(*args)
    assert (float(nu) < 1e-2 ** (m / 2)) == (case == "near_singular")  # the case is what it says
    w = [jnp.asarray(rng.normal(size=n)) for _ in range(3)]

    def loss(f):
        def inner(*a):
            dqP, (p1, p2), nu = f(*a)
            return jnp.sum(w[0] * jnp.sin(dqP)) + jnp.sum(w[1] * p1) + jnp.sum(w[2] * p2 * p2) + 3.0 * nu

        return inner

    for a, b in zip(
        jax.tree.leaves(jax.jit(projections.damped_projections)(*args)),
        jax.tree.leaves(jax.jit(_plain_projections)(*args)),
        strict=True,
    ):
        assert_close(a, b, rtol=1e-13, atol=1e-13, what="values")
    got = jax.jit(jax.grad(loss(projections.damped_projections), argnums=(0, 1, 2, 3, 4)))(
        *args
    )  # jitted: no op-by-op dispatch
    want = jax.jit(jax.grad(loss(_plain_projections), argnums=(0, 1, 2, 3, 4)))(*args)
    for a, b in zip(jax.tree.leaves(got), jax.tree.leaves(want), strict=True):
        assert_close(a, b, rtol=1e-9, atol=1e-9 * (1.0 + float(np.max(np.abs(np.asarray(b))))), what="VJP")
    tangents = jax.tree.map(lambda x: jnp.asarray(rng.normal(size=np.shape(x))), args)
    got_t = jax.jit(lambda a, t: jax.jvp(projections.damped_projections, a, t)[1])(args, tangents)
    want_t = jax.jit(lambda a, t: jax.jvp(_plain_projections, a, t)[1])(args, tangents)
    for a, b in zip(jax.tree.leaves(got_t), jax.tree.leaves(want_t), strict=True):
        assert_close(a, b, rtol=1e-9, atol=1e-9 * (1.0 + float(np.max(np.abs(np.asarray(b))))), what="JVP")


@pytest.mark.slow
def test_damped_projections_of_a_zero_jacobian_are_finite():
    """Every joint frozen (J = 0, the re-solve after all joints saturate): J+ = 0 exactly, the
    projection is the identity, and values and gradients are finite (the damped inverse of the
    zero matrix used to underflow to 1/0)."""
    for m in (2, 3, 6):
        Jf = jnp.zeros((m, 4))
        dx, v = jnp.ones(m), jnp.arange(1.0, 5.0)
        dqP, (Pv,), nu = jax.jit(projections.damped_projections)(Jf, dx, (v,), jnp.asarray(1e-2), jnp.asarray(0.1))
        assert np.all(np.asarray(dqP) == 0.0) and np.all(np.asarray(Pv) == np.asarray(v)) and float(nu) == 0.0
        g = jax.jit(
            jax.grad(
                lambda J, dx=dx, v=v: jnp.sum(projections.damped_projections(J, dx, (v,), 1e-2, 0.1)[0] ** 2 + 1.0)
            )
        )(Jf)
        assert np.all(np.isfinite(np.asarray(g)))


@pytest.mark.slow
@pytest.mark.parametrize("task,m", [("xy", 2), ("xyz", 3), ("full", 6)])
def test_realised_stiffness_vjp_and_jvp_equal_autodiff(task, m):
    """(K_C, |K_xd - K_C|_F) with its hand-written VJP / transposed JVP equal autodiff of
    cartesian_stiffness and frobenius (whose inverse has the JVP -K dC K)."""
    rng = np.random.default_rng(m)
    n = 7
    J, kj = jnp.asarray(rng.normal(size=(m, n))), jnp.asarray(rng.uniform(1.0, 5.0, size=n))
    A = rng.normal(size=(m, m))
    K = jnp.asarray(A @ A.T + m * np.eye(m))

    def plain(J, kj, K):
        KC = jaxstiff.cartesian_stiffness(J, kj, task)
        return KC, jaxstiff.frobenius(KC, K)

    ours = lambda J, kj, K: measures.realised_stiffness(J, kj, K, task)  # noqa: E731
    W = jnp.asarray(rng.normal(size=(m, m)))
    loss = lambda f: lambda *a: (lambda o: jnp.sum(W * o[0]) + 2.5 * o[1])(f(*a))  # noqa: E731
    grads = [jax.jit(jax.grad(loss(f), argnums=(0, 1, 2)))(J, kj, K) for f in (ours, plain)]
    for a, b in zip(*grads, strict=True):
        assert_close(a, b, rtol=1e-10, atol=1e-12 * (1.0 + float(np.max(np.abs(np.asarray(b))))), what="VJP")
    for tangents in [
        (J * 0.0 + 1.0, kj * 0.0, K * 0.0),
        (J * 0.0, jnp.asarray(rng.normal(size=n)), K * 0.0),
        (J * 0.0, kj * 0.0, W + W.T),
    ]:
        tans = [jax.jit(lambda p, t, f=f: jax.jvp(f, p, t)[1])((J, kj, K), tangents) for f in (ours, plain)]
        for a, b in zip(*tans, strict=True):
            assert_close(a, b, rtol=1e-10, atol=1e-12 * (1.0 + float(np.max(np.abs(np.asarray(b))))), what="JVP")


@pytest.mark.parametrize("poly", [False, True])
def test_kinematics_jvp_closed_form_equals_autodiff(poly):
    """The rollout's kinematics carry a closed-form JVP (built from J alone); it equals autodiff
    (with XLA's cos/sin, and with the polynomial ones that rollout batches of >= 64 use)."""
    robot = jaxstiff.Robot.from_urdf("kuka_lwr4")
    rng = np.random.default_rng(4)
    q, qd = jnp.asarray(rng.uniform(-2, 2, robot.n)), jnp.asarray(rng.normal(size=robot.n))
    got = jax.jit(lambda x, xd: jax.jvp(lambda y: pose.pose_jac(robot, poly, y), (x,), (xd,))[1])(q, qd)

    def ref(x):
        T, J = jaxstiff.fk_and_jacobian(robot, x)
        return T[:3, 3], T[:3, :3], J

    want = jax.jit(lambda x, xd: jax.jvp(ref, (x,), (xd,))[1])(q, qd)  # jitted: no op-by-op dispatch
    for a, b, name in zip(got, want, ("dp", "dR", "dJ"), strict=True):
        assert_close(a, b, rtol=1e-12, atol=1e-12, what=name)


# ---------------------------------------------------------------- gradients through a rollout
T_GRAD = 200


def _loss(x, path, check_reach=True):
    """A smooth scalar of a 200-step adaptive rollout; x = (beta, theta, k1/3000, k2/1000, q0 (3));
    ``check_reach`` False: a path that leaves the reach is rolled out (not refused up front)."""
    th = x[1]
    c, s = jnp.cos(th), jnp.sin(th)
    R = jnp.stack([jnp.stack([c, -s]), jnp.stack([s, c])])
    K = R @ jnp.diag(jnp.stack([3000.0 * x[2], 1000.0 * x[3]])) @ R.T
    r = jaxstiff.csc_rollout(PLANAR, path, K, x[4:], x[0], step="adaptive", check_reach=check_reach)
    return jnp.mean(r.u) / 1000.0 + jnp.mean(r.frobenius) / 1000.0 + 100.0 * jnp.mean(r.tracking_error)


X_GRAD = np.concatenate([[1.0, math.pi / 6, 1.0, 1.0], Q_SEED])
LINE = X_SEED + np.linspace(0.0, 1.0, T_GRAD)[:, None] * np.array([-0.4, 0.3])


@pytest.mark.slow
def test_gradient_through_200_steps_matches_central_differences():
    g = np.asarray(jax.grad(_loss)(jnp.asarray(X_GRAD), LINE))
    fd = central_diff(lambda x: float(_loss(jnp.asarray(x), LINE)), X_GRAD, h=1e-5)[0]
    assert np.all(np.isfinite(g))
    assert_close(g, fd, rtol=1e-5, atol=1e-5 * np.max(np.abs(fd)), what="d loss / (beta, K params, q0)")


@pytest.mark.slow
@pytest.mark.parametrize("shift", [0.0, 1e-15, -1e-15])
def test_adaptive_gradient_when_the_path_starts_at_the_tcp(shift):
    """|dq_P| has a kink at dx = 0; a path that starts exactly at the start TCP sits on it, and the
    FK's round-off (a shift of 1e-15 m) decided which one-sided derivative autodiff took: 2-4x off
    (even of the other sign) against central differences. Below 10 eps |dq_P| counts as 0, so the
    derivative there is the symmetric one, equal to central differences whatever the round-off."""
    x0 = np.asarray(PLANAR.fk(Q_SEED))[:2, 3] + shift
    path = x0 + (np.arange(30) / 200.0)[:, None] * np.array([-0.4, 0.3])

    def loss(q0):
        r = jaxstiff.csc_rollout(PLANAR, path, K_SEED, q0, 1.0, step="adaptive")
        return jnp.mean(r.u) / 1000.0 + jnp.mean(r.frobenius) / 1000.0

    g = np.asarray(jax.grad(loss)(jnp.asarray(Q_SEED)))
    fd = central_diff(lambda q: float(loss(jnp.asarray(q))), Q_SEED, h=1e-6)[0]
    assert_close(g, fd, rtol=1e-5, atol=1e-6 * np.max(np.abs(fd)), what=f"d loss / d q0, path shifted {shift:g} m")


@pytest.mark.slow
def test_no_null_step_without_a_null_space():
    """Two free joints, two task rows (planar 3R, joint 3 locked), near the stretched posture: there
    is no null space, and (I - J+ J) grad u is only round-off or, damped, a leftover that the
    adaptive rule scaled up to |dq_P| (0.17 rad steps in an audit). The null step is now zero
    (status 8), and beta changes nothing."""
    robot = jaxstiff.Robot.from_urdf("planar_3r", locked={"joint_3": 0.0})
    q0 = np.array([0.2, 0.05, 0.0])
    x0 = np.asarray(robot.fk(q0))[:2, 3]
    path = x0 + (np.arange(40) / 40.0)[:, None] * np.array([-0.3, 0.1])  # inward, from the TCP
    r1 = jaxstiff.csc_rollout(robot, path, K_SEED, q0, 1.0, step="adaptive")
    r0 = jaxstiff.csc_rollout(robot, path, K_SEED, q0, 0.0, step="adaptive")
    assert np.any(np.asarray(r1.status) & csc.STATUS_DAMPED)  # the case where the leftover was large
    assert np.all(np.asarray(r1.null_step) == 0.0)
    assert np.all(np.asarray(r1.status) & csc.STATUS_NULL_SMALL)
    assert_close(r1.q, r0.q, rtol=0, atol=1e-15, what="q with beta 1 vs beta 0")
    # a redundant arm still moves in its null space
    r3 = jaxstiff.csc_rollout(PLANAR, np.tile(X_SEED, (5, 1)), K_SEED, Q_SEED, 2e-3, step="constant")
    assert np.all(np.asarray(r3.null_step) > 1e-3)


@pytest.mark.slow
def test_forward_mode_equals_reverse_mode_and_hessian_is_finite():
    """The rollout's closed-form derivatives are custom JVPs (reverse mode transposes them), so
    jax.jvp / jacfwd / hessian work too: forward and reverse mode agree, the hessian matches
    central differences of the gradient."""
    x = jnp.asarray(X_GRAD)
    line = LINE[:40]
    g_rev = np.asarray(jax.grad(_loss)(x, line))
    g_fwd = np.asarray(jax.jacfwd(_loss)(x, line))
    assert_close(g_fwd, g_rev, rtol=1e-10, atol=1e-12 * np.max(np.abs(g_rev)), what="jacfwd vs grad")
    f_beta = lambda b: _loss(x.at[0].set(b), line)  # noqa: E731
    h = float(jax.hessian(f_beta)(x[0]))
    d = 1e-4
    fd = (float(jax.grad(f_beta)(x[0] + d)) - float(jax.grad(f_beta)(x[0] - d))) / (2 * d)
    assert math.isfinite(h) and abs(h - fd) <= 1e-5 * max(abs(fd), 1e-6), (h, fd)


def test_no_nan_through_a_singular_posture():
    """A path from the stretched (singular) posture outwards beyond reach: damping keeps it finite."""
    x = X_GRAD.copy()
    x[4:] = 0.0  # fully stretched along x: J loses rank for the xy task
    path = np.stack([np.linspace(3.0, 3.1, T_GRAD), np.zeros(T_GRAD)], axis=-1)  # beyond reach at the end
    # (the API refuses such a path up front, tests/model/test_reach.py; here the rollout runs it on purpose)
    r = jaxstiff.csc_rollout(PLANAR, path, K_SEED, x[4:], 1.0, check_reach=False)
    for name, a in r.as_dict().items():
        assert np.all(np.isfinite(np.asarray(a))), name
    assert np.all(np.asarray(r.status) & csc.STATUS_DAMPED)
    assert float(r.tracking_error[-1]) < 0.11  # the closest it can get: 0.1 m short of the target
    g = jax.grad(_loss)(jnp.asarray(x), path, False)
    assert np.all(np.isfinite(np.asarray(g)))
    x[4:] = [1e-7, -1e-7, 1e-7]  # near singular
    g = jax.grad(_loss)(jnp.asarray(x), path, False)
    assert np.all(np.isfinite(np.asarray(g)))


# ---------------------------------------------------------------- batching
@pytest.mark.slow
def test_batch_equals_separate_rollouts():
    T = T_GRAD  # singles reuse the forward program of the finite-difference test
    rng = np.random.default_rng(5)
    q0 = Q_SEED + rng.uniform(-0.05, 0.05, size=(3, 3))
    beta = np.array([0.5, 1.0, 2.0])
    K = np.stack([rot2(a) @ np.diag([3000.0, 1000.0]) @ rot2(a).T for a in (0.0, 30.0, 60.0)])
    paths = np.stack(
        [X_SEED + np.linspace(0, 1, T)[:, None] * np.array(v) for v in ([-0.3, 0.2], [0.2, 0.2], [0.0, -0.4])]
    )
    batched = jaxstiff.csc_rollout(PLANAR, paths, K, q0, beta)
    chunked = jaxstiff.csc_rollout(PLANAR, paths, K, q0, beta, chunk=2)  # lax.map over chunks, with a remainder
    assert batched.q.shape == (3, T, 3) and batched.K_C.shape == (3, T, 2, 2) and batched.u_start.shape == (3,)
    for b in range(3):
        single = jaxstiff.csc_rollout(PLANAR, paths[b], K[b], q0[b], beta[b])
        for name, a in single.as_dict().items():
            assert_close(getattr(batched, name)[b], a, rtol=1e-12, atol=1e-9, what=f"vmap {name}[{b}]")
            assert_close(getattr(chunked, name)[b], a, rtol=1e-12, atol=1e-9, what=f"chunked {name}[{b}]")
    # broadcasting: one path and K_xd for a batch of 3 starts
    bc = jaxstiff.csc_rollout(PLANAR, paths[1], K[1], q0, beta)
    assert bc.q.shape == (3, T, 3)


def test_varying_kxd(hold):
    T = 1000
    # K_xd varying along the path (T, m, m), here all equal, gives the constant-K_xd rollout
    same = jaxstiff.csc_rollout(
        PLANAR, np.tile(X_SEED, (T, 1)), np.broadcast_to(K_SEED, (T, 2, 2)), Q_SEED, 2e-3, step="constant"
    )
    assert_close(same.q, hold.q, rtol=1e-13, atol=1e-14, what="varying (all equal) vs constant K_xd")
    # K_xd turning by 90 degrees while the TCP holds still: u is reported against each waypoint's K_xd
    Ks = np.stack([rot2(a) @ np.diag([3000.0, 1000.0]) @ rot2(a).T for a in np.linspace(0, 90, T)])
    r = jaxstiff.csc_rollout(PLANAR, np.tile(X_SEED, (T, 1)), Ks, Q_SEED, 2e-3, step="constant")
    u_cf = np.array([u_numpy(planar_J(np.asarray(r.q[k])), Ks[k]) for k in range(T)])
    assert_close(r.u, u_cf, rtol=1e-11, what="u against the waypoint's own K_xd")
    assert abs(float(r.u_start) - u_numpy(planar_J(Q_SEED), Ks[0])) < 1e-9 * float(r.u_start)


# ---------------------------------------------------------------- limits, locks, dtype
_LOWER = list(PLANAR.lower_limits)
_LOWER[2] = math.radians(-80.0)  # the seed's hold drives joint 3 past -110 deg without this limit
PLANAR_LIM = dataclasses.replace(PLANAR, lower_limits=tuple(_LOWER))
HOLD_300 = np.tile(X_SEED, (300, 1))


def test_joint_limit_saturation_keeps_tcp_and_limit():
    robot = PLANAR_LIM
    r = jaxstiff.csc_rollout(robot, HOLD_300, K_SEED, Q_SEED, 2e-3, step="constant")
    q = np.asarray(r.q)
    assert q[:, 2].min() >= math.radians(-80.0) - 1e-12
    assert np.any(np.asarray(r.status) & csc.STATUS_JOINT_LIMIT)
    drift = np.linalg.norm(planar_fk(q) - X_SEED, axis=-1)
    assert drift.max() < 1e-6, drift.max()


@pytest.mark.slow
def test_gradient_with_an_active_joint_limit_is_finite_and_matches_differences():
    """Joint 3 runs into its limit at step ~50 and sits there for the rest (clamped, re-solved with
    the other joints): the gradient w.r.t. beta and q0 stays finite and agrees with central
    differences to a few percent. Only loosely: at the limit every step decides whether the
    joint is pushed past it, so the loss is piecewise smooth with kinks on a fine scale
    (differences with h = 1e-7 ... 1e-8 scatter by tens of percent; h = 1e-5 averages over them)."""

    def loss(x):
        r = jaxstiff.csc_rollout(PLANAR_LIM, HOLD_300, K_SEED, x[1:], x[0], step="constant")
        return jnp.mean(r.u) / 1000.0 + 100.0 * jnp.mean(r.tracking_error)

    x = np.concatenate([[2e-3], Q_SEED])
    status = np.asarray(jaxstiff.csc_rollout(PLANAR_LIM, HOLD_300, K_SEED, Q_SEED, 2e-3, step="constant").status)
    assert 10 < np.argmax(status & csc.STATUS_JOINT_LIMIT) < 290  # the limit is reached inside the rollout
    g = np.asarray(jax.grad(loss)(jnp.asarray(x)))
    assert np.all(np.isfinite(g))
    fd = central_diff(lambda v: float(loss(jnp.asarray(v))), x, h=1e-5)[0]
    assert_close(g, fd, rtol=0.05, atol=0.0, what="d loss / (beta, q0) with a joint at its limit")


@pytest.mark.slow
def test_chunked_batch_with_some_rollouts_at_a_limit_equals_separate_rollouts():
    """The saturation re-solve runs only in chunks where some rollout reaches a limit (a branch on
    the batch): a chunk with one saturating and one free rollout, a chunk with neither, and a
    remainder; values and the gradient of a batch loss equal those of separate rollouts."""
    rng = np.random.default_rng(6)
    q0 = Q_SEED + rng.uniform(-1e-3, 1e-3, size=(5, 3))
    beta = np.array([2e-3, 1e-5, 1e-5, 2e-3, 1e-5])  # the small steps never reach the -80 deg limit
    chunked = jaxstiff.csc_rollout(PLANAR_LIM, HOLD_300, K_SEED, q0, beta, step="constant", chunk=2)
    hit = (np.asarray(chunked.status) & csc.STATUS_JOINT_LIMIT).any(axis=1)
    assert hit[0] and hit[3] and not hit[1] and not hit[2], hit

    def loss(x, b):
        r = jaxstiff.csc_rollout(
            PLANAR_LIM, HOLD_300, K_SEED, x, beta[b] if b is not None else beta, step="constant", chunk=2
        )
        return jnp.sum(jnp.mean(r.u, axis=-1))

    g_batch = np.asarray(jax.grad(loss)(jnp.asarray(q0), None))
    for b in range(5):
        single = jaxstiff.csc_rollout(PLANAR_LIM, HOLD_300, K_SEED, q0[b], beta[b], step="constant")
        for name in ("q", "u", "status", "frobenius"):
            assert_close(getattr(chunked, name)[b], getattr(single, name), rtol=1e-12, atol=1e-9, what=f"{name}[{b}]")
        assert_close(g_batch[b], jax.grad(loss)(jnp.asarray(q0[b]), b), rtol=1e-9, atol=1e-9, what=f"grad[{b}]")


@pytest.mark.slow
def test_every_joint_saturating_moves_to_the_limits_without_nan():
    """All free joints pushed past their limits in one step: the re-solve has no joint left (J = 0);
    the step still takes every joint to its limit (no NaN guard, finite gradient)."""
    lo, hi = Q_SEED - 1e-3, Q_SEED + 1e-3
    robot = dataclasses.replace(PLANAR, lower_limits=tuple(lo), upper_limits=tuple(hi))
    path = X_SEED + np.linspace(0.0, 1.0, 20)[:, None] * np.array([0.5, -0.5])  # far faster than 1 mrad per step

    def loss(x):
        return jnp.mean(jaxstiff.csc_rollout(robot, path, K_SEED, x, 2e-3, step="constant").u)

    r = jaxstiff.csc_rollout(robot, path, K_SEED, Q_SEED, 2e-3, step="constant")
    status = np.asarray(r.status)
    assert not np.any(status & csc.STATUS_NAN), status
    assert np.all(status[1:] & csc.STATUS_JOINT_LIMIT)
    q = np.asarray(r.q)
    assert np.all(np.isclose(q[2:], lo) | np.isclose(q[2:], hi))  # every joint sits at a limit
    assert np.all(np.isfinite(np.asarray(jax.grad(loss)(jnp.asarray(Q_SEED)))))


@pytest.mark.slow
def test_locked_joint_never_moves_lwr():
    robot = jaxstiff.Robot.from_urdf("kuka_lwr4", locked={"lwr_a7": 0.3, "lwr_a3": -0.2})
    q0 = np.where(robot.free, np.deg2rad([20.0, 40.0, 0.0, -70.0, 25.0, 50.0, 0.0]), robot.locked_values)
    x0 = numpy_fk(robot, q0)[:3, 3]
    t = np.linspace(0.0, 1.0, 60)[:, None]
    path = x0 + 0.1 * np.hstack([np.sin(np.pi * t), t - t**2, 0.0 * t])
    K = np.diag([3000.0, 1000.0, 2000.0])
    r = jaxstiff.csc_rollout(robot, path, K, q0, 1.0, newton=1, joint_limits="priority", jl_gain=0.01)
    q = np.asarray(r.q)
    assert np.all(q[:, 6] == 0.3) and np.all(q[:, 2] == -0.2)
    assert np.all(q >= robot.lower - 1e-12) and np.all(q <= robot.upper + 1e-12)
    pos = np.array([numpy_fk(robot, qk)[:3, 3] for qk in q])
    assert np.linalg.norm(pos - path, axis=-1).max() < 1e-6  # one Newton correction per step
    assert float(r.u[-1]) < float(r.u_start)


@pytest.mark.slow
def test_full_task_holds_position_and_orientation():
    """Task "full" (6 rows): the 7-joint LWR has one redundant DOF; the tool orientation is held."""
    robot = jaxstiff.Robot.from_urdf("kuka_lwr4")
    q0 = np.deg2rad([20.0, 40.0, -30.0, -70.0, 25.0, 50.0, 10.0])
    T0 = numpy_fk(robot, q0)
    K = np.diag([3000.0, 1000.0, 1000.0, 100.0, 100.0, 100.0])
    r = jaxstiff.csc_rollout(robot, np.tile(T0[:3, 3], (100, 1)), K, q0, 2e-3, step="constant")
    assert r.K_C.shape == (100, 6, 6)
    q = np.asarray(r.q)
    assert np.abs(q[-1] - q0).max() > 0.05  # it moved along the self-motion
    for qk in q[::10]:
        Tk = numpy_fk(robot, qk)
        assert np.linalg.norm(Tk[:3, 3] - T0[:3, 3]) < 1e-5
        assert np.linalg.norm(Tk[:3, :3] - T0[:3, :3]) < 1e-4
    assert float(r.orientation_error.max()) < 1e-4
    assert float(r.u[-1]) < float(r.u_start)


def test_orientation_error_is_the_rotation_angle():
    """CSCResult.orientation_error is an angle: compared with the angle of an axis-angle rotation
    built with numpy (Rodrigues), from 1e-9 rad to just below pi, and with an autodiff-finite gradient at 0."""
    rng = np.random.default_rng(3)
    Rd = np.linalg.qr(rng.normal(size=(3, 3)))[0]
    Rd *= np.sign(np.linalg.det(Rd))  # a rotation (det +1)
    for th in (1e-9, 1e-3, 0.5, 1.5, 3.0, 3.14):
        a = rng.normal(size=3)
        a /= np.linalg.norm(a)
        S = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
        Rot = np.eye(3) + np.sin(th) * S + (1 - np.cos(th)) * S @ S
        got = float(pose.orientation_angle(jnp.asarray(Rot @ Rd), jnp.asarray(Rd)))
        assert abs(got - th) <= 1e-12 * max(1.0, th), (th, got)
    g = jax.grad(lambda R: pose.orientation_angle(R, jnp.asarray(Rd)))(jnp.asarray(Rd))
    assert np.all(np.isfinite(np.asarray(g)))


@pytest.mark.slow
def test_float32_stays_float32():
    r = jaxstiff.csc_rollout(
        PLANAR,
        np.tile(X_SEED, (20, 1)).astype(np.float32),
        K_SEED.astype(np.float32),
        Q_SEED.astype(np.float32),
        np.float32(2e-3),
        step="constant",
    )
    assert r.q.dtype == jnp.float32 and r.u.dtype == jnp.float32 and r.K_C.dtype == jnp.float32
    assert np.all(np.isfinite(np.asarray(r.u))) and float(r.u[-1]) < float(r.u_start)


def test_second_call_does_not_recompile(hold):
    fn = rollout.rollout_batch_jit(jax.default_backend(), True)  # the top-level (eager call) compilation
    before = fn._cache_size()
    assert before >= 1  # the fixture's rollout was compiled by this function
    jaxstiff.csc_rollout(PLANAR, np.tile(X_SEED, (1000, 1)), K_SEED, Q_SEED + 0.01, 1e-3, step="constant")
    assert fn._cache_size() == before


def test_path_object_is_accepted(hold):
    from jaxstiff.paths import Path

    path = Path(
        np.hstack([np.tile(X_SEED, (1000, 1)), np.zeros((1000, 1))]), directions=np.tile([1.0, 0.0, 0.0], (1000, 1))
    )
    r = jaxstiff.csc_rollout(PLANAR, path, K_SEED, Q_SEED, 2e-3, step="constant")
    assert_close(r.q, hold.q, rtol=0, atol=0)


# ---------------------------------------------------------------- bad input
@pytest.mark.parametrize(
    "kwargs,match",
    [
        (dict(K_xd=np.eye(3)), "task 'xy' needs K_xd"),
        (dict(K_xd=np.array([[1.0, 2.0], [0.0, 1.0]])), "symmetric"),
        (dict(K_xd=np.diag([3000.0, -1000.0])), r"positive semi-definite .* eigenvalues -1000 to 3000"),
        (dict(q0=np.zeros(4)), "q0 must have shape"),
        (dict(q0=np.array([0.0, 0.0, 4.0])), "joint_3.*outside its limits"),
        (dict(beta=-1.0), "beta must be >= 0"),
        (dict(path=np.zeros((5, 4))), "path points"),
        (dict(path=np.array([[np.nan, 0.0]])), "path contains NaN"),
        (dict(step="fast"), "step must be"),
        (dict(kmin=0.0), "kmin must be a finite number > 0"),
        (dict(kmin=np.inf), "kmin must be a finite number > 0"),
        # finite, but u and the Frobenius error would square it into inf (found by an adversarial run)
        (dict(K_xd=np.diag([1e300, 1e299])), r"K_xd has an entry of 1e\+300 N/m; at most 1e\+100"),
        (dict(newton=-1), "newton"),
        (dict(joint_limits="hard"), "joint_limits"),
        (dict(q0=Q_SEED.astype(np.float16)), "q0 has dtype float16.*pass float32 or float64"),
        (dict(chunk=0), "chunk must be a positive integer"),
        (dict(K_xd=K_SEED + 1j), "K_xd is complex"),
        (dict(chunk=1.5), "chunk must be a positive integer"),
    ],
)
def test_bad_input_raises_clear_value_error(kwargs, match):
    args = dict(path=np.tile(X_SEED, (3, 1)), K_xd=K_SEED, q0=Q_SEED, beta=1.0)
    args.update(kwargs)
    call = {k: args.pop(k) for k in ("path", "K_xd", "q0", "beta")}
    task = "xy" if "K_xd" in kwargs else None
    with pytest.raises(ValueError, match=match):
        jaxstiff.csc_rollout(PLANAR, call["path"], call["K_xd"], call["q0"], call["beta"], task=task, **args)


def test_task_the_robot_cannot_control_is_refused():
    """A planar chain asked for xyz (vz row dead everywhere: K_C would be the regulariser's 1e12) or
    an arm with fewer free joints than task rows (the path cannot be followed): the call must fail
    and say why."""
    path = np.tile(np.r_[X_SEED, 0.0], (3, 1))
    with pytest.raises(ValueError, match=r"task 'xyz'.*vz.*zero at every posture.*use task 'xy'"):
        jaxstiff.csc_rollout(PLANAR, path, np.diag([3000.0, 1000.0, 500.0]), Q_SEED, 1.0)
    lwr5 = jaxstiff.Robot.from_urdf("kuka_lwr4", locked={"lwr_a3": 0.0, "lwr_a7": 0.0})
    with pytest.raises(
        ValueError,
        match=r"task 'full' controls 6 Cartesian rows .* only 5 free joint.*cannot be followed.*or unlock joints",
    ):
        jaxstiff.csc_rollout(lwr5, np.array([[0.0, 0.3, 0.9]]), np.eye(6) * 1e3, np.full(7, 0.3) * lwr5.free, 1.0)


# ---------------------------------------------------------------- command line
def test_cli_hold_writes_result_file(tmp_path, capsys, hold):
    out = tmp_path / "hold.npz"
    rc = cli_main(
        [
            "csc",
            "--robot",
            "planar_3r",
            "--hold",
            f"{float(X_SEED[0])!r},{float(X_SEED[1])!r}",
            "--kxd",
            "3000,1000@30",
            "--q0-deg",
            "75,-74.74,-76.30",
            "--beta",
            "2e-3",
            "--step",
            "constant",
            "--steps",
            "1000",
            "--out",
            str(out),
        ]
    )
    assert rc == 0
    text = capsys.readouterr().out
    assert "u:" in text and "5994.9" in text
    with np.load(out, allow_pickle=False) as f:
        assert f["q"].shape == (1, 1000, 3)
        assert_close(f["u"][0], hold.u, rtol=1e-12, what="CLI u vs library")
        assert list(f["joint_names"]) == list(PLANAR.joint_names)
        meta = json.loads(str(f["meta"]))
    assert meta["step"] == "constant" and meta["task"] == "xy" and meta["beta"] == 2e-3
    assert [p.name for p in tmp_path.iterdir()] == ["hold.npz"]  # no temporary file left behind


def test_cli_warns_when_a_path_ends_off_its_target(tmp_path, capsys):
    """Holding a point the arm cannot attain: the file is written, and stderr says the rollout ends
    far from the target instead of only printing the number. The point (0.2, 0) lies within the
    planar arm's 1.66 m radius, so the reach check lets it through, but the joint limits keep the
    TCP at least 0.55 m from the base (a point beyond the radius is refused: tests/model/test_reach.py)."""
    out = tmp_path / "far.npz"
    rc = cli_main(
        [
            "csc",
            "--robot",
            str(DATA / "planar_4r_tight_limits.urdf"),
            "--hold",
            "0.2,0",
            "--kxd",
            "3000,1000",
            "--q0",
            "0,0.8,0,0.7",
            "--steps",
            "20",
            "--out",
            str(out),
        ]
    )
    err = capsys.readouterr().err
    assert rc == 0 and out.exists()
    assert re.search(
        r"warning: path 0 ends 0\.[3-9]\d* m from its last waypoint .*start posture's TCP is 1\.\d+ m from the first",
        err,
    ), err


@pytest.mark.slow
def test_cli_warns_when_the_arm_stays_at_a_singular_start(tmp_path, capsys):
    """The LWR straight up (a singular posture) with a target 0.2 m down its own axis: no joint
    moves the TCP along the arm, so the damped step is zero and the rollout stays there. The warning
    says so (it used to suggest only starting on the path); a bent start reaches the target."""
    out = tmp_path / "s.npz"
    lwr = jaxstiff.Robot.from_urdf("kuka_lwr4", locked={"lwr_a7": 0.0})
    tcp = np.asarray(lwr.fk(np.zeros(7)))[:3, 3]
    hold = ",".join(repr(float(v)) for v in tcp - [0.0, 0.0, 0.2])
    argv = [
        "csc",
        "--robot",
        "kuka_lwr4",
        "--lock",
        "lwr_a7=0",
        "--hold",
        hold,
        "--kxd",
        "3000,1000,2000",
        "--steps",
        "30",
        "--step",
        "constant",
        "--beta",
        "1e-3",
        "--out",
        str(out),
    ]
    assert cli_main(argv + ["--q0", "0,0,0,0,0,0,0"]) == 0
    err = capsys.readouterr().err
    assert "stayed in a (near) singular posture" in err and "start from a bent posture" in err, err
    with np.load(out) as f:
        assert f["status"][0, 0] & jaxstiff.csc.STATUS_DAMPED and f["tracking_error"][0, -1] > 0.19
    assert cli_main(argv + ["--q0", "0,0.3,0,-0.6,0,0.3,0"]) == 0
    assert "singular" not in capsys.readouterr().err


def test_cli_warns_when_task_xy_ignores_the_targets_z(tmp_path, capsys):
    """Task xy tracks x, y only: a 3-D --hold whose z is not the TCP's gets a warning naming the
    ignored z (it used to be dropped silently); a z equal to the TCP's, or a 2-D point, none."""
    z_tcp = float(PLANAR.fk(Q_SEED)[2, 3])
    x, y = float(X_SEED[0]), float(X_SEED[1])
    base = ["csc", "--robot", "planar_3r", "--kxd", "3000,1000", "--q0-deg", "75,-74.74,-76.30", "--steps", "3"]
    for hold, warned in (
        (f"{x!r},{y!r},{z_tcp + 0.5!r}", True),
        (f"{x!r},{y!r},{z_tcp!r}", False),
        (f"{x!r},{y!r}", False),
    ):
        assert cli_main(base + ["--hold", hold, "--out", str(tmp_path / "h.npz")]) == 0
        err = capsys.readouterr().err
        assert ("tracks x and y only" in err) == warned, (hold, err)
        if warned:
            assert re.search(r"z of --hold \(up to 0\.5 m from the start TCP's z = ", err), err
        with np.load(tmp_path / "h.npz") as f:
            assert f["target"].shape == (1, 3, 2)


@pytest.mark.parametrize(
    "argv,match",
    [
        (["--hold", "1,1", "--kxd", "1,2,3,4,5@30", "--q0", "0,0,0"], "--kxd"),
        (["--hold", "1,1", "--kxd", "1,2,2,-5", "--q0", "0,0,0"], "symmetric positive semi-definite"),
        (
            ["--hold", "1,1", "--kxd", "3000,-1", "--q0", "0,0,0"],
            "positive semi-definite and not zero (a stiffness, N/m): eigenvalues -1 to 3000",
        ),
        (["--hold", "1,1", "--kxd", "3000,1000", "--q0", "0,0"], "--q0"),
        (["--path", "/nonexistent/p.csv", "--kxd", "3000,1000", "--q0", "0,0,0"], "p.csv"),
        (["--hold", "1,x", "--kxd", "3000,1000", "--q0", "0,0,0"], "--hold"),
    ],
)
def test_cli_errors_are_one_line(tmp_path, capsys, argv, match):
    out = tmp_path / "r.npz"
    rc = cli_main(["csc", "--robot", "planar_3r", *argv, "--out", str(out)])
    assert rc == 2
    err = capsys.readouterr().err
    assert err.startswith("jaxstiff: error:") and match in err and "Traceback" not in err
    assert not out.exists()


def test_cli_takes_negative_comma_lists_as_values(tmp_path):
    """`--hold -1.2,0.9` (argparse alone takes '-1.2,0.9' for an unknown option and refuses)."""
    from jaxstiff.cli._common import join_negative_values as _join_negative_values

    assert _join_negative_values(["csc", "--hold", "-1.2,0.9", "--beta", "-1", "--q0", ".5,1", "-x"]) == [
        "csc",
        "--hold=-1.2,0.9",
        "--beta=-1",
        "--q0",
        ".5,1",
        "-x",
    ]
    out = tmp_path / "neg.npz"
    rc = cli_main(
        [
            "csc",
            "--robot",
            "planar_3r",
            "--hold",
            "-1.2,0.9",
            "--kxd",
            "3000,1000",
            "--q0-deg",
            "-60,-40,-30",
            "--steps",
            "3",
            "--out",
            str(out),
        ]
    )
    assert rc == 0
    with np.load(out) as f:
        np.testing.assert_array_equal(f["target"][0, 0], [-1.2, 0.9])
        np.testing.assert_allclose(f["q0"], np.deg2rad([-60.0, -40.0, -30.0]), rtol=0, atol=1e-15)


@pytest.mark.slow
def test_cli_path_with_a_pause_holds_still(tmp_path):
    """`csc --path` with a repeated row (the arm pauses): one step per row, no tangents needed
    (it was refused as a zero-length segment, a check only the shaping's directions need)."""
    f = tmp_path / "pause.csv"
    x, y = float(X_SEED[0]), float(X_SEED[1])
    f.write_text(f"x,y,z\n{x!r},{y!r},0\n{x!r},{y + 0.01!r},0\n{x!r},{y + 0.01!r},0\n{x!r},{y + 0.02!r},0\n")
    out = tmp_path / "p.npz"
    rc = cli_main(
        [
            "csc",
            "--robot",
            "planar_3r",
            "--path",
            str(f),
            "--kxd",
            "3000,1000",
            "--q0-deg",
            "75,-74.74,-76.30",
            "--out",
            str(out),
        ]
    )
    assert rc == 0
    with np.load(out) as r:
        np.testing.assert_array_equal(r["target"][0], [[x, y], [x, y + 0.01], [x, y + 0.01], [x, y + 0.02]])
        assert np.all(np.isfinite(r["q"])) and r["tracking_error"][0, -1] < 1e-3


@pytest.mark.slow
def test_gradients_finite_at_a_zero_desired_stiffness():
    """A traced K_xd = 0 (inside grad or jit: unchecked; a concrete one is refused, no stiffness): its
    default null_eps was tiny, so 1/null_eps^2 in a tangent of the null step overflowed (inf * 0 =
    NaN) and |K_xd|_F had no gradient at 0: grad w.r.t. K_xd and jacfwd w.r.t. q0 and beta were NaN.
    With the floor, every derivative is finite and equals central differences where the rollout is
    smooth (K_xd = 0 itself is a kink of |K - K_C|)."""
    hold = jnp.tile(jnp.asarray(X_SEED), (6, 1))
    q0 = jnp.asarray(Q_SEED)

    def loss(K, q, b, step="constant"):
        r = jaxstiff.csc_rollout(PLANAR, hold, K, q, b, step=step)
        return jnp.sum(r.frobenius) + jnp.sum(r.u) + jnp.sum(r.q)

    Z = jnp.zeros((2, 2))
    for step in ("constant", "adaptive"):
        for g in (
            jax.grad(loss, argnums=(0, 1, 2))(Z, q0, 2e-3, step),
            jax.jacfwd(loss, argnums=(0, 1, 2))(Z, q0, 2e-3, step),
        ):
            assert all(np.all(np.isfinite(np.asarray(x))) for x in g), (step, g)
    # with K_xd = 0 nothing depends on beta or q0's null motion: q0's gradient is the tracking's, finite
    # (jitted: K_xd = 0 traced, as above; a concrete K_xd = 0 is refused)
    jloss = jax.jit(loss, static_argnames="step")
    gq = jax.grad(lambda q: jloss(Z, q, 2e-3))(q0)
    fd = central_diff(lambda q: float(jloss(Z, jnp.asarray(q), 2e-3)), np.asarray(q0), 1e-6)[0]
    assert_close(gq, fd, rtol=1e-5, atol=1e-6, what="d loss / d q0 at K_xd = 0")


# ---------------------------------------------------------------- long runs in segments
def _fields_close(a, b, rtol=1e-12, atol=1e-12, rows=None):
    for f in dataclasses.fields(jaxstiff.CSCResult):
        x, y = np.asarray(getattr(a, f.name)), np.asarray(getattr(b, f.name))
        if rows is not None and f.name not in ("u_start", "frobenius_start"):
            axis = result.step_axis(f.name, y.ndim)
            y = np.take(y, np.arange(rows), axis=axis)
        assert x.shape == y.shape, (f.name, x.shape, y.shape)
        if f.name == "status":
            np.testing.assert_array_equal(x, y, err_msg=f.name)
        else:
            np.testing.assert_allclose(x, y, rtol=rtol, atol=atol, err_msg=f.name)


@pytest.mark.slow
@pytest.mark.parametrize("seg", [1, 7, 50, 60])
def test_segments_equal_one_rollout_planar_line(seg):
    """csc_rollout_segments continues each segment from the posture the previous one reached:
    the rows equal one rollout over the whole path (a last segment shorter than the others is
    padded and trimmed; seg >= T is one call). Two rollouts (different beta) at once."""
    robot = jaxstiff.Robot.from_urdf("planar_4r")
    q0 = np.deg2rad([30.0, 40.0, -50.0, 20.0])
    x0 = np.asarray(robot.fk(q0))[:2, 3]
    path = x0 + np.linspace(0.0, 0.3, 50)[:, None] * np.array([0.0, 1.0])
    K = rot2(30.0) @ np.diag([3000.0, 1000.0]) @ rot2(30.0).T
    beta = np.array([0.5, 2.0])
    whole = jaxstiff.csc_rollout(robot, path, K, q0, beta)
    seen = []
    parts = csc.csc_rollout_segments(
        robot, path, K, q0, beta, segment_steps=seg, progress=lambda d, t: seen.append((d, t))
    )
    _fields_close(parts, whole)
    assert seen[0] == (0, 50) and seen[-1] == (50, 50) and len(seen) == 1 + -(-50 // seg)  # (0: inputs checked)
    if seg == 7:  # K_xd varying along the path is cut with it
        Kt = K * np.linspace(1.0, 2.0, 50)[:, None, None]
        _fields_close(
            csc.csc_rollout_segments(robot, path, Kt, q0, beta, segment_steps=seg),
            jaxstiff.csc_rollout(robot, path, Kt, q0, beta),
        )


@pytest.mark.slow
def test_segments_hold_the_first_orientation_in_task_full():
    """Task full: every segment holds q0's tool orientation (not its own start's), so the rows
    equal one rollout's; a held orientation given explicitly is really used."""
    robot = jaxstiff.Robot.from_urdf("kuka_lwr4")
    q0 = np.deg2rad([20.0, 40.0, -30.0, -70.0, 25.0, 50.0, 10.0])
    T0 = numpy_fk(robot, q0)
    path = T0[:3, 3] + np.linspace(0.0, 0.03, 10)[:, None] * np.array([1.0, 0.0, 0.0])
    K = np.diag([3000.0, 1000.0, 1000.0, 100.0, 100.0, 100.0])
    whole = jaxstiff.csc_rollout(robot, path, K, q0, 2e-3, step="constant")
    parts = csc.csc_rollout_segments(robot, path, K, q0, 2e-3, segment_steps=5, step="constant")
    _fields_close(parts, whole, rtol=1e-10, atol=1e-10)
    # holding another orientation is a different rollout (5 steps: the segments' compiled program)
    Rz = np.array([[np.cos(0.01), -np.sin(0.01), 0.0], [np.sin(0.01), np.cos(0.01), 0.0], [0.0, 0.0, 1.0]])
    other = jaxstiff.csc_rollout(robot, path[:5], K, q0, 2e-3, step="constant", hold_orientation=Rz @ T0[:3, :3])
    assert float(other.orientation_error[-1]) < 1e-3 and float(other.orientation_error[0]) < 0.011
    Tend = numpy_fk(robot, np.asarray(other.q[-1]))
    assert np.linalg.norm(Tend[:3, :3] - Rz @ T0[:3, :3]) < 1e-3


@pytest.mark.parametrize(
    "kwargs,match",
    [
        (dict(hold_orientation=np.eye(3) * 2.0), "rotation matrix"),
        (dict(hold_orientation=np.diag([1.0, 1.0, -1.0])), "rotation matrix"),
        (dict(hold_orientation=np.eye(2)), r"shape \(\.\.\., 3, 3\)"),
    ],
)
def test_hold_orientation_is_checked(kwargs, match):
    robot = jaxstiff.Robot.from_urdf("kuka_lwr4")
    q0 = np.deg2rad([20.0, 40.0, -30.0, -70.0, 25.0, 50.0, 10.0])
    with pytest.raises(ValueError, match=match):
        jaxstiff.csc_rollout(robot, np.zeros((3, 3)) + 0.5, np.eye(6) * 1e3, q0, 1.0, **kwargs)
    with pytest.raises(ValueError, match="task 'full'"):
        jaxstiff.csc_rollout(PLANAR, np.tile(X_SEED, (3, 1)), K_SEED, Q_SEED, 1.0, hold_orientation=np.eye(3))


def test_segments_interrupted_keep_the_finished_rows(hold):
    """A KeyboardInterrupt after two segments: CSCInterrupted carries exactly the finished rows,
    equal to the first rows of the whole rollout; one before the first segment ends is re-raised."""
    path = np.tile(X_SEED, (1000, 1))

    def stop_after(n):
        calls = []

        def progress(done, total):
            calls.append(done)
            if len(calls) == n + 1:  # (the first call, with 0, says the inputs were checked)
                raise KeyboardInterrupt

        return progress

    with pytest.raises(csc.CSCInterrupted) as e:
        csc.csc_rollout_segments(
            PLANAR, path, K_SEED, Q_SEED, 2e-3, step="constant", segment_steps=300, progress=stop_after(2)
        )
    assert e.value.steps_done == 600 and e.value.steps_total == 1000
    _fields_close(e.value.result, hold, rows=600)
    with pytest.raises(ValueError, match="segment_steps"):
        csc.csc_rollout_segments(PLANAR, path, K_SEED, Q_SEED, 2e-3, segment_steps=0)
    # a bad late waypoint is found before any segment runs (not after the first ones' work)
    bad = path.copy()
    bad[900, 0] = np.nan
    seen = []
    with pytest.raises(ValueError, match="path contains NaN"):
        csc.csc_rollout_segments(
            PLANAR, bad, K_SEED, Q_SEED, 2e-3, segment_steps=300, progress=lambda d, t: seen.append(d)
        )
    assert seen == []


def test_cli_long_run_shows_progress_and_an_interrupt_keeps_the_finished_steps(tmp_path, capsys, monkeypatch, hold):
    """A run longer than one segment prints a progress line per segment; an interrupt after the
    second writes the finished steps (meta: interrupted, steps) and exits 130. The rows equal the
    library's uninterrupted rollout."""
    from jaxstiff.cli import _csc as _cli_csc

    monkeypatch.setattr(_cli_csc, "SEGMENT_WORK", 300)
    argv = [
        "csc",
        "--robot",
        "planar_3r",
        "--hold",
        f"{float(X_SEED[0])!r},{float(X_SEED[1])!r}",
        "--kxd",
        "3000,1000@30",
        "--q0-deg",
        "75,-74.74,-76.30",
        "--beta",
        "2e-3",
        "--step",
        "constant",
        "--steps",
        "1000",
    ]
    out = tmp_path / "full.npz"
    assert cli_main(argv + ["--out", str(out)]) == 0
    err = capsys.readouterr().err
    assert "in segments of 300 steps" in err and re.search(r"csc: 600/1000 steps x 1 rollout\(s\) \(60%\)", err), err
    with np.load(out) as f:
        assert_close(f["u"][0], hold.u, rtol=1e-12, what="segmented CLI u vs library")
        assert json.loads(str(f["meta"]))["interrupted"] is False

    class Stop(_cli_csc.StepProgress):
        def __call__(self, done, total):
            super().__call__(done, total)
            if done >= 600:
                raise KeyboardInterrupt

    monkeypatch.setattr(_cli_csc, "StepProgress", Stop)
    part = tmp_path / "part.npz"
    assert cli_main(argv + ["--out", str(part)]) == 130
    err = capsys.readouterr().err
    assert "wrote" in err and "600 of 1000 steps" in err, err
    with np.load(part) as f:
        meta = json.loads(str(f["meta"]))
        assert meta["interrupted"] is True and meta["steps"] == 600 and meta["steps_requested"] == 1000
        assert f["q"].shape == (1, 600, 3) and f["target"].shape == (1, 600, 2)
        assert_close(f["q"][0], np.asarray(hold.q)[:600], rtol=1e-12, atol=1e-14, what="interrupted rows")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["full.npz", "part.npz"]  # no temporary file


def test_cli_a_second_interrupt_before_the_write_still_writes_the_finished_steps(tmp_path, capsys, monkeypatch, hold):
    """Ctrl-C twice: the second (a real SIGINT through the command's handler) arrives after the
    first stopped the rollout at a segment and before the finished steps are written. It is only
    remembered: the file holds the 600 finished steps, exit 130."""
    import os
    import signal
    import threading

    from jaxstiff.cli import _csc as _cli_csc
    from jaxstiff.runtime._io import interrupt_pending

    if threading.current_thread() is not threading.main_thread():
        pytest.skip("signal handlers can only be installed in the main thread")
    monkeypatch.setattr(_cli_csc, "SEGMENT_WORK", 300)

    class Stop(_cli_csc.StepProgress):
        def __call__(self, done, total):
            super().__call__(done, total)
            if done >= 600:
                raise KeyboardInterrupt  # the first

    real_meta = _cli_csc._meta

    def meta(*a, **k):
        os.kill(os.getpid(), signal.SIGINT)  # the second
        for _ in range(1000):  # the handler runs at the next bytecode boundary of the main thread
            interrupt_pending()
        return real_meta(*a, **k)

    monkeypatch.setattr(_cli_csc, "StepProgress", Stop)
    monkeypatch.setattr(_cli_csc, "_meta", meta)
    part = tmp_path / "part.npz"
    argv = ["csc", "--robot", "planar_3r", "--hold", f"{float(X_SEED[0])!r},{float(X_SEED[1])!r}"]
    argv += ["--kxd", "3000,1000@30", "--q0-deg", "75,-74.74,-76.30", "--beta", "2e-3", "--step", "constant"]
    assert cli_main(argv + ["--steps", "1000", "--out", str(part)]) == 130
    err = capsys.readouterr().err
    assert "600 of 1000 steps" in err and "saving what was finished first" in err, err
    with np.load(part) as f:
        assert json.loads(str(f["meta"]))["steps"] == 600
        assert_close(f["q"][0], np.asarray(hold.q)[:600], rtol=1e-12, atol=1e-14, what="rows kept")


def test_cli_checks_numeric_flags_before_warning(tmp_path, capsys):
    """--kmin 0 with --hold and the adaptive step: the flag's error, and no hold warning first."""
    rc = cli_main(
        [
            "csc",
            "--robot",
            "planar_3r",
            "--hold",
            "1,1",
            "--kxd",
            "3000,1000",
            "--q0",
            "0,0,0",
            "--kmin",
            "0",
            "--out",
            str(tmp_path / "r.npz"),
        ]
    )
    err = capsys.readouterr().err
    assert rc == 2 and "--kmin must be" in err and "warning" not in err, err


@pytest.mark.slow
def test_cli_locked_joint_q0_must_be_the_locked_value(tmp_path, capsys):
    """The help says locked joints take their locked values in --q0: another value is an error
    naming the joint (it was silently replaced); the raw --q0 text is kept in meta."""
    base = [
        "csc",
        "--robot",
        "kuka_lwr4",
        "--lock",
        "lwr_a7=0.2",
        "--hold",
        "0.5,0.1,0.6",
        "--kxd",
        "3000,1000,2000",
        "--steps",
        "2",
    ]
    out = tmp_path / "r.npz"
    assert cli_main(base + ["--q0", "0.3,0.5,0,-1.2,0,0.6,0.9", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "--q0 gives joint 'lwr_a7' 0.9 rad, but it is locked at 0.2 rad" in err and not out.exists(), err
    assert cli_main(base + ["--q0-deg", "10,20,0,-60,0,30,20", "--out", str(out)]) == 2
    assert "locked at 11.4591559 deg" in capsys.readouterr().err
    assert cli_main(base + ["--q0-deg", "10,20,0,-60,0,30,11.4592", "--out", str(out)]) == 0
    with np.load(out) as f:
        meta = json.loads(str(f["meta"]))
        assert meta["q0_arg"] == {"--q0-deg": "10,20,0,-60,0,30,11.4592"} and meta["q0"][6] == 0.2
        assert np.all(f["q"][0, :, 6] == 0.2)


@pytest.mark.slow
def test_cli_joint_limit_avoidance_has_a_gain_by_default(tmp_path, capsys):
    """--joint-limits priority without --jl-gain used gain 0, i.e. did nothing: it now takes the
    documented default (recorded in meta) and moves the arm differently from --joint-limits off;
    an explicit --jl-gain 0 gets a warning."""
    x = np.asarray(jaxstiff.Robot.from_urdf("planar_4r").fk(np.array([0.4, 0.8, -0.6, 0.9])))[:2, 3]
    base = [
        "csc",
        "--robot",
        "planar_4r",
        "--hold",
        f"{float(x[0])!r},{float(x[1])!r}",
        "--kxd",
        "3000,1000@30",
        "--q0",
        "0.4,0.8,-0.6,0.9",
        "--step",
        "constant",
        "--beta",
        "5e-3",
        "--steps",
        "50",
    ]
    runs = {}
    for extra in ([], ["--joint-limits", "priority"], ["--joint-limits", "priority", "--jl-gain", "0"]):
        out = tmp_path / f"r{len(runs)}.npz"
        assert cli_main(base + extra + ["--out", str(out)]) == 0
        runs[tuple(extra)] = (np.load(out)["q"], json.loads(str(np.load(out)["meta"])), capsys.readouterr().err)
    q_off, meta_off, _ = runs[()]
    q_pr, meta_pr, err_pr = runs[("--joint-limits", "priority")]
    q_0, _, err_0 = runs[("--joint-limits", "priority", "--jl-gain", "0")]
    from jaxstiff.cli._csc import DEFAULT_JL_GAIN

    assert meta_off["jl_gain"] == 0.0 and meta_pr["jl_gain"] == DEFAULT_JL_GAIN > 0
    assert np.abs(q_pr - q_off).max() > 1e-6 and "does nothing" not in err_pr
    np.testing.assert_array_equal(q_0, q_off)
    assert "--joint-limits priority with --jl-gain 0 does nothing" in err_0


def test_saturation_keeps_tracking_when_the_resolve_pushes_another_joint_out():
    """Planar 4R with tight limits on joints 2 and 4 (a case from an independent audit): holding a
    point, the step freezes joint 2 at its limit and the re-solve then pushes joint 4 past its
    own; clamping it afterwards threw away part of the tracking step, and the TCP sat 1 mm off the
    point for 400 steps while the file reported a null step. Joint 4 is now frozen too and the
    step solved again: the TCP comes back onto the point (numpy FK) within the limits."""
    robot = jaxstiff.Robot.from_urdf(str(DATA / "planar_4r_tight_limits.urdf"))
    q0 = np.array([0.4, 0.8, -0.6, 0.9])
    x0 = numpy_fk(robot, q0)[:2, 3]
    K = rot2(30.0) @ np.diag([3000.0, 1000.0]) @ rot2(30.0).T
    r = jaxstiff.csc_rollout(
        robot, np.tile(x0, (600, 1)), K, q0, 5e-3, step="constant", joint_limits="priority", jl_gain=0.02
    )
    q = np.asarray(r.q)
    assert np.all(q >= robot.lower - 1e-12) and np.all(q <= robot.upper + 1e-12)
    assert np.any(np.asarray(r.status) & csc.STATUS_JOINT_LIMIT)  # the limits were really reached
    err = np.array([np.linalg.norm(numpy_fk(robot, qk)[:2, 3] - x0) for qk in q[300:]])
    assert err.max() < 1e-9, err.max()
    assert float(r.u[-1]) < float(r.u_start)


@pytest.mark.parametrize("mode", ["sum", "priority"])
def test_a_joint_with_a_one_value_range_does_not_stop_joint_limit_avoidance(tmp_path, mode):
    """A URDF may give a joint lower == upper. Its Liegeois term was (q - mid) / half = 0 / 0, so
    with joint-limit avoidance on every step was dropped by the NaN guard and the rollout stood
    still without a word (found by an adversarial run). That joint is now out of the term: the
    rollout moves as with avoidance off, keeps the joint at its one value, and no step is NaN."""
    path = one_value_range_planar(tmp_path)  # joint a3 (index 2): [-0.6, -0.6], q0's value for it
    with pytest.warns(UserWarning):  # the loader says the range is one value
        robot = jaxstiff.Robot.from_urdf(str(path))
    assert robot.lower[2] == robot.upper[2] == -0.6
    q0 = np.array([0.4, 0.8, -0.6, 0.9])
    x0 = numpy_fk(robot, q0)[:2, 3]
    K = rot2(30.0) @ np.diag([3000.0, 1000.0]) @ rot2(30.0).T
    r = jaxstiff.csc_rollout(
        robot, np.tile(x0, (100, 1)), K, q0, 5e-3, step="constant", joint_limits=mode, jl_gain=0.02
    )
    status = np.asarray(r.status)
    assert not np.any(status & csc.STATUS_NAN), status
    q = np.asarray(r.q)
    assert np.all(np.isfinite(q)) and np.all(q[:, 2] == -0.6)
    assert float(r.u[-1]) < float(r.u_start)  # it moved in its null space


# ---------------------------------------------------------------- settings, status bits, robot flags
def _csc_flag_defaults() -> dict:
    """The defaults of `jaxstiff csc`'s settings flags, parsed from a real command line."""
    import argparse

    from jaxstiff.cli._csc import SETTING_FLAGS, add_setting_flags

    p = argparse.ArgumentParser()
    add_setting_flags(p)
    args = p.parse_args([])
    return {name: getattr(args, name) for name in SETTING_FLAGS}


def test_settings_defaults_are_the_api_and_cli_defaults():
    """CSCSettings is the one source: its defaults are csc_rollout's effective defaults (jl_gain
    resolved: 0 with joint limits off, DEFAULT_JL_GAIN with them on) and `jaxstiff csc`'s flag
    defaults; csc_rollout's own keywords default to None ("from the settings")."""
    import inspect

    from jaxstiff.csc._inputs import rollout_settings
    from jaxstiff.settings import CSCSettings
    from jaxstiff.settings._csc import DEFAULT_JL_GAIN

    defaults = CSCSettings.defaults()
    assert rollout_settings() == {**defaults, "jl_gain": 0.0}
    assert rollout_settings(joint_limits="priority")["jl_gain"] == DEFAULT_JL_GAIN == 0.3
    assert rollout_settings(CSCSettings(joint_limits="sum"))["jl_gain"] == DEFAULT_JL_GAIN
    assert rollout_settings(CSCSettings(kmin=2.0), kmin=3.0)["kmin"] == 3.0  # a keyword overrides the settings
    assert _csc_flag_defaults() == defaults
    params = inspect.signature(jaxstiff.csc_rollout).parameters
    assert params["beta"].default is None  # the others are taken inline, every field of the settings
    from jaxstiff.csc._rollout import INLINE_CSC_SETTINGS

    assert set(defaults) - {"beta"} <= INLINE_CSC_SETTINGS
    # the effective default reaches the rollout: no keywords == every default given explicitly
    path = np.tile(X_SEED, (5, 1))
    a = jaxstiff.csc_rollout(PLANAR, path, K_SEED, Q_SEED)
    b = jaxstiff.csc_rollout(
        PLANAR,
        path,
        K_SEED,
        Q_SEED,
        1.0,
        step="adaptive",
        kmin=1.0,
        kmax=np.inf,
        nu0=1e-2,
        damping=0.1,
        newton=0,
        joint_limits="off",
        jl_gain=0.0,
    )
    _fields_close(a, b, rtol=0, atol=0)


def test_settings_object_and_its_checks():
    """csc_rollout(settings=CSCSettings(...)) equals the keywords; bad settings name the field and unit."""
    from jaxstiff.settings import CSCSettings

    path = np.tile(X_SEED, (20, 1))
    s = CSCSettings(step="constant", beta=2e-3)
    _fields_close(
        jaxstiff.csc_rollout(PLANAR, path, K_SEED, Q_SEED, settings=s),
        jaxstiff.csc_rollout(PLANAR, path, K_SEED, Q_SEED, 2e-3, step="constant"),
        rtol=0,
        atol=0,
    )
    for kwargs, match in (
        (dict(kmin=0.0), r"csc\.kmin \(Nm/rad\) must be a finite number > 0"),
        (dict(kmin=math.inf), r"csc\.kmin \(Nm/rad\) must be a finite number > 0"),
        (dict(nu0=1.0), r"csc\.nu0.*\[0, 1\)"),
        (dict(kmin=5.0, kmax=2.0), r"csc\.kmax \(2\) must be above csc\.kmin \(5\)"),
        (dict(step="fast"), "csc.step"),
        (dict(newton=1.5), "csc.newton"),
        (dict(beta=math.inf), "csc.beta"),
    ):
        with pytest.raises(ValueError, match=match):
            CSCSettings(**kwargs)
    with pytest.raises(ValueError, match="settings must be a jaxstiff.settings.CSCSettings"):
        jaxstiff.csc_rollout(PLANAR, path, K_SEED, Q_SEED, settings={"beta": 1.0})


def test_short_signature_and_unknown_keywords():
    """csc_rollout has at most 10 parameters; a misspelt setting is a TypeError naming the nearest one."""
    import inspect

    assert len(inspect.signature(jaxstiff.csc_rollout).parameters) <= 10
    path = np.tile(X_SEED, (3, 1))
    with pytest.raises(TypeError, match="'damping'"):
        jaxstiff.csc_rollout(PLANAR, path, K_SEED, Q_SEED, dampign=0.2)


def test_status_bits_are_an_int_flag_with_the_old_values():
    assert issubclass(csc.CSCStatus, int)
    assert (csc.STATUS_OK, csc.STATUS_DAMPED, csc.STATUS_JOINT_LIMIT, csc.STATUS_NAN, csc.STATUS_NULL_SMALL) == (
        0,
        1,
        2,
        4,
        8,
    )
    assert csc.STATUS_DAMPED is csc.CSCStatus.DAMPED and rollout.STATUS_NAN is csc.CSCStatus.NAN
    assert (
        csc.describe_status(csc.CSCStatus.DAMPED | csc.CSCStatus.NULL_SMALL)
        == "damped (near singular), null-space gradient below null_eps"
    )
    assert csc.describe_status(0) == "ok" and csc.STATUS_NAMES[4] == "NaN guard (step dropped)"


def test_cli_meta_records_settings_with_units_and_robot_spec(tmp_path):
    """meta["settings"]: every CSCSettings field with its value (jl_gain resolved) and units;
    meta["robot_spec"]: the robot flags; the array units name rad for orientation_error (csc files
    store radians where shape files store alpha_deg in degrees)."""
    from jaxstiff.settings import CSCSettings

    out = tmp_path / "r.npz"
    assert (
        cli_main(
            [
                "csc",
                "--robot",
                "planar_3r",
                "--hold",
                "1.2,0.5",
                "--steps",
                "3",
                "--kxd",
                "3000,1000@30",
                "--q0-deg",
                "20,40,30",
                "--kmin",
                "2",
                "--joint-limits",
                "sum",
                "--out",
                str(out),
            ]
        )
        == 0
    )
    with np.load(out) as f:
        meta = json.loads(str(f["meta"]))
    s = meta["settings"]
    assert set(CSCSettings.field_names()) <= set(s)
    assert (
        s["kmin"] == 2.0
        and s["kmax"] == "Infinity"  # as meta_dumps spells every non-finite number
        and s["task"] == "xy"
        and s["jl_gain"] == 0.3
        and s["joint_limits"] == "sum"
    )
    assert s["units"]["kmin"] == "Nm/rad" and s["units"]["kmax"] == "Nm/rad" and "rad per step" in s["units"]["beta"]
    assert meta["kmin"] == 2.0 and meta["jl_gain"] == 0.3 and meta["nu0"] == 1e-2  # the former keys stay
    assert meta["units"]["orientation_error"] == "rad"
    assert meta["robot_spec"]["urdf"] == "planar_3r" and meta["robot_spec"]["locked"] == {}


@pytest.mark.slow
def test_cli_lwr_locks_its_seventh_joint_by_default(tmp_path, capsys):
    """Without --lock, `jaxstiff csc` on the shipped kuka_lwr4 locks lwr_a7 = 0 as `jaxstiff shape`
    does (RobotSpec's default); a --q0 with another value for lwr_a7 is the locked-joint error;
    '--lock none' frees it."""
    lwr = jaxstiff.Robot.from_urdf("kuka_lwr4", locked={"lwr_a7": 0.0})
    q = np.array([0.3, 0.5, 0.0, -1.2, 0.0, 0.6, 0.0])
    hold = ",".join(repr(float(v)) for v in np.asarray(lwr.fk(q))[:3, 3])
    base = ["csc", "--robot", "kuka_lwr4", "--hold", hold, "--kxd", "3000,1000,2000", "--steps", "2"]
    out = tmp_path / "r.npz"
    assert cli_main(base + ["--q0", "0.3,0.5,0,-1.2,0,0.6,0", "--out", str(out)]) == 0
    with np.load(out) as f:
        meta = json.loads(str(f["meta"]))
        assert np.all(f["q"][0, :, 6] == 0.0)
    assert meta["robot"]["locked"] == {"lwr_a7": 0.0} and meta["robot_spec"]["locked_by_default"] is True
    capsys.readouterr()
    assert cli_main(base + ["--q0", "0.3,0.5,0,-1.2,0,0.6,0.4", "--out", str(out)]) == 2
    assert "--q0 gives joint 'lwr_a7' 0.4 rad, but it is locked at 0 rad" in capsys.readouterr().err
    assert cli_main(base + ["--lock", "none", "--q0", "0.3,0.5,0,-1.2,0,0.6,0.4", "--out", str(out)]) == 0
    with np.load(out) as f:
        assert json.loads(str(f["meta"]))["robot"]["locked"] == {}


def test_cli_tcp_flag_is_accepted_and_recorded(tmp_path):
    """--tcp x,y,z,roll,pitch,yaw (the shared robot flags): the tool offset moves the TCP and is
    recorded in meta (robot_spec.tcp as given, robot.tcp as the 4x4 transform)."""
    out = tmp_path / "t.npz"
    tcp = [0.0, 0.0, 0.1, 0.0, 0.0, 0.5]
    from jaxstiff.settings._robot import tcp_transform

    robot = jaxstiff.Robot.from_urdf("planar_3r", tcp=tcp_transform(tcp))
    q0 = np.deg2rad([20.0, 40.0, 30.0])
    x = [float(v) for v in np.asarray(robot.fk(q0))[:2, 3]]
    assert (
        cli_main(
            [
                "csc",
                "--robot",
                "planar_3r",
                "--tcp",
                ",".join(map(str, tcp)),
                "--hold",
                f"{x[0]!r},{x[1]!r}",
                "--kxd",
                "3000,1000@30",
                "--q0-deg",
                "20,40,30",
                "--steps",
                "3",
                "--out",
                str(out),
            ]
        )
        == 0
    )
    with np.load(out) as f:
        meta = json.loads(str(f["meta"]))
        assert f["tracking_error"][0, 0] < 1e-9  # the TCP with the tool offset starts on the point
    assert meta["robot_spec"]["tcp"] == tcp
    assert np.allclose(np.asarray(meta["robot"]["tcp"])[:3, 3], [0.0, 0.0, 0.1])
    assert (
        cli_main(
            [
                "csc",
                "--robot",
                "planar_3r",
                "--tcp",
                "1,2",
                "--hold",
                "1,1",
                "--kxd",
                "3000,1000",
                "--q0",
                "0,0,0",
                "--out",
                str(out),
            ]
        )
        == 2
    )


def test_a_planar_path_with_a_3d_kxd_names_the_disagreement():
    # the task follows K_xd's size: a 3x3 K_xd with (x, y) points blamed the robot's vz row ("a
    # planar chain? use task 'xy'") instead of the K_xd / path mismatch (an independent check)
    robot = jaxstiff.Robot.from_urdf("planar_3r")
    path = np.zeros((3, 2)) + [1.5, 0.5]
    with pytest.raises(ValueError, match=r"K_xd is 3x3, so the task is 'xyz', but the path has 2 coordinates"):
        jaxstiff.csc_rollout(robot, path, np.eye(3) * 1000.0, np.radians([30.0, 60.0, 30.0]))
    out = jaxstiff.csc_rollout(robot, path, np.eye(2) * 1000.0, np.radians([30.0, 60.0, 30.0]))  # 2x2: runs
    assert np.all(np.isfinite(np.asarray(out.q)))


def test_result_save_and_load_round_trip(tmp_path):
    """CSCResult.save / load keep every field bit for bit (status as the rollout's int32); the
    file is the command's format (extra arrays, meta); other files are refused by name."""
    import json

    res = jaxstiff.csc_rollout(PLANAR, np.tile(X_SEED, (4, 1)), K_SEED, Q_SEED)
    f = res.save(tmp_path / "r.npz", joint_names=PLANAR.joint_names, meta={"note": "x"}, q0=Q_SEED)
    back = jaxstiff.CSCResult.load(f)
    for name, a in res.as_dict().items():
        np.testing.assert_array_equal(np.asarray(getattr(back, name)), np.asarray(a), err_msg=name)
        assert np.asarray(getattr(back, name)).dtype == np.asarray(a).dtype, name
    with np.load(f, allow_pickle=False) as z:
        assert json.loads(str(z["meta"])) == {"note": "x"}
        np.testing.assert_array_equal(z["q0"], Q_SEED)
        assert list(z["joint_names"]) == list(PLANAR.joint_names)
    with pytest.raises(ValueError, match="must not reuse a field name"):
        res.save(tmp_path / "s.npz", u=np.zeros(3))
    (tmp_path / "t.csv").write_text("x,y,z\n")
    with pytest.raises(ValueError, match="not a readable .npz"):
        jaxstiff.CSCResult.load(tmp_path / "t.csv")
    np.savez(tmp_path / "other.npz", criterion=np.zeros(2))
    with pytest.raises(ValueError, match="a shape result"):
        jaxstiff.CSCResult.load(tmp_path / "other.npz")
    assert not (tmp_path / "s.npz").exists()
