"""Refuse a plan that cannot fit in memory before any work, with the estimate, the limit and the knob.

A user-given count (a path generator's ``n``, ``jaxstiff csc --steps``, the waypoints of a sweep's
paths, the result rows of a shaping run) decides how much memory a command allocates. Without a
check, a count such as ``10**12`` ends in numpy's raw ``_ArrayMemoryError`` traceback (or in the
kernel's OOM killer). :func:`check_plan_size` turns that into one clear message::

    line: n = 1000000000000 waypoints need about 144 TB of memory (144 B each); 12.3 GB is
    available: lower n

The limit is the memory available now (``MemAvailable`` of ``/proc/meminfo``, which counts the
page cache the kernel can drop; elsewhere the free physical pages from ``os.sysconf``), or the
``JAXSTIFF_MEMORY_LIMIT`` environment variable (bytes, suffixes k/M/G/T accepted) when set: a user
sharing a machine, or a container whose cgroup limit is lower than the host's memory, sets it.
Only the memory held at once counts: work that goes in pieces (a long CSC run in segments, a sweep
in chunks) is estimated per piece by its caller, so what can be streamed is not refused.
"""

from __future__ import annotations

import os
import re

__all__ = ["available_memory_bytes", "format_bytes", "MEMORY_LIMIT_ENV"]

MEMORY_LIMIT_ENV = "JAXSTIFF_MEMORY_LIMIT"  #: bytes a plan may use (overrides the available memory)
_SUFFIX = {"": 1, "k": 1e3, "m": 1e6, "g": 1e9, "t": 1e12}


class PlanTooLargeError(ValueError):
    """A plan whose estimated memory exceeds the limit (a ``ValueError``: the command line exits 2).

    Attributes:
        estimate_bytes, limit_bytes: the estimate and the limit, bytes.
        key_or_flag: the flag or config key that sets the count.
    """

    def __init__(self, message: str, estimate_bytes: float, limit_bytes: float, key_or_flag: str) -> None:
        super().__init__(message)
        self.estimate_bytes, self.limit_bytes, self.key_or_flag = estimate_bytes, limit_bytes, key_or_flag


def format_bytes(n: float) -> str:
    """``n`` bytes as a short decimal size (``'14.6 TB'``)."""
    for unit, scale in (("PB", 1e15), ("TB", 1e12), ("GB", 1e9), ("MB", 1e6), ("kB", 1e3)):
        if n >= scale:
            return f"{n / scale:.3g} {unit}"
    return f"{n:.0f} B"


def _env_limit() -> float | None:
    raw = os.environ.get(MEMORY_LIMIT_ENV, "").strip()
    if not raw:
        return None
    m = re.fullmatch(r"(\d+(?:\.\d*)?)\s*([kmgtKMGT]?)[bB]?", raw)
    if not m:
        raise ValueError(f"{MEMORY_LIMIT_ENV}={raw!r}: expected a size in bytes such as 8G or 500000000")
    return float(m[1]) * _SUFFIX[m[2].lower()]


def available_memory_bytes() -> float:
    """Bytes a plan may use: ``$JAXSTIFF_MEMORY_LIMIT`` if set, else the memory available now
    (``MemAvailable`` from ``/proc/meminfo``, else free physical pages from ``os.sysconf``; inf
    when neither is known)."""
    env = _env_limit()
    if env is not None:
        return env
    try:
        with open("/proc/meminfo", encoding="ascii") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return float(line.split()[1]) * 1024.0
    except (OSError, ValueError, IndexError):
        pass
    try:
        return float(os.sysconf("SC_AVPHYS_PAGES")) * float(os.sysconf("SC_PAGE_SIZE"))
    except (ValueError, OSError, AttributeError):
        return float("inf")


def check_plan_size(
    what: str, n_values: float, bytes_per_value: float, key_or_flag: str, *, limit_bytes: float | None = None
) -> float:
    """Refuse ``n_values`` items of ``bytes_per_value`` bytes each when they exceed the memory limit.

    Args:
        what: what is counted, as the message should name it (``"line: n = 10 waypoints"`` style:
            the caller says ``"line: n = 1000000000000 waypoints"``).
        n_values: the count (any non-negative number; a Python int of any size is fine).
        bytes_per_value: the estimated bytes held at once per item (every array and temporary).
        key_or_flag: the flag or config key that sets the count (``"--steps"``, ``"paths[0].n"``).
        limit_bytes: the limit; default :func:`available_memory_bytes`.

    Returns:
        The estimate, bytes.

    Raises:
        PlanTooLargeError: the estimate exceeds the limit; the message gives both and the knob.
    """
    estimate = float(n_values) * float(bytes_per_value)
    limit = available_memory_bytes() if limit_bytes is None else float(limit_bytes)
    if estimate > limit:
        where = "the limit set by " + MEMORY_LIMIT_ENV if limit_bytes is None and _env_limit() is not None else None
        raise PlanTooLargeError(
            f"{what} need about {format_bytes(estimate)} of memory ({format_bytes(bytes_per_value)} each); "
            f"{format_bytes(limit)} is {where or 'available'}: lower {key_or_flag}",
            estimate,
            limit,
            key_or_flag,
        )
    return estimate
