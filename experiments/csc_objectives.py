"""CSC with the seed's objective u (off-diagonal norm, S1-19) vs |K_xd - K_C|_F itself (S1-10).

Every case here is this project's own (seed 001 gives no simulation example); the "frobenius"
objective is beyond the seed (SPEC section 6). Which one ends closer to K_xd, and at what cost?

Cases (the same as experiments/csc_planar3r_hold.py, csc_planar4r_line.py and csc_lwr_path.py set
up, with one beta each):

* planar 3R hold: q0 = (75, -74.74, -76.30) deg, hold x(q0), K_xd = R(30 deg) diag(3000, 1000) R^T
  N/m, constant null step beta = 2e-3 rad, T = 1000 steps;
* planar 4R line: q0 = (90, -60, -60, -50) deg, a 1 m straight line from x(q0) along (-0.6, 0.8)
  in T = 500 steps, the same K_xd, adaptive step (S1-22) beta = 4;
* KUKA LWR 4 (A7 locked, rigid), the shipped default path resampled to T = 300 waypoints, K_xd =
  R_z(30 deg) diag(3000, 1000, 2000) R_z^T N/m, task xyz, IK start from a bent elbow, adaptive step
  beta = 2, one Newton correction per step.

For each: final and mean |K_xd - K_C|_F, final and mean u, the largest tracking error after the
first 10 steps, and the time per rollout step of the forward rollout (compiled; best of 3 runs;
a shared 2-core CPU, so ratios mean more than the absolute numbers).

Outputs (``--out``): ``objectives.png`` (|K_xd - K_C|_F and u along each case, both objectives),
``summary.md`` (the table), ``summary.json``. ``--quick`` runs shorter cases (T / 3).

Usage:
    python experiments/csc_objectives.py [--out DIR] [--quick]
"""

from __future__ import annotations

import json
import math
import os
import sys
import time


def _rot(deg: float, m: int):
    import numpy as np

    c, s = math.cos(math.radians(deg)), math.sin(math.radians(deg))
    R = np.eye(m)
    R[:2, :2] = [[c, -s], [s, c]]
    return R


