"""Numerical stress (issue 24, item 5): 10^5 random and exactly singular configurations per arm,
task and posture family (the LWR and a Panda-like arm with rotated joint frames), joint
stiffnesses from 1e-6 to 1e6 Nm/rad, and degenerate ellipsoids (lambda1 = lambda2, spheres):
no NaN and no Inf in the values or gradients of the stiffness, its ellipsoid, the orientation
error, f1 and f2. ``python scripts/stress_numerics.py`` runs the same with 10^6."""

from __future__ import annotations

import importlib.util

import pytest
from helpers import REPO_ROOT


def _stress_module():
    spec = importlib.util.spec_from_file_location("stress_numerics", REPO_ROOT / "scripts" / "stress_numerics.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


@pytest.mark.slow
def test_no_nan_or_inf_over_1e5_configurations_per_case():
    res = _stress_module().run(100_000, seed=1, chunk=50_000)
    assert len(res) == 17  # 2 arms x 2 tasks x 4 posture families + the degenerate matrices
    bad = {case: {k: c for k, c in counts.items() if c != [0, 0]} for case, counts in res.items()}
    bad = {case: v for case, v in bad.items() if v}
    assert not bad, f"non-finite [NaN, Inf] counts: {bad}"
