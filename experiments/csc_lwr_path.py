"""CSC on the KUKA LWR 4 along the shipped default path, and CSC compared with the shaping solver.

The project's own case: seed 001 gives no simulation example, and seed 000 gives no path
(``csc_cases.lwr_path`` writes every choice down; the summary prints them next to the results).
Setup: ``urdf/kuka_lwr4.urdf`` with the 7th joint (flange rotation) locked at 0, as seed 000 does:
for a TCP on the A7 axis that joint does not move the TCP, so 6 free joints and task "xyz" (3
position rows) leave 3 redundant degrees of freedom. Path: the shipped default path
(:func:`jaxstiff.paths.default_path`, a single half-sine bump in the plane z = 0.30 m, 60 waypoints
about 9 mm apart), refined to 10 CSC steps per segment (591 steps; the original waypoints are every 10th).
Desired stiffness along the path (K_xd varying, (T, 3, 3)): 3000 N/m along the path tangent, 1000 N/m
across it and vertically, ``K_xd = R_t diag(3000, 1000, 1000) R_t^T``. Start posture: damped
least-squares IK (:func:`jaxstiff.ik.ik_position`) of the first waypoint from a bent-elbow guess
(-30, 30, 0, 90, 0, -30, 0) deg. Adaptive step (S1-22), beta = 0 (tracking only), 2, 5, 10, 20 in one
batched call, one Newton correction per step. The minimum of u lies beyond the LWR's joint limits
(without avoidance, beta >= 5 spends most steps with a joint clamped at its limit and the TCP leaves
the path by millimetres), so joint-limit avoidance is on by default: ``joint_limits="sum"``,
``jl_gain=0.3`` (``--joint-limits off`` shows the other case).

Comparison with the shaping solver (issue item 5): ``jaxstiff.shape`` (seed 000, SLSQP per waypoint)
on the 60 original waypoints with criterion f2, ratio r = 3 (K_xd's ratio), task "xyz", the same
start posture, its default rate limits (2 deg, 5 Nm/rad per waypoint) and stiffness range 1-100 Nm/rad.
The two methods realise different sizes (CSC: kj = diag(J^T K_xd J), thousands of Nm/rad; shaping:
1-100 Nm/rad, then CMS), so they are compared on shape and orientation: the angle alpha between the
realised major axis and the tangent, the axis ratio rho, and the scale-free Frobenius error
``min_k |K_xd - k K_C|_F / |K_xd|_F`` (k chosen optimally: the CMS factor that fits best).
Per waypoint, the summary says where the shaping run loses the ratio (|rho - 3| > 0.05) and the
alignment (alpha > 5 deg), and which of its bounds are active there: joints at the rate limit
(2 deg per waypoint), joint stiffnesses at the rate limit (5 Nm/rad per waypoint) or at the range
1-100 Nm/rad, joints at their limits.

Outputs (``--out``, default ``out/csc_lwr_path``): ``u_frobenius.png``, ``ellipses_top.png`` (xy
block of the stiffness, desired vs realised, along the path), ``joints.png`` (self-motion),
``csc_vs_shape.png`` (per waypoint, onsets marked), ``csc_vs_shape.csv`` (per waypoint),
``summary.md``, ``summary.json``.

Usage:
    python experiments/csc_lwr_path.py [--out DIR] [--substeps 10] [--no-shape]
"""

from __future__ import annotations

import json
import os
import sys
import time


