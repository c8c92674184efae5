"""Chunks of a batch run on several CPU threads at once (jaxstiff.runtime._threads, issue 23): the
chunk sizes and thread counts, results in order, and pgd's and the trajectory solver's results
bit-identical with one thread (one chunk) and with several (several chunks at once)."""

from __future__ import annotations

import threading
import time

import numpy as np
import pytest
from pgd_cases import OPTS

from jaxstiff.runtime import _threads as th


def test_chunk_rows():
    assert th.chunk_rows(1, 256, 2) == 2  # never a batch of 1
    assert th.chunk_rows(3, 256, 2) == 2
    assert th.chunk_rows(64, 256, 2) == 32
    assert th.chunk_rows(1000, 256, 2) == 256  # the memory bound wins
    assert th.chunk_rows(1000, 256, 16) == 63
    assert th.chunk_rows(5, 256, 1) == 5
    assert th.chunk_threads(3) == 3
    assert th.chunk_threads(0) >= 1


def test_usable_cores_follows_omp_num_threads(monkeypatch):
    monkeypatch.delenv("OMP_NUM_THREADS", raising=False)
    n = th.usable_cores()
    assert n >= 1
    monkeypatch.setenv("OMP_NUM_THREADS", "1")
    assert th.usable_cores() == 1
    monkeypatch.setenv("OMP_NUM_THREADS", "not a number")
    assert th.usable_cores() == n


def test_map_chunks_stops_queued_chunks_after_an_error():
    ran = []

    def work(i):
        ran.append(i)
        if i == 0:
            raise FloatingPointError("chunk 0")
        time.sleep(0.2)
        return i

    with pytest.raises(FloatingPointError, match="chunk 0"):
        th.map_chunks(work, list(range(8)), 2)
    assert len(ran) < 8  # the queued chunks were dropped


def test_map_chunks_keeps_order_and_runs_concurrently():
    seen = set()

    def slow(i):
        seen.add(threading.current_thread().name)
        time.sleep(0.05 * (5 - i))  # later items finish first
        return i * i

    assert th.map_chunks(slow, list(range(5)), 3) == [0, 1, 4, 9, 16]
    assert len(seen) > 1
    assert th.map_chunks(slow, [2], 4) == [4]


@pytest.mark.filterwarnings("ignore::jaxstiff.results._target.MissedTargetWarning")
@pytest.mark.parametrize("solver", ["pgd", pytest.param("trajectory", marks=pytest.mark.slow)])  # pgd: the fast lane
def test_results_do_not_depend_on_the_thread_count(solver, planar_paths, run_planar):
    path, q0 = planar_paths(5, 4, seed=5)
    opts = {**OPTS, **({"traj_iters": 40, "blocks": 2} if solver == "trajectory" else {})}
    one = run_planar(path, q0, solver=solver, options={**opts, "threads": 1})
    many = run_planar(path, q0, solver=solver, options={**opts, "threads": 3})  # chunks of 2: 3 at once
    for k in ("q", "kj", "criterion", "status", "pos_error"):
        np.testing.assert_array_equal(getattr(many, k), getattr(one, k), err_msg=k)
    assert np.all(np.isfinite(one.criterion))


def test_map_chunks_runs_workers_under_the_callers_x64_setting():
    import jax
    import jax.numpy as jnp

    for x64, want in ((False, "float32"), (True, "float64")):
        with jax.enable_x64(x64):  # thread-local: a bare worker thread would see the global flag
            got = th.map_chunks(lambda _: str(jnp.zeros(1, dtype=float).dtype), list(range(4)), 2)
        assert got == [want] * 4
