"""Throughput of the shaping pipeline on a batch of KUKA LWR configurations.

Stages, timed cumulatively (each row runs everything above it in one jitted function and returns
that stage's own products; the share of a stage is the difference to the row above, clipped at 0:
XLA fuses across stages, so writing out a stage's products can cost more than computing the next):

    fk+J        fk_and_jacobian (pose and 6x7 geometric Jacobian)
    +stiffness  translational_stiffness (task "full": Schur complement of the 6x6 compliance)
    +ellipsoid  ellipsoid (3x3 Jacobi eigen-decomposition, ratio, volume)
    +f2         f2 criterion (S0-15) against a direction per configuration, r = 5
    +grad       value and gradient of f2 w.r.t. q and kj (reverse mode through all of the above)

Compilation is timed apart (lower + compile). Each stage is called ``--repeats`` times after a
warm-up; the fastest wall time is reported (the median and the process CPU time are in the JSON),
since other processes may share the CPU. ``--compare-lapack`` also times the same stages
with LAPACK kernels (``jnp.linalg.inv`` and ``jnp.linalg.eigh``) in place of the closed forms,
and reports their max difference, to back the choice of closed forms.

Usage:
    python scripts/bench_pipeline.py                       # 1e5 configurations, float64
    python scripts/bench_pipeline.py --batch 10000 --repeats 3 --json out/bench_pipeline.json
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import tempfile
import time

import numpy as np


def _parse(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--batch", type=int, default=100_000, help="configurations per call (default 1e5)")
    p.add_argument(
        "--repeats",
        type=int,
        default=7,
        help="timed calls per stage; the fastest is reported (the machine may be shared)",
    )
    p.add_argument("--task", default="full", choices=["full", "xyz"], help="translational stiffness task")
    p.add_argument("--ratio", type=float, default=5.0, help="r of f2")
    p.add_argument("--float32", action="store_true", help="run in float32 instead of float64")
    p.add_argument("--compare-lapack", action="store_true", help="also time LAPACK inv/eigh variants")
    p.add_argument("--json", metavar="FILE", help="write the results as JSON")
    p.add_argument("--seed", type=int, default=0)
    args = p.parse_args(argv)
    if args.batch < 1 or args.repeats < 1:
        p.error("--batch and --repeats must be >= 1")
    return args


def main(argv: list[str] | None = None) -> int:  # noqa: C901, PLR0915 - the benchmark's procedure, read top to bottom
    """Time the stages of the pipeline (and, with --compare-lapack, a LAPACK variant). Long (~160
    lines) because the staged kernels are closures over the JAX modules imported after the x64
    switch and over the batch; they are defined here, next to the timing loop that uses them."""
    args = _parse(argv)
    import jax
    import jax.numpy as jnp

    from jaxstiff.runtime._x64 import enable_x64

    if not args.float32:
        enable_x64()
    import importlib

    import jaxstiff
    from jaxstiff._numerics.eig import eigh_descending, gap_tol  # times the package's private numerics
    from jaxstiff._numerics.safe import safe_ratio  # times the package's private numerics
    from jaxstiff.stiffness._ellipsoid import alpha_rad

    # jaxstiff.stiffness is also reached as a package attribute; fetch the module itself
    stiffness = importlib.import_module("jaxstiff.stiffness")

    dtype = jnp.float32 if args.float32 else jnp.float64
    robot = jaxstiff.Robot.from_urdf("kuka_lwr4")
    rng = np.random.default_rng(args.seed)
    lo, hi = np.asarray(robot.lower), np.asarray(robot.upper)
    q = jnp.asarray(rng.uniform(lo, hi, size=(args.batch, robot.n)), dtype=dtype)
    kj = jnp.asarray(rng.uniform(1.0, 100.0, size=(args.batch, robot.n)), dtype=dtype)
    d = rng.normal(size=(args.batch, 3))
    d = jnp.asarray(d / np.linalg.norm(d, axis=1, keepdims=True), dtype=dtype)
    task, r = args.task, args.ratio

    def make_stages(K_fn, eig_fn):
        # Each stage computes everything up to it and returns only its own products (what a caller
        # truncating the pipeline there would keep); earlier products are consumed, not written out.
        def fkJ(q, kj, d):
            T, J = jaxstiff.fk_and_jacobian(robot, q)
            return T, J

        def stiff(q, kj, d):
            T, J = fkJ(q, kj, d)
            return (K_fn(J, kj),)

        def ellip(q, kj, d):
            (K,) = stiff(q, kj, d)
            w, V = eig_fn(K)
            return w, V, safe_ratio(w[..., 0], w[..., 1]), jnp.prod(w, -1)

        def crit(q, kj, d):
            w, V, rho, vol = ellip(q, kj, d)
            alpha = alpha_rad(V[..., :, 0], d) * (180.0 / np.pi)
            return ((1.0 + alpha) * (1.0 + jnp.abs(r - rho)),)

        def grad(q, kj, d):
            def total(q, kj):
                (f,) = crit(q, kj, d)
                return jnp.sum(f), f

            (_, f), (gq, gk) = jax.value_and_grad(total, argnums=(0, 1), has_aux=True)(q, kj)
            return f, gq, gk

        return [("fk+J", fkJ), ("+stiffness", stiff), ("+ellipsoid", ellip), ("+f2", crit), ("+grad", grad)]

    closed = make_stages(lambda J, kj: stiffness.translational_stiffness(J, kj, task), eigh_descending)

    def lapack_K(J, kj):  # LAPACK inverse of the undamped compliance (fine at random postures)
        C = stiffness.compliance(J, kj, task)
        K = jnp.linalg.inv(C)[..., :3, :3]
        return 0.5 * (K + jnp.swapaxes(K, -1, -2))

    def lapack_eig_primal(K):
        w, V = jnp.linalg.eigh(K)
        return w[..., ::-1], V[..., ::-1]

    @jax.custom_jvp
    def lapack_eig(K):
        return lapack_eig_primal(K)

    @lapack_eig.defjvp
    def _lapack_eig_jvp(primals, tangents):  # the same rule as jaxstiff's, with LAPACK matmuls
        (K,), (dK,) = primals, tangents
        w, V = lapack_eig_primal(K)
        dK = 0.5 * (dK + jnp.swapaxes(dK, -1, -2))
        A = jnp.swapaxes(V, -1, -2) @ dK @ V
        gap = w[..., None, :] - w[..., :, None]
        scale = jnp.max(jnp.abs(w), axis=-1)[..., None, None]
        ok = jnp.abs(gap) > gap_tol(K.dtype) * scale + jnp.finfo(K.dtype).tiny
        Finv = jnp.where(ok, 1.0 / jnp.where(ok, gap, 1.0), 0.0)
        return (w, V), (jnp.diagonal(A, axis1=-2, axis2=-1), V @ (Finv * A))

    lapack = make_stages(lapack_K, lapack_eig)

    def run(stages, label):
        rows, outs = [], {}
        for name, fn in stages:
            t0 = time.perf_counter()
            timed = jax.jit(fn).lower(q, kj, d).compile()
            t_compile = time.perf_counter() - t0
            jax.block_until_ready(timed(q, kj, d))  # warm-up
            times, cpu = [], []
            for _ in range(args.repeats):
                t0, c0 = time.perf_counter(), time.process_time()
                jax.block_until_ready(timed(q, kj, d))
                times.append(time.perf_counter() - t0)
                cpu.append(time.process_time() - c0)
            t = float(np.min(times))
            rows.append(
                {
                    "stage": name,
                    "seconds": t,
                    "median_s": float(np.median(times)),
                    "cpu_seconds": float(np.min(cpu)),
                    "compile_s": t_compile,
                    "configs_per_s": args.batch / t,
                }
            )
            outs[name] = timed(q, kj, d)
        prev = 0.0
        total = rows[-1]["seconds"]
        for row in rows:
            row["stage_s"] = max(row["seconds"] - prev, 0.0)
            row["share"] = row["stage_s"] / total
            prev = row["seconds"]
        print(f"\n{label}: batch {args.batch}, {np.dtype(dtype).name}, task {task!r}, fastest of {args.repeats} calls")
        print(
            f"{'stage':<12} {'cumul. s':>10} {'stage s':>10} {'share':>7} {'configs/s':>12} {'CPU s':>8} {'compile s':>10}"
        )
        for row in rows:
            print(
                f"{row['stage']:<12} {row['seconds']:>10.4f} {row['stage_s']:>10.4f} {row['share']:>6.1%} "
                f"{row['configs_per_s']:>12.3e} {row['cpu_seconds']:>8.3f} {row['compile_s']:>10.2f}"
            )
        return rows, outs

    results = {"closed_form": None}
    rows, outs = run(closed, "closed forms (jaxstiff)")
    results["closed_form"] = rows
    # sanity: the values must be finite
    f_val = np.asarray(outs["+f2"][0])
    g_q, g_k = (np.asarray(x) for x in outs["+grad"][1:])
    finite = bool(np.isfinite(f_val).all() and np.isfinite(g_q).all() and np.isfinite(g_k).all())
    print(f"all values and gradients finite: {finite}")
    results["finite"] = finite

    if args.compare_lapack:
        rows_l, outs_l = run(lapack, "LAPACK inv + eigh (for comparison)")
        results["lapack"] = rows_l
        f_l = np.asarray(outs_l["+f2"][0])
        rel = np.abs(f_l - f_val) / np.maximum(np.abs(f_l), 1.0)
        # f2 is smooth only where the posture is well conditioned; report the median and 99th percentile
        results["f2_rel_diff_vs_lapack"] = {"median": float(np.median(rel)), "p99": float(np.quantile(rel, 0.99))}
        print(
            f"f2 closed form vs LAPACK, relative difference: median {np.median(rel):.2e}, p99 {np.quantile(rel, 0.99):.2e}"
        )

    results["meta"] = {
        "batch": args.batch,
        "repeats": args.repeats,
        "dtype": np.dtype(dtype).name,
        "task": task,
        "ratio": r,
        "robot": "kuka_lwr4",
        "device": str(jax.devices()[0]),
        "cpu_count": os.cpu_count(),
        "platform": platform.platform(),
        "python": sys.version.split()[0],
        "jax": jax.__version__,
        "numpy": np.__version__,
        "jaxstiff": jaxstiff.__version__,
    }
    if args.json:
        folder = os.path.dirname(os.path.abspath(args.json))
        os.makedirs(folder, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=folder, suffix=".tmp")
        with os.fdopen(fd, "w") as fh:
            json.dump(results, fh, indent=2)
        os.replace(tmp, args.json)
        print(f"wrote {args.json}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
