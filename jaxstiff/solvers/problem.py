"""The per-waypoint shaping problem of seed 000 (SPEC section 5, S0-10 ... S0-14), solver-agnostic.

For waypoint p with target position ``x_p``, desired direction ``d_p`` and the previous state
``(q_{p-1}, kj_{p-1})``::

    (q_p, kj_p) = argmin  f(K_T(q, kj), d_p, r, c)                                   (S0-10)
        subject to  position(T(q))[rows] = x_p[rows]                                  (primary task)
                    max(q_min, q_{p-1} - dq) <= q  <= min(q_max, q_{p-1} + dq)        (S0-11, S0-12)
                    max(k_min, kj_{p-1} - dk) <= kj <= min(k_max, kj_{p-1} + dk)      (S0-13, S0-14)
                    locked joints fixed

Decision vector ``x = [q_free (n_free), kj (n)]``: the free joints' positions (rad or m) and the
stiffness of *every* joint (Nm/rad; a locked joint keeps its stiffness as a variable, SPEC
section 1). ``rows`` are the position rows of the task: (x, y) for ``"xy"`` (a planar chain
cannot move along z, the z equation would be a zero row), (x, y, z) otherwise.

Everything here is a pure function of its inputs; :class:`WaypointProblem` is a frozen, hashable
description (robot, task, criterion) so that one compilation serves every waypoint of every path:

* :meth:`WaypointProblem.objective` ``(q, kj, d, r, c) -> f``, :meth:`~WaypointProblem.residual`
  ``(q, target) -> position - target``: traceable, vmappable building blocks for any solver
  (SLSQP here; projected gradient and trajectory-level solvers build on the same functions).
* :func:`compiled` ``(problem) -> fused(x, params)``: one jitted call returning objective,
  gradient, constraint and constraint Jacobian in one flat float64 array, compiled once per
  problem (cached), for callers that work on numpy vectors (SLSQP).
* :func:`box` the rate-limited bounds (numpy), :func:`clip_to_box`, :func:`newton_project` (put a
  point back on the position constraint inside the box) and :func:`check_point` (the honest
  per-waypoint verdict, used for the status codes of :mod:`jaxstiff.results`).

Units: metres, radians, Nm/rad; the criterion's alpha is in degrees (seed 000).

Example:
    >>> import jaxstiff
    >>> from jaxstiff.solvers.problem import WaypointProblem
    >>> robot = jaxstiff.Robot.from_urdf("kuka_lwr4", locked={"lwr_a7": 0.0})
    >>> prob = WaypointProblem(robot, "full", jaxstiff.f2)
    >>> prob.n_free, prob.nx
    (6, 13)
"""

from __future__ import annotations

import dataclasses
import functools
import inspect
import math
import zlib
from typing import Callable

import jax
import jax.numpy as jnp
import numpy as np

from jaxstiff.stiffness.criteria import alpha_and_ratio
from jaxstiff.model.kinematics import position_and_jacobian
from jaxstiff.model.robot import Robot
from jaxstiff.stiffness.core import task_rows, translational_stiffness

__all__ = [
    "WaypointProblem",
    "compiled",
    "compiled_evaluate",
    "compiled_report",
    "compiled_scaled",
    "compiled_position",
    "jax_pos_and_jac",
    "box",
    "clip_to_box",
    "newton_project",
    "check_point",
    "PointCheck",
    "POS_TOL",
    "BOUND_TOL",
    "content_seed",
]

POS_TOL = 1e-9  #: m, largest position error of a waypoint that counts as reached
BOUND_TOL = 1e-9  #: largest excursion outside the box that SLSQP may report before it counts as clipped


def _accepts_c(fn: Callable) -> bool:
    try:
        sig = inspect.signature(fn)
    except (TypeError, ValueError):
        return False
    params = sig.parameters
    return "c" in params or any(p.kind is inspect.Parameter.VAR_KEYWORD for p in params.values())


