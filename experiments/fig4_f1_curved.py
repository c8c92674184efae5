"""Seed 000, Fig. 4 on jaxstiff's own tight-turn path (f1, ratio at least 5).

The seed's Fig. 4/5 path is "a curved path in the xy plane" and it says the limits show "where the
trajectory curves most". The shipped default path turns at most 1.9 deg per waypoint, below the
2 deg joint rate limit, so there they never show (``fig4_f1.py``, ``fig5_f2.py``). This run uses the
same setup on an elliptic arc in the horizontal plane z = 0.30 m
(:func:`jaxstiff.paths._generators.ellipse_arc`, :data:`CURVED_PATH_SPEC`): centre (0.55, 0) m,
semi-axes 0.20 m along x and 0.12 m along y, from (0.55, 0.12) through the apex (0.75, 0) to
(0.55, -0.12), 60 waypoints equally spaced (8.6 mm). Its curvature runs from 3 1/m at the two ends to
13.9 1/m at the apex, so the tangent turns about 1.5 deg per waypoint at the ends (below the limit)
and 6.8 deg at the apex (3.4 times the limit), 180 deg in all. The TCP stays 0.56-0.75 m from the
base axis (elbow bent, every waypoint reachable by IK: tests/stiffness/test_paths_curved.py).

Writes ``fig4_f1_curved.png`` (panels (a)-(g) as in ``fig4_f1.py``), ``fig4_f1_curved_turning.png``
(alpha and rho along the path with the tangent's turning per waypoint and the rate limit on a twin
axis, and the joints held by the rate limits), ``summary.md`` (the interpretations, the table of
``fig4_f1.py``, and where the criterion holds and where it gives way, with waypoint ranges and the
turning there), ``summary.csv`` and ``fig4_f1_curved.npz``. ``--quick``: the first 36 waypoints
(up to just past the apex).

Usage:
    python experiments/fig4_f1_curved.py [--out DIR] [--quick]
"""

from __future__ import annotations

import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from fig4_f1 import run  # noqa: E402  (the shared run and summary table)

#: The curved path of the ``_curved`` runs (metres, degrees; base frame of the LWR).
CURVED_PATH_SPEC = {
    "generator": "ellipse_arc",
    "center": [0.55, 0.0, 0.30],
    "semi_x": 0.20,
    "semi_y": 0.12,
    "start_deg": 90.0,
    "end_deg": -90.0,
    "n": 60,
}
QUICK_WAYPOINTS = 36  #: --quick: the first waypoints only (the apex is at 29-30)

#: "holds": alpha below this (deg) and the ratio within 2% (f2) or at least 98% of r (f1), as in the table
from jaxstiff.results._target import ALPHA_TOL_DEG as ALPHA_OK_DEG  # noqa: E402  (the one "in target" rule)
from jaxstiff.results._target import RATIO_REL_TOL, target_masks  # noqa: E402


def curved_path(quick: bool = False):
    """The elliptic arc of :data:`CURVED_PATH_SPEC` (its first :data:`QUICK_WAYPOINTS` with ``quick``)."""
    from jaxstiff.paths import Path, ellipse_arc

    spec = {k: v for k, v in CURVED_PATH_SPEC.items() if k != "generator"}
    p = ellipse_arc(**spec)
    if quick:
        return Path(p.points[:QUICK_WAYPOINTS], p.directions[:QUICK_WAYPOINTS], name="curved (quick)")
    return Path(p.points, p.directions, name="curved")


