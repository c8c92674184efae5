"""Tests run in float64 (the library itself never flips the flag at import), and keep their compiled
programs in a cache folder of their own instead of the user's (``~/.cache/jaxstiff``): shared by the
test worker processes and by later test runs (entries are keyed by content, a stale one is never
used); ``JAXSTIFF_CACHE_DIR`` set by the caller wins. Tests that are about the cache set their own."""

import os
import tempfile

import jax
import pytest

os.environ.setdefault(
    "JAXSTIFF_CACHE_DIR",
    os.path.join(tempfile.gettempdir(), f"jaxstiff-test-cache-{os.getuid() if hasattr(os, 'getuid') else 'user'}"),
)
jax.config.update("jax_enable_x64", True)


@pytest.fixture(autouse=True, scope="module")
def _release_compiled_programs():
    """A test worker compiles thousands of programs and keeps them: every XLA:CPU executable holds
    about 13 memory mappings, and past the kernel's limit (vm.max_map_count, 65530) the next
    compile crashes the worker with a segfault (it did, twice, at ~80 % of the suite). Between
    modules, a worker that holds more than a third of its limit lets its compiled programs go
    (jaxstiff.runtime._programs); they compile again, or load from the cache, when needed."""
    from jaxstiff.runtime import release_if_near_map_limit

    release_if_near_map_limit(share=1 / 3)
    yield