@dataclasses.dataclass(frozen=True)
class WaypointProblem:
    """The waypoint problem's static part: robot (with its locked joints), task and criterion.

    Hashable; use it as a static argument of ``jax.jit`` or as a cache key.

    Args:
        robot: the chain; its locked joints are held at their values.
        task: ``"full"`` (K_T = top-left 3x3 of the 6x6 K_C, S0-6/7), ``"xyz"`` or ``"xy"``.
        criterion: ``crit(K, d, r[, c]) -> scalar`` (jaxstiff.f1, jaxstiff.f2 or your own).
    """

    robot: Robot
    task: str
    criterion: Callable

    def __post_init__(self):
        task_rows(self.task)  # validates the task name
        if not callable(self.criterion):
            raise ValueError(f"criterion must be callable, got {self.criterion!r}")

    # ------------------------------------------------------------------ layout
    @property
    def n(self) -> int:
        """Actuated joints (locked included)."""
        return self.robot.n

    @property
    def free_idx(self) -> tuple[int, ...]:
        """Indices of the free joints in q."""
        return tuple(i for i, v in enumerate(self.robot.locked) if v is None)

    @property
    def n_free(self) -> int:
        return len(self.free_idx)

    @property
    def nx(self) -> int:
        """Length of the decision vector ``x = [q_free, kj]``."""
        return self.n_free + self.n

    @property
    def pos_rows(self) -> tuple[int, ...]:
        """Position rows of the equality constraint: (0, 1) for task "xy", else (0, 1, 2)."""
        return (0, 1) if self.task == "xy" else (0, 1, 2)

    @property
    def m(self) -> int:
        """Dimension of K_T: 2 for "xy", else 3."""
        return 2 if self.task == "xy" else 3

    def q_of(self, x: jax.Array) -> jax.Array:
        """Full joint vector (..., n) from ``x`` (..., nx): free entries from x, locked ones constant."""
        cols = []
        k = 0
        for v in self.robot.locked:
            if v is None:
                cols.append(x[..., k])
                k += 1
            else:
                cols.append(jnp.full(x.shape[:-1], v, dtype=x.dtype))
        return jnp.stack(cols, axis=-1)

    def kj_of(self, x: jax.Array) -> jax.Array:
        """Joint stiffnesses (..., n) from ``x`` (..., nx)."""
        return x[..., self.n_free :]

    def x_of(self, q, kj):
        """Decision vector (..., nx) from ``q`` (..., n) and ``kj`` (..., n); works on numpy and JAX."""
        xp = jnp if isinstance(q, jax.Array) or isinstance(kj, jax.Array) else np
        q = xp.asarray(q)
        return xp.concatenate([q[..., list(self.free_idx)], xp.asarray(kj)], axis=-1)

    # ------------------------------------------------------------------ pure building blocks
    def stiffness(self, q: jax.Array, kj: jax.Array) -> jax.Array:
        """Translational stiffness ``K_T`` (..., m, m), N/m, at (q, kj) (S0-4, S0-6).

        """
        _, J = position_and_jacobian(self.robot, q, task_rows(self.task))
        return translational_stiffness(J, kj, task=self.task)

    def objective(self, q: jax.Array, kj: jax.Array, d: jax.Array, r, c) -> jax.Array:
        """Criterion value ``f(K_T(q, kj), d, r[, c])`` (...,). ``d`` (..., 3): only its first m entries are used."""
        K = self.stiffness(q, kj)
        dd = jnp.asarray(d, dtype=K.dtype)[..., : self.m]
        if _accepts_c(self.criterion):
            return self.criterion(K, dd, r, c=c)
        return self.criterion(K, dd, r)

    def position(self, q: jax.Array) -> jax.Array:
        """TCP position (..., 3), m, base frame."""
        p, _ = position_and_jacobian(self.robot, q, (0, 1, 2))
        return p

    def residual(self, q: jax.Array, target: jax.Array) -> jax.Array:
        """Equality constraint ``position(q)[rows] - target[rows]`` (..., len(rows)), m."""
        p = self.position(q)
        rows = list(self.pos_rows)
        return p[..., rows] - jnp.asarray(target, dtype=p.dtype)[..., rows]

    def report(self, q: jax.Array, kj: jax.Array, d: jax.Array, r, c):
        """``(position (...,3), K_T (...,m,m), alpha_deg (...,), ratio (...,), criterion (...,))``."""
        p, J = position_and_jacobian(self.robot, q, task_rows(self.task))
        K = translational_stiffness(J, kj, task=self.task)
        dd = jnp.asarray(d, dtype=K.dtype)[..., : self.m]
        alpha, rho = alpha_and_ratio(K, dd)
        if _accepts_c(self.criterion):
            f = self.criterion(K, dd, r, c=c)
        else:
            f = self.criterion(K, dd, r)
        return p, K, alpha, rho, f

    # ------------------------------------------------------------------ flat x/params interface
    # params = [target (3), d (3), r, c]
    def objective_x(self, x: jax.Array, params: jax.Array) -> jax.Array:
        """Objective as a function of the decision vector and the flat parameter vector."""
        return self.objective(self.q_of(x), self.kj_of(x), params[3:6], params[6], params[7])

    def residual_x(self, x: jax.Array, params: jax.Array) -> jax.Array:
        return self.residual(self.q_of(x), params[0:3])

    def fused(self, x: jax.Array, params: jax.Array) -> jax.Array:
        """``[f, df/dx (nx), c (k), dc/dx (k*nx, row-major)]`` in one flat array, k = len(pos_rows).

        One kernel call per point SLSQP asks about. The constraint Jacobian is the analytic one:
        the free columns of the task rows of the geometric Jacobian, zeros for the stiffness
        columns. Split it with :meth:`unpack`.
        """
        f, g = jax.value_and_grad(self.objective_x)(x, params)
        q = self.q_of(x)
        rows = self.pos_rows
        p, Jp = position_and_jacobian(self.robot, q, rows)
        c = p[jnp.asarray(rows)] - params[jnp.asarray(rows)]
        Jq = Jp[:, jnp.asarray(self.free_idx)] if self.n_free else jnp.zeros((len(rows), 0), x.dtype)
        A = jnp.concatenate([Jq, jnp.zeros((len(rows), self.n), dtype=x.dtype)], axis=1)
        return jnp.concatenate([f[None], g, c, A.ravel()])

    def fused_scaled(self, y: jax.Array, params: jax.Array, scale: jax.Array) -> jax.Array:
        """:meth:`fused` in scaled variables, as a solver sees them: ``x = y * scale[:nx]``, the
        objective times ``scale[nx]``; returns ``[f s_f, df/dy (nx), c (k), dc/dy (k*nx)]``.

        Scaling inside the kernel keeps the solver's Python side to array views (no numpy
        arithmetic per evaluation).
        """
        sx, sf = scale[: self.nx], scale[self.nx]
        out = self.fused(y * sx, params)
        nx, k = self.nx, len(self.pos_rows)
        f, g, c, A = out[0], out[1 : 1 + nx], out[1 + nx : 1 + nx + k], out[1 + nx + k :].reshape(k, nx)
        return jnp.concatenate([(f * sf)[None], g * sx * sf, c, (A * sx[None, :]).ravel()])

    def unpack(self, out: np.ndarray):
        """Split :meth:`fused`'s output into ``(f, grad (nx,), c (k,), A (k, nx))``."""
        nx, k = self.nx, len(self.pos_rows)
        return out[0], out[1 : 1 + nx], out[1 + nx : 1 + nx + k], out[1 + nx + k :].reshape(k, nx)

    def report_x(self, x: jax.Array, params: jax.Array) -> jax.Array:
        """``[position (3), K_T (m*m), alpha_deg, ratio, criterion]`` at one point, flat."""
        p, K, alpha, rho, f = self.report(self.q_of(x), self.kj_of(x), params[3:6], params[6], params[7])
        return jnp.concatenate([p, K.ravel(), alpha[None], rho[None], f[None]])

    def unpack_report(self, out: np.ndarray):
        """``(position (3,), K_T (m, m), alpha_deg, ratio, criterion)`` from :meth:`report_x`'s output."""
        m = self.m
        return out[:3], out[3 : 3 + m * m].reshape(m, m), out[3 + m * m], out[4 + m * m], out[5 + m * m]

    @staticmethod
    def params(target, direction, r: float, c: float) -> np.ndarray:
        """The flat float64 parameter vector ``[target (3), d (3), r, c]``."""
        return np.concatenate([np.asarray(target, float), np.asarray(direction, float), [float(r), float(c)]])


