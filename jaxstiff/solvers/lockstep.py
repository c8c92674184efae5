"""Many sequential solves advanced in lockstep, their kernel evaluations batched into one call.

A per-waypoint SLSQP solve asks for one kernel evaluation per iteration (reverse communication,
:func:`jaxstiff.solvers.slsqp.make_slsqp_solver`'s ``steps``). Solving B paths one after another
pays B x (iterations) small kernel calls, each mostly dispatch overhead (tens of microseconds for
a few microseconds of arithmetic). Written as generators that ``yield`` their evaluation requests,
the B solves advance together instead: each round collects every pending request and evaluates
them in one vmapped call. Each generator still runs its own, unchanged, sequential logic.

Protocol: a generator yields a request ``(y (nx,), params (np,))`` and is sent back the kernel's
output row for it; its return value is the solve's result.
"""

from __future__ import annotations

from collections.abc import Callable, Generator, Sequence
from typing import Any, TypeVar

import numpy as np

__all__ = ["Request", "Steps", "run_steps", "run_lockstep", "bucket_size"]

#: one evaluation request: the point and the waypoint's parameters
Request = tuple[np.ndarray, np.ndarray]
T = TypeVar("T")
Q = TypeVar("Q")
A = TypeVar("A")
#: a solve written as a generator of requests (sent the kernel's output) returning ``T``
Steps = Generator[Request, np.ndarray, T]


def run_steps(gen: Generator[Q, A, T], evaluate: Callable[[Q], A]) -> T:
    """Drive one generator to its end, sending back ``evaluate(request)`` for each request it
    yields; its result (any request/answer types: also SLSQP's own reverse-communication loop)."""
    try:
        req = next(gen)
        while True:
            req = gen.send(evaluate(req))
    except StopIteration as stop:
        return stop.value


def bucket_size(rows: int) -> int:
    """Rows of a batched call for ``rows`` requests: 2, 16, 128, 1024, ... (padded: few compiled
    sizes, each a few seconds of compilation, and never 1, which XLA compiles differently; a call
    costs nearly the same at 2 and at 64 rows on a CPU: docs/notes/speed.md)."""
    size = 2
    while size < rows:
        size *= 8
    return size


def run_lockstep(
    gens: Sequence[Generator[Request, np.ndarray, Any]],
    evaluate: Callable[[np.ndarray, np.ndarray], Any],
) -> list[Any]:
    """Advance every generator until all have ended; each round evaluates all pending requests in
    one call ``evaluate(Y (R, nx), params (R, np)) -> (R, out)`` (R a :func:`bucket_size`, the
    rows beyond the requests repeat the last one). Returns the generators' results, in order. An
    exception raised by a generator propagates (the others are closed)."""
    results: list[Any] = [None] * len(gens)
    pending: dict[int, Request] = {}

    def advance(i: int, value: np.ndarray | None) -> None:
        try:
            pending[i] = next(gens[i]) if value is None else gens[i].send(value)
        except StopIteration as stop:
            pending.pop(i, None)
            results[i] = stop.value

    try:
        for i in range(len(gens)):
            advance(i, None)
        while pending:
            idx = list(pending)
            R = bucket_size(len(idx))
            rows = idx + [idx[-1]] * (R - len(idx))
            Y = np.stack([pending[i][0] for i in rows])
            Pm = np.stack([pending[i][1] for i in rows])
            out = np.asarray(evaluate(Y, Pm))
            for j, i in enumerate(idx):
                advance(i, out[j])
    finally:
        for g in gens:
            g.close()
    return results
