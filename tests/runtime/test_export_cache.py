"""Traced programs kept on disk (jaxstiff.runtime._export_cache): a second compile of the same key
and shapes reads the file instead of tracing (a trace counter in the function proves it), gives
the function's values (against numpy), and every ingredient of the key (caller's key, shapes,
jaxstiff's code) leads to its own file; damaged files are replaced; key None and the environment
switch leave no file. End to end: pgd from the file gives the same bits as pgd traced anew, and
matches pgd without the cache; and the problem fingerprint follows the problem's content."""

from __future__ import annotations

import os

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxstiff
from jaxstiff.runtime import _export_cache as ec
from jaxstiff.shaping import run_shape
from jaxstiff.solvers._pgd import batch as pgd_batch
from jaxstiff.solvers._problem import WaypointProblem


@pytest.fixture
def cache(tmp_path, restore_jax_cache, monkeypatch):
    monkeypatch.delenv(ec.EXPORT_ENV, raising=False)
    monkeypatch.setattr("jaxstiff.runtime._compile_cache._WARNED", set())  # each test sees its first warning
    jax.config.update("jax_compilation_cache_dir", str(tmp_path / "xla"))
    return tmp_path / "xla" / ec.EXPORT_SUBDIR


class Counted:
    """``sin(x) * a + cumsum(x)``, counting how often it is traced. :meth:`jit` wraps a new
    function object each time, so JAX's in-memory trace cache (keyed by the function) never
    answers: only the file can spare a trace."""

    def __init__(self):
        self.traces = 0

    def jit(self):
        def fn(x, a):
            self.traces += 1
            return {"y": jnp.sin(x) * a + jnp.cumsum(x), "n": jnp.sum(x > 0)}

        return jax.jit(fn)


def _expected(x, a):
    return np.sin(x) * a + np.cumsum(x), np.sum(x > 0)


def _files(folder):
    return sorted(p for p in os.listdir(folder) if p.endswith(".jaxexp")) if folder.exists() else []


def _check(comp, x, a):
    out = comp(x, a)
    y, n = _expected(np.asarray(x), float(a))
    np.testing.assert_allclose(np.asarray(out["y"]), y, rtol=1e-14, atol=1e-14)
    assert int(out["n"]) == n


def test_second_compile_reads_the_file_instead_of_tracing(cache):
    f = Counted()
    x, a = np.linspace(-1.0, 2.0, 7), 1.5
    _check(ec.compile_with_export_cache(f.jit(), (x, a), "k1"), x, a)
    assert f.traces == 1 and len(_files(cache)) == 1
    # a fresh jit (no in-memory trace cache): the program comes from the file, f is not traced
    _check(ec.compile_with_export_cache(f.jit(), (x, a), "k1"), x, a)
    assert f.traces == 1 and len(_files(cache)) == 1
    # the argument values are inputs, not part of the program
    _check(ec.compile_with_export_cache(f.jit(), (x * 3.0, -2.0), "k1"), x * 3.0, -2.0)
    assert f.traces == 1


def test_each_part_of_the_key_gets_its_own_file(cache, monkeypatch):
    f = Counted()
    x, a = np.linspace(-1.0, 2.0, 7), 1.5
    ec.compile_with_export_cache(f.jit(), (x, a), "k1")
    ec.compile_with_export_cache(f.jit(), (x, a), "k2")  # another caller key
    x9 = np.linspace(-1.0, 2.0, 9)
    _check(ec.compile_with_export_cache(f.jit(), (x9, a), "k1"), x9, a)  # another shape
    assert f.traces == 3 and len(_files(cache)) == 3
    monkeypatch.setattr(ec, "code_fingerprint", lambda: "jaxstiff's code changed")
    ec.compile_with_export_cache(f.jit(), (x, a), "k1")
    assert f.traces == 4 and len(_files(cache)) == 4


def test_damaged_file_is_replaced(cache):
    f = Counted()
    x, a = np.linspace(-1.0, 2.0, 7), 1.5
    ec.compile_with_export_cache(f.jit(), (x, a), "k1")
    (name,) = _files(cache)
    (cache / name).write_bytes(b"not a program")
    with pytest.warns(ec.CacheDamageWarning, match="no jaxstiff header"):
        _check(ec.compile_with_export_cache(f.jit(), (x, a), "k1"), x, a)
    assert f.traces == 2
    assert (cache / name).read_bytes() != b"not a program"
    ec.compile_with_export_cache(f.jit(), (x, a), "k1")
    assert f.traces == 2  # the replacement is read


def test_no_key_or_switched_off_writes_nothing(cache, monkeypatch):
    f = Counted()
    x, a = np.linspace(-1.0, 2.0, 7), 1.5
    _check(ec.compile_with_export_cache(f.jit(), (x, a), None), x, a)
    monkeypatch.setenv(ec.EXPORT_ENV, "0")
    assert ec.export_dir() is None
    _check(ec.compile_with_export_cache(f.jit(), (x, a), "k1"), x, a)
    assert f.traces == 2 and _files(cache) == []


def test_off_without_a_compilation_cache(restore_jax_cache, tmp_path):
    jax.config.update("jax_compilation_cache_dir", None)
    assert ec.export_dir() is None


