"""Criteria f1, f2 (seed 000 S0-9, S0-15), frobenius (S1-10), offdiag (S1-19) against references.

References: matrices built from a chosen orientation error alpha and axis ratio rho (so the
criteria's closed forms are known); a numpy re-implementation (``numpy.linalg.eigh`` + ``acos``);
hand-computed joint stiffnesses; central finite differences of the whole pipeline
q, kj -> FK/Jacobian -> K_T -> f.
"""

from __future__ import annotations

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from helpers import assert_close, central_diff, robot_by_name
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import jaxstiff
from jaxstiff.stiffness._criteria import CRITERIA, alpha_and_ratio

RNG = np.random.default_rng(99)
N = 64


def k_from_alpha_rho(alpha_deg, rho, lam2=100.0, phi_deg=30.0):
    """2x2 K whose major axis makes alpha with d = (cos phi, sin phi), axis ratio rho."""
    th = np.radians(phi_deg + np.asarray(alpha_deg))
    c, s = np.cos(th), np.sin(th)
    R = np.stack([np.stack([c, -s], -1), np.stack([s, c], -1)], -2)
    lams = np.stack([rho * lam2 * np.ones_like(th), lam2 * np.ones_like(th)], -1)
    K = (R * lams[..., None, :]) @ np.swapaxes(R, -1, -2)
    d = np.array([math.cos(math.radians(phi_deg)), math.sin(math.radians(phi_deg))])
    return K, np.broadcast_to(d, K.shape[:-1])


def numpy_f(name, K, d, r, c=0.01):
    w, V = np.linalg.eigh(K)
    v1 = V[..., :, -1]
    dn = d / np.linalg.norm(d, axis=-1, keepdims=True)
    alpha = np.degrees(np.arccos(np.clip(np.abs(np.sum(v1 * dn, -1)), 0.0, 1.0)))
    rho = w[..., -1] / w[..., -2]
    if name == "f1":
        return (np.abs(alpha) + c) / (np.minimum(rho, r) / r)
    return (1 + np.abs(alpha)) * (1 + np.abs(r - rho))


@pytest.mark.parametrize("name", ["f1", "f2"])
@pytest.mark.parametrize("m", [2, 3])
def test_criteria_match_numpy_reimplementation(name, m):
    A = RNG.normal(size=(N, m, m + 1))
    K = A @ np.swapaxes(A, -1, -2) * 1e3
    d = RNG.normal(size=(N, m))
    f = np.asarray(getattr(jaxstiff, name)(jnp.asarray(K), jnp.asarray(d), 5.0))
    ref = numpy_f(name, K, d, 5.0)
    assert_close(f, ref, rtol=1e-7, atol=1e-7)  # acos in the reference limits its accuracy


def test_constructed_alpha_and_ratio():
    alpha = np.array([0.0, 1e-4, 3.0, 45.0, 89.0, 90.0])
    rho = np.array([1.5, 2.0, 5.0, 5.0, 7.0, 20.0])
    K, d = k_from_alpha_rho(alpha, rho)
    a, r = alpha_and_ratio(jnp.asarray(K), jnp.asarray(d))
    assert_close(a, alpha, atol=1e-9)
    assert_close(r, rho, rtol=1e-12)


def test_f1_constant_on_its_minimum_set():
    """alpha = 0 and any rho >= r: f1 = c (S0-9); anywhere else f1 > c."""
    r, c = 5.0, 0.01
    rho = np.array([5.0, 5.0 + 1e-9, 6.0, 10.0, 50.0, 1e4])
    K, d = k_from_alpha_rho(np.zeros_like(rho), rho)
    assert_close(jaxstiff.f1(jnp.asarray(K), jnp.asarray(d), r, c=c), np.full(rho.shape, c), rtol=1e-9)
    # on a grid over alpha x rho the minimum value c is reached exactly on that set
    A, P = np.meshgrid(np.linspace(0, 90, 91), np.arange(11, 101) / 10.0, indexing="ij")  # rho > 1: alpha defined
    K, d = k_from_alpha_rho(A, P)
    f = np.asarray(jaxstiff.f1(jnp.asarray(K), jnp.asarray(d), r, c=c))
    on_set = (A == 0) & (P >= r)
    assert np.all(np.abs(f[on_set] - c) < 1e-9)
    assert np.all(f[~on_set] > c + 1e-6)
    assert_close(f, (A + c) / (np.minimum(P, r) / r), rtol=1e-7, atol=1e-8)


