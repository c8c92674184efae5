"""The numpy side of the waypoint problem: the rate-limited box (S0-11 ... S0-14) and its
:class:`Limits`, clipping, the Newton projection onto the path inside the box, the per-point
check and the per-path random seed (:mod:`jaxstiff.solvers._problem`)."""

from __future__ import annotations

import dataclasses
import zlib
from collections.abc import Callable

import numpy as np

from jaxstiff.solvers._problem.compiled import jax_pos_and_jac
from jaxstiff.solvers._problem.waypoint import WaypointProblem

__all__ = ["box", "Limits"]

POS_TOL = 1e-9  #: m, largest position error of a waypoint that counts as reached
BOUND_TOL = 1e-9  #: largest excursion outside the box that SLSQP may report before it counts as clipped


def content_seed(*arrays) -> int:
    """A 32-bit number (CRC-32) of the arrays' float64 bytes, C order, in the order given.

    Seeds a path's own randomness from its data (targets, directions, start state), so that a
    path's result does not depend on its position in a batch, on the batch size or on the chunk
    size (identical paths get identical random numbers).
    """
    h = 0
    for a in arrays:
        h = zlib.crc32(np.ascontiguousarray(np.asarray(a, dtype=np.float64)).tobytes(), h)
    return h


def box(
    problem: WaypointProblem,
    q_prev: np.ndarray | None,
    kj_prev: np.ndarray | None,
    dq: np.ndarray,
    dk: np.ndarray,
    kmin: float,
    kmax: float,
) -> tuple[np.ndarray, np.ndarray]:
    """Bounds ``(lb, ub)`` (nx,) of the decision vector (S0-11 ... S0-14).

    ``q_prev``/``kj_prev`` ``None`` means no rate limit (joint and stiffness limits only).
    ``dq``, ``dk``: (n,) rate limits per waypoint (rad or m; Nm/rad), ``inf`` for none.
    ``kj_prev``, ``dk`` (n,): the entries of rigid locked joints are ignored.
    """
    robot = problem.robot
    free = list(problem.free_idx)
    ql, qu = robot.lower.copy(), robot.upper.copy()
    kl, ku = np.full(problem.n_spring, float(kmin)), np.full(problem.n_spring, float(kmax))
    if q_prev is not None:
        lo, hi = rate_bounds(q_prev, dq)
        ql, qu = np.maximum(ql, lo), np.minimum(qu, hi)
    if kj_prev is not None:
        lo, hi = rate_bounds(problem.spring_cols(np.asarray(kj_prev)), problem.spring_cols(np.asarray(dk)))
        kl, ku = np.maximum(kl, lo), np.minimum(ku, hi)
    return np.concatenate([ql[free], kl]), np.concatenate([qu[free], ku])


def rate_bounds(ref, step, xp=np):
    """``(ref - step, ref + step)`` rounded inwards where needed, so that every x between them
    satisfies ``|x - ref| <= step`` exactly as a file check computes it in floating point
    (``ref + step`` can round up by half an ulp of ``ref``: 7e-15 at 100 Nm/rad)."""
    lo, hi = ref - step, ref + step
    lo = xp.where(ref - lo > step, xp.nextafter(lo, xp.inf), lo)
    hi = xp.where(hi - ref > step, xp.nextafter(hi, -xp.inf), hi)
    return lo, hi


def clip_to_box(x: np.ndarray, lb: np.ndarray, ub: np.ndarray) -> np.ndarray:
    """``x`` clipped into ``[lb, ub]`` (exactly: every entry compares within the box)."""
    return np.minimum(np.maximum(x, lb), ub)


def newton_project(
    problem: WaypointProblem,
    x: np.ndarray,
    target: np.ndarray,
    lb: np.ndarray,
    ub: np.ndarray,
    pos_and_jac: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]] | None = None,
    tol: float = 1e-12,
    max_steps: int = 30,
) -> np.ndarray:
    """Move ``x``'s free joints onto ``position(q)[rows] = target[rows]`` without leaving the box.

    Minimum-norm Gauss-Newton steps ``dq = J^+ e`` (damped by 1e-12 for rank loss), clipped to the
    box; joints that end at a bound are dropped from the next step (a small active set). Stops at
    ``|e| <= tol`` or after ``max_steps``. The stiffness part of ``x`` is not touched.

    Args:
        pos_and_jac: ``q (n,) -> (position (3,), J[rows][:, free] (k, n_free))``; default
            the problem's jitted kernel. The numpy baseline passes its own.

    Returns:
        The projected ``x`` (always inside the box; may still be off target if unreachable).
    """
    if pos_and_jac is None:
        pos_and_jac = jax_pos_and_jac(problem)

    rows = list(problem.pos_rows)
    nf = problem.n_free
    x = clip_to_box(np.array(x, dtype=float), lb, ub)
    locked = problem.robot.locked_values
    free = list(problem.free_idx)
    qfull = np.nan_to_num(locked)
    active = np.zeros(nf, dtype=bool)
    for _ in range(max_steps):
        qfull[free] = x[:nf]
        p, J = pos_and_jac(qfull)
        e = np.asarray(target, float)[rows] - p[rows]
        if not np.all(np.isfinite(e)) or np.linalg.norm(e) <= tol:
            break
        Ja = np.where(active[None, :], 0.0, J)
        JJt = Ja @ Ja.T
        tr = float(np.trace(JJt))
        if not tr > 1e-200:  # no joint left that moves the TCP (all at a bound, or a singular posture)
            break
        try:
            step = Ja.T @ np.linalg.solve(JJt + 1e-12 * tr * np.eye(len(rows)), e)
        except np.linalg.LinAlgError:
            break
        if not np.all(np.isfinite(step)):
            break
        new = clip_to_box(x[:nf] + step, lb[:nf], ub[:nf])
        hit = new != x[:nf] + step
        active |= hit
        x[:nf] = new
        if active.all():
            break
    return x


