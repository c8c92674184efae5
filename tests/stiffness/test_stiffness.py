"""Stiffness mappings (SPEC section 2) against independent references.

References: ``numpy.linalg.inv`` of ``J K_j^-1 J^T``; the minimum joint-spring energy of a TCP
displacement (a KKT system solved by numpy), which defines what the translational stiffness of
tasks ``xyz`` and ``full`` mean physically; a closed-form geometric (CCT) term for the planar 3R
and central finite differences of ``J(q)^T F`` for the LWR; exact CMS scaling.
"""

from __future__ import annotations

import functools
import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from helpers import assert_close, central_diff, robot_by_name
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import jaxstiff
from jaxstiff.stiffness import TASK_ROWS, cms_scale, compliance_condition

RNG = np.random.default_rng(42)
N = 64  # batch size used throughout (each new shape compiles anew)


def random_postures(r, n=N, rng=RNG):
    q = rng.uniform(np.asarray(r.lower), np.asarray(r.upper), size=(n, r.n))
    kj = rng.uniform(1.0, 100.0, size=(n, r.n))
    return q, kj


def numpy_compliance(J, kj, task):
    Js = np.asarray(J)[..., list(TASK_ROWS[task]), :]
    return np.einsum("...in,...jn->...ij", Js / kj[..., None, :], Js)


def check_rel_error(rel, cond):
    """Relative errors of K against an undamped numpy reference, by the compliance's condition number.

    1e-12 where the posture is well conditioned (cond < 1e3); ~eps * cond (rounding, like LAPACK's
    own) while the damping is provably off (every Cholesky pivot keeps >= 1/cond of its diagonal,
    so cond < 1e5 means e < 1e-12 t exp(-10)); and at most the damping's own effect, ~1e-12 * cond,
    beyond that.
    """
    assert np.all(rel[cond < 1e3] < 1e-12), rel[cond < 1e3].max()
    ok = cond < 1e5
    assert np.all(rel[ok] < 1e-12 + 2e-15 * cond[ok]), (rel[ok] / cond[ok]).max()
    assert np.all(rel < 1e-12 + 2e-12 * cond), (rel / cond).max()


CASES = [("kuka_lwr4", "xyz"), ("kuka_lwr4", "full"), ("planar_3r", "xy")]


@pytest.mark.slow
@pytest.mark.parametrize("name,task", CASES)
def test_cartesian_stiffness_matches_numpy_inverse(name, task):
    r = robot_by_name(name)
    q, kj = random_postures(r)
    J = np.asarray(r.jacobian(jnp.asarray(q)))
    K = jaxstiff.cartesian_stiffness(jnp.asarray(J), jnp.asarray(kj), task)
    assert K.dtype == jnp.float64
    K = np.asarray(K)
    C = numpy_compliance(J, kj, task)
    Kn = np.linalg.inv(C)
    cond = np.linalg.cond(C)
    rel = np.abs(K - Kn).max(axis=(-2, -1)) / np.abs(Kn).max(axis=(-2, -1))
    check_rel_error(rel, cond)
    assert_close(K, np.swapaxes(K, -1, -2), rtol=0, atol=0, what="exactly symmetric")
    # the translational stiffness: K_C itself, or its top-left block for "full"
    KT = np.asarray(jaxstiff.translational_stiffness(jnp.asarray(J), jnp.asarray(kj), task))
    ref = K[..., :3, :3] if task == "full" else K
    check_rel_error(np.abs(KT - ref).max(axis=(-2, -1)) / np.abs(ref).max(axis=(-2, -1)), cond)


def min_spring_energy(J6, kj, dx, task):
    """Least joint-spring energy 1/2 dq^T K_j dq of a TCP displacement (numpy KKT solve).

    ``full``: the TCP translates by dx with its orientation held (J dq = [dx; 0]);
    ``xyz``: the TCP translates by dx, orientation free (J_v dq = dx).
    """
    n = J6.shape[1]
    A = J6 if task == "full" else J6[:3]
    b = np.concatenate([dx, np.zeros(3)]) if task == "full" else dx
    kkt = np.block([[np.diag(kj), A.T], [A, np.zeros((A.shape[0], A.shape[0]))]])
    sol = np.linalg.solve(kkt, np.concatenate([np.zeros(n), b]))
    dq = sol[:n]
    return 0.5 * dq @ (kj * dq)


