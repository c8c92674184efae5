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

#: the tests that take 20 s or more on a quiet 2-core machine (``--durations``), longest first: they
#: start first, so that no worker is left with one of them while the others have run out of tests
_LONGEST = (
    "runtime/test_cache_damage.py::test_bit_flips_in_every_cache_kind_many",
    "sweep/test_hostile_sweep_store.py::test_hostile_sweep_stores_all",
    "solvers/test_trajectory_lm.py::",
    "stiffness/test_stress_numerics.py::",
    "results/test_hostile_files.py::test_hostile_files_all",
    "runtime/test_export_cache.py::test_pgd_from_the_file_equals_pgd_traced",
    "sweep/test_sweep_ray_lost_worker.py::",
    "view/test_png_arms.py::",
    "sweep/test_sweep.py::test_ray_backend_gives_the_same_table",
    "view/test_browser.py::",
    "test_examples.py::",
    "docs/test_code_blocks.py::test_page_code_runs",
    "sweep/test_hostile_sweep_store.py::test_hostile_sweep_stores_sample",
)


def _rank(item: pytest.Item) -> int:
    rel = item.nodeid.split("tests/", 1)[-1]
    return next((i for i, p in enumerate(_LONGEST) if rel.startswith(p)), len(_LONGEST))


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    """The longest tests first, the rest in the order pytest collected them (a stable sort)."""
    items.sort(key=_rank)


def pytest_configure(config: pytest.Config) -> None:
    """With test workers (``-n``), hand a worker at most 8 tests at a time, so that the long tests
    that start first spread over the workers (pytest-xdist otherwise sends each worker a quarter of
    its share at once, in collection order: all the longest to one worker). Not one at a time: a
    worker that runs neighbouring tests reuses their compiled programs, and one at a time made the
    fast lane 14 % slower (191 s against 167 s) and used 12 % more CPU. ``--maxschedchunk`` given
    on the command line wins."""
    if getattr(config.option, "maxschedchunk", 0) is None:
        config.option.maxschedchunk = 8


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