@dataclasses.dataclass(frozen=True)
class PointCheck:
    """Verdict on a candidate waypoint solution: position error (m), box excursion, finiteness."""

    pos_error: float
    box_excursion: float
    finite: bool


def check_point(x: np.ndarray, lb: np.ndarray, ub: np.ndarray, pos_error: float, crit: float) -> PointCheck:
    """Measure how far ``x`` is outside ``[lb, ub]`` and whether everything is finite."""
    exc = float(np.max(np.r_[lb - x, x - ub, 0.0])) if np.all(np.isfinite(x)) else float("inf")
    finite = bool(np.all(np.isfinite(x)) and np.isfinite(pos_error) and np.isfinite(crit))
    return PointCheck(pos_error=float(pos_error), box_excursion=exc, finite=finite)


@dataclasses.dataclass(frozen=True, eq=False)
class Limits:
    """Joint-stiffness range and rate limits of a shaping run (S0-11 ... S0-14).

    Attributes:
        dq: (n,) largest joint change per waypoint (rad or m), the same for every path, or
            (B, n): one row per path of the batch; ``inf`` = none.
        dk: (n,) or (B, n) largest stiffness change per waypoint (Nm/rad); ``inf`` = none.
        kmin, kmax: stiffness range (Nm/rad), 0 < kmin < kmax.
        first_rate_limit: apply ``dq``/``dk`` between the start state ``(q0, kj0)`` and the first
            waypoint (True), or let the first waypoint use the whole joint/stiffness range
            (False: the start state is only the initial guess).

    A solver of a batch takes path b's limits from :meth:`for_path` (or :meth:`rows` for all
    paths at once); :meth:`box` needs (n,) limits, i.e. one path's.
    """

    dq: np.ndarray
    dk: np.ndarray
    kmin: float
    kmax: float
    first_rate_limit: bool

    @property
    def per_path(self) -> bool:
        """True if ``dq`` or ``dk`` has one row per path (B, n)."""
        return np.ndim(self.dq) == 2 or np.ndim(self.dk) == 2

    def for_path(self, b: int) -> Limits:
        """The limits of path ``b`` with (n,) ``dq`` and ``dk`` (itself when they are per joint only)."""
        if not self.per_path:
            return self
        dq = np.asarray(self.dq, float)
        dk = np.asarray(self.dk, float)
        return Limits(
            dq[b] if dq.ndim == 2 else dq, dk[b] if dk.ndim == 2 else dk, self.kmin, self.kmax, self.first_rate_limit
        )

    def rows(self, B: int) -> tuple[np.ndarray, np.ndarray]:
        """``(dq (B, n), dk (B, n))``: the rate limits of every path of a batch of B."""
        dq, dk = np.asarray(self.dq, float), np.asarray(self.dk, float)
        for name, a in (("dq", dq), ("dk", dk)):
            if a.ndim == 2 and a.shape[0] != B:
                raise ValueError(f"Limits.{name} has {a.shape[0]} rows, the batch has {B} paths")
        n = dq.shape[-1]
        return np.broadcast_to(dq, (B, n)).copy(), np.broadcast_to(dk, (B, dk.shape[-1])).copy()

    def box(self, problem: WaypointProblem, q_ref, kj_ref, rate: bool):
        """Bounds ``(lb, ub)`` around a reference state; ``rate=False`` drops the rate limits.

        Needs one path's limits ((n,) ``dq``/``dk``): use ``limits.for_path(b).box(...)``.
        """
        if self.per_path:
            raise ValueError("Limits.box needs one path's rate limits; use limits.for_path(b).box(...)")
        if not rate:
            return box(problem, None, None, self.dq, self.dk, self.kmin, self.kmax)
        return box(problem, q_ref, kj_ref, self.dq, self.dk, self.kmin, self.kmax)


@dataclasses.dataclass(frozen=True, eq=False)
class WaypointBatch:
    """The paths a solver works on: what every shipped solver entry point takes first.

    Attributes:
        problem: the waypoint problem (robot, task, criterion).
        targets, directions: (B, P, 3) TCP positions (m) and unit desired directions.
        q0, kj0: (B, n) start states (rad or m; Nm/rad).
        limits: stiffness range and rate limits; (n,) or per path (B, n), see :meth:`Limits.for_path`.
        ratio: the wanted axis ratio, a float (every path) or a (B,) array (per path).
        c: f1's offset (a float, every path).
    """

    problem: WaypointProblem
    targets: np.ndarray
    directions: np.ndarray
    q0: np.ndarray
    kj0: np.ndarray
    limits: Limits
    ratio: float | np.ndarray
    c: float

    @property
    def ratios(self) -> np.ndarray:
        """(B,) the wanted axis ratio of every path."""
        return np.broadcast_to(np.asarray(self.ratio, float), (self.targets.shape[0],)).copy()