def test_f2_unique_minimum_at_alpha0_rho_r():
    r = 5.0
    A, P = np.meshgrid(np.linspace(0, 90, 91), np.arange(11, 101) / 10.0, indexing="ij")  # rho > 1: alpha defined
    K, d = k_from_alpha_rho(A, P)
    f = np.asarray(jaxstiff.f2(jnp.asarray(K), jnp.asarray(d), r))
    i, j = np.unravel_index(np.argmin(f), f.shape)
    assert A[i, j] == 0.0 and P[i, j] == r
    assert_close(f[i, j], 1.0, atol=1e-9)
    mask = np.ones_like(f, bool)
    mask[i, j] = False
    assert np.all(f[mask] > 1.0 + 1e-6), "the minimum is unique"
    assert_close(f, (1 + A) * (1 + np.abs(r - P)), rtol=1e-7, atol=1e-8)
    # and exactly at a constructed K with alpha = 0, rho = r (3-D too)
    Q = np.linalg.qr(RNG.normal(size=(3, 3)))[0]
    K3 = Q @ np.diag([5 * 40.0, 40.0, 13.0]) @ Q.T
    assert_close(jaxstiff.f2(jnp.asarray(K3), jnp.asarray(-Q[:, 0]), r), 1.0, atol=1e-9)


def test_offdiag_hand_computation():
    # J^T K J = [[1, 0], [2, 1]] diag(2, 3) [[1, 2], [0, 1]] = [[2, 4], [4, 11]] -> u = 4
    J = jnp.array([[1.0, 2.0], [0.0, 1.0]])
    assert_close(jaxstiff.offdiag(J, jnp.diag(jnp.array([2.0, 3.0]))), 4.0, rtol=1e-15)
    # 2x3: J^T K J with J = [[1, 0, 1], [0, 1, 1]], K = [[2, 1], [1, 3]]:
    # = [[2, 1, 3], [1, 3, 4], [3, 4, 7]] -> u = sqrt(1 + 9 + 16)
    J = jnp.array([[1.0, 0.0, 1.0], [0.0, 1.0, 1.0]])
    K = jnp.array([[2.0, 1.0], [1.0, 3.0]])
    assert_close(jaxstiff.offdiag(J, K), math.sqrt(26.0), rtol=1e-15)
    # diagonal joint stiffness -> u = 0 with a finite gradient
    J = jnp.eye(3)
    assert float(jaxstiff.offdiag(J, jnp.diag(jnp.array([1.0, 2.0, 3.0])))) == 0.0
    g = jax.grad(lambda x: jaxstiff.offdiag(x, jnp.diag(jnp.array([1.0, 2.0, 3.0]))))(J)
    assert bool(jnp.all(jnp.isfinite(g)))
    # batched: broadcast one K over a batch of J
    Jb = jnp.asarray(RNG.normal(size=(5, 2, 4)))
    ref = [
        np.sqrt(sum((Jn.T @ np.asarray(K) @ Jn)[i, j] ** 2 for i in range(4) for j in range(i + 1, 4)))
        for Jn in np.asarray(Jb)
    ]
    assert_close(jaxstiff.offdiag(Jb, K), np.array(ref), rtol=1e-13)


