"""A damaged cache entry never crashes a run nor changes its result (issue 42).

Single bits are flipped at many offsets (header and payload) of each on-disk cache kind: the
traced programs (``jaxstiff-programs/*.jaxexp``) and the entries of JAX's compilation cache. After
each flip the cached call runs in its own process (``cache_damage_runner.py``): it must exit 0,
give the reference result bit for bit, and say once that it discarded the damaged entry (every
single-bit flip changes the checked bytes, so each one must be seen); each run records the cache
files it read, and the flipped one must be among them. The reference is the run from the intact
caches, and its q is checked independently by forward kinematics.

In-process checks: the header format (key, length, sha256) refuses each kind of damage before
deserialization; a whole file whose program does not deserialize or compile is replaced; JAX's
cache goes through :class:`~jaxstiff.runtime._compile_cache.CheckedCache`.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from helpers import REPO_ROOT

from jaxstiff.runtime import _compile_cache as cc
from jaxstiff.runtime import _export_cache as ec

RUNNER = os.path.join(os.path.dirname(__file__), "cache_damage_runner.py")


def _run_flips(tmp_path, n, edit=None, env=None):
    out = subprocess.run(
        [sys.executable, RUNNER, str(tmp_path / "cache"), str(n), *([str(edit)] if edit else [])],
        capture_output=True,
        text=True,
        timeout=1800,
        cwd=tmp_path,
        env=env,
    )
    assert out.returncode == 0, out.stderr[-3000:]
    return json.loads(out.stdout)


def _check_report(rep, n):
    from jaxstiff.model import Robot

    rc, clean = rep["clean"]
    assert rep["first"][0] == 0 and rc == 0
    assert clean["traced"] == 0 and clean["hits"] >= 1 and clean["warnings"] == []  # both caches were read
    q = np.frombuffer(bytes.fromhex(clean["q"]), dtype=np.float64)
    robot = Robot.from_urdf("planar_3r")
    np.testing.assert_allclose(np.asarray(robot.fk(q))[:2, 3], [1.2, 0.5], atol=1e-9)  # independent: FK
    assert rep["files"]["traced"] >= 1 and rep["files"]["compiled"] >= 1
    counts = {}
    for kind, rows in rep["flips"].items():
        assert len(rows) >= 0.8 * n, (kind, len(rows))
        assert any(off < 100 for off, *_ in rows)  # the header is hit too
        for off, bit, code, qhex, warned, traced, read in rows:
            where = f"{kind} byte {off} bit {bit}"
            assert code == 0, f"{where}: exit status {code}"
            assert read, f"{where}: the run did not read the flipped file"
            assert qhex == clean["q"], f"{where}: another result"
            assert warned == 1, f"{where}: {warned} damage warnings (every flip must be seen, once)"
            if kind == "traced":
                assert traced == 1, f"{where}: the program was not traced again"
        counts[kind] = len(rows)
    rc, healed = rep["healed"]
    assert rc == 0 and healed["warnings"] == [] and healed["q"] == clean["q"]
    return counts


def test_bit_flips_in_every_cache_kind_fast(tmp_path):
    """The fast lane's sample: 8 offsets per kind (about 20 s alone on a 2-core machine)."""
    counts = _check_report(_run_flips(tmp_path, 8), 8)
    assert set(counts) == {"traced", "compiled"}


@pytest.mark.slow
def test_bit_flips_in_every_cache_kind_many(tmp_path):
    """150 offsets per kind (about 5 minutes on a 2-core machine)."""
    counts = _check_report(_run_flips(tmp_path, 150), 150)
    print(f"bit flips run: {counts}")


@pytest.mark.slow
def test_bit_flips_seen_when_the_sources_change_during_the_run(tmp_path):
    """The fast lane once ran in a checkout that changed under it (a merge): a flip run after the
    change keyed the traced program by the new code fingerprint, traced it afresh beside the
    flipped file, never read that file and reported no damage. The runner takes the fingerprint
    once, before its forks: here it runs a copy of the package whose ik.py it edits after the
    reference run, and every flip must still be read and seen (about 15 s)."""
    import jaxstiff

    src = tmp_path / "src"
    shutil.copytree(os.path.dirname(jaxstiff.__file__), src / "jaxstiff", ignore=shutil.ignore_patterns("__pycache__"))
    shutil.copytree(REPO_ROOT / "urdf", src / "urdf")  # beside the package, as in a checkout
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(filter(None, [str(src), os.environ.get("PYTHONPATH")]))}
    rep = _run_flips(tmp_path, 3, edit=src / "jaxstiff" / "ik.py", env=env)
    assert rep["package"] == os.path.realpath(src / "jaxstiff")  # the copy ran, not the checkout
    assert rep["fingerprint"]["on_disk"] != rep["fingerprint"]["pinned"]  # the edit changed the key
    assert set(_check_report(rep, 3)) == {"traced", "compiled"}


# ---------------------------------------------------------------------- in-process
def test_header_refuses_each_kind_of_damage():
    payload = b"\x00program bytes\xff" * 10
    data = cc.pack("k" * 64, payload)
    assert cc.unpack(data, "k" * 64) == payload
    cases = {
        "no jaxstiff header": b"X" + data[1:],
        "another key": cc.pack("j" * 64, payload),
        "the header says": data[:-1],
        "sha256": data[:-1] + bytes([data[-1] ^ 1]),
        "cut short": data[: len(cc.MAGIC) + 10],
    }
    for why, bad in cases.items():
        with pytest.raises(ValueError, match=why):
            cc.unpack(bad, "k" * 64)


