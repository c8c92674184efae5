"""Issue 23, item 5: the "in target" flag and warning of the greedy solvers, and rate limits per
metre of path.

Independent references: hand arithmetic (tolerances, ranges, segment lengths), the result's own
alpha/rho arrays against the stated rule, and an invariant (one curved path sampled at 40 and at
80 waypoints gives nearly the same alpha/rho profile over arc length with per-metre limits, and
clearly different ones with the same per-waypoint limits).
"""

from __future__ import annotations

import argparse
import math
import warnings

import numpy as np
import pytest

import jaxstiff
from jaxstiff.cli._shape import summary_table
from jaxstiff.cli._shape_flags import add_shape_flags, limit_kwargs
from jaxstiff.paths import arc
from jaxstiff.results._target import (
    MissedTargetWarning,
    compress_ranges,
    missed_target_warning,
    target_masks,
    warn_missed_target,
)
from jaxstiff.settings import ShapeSettings
from jaxstiff.settings._shape import per_metre_limit, shortest_segments
from jaxstiff.solvers import SLSQP

PLANAR = jaxstiff.Robot.from_urdf("planar_3r")
PER_M = ShapeSettings(dq_per_m=1.0, dk_per_m=50.0)  # rad/m, Nm/rad/m: they bind on the arc below


def _arc(n: int) -> jaxstiff.Path:
    """60 deg either side on a 0.3 m circle: the tangent turns 120 deg over 0.63 m."""
    return arc((1.2, 0.0, 0.0), 0.3, -60.0, 60.0, n)


def _shape(n: int, **kw) -> jaxstiff.ShapeResult:
    # seed 000's greedy walk alone (no path retries: those walk the path again from other first
    # postures and add starts at off-target waypoints): these tests are about the rate limits' rule
    # per metre and the missed-target report, on one walk whose misses the limits cause
    kw.setdefault("solver", SLSQP(path_retries=0))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return jaxstiff.shape(PLANAR, _arc(n), "f2", 3.0, task="xy", **kw)


@pytest.fixture(scope="module")
def arc40() -> jaxstiff.ShapeResult:
    return _shape(40, settings=PER_M)


# ---------------------------------------------------------------------- the in-target rule
def test_target_masks_by_hand():
    alpha = np.array([0.0, 0.999, 1.0, 0.5, np.nan, 0.2])
    rho = np.array([5.0, 5.09, 5.0, 4.91, 5.0, 5.2])
    a_ok, r_ok = target_masks(alpha, rho, 5.0, "f2")
    np.testing.assert_array_equal(a_ok, [True, True, False, True, False, True])
    np.testing.assert_array_equal(r_ok, [True, True, True, True, True, False])  # 0.1/5 = 0.02 is out
    _, r_ok1 = target_masks(alpha, rho, 5.0, "f1")  # f1: at least 0.98 r
    np.testing.assert_array_equal(r_ok1, [True, True, True, True, True, True])
    assert not target_masks(0.0, 4.89, 5.0, "f1")[1]


def test_compress_ranges():
    assert compress_ranges([0, 1, 2, 5, 7, 8]) == "0-2, 5, 7-8"
    assert compress_ranges(np.array([9, 3, 3, 4])) == "3-4, 9"
    assert compress_ranges([]) == ""


def test_greedy_slsqp_converges_but_misses_and_says_so(arc40, tmp_path):
    """The issue's defect on the planar arm: slsqp reports status 0 everywhere while alpha climbs
    (the rate limits hold the ellipsoid back); the flag, the summary, the table and the warning
    say which waypoints miss."""
    res = arc40
    assert np.all(res.status == 0) and res.alpha_deg.max() > 30.0  # converged, far off target
    flag = res.in_target
    want = (res.alpha_deg < 1.0) & (np.abs(res.ratio - 3.0) / 3.0 < 0.02)  # the rule, by hand
    np.testing.assert_array_equal(flag, want)
    assert not flag.all() and flag[0, 0]
    # never in target while alpha or rho misses; the summary's share is the flag's
    assert not np.any(flag & ((res.alpha_deg >= 1.0) | (np.abs(res.ratio - 3.0) >= 0.06)))
    assert res.summary()["share_both"] == np.mean(flag)
    row = summary_table(res).splitlines()[1].split()
    assert "in target" in summary_table(res) and row[6] == f"{np.mean(flag):.0%}"
    # the flag is derived from the file's arrays and meta: the same after a round trip
    res.save(tmp_path / "r.npz")
    np.testing.assert_array_equal(jaxstiff.ShapeResult.load(tmp_path / "r.npz").in_target, flag)
    with pytest.warns(MissedTargetWarning) as rec:
        text = warn_missed_target(res)
    assert len(rec) == 1 and text is not None
    assert f"path 0: waypoints {compress_ranges(np.flatnonzero(~flag[0]))}" in text
    # the hybrid (command line too), and trajectory from the hybrid's answer (pgd's warm start can be worse)
    assert "solver 'hybrid' (--solver hybrid)" in text and "Trajectory(warm=Hybrid())" in text


