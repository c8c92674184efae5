"""batched_like (jaxstiff._numerics.batch): a loop's initial carry made batched under vmap without
changing a value, so that JAX batches the loop body once (pgd's tracing time, issue 23). Checked:
every value comes back bit for bit (NaN, inf, -0.0, integers, booleans, an empty reference), and
a vmapped loop started from it gives what the same loop gives per example."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

from jaxstiff._numerics.batch import batched_like  # tests a function of the private numerics module


def test_values_come_back_unchanged():
    tree = (
        jnp.array([np.nan, np.inf, -np.inf, -0.0, 1.5]),
        jnp.arange(4, dtype=jnp.int32),
        jnp.array([True, False]),
        jnp.asarray(2.0),
    )
    for ref in (jnp.array([1.0, 2.0]), jnp.array([np.nan]), jnp.zeros((0, 3))):
        out = batched_like(tree, ref)
        for a, b in zip(tree, out, strict=True):
            assert a.dtype == b.dtype and a.shape == b.shape
            np.testing.assert_array_equal(np.asarray(a), np.asarray(b))
        assert np.signbit(np.asarray(out[0])[3])  # -0.0 stays -0.0


def test_a_vmapped_loop_from_it_equals_the_loop_per_example():
    def run(x):
        def body(i, c):
            acc, m = c
            return acc + jnp.sin(x * i) * m, m * 0.5

        init = (jnp.zeros(3), jnp.asarray(1.0))
        return jax.lax.fori_loop(0, 7, body, batched_like(init, x))

    xs = jnp.array([[0.1, 0.2, 0.3], [np.nan, 1.0, -2.0], [np.inf, 0.0, 5.0]])
    batched = jax.jit(jax.vmap(run))(xs)
    for k in range(xs.shape[0]):
        one = jax.jit(run)(xs[k])
        np.testing.assert_array_equal(np.asarray(batched[0][k]), np.asarray(one[0]))
        np.testing.assert_array_equal(np.asarray(batched[1][k]), np.asarray(one[1]))
    # under vmap the carry is batched from the start: the jaxpr's loop carries the batch axis
    jaxpr = jax.make_jaxpr(jax.vmap(run))(xs)

    def loops(jx):
        for e in jx.eqns:
            if e.primitive.name in ("while", "scan"):
                yield e
            for v in e.params.values():
                sub = getattr(v, "jaxpr", v)
                if hasattr(sub, "eqns"):
                    yield from loops(sub)

    loop = next(loops(jaxpr.jaxpr))
    carries = [v for v in loop.outvars if not jnp.issubdtype(v.aval.dtype, jnp.integer)]  # (not the loop index)
    assert carries and all(v.aval.shape[:1] == (3,) for v in carries)