def test_translational_stiffness_physical_meaning():
    """1/2 dx^T K_T dx is the least spring energy of a TCP translation dx (orientation held for
    "full", free for "xyz"); so K_T(full) >= K_T(xyz) in the Loewner order."""
    r = robot_by_name("kuka_lwr4")
    q, kj = random_postures(r, n=N)
    J = np.asarray(r.jacobian(jnp.asarray(q)))
    KT = {t: np.asarray(jaxstiff.translational_stiffness(jnp.asarray(J), jnp.asarray(kj), t)) for t in ("full", "xyz")}
    for b in range(8):
        for dx in RNG.normal(size=(4, 3)) * 1e-3:
            for task in ("full", "xyz"):
                E = min_spring_energy(J[b], kj[b], dx, task)
                assert_close(0.5 * dx @ KT[task][b] @ dx, E, rtol=1e-9, what=task)
        diff = np.linalg.eigvalsh(KT["full"][b] - KT["xyz"][b])
        assert diff.min() > -1e-9 * np.abs(KT["full"][b]).max()


def test_full_is_schur_complement():
    r = robot_by_name("kuka_lwr4")
    q, kj = random_postures(r, n=N)
    J = np.asarray(r.jacobian(jnp.asarray(q)))
    C = numpy_compliance(J, kj, "full")
    S = C[:, :3, :3] - C[:, :3, 3:] @ np.linalg.solve(C[:, 3:, 3:], C[:, 3:, :3])
    KT = np.asarray(jaxstiff.translational_stiffness(jnp.asarray(J), jnp.asarray(kj), "full"))
    check_rel_error(np.abs(KT - np.linalg.inv(S)).max((-2, -1)) / np.abs(KT).max((-2, -1)), np.linalg.cond(C))


@pytest.mark.parametrize("name,task", [("kuka_lwr4", "full"), ("kuka_lwr4", "xyz"), ("planar_3r", "xy")])
def test_cms_scales_axes_only(name, task):
    """Scaling every kj by k scales K_T by k: axes by k, same ratio and directions (S0 section III).

    Exact to 1e-12 at well-conditioned postures; elsewhere rounding grows like eps * cond(C)."""
    r = robot_by_name(name)
    q, kj = random_postures(r, n=N)
    J = r.jacobian(jnp.asarray(q))
    cond = np.linalg.cond(numpy_compliance(np.asarray(J), kj, task))
    tol = np.where(cond < 1e3, 1e-12, 1e-12 + 2e-15 * cond)
    K = np.asarray(jaxstiff.translational_stiffness(J, jnp.asarray(kj), task))
    e = jaxstiff.ellipsoid(jnp.asarray(K))
    for k in [0.5, 1.7, 3.0]:
        Kk = np.asarray(jaxstiff.translational_stiffness(J, jnp.asarray(k * kj), task))
        rel = np.abs(Kk - k * K).max((-2, -1)) / np.abs(k * K).max((-2, -1))
        assert np.all(rel < tol), (rel / tol).max()
        ek = jaxstiff.ellipsoid(jnp.asarray(Kk))
        assert np.all(np.abs(np.asarray(ek.axes) / (k * np.asarray(e.axes)) - 1).max(-1) < 10 * tol)
        assert np.all(np.abs(np.asarray(ek.ratio) / np.asarray(e.ratio) - 1) < 10 * tol)
        v, vk = np.asarray(e.major), np.asarray(ek.major)
        vd = np.sum(v * vk, -1, keepdims=True)
        angle = np.linalg.norm(vk - vd * v, axis=-1)  # sine of the angle between the major axes
        ok = (cond < 1e3) & (np.asarray(e.ratio) > 1.1)
        assert ok.sum() > N // 4
        assert np.all(angle[ok] < 1e-10), "major axis unchanged"


