"""The waypoint problem's static part, :class:`WaypointProblem` (robot, task, criterion), and its
pure, traceable building blocks (SPEC section 5, S0-10; :mod:`jaxstiff.solvers._problem`)."""

from __future__ import annotations

import dataclasses
import functools
from collections.abc import Callable
from typing import Any, overload

import jax
import jax.numpy as jnp
import numpy as np
from numpy.typing import ArrayLike

from jaxstiff.model._chain import LOCKED_JOINT_MODES
from jaxstiff.model._kinematics import position_and_jacobian, position_and_jacobian_raw
from jaxstiff.model._kinematics_scan import solver_uses_scan
from jaxstiff.model._robot import Robot
from jaxstiff.settings._shape import task_dim
from jaxstiff.stiffness._core import compliance, task_rows, translational_stiffness
from jaxstiff.stiffness._criteria import accepts_c, alpha_and_ratio, alpha_and_ratio_of_eig, f1, f1_of, f2, f2_of
from jaxstiff.stiffness._schur import stiffness_eig_of_compliance

__all__: list[str] = []


@dataclasses.dataclass(frozen=True)
class WaypointProblem:
    """The waypoint problem's static part: robot (with its locked joints), task, criterion and
    what a locked joint's stiffness is.

    Hashable; use it as a static argument of ``jax.jit`` or as a cache key.

    Args:
        robot: the chain; its locked joints are held at their values.
        task: ``"full"`` (K_T = top-left 3x3 of the 6x6 K_C, S0-6/7), ``"xyz"`` or ``"xy"``.
        criterion: ``crit(K, d, r[, c]) -> scalar`` (jaxstiff.f1, jaxstiff.f2 or your own).
        locked_joints: ``"rigid"`` (default, SPEC section 1): a locked joint has no spring, adds no
            compliance and has no stiffness variable; its ``kj`` entry reads ``+inf``.
            ``"spring"``: a locked joint keeps its spring, whose stiffness is a variable like the
            free joints'. Without locked joints both are the same.
    """

    robot: Robot
    task: str
    criterion: Callable
    locked_joints: str = "rigid"

    def __post_init__(self):
        task_rows(self.task)  # validates the task name
        if not callable(self.criterion):
            raise ValueError(f"criterion must be callable, got {self.criterion!r}")
        if self.locked_joints not in LOCKED_JOINT_MODES:
            raise ValueError(
                f"locked_joints must be one of {', '.join(map(repr, LOCKED_JOINT_MODES))}, got {self.locked_joints!r}"
            )

    def fingerprint(self) -> str | None:
        """A content key of the problem that holds across processes (robot content, task, locked
        joint mode, criterion), for disk caches of traced programs; None for a criterion other
        than the built-in f1 and f2 (a user's function cannot be keyed by its content)."""
        if self.criterion is f1:
            crit = "f1"
        elif self.criterion is f2:
            crit = "f2"
        else:
            return None
        return f"{self.robot.fingerprint()}|{self.task}|{self.locked_joints}|{crit}"

    def criterion_minimum(self, c: float) -> float | None:
        """The least value the criterion can take: 1 for f2 (alpha = 0, rho = r), ``c`` for f1
        (alpha = 0, rho >= r); None for another criterion (unknown)."""
        if self.criterion is f2:
            return 1.0
        if self.criterion is f1:
            return float(c)
        return None

    def kinematics(self, q: jax.Array, rows: tuple[int, ...] = (0, 1, 2, 3, 4, 5)) -> tuple[jax.Array, jax.Array]:
        """TCP position (..., 3) and Jacobian rows (..., len(rows), n) at ``q`` (..., n), as every
        solver program computes them: the kernel of
        :func:`jaxstiff.model._kinematics_scan.solver_uses_scan` (traceable, no checks)."""
        if solver_uses_scan(self.robot):
            return position_and_jacobian_raw(self.robot, jnp.asarray(q), rows, kernel="scan")
        return position_and_jacobian(self.robot, q, rows)

    # ------------------------------------------------------------------ layout
    @property
    def n(self) -> int:
        """Actuated joints (locked included)."""
        return self.robot.n

    # The layout below is read per SLSQP step (tens of thousands of times in a batch's polish):
    # computed once per problem (cached_property writes the instance's __dict__, which a frozen
    # dataclass allows; equality and hash still read the fields only).
    @functools.cached_property
    def free_idx(self) -> tuple[int, ...]:
        """Indices of the free joints in q."""
        return tuple(i for i, v in enumerate(self.robot.locked) if v is None)

    @functools.cached_property
    def n_free(self) -> int:
        return len(self.free_idx)

    @functools.cached_property
    def spring_idx(self) -> tuple[int, ...]:
        """Indices of the joints with a spring, i.e. a stiffness variable: every joint with
        ``locked_joints="spring"``, the free joints with ``"rigid"``."""
        if self.locked_joints == "spring":
            return tuple(range(self.n))
        return self.free_idx

    @functools.cached_property
    def n_spring(self) -> int:
        """Number of stiffness variables (``n`` or ``n_free``, see :attr:`spring_idx`)."""
        return len(self.spring_idx)

    @functools.cached_property
    def all_springs(self) -> bool:
        """True if every joint has a spring (no rigid locked joint): kj in x is all of kj."""
        return self.n_spring == self.n

    @functools.cached_property
    def nx(self) -> int:
        """Length of the decision vector ``x = [q_free, kj_spring]`` (``n_free + n_spring``)."""
        return self.n_free + self.n_spring

    def spring_cols(self, a: Any, axis: int = -1) -> Any:
        """``a`` with only the sprung joints' entries along ``axis`` (``a`` itself when every joint
        has a spring; numpy or JAX)."""
        if self.all_springs:
            return a
        xp = jnp if isinstance(a, jax.Array) else np
        return xp.take(a, xp.asarray(self.spring_idx, dtype=int), axis=axis)

    def kj_full(self, kv: Any) -> Any:
        """Joint stiffnesses (..., n) from the stiffness variables (..., n_spring): rigid locked
        joints read ``+inf`` (infinite stiffness). numpy in, numpy out; JAX in, JAX out."""
        if self.all_springs:
            return kv
        if not isinstance(kv, jax.Array):  # numpy: one placement, the values themselves
            kv = np.asarray(kv)
            full = np.full((*kv.shape[:-1], self.n), np.inf, dtype=np.promote_types(kv.dtype, np.float16))
            full[..., list(self.spring_idx)] = kv
            return full
        cols, k = [], 0  # JAX: traceable, one column at a time
        for i in range(self.n):
            if i in self.spring_idx:
                cols.append(kv[..., k])
                k += 1
            else:
                cols.append(jnp.full(kv.shape[:-1], jnp.inf, dtype=kv.dtype))
        return jnp.stack(cols, axis=-1)

    @property
    def pos_rows(self) -> tuple[int, ...]:
        """Position rows of the equality constraint: (0, 1) for task "xy", else (0, 1, 2)."""
        return (0, 1) if self.task == "xy" else (0, 1, 2)

    @property
    def m(self) -> int:
        """Dimension of K_T: 2 for "xy", else 3."""
        return task_dim(self.task)

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
        """Joint stiffnesses (..., n) from ``x`` (..., nx); ``+inf`` for rigid locked joints."""
        return self.kj_full(x[..., self.n_free :])

    @overload
    def x_of(self, q: jax.Array, kj: ArrayLike) -> jax.Array: ...
    @overload
    def x_of(self, q: ArrayLike, kj: jax.Array) -> jax.Array: ...
    @overload
    def x_of(self, q: ArrayLike, kj: ArrayLike) -> np.ndarray: ...

    def x_of(self, q: ArrayLike, kj: ArrayLike) -> np.ndarray | jax.Array:
        """Decision vector (..., nx) from ``q`` (..., n) and ``kj`` (..., n); works on numpy and JAX.
        The ``kj`` entries of rigid locked joints are ignored (whatever they hold)."""
        xp = jnp if isinstance(q, jax.Array) or isinstance(kj, jax.Array) else np
        q = xp.asarray(q)
        return xp.concatenate([q[..., list(self.free_idx)], self.spring_cols(xp.asarray(kj))], axis=-1)

    # ------------------------------------------------------------------ pure building blocks
    def stiffness(self, q: jax.Array, kj: jax.Array) -> jax.Array:
        """Translational stiffness ``K_T`` (..., m, m), N/m, at (q, kj) (S0-4, S0-6); the sum of the
        compliance runs over the sprung joints only (``kj`` of rigid joints is not read)."""
        _, J = self.kinematics(q, task_rows(self.task))
        return self.stiffness_of(J, kj)

    def stiffness_of(self, J: jax.Array, kj: jax.Array) -> jax.Array:
        """``K_T`` (..., m, m) from the task-row Jacobian (..., m_task, n) and ``kj`` (..., n)."""
        return translational_stiffness(self.spring_cols(J), self.spring_cols(kj), task=self.task)

    def objective(self, q: jax.Array, kj: jax.Array, d: jax.Array, r, c) -> jax.Array:
        """Criterion value ``f(K_T(q, kj), d, r[, c])`` (...,). ``d`` (..., 3): only its first m entries are used.

        For the built-in f1 and f2 the axes and the major direction come from one eigen-decomposition
        of the translational compliance (:func:`jaxstiff.stiffness._schur.stiffness_eig_of_compliance`)
        instead of forming ``K_T`` and decomposing it again: the same value to rounding (up to ~1e-7
        relative next to a singular posture, where ``K_T``'s own decomposition is the less accurate
        of the two) at a lower cost per evaluation and gradient."""
        _, J = self.kinematics(q, task_rows(self.task))
        return self.objective_of(J, kj, d, r, c)

    def objective_of(self, J: jax.Array, kj: jax.Array, d: jax.Array, r, c) -> jax.Array:
        """:meth:`objective` from the task-row Jacobian (..., m_task, n) and ``kj`` (..., n)."""
        if self.criterion is f1 or self.criterion is f2:
            C = compliance(self.spring_cols(J), self.spring_cols(kj), task=self.task)
            w, V = stiffness_eig_of_compliance(C)
            alpha, rho = alpha_and_ratio_of_eig(w, V, jnp.asarray(d, dtype=w.dtype)[..., : self.m])
            return f1_of(alpha, rho, r, c) if self.criterion is f1 else f2_of(alpha, rho, r)
        K = self.stiffness_of(J, kj)
        dd = jnp.asarray(d, dtype=K.dtype)[..., : self.m]
        return self.criterion_value(K, dd, r, c)

    def criterion_value(self, K: jax.Array, dd: jax.Array, r, c) -> jax.Array:
        """The criterion at ``K`` (..., m, m) as an array (...,) of K's dtype (a user's criterion may
        return a Python number, or take no ``c``)."""
        out = self.criterion(K, dd, r, c=c) if accepts_c(self.criterion) else self.criterion(K, dd, r)
        return jnp.broadcast_to(jnp.asarray(out, K.dtype), K.shape[:-2])

    def position(self, q: jax.Array) -> jax.Array:
        """TCP position (..., 3), m, base frame."""
        p, _ = self.kinematics(q, (0, 1, 2))
        return p

    def residual(self, q: jax.Array, target: jax.Array) -> jax.Array:
        """Equality constraint ``position(q)[rows] - target[rows]`` (..., len(rows)), m."""
        p = self.position(q)
        rows = list(self.pos_rows)
        return p[..., rows] - jnp.asarray(target, dtype=p.dtype)[..., rows]

    def report(self, q: jax.Array, kj: jax.Array, d: jax.Array, r, c):
        """``(position (...,3), K_T (...,m,m), alpha_deg (...,), ratio (...,), criterion (...,))``."""
        p, J = self.kinematics(q, task_rows(self.task))
        K = self.stiffness_of(J, kj)
        dd = jnp.asarray(d, dtype=K.dtype)[..., : self.m]
        alpha, rho = alpha_and_ratio(K, dd)
        return p, K, alpha, rho, self.criterion_value(K, dd, r, c)

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
        p, Jp = self.kinematics(q, rows)
        c = p[jnp.asarray(rows)] - params[jnp.asarray(rows)]
        Jq = Jp[:, jnp.asarray(self.free_idx)] if self.n_free else jnp.zeros((len(rows), 0), x.dtype)
        A = jnp.concatenate([Jq, jnp.zeros((len(rows), self.n_spring), dtype=x.dtype)], axis=1)
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