def test_frobenius():
    K = RNG.normal(size=(4, 3, 3))
    Kd = RNG.normal(size=(3, 3))
    assert_close(jaxstiff.frobenius(jnp.asarray(K), jnp.asarray(Kd)), np.linalg.norm(Kd - K, axis=(-2, -1)), rtol=1e-14)
    g = jax.grad(lambda k: jaxstiff.frobenius(k, jnp.asarray(Kd)))(jnp.asarray(Kd))
    assert bool(jnp.all(jnp.isfinite(g))) and float(jnp.max(jnp.abs(g))) == 0.0


# ------------------------------------------------------------------ gradients
@jax.jit
def _f1_f2_grad_K(K, d, r, w):
    """Gradient w.r.t. K of ``w[0] f1 + w[1] f2`` (one compilation per shape serves both)."""
    return jax.grad(lambda k: w[0] * jaxstiff.f1(k, d, r) + w[1] * jaxstiff.f2(k, d, r))(K)


@pytest.mark.slow
@pytest.mark.parametrize("m", [2, 3])
def test_gradient_wrt_K_vs_finite_differences(m):
    rng = np.random.default_rng(5 + m)
    for name, w in (("f1", np.array([1.0, 0.0])), ("f2", np.array([0.0, 1.0]))):
        fn = getattr(jaxstiff, name)
        for _ in range(3):
            A = rng.normal(size=(m, m + 1))
            K = A @ A.T * 100.0 + np.eye(m) * 10.0
            d = rng.normal(size=m)
            r = 1.2 if name == "f1" else 5.0  # f1 with r below rho: away from the min(rho, r) kink
            g = np.asarray(_f1_f2_grad_K(jnp.asarray(K), jnp.asarray(d), r, jnp.asarray(w)))
            f = lambda x, fn=fn, d=d, r=r: np.asarray(  # noqa: E731
                fn(jnp.asarray(0.5 * (x + x.reshape(m, m).T.ravel())).reshape(m, m), jnp.asarray(d), r)
            )
            fd = central_diff(f, K.ravel(), h=1e-5).reshape(m, m)
            assert_close(0.5 * (g + g.T), fd, rtol=1e-5, atol=1e-7, what=name)


_PIPELINES: dict = {}


def pipeline(rname: str, task: str):
    """``vg(q, kj, d, r, w) -> (f, (df/dq, df/dkj))`` with ``f = w[0] f1 + w[1] f2`` through
    FK/Jacobian/K_T: one compilation per robot and task serves both criteria (w = (1, 0) or (0, 1))."""
    key = (rname, task)
    if key not in _PIPELINES:
        rb = robot_by_name(rname)

        def f(q, kj, d, r, w):
            K = jaxstiff.translational_stiffness(jaxstiff.jacobian(rb, q), kj, task)
            return w[0] * jaxstiff.f1(K, d, r) + w[1] * jaxstiff.f2(K, d, r)

        _PIPELINES[key] = jax.jit(jax.value_and_grad(f, argnums=(0, 1)))
    return _PIPELINES[key]


WEIGHTS = {"f1": jnp.array([1.0, 0.0]), "f2": jnp.array([0.0, 1.0])}


# LWR "xyz" shares all of this but the task rows; its singular postures are covered in test_stiffness
PIPE_CASES = [("kuka_lwr4", "full"), ("planar_3r", "xy")]


