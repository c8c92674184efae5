"""CSC on the planar 3R arm holding a point: the project's own case (seed 001 gives no simulation example).

Setup (SPEC section 6; every choice is this project's, see ``csc_cases.planar3r_hold``): links 1 m,
start posture q = (75, -74.74, -76.30) deg (seed 000's Fig. 2 posture), the TCP held at x(q0),
desired stiffness K_xd = R(30 deg) diag(3000, 1000) R(30 deg)^T N/m, task "xy". Holding still, the
seed's adaptive step is zero (|dq_P| = 0), so the constant step is used: a null-space step of
beta = 2e-3 rad per time step, 2000 steps. The closed loop keeps the TCP on the point. A second,
batched run compares beta = 0.5e-3 ... 8e-3 (one vmap). The summary states where the Frobenius
error is lowest: u keeps falling after it (seed 001's Proposition 2 is tested in
``csc_propositions.py``).

Outputs (``--out``, default ``out/csc_planar3r_hold``): ``u_frobenius.png`` (u(t) and
``|K_xd - K_C|_F`` over the steps), ``ellipses.png`` (desired vs realised stiffness ellipses at
the start and at the end), ``self_motion.png`` (the arm's postures along the self-motion, joint
angles over time), ``beta_sweep.png``, ``summary.md`` and ``summary.json``.

Usage:
    python experiments/csc_planar3r_hold.py [--out DIR] [--steps 2000] [--beta 2e-3]
"""

from __future__ import annotations

import json
import os
import sys
import time


