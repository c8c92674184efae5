"""Stiffness at exactly singular postures (issue 24, finding 1): the LWR with its elbow straight.

References are independent numpy computations from J: the translational compliance
``S = A (I - B^+ B) A^T`` (``A``, ``B`` the translational and rotational rows of ``J K_j^-1/2``,
the projector from a QR factorisation; task "full"), or ``A A^T`` (task "xyz"); the finite axes are
1/eigenvalues of S on its range. For the issue's case the Schur complement of ``C`` (as the
issue computes it) is checked too.
"""

from __future__ import annotations

import functools

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from helpers import assert_close

import jaxstiff
from jaxstiff.stiffness import translational_axes, translational_compliance

Q_CASE = np.array([-2.6390270612749482, -1.5696481420537225, -1.6765694625953258, 0.0, -2.4352979896566778, 1.529683441680743, -1.700039111412567])  # fmt: skip
KJ_CASE = np.array([27.65831725056191, 1.2340370506030465, 1.5808087305479992, 8.171333436700865, 15.822027075893665, 4.129801856805123, 3.5070456973858075])  # fmt: skip


@functools.cache
def lwr(locked: bool) -> jaxstiff.Robot:
    return jaxstiff.Robot.from_urdf("kuka_lwr4", locked={"lwr_a7": float(Q_CASE[6])} if locked else {})


def reference_compliance_eigs(J: np.ndarray, kj: np.ndarray, task: str) -> np.ndarray:
    """Eigenvalues (..., 3) ascending of S, from J by a QR projector (no C_RR^-1 is formed)."""
    w = 1.0 / np.sqrt(kj)
    A = J[..., :3, :] * w[..., None, :]
    if task == "full":
        B = J[..., 3:, :] * w[..., None, :]
        Q, _ = np.linalg.qr(np.swapaxes(B, -1, -2))
        A = A - (A @ Q) @ np.swapaxes(Q, -1, -2)
    s = np.linalg.svd(A, compute_uv=False)
    return (s**2)[..., ::-1]


def reference_axes(mu: np.ndarray) -> np.ndarray:
    """Stiffness axes (..., 3), descending: 1/mu on the range of S, inf on its null space (the
    documented rule: an eigenvalue at or below 1e-8 of the mean of S's eigenvalues)."""
    finite = mu > 1e-8 * mu.mean(-1, keepdims=True)
    return np.where(finite, 1.0 / np.where(finite, mu, 1.0), np.inf)


def schur_reference_axes(J: np.ndarray, kj: np.ndarray) -> np.ndarray:
    """The issue's reference: the Schur complement of C = J K^-1 J^T, restricted to its range."""
    C = (J / kj) @ J.T
    S = C[:3, :3] - C[:3, 3:] @ np.linalg.solve(C[3:, 3:], C[3:, :3])
    mu, _ = np.linalg.eigh(0.5 * (S + S.T))
    return reference_axes(mu)


def case_inputs(variant: str) -> tuple[np.ndarray, np.ndarray]:
    """(J, kj) of the issue's case: every joint sprung, lwr_a7 locked and rigid (its column dropped,
    as the solvers do, or its kj = inf, as the public functions read it)."""
    J = np.asarray(lwr(variant != "all").jacobian(jnp.asarray(Q_CASE)))
    if variant == "all":
        return J, KJ_CASE
    if variant == "a7_dropped":
        return J[:, :6], KJ_CASE[:6]
    return J, np.concatenate([KJ_CASE[:6], [np.inf]])