@pytest.mark.slow
@pytest.mark.parametrize("rname,task", PIPE_CASES)
def test_gradient_wrt_q_and_kj_vs_finite_differences(rname, task):
    rb = robot_by_name(rname)
    m = 2 if task == "xy" else 3
    rng = np.random.default_rng(11)
    vg = pipeline(rname, task)
    for name, r in [("f1", 1.05), ("f2", 5.0)]:
        w = WEIGHTS[name]
        checked = 0
        for _ in range(8):
            d = jnp.asarray(rng.normal(size=m))
            q = rng.uniform(np.asarray(rb.lower) * 0.8, np.asarray(rb.upper) * 0.8)
            kj = rng.uniform(5.0, 95.0, size=rb.n)
            K = np.asarray(jaxstiff.translational_stiffness(rb.jacobian(jnp.asarray(q)), jnp.asarray(kj), task))
            lam = np.linalg.eigvalsh(K)
            cond_c = float(jaxstiff.compliance_condition(rb.jacobian(jnp.asarray(q)), jnp.asarray(kj), task))
            if cond_c > 1e4 or lam[-1] / lam[-2] < 1.2 or (name == "f1" and lam[-1] / lam[-2] < 1.1 * r):
                continue  # smooth, well-conditioned points only: finite differences lose ~eps*cond/h there
            _, (gq, gk) = vg(jnp.asarray(q), jnp.asarray(kj), d, r, w)
            gq, gk = np.asarray(gq), np.asarray(gk)

            def f(qq, kk):
                return np.asarray(vg(jnp.asarray(qq), jnp.asarray(kk), d, r, w)[0])  # noqa: B023  (called in this iteration)

            fq = central_diff(lambda x: f(x, kj), q, h=1e-6)[0]  # noqa: B023  (called in this iteration)
            fk = central_diff(lambda x: f(q, x), kj, h=1e-5)[0]  # noqa: B023  (called in this iteration)
            scale_q = np.abs(fq).max() + 1e-9
            scale_k = np.abs(fk).max() + 1e-12
            assert_close(gq / scale_q, fq / scale_q, rtol=0, atol=1e-5, what=f"d {name} / d q")
            assert_close(gk / scale_k, fk / scale_k, rtol=0, atol=1e-5, what=f"d {name} / d kj")
            checked += 1
            if checked == 2:
                break
        assert checked >= 2, name


SINGULAR = [
    ("kuka_lwr4", np.zeros(7), "full", np.array([1.0, 0.0, 0.0])),
    ("kuka_lwr4", np.array([0.3, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]), "full", np.array([0.0, 0.0, 1.0])),
    (
        "kuka_lwr4",
        np.array([0.0, 0.5, 0.0, 0.0, 0.0, 0.0, 0.0]),
        "full",
        np.array([1.0, 1.0, 0.0]),
    ),  # lower arm stretched
    ("planar_3r", np.zeros(3), "xy", np.array([1.0, 0.0])),
    ("planar_3r", np.zeros(3), "xy", np.array([0.0, 1.0])),
    ("planar_3r", np.array([0.7, 0.0, 0.0]), "xy", np.array([1.0, 1.0])),
]


@pytest.mark.parametrize("rname,q,task,d", SINGULAR)
def test_values_and_gradients_finite_at_singular_postures(rname, q, task, d):
    rb = robot_by_name(rname)
    vg = pipeline(rname, task)
    for kj in (np.full(rb.n, 1.0), np.full(rb.n, 100.0), np.linspace(1.0, 100.0, rb.n)):  # kj at its bounds
        for r in (1.0, 5.0):
            for name, w in WEIGHTS.items():
                val, (gq, gk) = vg(jnp.asarray(q), jnp.asarray(kj), jnp.asarray(d), r, w)
                for x in (val, gq, gk):
                    assert bool(jnp.all(jnp.isfinite(x))), (name, kj, r)


@pytest.mark.parametrize("m", [2, 3])
def test_gradients_finite_at_spheres_and_repeated_axes(m):
    d = jnp.asarray(np.arange(1.0, m + 1.0))
    mats = [np.eye(m) * 7.0]
    if m == 3:
        Q = np.linalg.qr(RNG.normal(size=(3, 3)))[0]
        mats += [Q @ np.diag([9.0, 2.0, 2.0]) @ Q.T, Q @ np.diag([9.0, 9.0, 2.0]) @ Q.T]
    for K in mats:
        for name, w in (("f1", np.array([1.0, 0.0])), ("f2", np.array([0.0, 1.0]))):
            for r in (1.0, 5.0):  # r = 1: the kinks of min(rho, r) and |r - rho| sit at the sphere
                v = getattr(jaxstiff, name)(jnp.asarray(K), d, r)
                gK = _f1_f2_grad_K(jnp.asarray(K), d, r, jnp.asarray(w))
                assert bool(jnp.isfinite(v)) and bool(jnp.all(jnp.isfinite(gK))), (name, r, K)


