"""Seed 000, Fig. 5 on jaxstiff's own tight-turn path (f2, ratio exactly 5).

The seed's headline f2 result: the ellipsoids reach exactly 5:1 along the tangent except where the
trajectory curves most. The same setup and curved path as ``fig4_f1_curved.py`` (an elliptic arc in
the plane z = 0.30 m whose tangent turns 1.5 deg per waypoint at the ends and 6.8 deg at the apex,
against the 2 deg joint rate limit) with criterion f2 (S0-15), r = 5. Writes ``fig5_f2_curved.png``
(panels (a)-(g)), ``fig5_f2_curved_turning.png`` (alpha and rho with the tangent's turning per
waypoint and the rate limit on a twin axis; the joints held by the rate limits), ``summary.md``
(interpretations, table, where f2 holds and where it gives way), ``summary.csv`` and
``fig5_f2_curved.npz``. ``--quick``: the first 36 waypoints.

Usage:
    python experiments/fig5_f2_curved.py [--out DIR] [--quick]
"""

from __future__ import annotations

import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from fig4_f1_curved import curved_main  # noqa: E402  (the curved path, its run and analysis)


def main(argv=None) -> int:
    return curved_main(
        "f2",
        "fig5_f2_curved",
        "After seed 000 Fig. 5, on jaxstiff's own tight-turn path: f2, ratio exactly 5 - KUKA LWR 4 (A7 locked)",
        argv,
    )


if __name__ == "__main__":
    sys.exit(main())