def test_problem_fingerprint_follows_the_content():
    a = jaxstiff.Robot.from_urdf("kuka_lwr4", locked={"lwr_a7": 0.0})
    b = jaxstiff.Robot.from_urdf("kuka_lwr4", locked={"lwr_a7": 0.0})
    assert a is not b and a.fingerprint() == b.fingerprint()
    assert a.fingerprint() != a.with_tcp([0.0, 0.0, 0.1]).fingerprint()
    assert a.fingerprint() != a.with_locked({"lwr_a7": 0.1}).fingerprint()
    pa = WaypointProblem(a, "full", jaxstiff.f2)
    assert pa.fingerprint() == WaypointProblem(b, "full", jaxstiff.f2).fingerprint()
    others = [
        WaypointProblem(a, "xyz", jaxstiff.f2),
        WaypointProblem(a, "full", jaxstiff.f1),
        WaypointProblem(a, "full", jaxstiff.f2, locked_joints="spring"),
    ]
    assert len({pa.fingerprint(), *(p.fingerprint() for p in others)}) == 4
    # a user's own criterion cannot be keyed by content: no disk cache for it
    assert WaypointProblem(a, "full", lambda K, d, r: jaxstiff.f2(K, d, r)).fingerprint() is None


@pytest.mark.slow  # pgd's whole program compiled twice; the fast lane checks the file format with smaller programs
@pytest.mark.filterwarnings("ignore::jaxstiff.results._target.MissedTargetWarning")  # not about targets
def test_pgd_from_the_file_equals_pgd_traced(cache, monkeypatch):
    robot = jaxstiff.Robot.from_urdf("planar_3r")
    q = np.array([[0.3, 0.9, -0.6], [0.1, 0.7, -0.4]])
    s = np.linspace(0.0, 1.0, 4)
    Q = q[:, None, :] + s[None, :, None] * np.array([0.1, -0.1, 0.05])
    pts = np.asarray(jax.vmap(jax.vmap(lambda qq: robot.fk(qq)[:3, 3]))(jnp.asarray(Q)))
    opts = {"iters": 9, "iters_first": 13, "starts_first": 4, "chunk": 2}

    def run():
        pgd_batch.compiled_kernel.cache_clear()  # no in-memory program: trace, or read the file
        res = run_shape(robot, pts, "f2", 3.0, task="xy", solver="pgd", starts=3, q0=q, dq=0.1, options=opts)
        return np.concatenate([res.q.ravel(), res.kj.ravel(), res.criterion.ravel()])

    first = run()
    assert len(_files(cache)) >= 1  # pgd's kernel (and the IK's and the report's programs)

    def no_tracing(*a, **k):
        raise AssertionError("traced although the program is on disk")

    with monkeypatch.context() as m:
        m.setattr(jax.export, "export", no_tracing)
        second = run()
    np.testing.assert_array_equal(second, first)
    monkeypatch.setenv(ec.EXPORT_ENV, "0")
    plain = run()
    np.testing.assert_allclose(plain, first, rtol=1e-12, atol=1e-12)
    assert np.all(np.isfinite(first))


def test_disk_jit_one_program_per_signature_and_from_the_file(cache):
    f = Counted()
    fn = getattr(f.jit(), "__wrapped__")  # noqa: B009 - the plain function (a new object: no shared trace cache)
    x, a = np.linspace(-1.0, 2.0, 7), np.float64(1.5)
    dj = ec.DiskJit(fn, "dj")
    _check(dj, x, a)
    _check(dj, x * 2.0, np.float64(-1.0))  # same signature: no new program
    assert f.traces == 1 and dj._cache_size() == 1 and len(_files(cache)) == 1
    _check(dj, jnp.asarray(x), a)  # a JAX array instead of numpy: another signature, same file
    assert len(_files(cache)) == 1
    x5 = np.linspace(0.0, 1.0, 5)
    _check(dj, x5, a)  # another shape: another program and file
    assert len(_files(cache)) == 2
    traces = f.traces
    _check(ec.DiskJit(fn, "dj"), x5, a)  # a new DiskJit (a later process): read, not traced
    assert f.traces == traces
    plain = ec.DiskJit(fn, None)  # no key: jax.jit, nothing written
    _check(plain, np.linspace(0.0, 1.0, 11), a)
    assert len(_files(cache)) == 2 and plain._cache_size() == 1


def test_disk_jit_specialize_is_the_program_it_calls(cache):
    f = Counted()
    fn = getattr(f.jit(), "__wrapped__")  # noqa: B009 - (untyped in the stubs)
    x, a = np.linspace(-1.0, 2.0, 7), np.float64(1.5)
    dj = ec.DiskJit(fn, "spec")
    kernel = dj.specialize(x, a)  # traced (and written) here, not at the first call
    assert f.traces == 1 and len(_files(cache)) == 1
    _check(kernel, x * 3.0, np.float64(0.25))  # the direct call computes what the function does
    assert dj.specialize(x + 1.0, a) is kernel  # one lookup per signature, the same program
    _check(dj, x, a)
    assert f.traces == 1 and dj._cache_size() == 1
    assert dj.specialize(np.linspace(0.0, 1.0, 5), a) is not kernel  # another shape, another program
    assert ec.DiskJit(fn, None).specialize(x, a) is not None


def test_ik_and_solver_kernels_equal_with_and_without_the_file(cache, monkeypatch):
    from jaxstiff.ik import ik_position, ik_program

    robot = jaxstiff.Robot.from_urdf("kuka_lwr4", locked={"lwr_a7": 0.0})
    target = np.array([0.45, 0.1, 0.55])
    ik_program.cache_clear()
    q1, e1 = ik_position(robot, target)
    assert len(_files(cache)) == 1 and e1 < 1e-9
    monkeypatch.setenv(ec.EXPORT_ENV, "0")
    ik_program.cache_clear()
    q0, e0 = ik_position(robot, target)
    np.testing.assert_array_equal(q1, q0)
    # the independent check: forward kinematics puts the TCP on the target
    np.testing.assert_allclose(np.asarray(robot.fk(q1))[:3, 3], target, atol=1e-9)