# ---------------------------------------------------------------------- compiled, cached
@functools.lru_cache(maxsize=64)
def compiled_scaled(problem: WaypointProblem) -> Callable[[np.ndarray, np.ndarray, np.ndarray], jax.Array]:
    """The jitted ``fused_scaled(y, params, scale)`` of a problem, compiled once per problem and dtype."""
    return jax.jit(problem.fused_scaled)


@functools.lru_cache(maxsize=64)
def compiled(problem: WaypointProblem) -> Callable[[np.ndarray, np.ndarray], jax.Array]:
    """``fused(x, params)`` of a problem, unscaled, on the one jitted kernel of :func:`compiled_scaled`."""
    fs = compiled_scaled(problem)
    nx = problem.nx

    def fused(x, params):
        # the argument kinds the SLSQP driver uses (x numpy, the rest device arrays): jit's cache
        # keys numpy and device arrays apart, so mixing them would compile the kernel twice
        x = np.asarray(x)
        return fs(x, jnp.asarray(params, dtype=x.dtype), jnp.ones(nx + 1, dtype=x.dtype))

    fused._cache_size = fs._cache_size  # type: ignore[attr-defined]
    return fused


@functools.lru_cache(maxsize=64)
def compiled_report(problem: WaypointProblem) -> Callable[[np.ndarray, np.ndarray], jax.Array]:
    """Jitted single-point :meth:`WaypointProblem.report_x` ``(x, params)``: one compilation per problem."""
    return jax.jit(problem.report_x)


