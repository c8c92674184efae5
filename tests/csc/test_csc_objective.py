"""CSC's null-space objective (``objective="offdiag"`` / ``"frobenius"``) and locked joints
(``locked_joints="rigid"`` / ``"spring"``), SPEC sections 1 and 6 (issue 21, items 2 and 4).

References outside the code under test: the planar 3R in closed form (numpy), the numpy Jacobian
of :mod:`jaxstiff.results._numpy_check` (4x4 products), central finite differences, and a result
file written by the code before ``locked_joints`` existed (``data/csc_lwr_full_spring_before.npz``:
the LWR, lwr_a7 locked, task "full", 40 steps of the default path, beta 2) for ``"spring"``.
"""

from __future__ import annotations

import math
import os

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from helpers import central_diff

import jaxstiff
from jaxstiff import csc
from jaxstiff.results._numpy_check import np_jacobian_rows

HERE = os.path.dirname(__file__)
PLANAR = jaxstiff.Robot.from_urdf("planar_3r")
Q3 = np.deg2rad([75.0, -74.74, -76.30])
LWR_A7 = jaxstiff.Robot.from_urdf("kuka_lwr4", locked={"lwr_a7": 0.0})
LWR_A3A7 = jaxstiff.Robot.from_urdf("kuka_lwr4", locked={"lwr_a3": -0.2, "lwr_a7": 0.3})
Q7 = np.deg2rad([20.0, 40.0, -30.0, -70.0, 25.0, 50.0, 0.0])


def rot(deg: float, m: int) -> np.ndarray:
    c, s = math.cos(math.radians(deg)), math.sin(math.radians(deg))
    R = np.eye(m)
    R[:2, :2] = [[c, -s], [s, c]]
    return R


K2 = rot(30.0, 2) @ np.diag([3000.0, 1000.0]) @ rot(30.0, 2).T
K3 = rot(30.0, 3) @ np.diag([3000.0, 1000.0, 2000.0]) @ rot(30.0, 3).T


# ------------------------------------------------------------------ numpy references
def planar_J(q) -> np.ndarray:
    c = np.cumsum(np.asarray(q, float))
    return np.array([[-np.sin(c[i:]).sum() for i in range(3)], [np.cos(c[i:]).sum() for i in range(3)]])


def measures_np(
    J: np.ndarray, K: np.ndarray, kmin: float = 1.0, kmax: float = np.inf
) -> tuple[float, float, np.ndarray]:
    """(u, |K - K_C|_F, kj) of task rows J (m, n) in numpy: kj = clip(diag(J^T K J)), K_C = (J Kj^-1 J^T)^-1."""
    Kq = J.T @ K @ J
    iu = np.triu_indices(Kq.shape[0], 1)
    kj = np.clip(np.diag(Kq), kmin, kmax)
    KC = np.linalg.inv(J @ np.diag(1.0 / kj) @ J.T)
    return float(np.sqrt(np.sum(Kq[iu] ** 2))), float(np.linalg.norm(K - KC)), kj


def frob_planar(q) -> float:
    return measures_np(planar_J(q), K2)[1]


def rigid_rows(robot: jaxstiff.Robot, q: np.ndarray, m: int) -> np.ndarray:
    """Task rows over the free joints only: the locked joints' columns removed (n_free columns)."""
    return np_jacobian_rows(robot, np.where(robot.free, q, robot.locked_values))[:m][:, robot.free]


# ------------------------------------------------------------------ frobenius objective
def test_frobenius_gradient_planar_against_closed_form_differences():
    f, g = csc.frobenius_gradient(PLANAR, jnp.asarray(Q3), jnp.asarray(K2))
    assert float(f) == pytest.approx(frob_planar(Q3), rel=1e-10)
    np.testing.assert_allclose(np.asarray(g), central_diff(frob_planar, Q3, h=1e-6)[0], rtol=1e-6, atol=1e-6)


@pytest.mark.parametrize("locked_joints", ["rigid", "spring"])
def test_frobenius_gradient_lwr_against_numpy_differences(locked_joints):
    """Two locked joints (a3, a7); rigid: the numpy reference drops their columns; spring: keeps them."""
    robot = LWR_A3A7
    q = np.where(robot.free, Q7, robot.locked_values)

    def f_np(qf: np.ndarray) -> float:
        qq = q.copy()
        qq[robot.free] = qf
        J = rigid_rows(robot, qq, 3) if locked_joints == "rigid" else np_jacobian_rows(robot, qq)[:3]
        return measures_np(J, K3)[1]

    f, g = csc.frobenius_gradient(robot, jnp.asarray(q), jnp.asarray(K3), locked_joints=locked_joints)
    assert float(f) == pytest.approx(f_np(q[robot.free]), rel=1e-9)
    fd = central_diff(f_np, q[robot.free], h=1e-6)[0]
    np.testing.assert_allclose(np.asarray(g)[robot.free], fd, rtol=1e-5, atol=1e-5 * np.abs(fd).max())
    if locked_joints == "rigid":
        assert np.all(np.asarray(g)[~robot.free] == 0.0)  # no stiffness variable, no gradient


