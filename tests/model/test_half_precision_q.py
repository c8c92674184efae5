"""float16 joint values were accepted silently by Robot.fk/jacobian (FK off by 0.9 mm): refused,
naming the argument, by the same rule as shape and csc_rollout (jaxstiff.runtime._dtypes)."""

import numpy as np
import pytest

import jaxstiff


@pytest.mark.parametrize("method", ["fk", "jacobian", "fk_and_jacobian"])
def test_robot_methods_refuse_float16(method):
    r = jaxstiff.Robot.from_urdf("kuka_lwr4", locked={})
    q = np.full(7, 0.3)
    with pytest.raises(ValueError, match=r"q has dtype float16 \(half precision\).*float32 or float64"):
        getattr(r, method)(q.astype(np.float16))
    ref = np.asarray(r.fk(q))  # float64 in, reference
    got = np.asarray(r.fk(q.astype(np.float32)))  # float32 still allowed
    assert np.abs(got - ref).max() < 1e-5


@pytest.mark.parametrize("name", ["fk", "jacobian", "fk_and_jacobian"])
def test_module_functions_refuse_float16_too(name):
    """The Robot methods refused float16; the module functions jaxstiff.fk etc. computed in it
    (z = 1.179 against 1.1785 m): the same rule now, naming the function."""
    r = jaxstiff.Robot.from_urdf("kuka_lwr4", locked={})
    with pytest.raises(ValueError, match=rf"{name}: q has dtype float16 \(half precision\)"):
        getattr(jaxstiff, name)(r, np.zeros(7, np.float16))