def test_cms_factor_reaches_targets():
    r = robot_by_name("kuka_lwr4")
    q, kj = random_postures(r, n=N)
    J = r.jacobian(jnp.asarray(q))
    K = jaxstiff.translational_stiffness(J, jnp.asarray(kj), "full")
    k = jaxstiff.cms_factor(K, target_major=5000.0)
    assert_close(
        np.linalg.eigvalsh(np.asarray(k)[:, None, None] * np.asarray(K))[:, -1], np.full(N, 5000.0), rtol=1e-12
    )
    k, kj_scaled = cms_scale(K, jnp.asarray(kj), target_volume=1e9)
    assert_close(kj_scaled, np.asarray(k)[:, None] * kj, rtol=1e-15)
    K_scaled = jaxstiff.translational_stiffness(J, kj_scaled, "full")
    # the volume target is met to 1e-10 where the posture is well conditioned; near a singularity
    # K carries the documented damping (check_rel_error: ~1e-12 x cond, ~3x that in a determinant).
    # Which postures the shared RNG draws here depends on the tests run before (the fast lane's
    # order drew one with cond ~1e12), so the bound follows the condition, as check_rel_error does.
    rel = np.abs(np.linalg.det(np.asarray(K_scaled)) / 1e9 - 1.0)
    cond = np.asarray(jaxstiff.compliance_condition(J, kj_scaled, "full"))
    assert np.all(rel[cond < 1e5] < 1e-10), rel[cond < 1e5].max()
    assert np.all(rel < 1e-10 + 6e-12 * cond), (rel / cond).max()
    with pytest.raises(ValueError, match="exactly one"):
        jaxstiff.cms_factor(K)
    with pytest.raises(ValueError, match="target_major must be a finite number > 0"):
        jaxstiff.cms_factor(K, target_major=-1.0)


def test_cms_factor_refuses_what_no_finite_factor_sizes():
    """A tester got k = -0.0033 (an array target of -5), NaN (one negative entry of an array
    target), inf (K = 0, a singular K with a volume target, target inf) and a plausible 0.333 for
    an indefinite K, all without a word, where the docstring promises k > 0. Concrete input is
    checked; a traced one is not (a singular K gives inf there)."""
    K = jnp.diag(jnp.array([4.0, 1.0, 0.5]))
    for bad, match in (
        (dict(target_major=np.array(-5.0)), "target_major must be a finite number > 0, got -5"),
        (dict(target_volume=jnp.array([1e9, -1e9])), "target_volume must be a finite number > 0, got -1e\\+09"),
        (dict(target_major=float("inf")), "target_major must be a finite number > 0, got inf"),
    ):
        with pytest.raises(ValueError, match=match):
            jaxstiff.cms_factor(K, **bad)
    with pytest.raises(ValueError, match="largest eigenvalue is 0"):
        jaxstiff.cms_factor(jnp.zeros((3, 3)), target_major=1000.0)
    with pytest.raises(ValueError, match="singular K has a volume of 0.*smallest eigenvalue is 0"):
        jaxstiff.cms_factor(jnp.diag(jnp.array([1.0, 1.0, 0.0])), target_volume=1e6)
    with pytest.raises(ValueError, match="positive \\(semi-\\)definite"):
        jaxstiff.cms_factor(jnp.array([[1.0, 2.0], [2.0, 1.0]]), target_major=1.0)
    # a singular K has a major axis: a major-axis target sizes it (k = 1000 / 4)
    assert float(jaxstiff.cms_factor(jnp.diag(jnp.array([4.0, 1.0, 0.0])), target_major=1000.0)) == 250.0
    # traced: unchecked, as documented
    assert np.isinf(
        float(jax.jit(lambda k: jaxstiff.cms_factor(k, target_volume=1e6))(jnp.diag(jnp.array([1.0, 1.0, 0.0]))))
    )


def planar_kg(q, F):
    """Closed form d(J^T F)/dq of the planar 3R (unit links), F = (Fx, Fy)."""
    c = np.cumsum(q)
    KG = np.zeros((3, 3))
    for i in range(3):
        for j in range(3):
            k0 = max(i, j)
            KG[i, j] = np.sum(-F[0] * np.cos(c[k0:]) - F[1] * np.sin(c[k0:]))
    return KG


def test_joint_stiffness_congruence_and_cct_planar_closed_form():
    r = robot_by_name("planar_3r")
    q = np.radians([75.0, -74.74, -76.30])
    J = np.asarray(r.jacobian(jnp.asarray(q)))
    Kx = np.array([[900.0, 120.0], [120.0, 300.0]])
    Kq = np.asarray(jaxstiff.joint_stiffness(jnp.asarray(J), jnp.asarray(Kx), task="xy"))
    assert_close(Kq, J[:2].T @ Kx @ J[:2], rtol=1e-13)
    F = np.array([12.0, -7.0])
    Kq_F = np.asarray(
        jaxstiff.joint_stiffness(jnp.asarray(J), jnp.asarray(Kx), jnp.asarray(F), robot=r, q=jnp.asarray(q), task="xy")
    )
    assert_close(Kq_F - Kq, planar_kg(q, F), rtol=1e-12, atol=1e-12)
    # F = 0 reduces to the congruence
    Kq_0 = jaxstiff.joint_stiffness(jnp.asarray(J), jnp.asarray(Kx), jnp.zeros(2), robot=r, q=jnp.asarray(q), task="xy")
    assert_close(Kq_0, Kq, rtol=1e-14)


