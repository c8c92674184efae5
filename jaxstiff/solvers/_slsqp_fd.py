"""The seed's own method, as its authors ran it: SLSQP with finite-difference gradients, plain numpy.

Seed 000 solved each waypoint with SLSQP in MATLAB, objective and constraints as ordinary
functions and derivatives by finite differences. This module does the same in numpy, with no JAX
and no jit anywhere in the solve: forward kinematics by 4x4 products, the Cartesian stiffness by a
matrix inverse (S0-4), the ellipsoid by ``numpy.linalg.eigh`` (S0-8), f1/f2 (S0-9, S0-15), and
``scipy.optimize.minimize(method="SLSQP")`` estimating every gradient and the constraint Jacobian
by forward differences (scipy's default step, ``sqrt(machine eps)``).

It exists as the baseline that the JAX solver's speed-up is measured against
(``scripts/bench_shape.py``), and as an independent cross-check of the problem definition. The
greedy chaining, the bounds and the final checks are the same as the JAX solver's
(:func:`jaxstiff.solvers._greedy.greedy_path`), run with the numpy kinematics here.

Only the built-in criteria f1 and f2 are available (a custom criterion is a JAX function).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from typing import Any, cast

import numpy as np

from jaxstiff.model._robot import Robot
from jaxstiff.solvers._base import SolveRequest
from jaxstiff.solvers._greedy import (
    Objective,
    PosAndJac,
    SolverOutput,
    WaypointSolver,
    check_single_start,
    refuse_target_step,
    run_greedy,
)
from jaxstiff.solvers._problem import WaypointProblem
from jaxstiff.solvers._slsqp import check_options, variable_scale

__all__ = ["make_fd_solver", "numpy_objective", "numpy_pos_and_jac", "NumpyChain", "run_request"]


class NumpyChain:
    """Forward kinematics and the geometric Jacobian of a Robot in plain numpy (one posture)."""

    def __init__(self, robot: Robot):
        self.n = robot.n
        self.origins = [robot.origin_matrix(i) for i in range(robot.n)]
        self.axes = [np.asarray(a, float) for a in robot.axes]
        self.types = list(robot.joint_types)
        self.tip = robot.tip_matrix
        self.skew = [np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]]) for a in self.axes]

    def _joint(self, i: int, qi: float) -> np.ndarray:
        M = np.eye(4)
        if self.types[i] == 1:
            M[:3, 3] = self.axes[i] * qi
        else:
            K = self.skew[i]
            M[:3, :3] = np.eye(3) + math.sin(qi) * K + (1.0 - math.cos(qi)) * (K @ K)
        return M

    def position(self, q: np.ndarray) -> np.ndarray:
        T = np.eye(4)
        for i in range(self.n):
            T = T @ self.origins[i] @ self._joint(i, q[i])
        return (T @ self.tip)[:3, 3]

    def position_and_jacobian(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        T = np.eye(4)
        zs, ps = [], []
        for i in range(self.n):
            T = T @ self.origins[i]
            zs.append(T[:3, :3] @ self.axes[i])
            ps.append(T[:3, 3].copy())
            T = T @ self._joint(i, q[i])
        p = (T @ self.tip)[:3, 3]
        J = np.zeros((6, self.n))
        for i in range(self.n):
            if self.types[i] == 1:
                J[:3, i] = zs[i]
            else:
                J[:3, i] = np.cross(zs[i], p - ps[i])
                J[3:, i] = zs[i]
        return p, J


def _split(problem: WaypointProblem) -> tuple[Callable[[np.ndarray], np.ndarray], int]:
    free = list(problem.free_idx)
    nf = problem.n_free
    base = np.nan_to_num(problem.robot.locked_values)

    def q_of(x: np.ndarray) -> np.ndarray:
        q = base.copy()
        q[free] = x[:nf]
        return q

    return q_of, nf


def numpy_objective(problem: WaypointProblem) -> Objective:
    """``(x, params) -> f`` in numpy: K_T (S0-4, S0-6), eigen-decomposition (S0-8), f1/f2."""
    name = getattr(problem.criterion, "__name__", "")
    if name not in ("f1", "f2"):
        raise ValueError(f"solver 'slsqp-fd' supports the criteria f1 and f2 only, got {name or problem.criterion!r}")
    chain = NumpyChain(problem.robot)
    q_of, nf = _split(problem)
    rows = {"xy": [0, 1], "xyz": [0, 1, 2], "full": list(range(6))}[problem.task]
    m = problem.m

    def objective(x: np.ndarray, params: np.ndarray) -> float:
        q, kj = q_of(x), x[nf:]  # kj of the sprung joints (all, or the free ones: rigid locked joints)
        _, J = chain.position_and_jacobian(q)
        Js = problem.spring_cols(J[rows])
        K = np.linalg.inv((Js / kj) @ Js.T)
        if problem.task == "full":
            K = K[:3, :3]
        w, V = np.linalg.eigh(0.5 * (K + K.T))
        v1 = V[:, -1]
        d = params[3 : 3 + m] / np.linalg.norm(params[3 : 3 + m])
        alpha = math.degrees(math.acos(min(1.0, abs(float(v1 @ d)))))
        rho = w[-1] / w[-2]
        r, c = params[6], params[7]
        if name == "f1":
            return (abs(alpha) + c) / (min(rho, r) / r)
        return (1.0 + abs(alpha)) * (1.0 + abs(r - rho))

    return objective


def numpy_pos_and_jac(problem: WaypointProblem) -> PosAndJac:
    """``q (n,) -> (position (3,), J[rows][:, free])`` in numpy (for the repair and the checks)."""
    chain = NumpyChain(problem.robot)
    free = list(problem.free_idx)
    rows = list(problem.pos_rows)

    def pos_and_jac(q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        p, J = chain.position_and_jacobian(q)
        return p, J[np.ix_(rows, free)]

    return pos_and_jac


def make_fd_solver(
    problem: WaypointProblem, options: Mapping[str, Any] | None = None, kj_range: tuple[float, float] | None = None
) -> WaypointSolver:
    """Per-waypoint SLSQP ``(x0, lb, ub, params, maxiter=None) -> SolverOutput``, finite differences.

    Same options and the same variable/objective scaling as the JAX solver
    (:data:`jaxstiff.solvers._slsqp.DEFAULT_OPTIONS`), so the two differ only in where the
    derivatives come from.
    """
    from scipy.optimize import Bounds, minimize

    opts = check_options(options)
    objective = numpy_objective(problem)
    chain = NumpyChain(problem.robot)
    q_of, _ = _split(problem)
    rows = list(problem.pos_rows)
    scale = variable_scale(problem, opts["kj_scale"], kj_range)
    fscale = float(opts["f_scale"])

    def solve(
        x0: np.ndarray, lb: np.ndarray, ub: np.ndarray, params: np.ndarray, maxiter: int | None = None
    ) -> SolverOutput:
        count = [0]

        def fun(y: np.ndarray) -> float:
            count[0] += 1
            return objective(y * scale, params) * fscale

        def con(y: np.ndarray) -> np.ndarray:
            return chain.position(q_of(y * scale))[rows] - params[0:3][rows]

        res = minimize(
            fun,
            x0 / scale,
            bounds=Bounds(lb / scale, ub / scale),  # pyright: ignore[reportArgumentType] (stub: float; arrays are documented)
            constraints=[{"type": "eq", "fun": con}],
            method="SLSQP",
            options={"maxiter": int(maxiter or opts["maxiter"]), "ftol": float(opts["ftol"])},
        )
        return SolverOutput(
            np.asarray(res.x, float) * scale, int(res.status), int(res.status) == 0, int(res.nit), count[0]
        )

    solve.options = opts  # type: ignore[attr-defined]
    return cast(WaypointSolver, solve)  # a function with its options attached


def run_request(req: SolveRequest) -> dict[str, Any]:
    """Adapter for :data:`~jaxstiff.solvers._base.SOLVERS` (``solver="slsqp-fd"``): greedy SLSQP with
    numpy derivatives by finite differences."""
    check_single_start(req.starts, "slsqp-fd")
    refuse_target_step(req.options, "slsqp-fd (the seed's method)")
    prob = req.problem
    solver = make_fd_solver(prob, req.options, (req.limits.kmin, req.limits.kmax))
    return run_greedy(
        req, solver, {"pos_and_jac": numpy_pos_and_jac(prob), "objective": numpy_objective(prob)}, seed_scheme=True
    )
