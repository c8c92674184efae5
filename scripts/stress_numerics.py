"""Numerical stress: values and gradients of the stiffness chain over many random and exactly
singular configurations (issue 24, item 5). Counts NaN and Inf; prints one table.

For each arm (the shipped KUKA LWR 4 with every joint free, and a Panda-like arm with rotated joint
frames, ``tests/data/panda_like.urdf``) and each posture family (uniform in the joint limits;
elbow straight; wrist straight; both), N configurations with joint stiffnesses log-uniform in
[1e-6, 1e6] Nm/rad and a random unit direction:

* values: ``translational_stiffness`` (tasks full and xyz), ``ellipsoid`` of it (axes, ratio,
  volume), ``orientation_error``, ``f1`` (r = 5) and ``f2`` (r = 5);
* gradients of ``f1``, ``f2`` and the orientation error w.r.t. (q, log kj) through the Jacobian;
* the degenerate ellipsoids: K = s I, K with lambda1 = lambda2 > lambda3, K with lambda1 > lambda2 =
  lambda3, each with values and gradients w.r.t. K.

Every count must be 0 (``translational_axes``, which reports +inf on purpose for a direction the
posture cannot yield in, is not part of it). Float64.

    python scripts/stress_numerics.py [--n 1000000] [--seed 0] [--chunk 20000]
"""

from __future__ import annotations

import argparse
import os
import time

import jax
import jax.numpy as jnp
import numpy as np

jax.config.update("jax_enable_x64", True)

import jaxstiff  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))
PANDA_LIKE = os.path.join(HERE, "..", "tests", "data", "panda_like.urdf")
R = 5.0  #: the ratio of f1 and f2


def robots() -> dict[str, jaxstiff.Robot]:
    """The two arms, every joint free."""
    return {
        "kuka_lwr4": jaxstiff.Robot.from_urdf("kuka_lwr4", locked={}),
        "panda_like": jaxstiff.Robot.from_urdf(PANDA_LIKE),
    }


def postures(robot: jaxstiff.Robot, family: str, n: int, rng: np.random.Generator) -> np.ndarray:
    """(n, 7) joint values of ``family``: uniform in the limits, then the elbow (joint 4) and/or the
    wrist (joint 6) set exactly to 0, where the LWR's axes line up (the Panda's elbow limit excludes 0:
    its singular set is met only outside the limits, which the kernels must survive as well)."""
    q = rng.uniform(robot.lower, robot.upper, size=(n, robot.n))
    if family in ("elbow", "both"):
        q[:, 3] = 0.0
    if family in ("wrist", "both"):
        q[:, 5] = 0.0
    return q


def _scalars(K: jax.Array, d: jax.Array) -> dict[str, jax.Array]:
    e = jaxstiff.ellipsoid(K)
    return {
        "K": K,
        "axes": e.axes,
        "ratio": e.ratio,
        "volume": e.volume,
        "alpha": jaxstiff.orientation_error(K, d),
        "f1": jaxstiff.f1(K, d, R),
        "f2": jaxstiff.f2(K, d, R),
    }


def make_kernel(robot: jaxstiff.Robot, task: str):
    """jit(vmap) of the values and the gradients of one configuration (q, log kj, d)."""

    def stiffness(q, logkj):
        J = jaxstiff.jacobian(robot, q)
        return jaxstiff.translational_stiffness(J, jnp.exp(logkj), task=task)

    def one(q, logkj, d):
        K = stiffness(q, logkj)
        out = _scalars(K, d)
        for name, fn in (("f1", jaxstiff.f1), ("f2", jaxstiff.f2), ("alpha", None)):

            def loss(q_, k_, fn=fn):
                Kq = stiffness(q_, k_)
                return jaxstiff.orientation_error(Kq, d) if fn is None else fn(Kq, d, R)

            gq, gk = jax.grad(loss, argnums=(0, 1))(q, logkj)
            out[f"d{name}/dq"], out[f"d{name}/dlogkj"] = gq, gk
        return out

    return jax.jit(jax.vmap(one))