def setup_text(criterion: str) -> str:
    """The interpretations of the curved run, with the path's numbers computed from the path."""
    import numpy as np

    from jaxstiff.paths import ellipse_curvature, turning_deg

    s = CURVED_PATH_SPEC
    p = curved_path()
    t = turning_deg(p)
    kappa = ellipse_curvature(s["semi_x"], s["semi_y"], np.linspace(s["start_deg"], s["end_deg"], 721))
    dist = np.hypot(p.points[:, 0], p.points[:, 1])
    crit = "f1 (S0-9) with r = 5, c = 0.01" if criterion == "f1" else "f2 (S0-15) with r = 5"
    return (
        "(the seed gives neither the path nor the rate limits; this path is jaxstiff's own, chosen so the "
        "tangent turns by more degrees per waypoint than the joint rate limit dq allows a joint to move; the two are "
        "different quantities, so this does not show the limits cannot follow it) ``urdf/kuka_lwr4.urdf`` with ``lwr_a7`` locked at 0 "
        "(as in the seed) and rigid: it neither moves nor gives, so K_C sums over the 6 free joints (jaxstiff's "
        "default for a locked joint, SPEC section 1); path: an "
        f"elliptic arc in the horizontal plane z = {s['center'][2]:.2f} m (`ellipse_arc`, centre "
        f"({s['center'][0]:.2f}, {s['center'][1]:.2f}) m, semi-axes {s['semi_x']:.2f} m along x and "
        f"{s['semi_y']:.2f} m along y, parameter {s['start_deg']:g} to {s['end_deg']:g} deg), {p.P} waypoints "
        f"{1e3 * float(p.length) / (p.P - 1):.1f} mm apart, {float(p.length):.3f} m long; curvature "
        f"{kappa.min():.1f} to {kappa.max():.1f} 1/m, so the tangent turns {t.min():.2f} deg per waypoint at the "
        f"ends and {t.max():.2f} deg at the apex ({t.sum():.0f} deg in all); TCP {dist.min():.2f}-{dist.max():.2f} m "
        f'from the base axis; desired direction = the path tangent; criterion {crit}; task "full" (K_T = '
        "top-left 3x3 of the 6x6 K_C, S0-6/7); kj in [1, 100] Nm/rad; rate limits 2 deg and 5 Nm/rad per "
        "waypoint (S0-11 ... S0-14; jaxstiff's defaults, the seed gives none), not applied to the first "
        'waypoint; solver "slsqp" (SLSQP per waypoint from the previous one, as in the seed); CMS to a '
        "geometric-mean axis of 1000 N/m."
    )


def _runs(mask):
    """Contiguous runs of True in a (P,) bool array as (first, last) waypoint pairs."""
    import numpy as np

    d = np.diff(np.r_[0, mask.astype(int), 0])
    return list(zip(np.flatnonzero(d == 1).tolist(), (np.flatnonzero(d == -1) - 1).tolist(), strict=True))


def _ranges_text(runs) -> str:
    return ", ".join(f"{a}-{b}" if b > a else f"{a}" for a, b in runs) or "none"


def hold_mask(res):
    """(P,) bool: the waypoints where the criterion holds (alpha and ratio as in the summary table)."""

    a_ok, r_ok = target_masks(res.alpha_deg[0], res.ratio[0], float(res.meta["ratio"]), res.meta["criterion"])
    return a_ok & r_ok


def where_it_holds(res, limits) -> list[str]:
    """Markdown: where the criterion holds and where it gives way, with the turning of the path there."""
    import numpy as np

    crit, r, P = res.meta["criterion"], float(res.meta["ratio"]), res.P
    alpha, rho = res.alpha_deg[0], res.ratio[0]
    turn = np.r_[np.nan, limits["turning"]]  # the turn that reaches waypoint p (none before waypoint 0)
    ok = hold_mask(res)
    rule = f"rho >= {(1 - RATIO_REL_TOL) * r:g}" if crit == "f1" else f"|rho - {r:g}| / {r:g} < {RATIO_REL_TOL:.0%}"
    lines = [
        f"**Where {crit} holds and where it gives way** (holds: alpha < {ALPHA_OK_DEG:g} deg and {rule}; the turn "
        f"of waypoint p is the angle between the tangents at p - 1 and p; joint rate limit {limits['dq_deg']:g} "
        "deg per waypoint).",
        "",
    ]
    if ok.any():
        tk = turn[ok & np.isfinite(turn)]
        lines.append(
            f"* Holds at {int(ok.sum())} of {P} waypoints ({_ranges_text(_runs(ok))}), where the tangent turns "
            f"{tk.min():.2f}-{tk.max():.2f} deg per waypoint: alpha at most {alpha[ok].max():.2g} deg, rho "
            f"{rho[ok].min():.3f}-{rho[ok].max():.3f}."
        )
    else:
        lines.append(f"* Holds at none of the {P} waypoints.")
    rows = []
    for a, b in _runs(~ok):
        sl = slice(a, b + 1)
        t = turn[sl][np.isfinite(turn[sl])]
        k = a + int(np.argmax(alpha[sl]))
        rows.append(
            f"| {a}-{b} | {b - a + 1} | {t.min():.2f}-{t.max():.2f} | {alpha[sl].max():.3g} (at {k}) | "
            f"{rho[sl].min():.3f}-{rho[sl].max():.3f} | {int(np.count_nonzero(limits['per_wp']['q_rate'][sl]))} | "
            f"{int(np.count_nonzero(limits['per_wp']['kj_rate'][sl]))} |"
        )
    if rows:
        lines += [
            "* Gives way:",
            "",
            "| waypoints | count | turn there (deg per waypoint) | max alpha (deg) | rho | with a joint at dq | "
            "with a stiffness at dk |",
            "| --- | --- | --- | --- | --- | --- | --- |",
            *rows,
            "",
        ]
        fin = np.isfinite(turn)
        if (ok & fin).any() and (~ok & fin).any():
            lines.append(
                f"* Fastest turn at which {crit} still holds: {turn[ok & fin].max():.2f} deg per waypoint; slowest "
                f"turn at which it gives way: {turn[~ok & fin].min():.2f} deg per waypoint (the tangent's fastest "
                f"turn, {np.nanmax(turn):.2f} deg, reaches waypoint {int(np.nanargmax(turn))}; alpha peaks at "
                f"waypoint {int(np.argmax(alpha))})."
            )
        last = _runs(~ok)[-1][1]
        lines.append(
            f"* It does not recover before the end of the path (waypoint {P - 1})."
            if last == P - 1
            else f"* After the last give-way range it holds again from waypoint {last + 1} to the end."
        )
    return lines


