"""jaxstiff.runtime._programs: compiled programs are let go, and with them their memory mappings
(counted independently, from /proc/self/maps), without changing a result."""

from __future__ import annotations

import sys

import numpy as np
import pytest

from jaxstiff.runtime import _programs as programs

pytestmark = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="/proc/self/maps")


def test_released_programs_give_back_their_mappings():
    import jax
    import jax.numpy as jnp

    held = programs.program_cache(None)(lambda k: jax.jit(lambda x: jnp.sin(x) * k).lower(jnp.ones(3)).compile())
    programs.release_compiled()
    m0 = programs.memory_maps()
    outs = [np.asarray(held(k)(jnp.ones(3))) for k in range(60)]
    m1 = programs.memory_maps()
    assert m1 - m0 > 60 * 2, (m0, m1)  # each executable holds mappings of its own
    programs.release_compiled()
    m2 = programs.memory_maps()
    assert m2 - m0 < 0.5 * (m1 - m0), (m0, m1, m2)
    again = [np.asarray(held(k)(jnp.ones(3))) for k in range(60)]  # compiled again: same numbers
    for a, b in zip(outs, again, strict=True):
        np.testing.assert_array_equal(a, b)


def test_release_only_near_the_limit(monkeypatch):
    calls = []
    monkeypatch.setattr(programs, "release_compiled", lambda: calls.append(1))
    monkeypatch.setattr(programs, "map_limit", lambda: 1000)
    monkeypatch.setattr(programs, "memory_maps", lambda: 400)
    assert programs.release_if_near_map_limit(0.5) is False and not calls
    monkeypatch.setattr(programs, "memory_maps", lambda: 600)
    assert programs.release_if_near_map_limit(0.5) is True and calls == [1]
    monkeypatch.setattr(programs, "memory_maps", lambda: None)  # off Linux: nothing to read
    assert programs.release_if_near_map_limit(0.5) is False


def test_limit_and_count_are_read():
    assert programs.memory_maps() > 10
    assert programs.map_limit() is None or programs.map_limit() > 1000