def _cases(quick: bool) -> list[dict]:
    """The three cases: robot, targets, K_xd, q0 and the rollout keywords."""
    import numpy as np

    import jaxstiff
    from jaxstiff.ik import ik_position
    from jaxstiff.paths import default_path

    div = 3 if quick else 1
    K2 = _rot(30.0, 2) @ np.diag([3000.0, 1000.0]) @ _rot(30.0, 2).T
    r3 = jaxstiff.Robot.from_urdf("planar_3r")
    q3 = np.deg2rad([75.0, -74.74, -76.30])
    r4 = jaxstiff.Robot.from_urdf("planar_4r")
    q4 = np.deg2rad([90.0, -60.0, -60.0, -50.0])
    T4 = 500 // div
    x4 = np.asarray(r4.fk(q4))[:2, 3]
    lwr = jaxstiff.Robot.from_urdf("kuka_lwr4", locked={"lwr_a7": 0.0})
    pts = np.asarray(default_path(n=300 // div).points)
    q7, _ = ik_position(lwr, pts[0], q_start=np.deg2rad([-30.0, 30.0, 0.0, 90.0, 0.0, -30.0, 0.0]))
    K3 = _rot(30.0, 3) @ np.diag([3000.0, 1000.0, 2000.0]) @ _rot(30.0, 3).T
    return [
        dict(
            name="planar 3R hold",
            robot=r3,
            targets=np.tile(np.asarray(r3.fk(q3))[:2, 3], (1000 // div, 1)),
            K=K2,
            q0=q3,
            kw=dict(beta=2e-3, step="constant"),
        ),
        dict(
            name="planar 4R line",
            robot=r4,
            targets=x4 + np.linspace(0.0, 1.0, T4 + 1)[1:, None] * np.array([-0.6, 0.8]),
            K=K2,
            q0=q4,
            kw=dict(beta=4.0, step="adaptive"),
        ),
        dict(
            name="LWR default path",
            robot=lwr,
            targets=pts,
            K=K3,
            q0=np.asarray(q7),
            kw=dict(beta=2.0, step="adaptive", newton=1),
        ),
    ]


def _run(case: dict, objective: str) -> dict:
    """One rollout (compiled first) with its metrics and the best of 3 timed runs."""
    import jax
    import numpy as np

    import jaxstiff

    def go():
        kw = dict(case["kw"])
        beta = kw.pop("beta")
        r = jaxstiff.csc_rollout(case["robot"], case["targets"], case["K"], case["q0"], beta, objective=objective, **kw)
        return jax.block_until_ready(r)

    t0 = time.perf_counter()
    r = go()
    t_first = time.perf_counter() - t0
    times = []
    for _ in range(3):
        t0 = time.perf_counter()
        go()
        times.append(time.perf_counter() - t0)
    r = jax.tree_util.tree_map(np.asarray, r)
    T = r.q.shape[0]
    return {
        "frobenius": r.frobenius,
        "u": r.u,
        "row": {
            "frobenius_start": float(r.frobenius_start),
            "frobenius_end": float(r.frobenius[-1]),
            "frobenius_mean": float(np.mean(r.frobenius)),
            "u_start": float(r.u_start),
            "u_end": float(r.u[-1]),
            "u_mean": float(np.mean(r.u)),
            "max_tracking_error_m": float(np.max(r.tracking_error[10:])),
            "steps": int(T),
            "us_per_step": 1e6 * min(times) / T,
            "compile_and_first_run_s": t_first,
            "nan_guard_steps": int(np.sum((r.status & 4) != 0)),
        },
    }


def _plot(cases: list[dict], runs: dict, path: str) -> None:
    from jaxstiff import plots

    plt = plots.pyplot()
    fig, axes = plt.subplots(len(cases), 2, figsize=(11, 3.2 * len(cases)), squeeze=False)
    styles = {
        "offdiag": dict(color="C0", label="objective u (seed, S1-19)"),
        "frobenius": dict(color="C3", ls="--", label="objective |K_xd - K_C|_F"),
    }
    for i, case in enumerate(cases):
        for obj, st in styles.items():
            run = runs[(case["name"], obj)]
            axes[i, 0].plot(run["frobenius"], **st)
            axes[i, 1].plot(run["u"], **st)
        axes[i, 0].set(title=f"{case['name']}: |K_xd - K_C|_F", xlabel="step k", ylabel="|K_xd - K_C|_F [N/m]")
        axes[i, 1].set(title=f"{case['name']}: u", xlabel="step k", ylabel="u [Nm/rad]")
        for a in axes[i]:
            a.grid(alpha=0.3)
    axes[0, 0].legend(loc="best", fontsize=8)
    fig.suptitle("CSC objectives on this project's own cases (not the seed's)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def _summary_md(cases: list[dict], runs: dict, quick: bool) -> str:
    from jaxstiff.plots import markdown_table

    rows = []
    for case in cases:
        base = runs[(case["name"], "offdiag")]["row"]["us_per_step"]
        for obj in ("offdiag", "frobenius"):
            v = runs[(case["name"], obj)]["row"]
            rows.append(
                {
                    "case (project's own)": case["name"],
                    "objective": obj,
                    "‖K_xd−K_C‖_F start → end [N/m]": f"{v['frobenius_start']:.1f} -> {v['frobenius_end']:.1f}",
                    "mean ‖K_xd−K_C‖_F [N/m]": f"{v['frobenius_mean']:.1f}",
                    "u start → end [Nm/rad]": f"{v['u_start']:.1f} -> {v['u_end']:.1f}",
                    "mean u [Nm/rad]": f"{v['u_mean']:.1f}",
                    "max track err [m]": f"{v['max_tracking_error_m']:.2g}",
                    "us/step": f"{v['us_per_step']:.1f}",
                    "x offdiag": f"{v['us_per_step'] / base:.2f}",
                }
            )
    closer = {}
    for c in cases:
        a, b = (runs[(c["name"], o)]["row"]["frobenius_end"] for o in ("offdiag", "frobenius"))
        closer[c["name"]] = (
            "a tie (same final posture)" if abs(a - b) <= 1e-9 * max(a, b) else ("offdiag" if a < b else "frobenius")
        )
    lines = [
        "# CSC objectives: u (seed 001) vs |K_xd - K_C|_F (this project's own)",
        "",
        "Every case is this project's own (seed 001 has no simulation example); the frobenius "
        "objective is beyond the seed (SPEC section 6). Both measures are reported whichever objective "
        "drives the null-space step." + (" Quick run (T / 3)." if quick else ""),
        "",
        *markdown_table(rows),
        "",
        "Ends closer to K_xd (final ‖K_xd − K_C‖_F): "
        + "; ".join(f"{k}: {v}" for k, v in closer.items())
        + ". Time per rollout step: forward rollout, compiled, best of 3, one rollout at a time on a "
        "shared CPU (`x offdiag` is the ratio to the seed objective's time in the same case).",
        "",
        "![objectives](objectives.png)",
        "",
    ]
    return "\n".join(lines)


def main(argv=None) -> int:
    from jaxstiff.plots import experiment_parser

    ap = experiment_parser("csc_objectives", __doc__ or "")
    ap.add_argument("--quick", action="store_true", help="shorter cases (T / 3)")
    args = ap.parse_args(argv)

    from jaxstiff.runtime._x64 import enable_x64

    enable_x64()
    from jaxstiff.runtime._io import atomic_write_text

    os.makedirs(args.out, exist_ok=True)
    cases = _cases(args.quick)
    runs = {(c["name"], obj): _run(c, obj) for c in cases for obj in ("offdiag", "frobenius")}
    _plot(cases, runs, os.path.join(args.out, "objectives.png"))
    md = _summary_md(cases, runs, args.quick)
    atomic_write_text(os.path.join(args.out, "summary.md"), md)
    summary = {f"{name} / {obj}": run["row"] for (name, obj), run in runs.items()}
    atomic_write_text(os.path.join(args.out, "summary.json"), json.dumps(summary, indent=2))
    print(md)
    return 0


if __name__ == "__main__":
    sys.exit(main())
