"""Per-path parameters of ``jaxstiff.shape`` (ratio (B,), dq/dk (B, n)) and batch independence.

Independent references: the rate limits are checked on the result arrays with numpy against each
path's own dq/dk; a batch with per-path parameters is compared with separate single-path runs;
a path's result is compared across batches where it stands at another position / alone; the
file-only verification (:func:`jaxstiff.results.verify`) must use the per-path values (a file whose
meta claims a tighter limit for one path must fail it).
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from helpers import joint_motion_traces

import jaxstiff
from jaxstiff.results import _files as R
from jaxstiff.shaping import run_shape

PLANAR = jaxstiff.Robot.from_urdf("planar_3r")
PGD_OPTS = {"starts": 2, "iters": 5, "iters_first": 10, "starts_first": 2, "chunk": 8}


def planar_paths(B: int, P: int, seed: int = 0):
    """TCP traces (numpy FK) of joint-space motions of the planar arm: reachable by construction."""
    return joint_motion_traces(PLANAR, B, P, seed)


def shape(pts, d, q0, solver="slsqp", ratio=3.0, **kw):
    if solver in ("pgd", "hybrid"):
        kw.setdefault("options", PGD_OPTS)
    kw.setdefault("first_starts", 3)
    # solver options as a dict: run_shape, shape()'s full form (shape(options=...) is deprecated)
    call = run_shape if "options" in kw else jaxstiff.shape
    return call(PLANAR, jaxstiff.Path(pts, d), "f2", ratio, task="xy", solver=solver, q0=q0, **kw)


def rate_excess(res, b, dq, dk):
    """Largest excess of |x_p - x_ref(p)| over path b's own (dq, dk), numpy only (>0: violated)."""
    first_rate = res.meta["limits"]["first_rate_limit"]
    q_ref, k_ref, started = res.q0[b], res.kj0[b], first_rate
    worst = -np.inf
    for p in range(res.P):
        if started:
            worst = max(
                worst, float(np.max(np.abs(res.q[b, p] - q_ref) - dq)), float(np.max(np.abs(res.kj[b, p] - k_ref) - dk))
            )
        if res.status[b, p] in R.USABLE:
            q_ref, k_ref, started = res.q[b, p], res.kj[b, p], True
    return worst


PTS, DIRS, Q0 = planar_paths(2, 5, seed=4)
# path 1 gets tight joint and stiffness limits, path 0 loose ones: a solver using one path's
# limits for both would break path 1's
DQ = np.array([[0.3, 0.3, 0.3], [0.05, 0.06, 0.05]])
DK = np.array([[20.0, 20.0, 20.0], [0.5, 1.0, 0.25]])
RATIOS = np.array([2.5, 4.0])


@pytest.fixture(scope="module")
def slsqp_batch():
    return shape(PTS, DIRS, Q0, ratio=RATIOS, dq=DQ, dk=DK, first_rate_limit=True)


def test_bad_per_path_values_name_the_path():
    with pytest.raises(ValueError, match="ratio .*path 1"):
        shape(PTS, DIRS, Q0, ratio=[3.0, 1.0])
    with pytest.raises(ValueError, match=r"ratio must be a number or 2 numbers"):
        shape(PTS, DIRS, Q0, ratio=[3.0, 3.0, 3.0])
    with pytest.raises(ValueError, match=r"dq .*path 1, joint 2"):
        shape(PTS, DIRS, Q0, dq=[[0.1, 0.1, 0.1], [0.1, 0.1, -0.1]])
    with pytest.raises(ValueError, match=r"dk .*NaN: path 0, joint 1"):
        shape(PTS, DIRS, Q0, dk=[[1.0, np.nan, 1.0], [1.0, 1.0, 1.0]])
    with pytest.raises(ValueError, match=r"dq .*shape \(2, 3\)"):
        shape(PTS, DIRS, Q0, dq=np.full((3, 3), 0.1))


