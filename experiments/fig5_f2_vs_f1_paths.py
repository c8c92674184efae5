"""Is f2 ("ratio exactly r") harder than f1 ("ratio at least r")? Both over a family of paths, not one.

The default-path runs (``fig4_f1``, ``fig5_f2``) compare the criteria on one path, and their
first waypoint is a tie that rounding decides (a 1e-13 m shift of the curved path moves the waypoints
where they hold by tens). Here both run on the same family, everything else at jaxstiff's defaults
(KUKA LWR 4, ``lwr_a7`` locked and rigid, task "full", r = 5, c = 0.01, solver "slsqp", rate limits
2 deg and 5 Nm/rad per waypoint):

* ``shift``: the default path moved by 24 offsets: 12 at rounding level (1e-13 to 6e-13 m along x,
  both signs) and 12 of up to 5 mm (uniform in a 1 cm cube, seed 0), directions unchanged;
* ``random``: 16 paths of 60 waypoints traced by the TCP in a smooth joint-space motion from a random
  posture by up to 0.35 rad a joint (``scripts/bench_batch.py: random_reachable_paths``, seed 0):
  reachable by construction; ``random-wide``: 16 more by up to 0.8 rad a joint (seed 1), longer
  paths that turn more (every joint still moves less than the 2 deg rate limit per waypoint).

Per path and criterion: the share of the waypoints in target (alpha < 1 deg and rho >= 0.98 r for f1,
|rho - r| / r < 2 % for f2, unreachable waypoints count as not in target) and the first waypoint
that is not. Writes ``summary.md`` (distribution tables and the per-path comparison), ``paths.csv``
(one row per path) and ``f2_vs_f1_paths.png`` (f1's share against f2's per path; first failing waypoint).

Usage:
    python experiments/fig5_f2_vs_f1_paths.py [--out DIR] [--quick]
"""

from __future__ import annotations

import os
import sys

N_TINY, N_SMALL, N_RANDOM, R_TARGET = 12, 12, 16, 5.0
FAMILIES = (("shift", "o", "C0"), ("random", "s", "C3"), ("random-wide", "^", "C2"))