@pytest.mark.slow
def test_cct_term_vs_finite_differences_lwr():
    task = "full"
    r = robot_by_name("kuka_lwr4")
    rows = list(TASK_ROWS[task])
    q = RNG.uniform(-1.5, 1.5, size=(2, r.n))
    F = RNG.normal(size=(2, len(rows))) * 20.0
    Kx = np.eye(len(rows)) * 1000.0
    J = r.jacobian(jnp.asarray(q))
    KG = np.asarray(
        jaxstiff.joint_stiffness(J, jnp.asarray(Kx), jnp.asarray(F), robot=r, q=jnp.asarray(q), task=task)
    ) - np.asarray(jaxstiff.joint_stiffness(J, jnp.asarray(Kx), task=task))
    for b in range(2):
        tau = lambda x: np.asarray(r.jacobian(jnp.asarray(x)))[rows].T @ F[b]  # noqa: E731, B023  (called in this iteration)
        assert_close(KG[b], central_diff(tau, q[b], h=1e-6), rtol=1e-7, atol=1e-7)


def test_cct_wrench_broadcast_over_postures():
    r = robot_by_name("planar_3r")
    q = RNG.uniform(-2, 2, size=(4, 3))
    F = np.array([3.0, -5.0])
    J = r.jacobian(jnp.asarray(q))
    Kq = jaxstiff.joint_stiffness(J, jnp.eye(2) * 100.0, jnp.asarray(F), robot=r, q=jnp.asarray(q), task="xy")
    assert Kq.shape == (4, 3, 3)
    Jn = np.asarray(J)[:, :2]
    for b in range(4):
        assert_close(Kq[b], Jn[b].T @ (100.0 * Jn[b]) + planar_kg(q[b], F), rtol=1e-12, atol=1e-12)


def test_joint_stiffness_errors():
    r = robot_by_name("planar_3r")
    J = r.jacobian(jnp.zeros(3))
    with pytest.raises(ValueError, match="needs robot= and q="):
        jaxstiff.joint_stiffness(J, jnp.eye(2), jnp.ones(2), task="xy")
    with pytest.raises(ValueError, match="K_x must have shape"):
        jaxstiff.joint_stiffness(J, jnp.eye(3), task="xy")


@functools.partial(jax.jit, static_argnums=2)
def _grad_of_stiffness(J, kj, task):
    """Gradient of a scalar of K_T w.r.t. J and kj (compiled once per shape and task)."""
    return jax.grad(
        lambda JJ, kk: jnp.sum(jnp.sin(jaxstiff.translational_stiffness(JJ, kk, task) * 1e-3)), argnums=(0, 1)
    )(J, kj)


SINGULAR = [
    ("kuka_lwr4", np.zeros(7), "full"),  # stretched upright
    ("kuka_lwr4", np.zeros(7), "xyz"),
    ("kuka_lwr4", np.array([0.3, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]), "full"),
    ("planar_3r", np.zeros(3), "xy"),  # stretched
    ("planar_3r", np.array([0.4, 0.0, 0.0]), "xy"),
]


@pytest.mark.slow
@pytest.mark.parametrize("name,q,task", SINGULAR)
def test_singular_postures_are_flagged_and_finite(name, q, task):
    r = robot_by_name(name)
    J = r.jacobian(jnp.asarray(q))
    for kj in [np.full(r.n, 1.0), np.full(r.n, 100.0), np.linspace(1.0, 100.0, r.n)]:
        K = jaxstiff.cartesian_stiffness(J, jnp.asarray(kj), task)
        KT = jaxstiff.translational_stiffness(J, jnp.asarray(kj), task)
        assert bool(jnp.all(jnp.isfinite(K))) and bool(jnp.all(jnp.isfinite(KT)))
        assert np.linalg.eigvalsh(np.asarray(KT)).min() > 0, "K_T stays positive definite"
        assert float(compliance_condition(J, jnp.asarray(kj), task)) > 1e10
        g = _grad_of_stiffness(J, jnp.asarray(kj), task)
        assert all(bool(jnp.all(jnp.isfinite(x))) for x in g)