def test_per_path_limits_hold_and_are_recorded(slsqp_batch, tmp_path):
    res = slsqp_batch
    assert np.all(R.is_usable(res.status))
    for b in range(2):
        assert rate_excess(res, b, DQ[b], DK[b]) <= 1e-12
    # the loose path uses more than the tight path's limits (else the check above would prove nothing)
    assert rate_excess(res, 0, DQ[1], DK[1]) > 1e-3
    assert np.all(np.abs(res.ratio[0] - RATIOS[0]) < 1e-3)  # f2 reaches the loose path's own ratio
    assert res.meta["ratio"] == RATIOS.tolist()
    assert res.meta["limits"]["dq"] == DQ.tolist() and res.meta["limits"]["dk"] == DK.tolist()
    assert res.meta["per_path"] == ["ratio", "dq", "dk"]
    f = tmp_path / "pp.npz"
    res.save(f)
    back = jaxstiff.ShapeResult.load(f)
    prm = R.path_parameters(back.meta, back.B, back.n)
    np.testing.assert_array_equal(prm["ratio"], RATIOS)
    np.testing.assert_array_equal(prm["dq"], DQ)
    v = R.verify(back)
    assert v["max_rate_violation"] <= 1e-12 and v["max_pos_error"] <= 1e-9
    assert v["max_criterion_mismatch"] < 1e-8  # f2 recomputed with each path's own ratio
    # a meta that claims path 0 had path 1's tight limits must fail the file-only check
    meta = json.loads(json.dumps(back.meta))
    meta["limits"]["dq"] = [DQ[1].tolist(), DQ[1].tolist()]
    bad = jaxstiff.ShapeResult(**{**back.arrays(), "meta": meta})
    assert R.verify(bad)["max_rate_violation"] > 1e-3
    meta = json.loads(json.dumps(back.meta))
    meta["ratio"] = [RATIOS[1], RATIOS[1]]
    bad = jaxstiff.ShapeResult(**{**back.arrays(), "meta": meta})
    assert R.verify(bad)["max_criterion_mismatch"] > 1e-3
    # summary: ratio shares against each path's own target
    s = R.summary(back)
    want = np.mean(np.abs(back.ratio - RATIOS[:, None]) / RATIOS[:, None] < 0.02)
    assert s["share_ratio"] == want and s["ratio_target"] == RATIOS.tolist()


def test_per_path_batch_equals_single_runs_slsqp(slsqp_batch):
    for b in range(2):
        one = shape(
            PTS[b : b + 1], DIRS[b : b + 1], Q0[b], ratio=float(RATIOS[b]), dq=DQ[b], dk=DK[b], first_rate_limit=True
        )
        for key in ("q", "kj", "status", "criterion", "ratio", "alpha_deg"):
            np.testing.assert_array_equal(getattr(one, key)[0], getattr(slsqp_batch, key)[b], err_msg=key)


def test_old_style_meta_still_reads():
    # files written before per-path parameters: ratio a number, dq/dk n numbers
    meta = {"ratio": 5.0, "c": 0.01, "limits": {"dq": [0.1, 0.2, 0.3], "dk": [5.0, 5.0, 5.0]}}
    prm = R.path_parameters(meta, 2, 3)
    np.testing.assert_array_equal(prm["ratio"], [5.0, 5.0])
    np.testing.assert_array_equal(prm["dq"], [[0.1, 0.2, 0.3]] * 2)
    with pytest.raises(ValueError, match="limits.dk"):
        R.path_parameters({**meta, "limits": {"dq": [0.1] * 3, "dk": [1.0] * 4}}, 2, 3)


def test_equal_per_path_values_are_recorded_once():
    res = shape(PTS, DIRS, Q0, ratio=[3.0, 3.0], dq=np.full((2, 3), 0.05), first_starts=1)
    assert res.meta["ratio"] == 3.0 and res.meta["limits"]["dq"] == [0.05] * 3 and res.meta["per_path"] == []


def _three_batches(solver, **kw):
    """Path B's result in [A, B], alone and in [B, A]."""
    pts, d, q0 = planar_paths(2, 5, seed=9)
    ab = shape(pts, d, q0, solver=solver, **kw)
    b = shape(pts[1:], d[1:], q0[1:], solver=solver, **kw)
    ba = shape(pts[::-1], d[::-1], q0[::-1], solver=solver, **kw)
    return [(r, i) for r, i in ((ab, 1), (b, 0), (ba, 0))]


