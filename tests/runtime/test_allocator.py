"""jaxstiff.runtime._allocator: a large block freed and made again does not page-fault again.

Measured with the process's own minor page-fault counter (``getrusage``), in fresh interpreters
(the allocator's state is per process), on blocks from ``malloc`` as XLA gets them: without the
setting, glibc hands a 64 MB block back to the system on free and the next one faults in all of
its ~16k pages again; with it, the second block reuses the first one's pages.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

pytestmark = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="glibc's allocator")

_PROBE = r"""
import ctypes, json, resource
import sys
import jaxstiff  # changes nothing process-wide
from jaxstiff.runtime import tune_allocator

tuned = tune_allocator() if sys.argv[1] == "tune" else None  # the command line's opt-in, and a script's

libc = ctypes.CDLL(None)
libc.malloc.restype = ctypes.c_void_p
libc.malloc.argtypes = (ctypes.c_size_t,)
libc.free.argtypes = (ctypes.c_void_p,)
N = 64_000_000  # as XLA allocates: plain malloc, no huge-page advice (numpy asks for huge pages)

def block():
    p = libc.malloc(N)
    ctypes.memset(p, 1, N)  # touch every page
    return p

def faults():
    return resource.getrusage(resource.RUSAGE_SELF).ru_minflt

libc.free(block())
f0 = faults()
libc.free(block())
print(json.dumps({"tuned": tuned, "second_faults": faults() - f0}))
"""


def _probe(env_value: str | None, mode: str = "tune") -> dict:
    env = {k: v for k, v in os.environ.items() if not k.startswith("MALLOC_") and k != "GLIBC_TUNABLES"}
    env.pop("JAXSTIFF_MALLOC_TUNE", None)
    if env_value is not None:
        env["JAXSTIFF_MALLOC_TUNE"] = env_value
    out = subprocess.run([sys.executable, "-c", _PROBE, mode], env=env, capture_output=True, text=True, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def _is_glibc() -> bool:
    import ctypes

    return hasattr(ctypes.CDLL(None), "gnu_get_libc_version")


@pytest.mark.skipif(not _is_glibc(), reason="glibc only")
def test_freed_large_block_is_reused_without_page_faults():
    on, off = _probe(None), _probe("0")
    assert on["tuned"] is True and off["tuned"] is False
    pages = 64e6 / 4096
    # untuned: the new block faults in (nearly) every page; tuned: (nearly) none
    assert off["second_faults"] > 0.8 * pages, off
    assert on["second_faults"] < 0.1 * pages, on


@pytest.mark.skipif(not _is_glibc(), reason="glibc only")
def test_importing_the_package_leaves_the_allocator_alone():
    """``import jaxstiff`` changes no process-wide setting: a freed large block faults in again."""
    plain = _probe(None, mode="import-only")
    assert plain["tuned"] is None
    assert plain["second_faults"] > 0.8 * 64e6 / 4096, plain


def test_opt_out_user_settings_and_non_linux_are_no_ops(monkeypatch):
    from jaxstiff.runtime import _allocator as allocator

    for k in ("MALLOC_ARENA_MAX", "MALLOC_MMAP_THRESHOLD_", "MALLOC_TRIM_THRESHOLD_", "GLIBC_TUNABLES"):
        monkeypatch.delenv(k, raising=False)
    monkeypatch.setenv("JAXSTIFF_MALLOC_TUNE", "0")
    assert allocator.tune_allocator() is False
    monkeypatch.delenv("JAXSTIFF_MALLOC_TUNE")
    # the user's own malloc settings are kept
    monkeypatch.setenv("MALLOC_ARENA_MAX", "4")
    assert allocator.tune_allocator() is False
    monkeypatch.delenv("MALLOC_ARENA_MAX")
    monkeypatch.setenv("GLIBC_TUNABLES", "glibc.malloc.mmap_threshold=65536")
    assert allocator.tune_allocator() is False
    monkeypatch.delenv("GLIBC_TUNABLES")
    monkeypatch.setattr(allocator.sys, "platform", "darwin")
    assert allocator.tune_allocator() is False


def test_threshold_out_of_range_is_refused():
    from jaxstiff.runtime import _allocator as allocator

    for bad in (0, -1, 2**31):
        with pytest.raises(ValueError, match="threshold"):
            allocator.tune_allocator(bad)