def test_kinks_give_finite_gradients():
    # rho = r exactly (f1's min and f2's |r - rho|) and alpha = 0 exactly (|alpha|)
    K, d = k_from_alpha_rho(np.array(0.0), np.array(5.0))
    for name in ("f1", "f2"):
        g = jax.grad(lambda k: getattr(jaxstiff, name)(k, jnp.asarray(d), 5.0))(jnp.asarray(K))  # noqa: B023  (called in this iteration)
        assert bool(jnp.all(jnp.isfinite(g)))


@pytest.mark.parametrize("dtype", [jnp.float32, jnp.float64])
def test_dtype_kept(dtype):
    K, d = k_from_alpha_rho(RNG.uniform(1, 60, size=N), RNG.uniform(1.5, 8, size=N))  # (N, 2, 2) like above
    for name in ("f1", "f2"):
        v = getattr(jaxstiff, name)(jnp.asarray(K, dtype), jnp.asarray(d, dtype), 5.0)
        assert v.dtype == dtype
        assert_close(v, numpy_f(name, K, d, 5.0), rtol=1e-4 if dtype == jnp.float32 else 1e-7)
    assert jaxstiff.frobenius(jnp.asarray(K, dtype), jnp.asarray(K, dtype) * 2).dtype == dtype
    assert jaxstiff.offdiag(jnp.ones((2, 3), dtype), jnp.eye(2, dtype=dtype)).dtype == dtype
    if dtype == jnp.float32:  # gradients keep float32 too
        g = _f1_f2_grad_K(jnp.asarray(K[0], dtype), jnp.asarray(d[0], dtype), 5.0, jnp.asarray([0.5, 0.5], dtype))
        assert g.dtype == dtype and bool(jnp.all(jnp.isfinite(g)))


def test_vmap_and_jit():
    K, d = k_from_alpha_rho(RNG.uniform(0, 90, size=N), RNG.uniform(1, 8, size=N))
    a = jax.vmap(lambda k, dd: jaxstiff.f2(k, dd, 5.0))(jnp.asarray(K), jnp.asarray(d))
    b = jax.jit(lambda k, dd: jaxstiff.f2(k, dd, 5.0))(jnp.asarray(K), jnp.asarray(d))
    assert_close(a, b, rtol=1e-13)


def test_user_criteria_and_registry():
    def mine(K, d, r):  # no c parameter: get_criterion wraps it
        return jaxstiff.f2(K, d, r) + 1.0

    crit = jaxstiff.get_criterion(mine)
    assert jaxstiff.get_criterion(mine) is crit, "one wrapper per function (static-argument friendly)"
    K, d = k_from_alpha_rho(np.array(0.0), np.array(5.0))
    assert_close(crit(jnp.asarray(K), jnp.asarray(d), 5.0, c=0.3), 2.0, atol=1e-9)
    jaxstiff.register_criterion("_test_mine", mine, overwrite=True)
    try:
        assert_close(jaxstiff.get_criterion("_test_mine")(jnp.asarray(K), jnp.asarray(d), 5.0, c=0.01), 2.0, atol=1e-9)
        with pytest.raises(ValueError, match="already registered"):
            jaxstiff.register_criterion("_test_mine", mine)
        # a registered criterion is jit-able and differentiable like the built-ins
        g = jax.grad(lambda k: jaxstiff.get_criterion("_test_mine")(k, jnp.asarray(d), 5.0))(jnp.asarray(K))
        assert bool(jnp.all(jnp.isfinite(g)))
    finally:
        CRITERIA.pop("_test_mine", None)
    with pytest.raises(ValueError, match="built in"):
        jaxstiff.register_criterion("f1", mine)
    with pytest.raises(ValueError, match="unknown criterion 'f3'"):
        jaxstiff.get_criterion("f3")
    with pytest.raises(ValueError, match="must be callable"):
        jaxstiff.register_criterion("x", 3)


