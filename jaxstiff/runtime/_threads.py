"""Compiled chunks of a batch run on several CPU threads at once.

XLA:CPU spreads one execution of jaxstiff's batched kernels over its thread pool poorly: the loops
are short (a few hundred lanes of small-matrix arithmetic per operation), and a 2-core machine ran
pgd's 64 x 50 batch in 1.6-1.7 s of wall time for 2.2 s of CPU time. Two executions of half the
batch each, on two Python threads (JAX releases the GIL while a program runs), took 0.78 s for
1.5 s of CPU time, with bit-identical rows (docs/notes/speed.md). So the batch solvers split a
batch into at least as many chunks as there are threads and run them concurrently.

The thread count: the solver option (``threads``; 0 = automatic), else the cores this process may
use on a CPU backend (:func:`usable_cores`: its CPU affinity, capped by ``$OMP_NUM_THREADS``), 1
on an accelerator (one device runs one program at a time) or when the batch is sharded across
devices.
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable, Sequence
from concurrent.futures import ThreadPoolExecutor
from typing import Any, TypeVar

__all__ = ["usable_cores"]

T = TypeVar("T")


def usable_cores() -> int:
    """Cores this process may run on: its CPU affinity where the OS tells (else ``os.cpu_count``),
    capped by ``$OMP_NUM_THREADS`` when that is a positive number (Ray sets it to a task's CPUs,
    and batch schedulers often do, so that worker processes sharing a host do not oversubscribe it)."""
    try:
        n = len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        n = os.cpu_count() or 1
    omp = os.environ.get("OMP_NUM_THREADS", "").strip()
    if omp.isdigit() and int(omp) > 0:
        n = min(n, int(omp))
    return max(n, 1)


def chunk_threads(requested: int = 0) -> int:
    """Threads running chunks at once: ``requested`` if > 0, else :func:`usable_cores` on a CPU
    backend with one local device, else 1."""
    if requested > 0:
        return int(requested)
    import jax

    if jax.default_backend() != "cpu" or jax.local_device_count() > 1:
        return 1
    return usable_cores()


#: trajectories per compiled pgd call on a CPU when the option ``chunk`` is 0 (automatic)
CPU_CHUNK = 8
#: the same on an accelerator, or a CPU batch sharded across several devices (a memory bound)
DEVICE_CHUNK = 256


def auto_chunk(requested: int = 0) -> int:
    """Trajectories per compiled pgd call: ``requested`` if > 0, else :data:`CPU_CHUNK` on a CPU
    backend with one local device, else :data:`DEVICE_CHUNK`. On a 2-core CPU a pgd call's cost
    per trajectory is flat from 4 to 32 rows (LWR, UR10, Z1; 64 x 50 in 1.9-2.4 s at 8, 16 and
    32 rows), while the first-waypoint retry reruns its few paths in a call of full size (2 LWR
    paths: 2.2-2.6 s in 32 rows, 0.5-0.7 s in 8)."""
    if requested > 0:
        return int(requested)
    import jax

    if jax.default_backend() == "cpu" and jax.local_device_count() == 1:
        return CPU_CHUNK
    return DEVICE_CHUNK


def chunk_rows(B: int, chunk: int, threads: int) -> int:
    """Rows per compiled call: at most ``chunk`` (the memory bound), small enough that the B rows
    make at least ``threads`` chunks, and at least 2 (XLA compiles a batch of 1 differently, so a
    lone row would not have the bits it has in a batch)."""
    return max(min(int(chunk), math.ceil(B / max(int(threads), 1))), 2)


def map_chunks(fn: Callable[[Any], T], items: Sequence[Any], threads: int) -> list[T]:
    """``[fn(item) for item in items]``, on up to ``threads`` threads at once (results in order).

    JAX's x64 setting is thread-local (``jax.enable_x64`` in the caller does not reach a new
    thread): each worker runs ``fn`` under the caller's setting."""
    if threads <= 1 or len(items) <= 1:
        return [fn(it) for it in items]
    import jax

    x64 = bool(getattr(jax.config, "jax_enable_x64"))  # noqa: B009 - the caller's (thread-local) value

    def work(item: Any) -> T:
        with jax.enable_x64(x64):
            return fn(item)

    ex = ThreadPoolExecutor(max_workers=min(threads, len(items)), thread_name_prefix="jaxstiff-chunk")
    try:
        return list(ex.map(work, items))
    except BaseException:
        # an error or an interrupt: chunks not started yet are dropped, running ones finish
        ex.shutdown(wait=True, cancel_futures=True)
        raise
    finally:
        ex.shutdown(wait=True)