def test_condition_of_regular_postures_is_modest():
    r = robot_by_name("kuka_lwr4")
    q = np.array([0.3, 0.8, -0.4, -1.3, 0.5, 0.9, 0.0])
    kj = np.full(7, 50.0)
    J = r.jacobian(jnp.asarray(q))
    for task in ("full", "xyz"):
        cond = float(compliance_condition(J, jnp.asarray(kj), task))
        assert_close(cond, np.linalg.cond(numpy_compliance(np.asarray(J), kj, task)), rtol=1e-6)
        assert cond < 1e4


def test_zero_or_negative_kj_stays_finite():
    """Inside a trace (a batch where some kj are not known to be positive) the clamp keeps K finite;
    given as numbers, kj <= 0 is refused (test_concrete_non_positive_kj_is_refused_by_name)."""
    r = robot_by_name("planar_3r")
    J = r.jacobian(jnp.asarray([0.5, 0.5, 0.5]))
    K = jax.jit(jaxstiff.translational_stiffness, static_argnames="task")(J, jnp.asarray([0.0, -1.0, 10.0]), task="xy")
    assert bool(jnp.all(jnp.isfinite(K)))


@pytest.mark.slow
def test_dtype_kept_float32():
    r = robot_by_name("kuka_lwr4")
    q = np.array([0.3, 0.8, -0.4, -1.3, 0.5, 0.9, 0.0])
    kj = np.linspace(10.0, 90.0, 7)
    J64 = r.jacobian(jnp.asarray(q))
    J32 = jnp.asarray(J64, jnp.float32)
    for task in ("xyz", "full"):
        for fn in (jaxstiff.cartesian_stiffness, jaxstiff.translational_stiffness):
            out32 = fn(J32, jnp.asarray(kj, jnp.float32), task)
            out64 = fn(J64, jnp.asarray(kj), task)
            assert out32.dtype == jnp.float32 and out64.dtype == jnp.float64
            assert_close(out32, out64, rtol=2e-3, atol=2e-4 * float(jnp.max(jnp.abs(out64))))


def test_batch_shapes_and_broadcasting():
    r = robot_by_name("planar_3r")
    q = RNG.uniform(-2, 2, size=(3, 1, 2, 3))
    J = r.jacobian(jnp.asarray(q))
    kj = jnp.asarray([500.0, 300.0, 100.0])  # one kj for the whole batch
    K = jaxstiff.translational_stiffness(J, kj, "xy")
    assert K.shape == (3, 1, 2, 2, 2)
    ref = np.linalg.inv(numpy_compliance(np.asarray(J), np.asarray(kj), "xy"))
    assert_close(K, ref, rtol=1e-9)
    for shape in [(), (1,)]:
        qq = jnp.asarray(RNG.uniform(-2, 2, size=shape + (3,)))
        assert jaxstiff.translational_stiffness(r.jacobian(qq), kj, "xy").shape == shape + (2, 2)


def test_no_recompilation_for_same_shapes():
    r = robot_by_name("planar_3r")
    J = r.jacobian(jnp.asarray(RNG.uniform(-2, 2, size=(N, 3))))
    kj = jnp.asarray(RNG.uniform(1, 100, size=(N, 3)))
    jaxstiff.translational_stiffness(J, kj, "xy")
    before = jaxstiff.translational_stiffness._cache_size()
    jaxstiff.translational_stiffness(J * 1.01, kj * 2.0, "xy")
    assert jaxstiff.translational_stiffness._cache_size() == before


def test_bad_inputs_raise_clear_errors():
    J = jnp.ones((6, 3))
    with pytest.raises(ValueError, match="unknown task 'xz'"):
        jaxstiff.cartesian_stiffness(J, jnp.ones(3), "xz")
    with pytest.raises(ValueError, match="J must have 6 rows"):
        jaxstiff.cartesian_stiffness(jnp.ones((5, 3)), jnp.ones(3), "full")
    with pytest.raises(ValueError, match=r"kj must have shape \(\.\.\., 3\)"):
        jaxstiff.cartesian_stiffness(J, jnp.ones(4), "xyz")
    with pytest.raises(ValueError, match="floating"):
        jaxstiff.cartesian_stiffness(jnp.ones((6, 3), dtype=jnp.int32), jnp.ones(3), "xyz")


