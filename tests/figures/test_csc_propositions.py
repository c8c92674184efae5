"""The numpy helpers of experiments/csc_propositions.py against closed forms and invariants.

The experiment is a plain script (not part of the package); it is loaded from its file.
"""

from __future__ import annotations

import os
import sys

import numpy as np
import pytest
from helpers import load_script

HERE = os.path.dirname(os.path.abspath(__file__))
EXPERIMENTS = os.path.join(os.path.dirname(os.path.dirname(HERE)), "experiments")


@pytest.fixture(scope="module")
def props():
    sys.path.insert(0, EXPERIMENTS)  # the script imports csc_cases from its own folder
    try:
        yield load_script("experiments/csc_propositions.py")
    finally:
        sys.path.remove(EXPERIMENTS)


def _k_rot(angle_deg: float, diag) -> np.ndarray:
    c, s = np.cos(np.radians(angle_deg)), np.sin(np.radians(angle_deg))
    R = np.array([[c, -s], [s, c]])
    return R @ np.diag(diag) @ R.T


def test_trace_identity_and_u(props):
    """tr(K K_C^-1) = number of joints (no clipping), u by its definition, K_C by a plain inverse."""
    rng = np.random.default_rng(3)
    K = _k_rot(30.0, [3000.0, 1000.0])
    J = rng.normal(size=(5, 2, 4))
    u, KC, tr, kj = props.realised(J, K)
    assert np.all(kj > 1.0)
    np.testing.assert_allclose(tr, 4.0, rtol=1e-12)
    A = J[0].T @ K @ J[0]
    want_u = np.sqrt(sum(A[i, j] ** 2 for i in range(4) for j in range(i + 1, 4)))
    np.testing.assert_allclose(u[0], want_u, rtol=1e-12)
    C = sum(np.outer(J[0][:, i], J[0][:, i]) / A[i, i] for i in range(4))
    np.testing.assert_allclose(KC[0], np.linalg.inv(C), rtol=1e-10)


def test_exact_match_needs_n_equal_m(props):
    """Two columns with K^(1/2) j_1 orthogonal to K^(1/2) j_2 realise K exactly; a third column breaks it."""
    K = _k_rot(30.0, [3000.0, 1000.0])
    w, V = np.linalg.eigh(K)
    Kmh = V @ np.diag(w**-0.5) @ V.T
    J2 = Kmh @ np.eye(2)  # K^(1/2) J2 = I: orthonormal
    _, KC, tr, _ = props.realised(J2, K)
    np.testing.assert_allclose(KC, K, rtol=1e-10)
    assert tr == pytest.approx(2.0)
    J3 = np.hstack([J2, Kmh @ np.array([[0.6], [0.8]])])
    _, KC3, tr3, _ = props.realised(J3, K)
    assert tr3 == pytest.approx(3.0)
    assert np.linalg.norm(K - KC3) / np.linalg.norm(K) > 0.1


def test_aligned_floor_closed_form(props):
    """m = 2, n' = 3, K ~ diag(3000, 1000): the grid against scipy's bounded scalar minimiser, and mu = (1, 2)
    (1000 (1 - 1/2) = 500 N/m) as an upper bound."""
    from scipy.optimize import minimize_scalar

    K = _k_rot(30.0, [3000.0, 1000.0])
    r = minimize_scalar(
        lambda m: 3000.0**2 * (1 - 1 / m) ** 2 + 1000.0**2 * (1 - 1 / (3 - m)) ** 2,
        bounds=(0.5, 2.5),
        method="bounded",
        options={"xatol": 1e-10},
    )
    floor = props.aligned_floor(K, 3)
    assert floor == pytest.approx(np.sqrt(r.fun) / np.linalg.norm(K), rel=1e-5)
    assert floor <= 500.0 / np.linalg.norm(K)
    assert props.aligned_floor(K, 2) == pytest.approx(0.0, abs=1e-6)  # n' = m: an exact match is possible
    # isotropic 3x3, n' = 6: at most (1 - 1/2) |K|_F (every mu = 2), and above 0
    assert 0.0 < props.aligned_floor(np.eye(3) * 1000.0, 6) <= 0.5 + 1e-9


def test_spearman(props):
    a = np.arange(10.0)
    assert props.spearman(a, a**3) == pytest.approx(1.0)
    assert props.spearman(a, -np.exp(a)) == pytest.approx(-1.0)
