"""Seed 000, Fig. 6: the criteria f1 (S0-9) and f2 (S0-15) over orientation error x axis ratio.

Every grid point is evaluated by the library itself: a 2x2 stiffness K is built with its major
axis at angle alpha from the desired direction d and axis ratio rho (lambda2 = 100 N/m), and
``jaxstiff.f1`` / ``jaxstiff.f2`` are called on it (so the figure shows what the solvers
minimise, eigen-decomposition included). r = 5, c = 0.01 as in the seed. The minimum sets are
marked in red: f1's is the line alpha = 0, rho >= r (value c), f2's the single point (0, r)
(value 1).

Prints, and writes as ``summary.csv``/``summary.md``: the grid minima and where they lie, and f1,
f2 at a few (alpha, rho). Writes ``fig6_criteria.png``.

Usage:
    python experiments/fig6_criteria.py [--out DIR] [--ratio 5] [--c 0.01]
"""

from __future__ import annotations

import os
import sys


def _parse(argv=None):
    from jaxstiff.plots import experiment_parser

    p = experiment_parser("fig6_criteria", "Seed 000 Fig. 6: f1 and f2 over orientation error x axis ratio")
    p.add_argument("--ratio", type=float, default=5.0, help="r of f1 and f2 (default 5)")
    p.add_argument("--c", type=float, default=0.01, help="c of f1 (default 0.01)")
    p.add_argument("--rho-max", type=float, default=10.0, help="largest axis ratio on the grid (default 10)")
    args = p.parse_args(argv)
    if not args.ratio >= 1.0:
        p.error(f"--ratio must be >= 1, got {args.ratio}")
    if not args.c > 0:
        p.error(f"--c must be > 0, got {args.c}")
    if not args.rho_max > args.ratio:
        p.error(f"--rho-max must exceed --ratio ({args.ratio}), got {args.rho_max}")
    return args


def stiffness_with(alpha_deg, rho, phi_deg: float = 30.0, lam2: float = 100.0):
    """2x2 K (N/m) whose major axis makes ``alpha`` with d = (cos phi, sin phi) and whose axis ratio is ``rho``."""
    import numpy as np

    th = np.radians(phi_deg + np.asarray(alpha_deg, dtype=float))
    c, s = np.cos(th), np.sin(th)
    R = np.stack([np.stack([c, -s], -1), np.stack([s, c], -1)], -2)
    lams = np.stack([rho * lam2 * np.ones_like(th), lam2 * np.ones_like(th)], -1)
    K = (R * lams[..., None, :]) @ np.swapaxes(R, -1, -2)
    d = np.array([np.cos(np.radians(phi_deg)), np.sin(np.radians(phi_deg))])
    return K, np.broadcast_to(d, K.shape[:-1]).copy()


def main(argv=None) -> int:
    args = _parse(argv)
    from jaxstiff.runtime._x64 import enable_x64

    enable_x64()
    import jax.numpy as jnp
    import numpy as np

    import jaxstiff
    from jaxstiff import plots
    from jaxstiff.runtime._io import atomic_write_text

    os.makedirs(args.out, exist_ok=True)
    r, c = args.ratio, args.c
    alpha = np.linspace(-90.0, 90.0, 181)  # 1 deg steps, 0 on the grid
    # 0.05 steps from 1.05: at rho = 1 (a circle) the major axis, hence alpha, is undefined
    n_rho = int(round((args.rho_max - 1.05) / 0.05)) + 1
    rho = np.linspace(1.05, args.rho_max, n_rho)
    rho[np.argmin(np.abs(rho - r))] = r  # r exactly on the grid
    A, P = np.meshgrid(alpha, rho, indexing="ij")
    K, d = stiffness_with(A, P)
    F1 = np.asarray(jaxstiff.f1(jnp.asarray(K), jnp.asarray(d), r, c=c))
    F2 = np.asarray(jaxstiff.f2(jnp.asarray(K), jnp.asarray(d), r))
    i1 = np.unravel_index(np.argmin(F1), F1.shape)
    i2 = np.unravel_index(np.argmin(F2), F2.shape)
    on_line = (A == 0) & (P >= r)
    f1_line = F1[on_line]
    assert np.all(np.isfinite(F1)) and np.all(np.isfinite(F2))

    samples = [(0.0, 1.5), (0.0, r), (0.0, 2 * r), (5.0, r), (5.0, 2.0), (45.0, r), (90.0, r), (-10.0, 8.0)]
    Ks, ds = stiffness_with(np.array([a for a, _ in samples]), np.array([p for _, p in samples]))
    s1 = np.asarray(jaxstiff.f1(jnp.asarray(Ks), jnp.asarray(ds), r, c=c))
    s2 = np.asarray(jaxstiff.f2(jnp.asarray(Ks), jnp.asarray(ds), r))
    rows = [
        {"alpha_deg": f"{a:g}", "rho": f"{p:g}", "f1": f"{v1:.6g}", "f2": f"{v2:.6g}"}
        for (a, p), v1, v2 in zip(samples, s1, s2, strict=True)
    ]

    print(
        f"Seed 000 Fig. 6: criteria on a {alpha.size} x {rho.size} grid, alpha in [-90, 90] deg, rho in [1.05, {args.rho_max:g}], r = {r:g}, c = {c:g}"
    )
    print(
        f"f1: grid minimum {F1[i1]:.6g} (= c); on the whole line alpha = 0, rho >= r ({on_line.sum()} points) f1 = "
        f"{f1_line.min():.6g} ... {f1_line.max():.6g}; off that line f1 >= {F1[~on_line].min():.6g}"
    )
    print(
        f"f2: grid minimum {F2[i2]:.6g} at alpha = {A[i2]:g} deg, rho = {P[i2]:g}; next smallest {np.partition(F2.ravel(), 1)[1]:.6g}"
    )
    print(f"{'alpha_deg':>10s} {'rho':>6s} {'f1':>12s} {'f2':>12s}")
    for row in rows:
        print(f"{row['alpha_deg']:>10s} {row['rho']:>6s} {row['f1']:>12s} {row['f2']:>12s}")

    plots.save_table_csv(rows, os.path.join(args.out, "summary.csv"))
    md = [
        "# Seed 000 Fig. 6: criteria landscape",
        "",
        f"f1 and f2 evaluated by jaxstiff on constructed 2x2 stiffness matrices over α ∈ [−90°, 90°] × ρ ∈ [1.05, {args.rho_max:g}] "
        f"({alpha.size} × {rho.size} points), r = {r:g}, c = {c:g}.",
        "",
        f"* f1 minimum {F1[i1]:.4g} (= c), reached along the whole line α = 0, ρ ≥ r: {f1_line.min():.6g} … {f1_line.max():.6g} "
        f"over {on_line.sum()} grid points; everywhere else ≥ {F1[~on_line].min():.4g}.",
        f"* f2 minimum {F2[i2]:.4g} at the single point α = {A[i2]:g}°, ρ = {P[i2]:g}; the next smallest grid value is "
        f"{np.partition(F2.ravel(), 1)[1]:.4g}.",
        "",
        "![Fig. 6](fig6_criteria.png)",
        "",
    ]
    atomic_write_text(os.path.join(args.out, "summary.md"), "\n".join(md))
    png = plots.figure_criteria(alpha, rho, F1, F2, r, c, os.path.join(args.out, "fig6_criteria.png"))
    print(f"wrote {png}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