@pytest.fixture
def cache(tmp_path, restore_jax_cache, monkeypatch):
    monkeypatch.delenv(ec.EXPORT_ENV, raising=False)
    monkeypatch.setattr(cc, "_WARNED", set())
    jax.config.update("jax_compilation_cache_dir", str(tmp_path / "xla"))
    return tmp_path / "xla" / ec.EXPORT_SUBDIR


def _fn(x, a):
    return jnp.sin(x) * a + jnp.cumsum(x)


_NOT_A_PROGRAM = r"""
import os, sys, warnings
import jax
jax.config.update("jax_enable_x64", True)
import jax.numpy as jnp
import numpy as np
from jaxstiff.runtime import _compile_cache as cc
from jaxstiff.runtime import _export_cache as ec

os.environ.pop(ec.EXPORT_ENV, None)
jax.config.update("jax_compilation_cache_dir", os.path.join(sys.argv[1], "xla"))
cache = os.path.join(sys.argv[1], "xla", ec.EXPORT_SUBDIR)


def _fn(x, a):
    return jnp.sin(x) * a + jnp.cumsum(x)


x, a = np.linspace(-1.0, 2.0, 7), 1.5
want = np.sin(x) * a + np.cumsum(x)
ec.compile_with_export_cache(jax.jit(_fn), (x, a), "k1")
(name,) = os.listdir(cache)
file_key = name.removesuffix(".jaxexp")
path = os.path.join(cache, name)
# a file whose header checks (key, length, sha256) but whose program is not one
open(path, "wb").write(cc.pack(file_key, b"\x01" * 300))
with warnings.catch_warnings(record=True) as seen:
    warnings.simplefilter("always")
    comp = ec.compile_with_export_cache(jax.jit(_fn), (x, a), "k1")
assert any(issubclass(w.category, cc.CacheDamageWarning) and "cannot be deserialized" in str(w.message) for w in seen)
np.testing.assert_allclose(np.asarray(comp(x, a)), want, rtol=1e-14)
assert cc.unpack(open(path, "rb").read(), file_key)  # rewritten whole
# a second damage of the process: replaced, no second warning
open(path, "wb").write(b"garbage")
with warnings.catch_warnings(record=True) as seen:
    warnings.simplefilter("always")
    dj = ec.DiskJit(_fn, "k1")
    np.testing.assert_allclose(np.asarray(dj(x, np.float64(a))), want, rtol=1e-14)
assert not [w for w in seen if issubclass(w.category, cc.CacheDamageWarning)]
print("ok")
"""


def test_whole_file_that_does_not_deserialize_is_replaced_with_one_warning(tmp_path):
    """Run in its own process: the bytes handed to the deserializer here are not a program, and a
    native deserializer given garbage may corrupt memory that a later compile in the same test
    worker trips over (a worker once segfaulted inside XLA's compile later in the suite)."""
    run = subprocess.run(
        [sys.executable, "-c", _NOT_A_PROGRAM, str(tmp_path)], capture_output=True, text=True, timeout=300
    )
    assert run.returncode == 0 and run.stdout.strip().endswith("ok"), (run.returncode, run.stdout, run.stderr[-3000:])


def test_program_that_fails_to_compile_is_traced_again(cache, monkeypatch):
    x, a = np.linspace(-1.0, 2.0, 7), np.float64(1.5)
    want = np.sin(x) * a + np.cumsum(x)
    ec.DiskJit(_fn, "k2")(x, a)
    real = jax.export.deserialize

    class Broken:
        def __init__(self, exp):
            self.exp = exp

        def call(self, *args):
            raise RuntimeError("Failed to deserialize StableHLO")  # what a foreign program gives at lowering

    monkeypatch.setattr(jax.export, "deserialize", lambda b: Broken(real(b)))
    with pytest.warns(cc.CacheDamageWarning, match="does not compile"):
        out = ec.DiskJit(_fn, "k2")(x, a)
    np.testing.assert_allclose(np.asarray(out), want, rtol=1e-14)


def test_jax_cache_entries_carry_the_header(tmp_path, restore_jax_cache, monkeypatch):
    monkeypatch.setattr(cc, "_WARNED", set())
    folder = str(tmp_path / "xla")
    assert cc.enable_compile_cache(folder, min_compile_s=0.0) == folder

    def fresh():
        return jax.jit(lambda x: jnp.cumsum(jnp.cos(x)) * 2.0)

    x = np.linspace(0.0, 1.0, 13)
    want = np.cumsum(np.cos(x)) * 2.0
    np.testing.assert_allclose(np.asarray(fresh()(x)), want, rtol=1e-14)
    entries = [f for f in os.listdir(folder) if f.endswith(cc.CHECKED_KEY_SUFFIX + "-cache")]
    assert entries
    for f in entries:
        data = open(os.path.join(folder, f), "rb").read()
        assert data.startswith(cc.MAGIC)
        cc.unpack(data, f.removesuffix(cc.CHECKED_KEY_SUFFIX + "-cache"))
    # a damaged entry: removed, reported once, compiled again; same numbers
    path = os.path.join(folder, entries[0])
    data = bytearray(open(path, "rb").read())
    data[len(data) // 2] ^= 0x10
    open(path, "wb").write(data)
    with pytest.warns(cc.CacheDamageWarning, match="compilation cache entry"):
        np.testing.assert_allclose(np.asarray(fresh()(x)), want, rtol=1e-14)
