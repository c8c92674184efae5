"""glibc's allocator tuned for large arrays made again and again (Linux only).

A jitted call returns new arrays every time. glibc's ``malloc`` serves a request above its mmap
threshold (at most 32 MiB by default) with a fresh ``mmap`` and gives it back with ``munmap`` on
free, so every call of, say, ``fk_and_jacobian`` on 1e5 configurations (a 34 MB Jacobian) pays
a page fault and the kernel's zeroing for each 4 KiB page of its output: on a 2-core CPU about
10 of its 21-26 ms (docs/notes/speed.md). With the mmap and trim thresholds raised to
:data:`THRESHOLD_BYTES`, such blocks come from the heap and are reused by the next call. XLA's
threads allocate from their own arenas, whose extra heaps (64 MiB each) go back to the system as
soon as they are empty whatever the thresholds say; a top pad of :data:`TOP_PAD_BYTES` keeps them
(FK + Jacobian at 1e5 in float64: 12.7-15 ms in every run, against 14 or 24 ms, either, run to
run with the thresholds alone). Limiting glibc to one arena did the same for that call but made
XLA's multi-threaded compiles about 20 % slower (one lock for every thread's allocations).

The cost is that up to :data:`THRESHOLD_BYTES` of freed memory (and a pad of up to
:data:`TOP_PAD_BYTES` per heap) stays with the process instead of returning to the system at once
(it is reused by later allocations; peak RSS of ``scripts/bench_batch.py`` at 64 x 50 rose by
about 50 MiB, 1.0 -> 1.06 GiB). ``import jaxstiff`` applies
the setting unless the environment variable ``JAXSTIFF_MALLOC_TUNE`` is ``0`` or the environment
configures glibc's malloc itself (``MALLOC_ARENA_MAX`` and the like); it changes nothing
off glibc (macOS, Windows, musl) and nothing if the allocator is replaced (``LD_PRELOAD`` of
tcmalloc or jemalloc, which keep freed memory by design).
"""

from __future__ import annotations

import ctypes
import os
import sys

__all__ = ["THRESHOLD_BYTES", "TOP_PAD_BYTES", "tune_allocator"]

#: mmap and trim thresholds set by :func:`tune_allocator` (256 MiB: the outputs of a 7-joint FK +
#: Jacobian up to about 5e5 configurations in float64 come from the reused heap).
THRESHOLD_BYTES = 256 * 1024 * 1024
#: top pad set by :func:`tune_allocator`: glibc's largest heap of a thread arena (64 MiB on 64-bit),
#: so that an empty heap is kept for the next large block instead of unmapped
TOP_PAD_BYTES = 64 * 1024 * 1024

_M_TRIM_THRESHOLD = -1  # mallopt parameter numbers (glibc malloc.h)
_M_TOP_PAD = -2
_M_MMAP_THRESHOLD = -3
_USER_KEYS = (
    "MALLOC_MMAP_THRESHOLD_",
    "MALLOC_TRIM_THRESHOLD_",
    "MALLOC_ARENA_MAX",
    "MALLOC_TOP_PAD_",
    "MALLOC_MMAP_MAX_",
)


def _user_configured() -> bool:
    """Whether the environment sets glibc's malloc itself (then it is left as the user set it)."""
    env = os.environ
    return any(k in env for k in _USER_KEYS) or "glibc.malloc." in env.get("GLIBC_TUNABLES", "")


def tune_allocator(threshold: int = THRESHOLD_BYTES) -> bool:
    """Raise glibc's mmap and trim thresholds to ``threshold`` bytes and its top pad to
    :data:`TOP_PAD_BYTES` (module docstring).

    Returns:
        True where glibc accepted the settings; False off Linux/glibc, where ``mallopt`` is
        missing, with ``JAXSTIFF_MALLOC_TUNE=0``, or where the environment configures glibc's
        malloc itself (``MALLOC_ARENA_MAX``, ``MALLOC_MMAP_THRESHOLD_`` and the like, or
        ``glibc.malloc.*`` in ``GLIBC_TUNABLES``: the user's choice is kept). Idempotent (calling
        it again sets the same values) and cheap (no JAX import).
    """
    if not 0 < int(threshold) < 2**31:  # mallopt takes a C int
        raise ValueError(f"threshold must be between 1 and 2**31 - 1 bytes, got {threshold!r}")
    if os.environ.get("JAXSTIFF_MALLOC_TUNE", "1").strip() == "0" or not sys.platform.startswith("linux"):
        return False
    if _user_configured():
        return False
    try:
        libc = ctypes.CDLL(None)
        if not hasattr(libc, "gnu_get_libc_version"):  # musl and others: their own allocator
            return False
        mallopt = libc.mallopt
    except (OSError, AttributeError):
        return False
    mallopt.argtypes = (ctypes.c_int, ctypes.c_int)
    mallopt.restype = ctypes.c_int
    settings = ((_M_MMAP_THRESHOLD, int(threshold)), (_M_TRIM_THRESHOLD, int(threshold)), (_M_TOP_PAD, TOP_PAD_BYTES))
    return all(mallopt(param, value) for param, value in settings)
