"""The first waypoint's problem (no rate limit) in three SLSQP forms, side by side: a measurement
for the next change of the solvers, not a benchmark of what ships.

Forms, each scipy's SLSQP with JAX derivatives, the same starts and bounds:

* ``direct``: what jaxstiff solves (greedy SLSQP's first waypoint, and the batch solvers' retry
  search): minimise f2 = (1 + alpha)(1 + |r - rho|) with the TCP on the target;
* ``epigraph``: the form of ``scripts/bench_casadi.py``'s CasADi model: two more variables a
  (deg) and t, minimise (1 + a)(1 + t) subject to cos^2(alpha) >= cos^2(a), t >= r - rho,
  t >= rho - r and the TCP on the target (smooth except where the two largest eigenvalues cross);
* ``epigraph + polish``: the epigraph's answer with the lowest f2 per path, then the direct form
  from it (the epigraph stops short of alpha = 0, where the derivative of its first constraint in
  a vanishes: f2 = 1.0001 where 1 is reached).

Paths: ``scripts/bench_batch.py``'s random reachable paths (seed 0), their first waypoints;
starts: the path's start posture with kj mid-range and 7 of greedy SLSQP's rescue starts.
Printed per arm: the SLSQP iterations summed over every start (for the third form: the epigraph's
solves plus the one polish per path), and each path's best f2 among the starts whose answer is on
the path (1e-6 m).

Usage:
    python scripts/first_waypoint_forms.py                  # every arm, 8 paths
    python scripts/first_waypoint_forms.py --arms ur10 --paths 4
"""

from __future__ import annotations

import argparse
import math
import os
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)

DEG = 180.0 / math.pi


def forms_for(robot, r: float):
    """The direct and epigraph SLSQP solves of ``robot``'s first-waypoint problem (f2, ratio r)."""
    import jax
    import jax.numpy as jnp
    from scipy.optimize import minimize

    from jaxstiff.settings import ShapeSettings
    from jaxstiff.solvers._problem import WaypointProblem
    from jaxstiff.stiffness import compliance
    from jaxstiff.stiffness._schur import stiffness_eig_of_compliance

    prob = WaypointProblem(robot, "full", __import__("jaxstiff").f2)
    s = ShapeSettings()
    nf, ns = prob.n_free, prob.n_spring
    free = list(prob.free_idx)
    lo = np.where(np.isfinite(robot.lower), robot.lower, -np.pi)[free]
    hi = np.where(np.isfinite(robot.upper), robot.upper, np.pi)[free]
    lb, ub = np.r_[lo, np.full(ns, s.kmin)], np.r_[hi, np.full(ns, s.kmax)]
    sc = np.r_[np.ones(nf), np.full(ns, s.kmax)]  # SLSQP's variables y = x / sc

    def shape_parts(y, params):
        x = y * sc
        _, J = prob.kinematics(prob.q_of(x), (0, 1, 2, 3, 4, 5))
        C = compliance(prob.spring_cols(J), prob.spring_cols(prob.kj_of(x)), task="full")
        w, V = stiffness_eig_of_compliance(C)
        d = params[3:6] / jnp.linalg.norm(params[3:6])
        return jnp.stack([jnp.dot(V[:, 0], d) ** 2, w[0] / w[1]])

    f_val_grad = jax.jit(jax.value_and_grad(lambda y, p: prob.objective_x(y * sc, p)))
    res = jax.jit(lambda y, p: prob.residual_x(y * sc, p))
    res_jac = jax.jit(jax.jacfwd(lambda y, p: prob.residual_x(y * sc, p)))
    parts, parts_jac = jax.jit(shape_parts), jax.jit(jax.jacfwd(shape_parts))
    bounds = list(zip(lb / sc, ub / sc, strict=True))
    opts = {"maxiter": 1000, "ftol": 1e-10}

    def direct(y0, p):
        eq = {"type": "eq", "fun": lambda y: np.asarray(res(y, p)), "jac": lambda y: np.asarray(res_jac(y, p))}
        sol = minimize(
            lambda y: tuple(np.asarray(v) for v in f_val_grad(y, p)),
            y0,
            jac=True,
            method="SLSQP",
            bounds=bounds,
            constraints=[eq],
            options=opts,
        )
        return sol.x, int(sol.nit)

    def epigraph(y0, p):
        n = y0.size
        c2, rho = (float(v) for v in parts(y0, p))
        z0 = np.r_[y0, math.acos(min(math.sqrt(max(c2, 0.0)), 1.0)) * DEG + 1e-6, abs(r - rho) + 1e-9]

        def obj(z):
            return (1 + z[n]) * (1 + z[n + 1]), np.r_[np.zeros(n), 1 + z[n + 1], 1 + z[n]]

        def ineq(z):
            c2, rho = np.asarray(parts(z[:n], p))
            return np.array([c2 - math.cos(z[n] / DEG) ** 2, z[n + 1] - (r - rho), z[n + 1] + (r - rho)])

        def ineq_jac(z):
            Jc = np.asarray(parts_jac(z[:n], p))
            out = np.zeros((3, n + 2))
            out[0, :n], out[0, n] = Jc[0], math.sin(2 * z[n] / DEG) / DEG
            out[1, :n], out[1, n + 1] = Jc[1], 1.0
            out[2, :n], out[2, n + 1] = -Jc[1], 1.0
            return out

        cons = [
            {
                "type": "eq",
                "fun": lambda z: np.asarray(res(z[:n], p)),
                "jac": lambda z: np.c_[np.asarray(res_jac(z[:n], p)), np.zeros((3, 2))],
            },
            {"type": "ineq", "fun": ineq, "jac": ineq_jac},
        ]
        sol = minimize(
            obj,
            z0,
            jac=True,
            method="SLSQP",
            bounds=bounds + [(0.0, 90.0), (0.0, None)],
            constraints=cons,
            options=opts,
        )
        return sol.x[:n], int(sol.nit)

    def judge(y, p):
        on_path = float(np.linalg.norm(res(y, p))) <= 1e-6
        return float(f_val_grad(y, p)[0]) if on_path else math.inf

    return prob, lb, ub, sc, direct, epigraph, judge


