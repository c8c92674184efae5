"""Tests run in float64 (the library itself never flips the flag at import), and keep their compiled
programs in a cache folder of their own instead of the user's (``~/.cache/jaxstiff``): shared by the
test worker processes and by later test runs (entries are keyed by content, a stale one is never
used); ``JAXSTIFF_CACHE_DIR`` set by the caller wins. Tests that are about the cache set their own."""

import os
import tempfile

import jax

os.environ.setdefault(
    "JAXSTIFF_CACHE_DIR",
    os.path.join(tempfile.gettempdir(), f"jaxstiff-test-cache-{os.getuid() if hasattr(os, 'getuid') else 'user'}"),
)
jax.config.update("jax_enable_x64", True)
