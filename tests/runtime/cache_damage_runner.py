"""Flip single bits in jaxstiff's on-disk caches and run the cached call after each flip, each run
in its own forked process (a damaged program can crash XLA's deserializer: a segfault that no
``try`` catches). Run by tests/runtime/test_cache_damage.py as its own process (the pytest process
never forks with JAX started in it)::

    python cache_damage_runner.py CACHE_DIR FLIPS_PER_KIND [EDIT_FILE]

Writes one JSON object on stdout: the reference result, and per cache kind (``traced``: the
``jaxstiff-programs/*.jaxexp`` files; ``compiled``: the entries of JAX's compilation cache) the
flips as ``[offset, bit, exit status or -signal (-9: killed after TIMEOUT_S), result hex or None,
warnings, traced, read]`` (read: the run read the flipped file; None where it died).

Every run computes the traced program's file key from jaxstiff's code fingerprint taken once, here,
before the first fork, and runs the modules imported here: the file a run reads is the one that
was flipped even where the checkout's sources change while the runner runs (a merge into the
checkout under test: the fast lane once saw a later run trace a fresh program under another key,
never read the flipped file and so report no damage). ``EDIT_FILE``, for the test of that: a
source file of the jaxstiff package being run (a copy) that gets a comment line appended after
the reference run.

The cached call is the damped-least-squares IK of the planar 3R arm (:func:`jaxstiff.ik.ik_position`):
a DiskJit program, so it goes through both caches, and small (about a second per run).
"""

from __future__ import annotations

import json
import os
import select
import shutil
import signal
import sys
import time
import warnings

import jax  # imported before the forks; the backend is started in each child, never here
import numpy as np

jax.config.update("jax_enable_x64", True)

from jaxstiff.runtime import _compile_cache as cc  # noqa: E402
from jaxstiff.runtime import _export_cache as ec  # noqa: E402

TARGET = np.array([1.2, 0.5, 0.0])
#: seconds a run may take (about 1 s from intact caches): a longer one is killed and counted as a hang
TIMEOUT_S = 120.0


def _child(cache: str, out: int) -> None:
    """The cached call; its result, the damage warnings seen and the traces made go to ``out``."""
    from jax import export

    from jaxstiff.ik import ik_position
    from jaxstiff.model import Robot

    traced = []
    real_export = export.export

    def counting_export(*a, **k):
        traced.append(1)
        return real_export(*a, **k)

    export.export = counting_export
    read = _record_reads()
    cc.enable_compile_cache(cache, min_compile_s=0.0)
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")
        with cc.CompileClock() as clock:
            q, err = ik_position(Robot.from_urdf("planar_3r"), TARGET)
    kind = getattr(cc, "CacheDamageWarning", None)  # (None: the code before the checks, for comparison)
    damage = [str(w.message) for w in seen if kind is not None and issubclass(w.category, kind)]
    rec = {
        "q": np.asarray(q, dtype=np.float64).tobytes().hex(),
        "err": float(err),
        "warnings": damage,
        "traced": len(traced),
        "hits": clock.cache_hits,
        "read": read,
    }
    os.write(out, json.dumps(rec).encode())


def _record_reads() -> list[str]:
    """The cache files this process reads from now on (real paths; traced programs and JAX's
    entries), as a list that fills as they are read (empty for code without these hooks)."""
    read: list[str] = []
    real_read = getattr(ec, "_read", None)
    if real_read is not None:

        def recording_read(path, file_key):
            read.append(os.path.realpath(path))
            return real_read(path, file_key)

        ec._read = recording_read
    checked = getattr(cc, "CheckedCache", None)
    if checked is not None:
        real_get = checked.get

        def recording_get(self, key):
            where = os.path.join(os.fspath(self._path), f"{key}{cc.CHECKED_KEY_SUFFIX}-cache")
            read.append(os.path.realpath(where))
            return real_get(self, key)

        checked.get = recording_get
    return read


def pin_code() -> str:
    """Take jaxstiff's code fingerprint (the forked runs inherit it: ``functools.cache``) and import
    the modules of the cached call, before the first fork: every run then reads the same traced
    program file, whatever happens to the sources on disk meanwhile (module docstring). The
    fingerprint."""
    import jaxstiff.ik  # noqa: F401 - imported for the forks (no backend is started by it)
    import jaxstiff.model._robot  # noqa: F401

    return ec.code_fingerprint()


