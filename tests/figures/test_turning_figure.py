"""The turning figure of the ``_curved`` experiments, the joints-at-a-limit counts it shows, and the
N/m scale of the seven-panel figure: counts against a hand-made result whose steps are set to the
rate limits, the PNG read back as pixels (not blank: the curves' colours are there)."""

from __future__ import annotations

import numpy as np
import pytest
from hand_made_results import arc_result

import jaxstiff
from jaxstiff.plots import figure_turning, nice_value, pyplot, rate_limited_joints

DQ, DK = np.radians(2.0), 5.0


def _result(robot, P=12):
    """A hand-made result on a horizontal arc: joints 0 and 2 step exactly dq at waypoints 4-7, joint
    1's stiffness steps exactly dk at waypoints 6-9, joint 3's stiffness sits at kmax throughout."""
    n = robot.n
    steps = np.zeros((P, n))
    steps[4:8, [0, 2]] = DQ
    q = np.deg2rad([10.0, 30.0, 0.0, -60.0, 0.0, 40.0, 0.0]) + np.cumsum(steps, axis=0)
    ksteps = np.zeros((P, n))
    ksteps[6:10, 1] = DK
    kj = 50.0 + np.cumsum(ksteps, axis=0)
    kj[:, 3] = 100.0
    path = jaxstiff.paths.arc([0.0, 0.0, 0.3], 0.6, 0.0, 44.0, n=P)  # turns 4 deg per waypoint
    alpha = np.r_[np.full(4, 1e-7), np.linspace(2, 30, 4), np.full(P - 8, 1e-6)]
    return arc_result(q, kj, path, DQ, DK, alpha)


def test_rate_limited_joints_counts_the_steps_set_to_the_limits():
    robot = jaxstiff.Robot.from_urdf("kuka_lwr4", locked={"lwr_a7": 0.0})
    lim = rate_limited_joints(_result(robot), robot)
    expect_q = np.zeros(12, int)
    expect_q[4:8] = 2
    expect_k = np.zeros(12, int)
    expect_k[6:10] = 1
    np.testing.assert_array_equal(lim["q_rate"], expect_q)
    np.testing.assert_array_equal(lim["kj_rate"], expect_k)
    np.testing.assert_array_equal(lim["kj_bound"], np.ones(12, int))  # joint 3 at kmax
    np.testing.assert_array_equal(lim["q_bound"], np.zeros(12, int))


def test_rigid_locked_joint_kj_inf_counts_nothing_and_warns_nothing():
    """A rigid locked joint's kj is +inf in the file (SPEC section 1): the counts are those of the
    same result with a finite value there (the joint is locked, it never counts), without the
    'invalid value' RuntimeWarning of inf - inf (the warnings filter makes it an error)."""
    import warnings

    robot = jaxstiff.Robot.from_urdf("kuka_lwr4", locked={"lwr_a7": 0.0})
    finite = rate_limited_joints(_result(robot), robot)
    res = _result(robot)
    res.kj[..., 6] = np.inf
    res.kj0[..., 6] = np.inf
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        rigid = rate_limited_joints(res, robot)
    for k in finite:
        np.testing.assert_array_equal(rigid[k], finite[k])


def test_figure_turning_is_drawn(tmp_path):
    robot = jaxstiff.Robot.from_urdf("kuka_lwr4", locked={"lwr_a7": 0.0})
    file = figure_turning(_result(robot), robot, tmp_path / "turning.png", "test", dpi=40)
    img = pyplot().imread(file)[..., :3]  # floats in [0, 1]
    h, w, _ = img.shape
    assert h > 300 and w > 300
    ink = np.any(img < 0.9, axis=-1)
    assert ink.mean() > 0.03, "the figure is (nearly) blank"
    # the orientation error (C3, red) and the turning curve (grey) are drawn
    red = (img[..., 0] > 0.7) & (img[..., 1] < 0.3) & (img[..., 2] < 0.3)
    grey = (np.ptp(img, axis=-1) < 0.03) & (img[..., 0] > 0.4) & (img[..., 0] < 0.65)
    assert red.sum() > 20 and grey.sum() > 20
    assert [f.name for f in tmp_path.iterdir()] == ["turning.png"]


def test_nice_value_is_the_round_value_at_most_x():
    assert [nice_value(x) for x in (730.0, 0.031, 1.0, 99.99, 2.0, 5e-4)] == [500.0, 0.02, 1.0, 50.0, 2.0, 5e-4]
    for x in (0.0, -1.0, float("nan")):
        with pytest.raises(ValueError, match="finite number > 0"):
            nice_value(x)
