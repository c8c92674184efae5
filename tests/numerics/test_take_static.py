"""take_static (static-index selection by slices) against jnp.take: values, shapes, axes, negative
and repeated indices, and under jit, vmap and grad."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from jaxstiff._numerics.batch import take_static


@settings(max_examples=40, deadline=None)
@given(
    shape=st.lists(st.integers(1, 5), min_size=1, max_size=3),
    data=st.data(),
)
def test_matches_jnp_take(shape, data):
    axis = data.draw(st.integers(-len(shape), len(shape) - 1))
    n = shape[axis]
    idx = data.draw(st.lists(st.integers(-n, n - 1), min_size=1, max_size=6))
    a = jnp.asarray(np.random.default_rng(len(idx)).normal(size=shape))
    got = take_static(a, idx, axis=axis)
    want = jnp.take(a, jnp.asarray(idx), axis=axis)
    assert got.shape == want.shape
    np.testing.assert_array_equal(np.asarray(got), np.asarray(want))


def test_composes_with_jit_vmap_and_grad():
    a = jnp.asarray(np.random.default_rng(0).normal(size=(4, 6, 7)))
    idx = (0, 1, 2, 5)
    f = jax.jit(jax.vmap(lambda x: take_static(x, idx, axis=0)))
    np.testing.assert_array_equal(np.asarray(f(a)), np.asarray(a[:, list(idx)]))
    w = jnp.asarray(np.random.default_rng(1).normal(size=(4, 4, 7)))
    g = jax.grad(lambda x: jnp.sum(w * take_static(x, idx, axis=1)))(a)
    g_ref = jax.grad(lambda x: jnp.sum(w * x[:, list(idx)]))(a)
    np.testing.assert_array_equal(np.asarray(g), np.asarray(g_ref))


def test_no_index_is_refused():
    with pytest.raises(ValueError, match="at least one index"):
        take_static(jnp.zeros(3), [])
