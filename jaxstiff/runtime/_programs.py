"""Compiled programs held by the process, and letting them go.

Every XLA:CPU executable keeps about 13 memory mappings of its own (JIT code and data sections;
measured with jaxlib 0.10: 200 small programs, 13.5 maps each). Linux caps a process at
``vm.max_map_count`` mappings (65530 by default); past it, the next ``mmap`` fails and XLA's
compiler crashes the process with a segmentation fault, in the middle of a compile. A process that
compiles some 4800 programs and keeps them (JAX's jit caches, jaxstiff's caches of compiled
programs below) reaches it: the test suite's long-lived workers did, and so could a long sweep or
notebook with many distinct settings.

:func:`program_cache` is the ``functools.lru_cache`` of jaxstiff's compiled programs, registered so
that :func:`release_compiled` can empty them all, together with JAX's own caches
(``jax.clear_caches()``); :func:`release_if_near_map_limit` does so when the process holds more
than a share of its mapping limit (the sweep calls it after each chunk). A released program is
compiled again when next needed (or loaded from the persistent compilation cache).
"""

from __future__ import annotations

import functools
import gc
import sys
from collections.abc import Callable
from typing import Any, TypeVar

__all__ = [
    "program_cache",
    "register_cache",
    "release_compiled",
    "memory_maps",
    "map_limit",
    "release_if_near_map_limit",
]

F = TypeVar("F", bound=Callable[..., Any])
_CACHES: list[Any] = []


def program_cache(maxsize: int | None = 64) -> Callable[[F], F]:
    """``functools.lru_cache(maxsize)`` for a function that returns compiled programs, registered
    with :func:`release_compiled`."""

    def wrap(fn: F) -> F:
        cached = functools.lru_cache(maxsize=maxsize)(fn)
        _CACHES.append(cached)
        return cached  # type: ignore[return-value]

    return wrap


def register_cache(cache: Any) -> Any:
    """Register an object with a ``cache_clear()`` method that holds compiled programs (a dict
    of one's own), so that :func:`release_compiled` empties it too; returns it."""
    _CACHES.append(cache)
    return cache


def release_compiled() -> None:
    """Drop every compiled program jaxstiff and JAX hold in memory (their caches; programs still
    referenced elsewhere stay alive). Results do not change: a program is compiled again, or
    loaded from the persistent compilation cache, when it is next needed."""
    for c in _CACHES:
        c.cache_clear()
    if "jax" in sys.modules:
        sys.modules["jax"].clear_caches()
    gc.collect()


def memory_maps() -> int | None:
    """The number of memory mappings of this process (Linux: lines of ``/proc/self/maps``), else None."""
    try:
        with open("/proc/self/maps", "rb") as f:
            return sum(1 for _ in f)
    except OSError:
        return None


def map_limit() -> int | None:
    """``vm.max_map_count`` (Linux), else None."""
    try:
        with open("/proc/sys/vm/max_map_count") as f:
            return int(f.read().strip())
    except (OSError, ValueError):
        return None


def release_if_near_map_limit(share: float = 0.5) -> bool:
    """:func:`release_compiled` when this process holds more than ``share`` of its mapping limit.
    Returns True when it released. A no-op off Linux (no limit to read)."""
    n, limit = memory_maps(), map_limit()
    if n is None or limit is None or n <= share * limit:
        return False
    release_compiled()
    return True
