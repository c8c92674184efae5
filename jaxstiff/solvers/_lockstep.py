"""Many sequential solves advanced in lockstep, their kernel evaluations batched into one call.

A per-waypoint SLSQP solve asks for one kernel evaluation per iteration (reverse communication,
:func:`jaxstiff.solvers._slsqp.make_slsqp_solver`'s ``steps``). Solving B paths one after another
pays B x (iterations) small kernel calls, each mostly dispatch overhead (tens of microseconds for
a few microseconds of arithmetic). Written as generators that ``yield`` their evaluation requests,
the B solves advance together instead: each round collects every pending request and evaluates
them in one vmapped call. Each generator still runs its own, unchanged, sequential logic.

Protocol: a generator yields a request ``(y (nx,), params (np,))`` and is sent back the kernel's
output row for it; its return value is the solve's result.
"""

from __future__ import annotations

import threading
from collections.abc import Callable, Generator, Sequence
from typing import Any, TypeVar

import numpy as np

__all__ = ["Request", "bucket_size"]

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
    """Rows of a batched call for ``rows`` requests: 16, 128, 1024, ... (padded: few compiled
    sizes, each a few seconds of compilation; a call costs nearly the same at 2 and at 64 rows on
    a CPU: docs/notes/speed.md). Never fewer than 16: XLA:CPU compiles a row count below the
    vector width differently, and a row's result at 2 rows differed in the last bits from the same
    row's at 16, 128 and 1024 (on 6 % of the LWR's evaluations; those three agreed on all of them),
    so that a result depended on which compiled row count answered, a matter of timing
    (:class:`RowsProgram`)."""
    size = 16
    while size < rows:
        size *= 8
    return size


class RowsProgram:
    """A jitted rows kernel ``fn(Y (R, nx), params (R, np), *consts) -> (R, out)`` compiled per
    row count R, where a row count not compiled yet does not hold up the caller: the first row
    count is compiled at once; a later, smaller one is compiled on a background thread while the
    calls go, padded, to the smallest row count already compiled above it (:meth:`rows_for`).

    A lockstep run starts with many paths (128 rows for 17-128 of them) and ends with a few (16,
    then 2): compiled in turn, each of those programs held the run up 2-3 s on a 2-core CPU (7 s
    of a cold 64 x 50 hybrid). A row's result has the same bits at every R >= 16
    (:func:`bucket_size`), so which program answers a request does not change the result.
    """

    def __init__(self, fn: Any, *consts: Any, dtype: Any = np.float64):
        self._fn, self._consts, self._dtype = fn, consts, dtype
        self._ready: dict[int, Callable[..., Any]] = {}
        self._building: set[int] = set()
        self._lock = threading.Lock()

    def _compile(self, R: int, nx: int, n_params: int, x64: bool) -> None:
        import jax

        with jax.enable_x64(x64):
            specs = (jax.ShapeDtypeStruct((R, nx), self._dtype), jax.ShapeDtypeStruct((R, n_params), self._dtype))
            compiled = self._fn.lower(*specs, *self._consts).compile()
        with self._lock:
            self._ready[R] = compiled

    def _background(self, R: int, nx: int, n_params: int, x64: bool) -> None:
        try:
            self._compile(R, nx, n_params, x64)
        except Exception:  # noqa: BLE001 - a failed build only means the larger program keeps answering
            pass

    def rows_for(self, R: int, nx: int, n_params: int) -> int:
        """The row count to call for a round of ``R`` rows (a :func:`bucket_size`): R when its
        program is ready or no larger one is (then R is compiled now), else the smallest ready
        larger row count while R's program is built on a background thread."""
        import jax

        with self._lock:
            ready = sorted(self._ready)
            if R in self._ready:
                return R
            larger = [r for r in ready if r > R]
            start = bool(larger) and R not in self._building
            if start:
                self._building.add(R)
        x64 = bool(jax.config.read("jax_enable_x64"))
        if not larger:
            self._compile(R, nx, n_params, x64)
            return R
        if start:
            # not a daemon: the interpreter waits for it at exit (a daemon thread stopped by the
            # interpreter's finalisation inside JAX's lowering or XLA's compiler aborted the
            # process, exit status 134, after a script's cold hybrid solve)
            threading.Thread(
                target=self._background, args=(R, nx, n_params, x64), name=f"RowsProgram-{R}", daemon=False
            ).start()
        return larger[0]

    def __call__(self, Y: np.ndarray, params: np.ndarray) -> Any:
        return self._ready[len(Y)](Y, params, *self._consts)


def run_lockstep(
    gens: Sequence[Generator[Request, np.ndarray, Any]],
    evaluate: Callable[[np.ndarray, np.ndarray], Any],
) -> list[Any]:
    """Advance every generator until all have ended; each round evaluates all pending requests in
    one call ``evaluate(Y (R, nx), params (R, np)) -> (R, out)`` (R a :func:`bucket_size`, or, for
    a :class:`RowsProgram`, the row count its :meth:`~RowsProgram.rows_for` gives; the rows
    beyond the requests repeat the last one). Returns the generators' results, in order. An
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
            if isinstance(evaluate, RowsProgram):
                req = pending[idx[0]]
                R = evaluate.rows_for(R, len(req[0]), len(req[1]))
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