def family(robot, quick: bool):
    """``[(family, label, Path)]``: the shifted default paths, then the random reachable ones."""
    import numpy as np

    import jaxstiff

    sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "scripts"))
    from bench_batch import random_reachable_paths

    base = jaxstiff.default_path()
    pts, dirs = np.asarray(base.points), np.asarray(base.directions)
    n_tiny, n_small, n_rand = (2, 2, 2) if quick else (N_TINY, N_SMALL, N_RANDOM)
    tiny = [np.array([s * k * 1e-13, 0.0, 0.0]) for k in range(1, n_tiny // 2 + 1) for s in (1, -1)]
    small = np.random.default_rng(0).uniform(-5e-3, 5e-3, size=(n_small, 3))
    out = [("shift", f"dx = {o[0]:+.0e} m", jaxstiff.Path(pts + o, dirs)) for o in tiny]
    out += [
        ("shift", "d = (" + ", ".join(f"{1e3 * v:+.1f}" for v in o) + ") mm", jaxstiff.Path(pts + o, dirs))
        for o in small
    ]
    for fam, seed, span in (("random", 0, 0.35), ("random-wide", 1, 0.8)):
        rp, rd, _ = random_reachable_paths(robot, n_rand, len(pts), seed=seed, span=span)
        out += [(fam, f"{fam} {i}", jaxstiff.Path(rp[i], rd[i])) for i in range(n_rand)]
    return out


def first_off(it) -> int:
    """The first waypoint not in target, or -1 when all are."""
    import numpy as np

    off = np.flatnonzero(~it)
    return int(off[0]) if off.size else -1


def stats(x) -> str:
    """'median (min-max; quartiles q1-q3)' of shares in percent."""
    import numpy as np

    q = np.percentile(100 * np.asarray(x), [0, 25, 50, 75, 100])
    return f"{q[2]:.1f} % ({q[0]:.1f}-{q[4]:.1f}; quartiles {q[1]:.1f}-{q[3]:.1f})"


def verdict(rows) -> list[str]:
    """What the table shows about "f2 is harder than f1", computed from the rows (Markdown lines)."""
    import numpy as np

    parts, signs = [], set()
    for fam, _, _ in FAMILIES:
        sel = [r for r in rows if r["family"] == fam]
        if not sel:
            continue
        a, b = np.array([r["share_f1"] for r in sel]), np.array([r["share_f2"] for r in sel])
        more, fewer = int((a > b).sum()), int((a < b).sum())
        signs.add("f1" if more > fewer else "f2" if fewer > more else "=")
        parts.append(
            f"`{fam}`: all waypoints in target on {int((a == 1).sum())} of {len(sel)} paths with f1 and "
            f"{int((b == 1).sum())} with f2; f1 holds more waypoints on {more}, f2 on {fewer}"
        )
    if signs == {"="}:
        head = "Neither criterion holds more often on any family."
    elif len(signs - {"="}) > 1:
        head = (
            "Which criterion holds more depends on the paths: f1 on some families, f2 on others, so "
            '"f2 is harder than f1" is not a general result on this evidence (one robot, r = 5, default settings).'
        )
    else:
        lead = next(iter(signs - {"="}))
        head = (
            f"On every family where they differ, {lead} holds at more waypoints (one robot, r = 5, default settings)."
        )
    return ["**What it shows.** " + head + " " + "; ".join(parts) + "."]


def main(argv=None) -> int:
    from jaxstiff.plots import experiment_parser

    ap = experiment_parser("fig5_f2_vs_f1_paths", __doc__ or "")
    ap.add_argument("--quick", action="store_true", help="2 paths of each family")
    args = ap.parse_args(argv)

    from jaxstiff.runtime._x64 import enable_x64
    from jaxstiff.shaping import prefer_sync_cpu_dispatch

    enable_x64()
    prefer_sync_cpu_dispatch()

    import warnings

    import numpy as np

    import jaxstiff
    from jaxstiff.plots import pyplot, save_figure
    from jaxstiff.runtime._io import atomic_write_text

    warnings.simplefilter("ignore")  # missed-target warnings: the tables say it all
    os.makedirs(args.out, exist_ok=True)
    robot = jaxstiff.Robot.from_urdf("kuka_lwr4", locked={"lwr_a7": 0.0})
    rows = []
    for fam, label, path in family(robot, args.quick):
        row = {"family": fam, "path": label}
        for crit in ("f1", "f2"):
            it = jaxstiff.shape(robot, path, crit, R_TARGET).in_target[0]
            row[f"share_{crit}"], row[f"first_off_{crit}"] = float(it.mean()), first_off(it)
        rows.append(row)
        print(f"{fam:6s} {label:32s} f1 {row['share_f1']:6.1%} (first off {row['first_off_f1']:3d})   "
              f"f2 {row['share_f2']:6.1%} (first off {row['first_off_f2']:3d})", flush=True)  # fmt: skip
    keys = list(rows[0])
    atomic_write_text(
        os.path.join(args.out, "paths.csv"), ",".join(keys) + "\n" + "".join(",".join(f'"{r[k]}"' for k in keys) + "\n" for r in rows)
    )  # fmt: skip

    lines = ["## f2 against f1 over a family of paths (KUKA LWR 4, r = 5, slsqp)", ""]
    lines += [
        "Setup: KUKA LWR 4 (`lwr_a7` locked and rigid), task full, r = 5, c = 0.01, solver slsqp, rate limits "
        "2 deg and 5 Nm/rad per waypoint (jaxstiff's defaults), f1 and f2 on the same paths: `shift`, the default "
        "path moved by 12 offsets at rounding level (1e-13 to 6e-13 m along x) and 12 of up to 5 mm (uniform in a 1 cm "
        "cube); `random`, 16 reachable paths of 60 waypoints traced by the TCP in a smooth joint motion of up to "
        "0.35 rad a joint from a random posture; `random-wide`, 16 more of up to 0.8 rad a joint. In target: alpha < "
        "1 deg and rho >= 0.98 r (f1) or |rho - r| / r < 2 % (f2); an unreachable waypoint counts as not in target.",
        "",
    ]
    lines += [
        "| family | paths | f1 in target: median (min-max; quartiles) | f2 in target | f1 > f2 / equal / f1 < f2 (paths) | paths all in target f1 / f2 | first waypoint off, median over the paths that fail, f1 / f2 |"
    ]
    lines += ["|---|---|---|---|---|---|---|"]
    for fam in (*(f for f, _, _ in FAMILIES), "all"):
        sel = [r for r in rows if fam in ("all", r["family"])]
        a, b = np.array([r["share_f1"] for r in sel]), np.array([r["share_f2"] for r in sel])
        fo1 = [r["first_off_f1"] for r in sel if r["first_off_f1"] >= 0]
        fo2 = [r["first_off_f2"] for r in sel if r["first_off_f2"] >= 0]
        med = lambda v: f"{np.median(v):.0f}" if v else "-"  # noqa: E731
        lines.append(
            f"| {fam} | {len(sel)} | {stats(a)} | {stats(b)} | {(a > b).sum()} / {(a == b).sum()} / {(a < b).sum()} | "
            f"{(a == 1).sum()} / {(b == 1).sum()} | {med(fo1)} / {med(fo2)} |"
        )
    lines += [
        "",
        "Per path (share in target; first waypoint off, -1: none):",
        "",
        "| family | path | f1 | f2 |",
        "|---|---|---|---|",
    ]
    lines += [
        f"| {r['family']} | {r['path']} | {r['share_f1']:.1%} ({r['first_off_f1']}) | {r['share_f2']:.1%} ({r['first_off_f2']}) |"
        for r in rows
    ]
    lines += ["", *verdict(rows), "", "![f2 against f1](f2_vs_f1_paths.png)", ""]

    plt = pyplot()
    fig, (ax, bx) = plt.subplots(1, 2, figsize=(12, 5), gridspec_kw={"wspace": 0.3})
    for j_fam, (fam, mk, col) in enumerate(FAMILIES):
        sel = [r for r in rows if r["family"] == fam]
        ax.scatter(
            [100 * r["share_f2"] for r in sel],
            [100 * r["share_f1"] for r in sel],
            marker=mk,
            color=col,
            alpha=0.7,
            label=f"{fam} ({len(sel)} paths)",
        )
        for j, crit in enumerate(("f1", "f2")):
            fo = [r[f"first_off_{crit}"] if r[f"first_off_{crit}"] >= 0 else 60 for r in sel]
            y = j + 0.2 * (j_fam - 1) + np.random.default_rng(j).uniform(-0.05, 0.05, len(fo))
            bx.scatter(fo, y, marker=mk, color=col, alpha=0.7, label=f"{fam}" if j == 0 else None)
    ax.plot([0, 100], [0, 100], "k:", lw=1, label="f1 = f2")
    ax.set(xlabel="f2: waypoints in target (%)", ylabel="f1: waypoints in target (%)", xlim=(-3, 103), ylim=(-3, 103),
           title="(a) share in target per path (above the line: f1 holds more)")  # fmt: skip
    ax.legend(fontsize=8, loc="upper left")  # the lower right holds paths where f1 fails and f2 holds
    bx.set(xlabel="first waypoint not in target (60: none)", yticks=[0, 1], yticklabels=["f1", "f2"], ylim=(-0.6, 1.6),
           title="(b) where each criterion first fails, per path")  # fmt: skip
    bx.legend(fontsize=8, loc="center left")
    for a_ in (ax, bx):
        a_.grid(alpha=0.3)
    fig.suptitle(f"f1 against f2 on {len(rows)} paths: KUKA LWR 4 (A7 locked), r = 5, slsqp, default limits")
    save_figure(fig, os.path.join(args.out, "f2_vs_f1_paths.png"), dpi=110)
    atomic_write_text(os.path.join(args.out, "summary.md"), "\n".join(lines) + "\n")
    print("\n".join(lines[:10]))
    return 0


if __name__ == "__main__":
    sys.exit(main())
