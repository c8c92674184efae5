"""The report of a finished sweep: ``summary.md`` and heat maps (``plots/*.png``).

Heat maps show a metric (default: ``share_both``, the share of waypoints that are usable, aligned
and reach the ratio, and ``share_ratio``, the share reaching the ratio; for CSC sweeps the u and
Frobenius reductions) averaged over every other axis and every path, for each pair of varying
numeric axes (or the pairs named in ``[report] heatmaps``). ``summary.md`` has the plan, the
overall means, one table per varying axis (the metric means per value), the best settings and
the heat maps.
"""

from __future__ import annotations

import math
import os
from typing import Any

import numpy as np

from jaxstiff.runtime._io import atomic_write
from jaxstiff.sweep._config import AXES, SweepPlan
from jaxstiff.sweep._metrics import METRICS
from jaxstiff.sweep._store import atomic_write_text, read_table

__all__ = ["heatmap"]


def _label(plan: SweepPlan, axis: str) -> str:
    spec = AXES[plan.kind].get(axis)
    if spec is None:
        return axis
    return f"{axis} ({spec.unit})" if spec.unit else axis


def _fmt(x: object) -> str:
    if isinstance(x, (float, np.floating)):
        if not math.isfinite(x):
            return str(x)
        return f"{x:.4g}"
    return str(x)


def heatmap(df: Any, plan: SweepPlan, x: str, y: str, metric: str, file: str) -> str:
    """Write one heat map: mean of ``metric`` over (x, y), every other axis and path averaged.

    Returns the file written (PNG, atomically).
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    piv = df.pivot_table(index=y, columns=x, values=metric, aggfunc="mean", dropna=False)  # keep all-NaN cells (n/a)
    piv = piv.sort_index(axis=0).sort_index(axis=1)
    ylab = max((len(_fmt(v)) for v in piv.index), default=4)
    width = 2.6 + 0.075 * ylab + 0.8 * max(3, piv.shape[1])
    fig, ax = plt.subplots(figsize=(max(5.5, width), 1.6 + 0.42 * max(4, piv.shape[0])))
    share = metric.startswith("share_") or metric.endswith("_reduction")
    vmin, vmax = (0.0, 1.0) if metric.startswith("share_") else (None, None)
    im = ax.imshow(piv.values, origin="lower", aspect="auto", cmap="viridis", vmin=vmin, vmax=vmax)
    ax.set_xticks(range(piv.shape[1]), [_fmt(v) for v in piv.columns])
    ax.set_yticks(range(piv.shape[0]), [_fmt(v) for v in piv.index])
    ax.set_xlabel(_label(plan, x))
    ax.set_ylabel(_label(plan, y))
    vals = piv.values
    finite = vals[np.isfinite(vals)]
    mid = 0.5 * (np.nanmin(finite) + np.nanmax(finite)) if finite.size else 0.0
    for i in range(vals.shape[0]):
        for j in range(vals.shape[1]):
            v = vals[i, j]
            txt = "n/a" if not np.isfinite(v) else (f"{v:.2f}" if share else f"{v:.3g}")
            ax.text(
                j,
                i,
                txt,
                ha="center",
                va="center",
                fontsize=8,
                color="white" if np.isfinite(v) and v < mid else "black",
            )
    cb = fig.colorbar(im, ax=ax)
    cb.set_label(metric + (" (fraction of waypoints)" if metric.startswith("share_") else ""))
    averaged = (
        "other axes averaged" if "path" in (x, y) else f"other axes and the {len(plan.trajectories)} paths averaged"
    )
    ax.set_title(f"{plan.name}: mean {metric}\n{y} vs {x} ({averaged})", fontsize=9)
    fig.tight_layout()
    try:
        return atomic_write(file, lambda fh: fig.savefig(fh, dpi=110, format="png", bbox_inches="tight"), binary=True)
    finally:
        plt.close(fig)


def _md_table(header: list[str], rows: list[list]) -> str:
    lines = ["| " + " | ".join(header) + " |", "|" + "|".join("---" for _ in header) + "|"]
    lines += ["| " + " | ".join(_fmt(v).replace("|", "\\|") for v in r) + " |" for r in rows]
    return "\n".join(lines)


def _md_header(plan: SweepPlan, manifest: dict | None) -> list[str]:
    """Title, description and the plan's facts (rows, robot, paths, hash, compute time, success rule)."""
    md = [f"# Sweep `{plan.name}` ({plan.kind})", ""]
    desc = plan.config["sweep"].get("description")
    if desc:
        md += [desc, ""]
    wall = None
    if manifest:
        ws = [v.get("wall_s") for v in manifest.get("chunks", {}).values() if v.get("wall_s") is not None]
        wall = sum(ws) if ws else None
    md += [
        f"- rows: **{plan.n_rows}** = {len(plan.settings)} settings x {len(plan.trajectories)} paths; "
        f"{len(plan.groups)} groups, {len(plan.chunks)} chunks",
        f"- robot: `{plan.robot.name}` ({plan.robot.n} joints, {plan.robot.n_free} free)"
        + (f", locked {plan.robot_spec.get('locked')}" if plan.robot_spec.get("locked") else ""),
        "- paths: "
        + ", ".join(f"`{t.name}` (P={t.P})" for t in plan.trajectories[:12])
        + (" ..." if len(plan.trajectories) > 12 else ""),
        f"- plan hash: `{plan.plan_hash[:16]}`",
    ]
    if wall is not None:
        md.append(f"- compute time (sum over chunks): {wall:.1f} s")
    if plan.kind == "shape":
        md.append(
            f"- success: usable waypoint with alpha < {plan.alpha_tol_deg:g} deg and ratio within "
            f"{100 * plan.ratio_rel_tol:g}% of r (f1: ratio >= {1 - plan.ratio_rel_tol:g} r)"
        )
    return md