def run_once(cache: str) -> tuple[int, dict | None]:
    """The cached call in a forked process: (exit status, or -signal; its record or None)."""
    r, w = os.pipe()
    pid = os.fork()
    if pid == 0:  # the child: no return from here
        code = 0
        try:
            os.close(r)
            _child(cache, w)
        except BaseException as e:  # noqa: BLE001 - any exception is a failure of the run
            print(f"child: {type(e).__name__}: {e}", file=sys.stderr)
            code = 1
        finally:
            os._exit(code)
    os.close(w)
    chunks = []
    deadline = time.monotonic() + TIMEOUT_S
    while True:  # a damaged program can also run for ever: killed at the deadline (exit -9)
        ready, _, _ = select.select([r], [], [], max(0.0, deadline - time.monotonic()))
        if not ready:
            os.kill(pid, signal.SIGKILL)
            break
        b = os.read(r, 1 << 16)
        if not b:
            break
        chunks.append(b)
    os.close(r)
    _, status = os.waitpid(pid, 0)
    rc = -os.WTERMSIG(status) if os.WIFSIGNALED(status) else os.WEXITSTATUS(status)
    data = b"".join(chunks)
    return rc, (json.loads(data) if data else None)


def offsets(size: int, n: int, seed: int) -> list[int]:
    """``n`` byte offsets: a third in the first 200 bytes (the header), the rest spread evenly
    over the file, each nudged by a random amount so that they do not fall on one stride."""
    rng = np.random.default_rng(seed)
    head = np.linspace(0, min(size, 200) - 1, max(1, n // 3)).astype(int)
    body = np.linspace(0, size - 1, n - len(head)).astype(int)
    body = np.clip(body + rng.integers(0, max(1, size // (2 * n)), len(body)), 0, size - 1)
    return sorted({int(x) for x in np.concatenate([head, body])})


def main() -> None:
    cache, n = sys.argv[1], int(sys.argv[2])
    edit = sys.argv[3] if len(sys.argv) > 3 else None
    pinned = pin_code()
    first = run_once(cache)  # fills both caches
    clean = run_once(cache)  # from the caches: the reference the damaged runs must give
    if edit:
        with open(edit, "a") as f:
            f.write("# edited while the runner runs\n")
    kinds = {
        "traced": sorted(
            os.path.join(cache, ec.EXPORT_SUBDIR, f)
            for f in os.listdir(os.path.join(cache, ec.EXPORT_SUBDIR))
            if f.endswith(".jaxexp")
        ),
        "compiled": sorted(os.path.join(cache, f) for f in os.listdir(cache) if f.endswith("-cache")),
    }
    pristine = cache + ".pristine"
    shutil.copytree(cache, pristine)
    import jaxstiff

    report = {
        "first": first,
        "clean": clean,
        "files": {k: len(v) for k, v in kinds.items()},
        "flips": {},
        "package": os.path.dirname(os.path.realpath(jaxstiff.__file__)),
        # the fingerprint every run used, and the one of the sources on disk now (another: they changed)
        "fingerprint": {"pinned": pinned, "on_disk": ec.code_fingerprint.__wrapped__()},
    }
    for seed, (kind, files) in enumerate(kinds.items()):
        rows = []
        for file in sorted(files, key=os.path.getsize)[-1:]:  # the kind's largest file: the IK program
            data = open(file, "rb").read()
            for off in offsets(len(data), n, seed):
                bit = off % 8
                shutil.rmtree(cache)
                shutil.copytree(pristine, cache)
                damaged = bytearray(data)
                damaged[off] ^= 1 << bit
                with open(file, "wb") as f:
                    f.write(damaged)
                rc, rec = run_once(cache)
                rows.append(
                    [
                        off,
                        bit,
                        rc,
                        None if rec is None else rec["q"],
                        None if rec is None else len(rec["warnings"]),
                        None if rec is None else rec["traced"],
                        None if rec is None else os.path.realpath(file) in rec["read"],
                    ]
                )
        report["flips"][kind] = rows
    # the last damaged run rewrote its entry: the next run reads it, no warning
    report["healed"] = run_once(cache)
    print(json.dumps(report))


if __name__ == "__main__":
    main()