@pytest.mark.parametrize("variant", ["all", "a7_dropped", "a7_inf"])
def test_issue_case_is_right_at_every_batch_size(variant):
    J, kj = case_inputs(variant)
    ref = reference_axes(reference_compliance_eigs(J[:, np.isfinite(kj)], kj[np.isfinite(kj)], "full"))
    assert np.isinf(ref[0]) and np.all(np.isfinite(ref[1:]))  # the case is what it says: one lost axis
    if variant == "all":
        assert_close(ref[1:], [36.98043668, 7.916777653], rtol=1e-9, what="issue's numbers")
        assert_close(schur_reference_axes(J, kj)[1:], ref[1:], rtol=1e-6, what="Schur-of-C reference")
    got_axes, got_ell = [], []
    for b in (1, 2, 8, 1000):
        Jb, kb = jnp.broadcast_to(J, (b, *J.shape)), jnp.broadcast_to(kj, (b, kj.size))
        axes = np.asarray(translational_axes(Jb, kb, "full")[0])
        ell = jaxstiff.ellipsoid(jaxstiff.translational_stiffness(Jb, kb, "full"))
        assert np.all(np.asarray(ell.axes) > 0) and np.all(np.asarray(ell.volume) > 0), "never indefinite"
        got_axes.append(axes)
        got_ell.append(np.asarray(ell.axes))
    for axes, ax_k in zip(got_axes, got_ell, strict=True):
        assert np.all(np.isinf(axes[:, 0])), "the lost direction is reported as infinitely stiff"
        assert_close(axes[:, 1:], np.broadcast_to(got_axes[0][0, 1:], axes[:, 1:].shape), rtol=1e-9)
        assert_close(ax_k, np.broadcast_to(got_ell[0][0], ax_k.shape), rtol=1e-9, what="ellipsoid(K_T)")
        assert_close(axes[0, 1:], ref[1:], rtol=1e-6, what="translational_axes")
        assert_close(ax_k[0, 1:], ref[1:], rtol=1e-6, what="ellipsoid(translational_stiffness)")
        assert ax_k[0, 0] > 1e6 * ax_k[0, 1], "the lost direction reads as a huge finite stiffness in K_T"


def test_translational_compliance_is_the_schur_complement_at_the_case():
    J, kj = case_inputs("all")
    S = np.asarray(translational_compliance(jnp.asarray(J), jnp.asarray(kj), "full"))
    mu = reference_compliance_eigs(J, kj, "full")
    assert_close(np.linalg.eigvalsh(S), mu, rtol=0, atol=1e-13 * mu[-1])


@pytest.mark.slow
@pytest.mark.parametrize("task", ["full", "xyz"])
def test_random_elbow_straight_postures(task):
    """10^4 postures with q4 = 0 exactly and kj log-uniform in [1e-3, 1e3] Nm/rad, every joint
    sprung: no negative axis, and every axis finite in the reference within 1e-6 of it."""
    rng = np.random.default_rng(24)
    r = lwr(False)
    q = rng.uniform(np.asarray(r.lower), np.asarray(r.upper), size=(10_000, 7))
    q[:, 3] = 0.0
    kj = 10.0 ** rng.uniform(-3.0, 3.0, size=q.shape)
    J = np.asarray(r.jacobian(jnp.asarray(q)))
    ref = reference_axes(reference_compliance_eigs(J, kj, task))
    axes = np.asarray(translational_axes(jnp.asarray(J), jnp.asarray(kj), task)[0])
    assert np.all(axes > 0)
    fin = np.isfinite(ref)
    mu = 1.0 / np.where(fin, ref, np.inf)
    mu_true = reference_compliance_eigs(J, kj, task)
    border = np.abs(np.log(mu_true / (1e-8 * mu_true.mean(-1, keepdims=True)))) < np.log(2.0)
    assert border.sum() < 0.01 * border.size  # eigenvalues within 2x of the floor: either reading is right
    assert np.array_equal(np.isfinite(axes)[~border], fin[~border]), "infinite exactly where the reference is"
    fin &= np.isfinite(axes)
    assert_close(axes[fin], ref[fin], rtol=1e-6, what="translational_axes")
    ell = jaxstiff.ellipsoid(jaxstiff.translational_stiffness(jnp.asarray(J), jnp.asarray(kj), task))
    ax_k = np.asarray(ell.axes)
    assert np.all(ax_k > 0) and np.all(np.asarray(ell.volume) > 0)
    # K_T is exact for every axis whose compliance exceeds 40 delta times the mean (module docstring
    # of jaxstiff.stiffness._schur); the few axes within 100x of that are left out
    exact = mu > 100 * 1e-8 * mu.sum(-1, keepdims=True) / 3
    assert exact.sum() > 0.95 * fin.sum()
    assert_close(ax_k[exact], ref[exact], rtol=1e-6, what="ellipsoid(translational_stiffness)")