def main(argv=None) -> int:  # noqa: PLR0915 - the experiment's procedure, read top to bottom
    from jaxstiff.plots import experiment_parser

    ap = experiment_parser("csc_lwr_path", __doc__)
    ap.add_argument("--substeps", type=int, default=10, help="CSC steps per path segment")
    ap.add_argument("--joint-limits", default="sum", choices=["off", "priority", "sum"], help="joint-limit avoidance")
    ap.add_argument("--jl-gain", type=float, default=0.3, help="joint-limit avoidance gain")
    ap.add_argument("--no-shape", action="store_true", help="skip the comparison with jaxstiff.shape")
    args = ap.parse_args(argv)

    from jaxstiff.runtime._x64 import enable_x64

    enable_x64()
    import csc_cases
    import jax
    import jax.numpy as jnp
    import numpy as np

    import jaxstiff
    from jaxstiff import plots
    from jaxstiff.runtime._io import atomic_write_text

    plt = plots.pyplot()
    os.makedirs(args.out, exist_ok=True)
    case = csc_cases.lwr_path(args.substeps, args.joint_limits, args.jl_gain)
    robot, q0, pts, K = case.robot, case.q0, case.path, case.K
    base, tang, wp_index = case.extra["base"], case.extra["tangents"], case.extra["wp_index"]
    tang_w = np.asarray(base.directions, dtype=float)
    T, S = len(pts), args.substeps
    betas = np.array([0.0, 2.0, 5.0, 10.0, 20.0])

    t0 = time.perf_counter()
    res = jax.tree_util.tree_map(
        np.asarray,
        jaxstiff.csc_rollout(
            robot, pts, K, q0, betas, step="adaptive", newton=1, joint_limits=args.joint_limits, jl_gain=args.jl_gain
        ),
    )
    t_first = time.perf_counter() - t0
    t0 = time.perf_counter()
    jax.block_until_ready(
        jaxstiff.csc_rollout(
            robot, pts, K, q0, betas, step="adaptive", newton=1, joint_limits=args.joint_limits, jl_gain=args.jl_gain
        ).q
    )
    t_csc = time.perf_counter() - t0

    def shape_metrics(KC, Kd, d):
        """alpha (deg, major axis vs d), rho = l1/l2, scale-free Frobenius min_k |Kd - k KC| / |Kd|."""
        w, V = np.linalg.eigh(KC)
        v1 = V[..., :, -1]
        cosang = np.abs(np.sum(v1 * d, -1)) / np.linalg.norm(d, axis=-1)
        alpha = np.degrees(np.arccos(np.clip(cosang, 0, 1)))
        rho = w[..., -1] / w[..., -2]
        k = np.sum(Kd * KC, axis=(-2, -1)) / np.sum(KC * KC, axis=(-2, -1))
        rel = np.linalg.norm(Kd - k[..., None, None] * KC, axis=(-2, -1)) / np.linalg.norm(Kd, axis=(-2, -1))
        return alpha, rho, rel

    u = np.hstack([res.u_start[:, None], res.u])
    fr = np.hstack([res.frobenius_start[:, None], res.frobenius])
    csc_alpha, csc_rho, csc_rel = shape_metrics(res.K_C, K[None], tang[None])
    best = int(np.argmin(csc_rel.mean(axis=1)))

    # ---------------------------------------------------------------- figure: u and Frobenius
    labels = ["beta = 0 (tracking only)" if beta == 0 else f"beta = {beta:g}" for beta in betas]
    plots.figure_u_frobenius(
        np.arange(T + 1),
        u,
        fr,
        labels,
        os.path.join(args.out, "u_frobenius.png"),
        xlabel="time step k (about 1 mm of path per step)",
        suptitle="KUKA LWR 4 (A7 locked), default path, K_xd = 3000 N/m along the tangent, 1000 across; adaptive CSC",
    )

    # ---------------------------------------------------------------- figure: ellipses, top view
    fig, ax = plt.subplots(1, 2, figsize=(9, 7.5), constrained_layout=True)
    scale = 1.5e-5  # m of drawing per N/m
    for a, b in zip(ax, (0, best), strict=True):
        a.plot(pts[:, 0], pts[:, 1], color="0.55", lw=2.5)
        for k in wp_index[::6]:
            e_d = pts[k, :2] + scale * plots.ellipse_points(K[k, :2, :2])
            e_c = pts[k, :2] + scale * plots.ellipse_points(res.K_C[b, k, :2, :2])
            a.plot(e_d[:, 0], e_d[:, 1], "k--", lw=1)
            a.plot(e_c[:, 0], e_c[:, 1], color="C3", lw=1.2)
        a.set_aspect("equal")
        a.grid(alpha=0.3)
        a.set(xlabel="x [m]", ylabel="y [m]")
        a.set_title(
            ("beta = 0: tracking only" if betas[b] == 0 else f"beta = {betas[b]:g}: with CSC")
            + f"\nmean scale-free error {csc_rel[b].mean():.3f}, mean alpha {csc_alpha[b].mean():.1f} deg",
            fontsize=10,
        )
    handles = [
        plt.Line2D([], [], color="0.55", lw=2.5),
        plt.Line2D([], [], color="k", ls="--"),
        plt.Line2D([], [], color="C3"),
    ]
    fig.legend(
        handles,
        [
            f"TCP path (z = {case.extra['z']:.2f} m)",
            r"desired $K_{xd}$, xy block (1 cm of drawing = %.0f N/m)" % (0.01 / scale),
            r"realised $K_C$, xy block",
        ],
        loc="lower center",
        ncol=3,
    )
    fig.get_layout_engine().set(rect=(0, 0.07, 1, 0.93))
    fig.suptitle("LWR stiffness in the path plane: {K u : |u| = 1} of the 2x2 xy block, every 6th waypoint")
    plots.save_figure(fig, os.path.join(args.out, "ellipses_top.png"), dpi=120, crop=False)

    # ---------------------------------------------------------------- figure: joints (self-motion)
    fig, ax = plt.subplots(1, 2, figsize=(12, 4.5), sharey=True)
    for a, b in zip(ax, (0, best), strict=True):
        qs = np.vstack([q0, res.q[b]])
        for i in range(6):
            a.plot(np.arange(T + 1), np.rad2deg(qs[:, i]), label=robot.joint_names[i])
        a.set(
            xlabel="time step k", title="beta = 0: tracking only" if betas[b] == 0 else f"beta = {betas[b]:g}: with CSC"
        )
        a.grid(alpha=0.3)
    ax[0].set_ylabel("joint angle [deg] (A7 locked at 0)")
    ax[1].legend(fontsize=8, ncol=2)
    fig.suptitle(
        f"LWR joint angles along the path; max tracking error {res.tracking_error[best].max():.1e} m (one Newton correction per step)"
    )
    fig.tight_layout()
    plots.save_figure(fig, os.path.join(args.out, "joints.png"), dpi=120, crop=False)

    summary = {
        "setup": {
            "robot": "kuka_lwr4, lwr_a7 locked at 0",
            "task": "xyz",
            "path": f"default_path() refined x{S}",
            "steps": T,
            "K_xd": "R_t diag(3000, 1000, 1000) R_t^T along the tangent",
            "q0_deg": np.rad2deg(q0).tolist(),
            "step": "adaptive",
            "newton": 1,
            "joint_limits": args.joint_limits,
            "jl_gain": args.jl_gain,
        },
        "csc": {
            f"{beta:g}": {
                "u_start": float(u[b, 0]),
                "u_end": float(u[b, -1]),
                "u_mean": float(u[b].mean()),
                "frobenius_mean": float(fr[b, 1:].mean()),
                "scale_free_error_mean": float(csc_rel[b].mean()),
                "alpha_mean_deg": float(csc_alpha[b].mean()),
                "rho_mean": float(csc_rho[b].mean()),
                "max_tracking_error_m": float(res.tracking_error[b].max()),
                "status_counts": csc_cases.status_counts(res.status[b]),
            }
            for b, beta in enumerate(betas)
        },
        "csc_time_5_rollouts_s": round(t_csc, 4),
        "csc_time_first_call_incl_compile_s": round(t_first, 3),
    }
    print(
        f"{'beta':>5} {'u start':>9} {'u end':>9} {'|dK|_F mean':>12} {'scale-free err':>15} {'alpha [deg]':>12} {'rho':>6} {'track err [m]':>14}"
    )
    for beta in betas:
        v = summary["csc"][f"{beta:g}"]
        print(
            f"{beta:5g} {v['u_start']:9.1f} {v['u_end']:9.1f} {v['frobenius_mean']:12.1f} {v['scale_free_error_mean']:15.3f} "
            f"{v['alpha_mean_deg']:12.2f} {v['rho_mean']:6.2f} {v['max_tracking_error_m']:14.2e}"
        )
    print(f"CSC: 5 rollouts x {T} steps in {t_csc:.3f} s after compilation")

    # ---------------------------------------------------------------- CSC vs the shaping solver
    if not args.no_shape and hasattr(jaxstiff, "shape"):
        t0 = time.perf_counter()
        sres = jaxstiff.shape(robot, base, criterion="f2", ratio=3.0, task="xyz", q0=q0)
        t_shape = time.perf_counter() - t0
        qs = jnp.asarray(sres.q[0])
        J = jaxstiff.jacobian(robot, qs)
        KT = np.asarray(jaxstiff.translational_stiffness(J, jnp.asarray(sres.kj[0]), task="xyz"))
        s_alpha, s_rho, s_rel = shape_metrics(KT, K[wp_index], tang_w)
        c_alpha, c_rho, c_rel = csc_alpha[best, wp_index], csc_rho[best, wp_index], csc_rel[best, wp_index]
        z_alpha, z_rho, z_rel = csc_alpha[0, wp_index], csc_rho[0, wp_index], csc_rel[0, wp_index]
        usable = np.isin(sres.status[0], (0, 1, 2))
        bounds = shaping_bounds(robot, sres, q0)
        lose_rho = first_true(np.abs(s_rho - 3.0) > 0.05)
        lose_alpha = first_true(s_alpha > 5.0)
        summary["comparison_at_the_60_waypoints"] = {
            "shape_f2_r3": {
                "alpha_mean_deg": float(s_alpha.mean()),
                "rho_mean": float(s_rho.mean()),
                "scale_free_error_mean": float(s_rel.mean()),
                "time_s": round(t_shape, 2),
                "usable_waypoints": int(usable.sum()),
                "max_position_error_m": float(np.max(sres.pos_error[0])),
            },
            f"csc_beta_{betas[best]:g}": {
                "alpha_mean_deg": float(c_alpha.mean()),
                "rho_mean": float(c_rho.mean()),
                "scale_free_error_mean": float(c_rel.mean()),
                "time_s_5_rollouts": round(t_csc, 4),
            },
            "csc_beta_0": {
                "alpha_mean_deg": float(z_alpha.mean()),
                "rho_mean": float(z_rho.mean()),
                "scale_free_error_mean": float(z_rel.mean()),
            },
        }
        fig, ax = plt.subplots(1, 3, figsize=(15, 4.5))
        x = np.arange(len(wp_index))
        for a, (vals, lab) in zip(
            ax,
            [
                ((z_alpha, c_alpha, s_alpha), "alpha: major axis vs tangent [deg]"),
                ((z_rho, c_rho, s_rho), r"axis ratio $\rho = \lambda_1/\lambda_2$ (wanted 3)"),
                ((z_rel, c_rel, s_rel), r"scale-free error $\min_k \|K_{xd} - k K\|_F / \|K_{xd}\|_F$"),
            ],
            strict=True,
        ):
            a.plot(x, vals[0], color="grey", label="CSC, beta = 0 (tracking only)")
            a.plot(x, vals[1], color="C0", label=f"CSC, beta = {betas[best]:g}")
            a.plot(x, vals[2], color="C2", label="shape: f2, r = 3 (SLSQP per waypoint)")
            a.set(xlabel="waypoint p", title=lab)
            a.grid(alpha=0.3)
        ax[1].axhline(3.0, color="k", ls=":", lw=1)
        for a in ax:
            for p_on, col, what in ((lose_rho, "C2", "ratio"), (lose_alpha, "C1", "alignment")):
                if p_on is not None:
                    a.axvline(p_on, color=col, ls="--", lw=1, label=f"shaping loses the {what} (waypoint {p_on})")
        ax[0].legend(fontsize=8)
        fig.suptitle(f"Same path and K_xd: CSC ({t_csc:.2f} s for 5 rollouts) vs shaping solver ({t_shape:.1f} s)")
        fig.tight_layout()
        plots.save_figure(fig, os.path.join(args.out, "csc_vs_shape.png"), dpi=120, crop=False)
        cmp = summary["comparison_at_the_60_waypoints"]
        print("\nCSC vs the shaping solver at the 60 waypoints (scale-free: sizes differ by design)")
        print(f"{'method':>28} {'alpha mean [deg]':>17} {'rho mean':>9} {'scale-free err':>15} {'time [s]':>9}")
        for name, v in cmp.items():
            tt = v.get("time_s", v.get("time_s_5_rollouts", float("nan")))
            print(
                f"{name:>28} {v['alpha_mean_deg']:17.2f} {v['rho_mean']:9.2f} {v['scale_free_error_mean']:15.3f} {tt:9.3f}"
            )
        closer = "shape" if s_rel.mean() < c_rel.mean() else "CSC"
        summary["closer_to_K_xd"] = closer
        print(f"closer to K_xd (scale-free error): {closer}")
        per_wp = [
            {
                "waypoint": str(p),
                "CSC beta 0: alpha/rho/err": f"{z_alpha[p]:.1f} / {z_rho[p]:.2f} / {z_rel[p]:.3f}",
                f"CSC beta {betas[best]:g}: alpha/rho/err": f"{c_alpha[p]:.1f} / {c_rho[p]:.2f} / {c_rel[p]:.3f}",
                "shape: alpha/rho/err": f"{s_alpha[p]:.1f} / {s_rho[p]:.2f} / {s_rel[p]:.3f}",
                "shape: bounds active": bounds[p] or "none",
            }
            for p in range(len(wp_index))
        ]
        plots.save_table_csv(per_wp, os.path.join(args.out, "csc_vs_shape.csv"))
        summary["shaping_onsets"] = {"ratio_lost_from_waypoint": lose_rho, "alignment_lost_from_waypoint": lose_alpha}
        shown = sorted(
            {0, 59, *(range(0, 60, 10)), *[p + d for p in (lose_rho, lose_alpha) if p is not None for d in (-1, 0, 1)]}
        )
        cmp_md = comparison_text(cmp, lose_rho, lose_alpha, bounds, s_rho, s_alpha, sres)
        cmp_md += ["", *plots.markdown_table([per_wp[p] for p in shown if 0 <= p < len(per_wp)])]
    else:
        summary["comparison_at_the_60_waypoints"] = "skipped"
        cmp_md = ["(comparison with the shaping solver skipped)"]
    kn = np.linalg.norm(K, axis=(-2, -1)).mean()
    body = [
        "## CSC result",
        "",
        "| beta | u start -> end [Nm/rad] | u mean | |K_xd - K_C|_F mean [N/m] (share of |K_xd|_F) | scale-free error | alpha mean [deg] | rho mean | max tracking error [m] | statuses |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for beta in betas:
        v = summary["csc"][f"{beta:g}"]
        body.append(
            f"| {beta:g} | {v['u_start']:.0f} -> {v['u_end']:.0f} | {v['u_mean']:.0f} | {v['frobenius_mean']:.0f} "
            f"({100 * v['frobenius_mean'] / kn:.0f} %) | {v['scale_free_error_mean']:.3f} | {v['alpha_mean_deg']:.1f} | "
            f"{v['rho_mean']:.2f} | {v['max_tracking_error_m']:.1e} | "
            + ", ".join(f"{k} {n}" for k, n in v["status_counts"].items())
            + " |"
        )
    i_u = int(np.argmin([summary["csc"][f"{b:g}"]["u_mean"] for b in betas]))
    i_f = int(np.argmin([summary["csc"][f"{b:g}"]["frobenius_mean"] for b in betas]))
    body += [
        "",
        f"Lowest mean u: beta = {betas[i_u]:g}; lowest mean Frobenius error: beta = {betas[i_f]:g}"
        + (
            " (the same run)."
            if i_u == i_f
            else ": ranking by u is not ranking by the stiffness error (seed 001's Proposition 2 is tested in `csc_propositions`)."
        )
        + " With beta >= 5 most steps end with a joint at its limit (status `joint limit reached`).",
        "",
        "## CSC vs the shaping solver (jaxstiff.shape, f2, r = 3)",
        "",
        "Shaping settings (the project's reading of seed 000, which gives none of them): rate limits 2 deg and "
        "5 Nm/rad per waypoint, joint stiffness range 1-100 Nm/rad, the same start posture, the 60 original "
        "waypoints. CSC realises kj = diag(J^T K_xd J) (thousands of Nm/rad), shaping 1-100 Nm/rad: they are "
        "compared on shape only (alpha, rho, the scale-free error).",
        "",
        *cmp_md,
    ]
    figs = ["u_frobenius.png", "ellipses_top.png", "joints.png"] + (
        ["csc_vs_shape.png"] if "closer_to_K_xd" in summary else []
    )
    csc_cases.write_summary(args.out, "CSC, KUKA LWR 4 along the default path", case.setup, body, figs)

    atomic_write_text(os.path.join(args.out, "summary.json"), json.dumps(summary, indent=2))
    print(f"figures and summary.json in {args.out}")
    return 0


def first_true(mask) -> int | None:
    """Index of the first True of a 1-D mask, None if there is none."""
    import numpy as np

    idx = np.flatnonzero(mask)
    return int(idx[0]) if idx.size else None


def shaping_bounds(robot, sres, q0) -> list[str]:
    """Per waypoint, the shaping run's active bounds as text (free joints only, waypoint 0 has no rate limit).

    ``dq`` rate limit (|q_p - q_p-1| within 1e-6 rad of it), ``dk`` rate limit, ``kmin`` / ``kmax``
    (the stiffness range, within 1e-3 Nm/rad), ``qlim`` (joint limit, within 1e-4 rad).
    """
    import numpy as np

    st = sres.meta["settings"]
    q, kj = np.asarray(sres.q[0]), np.asarray(sres.kj[0])
    dq = np.abs(np.diff(np.vstack([q0, q]), axis=0))
    dk = np.abs(np.diff(np.vstack([sres.kj0[0], kj]), axis=0))
    free = np.asarray(robot.free, dtype=bool)
    names = [n.replace("lwr_", "").upper() for n in robot.joint_names]
    out = []
    for p in range(len(q)):
        tests = {
            "dq rate": dq[p] >= st["dq"] - 1e-6,
            "dk rate": dk[p] >= st["dk"] - 1e-6,
            "kmin": kj[p] <= st["kmin"] + 1e-3,
            "kmax": kj[p] >= st["kmax"] - 1e-3,
            "qlim": (q[p] <= robot.lower + 1e-4) | (q[p] >= robot.upper - 1e-4),
        }
        if p == 0:
            tests.pop("dq rate"), tests.pop("dk rate")
        parts = [
            f"{k}: {' '.join(names[i] for i in np.flatnonzero(m & free))}" for k, m in tests.items() if (m & free).any()
        ]
        out.append("; ".join(parts))
    return out


def comparison_text(cmp, lose_rho, lose_alpha, bounds, s_rho, s_alpha, sres) -> list[str]:
    """Markdown lines: the mean table and, per waypoint, where and why the shaping run loses ratio or alignment."""
    lines = ["| method | alpha mean [deg] | rho mean | scale-free error mean |", "|---|---|---|---|"]
    lines += [
        f"| {k} | {v['alpha_mean_deg']:.2f} | {v['rho_mean']:.2f} | {v['scale_free_error_mean']:.3f} |"
        for k, v in cmp.items()
    ]
    lines.append("")
    if lose_rho is None:
        lines.append("The shaping run keeps rho within 0.05 of 3 at every waypoint.")
    else:
        lines.append(
            f"**Where the shaping run loses the ratio:** rho = 3 holds up to waypoint {lose_rho - 1}; from waypoint "
            f"{lose_rho} it falls (lowest {s_rho[lose_rho:].min():.2f}). Active bounds at waypoint {lose_rho - 1}: "
            f"{bounds[lose_rho - 1] or 'none'}; at waypoint {lose_rho}: {bounds[lose_rho] or 'none'}. The f2 optimum "
            "is then on its bounds: the joint stiffnesses sit at the ends of the 1-100 Nm/rad range and the joints "
            "move at the 2 deg rate limit or rest on a joint limit, so no reachable (q, kj) gives ratio 3 with the "
            "axis on the tangent and f2 trades ratio for alignment (criterion "
            f"{sres.criterion[0, lose_rho - 1]:.2f} -> {sres.criterion[0, -1]:.2f}; 1 is its optimum)."
        )
        pin = first_true(["qlim" in b for b in bounds])
        if pin is not None and pin < lose_rho:
            lines.append(
                f"The bounds close in before the ratio goes: a joint limit is active from waypoint {pin} ({bounds[pin]}); "
                f"the solver keeps rho = 3 for {lose_rho - pin} more waypoints by moving the remaining joints at the rate "
                "limit, then runs out of room."
            )
    if lose_alpha is None:
        lines.append(
            f"The shaping run keeps the major axis within 5 deg of the tangent at every waypoint (max {s_alpha.max():.1f} deg)."
        )
    else:
        lines.append(
            f"**Where the shaping run loses the alignment:** from waypoint {lose_alpha} (alpha {s_alpha[lose_alpha]:.1f} "
            f"deg; rho there {s_rho[lose_alpha]:.2f}: {'two axes of almost equal length, so the major axis is ill-defined and can swap' if s_rho[lose_alpha] < 1.1 else 'a clear major axis off the tangent'}). "
            f"Active bounds there: {bounds[lose_alpha] or 'none'}."
        )
    return lines


if __name__ == "__main__":
    sys.exit(main())
