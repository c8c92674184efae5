"""jaxstiff's kernel compiler options (jaxstiff._xla): accepted by this XLA, and the same numbers."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

from jaxstiff.runtime import kernel_compiler_options


def test_options_compile_and_do_not_change_results():
    opts = kernel_compiler_options()
    if jax.default_backend() == "cpu":
        assert opts in ({}, {"xla_cpu_experimental_ynn_fusion_type": "", "xla_cpu_multi_thread_eigen": False})
    else:
        assert opts == {}

    def f(a, b):  # the kind of tiny batched contraction the kernels are made of
        return jnp.sum(a[..., :, :, None] * b[..., None, :, :], axis=-2)

    rng = np.random.default_rng(0)
    a, b = rng.normal(size=(64, 3, 3)), rng.normal(size=(64, 3, 3))
    np.testing.assert_allclose(jax.jit(f, compiler_options=opts)(a, b), a @ b, rtol=1e-5, atol=1e-5)
    # a batched matrix product (XLA hands it to Eigen, single-threaded with these options)
    g = jax.jit(lambda a, b: jnp.einsum("bij,bjk->bik", a, b), compiler_options=opts)
    np.testing.assert_allclose(g(a, b), a @ b, rtol=1e-12, atol=1e-12)
