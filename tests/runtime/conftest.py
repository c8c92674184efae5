"""Fixtures of the runtime tests."""

import jax
import pytest
from jax.experimental.compilation_cache import compilation_cache

from jaxstiff.runtime import _compile_cache as cc


@pytest.fixture
def restore_jax_cache(monkeypatch):
    """The process-wide JAX cache settings as they were, after the test."""
    monkeypatch.delenv(cc.CACHE_ENV, raising=False)
    monkeypatch.delenv(cc.CACHE_DIR_ENV, raising=False)
    saved = [
        getattr(jax.config, k) for k in ("jax_compilation_cache_dir", "jax_persistent_cache_min_compile_time_secs")
    ]
    yield
    jax.config.update("jax_compilation_cache_dir", saved[0])
    jax.config.update("jax_persistent_cache_min_compile_time_secs", saved[1])
    compilation_cache.reset_cache()
