"""Numerical stress (issue 24, item 5): 10^5 random and exactly singular configurations per arm,
task and posture family (the LWR and a Panda-like arm with rotated joint frames), joint
stiffnesses from 1e-6 to 1e6 Nm/rad, and degenerate ellipsoids (lambda1 = lambda2, spheres):
no NaN and no Inf in the values or gradients of the stiffness, its ellipsoid, the orientation
error, f1 and f2. ``python scripts/stress_numerics.py`` runs the same with 10^6."""

from __future__ import annotations

import pytest
from helpers import load_script


def _stress_module():
    return load_script("scripts/stress_numerics.py")


@pytest.mark.slow
def test_no_nan_or_inf_over_1e5_configurations_per_case():
    res = _stress_module().run(100_000, seed=1, chunk=50_000)
    assert len(res) == 17  # 2 arms x 2 tasks x 4 posture families + the degenerate matrices
    bad = {case: {k: c for k, c in counts.items() if c != [0, 0]} for case, counts in res.items()}
    bad = {case: v for case, v in bad.items() if v}
    assert not bad, f"non-finite [NaN, Inf] counts: {bad}"
