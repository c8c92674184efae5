"""Ellipsoid decomposition and orientation error (SPEC section 3) against independent references.

References: ``numpy.linalg.eigh`` (LAPACK) on random, graded and nearly degenerate SPD matrices;
matrices built from chosen eigenvalues and rotations (closed forms for alpha, ratio, volume);
central finite differences for the custom JVP; ``acos`` in numpy for alpha.
"""

from __future__ import annotations

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from helpers import assert_close, central_diff
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import jaxstiff
from jaxstiff.stiffness._ellipsoid import alpha_rad, eigh_descending

RNG = np.random.default_rng(1234)
N = 64  # one batch size throughout: each new shape compiles anew


def random_rotation(rng, m, batch=()):
    Q, R = np.linalg.qr(rng.normal(size=batch + (m, m)))
    return Q * np.sign(np.diagonal(R, axis1=-2, axis2=-1))[..., None, :]


def spd_from(lams, Q):
    return (Q * np.asarray(lams)[..., None, :]) @ np.swapaxes(Q, -1, -2)


def random_spd(rng, m, batch=(), kind="rand"):
    if kind == "rand":
        A = rng.normal(size=batch + (m, m + 2))
        return A @ np.swapaxes(A, -1, -2)
    Q = random_rotation(rng, m, batch)
    if kind == "graded":
        lams = 10.0 ** rng.uniform(-10, 3, size=batch + (m,))
    elif kind == "near":  # clusters: eigenvalues equal up to 1e-14 ... 1e-3 relative
        base = rng.uniform(1, 10, size=batch + (1,))
        lams = base * (1 + 10.0 ** rng.uniform(-14, -3, size=batch + (m,)) * rng.integers(0, 2, size=batch + (m,)))
    else:
        raise ValueError(kind)
    return spd_from(lams, Q)


def check_against_numpy(K, w, V, rtol=1e-13):
    K, w, V = np.asarray(K), np.asarray(w), np.asarray(V)
    wn = np.linalg.eigh(K)[0][..., ::-1]
    scale = np.abs(wn).max(axis=-1, keepdims=True)
    assert np.all(np.isfinite(w)) and np.all(np.isfinite(V))
    assert np.all(np.abs(w - wn) <= rtol * scale), np.abs(w - wn).max()
    assert np.all(np.diff(w, axis=-1) <= 0), "eigenvalues not descending"
    m = K.shape[-1]
    assert_close(np.swapaxes(V, -1, -2) @ V, np.broadcast_to(np.eye(m), V.shape), atol=1e-13, what="orthonormal")
    resid = np.linalg.norm(K @ V - V * w[..., None, :], axis=-2) / scale
    assert resid.max() < 10 * rtol, resid.max()


@pytest.mark.parametrize("m", [2, 3])
@pytest.mark.parametrize("kind", ["rand", "graded", "near"])
def test_eigh_matches_numpy_batched(m, kind):
    K = random_spd(RNG, m, (N,), kind)
    w, V = jax.jit(eigh_descending)(jnp.asarray(K))
    assert w.dtype == V.dtype == jnp.float64
    check_against_numpy(K, w, V)
    # eigenvectors agree with LAPACK's up to sign where the eigenvalue is well separated
    wn, Vn = np.linalg.eigh(K)
    Vn = Vn[..., ::-1]
    wn = wn[..., ::-1]
    gaps = np.abs(np.diff(wn, axis=-1)) / np.abs(wn).max(-1, keepdims=True)
    sep = np.ones(wn.shape, bool)
    sep[..., :-1] &= gaps > 1e-3
    sep[..., 1:] &= gaps > 1e-3
    dots = np.abs(np.sum(np.asarray(V) * Vn, axis=-2))
    assert np.all(np.abs(dots[sep] - 1) < 1e-9)


@pytest.mark.parametrize("m", [2, 3])
def test_eigh_exact_degeneracies(m):
    for K in [np.eye(m) * 3.0, np.diag([2.0, 2.0, 1.0][:m]), np.diag([1.0, 2.0, 2.0][-m:]), np.zeros((m, m))]:
        w, V = eigh_descending(jnp.asarray(K))
        check_against_numpy(K, w, V) if K.any() else assert_close(w, np.zeros(m))