def test_bad_ratio_and_shapes():
    K = jnp.eye(2) * 3
    with pytest.raises(ValueError, match="ratio r must be finite and >= 1"):
        jaxstiff.f1(K, jnp.ones(2), 0.5)
    with pytest.raises(ValueError, match="ratio r must be finite and >= 1"):
        jaxstiff.f2(K, jnp.ones(2), 0.0)
    for f in (jaxstiff.f1, jaxstiff.f2):  # an infinite ratio gave inf (a tester's find)
        with pytest.raises(ValueError, match="ratio r must be finite and >= 1 .* got inf"):
            f(jnp.diag(jnp.array([4.0, 1.0])), jnp.array([1.0, 0.0]), float("inf"))
    with pytest.raises(ValueError, match="d must have shape"):
        jaxstiff.f2(K, jnp.ones(3), 5.0)
    with pytest.raises(ValueError, match="K_xd must have shape"):
        jaxstiff.offdiag(jnp.ones((2, 3)), jnp.eye(3))


def test_array_ratio_offset_and_batch_mismatches_are_named():
    """An array r is checked like a number (each entry >= 1, NaN refused, its batch against K's
    and d's), f1's offset c must be >= 0, and a d whose batch does not broadcast against K's is a
    ValueError naming both (these reached JAX as a broadcasting TypeError, or were accepted)."""
    K = jnp.stack([jnp.diag(jnp.array([5.0, 1.0]))] * 4)
    d = jnp.array([1.0, 0.0])
    for f in (jaxstiff.f1, jaxstiff.f2):
        with pytest.raises(ValueError, match=r"ratio r must be finite and >= 1 .* got 0.5 at index \(1,\)"):
            f(K, d, np.array([2.0, 0.5, 3.0, 4.0]))
        with pytest.raises(ValueError, match="ratio r must be finite and >= 1"):
            f(K, d, np.array([2.0, np.nan, 3.0, 4.0]))
        with pytest.raises(ValueError, match=r"batch axes do not broadcast: K \(4,\), d \(\), r \(3,\)"):
            f(K, d, jnp.array([2.0, 3.0, 4.0]))
        with pytest.raises(ValueError, match=r"batch axes do not broadcast: K \(4,\), d \(3,\)"):
            f(K, jnp.ones((3, 2)), 2.0)
        with pytest.raises(ValueError, match="must be a number or an array of numbers"):
            f(K, d, "five")
    with pytest.raises(ValueError, match=r"batch axes do not broadcast: K \(4,\), d \(3,\)"):
        jaxstiff.orientation_error(K, jnp.ones((3, 2)))
    with pytest.raises(ValueError, match="offset c must be >= 0"):
        jaxstiff.f1(K, d, 2.0, c=-0.5)
    # valid arrays still work, and a traced r is not inspected (jit, grad)
    np.testing.assert_allclose(np.asarray(jaxstiff.f2(K, d, jnp.array([5.0, 5.0, 6.0, 5.0]))), [1.0, 1.0, 2.0, 1.0])
    np.testing.assert_allclose(float(jax.jit(lambda r: jaxstiff.f2(K[0], d, r))(6.0)), 2.0)
    np.testing.assert_allclose(float(jax.grad(lambda r: jaxstiff.f2(K[0], d, r))(6.0)), 1.0)


