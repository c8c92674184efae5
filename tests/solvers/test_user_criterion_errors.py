"""A criterion of the user's own that cannot work is refused by name before any work (found by an
independent check: a matrix-valued criterion gave JAX's "Gradient only defined for scalar-output
functions", a two-argument one Python's "takes 2 positional arguments but 3 were given", and one
returning a Python number "'float' object is not subscriptable" from inside the report)."""

from __future__ import annotations

import warnings

import jax.numpy as jnp
import numpy as np
import pytest

import jaxstiff

ROBOT = jaxstiff.Robot.from_urdf("planar_3r")
PATH = jaxstiff.Path(np.c_[np.linspace(1.5, 1.52, 2), np.full(2, 0.5), np.zeros(2)])


def my_matrix(K, d, r):
    return K


def my_two_args(K, d):
    return jnp.trace(K)


@pytest.mark.parametrize(
    ("crit", "match"),
    [
        (my_matrix, r"criterion 'my_matrix' must return one real number per K \(shape \(2, 2\)"),
        (my_two_args, r"criterion 'my_two_args' failed on a 2x2 K \(TypeError: .*takes 2 positional"),
    ],
)
def test_a_criterion_that_cannot_work_is_refused_by_name(crit, match):
    with pytest.raises(ValueError, match=match):
        jaxstiff.shape(ROBOT, PATH, crit, 3.0, task="xy")


def test_a_criterion_returning_a_python_number_runs():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = jaxstiff.shape(ROBOT, PATH, lambda K, d, r: 1.0, 3.0, task="xy")
    np.testing.assert_array_equal(res.criterion, 1.0)
    assert np.all(res.status <= 2)