@pytest.mark.parametrize("shape", [(), (1,), (3, 1, 2)])
def test_ellipsoid_batch_shapes_and_closed_forms(shape):
    m = 3
    lams = np.sort(RNG.uniform(1, 100, size=shape + (m,)), axis=-1)[..., ::-1]
    Q = random_rotation(RNG, m, shape)
    e = jaxstiff.ellipsoid(jnp.asarray(spd_from(lams, Q)))
    assert e.axes.shape == shape + (3,) and e.directions.shape == shape + (3, 3)
    assert e.ratio.shape == shape and e.volume.shape == shape
    assert_close(e.axes, lams, rtol=1e-12)
    assert_close(e.ratio, lams[..., 0] / lams[..., 1], rtol=1e-12)
    assert_close(e.volume, np.prod(lams, axis=-1), rtol=1e-12)
    assert_close(np.abs(np.sum(np.asarray(e.major) * Q[..., :, 0], -1)), np.ones(shape), atol=1e-10)


def test_ellipsoid_is_a_pytree():
    K = jnp.asarray(random_spd(RNG, 2, (N,)))
    e = jax.jit(jaxstiff.ellipsoid)(K)
    e2 = jax.vmap(jaxstiff.ellipsoid)(K)
    assert isinstance(e, jaxstiff.Ellipsoid)
    for a, b in zip(jax.tree_util.tree_leaves(e), jax.tree_util.tree_leaves(e2), strict=True):
        assert_close(a, b, rtol=1e-14)


@pytest.mark.slow
@pytest.mark.parametrize("dtype", [jnp.float32])  # float64 in -> float64 out: checked in the tests above
def test_dtype_kept(dtype):
    K = jnp.asarray(random_spd(RNG, 3, (N,)), dtype=dtype)
    d = jnp.asarray(RNG.normal(size=(N, 3)), dtype=dtype)
    e = jaxstiff.ellipsoid(K)
    for leaf in jax.tree_util.tree_leaves(e):
        assert leaf.dtype == dtype
    a = jaxstiff.orientation_error(K, d)
    assert a.dtype == dtype
    g = jax.grad(lambda k: jnp.sum(jaxstiff.orientation_error(k, d)))(K)
    assert g.dtype == dtype and bool(jnp.all(jnp.isfinite(g)))
    if dtype == jnp.float32:  # float32 results agree with float64 ones to float32 precision
        e64 = jaxstiff.ellipsoid(jnp.asarray(K, jnp.float64))
        assert_close(e.axes, e64.axes, rtol=1e-5, atol=1e-5 * float(jnp.max(e64.axes)))


def numpy_alpha_deg(K, d):
    w, V = np.linalg.eigh(K)
    v1 = V[..., :, -1]
    dn = d / np.linalg.norm(d, axis=-1, keepdims=True)
    return np.degrees(np.arccos(np.clip(np.abs(np.sum(v1 * dn, -1)), 0, 1)))


@pytest.mark.parametrize("m", [2, 3])
def test_orientation_error_vs_acos_and_sign_invariance(m):
    K = random_spd(RNG, m, (N,))
    d = RNG.normal(size=(N, m))
    a = np.asarray(jaxstiff.orientation_error(jnp.asarray(K), jnp.asarray(d)))
    ref = numpy_alpha_deg(K, d)
    # acos loses accuracy near 0 deg; compare in sin/cos space there
    assert np.all((a >= 0) & (a <= 90))
    assert_close(np.sin(np.radians(a)), np.sin(np.radians(ref)), atol=1e-9)
    # sign of d
    assert_close(jaxstiff.orientation_error(jnp.asarray(K), jnp.asarray(-d)), a, atol=1e-12)
    assert_close(jaxstiff.orientation_error(jnp.asarray(K), jnp.asarray(3.7 * d)), a, atol=1e-12)
    # sign of the eigenvector
    _, V = eigh_descending(jnp.asarray(K))
    v1 = V[..., :, 0]
    a1 = np.degrees(np.asarray(alpha_rad(v1, jnp.asarray(d))))
    a2 = np.degrees(np.asarray(alpha_rad(-v1, jnp.asarray(d))))
    assert_close(a1, a2, atol=1e-12)
    assert_close(a1, a, atol=1e-12)