@pytest.mark.slow
def test_random_elbow_straight_postures_rigid_a7():
    """lwr_a7 locked and rigid (6 sprung joints, J square and of rank 5), kj log-uniform over a
    spread of 1e4: outside the floor region both readings match the J-based reference to 1e-6.
    (With a spread of 1e6 about 0.1 % of such postures are up to 2e-4 off through an
    ill-conditioned C_RR: docs/notes/stiffness_singular.md.)"""
    rng = np.random.default_rng(2401)
    r = lwr(True)
    q = rng.uniform(np.asarray(r.lower), np.asarray(r.upper), size=(4000, 7))
    q[:, 3] = 0.0
    q[:, 6] = Q_CASE[6]
    kj = 10.0 ** rng.uniform(-2.0, 2.0, size=(4000, 6))
    J = np.asarray(r.jacobian(jnp.asarray(q)))[:, :, :6]
    mu = reference_compliance_eigs(J, kj, "full")  # ascending
    assert np.all(mu[:, 0] < 1e-12 * mu[:, 2])  # every posture loses one direction
    a = 1e-8 * mu.sum(-1) / 3
    ref = 1.0 / mu[:, 1:]  # the two finite axes, descending
    axes = np.asarray(translational_axes(jnp.asarray(J), jnp.asarray(kj), "full")[0])
    assert np.all(np.isinf(axes[:, 0]))
    exact = mu[:, 1] > 40 * a  # the middle axis's compliance clear of the floor (schur's docstring)
    assert exact.mean() > 0.99
    assert_close(axes[exact, 1:], ref[exact], rtol=1e-6, what="translational_axes, rigid a7")
    ell = jaxstiff.ellipsoid(jaxstiff.translational_stiffness(jnp.asarray(J), jnp.asarray(kj), "full"))
    assert_close(np.asarray(ell.axes)[exact, 1:], ref[exact], rtol=1e-6, what="ellipsoid, rigid a7")


def _criteria(q: jax.Array, kj: jax.Array, robot: jaxstiff.Robot) -> jax.Array:
    K = jaxstiff.translational_stiffness(robot.jacobian(q), kj, "full")
    d = jnp.array([0.3, -0.5, 0.8])
    return jnp.stack([jaxstiff.f1(K, d, 5.0), jaxstiff.f2(K, d, 5.0), jaxstiff.orientation_error(K, d)])


def test_values_and_gradients_finite_at_singular_postures():
    rng = np.random.default_rng(5)
    r = lwr(False)
    q = rng.uniform(np.asarray(r.lower), np.asarray(r.upper), size=(16, 7))
    q[:, 3] = 0.0
    q[0] = Q_CASE
    kj = 10.0 ** rng.uniform(-3.0, 3.0, size=q.shape)
    kj[0] = KJ_CASE
    f = functools.partial(_criteria, robot=r)
    vals = jax.vmap(f)(jnp.asarray(q), jnp.asarray(kj))
    jq, jk = jax.vmap(jax.jacrev(f, argnums=(0, 1)))(jnp.asarray(q), jnp.asarray(kj))
    for x in (vals, jq, jk):
        assert bool(jnp.all(jnp.isfinite(x)))
    g = jax.jacrev(lambda k: translational_axes(r.jacobian(jnp.asarray(Q_CASE)), k, "full")[0])(jnp.asarray(KJ_CASE))
    assert bool(jnp.all(jnp.isfinite(g)))


@pytest.mark.parametrize("where", ["regular", "floor", "sphere"])
def test_stiffness_jvp_matches_finite_differences(where):
    """The JVP of K_T (Daleckii-Krein, floor included) against central differences of C -> K_T:
    at a regular posture, where the floor acts (an eigenvalue of S 3x the floor ``a``; at exactly
    zero the differences would need steps far below ``a`` and drown in rounding), and at S = I."""
    from jaxstiff.stiffness._schur import stiffness_of_compliance

    rng = np.random.default_rng(7)
    if where == "regular":
        J = np.asarray(lwr(False).jacobian(jnp.asarray(Q_CASE + 0.3)))
        C = (J / KJ_CASE) @ J.T
    else:
        R, _ = np.linalg.qr(rng.normal(size=(3, 3)))
        C = R @ np.diag([1.0, 2.0, 3e-8 if where == "floor" else 2.0]) @ R.T
    dC = rng.normal(size=C.shape)
    dC = dC + dC.T
    _, dK = jax.jvp(stiffness_of_compliance, (jnp.asarray(C),), (jnp.asarray(dC),))
    h = {"regular": 1e-7, "floor": 1e-12, "sphere": 1e-6}[where] * np.abs(C).max()
    fd = (np.asarray(stiffness_of_compliance(jnp.asarray(C + h * dC))) - np.asarray(stiffness_of_compliance(jnp.asarray(C - h * dC)))) / (2 * h)  # fmt: skip
    scale = np.abs(fd).max()
    assert np.all(np.isfinite(np.asarray(dK)))
    assert_close(np.asarray(dK) / scale, fd / scale, rtol=0, atol=1e-5, what=where)
