"""The ``[solver_options]`` and ``[report]`` tables of a sweep, checked against its axes.

Every solver of the sweep must know every option (a typo would otherwise be ignored) and accept
its value (:func:`jaxstiff.solvers._base.check_options`), before any work starts; the report's heat
maps must name varying axes (or ``"path"``) and its metrics those of the kind.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Mapping
from typing import Any

from jaxstiff.settings._shape import SINGLE_START_SOLVERS
from jaxstiff.sweep._axes import AXES
from jaxstiff.sweep._schema import ReportTable, SweepConfigError, check_table, suggest, typename, validate

__all__: list[str] = []


def solver_options(cfg: Mapping[str, Any], axes: Mapping[str, list], source: str = "") -> dict:
    """``[solver_options]``: numbers or strings; each solver of the sweep must know and accept them."""
    from jaxstiff.solvers._base import check_options, options_for_solver, solver_option_names
    from jaxstiff.solvers._trajectory import WARM_STARTS

    tbl = check_table(cfg.get("solver_options", {}), "solver_options", source)
    known = None
    which = ""
    if "solver" in axes:  # each row's solver gets the options it knows
        warm = tbl.get("warm", "pgd") if tbl.get("warm", "pgd") in WARM_STARTS else "pgd"
        names = [solver_option_names(s, warm) for s in axes["solver"]]
        if all(n is not None for n in names):
            known = tuple(sorted(set().union(*names)))  # type: ignore[arg-type]
        which = (
            "SLSQP" if set(axes["solver"]) <= set(SINGLE_START_SOLVERS) else "solver(s) " + ", ".join(axes["solver"])
        )
    for k, v in tbl.items():
        key = f"solver_options.{k}"
        if known is not None and k not in known:
            raise SweepConfigError(
                key, f"unknown option{suggest(k, known)} for {which}; options: {', '.join(known)}", source
            )
        if isinstance(v, bool) or not isinstance(v, (int, float, str)):
            raise SweepConfigError(key, f"expected a number or a string, got {typename(v)} {v!r}", source)
        if isinstance(v, float) and not math.isfinite(v) or (isinstance(v, (int, float)) and v < 0):
            raise SweepConfigError(key, f"must be a finite number >= 0, got {v!r}", source)
    if known is not None:  # values, as each solver of the sweep will see them
        for s in axes["solver"]:
            try:
                check_options(s, options_for_solver(s, tbl))
            except ValueError as e:
                raise SweepConfigError("solver_options", str(e), source) from None
    return tbl


def _heatmap_pairs(hm: Any, kind: str, axes: Mapping[str, list], n_paths: int, source: str) -> list[tuple[str, str]]:
    if not isinstance(hm, list) or not all(isinstance(p, list) and len(p) == 2 for p in hm):
        raise SweepConfigError(
            "report.heatmaps", f'expected a list of axis pairs, e.g. [["ratio", "dq_deg"]], got {hm!r}', source
        )
    pairs = []
    for i, (a, b) in enumerate(hm):
        key = f"report.heatmaps[{i}]"
        for ax in (a, b):
            if ax == "path":
                if n_paths < 2:
                    raise SweepConfigError(key, "'path' needs at least two paths", source)
                continue
            if ax not in AXES[kind]:
                raise SweepConfigError(
                    key, f"unknown axis {ax!r}{suggest(str(ax), list(AXES[kind]) + ['path'])} (axes and 'path')", source
                )
            if len(axes[ax]) < 2:
                raise SweepConfigError(key, f"axis {ax!r} has one value; a heat map needs two varying axes", source)
        if a == b:
            raise SweepConfigError(key, f"the two axes must differ, got {a!r} twice", source)
        pairs.append((a, b))
    return pairs


def report_choices(
    cfg: Mapping[str, Any], kind: str, axes: Mapping[str, list], n_paths: int, source: str = ""
) -> tuple[tuple[tuple[str, str], ...], tuple[str, ...]]:
    """``[report]``: the heat maps' axis pairs (default: up to 6 pairs of varying axes) and metrics."""
    from jaxstiff.sweep._metrics import METRICS

    tbl = validate(ReportTable, cfg.get("report", {}), "report", source)
    if tbl.heatmaps is not None:
        pairs = _heatmap_pairs(tbl.heatmaps, kind, axes, n_paths, source)
    else:  # numeric pairs first, then numeric x categorical, then categorical pairs; at most 6
        numeric = [k for k, s in AXES[kind].items() if s.type in ("float", "int") and len(axes[k]) > 1]
        others = [k for k, s in AXES[kind].items() if s.type not in ("float", "int") and len(axes[k]) > 1]
        pairs = (
            list(itertools.combinations(numeric, 2))
            + [(a, b) for a in numeric for b in others]
            + list(itertools.combinations(others, 2))
        )[:6]
    allowed = list(METRICS[kind])
    metrics = tbl.metrics if tbl.metrics is not None else allowed[:2]
    if not isinstance(metrics, list) or not metrics:
        raise SweepConfigError("report.metrics", f"expected a non-empty list of metric names, got {metrics!r}", source)
    for m in metrics:
        if m not in allowed:
            raise SweepConfigError(
                "report.metrics",
                f"unknown metric {m!r}{suggest(str(m), allowed)}; metrics: {', '.join(allowed)}",
                source,
            )
    return tuple(pairs), tuple(metrics)