def main(argv=None) -> int:
    from bench_casadi import ROBOTS, make_robot

    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--arms", nargs="+", default=list(ROBOTS), choices=list(ROBOTS))
    ap.add_argument("--paths", type=int, default=8, help="random reachable paths per arm (their first waypoints)")
    ap.add_argument("--ratio", type=float, default=5.0)
    args = ap.parse_args(argv)

    import jax

    jax.config.update("jax_enable_x64", True)
    import jax.numpy as jnp
    from bench_batch import random_reachable_paths

    from jaxstiff.solvers._greedy import rescue_starts
    from jaxstiff.solvers._problem import WaypointProblem

    for arm in args.arms:
        robot = make_robot(arm)
        pts, dirs, q0 = random_reachable_paths(robot, args.paths, 50, seed=0)
        prob, lb, ub, sc, direct, epigraph, judge = forms_for(robot, args.ratio)
        iters = {"direct": 0, "epigraph": 0, "epigraph + polish": 0}
        best: dict[str, list[float]] = {k: [] for k in iters}
        for b in range(args.paths):
            p = jnp.asarray(WaypointProblem.params(pts[b, 0], dirs[b, 0], args.ratio, 0.0))
            ref = np.r_[np.asarray(q0[b])[list(prob.free_idx)], np.full(prob.n_spring, 0.5 * (lb[-1] + ub[-1]))]
            starts = [np.clip(ref, lb, ub), *rescue_starts(prob, 7, ref, lb, ub, pts[b, 0], dirs[b, 0])]
            got = {"direct": [], "epigraph": []}
            for x0 in starts:
                for name, solve in (("direct", direct), ("epigraph", epigraph)):
                    y, nit = solve(np.clip(x0, lb, ub) / sc, p)
                    iters[name] += nit
                    got[name].append((judge(y, p), y))
            for name in got:
                best[name].append(min(f for f, _ in got[name]))
            f_epi, y_epi = min(got["epigraph"], key=lambda t: t[0])
            y_pol, nit = direct(np.clip(y_epi, lb / sc, ub / sc), p) if math.isfinite(f_epi) else (y_epi, 0)
            iters["epigraph + polish"] += nit
            best["epigraph + polish"].append(min(judge(y_pol, p), f_epi) if math.isfinite(f_epi) else math.inf)
        iters["epigraph + polish"] += iters["epigraph"]
        print(
            f"{arm}: SLSQP iterations over {args.paths} paths x {len(starts)} starts: "
            + ", ".join(f"{k} {v}" for k, v in iters.items()),
            flush=True,
        )
        for k, v in best.items():
            print(f"  best f2 per path, {k:18s}: " + " ".join(f"{x:9.4f}" for x in v), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