def curved_extra(tag: str):
    """The ``extra`` of :func:`fig4_f1.run` for a curved run: the turning figure and where it holds."""

    def extra(res, robot, limits, out) -> list[str]:
        from jaxstiff.plots import figure_turning

        name = f"{tag}_turning.png"
        crit = res.meta["criterion"]
        figure_turning(
            res, robot, os.path.join(out, name), f"{crit} on the curved path: alpha and rho against the turning rate"
        )
        return [f"![{tag} turning]({name})", "", *where_it_holds(res, limits), "", *rounding_spread(res, robot)]

    return extra


#: shifts of the path (m, along x) for :func:`rounding_spread`: far below every tolerance
ROUNDING_SHIFTS = (1e-13, -1e-13, 2e-13, -2e-13)


def rounding_spread(res, robot) -> list[str]:
    """Markdown: the same run on the path moved by :data:`ROUNDING_SHIFTS`, and where the criterion
    holds in each (jaxstiff's own check of how much the count owes to rounding)."""
    import numpy as np

    import jaxstiff

    crit, r = res.meta["criterion"], float(res.meta["ratio"])
    runs = []
    for s in ROUNDING_SHIFTS:
        moved = jaxstiff.Path(res.target[0] + np.array([s, 0.0, 0.0]), res.direction[0], name="moved")
        ok = hold_mask(jaxstiff.shape(robot, moved, crit, r))
        gives = _ranges_text(_runs(~ok)) if (~ok).any() else "nowhere"
        runs.append(f"{s:+.0e} m: holds at {int(ok.sum())} (gives way at {gives})")
    return [
        f"**How much of the count is rounding** (jaxstiff's own check; the seed has none): the same run on the "
        f"path moved along x by {'; '.join(runs)} of {res.P} waypoints (this run: {int(hold_mask(res).sum())}). "
        f"The first waypoint is not rate-limited and {crit} is equally good on a whole set of postures; which of "
        "them the multi-start SLSQP ends at is decided by rounding, and the greedy chain inherits it: another CPU, "
        "or a path moved by 1e-13 m, gives another count, in a range like the one above. Where the criterion "
        "gives way first and whether it recovers after the apex depend on that first posture.",
    ]


def curved_main(criterion: str, tag: str, title: str, argv=None) -> int:
    """Run :func:`fig4_f1.run` with ``criterion`` on the curved path, with its setup text and analysis."""
    return run(criterion, tag, title, argv, path_fn=curved_path, setup=setup_text(criterion), extra=curved_extra(tag))


def main(argv=None) -> int:
    return curved_main(
        "f1",
        "fig4_f1_curved",
        "After seed 000 Fig. 4, on jaxstiff's own tight-turn path: f1, ratio at least 5 - KUKA LWR 4 (A7 locked)",
        argv,
    )


if __name__ == "__main__":
    sys.exit(main())