@pytest.mark.parametrize("robot,q,K", [(PLANAR, Q3, K2), (LWR_A7, Q7, K3)], ids=["planar_3r", "lwr"])
def test_frobenius_null_step_lowers_frobenius_to_first_order(robot, q, K):
    """-dq_N of the frobenius objective: the decrease of |K_xd - K_C|_F per unit step tends to
    g . d (a descent, > 0), and the TCP moves only at second order."""
    dqN, f0, _ = csc.null_space_direction(robot, jnp.asarray(q), jnp.asarray(K), objective="frobenius")
    d = np.asarray(dqN) / np.linalg.norm(dqN)
    m = K.shape[0]
    fg = lambda qq: csc.frobenius_gradient(robot, jnp.asarray(qq), jnp.asarray(K))  # noqa: E731
    f0n, g = (np.asarray(a) for a in fg(q))
    assert float(f0) == pytest.approx(float(f0n), rel=1e-12)
    slope = float(g @ d)  # = |dq_N| > 0: the projected gradient is a descent direction
    assert slope == pytest.approx(float(np.linalg.norm(dqN)), rel=1e-8) and slope > 0
    drops = [(float(f0n) - float(fg(q - h * d)[0])) / h for h in (1e-3, 1e-4, 1e-5)]
    errs = [abs(r - slope) for r in drops]
    assert all(r > 0 for r in drops) and errs[2] < errs[1] < errs[0] and errs[2] < 1e-3 * slope, (drops, slope)
    tcp = lambda qq: np.asarray(robot.fk(jnp.asarray(qq)))[:3, 3][:m]  # noqa: E731
    disp = [np.linalg.norm(tcp(q - h * d) - tcp(q)) for h in (1e-2, 1e-3)]
    assert 70.0 < disp[0] / disp[1] < 130.0, disp


@pytest.mark.slow
def test_frobenius_rollout_keeps_the_tcp_on_the_path_like_the_seeds():
    """LWR (a7 locked), 60 waypoints of the default path from an IK start: both objectives track
    the path to the same accuracy; each lowers its own objective's mean below the other's."""
    from jaxstiff.ik import ik_position
    from jaxstiff.paths import default_path

    pts = np.asarray(default_path().points)
    q0, _ = ik_position(LWR_A7, pts[0], q_start=np.deg2rad([-30.0, 30.0, 0.0, 90.0, 0.0, -30.0, 0.0]))
    out = {}
    for obj in ("offdiag", "frobenius"):
        r = csc.csc_rollout(LWR_A7, pts, K3, np.asarray(q0), 5.0, objective=obj, newton=1)
        out[obj] = r
        assert float(np.max(r.tracking_error)) < 1e-4, obj
        assert np.all(np.asarray(r.status) & int(csc.CSCStatus.NAN) == 0)
        # both measures are reported, and they are the posture's own (numpy reference at the last row)
        qT = np.asarray(r.q[-1])
        u_np, f_np, _ = measures_np(rigid_rows(LWR_A7, qT, 3), K3)
        assert float(r.u[-1]) == pytest.approx(u_np, rel=1e-8) and float(r.frobenius[-1]) == pytest.approx(
            f_np, rel=1e-7
        )
    assert float(np.mean(out["frobenius"].frobenius)) < float(np.mean(out["offdiag"].frobenius))
    assert float(np.mean(out["offdiag"].u)) < float(np.mean(out["frobenius"].u))


