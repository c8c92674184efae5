"""Seed 000, Fig. 5: shaping along a curved path with f2 (ratio exactly 5), KUKA LWR 4, 7th joint locked.

The same setup as ``fig4_f1.py`` (shipped default path, tangent directions, 2 deg and 5 Nm/rad per
waypoint, kj in [1, 100] Nm/rad, task "full", SLSQP per waypoint with JAX derivatives, CMS to a
geometric-mean axis of 1000 N/m) with criterion f2 (S0-15), r = 5. Panels (a)-(g) as in the seed;
writes ``fig5_f2.png``, ``summary.md`` (share of waypoints with alpha < 1 deg and |rho - 5|/5 < 2%, max
position error and bound/rate violation from a numpy FK, time per waypoint), ``summary.csv`` and
``fig5_f2.npz``.

Usage:
    python experiments/fig5_f2.py [--out DIR] [--quick]
"""

from __future__ import annotations

import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from fig4_f1 import run  # noqa: E402  (the shared run and summary; the figure is jaxstiff.plots.figure_shape_path)


def main(argv=None) -> int:
    return run(
        "f2",
        "fig5_f2",
        "After seed 000 Fig. 5, on jaxstiff's own default path: f2, ratio exactly 5 - KUKA LWR 4 (A7 locked)",
        argv,
    )


if __name__ == "__main__":
    sys.exit(main())
