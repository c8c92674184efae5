"""The persistent compilation cache (jaxstiff.runtime._compile_cache) in one process: files appear
in the folder once it is on, none once it is off, a cache the user configured is left alone; and
CompileClock's union of time spans against a brute-force count, and against real compilations."""

import os

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from jax import monitoring

from jaxstiff.runtime import _compile_cache as cc


def _compile_new_program(tag: float) -> None:
    """A program no earlier call compiled (the constant is part of the HLO)."""
    jax.jit(lambda x: jnp.sin(x) * tag + jnp.cumsum(x))(np.arange(5.0)).block_until_ready()


def test_cache_on_writes_files_off_writes_none(tmp_path, restore_jax_cache):
    jax.config.update("jax_compilation_cache_dir", None)
    on = tmp_path / "on"
    assert cc.enable_compile_cache(str(on), min_compile_s=0.0) == str(on)
    assert cc.cache_dir_in_use() == str(on)
    _compile_new_program(1.2345)
    n_on = len(os.listdir(on))
    assert n_on >= 1
    assert cc.enable_compile_cache(None) is None  # turns off the cache it turned on
    assert cc.cache_dir_in_use() is None
    _compile_new_program(2.3456)
    assert len(os.listdir(on)) == n_on


def test_ensure_follows_the_environment(tmp_path, restore_jax_cache, monkeypatch):
    jax.config.update("jax_compilation_cache_dir", None)
    monkeypatch.setenv(cc.CACHE_DIR_ENV, str(tmp_path / "moved"))
    assert cc.ensure_compile_cache() == str(tmp_path / "moved")
    assert cc.ensure_compile_cache() == str(tmp_path / "moved")  # idempotent
    monkeypatch.setenv(cc.CACHE_ENV, "off")
    assert cc.ensure_compile_cache() is None and cc.cache_dir_in_use() is None
    with cc.compile_cache_flags(path=str(tmp_path / "flag")) as d:  # env still says off: off wins
        assert d is None and os.environ[cc.CACHE_DIR_ENV] == str(tmp_path / "flag")
    assert os.environ[cc.CACHE_DIR_ENV] == str(tmp_path / "moved")  # restored after the command
    monkeypatch.delenv(cc.CACHE_ENV)
    with cc.compile_cache_flags(off=True) as d:
        assert d is None
    with cc.compile_cache_flags(path=str(tmp_path / "flag")) as d:
        assert d == str(tmp_path / "flag") and os.path.isdir(tmp_path / "flag")


def test_a_cache_of_the_users_own_is_left_alone(tmp_path, restore_jax_cache):
    mine = str(tmp_path / "users")
    jax.config.update("jax_compilation_cache_dir", mine)
    assert cc.enable_compile_cache(str(tmp_path / "ours")) == mine
    assert cc.enable_compile_cache(None) == mine  # off does not touch the user's own either
    assert cc.cache_dir_in_use() == mine
    assert not (tmp_path / "ours").exists()


def test_an_unwritable_folder_is_skipped(tmp_path, restore_jax_cache):
    jax.config.update("jax_compilation_cache_dir", None)
    blocker = tmp_path / "file"
    blocker.write_text("x")
    assert cc.enable_compile_cache(str(blocker / "sub")) is None
    assert cc.cache_dir_in_use() is None


def _union_brute_force(spans, t0, t1, step=1e-3):
    grid = np.arange(t0, t1, step) + step / 2
    inside = np.zeros(grid.shape, bool)
    for a, b in spans:
        inside |= (grid >= a) & (grid < b)
    return inside.sum() * step


def test_clock_counts_nested_and_overlapping_spans_once():
    ev = cc.COMPILE_EVENTS
    spans = [(1.0, 3.0), (1.5, 2.0), (2.5, 4.0), (6.0, 6.5), (5.0, 5.2), (6.1, 6.2)]
    with cc.CompileClock() as clock:
        for i, (a, b) in enumerate(spans):
            monitoring.record_event_time_span(ev[i % 3], a, b, fun_name="synthetic")
        monitoring.record_event_time_span("/jax/some/other/event", 10.0, 20.0)  # not compilation
    monitoring.record_event_time_span(ev[0], 30.0, 40.0)  # after the block: not counted
    assert clock.seconds == pytest.approx(_union_brute_force(spans, 0, 8), abs=2e-3)
    assert clock.seconds_between(2.0, 5.1) == pytest.approx(_union_brute_force(spans, 2.0, 5.1), abs=2e-3)
    assert clock.programs == 2  # two spans of the backend-compile event
    meta = clock.meta()
    assert meta["programs"] == 2 and "backend_compile" in meta["measured"]


def test_clock_sees_a_real_compilation_and_not_a_cached_call():
    f = jax.jit(lambda x: jnp.tanh(x) * 0.5 + 3.25)
    x = np.linspace(0, 1, 11)
    with cc.CompileClock() as first:
        f(x).block_until_ready()
    assert first.programs == 1 and first.seconds > 0.0
    with cc.CompileClock() as again:
        f(x).block_until_ready()
    assert again.programs == 0 and again.seconds == 0.0