def test_seed_fig2_posture_numbers():
    """The seed's Fig. 2 posture: K_T from the closed-form planar Jacobian (numpy) matches."""
    r = robot_by_name("planar_3r")
    q = np.radians([75.0, -74.74, -76.30])
    kj = np.array([500.0, 300.0, 100.0])
    c = np.cumsum(q)
    Jxy = np.array([[-np.sin(c[i:]).sum() for i in range(3)], [np.cos(c[i:]).sum() for i in range(3)]])
    ref = np.linalg.inv(Jxy @ np.diag(1 / kj) @ Jxy.T)
    K = jaxstiff.translational_stiffness(r.jacobian(jnp.asarray(q)), jnp.asarray(kj), "xy")
    assert_close(K, ref, rtol=1e-12)
    assert math.isfinite(float(jaxstiff.ellipsoid(K).ratio))


@st.composite
def jacobian_batches(draw):
    """Random 6x7 Jacobians (N of them), some rank-deficient, over many scales, and kj in [1, 100]."""
    rng = np.random.default_rng(draw(st.integers(0, 2**31 - 1)))
    J = rng.normal(size=(N, 6, 7)) * 10.0 ** draw(st.floats(-2, 1))
    rank = draw(st.integers(1, 6))
    if rank < 6:  # J = A B with A 6 x rank: rank-deficient, lost directions in random orientations
        J = rng.normal(size=(N, 6, rank)) @ rng.normal(size=(N, rank, 7)) * 10.0 ** draw(st.floats(-2, 1))
    kj = rng.uniform(1.0, 100.0, size=(N, 7))
    if draw(st.booleans()):
        kj[:, draw(st.integers(0, 6))] = draw(st.sampled_from([1.0, 100.0]))  # a joint at a bound
    return J, kj, draw(st.sampled_from(["xyz", "full"]))


