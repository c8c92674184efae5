"""``jaxstiff.results.verify`` against tampered and corrupt files (found by an independent check):
``kj_scaled``, what a controller is commanded with, was not checked; a NaN joint position raised
numpy's LinAlgError; reversed ``joint_names`` passed; a criterion of the user's own reported a
criterion mismatch of 0.0 although nothing was re-checked."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

import jaxstiff
from jaxstiff.results import _files as R


@pytest.fixture(scope="module")
def planar():
    robot = jaxstiff.Robot.from_urdf("planar_3r")
    pts = np.c_[np.linspace(1.5, 1.53, 3), np.full(3, 0.5), np.zeros(3)]
    return jaxstiff.shape(robot, jaxstiff.Path(pts), "f2", 3.0, task="xy")


def test_the_untampered_file_verifies(planar):
    v = R.verify(planar)
    assert v["max_kj_scaled_mismatch"] <= 1e-15 and v["max_pos_error"] <= 1e-9
    assert all(math.isfinite(x) for x in v.values())


def test_kj_scaled_is_checked(planar):
    bad = dataclasses.replace(planar, kj_scaled=planar.kj_scaled * 10.0)
    assert R.verify(bad)["max_kj_scaled_mismatch"] == pytest.approx(9.0)


def test_a_nan_joint_position_is_reported_not_raised(planar):
    q = planar.q.copy()
    q[0, 1, 1] = np.nan
    v = R.verify(dataclasses.replace(planar, q=q))
    for k in ("max_pos_error", "max_bound_violation", "max_position_mismatch", "max_alpha_mismatch"):
        assert v[k] == math.inf, k


def test_joint_names_must_be_the_robots_in_chain_order(planar):
    bad = dataclasses.replace(planar, joint_names=planar.joint_names[::-1].copy())
    with pytest.raises(ValueError, match="not the robot's joints in chain order"):
        R.verify(bad)


def test_a_users_own_criterion_is_reported_as_not_checked(planar):
    meta = {**planar.meta, "criterion": "my_criterion"}
    v = R.verify(dataclasses.replace(planar, meta=meta))
    assert math.isnan(v["max_criterion_mismatch"])
    assert v["max_alpha_mismatch"] < 1e-8  # the rest is still checked


@pytest.mark.parametrize("key", ["time_s", "nit", "nfev"])
def test_a_negative_time_or_count_in_a_file_is_refused(planar, tmp_path, key):
    """A file with a negative time or iteration count (an adversarial run's tampering) was read and
    verified; a solver never writes one, so the reader refuses it, naming the array."""
    from helpers import tamper_result

    from jaxstiff.results._reader import ResultFileError

    src = planar.save(str(tmp_path / "ok.npz"))
    jaxstiff.ShapeResult.load(src)

    def negative(d):
        d[key] = d[key].copy()
        d[key][0, 1] = -5

    bad = tamper_result(src, str(tmp_path / "bad.npz"), arrays=negative)
    with pytest.raises(ResultFileError, match=rf"{key}.*values >= 0.*-5"):
        jaxstiff.ShapeResult.load(bad)
