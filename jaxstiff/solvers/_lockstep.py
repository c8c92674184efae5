"""Many sequential solves advanced in lockstep, their kernel evaluations batched into one call.

A per-waypoint SLSQP solve asks for one kernel evaluation per iteration (reverse communication,
:func:`jaxstiff.solvers._slsqp.make_slsqp_solver`'s ``steps``). Solving B paths one after another
pays B x (iterations) small kernel calls, each mostly dispatch overhead (tens of microseconds for
a few microseconds of arithmetic). Written as generators that ``yield`` their evaluation requests,
the B solves advance together instead: each round collects every pending request and evaluates
them in one vmapped call. Each generator still runs its own, unchanged, sequential logic.

Protocol: a generator yields a request ``(y (nx,), params (np,))`` and is sent back the kernel's
output row for it; its return value is the solve's result. A generator may also yield
:class:`Many` requests at once (the independent solves of one waypoint, :func:`gather`): they
are answered in the same round, and it is sent back the list of their rows. A path's chain of
rounds is then as long as its longest solve, not the sum of them: when few paths are left, a
round costs the same for 1 row as for 16, so the rounds, not the rows, set the time.
"""

from __future__ import annotations

import threading
from collections.abc import Callable, Generator, Sequence
from typing import Any, TypeVar

import numpy as np

__all__ = ["Many", "Request", "bucket_size", "gather"]

#: one evaluation request: the point and the waypoint's parameters
Request = tuple[np.ndarray, np.ndarray]
T = TypeVar("T")
Q = TypeVar("Q")
A = TypeVar("A")


class Many(list):
    """Several requests (each a :data:`Request` or, nested, a :class:`Many`) that one generator
    yields at once; it is sent back the list of their answers, in order (:func:`gather`)."""


#: a solve written as a generator of requests (sent the kernel's output row, or for :class:`Many`
#: requests the list of their answers) returning ``T``
Steps = Generator[Request | Many, Any, T]


def _flatten(item: Request | Many, into: list[Request]) -> None:
    """Append the requests of ``item`` (a request, or a nest of :class:`Many`) to ``into``."""
    if not isinstance(item, Many):
        into.append(item)
        return
    for sub in item:  # plain requests without a call each: a round holds hundreds of them
        if isinstance(sub, Many):
            _flatten(sub, into)
        else:
            into.append(sub)


def _answers(item: Request | Many, rows: Any, at: int) -> tuple[Any, int]:
    """The answer to ``item`` from the output ``rows`` starting at row ``at`` (:func:`_flatten`'s
    order): a row, or for a :class:`Many` the list of its answers; and the next row's index."""
    if not isinstance(item, Many):
        return rows[at], at + 1
    out = []
    for sub in item:
        if isinstance(sub, Many):
            ans, at = _answers(sub, rows, at)
            out.append(ans)
        else:
            out.append(rows[at])
            at += 1
    return out, at


def gather(gens: Sequence[Generator[Any, Any, T]]) -> Generator[Many, list[Any], list[T]]:
    """Run independent generators of requests side by side inside one lockstep generator
    (``results = yield from gather([...])``): each round yields all their pending requests as one
    :class:`Many`; returns their results, in order. Each generator sees the answers it would see
    alone, up to the rare last-bit differences of a row's place in a call (:class:`RowsProgram`)."""
    results: list[Any] = [None] * len(gens)
    pending: dict[int, Any] = {}
    sends: Any = [(i, None) for i in range(len(gens))]  # sending None starts a generator
    try:
        while True:
            for i, out in sends:  # once per request and round: no helper call
                try:
                    pending[i] = gens[i].send(out)
                except StopIteration as stop:
                    pending.pop(i, None)
                    results[i] = stop.value
            if not pending:
                break
            idx = list(pending)
            outs = yield Many(pending.values())  # a dict keeps its keys' order: idx's
            sends = zip(idx, outs, strict=True)
    finally:
        for g in gens:
            g.close()
    return results


def run_steps(gen: Generator[Q, A, T], evaluate: Callable[[Q], A]) -> T:
    """Drive one generator to its end, sending back ``evaluate(request)`` for each request it
    yields (for :class:`Many` requests, the list of their answers, one by one); its result (any
    request/answer types: also SLSQP's own reverse-communication loop)."""

    def answer(req: Any) -> Any:
        return [answer(r) for r in req] if isinstance(req, Many) else evaluate(req)

    try:
        req = next(gen)
        while True:
            req = gen.send(answer(req))
    except StopIteration as stop:
        return stop.value


#: the largest compiled row count: a round of more requests runs in calls of this many rows
MAX_ROWS = 128