@pytest.mark.slow
@pytest.mark.parametrize("locked_joints", ["rigid", "spring"])
def test_frobenius_rollout_gradient_matches_central_differences(locked_joints):
    """d/d(beta, q0, K_xd scale) of a rollout loss (mean frobenius + 1e-2 mean u), objective
    frobenius, LWR with a7 locked, 15 waypoints of the default path: against central differences."""
    from jaxstiff.ik import ik_position
    from jaxstiff.paths import default_path

    robot = LWR_A7
    pts = np.asarray(default_path(n=120).points)[:15]
    q0 = np.asarray(ik_position(robot, pts[0], q_start=Q7)[0])

    def loss(beta, q, s):
        r = csc.csc_rollout(robot, pts, s * K3, q, beta, objective="frobenius", locked_joints=locked_joints)
        return jnp.mean(r.frobenius) + 1e-2 * jnp.mean(r.u)

    args = (jnp.asarray(2.0), jnp.asarray(q0), jnp.asarray(1.0))
    g = jax.grad(loss, argnums=(0, 1, 2))(*args)
    lf = lambda b, q, s: float(loss(jnp.asarray(b), jnp.asarray(q), jnp.asarray(s)))  # noqa: E731
    fd_b = central_diff(lambda x: lf(x[0], q0, 1.0), np.array([2.0]), h=1e-5)[0, 0]
    fd_s = central_diff(lambda x: lf(2.0, q0, x[0]), np.array([1.0]), h=1e-6)[0, 0]
    free = robot.free

    def with_free(x: np.ndarray) -> np.ndarray:  # a locked joint's q0 stays at its value (else refused)
        q = q0.copy()
        q[free] = x
        return q

    fd_q = central_diff(lambda x: lf(2.0, with_free(x), 1.0), q0[free], h=1e-6)[0]
    assert float(g[0]) == pytest.approx(fd_b, rel=1e-5, abs=1e-6)
    assert float(g[2]) == pytest.approx(fd_s, rel=1e-5, abs=1e-6)
    np.testing.assert_allclose(np.asarray(g[1])[free], fd_q, rtol=1e-5, atol=1e-5 * np.abs(fd_q).max())
    assert np.all(np.asarray(g[1])[~free] == 0.0)  # a locked joint's q0 is held at its locked value


@pytest.mark.slow
def test_frobenius_rollout_gradient_planar_hold():
    """The planar 3R hold case (constant step), objective frobenius: d loss / d(beta, q0) vs central differences."""
    x0 = np.asarray(PLANAR.fk(jnp.asarray(Q3)))[:2, 3]
    pts = np.tile(x0, (30, 1))

    def loss(beta, q):
        r = csc.csc_rollout(PLANAR, pts, K2, q, beta, step="constant", objective="frobenius")
        return jnp.mean(r.frobenius)

    g = jax.grad(loss, argnums=(0, 1))(jnp.asarray(2e-3), jnp.asarray(Q3))
    fd_b = central_diff(lambda x: float(loss(jnp.asarray(x[0]), jnp.asarray(Q3))), np.array([2e-3]), h=1e-7)[0, 0]
    fd_q = central_diff(lambda x: float(loss(jnp.asarray(2e-3), jnp.asarray(x))), Q3, h=1e-6)[0]
    assert float(g[0]) == pytest.approx(fd_b, rel=1e-6)
    np.testing.assert_allclose(np.asarray(g[1]), fd_q, rtol=1e-6, atol=1e-6 * np.abs(fd_q).max())
    r = csc.csc_rollout(PLANAR, pts, K2, jnp.asarray(Q3), 2e-3, step="constant", objective="frobenius")
    assert float(r.frobenius[-1]) < float(r.frobenius_start)  # it lowers what it aims at


def test_objective_and_locked_joints_are_checked():
    x0 = np.asarray(PLANAR.fk(jnp.asarray(Q3)))[:2, 3]
    with pytest.raises(ValueError, match="objective must be 'offdiag' or 'frobenius', got 'frob'"):
        csc.csc_rollout(PLANAR, x0[None], K2, Q3, objective="frob")
    with pytest.raises(ValueError, match="locked_joints must be 'rigid' or 'spring', got 'stiff'"):
        csc.csc_rollout(PLANAR, x0[None], K2, Q3, locked_joints="stiff")
    with pytest.raises(ValueError, match="csc.objective"):
        jaxstiff.settings.CSCSettings(objective="u")  # type: ignore[arg-type]


