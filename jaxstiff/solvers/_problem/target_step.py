"""Greedy SLSQP's target step: a rate-limited waypoint solved as a system of equations first.

Why: f1 and f2 reach their least value (f2: 1; f1: c) exactly where the stiffness ellipsoid's
major axis lies along the wanted direction with the wanted ratio, and that set is the zero set of
smooth residuals (:meth:`~jaxstiff.solvers._problem.ops.WaypointOps.lm_residual`: the alignment
rows, the log-ratio row, the position rows). Where the previous waypoint is in target, the next
one's target postures lie close by, and Levenberg-Marquardt on those residuals inside the
waypoint's box reaches one in a few steps of one compiled call. SLSQP on f2 itself approaches the
same set at the kinks of ``|alpha|`` and ``|r - rho|``: about 30 iterations of Python and kernel
calls per waypoint on the LWR's default path, ending 1e-8-1e-6 above the least value (measured in
docs/notes/speed.md).

What: :func:`target_step` is that call for one problem, numpy in and out. The greedy walk
(:func:`jaxstiff.solvers._greedy.greedy_path`) judges its answer like any solver answer and keeps
it only where it is usable with the criterion within :data:`ACCEPT_REL` of its least value;
elsewhere SLSQP runs as before, from the same start.
"""

from __future__ import annotations

import threading
from collections.abc import Callable

import jax
import jax.numpy as jnp
import numpy as np

from jaxstiff.runtime._programs import program_cache
from jaxstiff.settings._solvers import PGDOptions
from jaxstiff.solvers._problem.ops import WaypointOps, box_scales, length_unit, lm_kind
from jaxstiff.solvers._problem.waypoint import WaypointProblem

__all__ = ["ACCEPT_REL", "LM_STEPS", "target_step"]

#: Levenberg-Marquardt steps, then Newton corrections onto the path
LM_STEPS, NEWTON_STEPS = 20, 3
#: the residuals' weights: pgd's defaults (position rows per length unit, alignment rows)
W_POS, W_ALIGN = float(PGDOptions.lm_wpos), float(PGDOptions.lm_walign)
#: the target step's answer is kept where its criterion is within this (relative) of the least value
ACCEPT_REL = 1e-9

#: ``(x (nx,), lb, ub, target (3,), direction (3,), ratio) -> x (nx,)``
TargetStep = Callable[[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, float], np.ndarray]


def target_step(problem: WaypointProblem, kspan: float) -> TargetStep | None:
    """The target step of ``problem`` (None where the criterion is not f1 or f2: no residuals
    whose zeros are its minimum set); ``kspan`` = kmax - kmin (Nm/rad), the stiffness step scale
    (an argument of the program: one compilation serves every stiffness range)."""
    built = _program(problem)
    if built is None:
        return None
    worker, done = built

    def call(x: np.ndarray, lb: np.ndarray, ub: np.ndarray, target: np.ndarray, d: np.ndarray, r: float) -> np.ndarray:
        worker.join()
        if "error" in done:
            raise done["error"]  # type: ignore[misc]
        f64 = np.float64
        args = (np.asarray(x, f64), np.asarray(lb, f64), np.asarray(ub, f64), np.asarray(target, f64))
        out = done["program"](*args, np.asarray(d, f64), f64(r), f64(kspan))  # type: ignore[operator]
        return np.asarray(out, float)

    return call


@program_cache(maxsize=16)
def _program(problem: WaypointProblem) -> tuple[threading.Thread, dict[str, object]] | None:
    """``problem``'s target-step program, compiled at once on a background thread (seconds of
    XLA, while the first waypoint's SLSQP starts run on the caller's; the process waits for it at
    exit): ``(thread, {"program": ...} or {"error": ...})``, None for a criterion without one."""
    kind = lm_kind(problem)
    if kind is None:
        return None
    ops = WaypointOps(problem)
    nf, nx = ops.nf, problem.nx
    wpos = W_POS / length_unit(problem.robot.length_scale)

    def step(x, lb, ub, target, d, r, kspan):
        s = box_scales(lb, ub, nf, kspan)
        y = ops.lm(x, lb, ub, target, d, r, kind, LM_STEPS, wpos, W_ALIGN, s)
        return ops.newton(y, target, lb, ub, NEWTON_STEPS)

    v, p3, sc = (
        jax.ShapeDtypeStruct((nx,), jnp.float64),
        jax.ShapeDtypeStruct((3,), jnp.float64),
        jax.ShapeDtypeStruct((), jnp.float64),
    )
    done: dict[str, object] = {}
    x64 = bool(jax.config.read("jax_enable_x64"))

    def build() -> None:
        try:
            with jax.enable_x64(x64):
                done["program"] = jax.jit(step).lower(v, v, v, p3, p3, sc, sc).compile()
        except BaseException as e:  # noqa: BLE001 - re-raised at the first call, on the caller's thread
            done["error"] = e

    # not a daemon: the interpreter waits for it at exit (a daemon stopped inside XLA's compiler by
    # the interpreter's finalisation aborts the process: docs/notes/speed.md, ninth session)
    worker = threading.Thread(target=build, name="jaxstiff-target-step", daemon=False)
    worker.start()
    return worker, done
