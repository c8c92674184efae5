"""Temporary files (issue 24, finding 4): every writer's temporary is removed on any exit it can
see (an exception, Ctrl-C, SIGTERM), and what a SIGKILL leaves is removed by the next write into
that folder, but only our own pattern, only when old enough, and never one a live writer holds."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
import time

import pytest

from jaxstiff.runtime._io import (
    STALE_TMP_S,
    atomic_write,
    atomic_write_text,
    clean_stale_temporaries,
    is_own_temporary,
)

OLD = time.time() - 3600.0  # an hour ago


def _touch(path, mtime: float = OLD, data: bytes = b"partial") -> str:
    with open(path, "wb") as fh:
        fh.write(data)
    os.utime(path, (mtime, mtime))
    return str(path)


def _leftovers(folder) -> list[str]:
    return sorted(n for n in os.listdir(folder) if n.startswith(".tmp-"))


def test_own_pattern():
    assert is_own_temporary(".tmp-ab_9xyz0.npz") and is_own_temporary(".tmp-abcdefgh")
    assert not is_own_temporary(".tmp-abc.npz")  # not 8 characters
    assert not is_own_temporary(".tmp-ABCDEFGH.npz")  # not tempfile's alphabet
    assert not is_own_temporary("x.tmp-abcdefgh.npz") and not is_own_temporary(".tmp-abcdefgh.npz.keep~")


def test_stale_leftover_removed_by_next_write_others_kept(tmp_path):
    stale = _touch(tmp_path / ".tmp-k9x_2abc.npz")
    young = _touch(tmp_path / ".tmp-young123.npz", mtime=time.time())
    foreign = [_touch(tmp_path / n) for n in (".tmp-user.npz", ".tmp-ABCDEFGH.csv", "notes.tmp-abcdefgh")]
    os.mkdir(tmp_path / ".tmp-folder12")
    atomic_write_text(tmp_path / "out.csv", "x\n")
    assert not os.path.exists(stale)
    assert os.path.exists(young) and all(os.path.exists(f) for f in foreign)
    assert os.path.isdir(tmp_path / ".tmp-folder12")
    assert (tmp_path / "out.csv").read_text() == "x\n"
    # the young one goes once it is older than STALE_TMP_S (and not held)
    os.utime(young, (time.time() - STALE_TMP_S - 1,) * 2)
    assert clean_stale_temporaries(tmp_path) == [young]


_HOLD = textwrap.dedent(
    """
    import fcntl, os, sys, time
    fd = os.open(sys.argv[1], os.O_RDWR)
    fcntl.flock(fd, fcntl.LOCK_EX)
    print("locked", flush=True)
    time.sleep(60)
    """
)


def test_a_live_writer_is_not_disturbed_however_old_its_file(tmp_path):
    """A concurrent writer holds a flock on its temporary; the cleaner leaves it even when its
    mtime is an hour old (a writer stalled in compression), and removes it once that process dies."""
    live = _touch(tmp_path / ".tmp-live0000.npz")
    p = subprocess.Popen([sys.executable, "-c", _HOLD, live], stdout=subprocess.PIPE, text=True)
    try:
        assert p.stdout is not None and p.stdout.readline().strip() == "locked"
        os.utime(live, (OLD, OLD))
        assert clean_stale_temporaries(tmp_path) == [] and os.path.exists(live)
    finally:
        p.kill()
        p.wait()
    assert clean_stale_temporaries(tmp_path) == [live]  # the kernel dropped the dead writer's lock


_WRITER = textwrap.dedent(
    """
    import sys, time
    from jaxstiff.runtime._io import atomic_write, interrupt_handlers

    def slow(fh):
        fh.write(b"x" * 100000)
        fh.flush()
        print("writing", flush=True)
        time.sleep(60)

    with interrupt_handlers():
        atomic_write(sys.argv[1], slow, binary=True)
    """
)


def _writer(target) -> subprocess.Popen:
    p = subprocess.Popen([sys.executable, "-c", _WRITER, str(target)], stdout=subprocess.PIPE, text=True)
    assert p.stdout is not None and p.stdout.readline().strip() == "writing"
    return p


def test_sigkill_leftover_cleaned_by_the_next_run(tmp_path):
    out = tmp_path / "result.npz"
    p = _writer(out)
    p.send_signal(signal.SIGKILL)
    p.wait()
    left = _leftovers(tmp_path)
    assert len(left) == 1 and is_own_temporary(left[0]) and not out.exists()  # what SIGKILL leaves
    os.utime(tmp_path / left[0], (OLD, OLD))  # (the next run starts later than STALE_TMP_S)
    atomic_write(out, lambda fh: fh.write(b"ok"), binary=True)  # a fresh process would do the same
    assert _leftovers(tmp_path) == [] and out.read_bytes() == b"ok"


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT])
def test_signal_during_write_leaves_nothing(tmp_path, sig):
    p = _writer(tmp_path / "result.npz")
    p.send_signal(sig)
    p.wait(timeout=30)
    assert _leftovers(tmp_path) == [] and not (tmp_path / "result.npz").exists()


def test_exception_during_write_leaves_nothing(tmp_path):
    def fail(fh):
        fh.write("half")
        raise RuntimeError("disk full")

    with pytest.raises(RuntimeError):
        atomic_write(tmp_path / "a.csv", fail)
    assert os.listdir(tmp_path) == []
