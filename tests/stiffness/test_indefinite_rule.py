"""One rule for an indefinite K (issue 24, finding 5): f2 gave 8.0 and orientation_error 0.0 for a
matrix that ellipsoid() refused; now every public function that reads an ellipsoid from K refuses
it the same way (concrete K), while a traced K (inside jit) is not checked and a semi-definite K
passes."""

import jax
import numpy as np
import pytest

import jaxstiff
from jaxstiff.stiffness._criteria import alpha_and_ratio

INDEFINITE = np.diag([3.0, 1.0, -2.0])
D = np.array([1.0, 0.0, 0.0])
CALLS = {
    "ellipsoid": lambda K: jaxstiff.ellipsoid(K),
    "orientation_error": lambda K: jaxstiff.orientation_error(K, D),
    "f1": lambda K: jaxstiff.f1(K, D, 5.0),
    "f2": lambda K: jaxstiff.f2(K, D, 5.0),
    "alpha_and_ratio": lambda K: alpha_and_ratio(K, D),
}


@pytest.mark.parametrize("name", sorted(CALLS))
def test_indefinite_is_refused_everywhere(name):
    with pytest.raises(ValueError, match=r"K must be positive \(semi-\)definite .* eigenvalue -2"):
        CALLS[name](INDEFINITE)
    batch = np.stack([np.eye(3), INDEFINITE])
    with pytest.raises(ValueError, match=r"eigenvalue -2 at index \(1,\)"):
        CALLS[name](batch)


@pytest.mark.parametrize("name", sorted(CALLS))
def test_semidefinite_passes_and_traced_is_not_checked(name):
    c, s = np.cos(0.3), np.sin(0.3)
    R = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1.0]])
    psd = R @ np.diag([3000.0, 1000.0, 0.0]) @ R.T  # rounding-level negative eigenvalue
    CALLS[name](psd)
    jax.jit(lambda K: jax.tree_util.tree_leaves(CALLS[name](K))[0])(INDEFINITE)


@pytest.mark.parametrize("name", sorted(CALLS))
def test_a_non_symmetric_k_is_refused(name):
    # eigvalsh reads one triangle: [[1, -3], [0, 1]] looked like the identity, while the
    # computations read its symmetric part, eigenvalues 2.5 and -0.5 (f2 gave 4e17, f1 90); a
    # clearly non-symmetric K is refused by name (a tester's [[3, 2], [0, 3]] came out as the
    # ellipsoid of [[3, 1], [1, 3]] without a word); rounding-level asymmetry passes
    K = np.array([[1.0, -3.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
    with pytest.raises(
        ValueError, match=r"K must be symmetric \(a stiffness matrix\): \|K - K\^T\| is 3 at index \(0, 1\)"
    ):
        CALLS[name](K)
    nearly = np.diag([3.0, 2.0, 1.0])
    nearly[0, 1] = 1e-13
    CALLS[name](nearly)