def test_orientation_error_constructed_2d():
    # K with major axis at angle theta, d at angle phi: alpha = distance of theta - phi to the nearest multiple of 180, in [0, 90]
    for theta, phi in [
        (10.0, 10.0),
        (10.0, 40.0),
        (80.0, -80.0),
        (0.0, 90.0),
        (30.0, 210.0),
        (179.0, 1.0),
        (45.0, 135.0),
    ]:
        t = math.radians(theta)
        R = np.array([[math.cos(t), -math.sin(t)], [math.sin(t), math.cos(t)]])
        K = R @ np.diag([7.0, 2.0]) @ R.T
        d = np.array([math.cos(math.radians(phi)), math.sin(math.radians(phi))])
        diff = (theta - phi) % 180.0
        expected = min(diff, 180.0 - diff)
        assert_close(
            jaxstiff.orientation_error(jnp.asarray(K), jnp.asarray(d)), expected, atol=1e-10, what=f"{theta}, {phi}"
        )


def test_orientation_error_small_angles_are_accurate():
    # acos(cos(1e-7 rad)) = 0 in float64; the atan2 form keeps small angles
    for eps in [1e-3, 1e-6, 1e-9]:
        K = np.diag([5.0, 1.0])
        d = np.array([math.cos(eps), math.sin(eps)])
        assert_close(jaxstiff.orientation_error(jnp.asarray(K), jnp.asarray(d)), math.degrees(eps), rtol=1e-9)


@pytest.mark.slow
def test_zero_direction_gives_zero_alpha_and_finite_gradient():
    K = jnp.asarray(random_spd(RNG, 3))
    d = jnp.zeros(3)
    assert float(jaxstiff.orientation_error(K, d)) == 0.0
    for g in _grads_of_everything(K, d):
        assert bool(jnp.all(jnp.isfinite(g)))


@pytest.mark.parametrize("m", [2, 3])
def test_jvp_matches_finite_differences(m):
    rng = np.random.default_rng(7)
    for _ in range(5):
        K = random_spd(rng, m)
        dK = rng.normal(size=(m, m))
        dK = dK + dK.T
        (w, V), (dw, dV) = jax.jvp(eigh_descending, (jnp.asarray(K),), (jnp.asarray(dK),))
        h = 1e-6
        wp, Vp = eigh_descending(jnp.asarray(K + h * dK))
        wm, Vm = eigh_descending(jnp.asarray(K - h * dK))
        # fix eigenvector signs to the unperturbed ones
        Vp = np.asarray(Vp) * np.sign(np.sum(np.asarray(Vp) * np.asarray(V), axis=-2))
        Vm = np.asarray(Vm) * np.sign(np.sum(np.asarray(Vm) * np.asarray(V), axis=-2))
        assert_close(dw, (np.asarray(wp) - np.asarray(wm)) / (2 * h), rtol=1e-6, atol=1e-7)
        assert_close(dV, (Vp - Vm) / (2 * h), rtol=1e-5, atol=1e-6)


def _grads(fn, K):
    return jax.grad(fn)(jnp.asarray(K))


@jax.jit
def _grads_of_everything(K, d):
    """Gradients w.r.t. K of alpha, rho, the volume and the directions (one compilation per shape)."""
    fns = (
        lambda k: jaxstiff.orientation_error(k, d),
        lambda k: jaxstiff.ellipsoid(k).ratio,
        lambda k: jaxstiff.ellipsoid(k).volume,
        lambda k: jnp.sum(jaxstiff.ellipsoid(k).directions),
    )
    return [jax.grad(f)(K) for f in fns]


