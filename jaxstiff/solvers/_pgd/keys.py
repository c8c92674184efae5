"""pgd's random keys, computed on the host: the bits :mod:`jax.random` gives, without compiling.

Why: :mod:`jax.random`'s functions run as small jitted programs. The seed's key
(``jax.random.PRNGKey``) and each chunk's waypoint keys (``fold_in`` and ``split``) would cost
about 1.4 s of XLA compilation on a process's first pgd call (0.6-0.8 s for the seed's key under
x64, 0.6-1.1 s for the chunk's keys; LWR, 2-core CPU), in the main thread, before pgd's own
compilation starts. The keys are a few hundred Threefry-2x32 hashes: numpy computes them in
microseconds.

What: :func:`seed_key` and :func:`chunk_keys` return the very bits of their :mod:`jax.random`
counterparts (Threefry-2x32, Salmon et al. 2011, as JAX's ``threefry2x32`` primitive computes
it, under either setting of ``jax_threefry_partitionable``); checked against :mod:`jax.random`
in ``tests/solvers/test_pgd_keys.py``. With another default PRNG implementation
(``jax_default_prng_impl``) they call :mod:`jax.random` itself.
"""

from __future__ import annotations

import functools
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from jaxstiff.solvers._pgd.kernel import waypoint_keys

__all__ = ["seed_key", "chunk_keys", "threefry2x32"]

#: the rotation constants of the two alternating groups of four rounds
_ROTATIONS = ((13, 15, 26, 6), (17, 29, 16, 24))
#: the key schedule's parity constant
_PARITY = np.uint32(0x1BD11BDA)


def threefry2x32(k1: Any, k2: Any, x1: Any, x2: Any) -> tuple[np.ndarray, np.ndarray]:
    """Threefry-2x32 with 20 rounds of the key ``(k1, k2)`` applied to the counter pairs
    ``(x1, x2)`` (uint32, broadcast together): the two uint32 outputs, as JAX's primitive."""
    k1, k2, x1, x2 = (np.asarray(a, np.uint32) for a in (k1, k2, x1, x2))
    ks = (k1, k2, k1 ^ k2 ^ _PARITY)
    a, b = x1 + ks[0], x2 + ks[1]
    for i in range(5):
        for r in _ROTATIONS[i % 2]:
            a = a + b
            b = (b << np.uint32(r)) | (b >> np.uint32(32 - r))
            b = a ^ b
        a = a + ks[(i + 1) % 3]
        b = b + ks[(i + 2) % 3] + np.uint32(i + 1)
    return a, b


def _flag(name: str) -> Any:
    """JAX's configuration value ``name`` in force here (a ``with jax.<flag>(...)`` block included)."""
    return getattr(jax.config, name)


def _host() -> bool:
    """Whether the host twin applies: JAX's default PRNG implementation is Threefry-2x32."""
    return str(_flag("jax_default_prng_impl")) == "threefry2x32"


def seed_key(seed: int) -> np.ndarray | jax.Array:
    """``jax.random.PRNGKey(seed)``: ``[seed >> 32, seed & 0xFFFFFFFF]`` (uint32) for a seed in
    [0, 2^32), on the host; other seeds and PRNG implementations by :mod:`jax.random`."""
    seed = int(seed)
    if _host() and 0 <= seed < 2**32:
        return np.array([0, seed], np.uint32)
    return jax.random.PRNGKey(seed)


def _split(k1: np.ndarray, k2: np.ndarray, n: int) -> np.ndarray:
    """``jax.random.split`` of the keys ``(k1, k2)`` (m,) into n each: (m, n, 2) uint32."""
    k1, k2 = k1[:, None], k2[:, None]
    if _flag("jax_threefry_partitionable"):
        # the counters are the 64-bit indices 0..n-1 as (high, low) words
        a, b = threefry2x32(k1, k2, np.zeros(n, np.uint32), np.arange(n, dtype=np.uint32))
        return np.stack([a, b], axis=-1)
    # the counters 0..2n-1, hashed as the pairs (i, n + i), the outputs laid out row-major as (n, 2)
    count = np.arange(2 * n, dtype=np.uint32)
    a, b = threefry2x32(k1, k2, count[:n], count[n:])
    return np.concatenate([a, b], axis=-1).reshape(k1.shape[0], n, 2)


def chunk_keys(base: Any, path_data: Any, P: int, cap: int) -> np.ndarray | jax.Array:
    """The waypoints' random keys (C, cap, 2) of a chunk of paths: each path's key is ``base``
    (:func:`seed_key`) folded with its data (C,) (``jax.random.fold_in``), its waypoints' keys
    those of its own length P (:func:`~jaxstiff.solvers._pgd.kernel.waypoint_keys`: the first
    waypoint's is the last of ``split(key, P + 1)``, waypoint p's the p-th), padded to the capacity
    with the last one: the same random starts whatever program runs the path."""
    if not _host():
        return _chunk_keys_jax(base, path_data, P, cap)
    base = np.asarray(base, np.uint32)
    data = np.asarray(path_data, np.uint32)
    # fold_in(key, d) hashes the counter pair (0, d): d's 64-bit seed key [0, d]
    f1, f2 = threefry2x32(base[0], base[1], np.zeros_like(data), data)
    k = _split(f1, f2, P + 1)  # (C, P + 1, 2)
    keys = np.concatenate([k[:, P:], k[:, 1:P]], axis=1)
    return np.concatenate([keys, np.repeat(keys[:, -1:], cap - P, axis=1)], axis=1)


@functools.partial(jax.jit, static_argnums=(2, 3))
def _chunk_keys_jax(base: jax.Array, path_data: Any, P: int, cap: int) -> jax.Array:
    """:func:`chunk_keys` by :mod:`jax.random`, for a PRNG implementation other than Threefry."""
    path_keys = jax.vmap(lambda i: jax.random.fold_in(base, i))(path_data)
    keys = jax.vmap(lambda k: waypoint_keys(k, P))(path_keys)
    return jnp.concatenate([keys, jnp.repeat(keys[:, -1:], cap - P, axis=1)], axis=1)
