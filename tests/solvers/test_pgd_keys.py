"""pgd's host-computed random keys (jaxstiff.solvers._pgd.keys) against jax.random itself.

The keys decide pgd's random starts, so a key that differs in one bit changes a result: they must
be jax.random's own bits under every setting that changes them (x64, the split's partitionable
form), and jax.random's own output where another PRNG implementation is the default."""

from __future__ import annotations

import itertools

import jax
import numpy as np
import pytest

from jaxstiff.solvers._pgd import keys as K


@pytest.mark.parametrize(("partitionable", "x64"), list(itertools.product([True, False], [True, False])))
def test_seed_and_chunk_keys_are_jax_randoms_bits(partitionable, x64):
    rng = np.random.default_rng(0)
    with jax.threefry_partitionable(partitionable), jax.enable_x64(x64):
        for seed in (0, 1, 3, 12345, 2**31 - 1) + ((2**32 - 1,) if x64 else ()):
            np.testing.assert_array_equal(K.seed_key(seed), np.asarray(jax.random.PRNGKey(seed)))
        for P, cap in [(1, 8), (5, 8), (8, 8), (50, 64), (60, 64)]:
            base = jax.random.PRNGKey(int(rng.integers(0, 2**31)))
            data = rng.integers(0, 2**32, size=7, dtype=np.uint64).astype(np.uint32)
            got = K.chunk_keys(np.asarray(base), data, P, cap)
            assert isinstance(got, np.ndarray) and got.dtype == np.uint32 and got.shape == (7, cap, 2)
            for i, d in enumerate(data):
                # written from jax.random directly: split(fold_in(base, d), P + 1), the first
                # waypoint's key the last one, padded with the last waypoint's
                k = np.asarray(jax.random.split(jax.random.fold_in(base, d), P + 1))
                own = np.concatenate([k[P:], k[1:P]])
                want = np.concatenate([own, np.repeat(own[-1:], cap - P, axis=0)])
                np.testing.assert_array_equal(got[i], want)


def test_threefry_known_answer():
    # the Threefry-2x32 (20 rounds) known-answer vectors of Salmon et al.'s Random123 suite, as
    # JAX's own tests state them: key (0x13198a2e, 0x03707344), counter (0x243f6a88, 0x85a308d3)
    a, b = K.threefry2x32(0x13198A2E, 0x03707344, 0x243F6A88, 0x85A308D3)
    assert (int(a), int(b)) == (0xC4923A9C, 0x483DF7A0)
    a, b = K.threefry2x32(0, 0, 0, 0)
    assert (int(a), int(b)) == (0x6B200159, 0x99BA4EFE)


def test_other_prng_implementation_is_left_to_jax():
    with jax.default_prng_impl("rbg"):
        base = K.seed_key(5)
        np.testing.assert_array_equal(np.asarray(base), np.asarray(jax.random.PRNGKey(5)))
        assert np.asarray(base).shape != (2,)  # rbg's key, not threefry's
        data = np.array([3, 4], np.uint32)
        got = np.asarray(K.chunk_keys(base, data, 3, 8))
        k = np.asarray(jax.random.split(jax.random.fold_in(base, 3), 4))
        np.testing.assert_array_equal(got[0, :3], np.concatenate([k[3:], k[1:3]]))