def bucket_size(rows: int) -> int:
    """Rows of a batched call for ``rows`` requests: 16 or 128, above that the next multiple of
    :data:`MAX_ROWS` (a :class:`RowsProgram` evaluates those in calls of 128 rows, on as many
    threads as the machine has cores). Padded: few compiled sizes, each a few seconds of
    compilation, and a call costs nearly the same at 2 and at 16 rows on a CPU
    (docs/notes/speed.md). Never fewer than 16: XLA:CPU compiles a row count below the vector
    width differently, and a row's result at 2 rows differed in the last bits from the same row's
    at 16, 128 and 1024 (on 6 % of the LWR's evaluations; those three agreed on all of them), so
    that a result depended on which compiled row count answered, a matter of timing
    (:class:`RowsProgram`). No program above 128 rows: on a 2-core CPU a 1024-row call (UR10)
    took 1.74 ms against 1.40 ms for its eight 128-row pieces on two threads, and compiled for
    as long as the 128-row program (1.7-2.3 s) in the cold first call of a batch solve."""
    if rows <= 16:
        return 16
    return MAX_ROWS * -(-int(rows) // MAX_ROWS)


class RowsProgram:
    """A jitted rows kernel ``fn(Y (R, nx), params (R, np), *consts) -> (R, out)`` compiled per
    row count R, where a row count not compiled yet does not hold up the caller: the first row
    count is compiled at once; a later, smaller one is compiled on a background thread while the
    calls go, padded, to the smallest row count already compiled above it (:meth:`rows_for`).

    A lockstep run starts with many paths (128 rows for 17-128 of them) and ends with a few (16):
    compiled in turn, each program would hold the run up 2-3 s on a 2-core CPU. A row's result has
    the same bits at every R >= 16 (:func:`bucket_size`) almost everywhere, so which program answers
    a request does not change the result. Not everywhere: on 256 random postures, stiffnesses and
    targets of the LWR and the UR10, 1 to 4 rows had other last bits in some gradient entries (f
    agreed) between a 16- and a 128-row call, or at another place in the same call, all of them
    at strongly elongated ellipsoids (f from 20 to 1e4). A lockstep result is the same for the
    same rounds; rounds grouped otherwise (a change of schedule, or a smaller program ready
    earlier or later) can change the last bits of a solve that meets such a point, and from there
    its path. :meth:`prepare` starts a build early, for a caller with an idle core.
    """

    def __init__(self, fn: Any, *consts: Any, dtype: Any = np.float64):
        self._fn, self._consts, self._dtype = fn, consts, dtype
        self._ready: dict[int, Callable[..., Any]] = {}
        self._building: dict[int, threading.Event] = {}  # row count -> set when its build ends
        self._failed: set[int] = set()  # background builds that raised: not started again
        self._lock = threading.Lock()

    def _compile(self, R: int, nx: int, n_params: int, x64: bool) -> None:
        import jax

        with jax.enable_x64(x64):
            specs = (jax.ShapeDtypeStruct((R, nx), self._dtype), jax.ShapeDtypeStruct((R, n_params), self._dtype))
            compiled = self._fn.lower(*specs, *self._consts).compile()
        with self._lock:
            self._ready[R] = compiled

    def _background(self, R: int, nx: int, n_params: int, x64: bool, done: threading.Event) -> None:
        try:
            self._compile(R, nx, n_params, x64)
        except Exception:  # noqa: BLE001 - a failed build: the caller that needs it compiles it and sees the error
            with self._lock:
                self._failed.add(R)
        finally:
            with self._lock:
                self._building.pop(R, None)
            done.set()

    def _start_build(self, R: int, nx: int, n_params: int) -> None:
        """Build R's program on a background thread unless it is ready or being built."""
        import jax

        with self._lock:
            if R in self._ready or R in self._building or R in self._failed:
                return
            done = self._building[R] = threading.Event()
        x64 = bool(jax.config.read("jax_enable_x64"))
        # not a daemon: the interpreter waits for it at exit (a daemon thread stopped by the
        # interpreter's finalisation inside JAX's lowering or XLA's compiler aborted the process,
        # exit status 134, after a script's cold hybrid solve)
        threading.Thread(
            target=self._background, args=(R, nx, n_params, x64, done), name=f"RowsProgram-{R}", daemon=False
        ).start()

    def prepare(self, R: int, nx: int, n_params: int) -> None:
        """Start building the program a round of ``R`` rows will call (:func:`bucket_size`'s row
        count, at most :data:`MAX_ROWS`) on a background thread, for a caller that knows it may
        need it soon and has a core idle meanwhile; :meth:`rows_for` then waits for that build
        instead of starting its own."""
        self._start_build(min(bucket_size(R), MAX_ROWS), nx, n_params)

    def rows_for(self, R: int, nx: int, n_params: int) -> int:
        """The row count to call for a round of ``R`` rows (a :func:`bucket_size`): R when its
        program is ready; else the smallest ready larger row count while R's program is built on
        a background thread; else R, once its program is built (here, or by a build already under
        way). Above :data:`MAX_ROWS`, R itself (called in pieces of 128 rows, whose program this
        builds)."""
        size = min(int(R), MAX_ROWS)
        with self._lock:
            if size in self._ready:
                return max(size, int(R))
            larger = [r for r in sorted(self._ready) if r > size]
            building = self._building.get(size)
        if larger:
            self._start_build(size, nx, n_params)
            return larger[0]
        if building is not None:
            building.wait()
        with self._lock:
            ready = size in self._ready
        if not ready:
            import jax

            self._compile(size, nx, n_params, bool(jax.config.read("jax_enable_x64")))
        return max(size, int(R))

    @property
    def consts(self) -> tuple[Any, ...]:
        """The arguments after ``(Y, params)`` that :meth:`__call__` passes."""
        return self._consts

    def __call__(self, Y: np.ndarray, params: np.ndarray) -> Any:
        return self.evaluate(Y, params, *self._consts)

    def evaluate(self, Y: np.ndarray, params: np.ndarray, *consts: Any) -> Any:
        """The kernel at the rows of ``Y`` (R, nx) and ``params`` (R, np) with ``consts`` in place of
        the program's own (the compiled programs take them as arguments): R a compiled row count,
        or a multiple of :data:`MAX_ROWS` (pieces of 128 rows, run on several threads at once,
        :func:`jaxstiff.runtime._threads.map_chunks`; each row has the bits it has in any call)."""
        R = len(Y)
        if R <= MAX_ROWS or R in self._ready:
            return self._ready[R](Y, params, *consts)
        from jaxstiff.runtime._threads import chunk_threads, map_chunks

        prog = self._ready[MAX_ROWS]
        pieces = []
        for s in range(0, R, MAX_ROWS):
            y, p = Y[s : s + MAX_ROWS], params[s : s + MAX_ROWS]
            if len(y) < MAX_ROWS:  # repeat the last row (rows are independent)
                y = np.concatenate([y, np.repeat(y[-1:], MAX_ROWS - len(y), axis=0)])
                p = np.concatenate([p, np.repeat(p[-1:], MAX_ROWS - len(p), axis=0)])
            pieces.append((y, p))
        outs = map_chunks(lambda yp: np.asarray(prog(yp[0], yp[1], *consts)), pieces, chunk_threads())
        return np.concatenate(outs)[:R]

    def at_points(self, X: np.ndarray, params: np.ndarray, *consts: Any) -> np.ndarray:
        """The kernel at the k rows of ``X`` (k, nx) and ``params`` (k, np) with ``consts`` (see
        :meth:`evaluate`), padded to the smallest ready row count (compiling 16 rows if none is):
        a row's values are those it has in a lockstep round."""
        X, params = np.asarray(X, self._dtype), np.asarray(params, self._dtype)
        k = len(X)
        R = self.rows_for(bucket_size(k), X.shape[1], params.shape[1])
        if R > k:
            X = np.concatenate([X, np.repeat(X[-1:], R - k, axis=0)])
            params = np.concatenate([params, np.repeat(params[-1:], R - k, axis=0)])
        return np.asarray(self.evaluate(X, params, *consts))[:k]


def _fill(reqs: Sequence[Request], R: int) -> tuple[np.ndarray, np.ndarray]:
    """``(Y (R, nx), params (R, np))`` of a round: its requests' rows, then the last one repeated
    up to R rows; the values ``np.stack`` would give, written into one buffer each (9x faster for
    a round of 44 requests in 128 rows). The dtypes are the first request's: a round's rows are
    one program's arguments, so they share one."""
    y0, p0 = reqs[0]
    Y = np.empty((R, len(y0)), np.asarray(y0).dtype)
    Pm = np.empty((R, len(p0)), np.asarray(p0).dtype)
    for i, (y, p) in enumerate(reqs):
        Y[i] = y
        Pm[i] = p
    n = len(reqs)
    Y[n:] = Y[n - 1]
    Pm[n:] = Pm[n - 1]
    return Y, Pm


def run_lockstep(
    gens: Sequence[Steps[Any]],
    evaluate: Callable[[np.ndarray, np.ndarray], Any],
) -> list[Any]:
    """Advance every generator until all have ended; each round evaluates all pending requests in
    one call ``evaluate(Y (R, nx), params (R, np)) -> (R, out)`` (R a :func:`bucket_size`, or, for
    a :class:`RowsProgram`, the row count its :meth:`~RowsProgram.rows_for` gives; the rows
    beyond the requests repeat the last one; a generator's :class:`Many` requests are rows of the
    same call). Returns the generators' results, in order. An exception raised by a generator
    propagates (the others are closed)."""
    group = gather(gens)  # one generator: each round, every pending request as one Many
    try:
        many = next(group)
        while True:
            reqs: list[Request] = []
            _flatten(many, reqs)
            if not reqs:  # only empty Many: answered without a call
                many = group.send(_answers(many, [], 0)[0])
                continue
            R = bucket_size(len(reqs))
            if isinstance(evaluate, RowsProgram):
                R = evaluate.rows_for(R, len(reqs[0][0]), len(reqs[0][1]))
            Y, Pm = _fill(reqs, R)
            many = group.send(_answers(many, np.asarray(evaluate(Y, Pm)), 0)[0])
    except StopIteration as stop:
        return stop.value
    finally:
        group.close()