def _md_axes_and_overall(plan: SweepPlan, df: Any) -> list[str]:
    """The axes table and the overall statistics of every metric."""
    md = ["", "## Axes", ""]
    md.append(
        _md_table(
            ["axis", "values", "meaning"],
            [
                [k, ", ".join(_fmt(x) if not isinstance(x, list) else str(x) for x in v), AXES[plan.kind][k].doc]
                for k, v in plan.axes.items()
            ],
        )
    )
    md += ["", "## Overall (over the rows with a value: a metric of no usable waypoint is NaN)", ""]
    md.append(
        _md_table(
            ["metric", "rows", "mean", "min", "max", "meaning"],
            [
                [
                    m,
                    f"{int(df[m].notna().sum())} of {len(df)}",
                    float(df[m].mean()),
                    float(df[m].min()),
                    float(df[m].max()),
                    METRICS[plan.kind][m],
                ]
                for m in METRICS[plan.kind]
            ],
        )
    )
    return md


def _md_by_axis(plan: SweepPlan, df: Any, metrics: list[str], varying: list[str]) -> list[str]:
    """The mean metrics per value of each varying axis, and the five best settings."""
    md: list[str] = []
    for ax in varying:
        g = df.groupby(ax, sort=True)[metrics].mean()
        md += ["", f"## By {_label(plan, ax)}", ""]
        md.append(
            _md_table(
                [ax] + [f"mean {m}" for m in metrics],
                [[i] + [float(v) for v in r] for i, r in zip(g.index, g.values, strict=True)],
            )
        )
    if varying:
        key = metrics[0]
        cols = varying
        g = df.groupby(cols, sort=True)[metrics].mean().sort_values(key, ascending=False).head(5)
        md += ["", f"## Best settings by mean {key}", ""]
        idx = [list(i) if isinstance(i, tuple) else [i] for i in g.index]
        md.append(
            _md_table(
                cols + [f"mean {m}" for m in metrics],
                [i + [float(v) for v in r] for i, r in zip(idx, g.values, strict=True)],
            )
        )
    return md


def _md_heatmaps(plan: SweepPlan, df: Any, metrics: list[str], plots: str) -> list[str]:
    """Draw the configured heat maps into ``plots`` and link them."""
    md: list[str] = []
    if plan.heatmaps:
        md += ["", "## Heat maps", ""]
        for x, y in plan.heatmaps:
            for m in metrics:
                f = heatmap(df, plan, x, y, m, os.path.join(plots, f"heatmap_{m}_{y}_vs_{x}.png"))
                md.append(f"![{m} over {y} x {x}](plots/{os.path.basename(f)})")
                md.append("")
    return md


def write_report(plan: SweepPlan, out: str, manifest: dict | None = None) -> str:
    """Write ``summary.md`` and ``plots/heatmap_*.png`` for the finished sweep in ``out``; return summary.md."""
    df = read_table(out)
    plots = os.path.join(out, "plots")
    os.makedirs(plots, exist_ok=True)
    metrics = list(plan.metrics)
    varying = plan.varying_axes()
    md = _md_header(plan, manifest)
    md += _md_axes_and_overall(plan, df)
    md += _md_by_axis(plan, df, metrics, varying)
    md += _md_heatmaps(plan, df, metrics, plots)
    md += [
        "",
        "Files: `results.parquet` (one row per path x setting; `result_file`/`result_index` point to the "
        "per-waypoint arrays), `arrays/`, `timing.csv`, `manifest.json`.",
        "",
    ]
    f = os.path.join(out, "summary.md")
    atomic_write_text(f, "\n".join(md))
    return f