@pytest.mark.slow
@pytest.mark.parametrize("solver", ["slsqp", "pgd"])
def test_result_does_not_depend_on_batch_position(solver):
    # default first_rate_limit=False: the first waypoint uses extra random start postures
    # (and pgd random starts everywhere); they must come from the path, not from its index
    runs = _three_batches(solver)
    (ref, i0), rest = runs[0], runs[1:]
    for res, i in rest:
        for key in ("q", "kj", "status", "criterion"):
            np.testing.assert_array_equal(getattr(res, key)[i], getattr(ref, key)[i0], err_msg=key)


TRAJ_OPTS = {"warm": "slsqp", "traj_iters": 4, "blocks": 1, "polish": 2}


@pytest.mark.slow
@pytest.mark.parametrize("solver", ["slsqp-fd", "hybrid", "trajectory"])
def test_every_solver_honours_per_path_parameters(solver):
    kw = dict(ratio=RATIOS, dq=DQ, dk=DK)  # first waypoint not rate-limited (default)
    if solver == "trajectory":
        kw["options"] = TRAJ_OPTS
    res = shape(PTS, DIRS, Q0, solver=solver, **kw)
    assert R.is_usable(res.status).mean() >= 0.8
    # meta says how the run was made: the given options over the solver's own defaults
    from jaxstiff.solvers import _pgd as pgd
    from jaxstiff.solvers import _slsqp as slsqp

    meta = res.meta
    if solver == "hybrid":  # pgd (2 starts given) then SLSQP
        assert (
            meta["starts"] == 2
            and meta["options"]["iters"] == 5
            and meta["options"]["mode"] == pgd.DEFAULT_OPTIONS["mode"]
        )
        assert meta["options"]["maxiter"] == slsqp.DEFAULT_OPTIONS["maxiter"] and meta["options"]["chain"] == "greedy"
    elif solver == "trajectory":  # warm start from SLSQP: single start
        assert meta["starts"] == 1 and meta["options"]["traj_iters"] == 4 and meta["options"]["mu0"] > 0
        assert meta["warm_options"]["maxiter"] == slsqp.DEFAULT_OPTIONS["maxiter"]
    else:
        # the defaults, with SLSQP's stiffness unit resolved from the range (kmax; 100 here)
        assert meta["starts"] == 1 and meta["options"] == {**slsqp.DEFAULT_OPTIONS, "kj_scale": 100.0}
    # what the solver did with the first waypoint's start postures (pgd: some of its own starts)
    use = meta["first_starts"]["use"]
    assert ("first-waypoint starts of pgd" in use) == (solver == "hybrid") and ("SLSQP solves" in use) == (
        solver != "hybrid"
    ), use
    for b in range(2):
        assert rate_excess(res, b, DQ[b], DK[b]) <= 1e-12, f"path {b}"
    assert rate_excess(res, 0, DQ[1], DK[1]) > 1e-3
    for b in range(2):  # each path as if it were alone, with its own parameters
        one = shape(
            PTS[b : b + 1],
            DIRS[b : b + 1],
            Q0[b],
            solver=solver,
            **{**kw, "ratio": float(RATIOS[b]), "dq": DQ[b], "dk": DK[b]},
        )
        for key in ("q", "kj", "status", "criterion"):
            np.testing.assert_array_equal(getattr(one, key)[0], getattr(res, key)[b], err_msg=f"{key}, path {b}")


def test_first_waypoint_start_postures_belong_to_the_path():
    """The extra first-waypoint starts a solver receives for path B are the same in [A, B], [B], [B, A]."""
    from jaxstiff.shaping import SOLVERS, register_solver

    seen = []

    def recorder(req):
        seen.append(req.first_starts)
        return SOLVERS["slsqp"](req)

    register_solver("_test_record", recorder)
    try:
        pts, d, q0 = planar_paths(2, 2, seed=9)
        shape(pts, d, q0, solver="_test_record")
        shape(pts[1:], d[1:], q0[1:], solver="_test_record")
        shape(pts[::-1], d[::-1], q0[::-1], solver="_test_record")
    finally:
        SOLVERS.pop("_test_record", None)
    (ab, b, ba) = seen
    assert len(ab[1]) == 2  # first_starts=3: q0 and 2 more
    for starts in (b[0], ba[0]):
        for (qs, ks), (qr, kr) in zip(starts, ab[1], strict=True):
            np.testing.assert_array_equal(qs, qr)
            np.testing.assert_array_equal(ks, kr)
    assert not np.array_equal(ab[0][0][0], ab[1][0][0])  # different paths: different postures