@pytest.mark.slow
@settings(max_examples=15, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(jacobian_batches())
def test_property_spd_finite_and_exact_when_regular(data):
    J, kj, task = data
    KT = np.asarray(jaxstiff.translational_stiffness(jnp.asarray(J), jnp.asarray(kj), task))
    assert np.all(np.isfinite(KT))
    assert_close(KT, np.swapaxes(KT, -1, -2), rtol=0, atol=0, what="symmetric")
    w = np.linalg.eigvalsh(KT)
    assert np.all(w[:, 0] > -1e-6 * w[:, -1]), "positive (semi-)definite up to rounding of the huge axes"
    C = numpy_compliance(J, kj, task)
    cond = np.linalg.cond(C)
    regular = cond < 1e5
    if regular.any():
        ref = np.linalg.inv(C[regular])
        ref = ref[:, :3, :3] if task == "full" else ref
        rel = np.abs(KT[regular] - ref).max((-2, -1)) / np.abs(ref).max((-2, -1))
        assert np.all(rel < 1e-12 + 2e-15 * cond[regular])
    else:  # rank-deficient draws: the stiffness functions report it
        assert np.all(np.asarray(compliance_condition(jnp.asarray(J), jnp.asarray(kj), task)) > 1e10)


@pytest.mark.slow
def test_fusion_boundary_is_an_identity_for_every_transformation():
    """The CPU fusion boundary (a primitive of its own) is the identity in value, under vmap
    (nested too), and for derivatives: forward, reverse, reverse over vmap, second order."""
    from jaxstiff.stiffness._core import fusion_boundary

    def f(x):
        y = fusion_boundary({"a": jnp.sin(x) * x, "b": x[..., :2] ** 3})
        return jnp.sum(y["a"] ** 2) + jnp.sum(jnp.cos(y["b"]))

    def ref(x):
        return jnp.sum((jnp.sin(x) * x) ** 2) + jnp.sum(jnp.cos(x[..., :2] ** 3))

    x = jnp.asarray(RNG.normal(size=(5, 4, 3)))
    for make in (
        lambda g: jax.vmap(jax.vmap(g)),
        lambda g: jax.vmap(jax.vmap(jax.grad(g))),
        lambda g: jax.grad(lambda z: jnp.sum(jax.vmap(jax.vmap(g))(z))),
        lambda g: jax.vmap(jax.vmap(jax.jacfwd(g))),
        lambda g: jax.vmap(jax.vmap(jax.hessian(g))),
        lambda g: jax.jit(jax.vmap(jax.vmap(jax.jacrev(jax.grad(g))))),
    ):
        np.testing.assert_allclose(make(f)(x), make(ref)(x), rtol=1e-13, atol=1e-13)
    assert fusion_boundary({}) == {}
    empty = jnp.zeros((0, 3))
    assert fusion_boundary(empty) is empty


@pytest.mark.slow
@pytest.mark.skipif(jax.default_backend() != "cpu", reason="the boundary is a conditional on CPU only")
def test_fusion_boundary_survives_vmap_on_cpu():
    """Under vmap the stiffness must still be computed behind a conditional (a ``select`` would
    let XLA re-evaluate the whole closed form per output entry: ~10x slower, same values)."""
    r = robot_by_name("kuka_lwr4")
    q, kj = random_postures(r, 8)

    def K(q, kj):
        return jaxstiff.stiffness.translational_stiffness(jaxstiff.jacobian(r, q), kj, task="full")

    hlo = jax.jit(jax.vmap(K)).lower(q, kj).compile().as_text()
    assert "conditional(" in hlo
    hlo = jax.jit(jax.vmap(jax.grad(lambda q, kj: jnp.sum(K(q, kj) ** 2)))).lower(q, kj).compile().as_text()
    assert "conditional(" in hlo


_ELBOW_BEYOND_PI = """<robot name="r"><link name="l0"/><link name="l1"/><link name="l2"/><link name="l3"/><link name="l4"/>
<joint name="j1" type="revolute"><parent link="l0"/><child link="l1"/><origin xyz="0 0 0.2"/><axis xyz="0 0 1"/><limit lower="-2.5" upper="2.5" effort="1" velocity="1"/></joint>
<joint name="j2" type="revolute"><parent link="l1"/><child link="l2"/><origin xyz="0 0 0.1"/><axis xyz="0 1 0"/><limit lower="-2.5" upper="2.5" effort="1" velocity="1"/></joint>
<joint name="j3" type="revolute"><parent link="l2"/><child link="l3"/><origin xyz="0.3 0 0"/><axis xyz="0 1 0"/><limit lower="3.3" upper="3.8" effort="1" velocity="1"/></joint>
<joint name="j4" type="fixed"><parent link="l3"/><child link="l4"/><origin xyz="0.25 0 0"/></joint></robot>"""


def test_task_check_samples_each_joint_inside_its_own_range(tmp_path):
    """An elbow whose range [3.3, 3.8] rad lies beyond pi: clipping it to [-pi, pi] sampled only the
    folded (singular) elbow and refused a controllable 'xyz' task. numpy (independent): the
    position Jacobian has 3 singular values well above 0 inside the range."""
    from jaxstiff.stiffness import check_task_feasible

    f = tmp_path / "elbow.urdf"
    f.write_text(_ELBOW_BEYOND_PI)
    robot = jaxstiff.Robot.from_urdf(str(f))
    s = np.linalg.svd(np.asarray(robot.jacobian(np.array([0.3, -0.8, 3.5])))[:3], compute_uv=False)
    assert s[-1] > 1e-3
    check_task_feasible(robot, "xyz")  # no error
    with pytest.raises(ValueError, match="only 3 joint"):
        check_task_feasible(robot, "full")


def test_task_check_counts_the_joints_with_a_spring():
    """Two of the LWR's seven joints locked. Kept as springs, the 6-row stiffness has seven springs,
    so task 'full' is defined (numpy: the full 6 x 7 Jacobian has rank 6 with a finite condition
    number), while a CSC rollout, whose free joints must follow all six rows, is refused. Rigid (the
    default), only the five free joints give, so K along one direction is infinite: refused, with
    the spring option named (it ran and stored a K_T of ~1e15 N/m)."""
    from jaxstiff.stiffness import check_task_feasible

    robot = jaxstiff.Robot.from_urdf("kuka_lwr4", locked={"lwr_a3": 0.0, "lwr_a7": 0.2})
    q = np.where(robot.free, np.deg2rad([20.0, 40.0, 0.0, -70.0, 25.0, 50.0, 0.0]), robot.locked_values)
    J = np.asarray(robot.jacobian(np.asarray(q, dtype=np.float64)), dtype=float)
    s = np.linalg.svd(J, compute_uv=False)
    assert s[-1] > 1e-3 * s[0]  # all seven columns: rank 6
    assert np.linalg.matrix_rank(J[:, robot.free]) == 5  # the free joints alone: rank 5
    check_task_feasible(robot, "full", locked_joints="spring")  # no error: the stiffness is defined
    with pytest.raises(
        ValueError, match=r"only 5 joint\(s\) have a spring \(the 2 locked one\(s\) are rigid\).*--locked-joints spring"
    ):
        check_task_feasible(robot, "full")
    check_task_feasible(robot, "xyz")  # five springs for three rows: defined
    with pytest.raises(ValueError, match="locked_joints must be 'rigid' or 'spring'"):
        check_task_feasible(robot, "xyz", locked_joints="stiff")
    K = np.asarray(jaxstiff.cartesian_stiffness(J, np.full(7, 50.0), task="full"))
    assert_close(K, np.linalg.inv(J @ np.diag(np.full(7, 1 / 50.0)) @ J.T), rtol=1e-9, what="K with locked springs")
    with pytest.raises(ValueError, match=r"only 5 free joint\(s\) move the TCP.*cannot be followed.*or unlock joints"):
        check_task_feasible(robot, "full", motion=True)


@pytest.mark.slow
@pytest.mark.parametrize("fn", ["compliance", "cartesian_stiffness", "translational_stiffness", "compliance_condition"])
def test_concrete_non_positive_kj_is_refused_by_name(fn):
    """kj <= 0 or NaN given as numbers: a ValueError naming the entry (it came back as a matrix of
    ~1e-140 from the regularisation, or of NaN); under a trace the clamp keeps a batch finite."""
    r = jaxstiff.Robot.from_urdf("kuka_lwr4", locked={"lwr_a7": 0.0})
    J = jaxstiff.jacobian(r, jnp.full(7, 0.3).at[6].set(0.0))  # lwr_a7 at its locked value
    f = getattr(jaxstiff.stiffness, fn)
    kj = np.full(7, 50.0)
    assert np.all(np.isfinite(np.asarray(f(J, kj, task="xyz"))))
    for bad, where in (
        (-kj, r"kj\[0\] = -50"),
        (np.where(np.arange(7) == 2, 0.0, kj), r"kj\[2\] = 0"),
        (np.tile(kj, (2, 1)) * [[1.0], [-1.0]], r"kj\[1, 0\] = -50"),
        (np.where(np.arange(7) == 4, np.nan, kj), r"kj\[4\] = nan"),  # it gave an all-NaN matrix
    ):
        with pytest.raises(ValueError, match=r"kj must be > 0 .*" + where):
            f(J, bad, task="xyz")
    traced = jax.jit(lambda k: f(J, k, task="xyz"))(jnp.asarray(np.where(np.arange(7) == 2, 0.0, kj)))
    assert np.all(np.isfinite(np.asarray(traced)))


def test_task_check_hint_when_no_task_fits():
    """Every joint locked (rigid): no task has a spring, so the hint must not send the user to task
    'xy' as if it would work (it said "task 'xy' needs a chain that moves in the base xy plane"
    for the planar 3R, which does move in that plane); it says no smaller task fits and why."""
    from jaxstiff.stiffness import check_task_feasible

    robot = jaxstiff.Robot.from_urdf("planar_3r", locked={"joint_1": 0.0, "joint_2": 0.3, "joint_3": 0.2})
    with pytest.raises(ValueError, match=r"only 0 joint\(s\) have a spring.*no smaller task fits either") as e:
        check_task_feasible(robot, "xyz")
    assert "use task" not in str(e.value)


def test_cms_factor_of_axes_far_from_one_newton_per_metre_is_finite():
    """k = (V / prod w)^(1/m) formed the product of the axes, which left float64 for axes far from
    1 N/m (1e-300 I: a volume of 0, k = inf; shaping with kmin 1e-300 stored inf in cms and
    kj_scaled). Checked in logarithms, independently of the formula: m log k + sum log w = log V."""
    for w in ([1e-300, 1e-300, 1e-300], [1e300, 1e300, 1e-300], [1e-200, 1e-150], [3.0, 2.0, 1.0]):
        K = jnp.diag(jnp.asarray(w))
        k = float(jaxstiff.cms_factor(K, target_volume=1e9))
        assert np.isfinite(k) and k > 0, (w, k)
        assert abs(len(w) * np.log(k) + np.sum(np.log(w)) - np.log(1e9)) < 1e-12 * len(w) * 700, (w, k)
