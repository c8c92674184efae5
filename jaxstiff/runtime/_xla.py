"""XLA compiler options for jaxstiff's batched kernels.

XLA:CPU (jaxlib 0.10) hands small fused reductions and elementwise loops to the YNNPACK library by
default. jaxstiff's kernels are made of many tiny contractions over a batch axis (3x3 and 6x6
products, cross products, unrolled factorisations), for which the library call costs more than
XLA's own loops (measurements: docs/notes/model.md). So jaxstiff compiles its own kernels with
that fusion type switched off. It also runs XLA's Eigen calls (the batched small matrix products)
single-threaded: split over threads, each of those tiny products costs more in coordination than
in arithmetic (pgd 64 x 50 in one execution: 1.61 -> 1.42 s, compile 14.6 -> 10.9 s; the cores
are used by running chunks concurrently instead, :mod:`jaxstiff.runtime._threads`;
docs/notes/speed.md). Single-threaded, a product's rounding no longer depends on the machine's
thread pool.

A computation the user jits around a jaxstiff call is compiled with the user's options (an inner
``jax.jit`` is inlined): pass :func:`kernel_compiler_options` to your own ``jax.jit(...,
compiler_options=...)``, or set ``XLA_FLAGS=--xla_cpu_experimental_ynn_fusion_type=`` before JAX
starts, to get the same effect there.
"""

from __future__ import annotations

import functools
import os

import jax

__all__ = ["kernel_compiler_options"]

_CPU: dict[str, str | bool] = {"xla_cpu_experimental_ynn_fusion_type": "", "xla_cpu_multi_thread_eigen": False}


@functools.cache
def _supported(backend: str) -> bool:
    if backend != "cpu" or os.environ.get("JAXSTIFF_XLA_DEFAULTS"):
        return False
    try:  # an XLA that does not know the option refuses to compile: then use the defaults
        jax.jit(lambda x: x + 1.0, compiler_options=_CPU).lower(1.0).compile()
    except Exception:  # noqa: BLE001 - any refusal means "not supported here"
        return False
    return True


def kernel_compiler_options() -> dict[str, str | bool]:
    """The compiler options jaxstiff uses for its kernels on the default backend ({} off CPU, on an
    XLA that does not know them, or with the environment variable ``JAXSTIFF_XLA_DEFAULTS`` set)."""
    return dict(_CPU) if _supported(jax.default_backend()) else {}