@functools.lru_cache(maxsize=64)
def compiled_evaluate(problem: WaypointProblem):
    """Jitted batch report ``(q (N,n), kj (N,n), d (N,3), r, c) -> (pos, K_T, alpha, ratio, f)``."""
    return jax.jit(problem.report)


@functools.lru_cache(maxsize=64)
def compiled_position(problem: WaypointProblem):
    """Jitted ``q (n,) -> [position (3,), J[rows][:, free] (k*n_free,)]`` in one flat array."""
    rows = problem.pos_rows
    free = jnp.asarray(problem.free_idx, dtype=int)

    def pj(q):
        p, J = position_and_jacobian(problem.robot, q, rows)
        return jnp.concatenate([p, J[:, free].ravel()])

    return jax.jit(pj)


def jax_pos_and_jac(problem: WaypointProblem) -> Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]]:
    """numpy wrapper of :func:`compiled_position`: ``q (n,) -> (position (3,), J (k, n_free))``."""
    fn = compiled_position(problem)
    k, nf = len(problem.pos_rows), problem.n_free

    def pos_and_jac(q):
        out = np.asarray(fn(q))
        return out[:3], out[3:].reshape(k, nf)

    return pos_and_jac


# ---------------------------------------------------------------------- numpy helpers
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
    """
    robot = problem.robot
    free = list(problem.free_idx)
    ql, qu = robot.lower.copy(), robot.upper.copy()
    kl, ku = np.full(problem.n, float(kmin)), np.full(problem.n, float(kmax))
    if q_prev is not None:
        lo, hi = rate_bounds(q_prev, dq)
        ql, qu = np.maximum(ql, lo), np.minimum(qu, hi)
    if kj_prev is not None:
        lo, hi = rate_bounds(kj_prev, dk)
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
        hit = (new != x[:nf] + step)
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

    def for_path(self, b: int) -> "Limits":
        """The limits of path ``b`` with (n,) ``dq`` and ``dk`` (itself when they are per joint only)."""
        if not self.per_path:
            return self
        dq = np.asarray(self.dq, float)
        dk = np.asarray(self.dk, float)
        return Limits(dq[b] if dq.ndim == 2 else dq, dk[b] if dk.ndim == 2 else dk, self.kmin, self.kmax,
                      self.first_rate_limit)

    def rows(self, B: int) -> tuple[np.ndarray, np.ndarray]:
        """``(dq (B, n), dk (B, n))``: the rate limits of every path of a batch of B."""
        dq, dk = np.asarray(self.dq, float), np.asarray(self.dk, float)
        for name, a in (("dq", dq), ("dk", dk)):
            if a.ndim == 2 and a.shape[0] != B:
                raise ValueError(f"Limits.{name} has {a.shape[0]} rows, the batch has {B} paths")
        n = dq.shape[-1]
        return np.broadcast_to(dq, (B, n)).copy(), np.broadcast_to(dk, (B, dk.shape[-1])).copy()

    def box(self, problem: "WaypointProblem", q_ref, kj_ref, rate: bool):
        """Bounds ``(lb, ub)`` around a reference state; ``rate=False`` drops the rate limits.

        Needs one path's limits ((n,) ``dq``/``dk``): use ``limits.for_path(b).box(...)``.
        """
        if self.per_path:
            raise ValueError("Limits.box needs one path's rate limits; use limits.for_path(b).box(...)")
        if not rate:
            return box(problem, None, None, self.dq, self.dk, self.kmin, self.kmax)
        return box(problem, q_ref, kj_ref, self.dq, self.dk, self.kmin, self.kmax)


def check_option_values(solver: str, opts: dict, *, int_min: dict | None = None, positive: tuple = (),
                        nonnegative: tuple = (), choices: dict | None = None) -> dict:
    """Check and normalise a solver's option values before any work (ValueError naming the option).

    ``int_min``: option -> smallest allowed integer (an integer-valued float such as 2.0 is taken,
    2.5 or "many" is not); ``positive`` / ``nonnegative``: finite numbers > 0 / >= 0;
    ``choices``: option -> allowed strings. Options not named are left alone. Returns a copy.
    """
    out = dict(opts)
    for k, lo in (int_min or {}).items():
        if k not in out:
            continue
        v = out[k]
        ok = not isinstance(v, bool) and (isinstance(v, (int, np.integer)) or (isinstance(v, (float, np.floating)) and float(v).is_integer()))
        if not ok or v < lo:
            raise ValueError(f"{solver} option {k!r} must be an integer >= {lo}, got {v!r}")
        out[k] = int(v)
    for names, lo, strict in ((positive, 0.0, True), (nonnegative, 0.0, False)):
        for k in names:
            if k not in out:
                continue
            v = out[k]
            num = not isinstance(v, bool) and isinstance(v, (int, float, np.integer, np.floating))
            if not num or not math.isfinite(float(v)) or (float(v) <= lo if strict else float(v) < lo):
                raise ValueError(f"{solver} option {k!r} must be a finite number {'>' if strict else '>='} {lo:g}, got {v!r}")
            out[k] = float(v)
    for k, allowed in (choices or {}).items():
        if k in out and out[k] not in allowed:
            raise ValueError(f"{solver} option {k!r} must be one of {', '.join(map(repr, allowed))}, got {out[k]!r}")
    return out