def test_warning_only_for_usable_misses_and_per_path():
    status = np.array([[0, 0, 0, 3], [0, 1, 0, 0]])
    flag = np.array([[True, False, False, False], [True, True, True, True]])
    text = missed_target_warning(status, flag, {"criterion": "f2", "solver": "slsqp"})
    assert text is not None and text.startswith("2 of 7 usable waypoints")
    assert "path 0: waypoints 1-2" in text and "path 1" not in text  # waypoint 3 is unusable
    assert missed_target_warning(status, np.ones_like(flag), {"solver": "slsqp"}) is None
    traj = missed_target_warning(status, flag, {"criterion": "f2", "solver": "trajectory"})
    assert traj is not None and "solver='trajectory'" not in traj
    hyb = missed_target_warning(status, flag, {"criterion": "f2", "solver": "hybrid"})
    assert hyb is not None and "Trajectory(warm=Hybrid())" in hyb and "--solver trajectory" not in hyb


# ---------------------------------------------------------------------- per-metre limits
def test_per_metre_conversion_by_hand():
    # path 0: segments 0.01 m; path 1: segments 0.02, 0.03 m (not even: the shortest counts)
    pts = np.array([[[0, 0, 0], [0.01, 0, 0], [0.02, 0, 0]], [[0, 0, 0], [0, 0.02, 0], [0, 0.05, 0]]], float)
    lo, hi = shortest_segments(pts)
    np.testing.assert_allclose(lo, [0.01, 0.02], rtol=1e-12)
    np.testing.assert_allclose(hi, [0.01, 0.03], rtol=1e-12)
    dq = per_metre_limit(2.0, lo, 3, "dq_per_m", "rad/m")
    np.testing.assert_allclose(dq, [[0.02] * 3, [0.04] * 3], rtol=1e-12)
    same = per_metre_limit([1.0, 2.0, np.inf], [0.5, 0.5], 3, "dq_per_m", "rad/m")
    np.testing.assert_array_equal(same, [0.5, 1.0, np.inf])  # one row for every path
    with pytest.raises(ValueError, match="path 0 repeats a waypoint"):
        shortest_segments(np.zeros((1, 3, 3)))
    with pytest.raises(ValueError, match="must be >= 0"):
        per_metre_limit(-1.0, [0.1], 3, "dq_per_m", "rad/m")


def test_per_metre_limits_reach_the_solver_and_meta(arc40):
    seg = 2 * 0.3 * math.sin(math.radians(120.0 / 39) / 2)  # chord of one step on the arc, m
    lim = arc40.meta["limits"]
    np.testing.assert_allclose(lim["dq"], 1.0 * seg, rtol=1e-9)
    np.testing.assert_allclose(lim["dk"], 50.0 * seg, rtol=1e-9)
    assert arc40.meta["settings"]["dq_per_m"] == 1.0 and arc40.meta["settings"]["dk_per_m"] == 50.0
    assert jaxstiff.results.verify(arc40)["max_rate_violation"] <= 1e-12


def test_per_metre_result_does_not_depend_on_sampling(arc40):
    """The same arc at 40 and 80 waypoints: per-metre limits give nearly the same alpha/rho over
    arc length; the same per-waypoint limits do not (so this test can fail)."""
    s40, s80 = np.linspace(0.0, 1.0, 40), np.linspace(0.0, 1.0, 80)
    r80 = _shape(80, settings=PER_M)
    assert np.all(r80.status == 0)
    span = float(arc40.alpha_deg.max())
    d_alpha = np.abs(arc40.alpha_deg[0] - np.interp(s40, s80, r80.alpha_deg[0])).max()
    d_rho = np.abs(arc40.ratio[0] - np.interp(s40, s80, r80.ratio[0])).max()
    assert d_alpha < 0.1 * span and d_rho < 0.01 * 3.0, (d_alpha, d_rho, span)
    lim = arc40.meta["limits"]
    w80 = _shape(80, dq=lim["dq"][0], dk=lim["dk"][0])  # per waypoint: twice the room per metre
    d_wp = np.abs(arc40.alpha_deg[0] - np.interp(s40, s80, w80.alpha_deg[0])).max()
    assert d_wp > 0.3 * span, (d_wp, span)


def test_per_metre_and_per_waypoint_exclude_each_other():
    with pytest.raises(ValueError, match="give dq .* or dq_per_m"):
        jaxstiff.shape(PLANAR, _arc(5), "f2", 3.0, task="xy", settings=ShapeSettings(dq_per_m=1.0), dq=0.1)
    with pytest.raises(ValueError, match="give dk .* or dk_per_m"):
        jaxstiff.shape(PLANAR, _arc(5), "f2", 3.0, task="xy", settings=ShapeSettings(dk_per_m=1.0, dk=7.0))
    p = argparse.ArgumentParser()
    add_shape_flags(p)
    for argv in (["--dq-deg", "3", "--dq-per-m", "1"], ["--dk", "3", "--dk-per-m", "1"]):
        with pytest.raises(SystemExit):
            p.parse_args(argv)
    with pytest.raises(ValueError, match="--dq-m .* --dq-per-m"):
        limit_kwargs(p.parse_args(["--dq-m", "0.1", "--dq-per-m", "1"]), 0.1, 5.0)
    kw = limit_kwargs(p.parse_args(["--dq-per-m", "1.5"]), 0.1, 5.0)
    assert kw["dq"] is None and kw["dk"] == 5.0 and kw["settings"].dq_per_m == 1.5
    assert limit_kwargs(p.parse_args([]), 0.1, 5.0) == {"dq": 0.1, "dk": 5.0}
