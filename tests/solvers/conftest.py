"""Fixtures of the solver tests on the planar 3R arm, task "xy": the arm, reachable paths on it, a
``jaxstiff.shape`` run with the shared pgd settings (tests/solvers/pgd_cases.py), and the
numpy-only check of a saved result. Session-scoped: the arm is loaded once per process, as the
module-level ``PLANAR`` of test_pgd.py was; the others are functions the tests call."""

from __future__ import annotations

import numpy as np
import pytest
from helpers import joint_motion_traces, numpy_fk
from pgd_cases import OPTS, STARTS

import jaxstiff
from jaxstiff.results import _files as R
from jaxstiff.shaping import run_shape


@pytest.fixture(scope="session")
def planar() -> jaxstiff.Robot:
    return jaxstiff.Robot.from_urdf("planar_3r")


@pytest.fixture(scope="session")
def planar_paths(planar):
    """``planar_paths(B, P, seed=0) -> (path, q0)``: TCP traces (numpy FK) of joint-space motions of
    the planar arm, reachable by construction, and their start postures (B, 3)."""

    def make(B: int, P: int, seed: int = 0):
        pts, d, qa = joint_motion_traces(planar, B, P, seed)
        return jaxstiff.Path(pts, d), qa

    return make


@pytest.fixture(scope="session")
def run_planar(planar):
    """``run_planar(path, q0, solver="pgd", **kw)``: f2, ratio 3, task "xy" on the planar arm with
    the shared options (OPTS), STARTS starts (none for SLSQP) and dq = 0.1 unless ``kw`` says."""

    def run(path, q0, solver="pgd", **kw):
        options = kw.pop("options", OPTS)
        kw.setdefault("dq", 0.1)  # rad per waypoint: room for the null-space motion of the short test paths
        kw.setdefault("starts", STARTS if solver != "slsqp" else None)
        # the solver by name with its options as a dict: run_shape, shape()'s full form
        return run_shape(planar, path, "f2", 3.0, task="xy", solver=solver, q0=q0, options=options, **kw)

    return run


@pytest.fixture(scope="session")
def check_planar_file(planar):
    """``check_planar_file(res, tmp_path, name="r.npz")``: save, reload, verify with numpy only;
    positions against the independent numpy FK. Returns the reloaded result."""

    def check(res, tmp_path, name="r.npz"):
        f = tmp_path / name
        res.save(f)
        back = jaxstiff.ShapeResult.load(f)
        v = R.verify(back)
        assert R.verify(f) == v  # the file's path alone does too
        assert v["max_pos_error"] <= 1e-9
        assert v["max_bound_violation"] <= 0.0 and v["max_rate_violation"] <= 1e-15
        assert v["max_alpha_mismatch"] < 1e-8 and v["max_criterion_mismatch"] < 1e-8
        for b in range(back.B):
            for p in range(back.P):
                if back.status[b, p] in R.USABLE:
                    assert np.linalg.norm(numpy_fk(planar, back.q[b, p])[:3, 3] - back.target[b, p]) <= 1e-9
        return back

    return check