# ------------------------------------------------------------------ locked joints
@pytest.mark.slow
@pytest.mark.parametrize("objective", ["offdiag", "frobenius"])
def test_locked_rigid_against_numpy(objective):
    """Rigid (default): kj of a locked joint is 0, u and K_C run over the free joints only (numpy
    with the locked columns removed); spring: every column, the locked joints' kj from the clip."""
    robot = LWR_A3A7
    q = np.where(robot.free, Q7, robot.locked_values)
    tcp = np.asarray(robot.fk(jnp.asarray(q)))[:3, 3]
    pts = np.tile(tcp, (2, 1))  # hold still, adaptive step: the posture does not move
    for mode in ("rigid", "spring"):
        r = csc.csc_rollout(robot, pts, K3, q, 1.0, objective=objective, locked_joints=mode)
        J = rigid_rows(robot, q, 3) if mode == "rigid" else np_jacobian_rows(robot, q)[:3]
        u_np, f_np, kj_np = measures_np(J, K3)
        assert float(r.u_start) == pytest.approx(u_np, rel=1e-10), mode
        assert float(r.frobenius_start) == pytest.approx(f_np, rel=1e-8), mode
        kj = np.asarray(r.kj[0])
        if mode == "rigid":
            assert np.all(np.isposinf(kj[~robot.free])) and np.allclose(kj[robot.free], kj_np, rtol=1e-10)
            KC_np = np.linalg.inv(J @ np.diag(1.0 / kj_np) @ J.T)
        else:
            assert np.allclose(kj, kj_np, rtol=1e-10) and np.all(kj > 0)
            KC_np = np.linalg.inv(J @ np.diag(1.0 / kj_np) @ J.T)
        np.testing.assert_allclose(np.asarray(r.K_C[0]), KC_np, rtol=1e-8)
        assert np.allclose(np.asarray(r.q), q)  # holding still: no motion
    # the two modes differ here (the locked joints' springs add compliance)
    assert float(csc.csc_rollout(robot, pts, K3, q, 1.0, locked_joints="spring").frobenius_start) != pytest.approx(
        float(csc.csc_rollout(robot, pts, K3, q, 1.0).frobenius_start), rel=1e-6
    )


def test_locked_rigid_gradients_exclude_locked_joints():
    """u's gradient (rigid) equals the gradient of numpy's u over the free columns, 0 at locked joints."""
    robot = LWR_A3A7
    q = np.where(robot.free, Q7, robot.locked_values)

    def u_np(qf: np.ndarray) -> float:
        qq = q.copy()
        qq[robot.free] = qf
        return measures_np(rigid_rows(robot, qq, 3), K3)[0]

    u, g = csc.offdiag_gradient(robot, jnp.asarray(q), jnp.asarray(K3))
    assert float(u) == pytest.approx(u_np(q[robot.free]), rel=1e-10)
    fd = central_diff(u_np, q[robot.free], h=1e-6)[0]
    np.testing.assert_allclose(np.asarray(g)[robot.free], fd, rtol=1e-6, atol=1e-6 * np.abs(fd).max())
    assert np.all(np.asarray(g)[~robot.free] == 0.0)


@pytest.mark.slow
def test_locked_spring_is_the_former_behaviour():
    """locked_joints="spring" reproduces a result file written before the option existed (LWR,
    lwr_a7 locked, task "full", 40 steps) to round-off (bit for bit on the machine that wrote it)."""
    with np.load(os.path.join(HERE, "data", "csc_lwr_full_spring_before.npz")) as f:
        ref = dict(f)
    K6 = np.diag([3000.0, 1000.0, 2000.0, 100.0, 100.0, 100.0])
    # written with the former default newton=0 (no Newton correction inside a step)
    r = csc.csc_rollout(LWR_A7, ref["targets"], K6, ref["q0"], 2.0, locked_joints="spring", newton=0)
    for name in ("q", "u", "frobenius", "kj", "K_C", "u_start", "frobenius_start", "null_step", "status"):
        np.testing.assert_allclose(np.asarray(getattr(r, name)), ref[name], rtol=1e-9, atol=1e-9, err_msg=name)
    rigid = csc.csc_rollout(LWR_A7, ref["targets"], K6, ref["q0"], 2.0)
    assert np.all(np.isposinf(np.asarray(rigid.kj)[:, 6])) and np.all(ref["kj"][:, 6] > 0)


def test_no_locked_joints_same_for_both_modes():
    """Without locked joints the option changes nothing, bit for bit (planar 3R hold)."""
    x0 = np.asarray(PLANAR.fk(jnp.asarray(Q3)))[:2, 3]
    pts = np.tile(x0, (20, 1))
    a = csc.csc_rollout(PLANAR, pts, K2, Q3, 2e-3, step="constant", locked_joints="rigid")
    b = csc.csc_rollout(PLANAR, pts, K2, Q3, 2e-3, step="constant", locked_joints="spring")
    for name, x in a.as_dict().items():
        assert np.array_equal(np.asarray(x), np.asarray(getattr(b, name))), name
