"""Long CSC runs as consecutive segments: progress after each, finished steps kept on an interrupt."""

from __future__ import annotations

import sys
import time
import warnings
from collections.abc import Callable
from typing import Any

import jax
import numpy as np

from jaxstiff.csc._inputs import CSCWarning, path_points, prepare_rollout
from jaxstiff.csc._result import START_FIELDS, CSCResult, concat_results, step_axis
from jaxstiff.csc._rollout import csc_rollout
from jaxstiff.model._robot import Robot
from jaxstiff.runtime._io import hold_interrupts, raise_if_interrupted
from jaxstiff.runtime._progress import Progress

__all__ = ["csc_rollout_segments"]


class CSCInterrupted(KeyboardInterrupt):
    """A :func:`csc_rollout_segments` run stopped by Ctrl-C (or SIGTERM under the command line).

    Attributes:
        result: :class:`CSCResult` of numpy arrays with the ``steps_done`` finished steps (the
            segment in flight when the interrupt came is lost).
        steps_done, steps_total: finished and requested steps per rollout.
    """

    def __init__(self, result: CSCResult, steps_done: int, steps_total: int) -> None:
        super().__init__(f"CSC rollout interrupted after {steps_done} of {steps_total} steps")
        self.result, self.steps_done, self.steps_total = result, steps_done, steps_total


def csc_rollout_segments(
    robot: Robot,
    path: Any,
    K_xd: Any,
    q0: Any,
    beta: Any = None,
    *,
    segment_steps: int,
    progress: Callable[[int, int], None] | None = None,
    **kwargs: Any,
) -> CSCResult:
    """:func:`csc_rollout` run as consecutive segments of ``segment_steps`` steps, for long runs
    that should show progress and keep their finished steps when interrupted.

    Each segment continues from the posture the previous one reached, with the same held
    orientation (task ``"full"``: ``q0``'s) and the same settings, so the rows are those of one
    :func:`csc_rollout` over the whole path (the same compiled step, to round-off). All segments
    have the same length (the last is padded with its final waypoint and the extra rows are
    dropped), so the program is compiled once. Not differentiable and not jittable (numpy out,
    Python loop): for gradients use :func:`csc_rollout`.

    Args:
        robot, path, K_xd, q0, beta: as :func:`csc_rollout` (``K_xd`` constant or along the path).
        segment_steps: steps per segment (>= 1).
        progress: optional ``progress(steps_done, steps_total)``: once with 0 when the inputs have
            been checked (before the first segment compiles and runs), then after every segment.
        **kwargs: the other keywords of :func:`csc_rollout` (``settings`` too; not ``hold_orientation``).

    Returns:
        :class:`CSCResult` of numpy arrays, as :func:`csc_rollout`'s.

    Raises:
        CSCInterrupted: a ``KeyboardInterrupt`` after at least one finished segment, carrying the
            finished rows (``._result``). One before the first segment ends is raised as is.
        ValueError: as :func:`csc_rollout`, or a bad ``segment_steps``.
    """
    if isinstance(segment_steps, bool) or not isinstance(segment_steps, (int, np.integer)) or segment_steps < 1:
        raise ValueError(f"segment_steps must be a positive integer, got {segment_steps!r}")
    if progress is not None and not callable(progress):
        raise TypeError(f"progress must be a function progress(steps_done, steps_total) (or None), got {progress!r}")
    if "hold_orientation" in kwargs:
        raise ValueError("csc_rollout_segments holds q0's orientation itself; hold_orientation is not accepted")
    varying = kwargs.pop("kxd_varying", None)
    # the whole path and every setting are checked before the first segment runs (a bad value
    # in a late waypoint must not surface after the work of the first segments)
    st = prepare_rollout(robot, path, K_xd, q0, beta, kxd_varying=varying, **kwargs)[0]
    pts = np.asarray(path_points(path))
    q = np.asarray(q0)
    R_hold = None
    if st.task == "full":  # every segment holds q0's orientation
        R_hold = np.asarray(robot.fk(np.where(robot.free, q, np.nan_to_num(robot.locked_values))))[..., :3, :3]

    def one(pts_seg: np.ndarray, K_seg: np.ndarray, q_start: np.ndarray) -> CSCResult:
        with warnings.catch_warnings():  # the check above warned once for the whole path, not per segment
            warnings.simplefilter("ignore", CSCWarning)
            r = csc_rollout(
                robot, pts_seg, K_seg, q_start, beta, kxd_varying=st.varying, hold_orientation=R_hold, **kwargs
            )
        return jax.tree_util.tree_map(np.asarray, r)

    return _run_segments(one, pts, np.asarray(K_xd), q, st.varying, int(segment_steps), progress)


