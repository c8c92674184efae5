"""solver="hybrid" (pgd + SLSQP polish, issue 5): never worse than pgd per waypoint, at least as good
as greedy SLSQP (an independent solver of the same problem), exactly feasible (numpy re-verification)."""

from __future__ import annotations

import numpy as np

from jaxstiff import results as R
from test_pgd import OPTS, STARTS, check_file, planar_paths, run


def test_hybrid_never_worse_than_pgd_and_matches_slsqp(tmp_path):
    path, q0 = planar_paths(3, 5)
    base = run(path, q0)  # same pgd settings and keys as inside the hybrid
    hyb = run(path, q0, solver="hybrid", options={**OPTS, "chain": "pgd"})
    gre = run(path, q0, solver="hybrid")  # default chain "greedy": also tries the seed's own start
    ref = run(path, q0, solver="slsqp", options=None)
    assert np.all(R.is_usable(hyb.status))
    both = R.is_usable(base.status)
    assert np.all(hyb.criterion[both] <= base.criterion[both] + 1e-12)
    ok = R.is_usable(ref.status)
    # per waypoint the chains differ (the polish keeps pgd's next point reachable), so compare totals
    assert hyb.criterion[ok].sum() <= base.criterion[ok].sum() + 1e-9
    assert np.mean(hyb.criterion[ok]) <= 1.5 * np.mean(ref.criterion[ok])
    check_file(hyb, tmp_path)
    # greedy chaining: at the first waypoint the box and the seed's start are SLSQP's own, and SLSQP
    # from that start is one of the candidates, so the hybrid is not worse there (up to SLSQP accuracy)
    assert np.all(gre.criterion[:, 0] <= ref.criterion[:, 0] * (1 + 1e-3))  # SLSQP stops within ftol
    assert np.all(R.is_usable(gre.status))
    check_file(gre, tmp_path, "g.npz")