def degenerate_matrices(n: int, rng: np.random.Generator) -> np.ndarray:
    """(3n, 3, 3): s I; lambda1 = lambda2 > lambda3; lambda1 > lambda2 = lambda3 (random rotations,
    scales 1e-6 ... 1e6)."""
    Q, _ = np.linalg.qr(rng.normal(size=(3 * n, 3, 3)))
    s = 10.0 ** rng.uniform(-6, 6, size=(3 * n, 1))
    lam = np.concatenate([np.ones((n, 3)), np.tile([3.0, 3.0, 1.0], (n, 1)), np.tile([3.0, 1.0, 1.0], (n, 1))]) * s
    return np.einsum("bij,bj,bkj->bik", Q, lam, Q)


@jax.jit
@jax.vmap
def degenerate_kernel(K, d):
    out = _scalars(K, d)
    out["df1/dK"] = jax.grad(lambda K_: jaxstiff.f1(K_, d, R))(K)
    out["df2/dK"] = jax.grad(lambda K_: jaxstiff.f2(K_, d, R))(K)
    out["dalpha/dK"] = jax.grad(lambda K_: jaxstiff.orientation_error(K_, d))(K)
    return out


def _count(out: dict, counts: dict[str, list[int]]) -> None:
    for k, v in out.items():
        a = np.asarray(v)
        c = counts.setdefault(k, [0, 0])
        c[0] += int(np.isnan(a).sum())
        c[1] += int(np.isinf(a).sum())


def _unit(rng: np.random.Generator, n: int) -> np.ndarray:
    d = rng.normal(size=(n, 3))
    return d / np.linalg.norm(d, axis=1, keepdims=True)


def run(n: int, seed: int = 0, chunk: int = 20_000, verbose: bool = False) -> dict[str, dict[str, list[int]]]:
    """``{case: {quantity: [NaN count, Inf count]}}`` over ``n`` configurations per (arm, family,
    task) and ``n`` degenerate matrices of each kind."""
    rng = np.random.default_rng(seed)
    result: dict[str, dict[str, list[int]]] = {}
    for rname, robot in robots().items():
        for task in ("full", "xyz"):
            kernel = make_kernel(robot, task)
            for family in ("uniform", "elbow", "wrist", "both"):
                counts: dict[str, list[int]] = {}
                t0 = time.perf_counter()
                for start in range(0, n, chunk):
                    m = min(chunk, n - start)
                    q = postures(robot, family, m, rng)
                    logkj = rng.uniform(np.log(1e-6), np.log(1e6), size=(m, robot.n))
                    _count(kernel(q, logkj, _unit(rng, m)), counts)
                case = f"{rname} {task} {family}"
                result[case] = counts
                if verbose:
                    print(f"{case}: {time.perf_counter() - t0:.1f} s", flush=True)
    counts = {}
    for start in range(0, n, chunk):
        m = min(chunk, n - start)
        K = degenerate_matrices(m, rng)
        _count(degenerate_kernel(K, _unit(rng, 3 * m)), counts)
    result["degenerate K (s I, l1 = l2, l2 = l3)"] = counts
    return result


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, default=1_000_000, help="configurations per arm, task and family")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--chunk", type=int, default=20_000, help="configurations per compiled call")
    a = ap.parse_args()
    t0 = time.perf_counter()
    res = run(a.n, a.seed, a.chunk, verbose=True)
    bad = 0
    print(f"\n{'case':<44}{'quantities':>11}{'NaN':>8}{'Inf':>8}")
    for case, counts in res.items():
        nan = sum(c[0] for c in counts.values())
        inf = sum(c[1] for c in counts.values())
        bad += nan + inf
        print(f"{case:<44}{len(counts):>11}{nan:>8}{inf:>8}")
    print(f"\n{a.n} configurations per row; {bad} non-finite values in all; {time.perf_counter() - t0:.0f} s")
    raise SystemExit(1 if bad else 0)


if __name__ == "__main__":
    main()