def _run_segments(
    one: Callable[[np.ndarray, np.ndarray, np.ndarray], CSCResult],
    pts: np.ndarray,
    K: np.ndarray,
    q: np.ndarray,
    varying: bool,
    segment_steps: int,
    progress: Callable[[int, int], None] | None,
) -> CSCResult:
    """The loop of :func:`csc_rollout_segments`: ``one(points, K_xd, q0)`` per segment of equal length."""
    T = pts.shape[-2]
    L = int(min(segment_steps, T))

    def seg(a: int, x: np.ndarray, axis: int) -> np.ndarray:  # rows a ... a + L - 1 of `axis`, padded with the last row
        idx = np.minimum(np.arange(a, a + L), T - 1)
        return np.take(x, idx, axis=axis)

    if progress is not None:
        progress(0, T)
    parts: list[CSCResult] = []
    done = 0
    try:
        while done < T:
            keep = min(L, T - done)
            r = one(seg(done, pts, pts.ndim - 2), seg(done, K, K.ndim - 3) if varying else K, q)
            if keep < L:  # the padded last segment: drop the rows past the path's end
                rows: dict[str, Any] = {
                    name: (a if name in START_FIELDS else np.take(a, np.arange(keep), axis=step_axis(name, a.ndim)))
                    for name, a in r.as_dict().items()
                }
                r = CSCResult(**rows)
            parts.append(r)
            q = np.asarray(r.q[..., -1, :])
            done += keep
            if progress is not None:
                progress(done, T)
            raise_if_interrupted()  # (an interrupt that JAX swallowed during the segment)
    except KeyboardInterrupt as e:
        if not parts:
            raise
        hold_interrupts()  # a second Ctrl-C before the command has written the finished rows must not lose them
        raise CSCInterrupted(concat_results(parts), done, T) from e
    return concat_results(parts)


class StepProgress:
    """A ``progress`` for :func:`csc_rollout_segments` (``jaxstiff csc``'s), on stderr: what runs how
    (once the inputs are checked), then for a segmented run the progress after each segment: a bar
    on a terminal (:mod:`jaxstiff.runtime._progress`), a line a segment with the time and ETA in a log."""

    def __init__(self, B: int, T: int, L: int, notes: list[str] | tuple[str, ...] = ()) -> None:
        self.B, self.T, self.L, self.notes = B, T, L, list(notes)
        self.t0 = time.perf_counter()
        self.t1: float | None = None
        self.first = 0
        self.bar: Progress | None = None

    def __call__(self, done: int, total: int) -> None:
        now = time.perf_counter()
        if done == 0:
            self._start()
            return
        if self.L >= self.T or self.bar is None:
            return
        if self.bar.terminal:
            self.bar.update(done - self.bar.n)
            if done >= total:
                self.bar.close()
            return
        if self.t1 is None:  # the rate leaves out the first segment (it includes the compilation)
            self.t1, self.first = now, done
        rate = (done - self.first) / (now - self.t1) if done > self.first and now > self.t1 else 0.0
        eta = (
            f"ETA {(total - done) / rate:.1f} s"
            if rate > 0 and done < total
            else ("done" if done >= total else "ETA ...")
        )
        self.bar.write(
            f"csc: {done}/{total} steps x {self.B} rollout(s) ({100 * done / total:.0f}%)  {now - self.t0:.1f} s  {eta}"
        )

    def _start(self) -> None:
        for note in self.notes:  # warnings about the settings, once they are known to be valid
            print(f"jaxstiff: warning: {note}", file=sys.stderr)
        if self.L >= self.T:
            msg = (
                f"csc: {self.B} rollout(s) x {self.T} steps in one compiled run (compiling, then running; no "
                "progress in between, and Ctrl-C takes effect when it ends) ..."
            )
        else:
            msg = (
                f"csc: {self.B} rollout(s) x {self.T} steps in segments of {self.L} steps (compiling, then a line "
                "per segment; Ctrl-C keeps the finished segments) ..."
            )
        print(msg, file=sys.stderr, flush=True)
        if self.L < self.T:  # in a log, the lines per segment above; the bar is closed only on a terminal
            self.bar = Progress(self.T, "csc", "steps")