@pytest.mark.parametrize("m", [2, 3])
def test_gradients_finite_at_spheres(m):
    d = jnp.asarray(np.ones(m))
    for K in [np.eye(m) * 4.0, np.eye(m) * 4.0 + 1e-14 * np.diag(np.arange(m))]:
        for g in _grads_of_everything(jnp.asarray(K), d):
            assert bool(jnp.all(jnp.isfinite(g)))
    # the volume's gradient is exact at the sphere: d det(K) / dK = cof(K) = 4^(m-1) I
    g_vol = _grads_of_everything(jnp.asarray(np.eye(m) * 4.0), d)[2]
    assert_close(g_vol, np.eye(m) * 4.0 ** (m - 1), rtol=1e-12)


def test_alpha_gradient_exact_when_lambda2_equals_lambda3():
    # v1 is well defined (lambda1 > lambda2 = lambda3): the gradient of alpha must be exact
    Q = random_rotation(np.random.default_rng(3), 3)
    K = spd_from([9.0, 2.0, 2.0], Q)
    d = np.array([0.3, -0.5, 0.8])
    fn = lambda k: jaxstiff.orientation_error(k, jnp.asarray(d))  # noqa: E731
    g = np.asarray(_grads(fn, K))
    fd = central_diff(lambda x: np.asarray(fn(jnp.asarray(x.reshape(3, 3)))), K.ravel(), h=1e-6).reshape(3, 3)
    # the gradient w.r.t. a symmetric matrix is defined up to its antisymmetric part: compare symmetric parts
    assert_close(0.5 * (g + g.T), 0.5 * (fd + fd.T), rtol=1e-6, atol=1e-8)


def test_bad_inputs_raise_clear_errors():
    with pytest.raises(ValueError, match=r"\(\.\.\., 2, 2\) or \(\.\.\., 3, 3\)"):
        jaxstiff.ellipsoid(jnp.eye(4))
    with pytest.raises(ValueError, match="floating"):
        jaxstiff.ellipsoid(jnp.eye(3, dtype=jnp.int32))
    with pytest.raises(ValueError, match="d must have shape"):
        jaxstiff.orientation_error(jnp.eye(3), jnp.ones(2))


@st.composite
def spd_batches(draw):
    m = draw(st.sampled_from([2, 3]))
    shape = (2, 3)  # one shape per m: each new shape compiles anew (shapes are tested above)
    seed = draw(st.integers(0, 2**31 - 1))
    rng = np.random.default_rng(seed)
    log_scale = draw(st.floats(-3, 6))
    cond = draw(st.floats(0, 8))
    lams = 10.0 ** (log_scale + rng.uniform(0, cond, size=shape + (m,)))
    if draw(st.booleans()):  # force a repeated eigenvalue
        lams[..., 1] = lams[..., 0]
    return (
        spd_from(lams, random_rotation(rng, m, shape)),
        np.sort(lams, axis=-1)[..., ::-1],
        rng.normal(size=shape + (m,)),
    )


@jax.jit
def _ellipsoid_alpha_grad(K, d):
    e = jaxstiff.ellipsoid(K)
    a = jaxstiff.orientation_error(K, d)
    g = jax.grad(lambda k: jnp.sum(jaxstiff.orientation_error(k, d) + jaxstiff.ellipsoid(k).ratio))(K)
    return e, a, g