@st.composite
def criterion_inputs(draw):
    m = draw(st.sampled_from([2, 3]))
    shape = (3, 2)  # one shape per m: each new shape compiles anew (shapes are tested elsewhere)
    rng = np.random.default_rng(draw(st.integers(0, 2**31 - 1)))
    Q = np.linalg.qr(rng.normal(size=shape + (m, m)))[0]
    lams = 10.0 ** (draw(st.floats(0, 5)) + rng.uniform(0, draw(st.floats(0, 6)), size=shape + (m,)))
    if draw(st.booleans()):
        lams[..., 0] = lams[..., 1]  # a sphere (2-D) or a repeated axis
    K = (Q * lams[..., None, :]) @ np.swapaxes(Q, -1, -2)
    d = rng.normal(size=shape + (m,))
    r = draw(st.floats(1.0, 20.0))
    return K, d, r


@jax.jit
def _both_with_grads(K, d, r):
    out = []
    for fn in (jaxstiff.f1, jaxstiff.f2):
        v, g = jax.value_and_grad(lambda k: jnp.sum(fn(k, d, r)))(K)  # noqa: B023  (called in this iteration)
        out.append((fn(K, d, r), g))
    return out


@pytest.mark.slow
@settings(max_examples=20, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(criterion_inputs())
def test_property_bounds_and_finiteness(data):
    K, d, r = data
    (v1, g1), (v2, g2) = _both_with_grads(jnp.asarray(K), jnp.asarray(d), r)
    assert v1.shape == K.shape[:-2] and v2.shape == K.shape[:-2]
    assert bool(jnp.all(v1 >= 0.01 - 1e-12)) and bool(jnp.all(v2 >= 1.0 - 1e-12))
    for x in (v1, g1, v2, g2):
        assert bool(jnp.all(jnp.isfinite(x)))
    # against the numpy reference where the eigen-decomposition is well separated
    w = np.linalg.eigvalsh(K)
    sep = (w[..., -1] - w[..., -2]) > 1e-6 * w[..., -1]
    assert_close(np.asarray(v2)[sep], numpy_f("f2", K, d, r)[sep], rtol=1e-6, atol=1e-6)


def test_nan_in_gives_nan_out_and_integer_J_is_refused():
    """frobenius/offdiag of a NaN input were 0 (a NaN sum of squares failed 's > 0' and read as a
    perfect match); offdiag of an integer J cast K_xd to int ([[1.5, .4], [.4, .7]] -> [[1, 0], [0, 0]])."""
    nan = jnp.nan
    assert np.isnan(float(jaxstiff.frobenius(jnp.array([[nan, 0.0], [0.0, 1.0]]), jnp.eye(2))))
    assert np.isnan(float(jaxstiff.frobenius(jnp.eye(2), jnp.full((2, 2), nan))))
    assert np.isnan(float(jaxstiff.offdiag(jnp.array([[nan, 1.0, 0.0], [0.0, 1.0, 1.0]]), jnp.eye(2))))
    assert float(jaxstiff.frobenius(jnp.eye(2), jnp.eye(2))) == 0.0  # and 0 stays 0, with a zero gradient
    assert np.all(np.asarray(jax.grad(lambda K: jaxstiff.frobenius(K, jnp.eye(2)))(jnp.eye(2))) == 0.0)
    K = jnp.array([[1.5, 0.4], [0.4, 0.7]])
    with pytest.raises(ValueError, match="J must have a floating dtype"):
        jaxstiff.offdiag(np.array([[1, 0, 1], [0, 1, 1]]), K)
    J = np.array([[1.0, 0.0, 1.0], [0.0, 1.0, 1.0]])
    Kq = J.T @ np.asarray(K) @ J
    assert float(jaxstiff.offdiag(J, K)) == pytest.approx(np.sqrt(np.sum(np.triu(Kq, 1) ** 2)), rel=1e-14)


@pytest.mark.slow
def test_shape_mismatches_name_the_arguments():
    """Raw JAX errors (TypeError 'mul got incompatible shapes', 'axis -2 is out of bounds',
    IndexError) were what a wrong shape gave; now a ValueError naming the arguments and shapes."""
    r = jaxstiff.Robot.from_urdf("kuka_lwr4", locked={"lwr_a7": 0.0})
    J = jaxstiff.jacobian(r, jnp.full((2, 7), 0.3).at[:, 6].set(0.0))  # lwr_a7 at its locked value
    cases = [
        (
            lambda: jaxstiff.translational_stiffness(J, jnp.ones((3, 7))),
            r"batch axes do not broadcast: J \(2,\), kj \(3,\)",
        ),
        (
            lambda: jaxstiff.frobenius(jnp.eye(3), jnp.eye(2)),
            r"K \(3, 3\) and K_d \(2, 2\) must be matrices of the same size",
        ),
        (
            lambda: jaxstiff.frobenius(jnp.ones(3), jnp.ones(3)),
            r"K must be square matrices \(\.\.\., m, m\), got shape \(3,\)",
        ),
        (
            lambda: jaxstiff.frobenius(jnp.ones((2, 3, 3)), jnp.ones((3, 3, 3))),
            r"batch axes do not broadcast: K \(2,\), K_d \(3,\)",
        ),
        (
            lambda: jaxstiff.offdiag(jnp.ones(3), jnp.eye(3)),
            r"J must be a task-row Jacobian \(\.\.\., m, n\), got shape \(3,\)",
        ),
        (
            lambda: jaxstiff.offdiag(jnp.ones((2, 3, 7)), jnp.ones((3, 3, 3))),
            r"batch axes do not broadcast: J \(2,\), K_xd \(3,\)",
        ),
    ]
    for call, match in cases:
        with pytest.raises(ValueError, match=match):
            call()
    # broadcasting that is allowed still works
    assert jaxstiff.translational_stiffness(J, jnp.full(7, 50.0)).shape == (2, 3, 3)
    assert jaxstiff.frobenius(jnp.ones((2, 3, 3)), jnp.eye(3)).shape == (2,)


class _NoSignature:
    """A criterion whose signature Python cannot read, that takes c and depends on it."""

    __signature__ = "unreadable"  # inspect.signature raises TypeError

    def __call__(self, K, d, r, c=0.01):
        return jnp.trace(K) * 0.0 + c


def _takes_c(K, d, r, c=0.01):
    return jnp.trace(K) * 0.0 + 10.0 * c


def _no_c(K, d, r):
    return jnp.trace(K) * 0.0 + r


def _kwargs(K, d, r, **kw):
    return jnp.trace(K) * 0.0 + 100.0 * kw["c"]


@pytest.mark.parametrize(
    "fn,expected", [(_NoSignature(), 0.05), (_takes_c, 0.5), (_no_c, 3.0), (_kwargs, 5.0)], ids=lambda v: str(v)[:20]
)
def test_every_caller_passes_c_by_one_rule(fn, expected):
    """get_criterion's wrapper and the solvers' WaypointProblem decide alike whether a user's
    criterion gets c (a c parameter, **kwargs, or a signature Python cannot read: it is passed),
    so the value does not depend on which path called the criterion. The two rules differed for
    an unreadable signature: the solvers called it without c (its default 0.01, silently)."""
    from jaxstiff.solvers._problem import WaypointProblem
    from jaxstiff.stiffness._criteria import accepts_c, get_criterion

    K = jnp.eye(3) * 2.0
    d = jnp.array([1.0, 0.0, 0.0])
    assert accepts_c(fn) == (fn is not _no_c)
    via_registry = get_criterion(fn)(K, d, 3.0, c=0.05)
    robot = jaxstiff.Robot.from_urdf("planar_3r")
    via_solver = WaypointProblem(robot, "full", fn).criterion_value(K, d, 3.0, 0.05)
    np.testing.assert_allclose(float(via_registry), expected)  # at c = 0.05, r = 3
    np.testing.assert_allclose(float(via_solver), float(via_registry))