def main(argv=None) -> int:  # noqa: PLR0915 - the experiment's procedure, read top to bottom
    from jaxstiff.plots import experiment_parser

    ap = experiment_parser("csc_planar3r_hold", __doc__)
    ap.add_argument("--steps", type=int, default=2000, help="time steps")
    ap.add_argument("--beta", type=float, default=2e-3, help="constant null step, rad")
    args = ap.parse_args(argv)

    from jaxstiff.runtime._x64 import enable_x64

    enable_x64()
    import csc_cases
    import jax
    import numpy as np

    import jaxstiff
    from jaxstiff import plots
    from jaxstiff.runtime._io import atomic_write_text

    plt = plots.pyplot()
    os.makedirs(args.out, exist_ok=True)
    case = csc_cases.planar3r_hold(args.steps, args.beta)
    robot, q0, K, path = case.robot, case.q0, case.K, case.path
    x0 = np.round(path[0], 3) + 0.0  # for the labels (no "-0.000")

    t0 = time.perf_counter()
    res = jax.tree_util.tree_map(np.asarray, jaxstiff.csc_rollout(robot, path, K, q0, args.beta, step="constant"))
    t_run = time.perf_counter() - t0
    adaptive = jaxstiff.csc_rollout(robot, path[:50], K, q0, 1.0, step="adaptive")  # holding: no null motion

    u = np.concatenate([[res.u_start], res.u])
    fr = np.concatenate([[res.frobenius_start], res.frobenius])
    steps = np.arange(len(u))
    k_half = int(np.argmax(u <= 0.5 * u[0])) if np.any(u <= 0.5 * u[0]) else None
    k_min = int(np.argmin(u))
    k_fmin = int(np.argmin(fr))

    # ---------------------------------------------------------------- figure 1: u(t), Frobenius(t)
    fig, ax = plt.subplots(1, 2, figsize=(11, 4))
    ax[0].plot(steps, u, color="C0")
    ax[0].axhline(0.5 * u[0], color="grey", ls="--", lw=1, label="50 % of the start value")
    ax[0].annotate(f"start {u[0]:.0f}", (0, u[0]), textcoords="offset points", xytext=(10, -12))
    ax[0].annotate(
        f"min {u[k_min]:.0f} (step {k_min})", (k_min, u[k_min]), textcoords="offset points", xytext=(-60, 12)
    )
    ax[0].set(xlabel="time step k", ylabel="u(q)  [Nm/rad]", title="off-diagonal joint stiffness u (S1-19)")
    ax[0].legend()
    ax[1].plot(steps, fr, color="C1")
    ax[1].plot(k_fmin, fr[k_fmin], "kv", ms=7)
    ax[1].annotate(
        f"min {fr[k_fmin]:.0f} (step {k_fmin}); then rises\nto {fr[-1]:.0f} while u still falls (to step {k_min})",
        (k_fmin, fr[k_fmin]),
        textcoords="offset points",
        xytext=(-40, 25),
        fontsize=9,
    )
    ax[1].set(
        xlabel="time step k",
        ylabel=r"$\|K_{xd} - K_C\|_F$  [N/m]",
        title="Frobenius error of the realised stiffness (S1-10)",
    )
    for a in ax:
        a.grid(alpha=0.3)
    fig.suptitle(f"Planar 3R holding ({x0[0]:.3f}, {x0[1]:.3f}) m, constant null step beta = {args.beta:g} rad")
    fig.tight_layout()
    plots.save_figure(fig, os.path.join(args.out, "u_frobenius.png"), dpi=120, crop=False)

    # ---------------------------------------------------------------- figure 2: ellipses
    fig, ax = plt.subplots(1, 2, figsize=(12, 5.5))
    for a, (k, label) in zip(ax, [(None, "start"), (len(res.u) - 1, f"end (step {len(res.u)})")], strict=True):
        if k is None:
            J = np.asarray(robot.jacobian(q0))[:2]
            kj = np.clip(np.diag(J.T @ K @ J), 1.0, None)
            KC = np.linalg.inv(J @ np.diag(1 / kj) @ J.T)
            uu, ff = u[0], fr[0]
        else:
            KC, uu, ff = res.K_C[k], res.u[k], res.frobenius[k]
        e_d, e_c = plots.ellipse_points(K, 200), plots.ellipse_points(KC, 200)
        a.plot(e_d[:, 0], e_d[:, 1], "k--", label=r"desired $K_{xd}$")
        a.plot(e_c[:, 0], e_c[:, 1], "C3", label=r"realised $K_C$ (diag of $J^T K_{xd} J$)")
        a.set_aspect("equal")
        a.set(
            xlabel="x stiffness [N/m]",
            ylabel="y stiffness [N/m]",
            title=f"{label}\nu = {uu:.0f} Nm/rad, " + r"$\|K_{xd} - K_C\|_F$" + f" = {ff:.0f} N/m",
        )
        a.grid(alpha=0.3)
        a.legend(loc="lower right", fontsize=8)
    fig.suptitle("Stiffness ellipses {K u : |u| = 1}: desired vs realised by uni-articular joint springs")
    fig.tight_layout()
    plots.save_figure(fig, os.path.join(args.out, "ellipses.png"), dpi=120, crop=False)

    # ---------------------------------------------------------------- figure 3: self-motion
    fig, ax = plt.subplots(1, 2, figsize=(12, 5))
    qs = np.vstack([q0, res.q])
    idx = np.linspace(0, len(qs) - 1, 11).astype(int)
    cmap = plt.get_cmap("viridis")
    for j, k in enumerate(idx):
        P = plots.chain_points(robot, qs[k])[:, :2]
        ax[0].plot(P[:, 0], P[:, 1], "-o", color=cmap(j / (len(idx) - 1)), ms=3, lw=1.5)
    ax[0].plot(*x0, "r*", ms=14, label=f"held TCP point ({x0[0]:.2f}, {x0[1]:.2f}) m", zorder=5)
    ax[0].set_aspect("equal")
    ax[0].set(xlabel="x [m]", ylabel="y [m]", title=f"self-motion: postures every {idx[1] - idx[0]} steps")
    sm = plt.cm.ScalarMappable(cmap=cmap, norm=plt.Normalize(0, len(qs) - 1))
    fig.colorbar(sm, ax=ax[0], label="time step k")
    ax[0].set_ylim(-0.15, 1.35)  # room above the arm for the legend: the held point is at the lower right
    ax[0].legend(loc="upper left", fontsize=9)
    ax[0].grid(alpha=0.3)
    for i in range(3):
        ax[1].plot(np.arange(len(qs)), np.rad2deg(qs[:, i]), label=f"q{i + 1}")
    ax2 = ax[1].twinx()
    ax2.semilogy(np.arange(1, len(qs)), np.maximum(res.tracking_error, 1e-16), color="grey", lw=0.8, label="TCP drift")
    ax2.set_ylabel("TCP drift |x - x_d| [m] (grey)")
    ax[1].set(xlabel="time step k", ylabel="joint angle [deg]", title="joint angles and TCP drift (closed loop)")
    ax[1].legend(loc="center right")
    ax[1].grid(alpha=0.3)
    fig.tight_layout()
    plots.save_figure(fig, os.path.join(args.out, "self_motion.png"), dpi=120, crop=False)

    # ---------------------------------------------------------------- figure 4: batched beta sweep
    betas = np.array([0.5e-3, 1e-3, 2e-3, 4e-3, 8e-3])
    sweep = jax.tree_util.tree_map(np.asarray, jaxstiff.csc_rollout(robot, path, K, q0, betas, step="constant"))
    fig, ax = plt.subplots(figsize=(7, 4.5))
    for b, beta in enumerate(betas):
        ax.plot(np.arange(1, args.steps + 1), sweep.u[b], label=f"beta = {beta:g} rad")
    ax.set(
        xlabel="time step k",
        ylabel="u(q) [Nm/rad]",
        title="constant null step: the step length sets the speed (one vmap)",
    )
    ax.grid(alpha=0.3)
    ax.legend()
    fig.tight_layout()
    plots.save_figure(fig, os.path.join(args.out, "beta_sweep.png"), dpi=120, crop=False)

    summary = {
        "setup": {
            "robot": "planar_3r",
            "q0_deg": [75.0, -74.74, -76.30],
            "x_hold_m": path[0].tolist(),
            "K_xd": K.tolist(),
            "task": "xy",
            "step": "constant",
            "beta_rad": args.beta,
            "steps": args.steps,
        },
        "u_start": float(u[0]),
        "u_end": float(u[-1]),
        "u_min": float(u[k_min]),
        "u_min_step": k_min,
        "u_drop_percent": float(100 * (1 - u[-1] / u[0])),
        "step_u_halved": k_half,
        "max_u_increase_per_step": float(np.max(np.diff(u))),
        "frobenius_start": float(fr[0]),
        "frobenius_end": float(fr[-1]),
        "frobenius_min": float(fr.min()),
        "frobenius_min_step": k_fmin,
        "u_at_frobenius_min": float(u[k_fmin]),
        "frobenius_share_of_K_xd_min_end": [float(fr.min() / np.linalg.norm(K)), float(fr[-1] / np.linalg.norm(K))],
        "max_tcp_drift_m": float(res.tracking_error.max()),
        "q_end_deg": np.rad2deg(res.q[-1]).tolist(),
        "status_counts": csc_cases.status_counts(res.status),
        "adaptive_step_null_motion_rad": float(np.abs(np.asarray(adaptive.q) - q0).max()),
        "beta_sweep": {
            f"{b:g}": {"u_end": float(sweep.u[i, -1]), "max_drift_m": float(sweep.tracking_error[i].max())}
            for i, b in enumerate(betas)
        },
        "run_time_s_incl_compile": round(t_run, 3),
    }
    atomic_write_text(os.path.join(args.out, "summary.json"), json.dumps(summary, indent=2))
    print(
        f"u: {u[0]:.1f} -> {u[-1]:.1f} Nm/rad ({summary['u_drop_percent']:.1f} % lower; min {u[k_min]:.1f} at step {k_min}; "
        f"halved at step {k_half})"
    )
    print(f"Frobenius |K_xd - K_C|: {fr[0]:.1f} -> {fr[-1]:.1f} N/m (min {fr.min():.1f})")
    print(
        f"max TCP drift over {args.steps} steps: {res.tracking_error.max():.2e} m; largest u increase per step: "
        f"{summary['max_u_increase_per_step']:.3g} Nm/rad"
    )
    print(
        f"adaptive step while holding: null motion {summary['adaptive_step_null_motion_rad']:.1e} rad (zero, as the seed's rule gives)"
    )
    for b, v in summary["beta_sweep"].items():
        print(f"  beta {b:>7} rad: u_end {v['u_end']:8.1f}, max drift {v['max_drift_m']:.1e} m")
    kn = float(np.linalg.norm(K))
    body = [
        "## Result",
        "",
        f"- u (S1-19): {u[0]:.1f} -> {u[-1]:.1f} Nm/rad ({summary['u_drop_percent']:.1f} % lower), lowest "
        f"{u[k_min]:.1f} at step {k_min}, halved at step {k_half}; the arm stops there (the constant step "
        "leaves a stationary point of u on the self-motion manifold), statuses: "
        + ", ".join(f"{k} {v}" for k, v in summary["status_counts"].items()),
        f"- |K_xd - K_C|_F: {fr[0]:.1f} -> {fr[-1]:.1f} N/m ({100 * fr[0] / kn:.0f} % -> {100 * fr[-1] / kn:.0f} % of "
        f"|K_xd|_F = {kn:.0f} N/m). **It is lowest at step {k_fmin}** ({fr[k_fmin]:.1f} N/m, "
        f"{100 * fr[k_fmin] / kn:.0f} %, u = {u[k_fmin]:.0f} Nm/rad) **and rises again by "
        f"{fr[-1] - fr[k_fmin]:.1f} N/m while u keeps falling** to {u[-1]:.0f} Nm/rad: lowering u is not "
        "lowering the stiffness error here (seed 001's Proposition 2 is a claim; tested in `csc_propositions`)",
        f"- TCP drift over {args.steps} steps: at most {res.tracking_error.max():.1e} m (closed loop)",
        f"- the seed's adaptive step while holding: null motion {summary['adaptive_step_null_motion_rad']:.1e} rad "
        "(zero, as S1-22 gives for a path that stands still)",
        "",
        "Batched beta sweep (one vmap; constant step, rad per step):",
        "",
        "| beta [rad] | u at the end [Nm/rad] | max TCP drift [m] |",
        "|---|---|---|",
        *(f"| {b} | {v['u_end']:.1f} | {v['max_drift_m']:.1e} |" for b, v in summary["beta_sweep"].items()),
    ]
    csc_cases.write_summary(
        args.out,
        "CSC, planar 3R holding a point",
        case.setup,
        body,
        ["u_frobenius.png", "ellipses.png", "self_motion.png", "beta_sweep.png"],
    )
    print(f"figures, summary.md and summary.json in {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