@pytest.mark.slow
@settings(max_examples=20, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(spd_batches())
def test_property_axes_ratio_volume_alpha(data):
    K, lams, d = data
    e, a, g = _ellipsoid_alpha_grad(jnp.asarray(K), jnp.asarray(d))
    assert_close(e.axes, lams, rtol=1e-11, atol=1e-12 * lams.max())
    # lambda_i is known to ~eps * lambda1 (absolute): relative errors grow with the condition number
    cond = lams.max() / lams.min()
    assert_close(e.ratio, lams[..., 0] / lams[..., 1], rtol=1e-12 + 1e-14 * cond)
    assert_close(e.volume, np.prod(lams, -1), rtol=1e-12 + 1e-14 * cond)
    assert a.shape == K.shape[:-2] and bool(jnp.all((a >= 0) & (a <= 90)))
    assert bool(jnp.all(jnp.isfinite(g)))


def test_plot_ellipse_points_lie_on_the_stiffness_ellipse():
    from jaxstiff import plots  # numpy only; matplotlib is imported by the figure functions

    K = random_spd(RNG, 2)
    pts = plots.ellipse_points(K)
    # x = V diag(lambda) u with |u| = 1  <=>  x^T K^-2 x = 1
    Kinv = np.linalg.inv(K)
    assert_close(np.einsum("ni,ij,nj->n", pts, Kinv @ Kinv, pts), np.ones(len(pts)), rtol=1e-12)
    assert_close(np.linalg.norm(pts, axis=1).max(), np.linalg.eigvalsh(K).max(), rtol=1e-3)


@pytest.mark.parametrize("bad", [np.nan, np.inf])
def test_non_finite_stiffness_gives_nan_not_a_perfect_score(bad):
    """A NaN/Inf entry used to stop the Jacobi rotations and report the coordinate axes: ratio 1,
    alpha 0 and finite f1/f2, i.e. a NaN looked like a solved waypoint."""
    K = np.diag([3.0, 2.0, 1.0])
    K[0, 1] = K[1, 0] = bad
    e = jaxstiff.ellipsoid(jnp.asarray(K))
    assert np.isnan(float(e.ratio)) and np.all(np.isnan(np.asarray(e.axes)))
    d = jnp.array([1.0, 0.0, 0.0])
    for value in (
        jaxstiff.orientation_error(jnp.asarray(K), d),
        jaxstiff.f1(jnp.asarray(K), d, 3.0),
        jaxstiff.f2(jnp.asarray(K), d, 3.0),
    ):
        assert np.isnan(float(value))
    both = jaxstiff.ellipsoid(jnp.stack([jnp.asarray(K), jnp.eye(3)]))  # the finite one is unaffected
    assert np.isnan(float(both.ratio[0])) and float(both.ratio[1]) == 1.0


def test_indefinite_stiffness_is_refused():
    with pytest.raises(ValueError, match=r"positive \(semi-\)definite .* eigenvalue -2"):
        jaxstiff.ellipsoid(-np.diag([1.0, 2.0]))
    with pytest.raises(ValueError, match=r"eigenvalue -1 at index \(1,\)"):
        jaxstiff.ellipsoid(np.stack([np.eye(3), np.diag([2.0, 1.0, -1.0])]))
    assert float(jaxstiff.ellipsoid(np.diag([4.0, 0.0])).ratio) > 1e6  # singular but not indefinite: allowed
    c, s = math.cos(0.3), math.sin(0.3)
    R = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1.0]]) @ np.array([[1, 0, 0], [0, c, -s], [0, s, c]])
    K = R @ np.diag([3000.0, 1000.0, 0.0]) @ R.T  # PSD with rounding-level negative eigenvalues
    assert np.linalg.eigvalsh(K)[0] <= 1e-12 and abs(float(jaxstiff.ellipsoid(K).ratio) - 3.0) < 1e-9


@pytest.mark.parametrize("dtype", [np.float64, np.float32])
def test_singular_ratio_is_the_documented_cap(dtype):
    """A singular K has no finite ratio; the documented value is 1/eps of its dtype (finite value
    and gradient), and K = 0 (no direction at all) reads 1."""
    with jax.enable_x64(dtype == np.float64):
        e = jaxstiff.ellipsoid(jnp.asarray(np.diag([2.0, 0.0]), dtype))
        assert float(e.ratio) == pytest.approx(1.0 / float(np.finfo(dtype).eps), rel=1e-12)
        g = jax.grad(lambda k: jaxstiff.ellipsoid(jnp.diag(k)).ratio)(jnp.asarray([2.0, 0.0], dtype))
        assert np.all(np.isfinite(np.asarray(g)))
        assert float(jaxstiff.ellipsoid(jnp.zeros((3, 3), dtype)).ratio) == 1.0
