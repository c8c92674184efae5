"""Waypoints at a singular posture are named (meta["singular"], SingularPostureWarning)."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import jaxstiff
from jaxstiff.results._singular import SINGULAR_COND, SingularPostureWarning, singular_waypoints


def test_condition_rule_on_given_matrices():
    """The rule on matrices whose condition numbers are known: diag(1, c) is singular iff
    c > SINGULAR_COND; a rotated one the same; non-finite K counts; unusable waypoints never do."""
    rot = np.array([[np.cos(0.3), -np.sin(0.3)], [np.sin(0.3), np.cos(0.3)]])
    conds = [5.0, 0.5 * SINGULAR_COND, 2.0 * SINGULAR_COND, 2e8]
    K = np.array([[rot @ np.diag([c * 3.0, 3.0]) @ rot.T for c in conds]])
    status = np.zeros((1, 4), int)
    np.testing.assert_array_equal(singular_waypoints(K, status), [[False, False, True, True]])
    K_nan = K.copy()
    K_nan[0, 0, 0, 0] = np.nan
    assert singular_waypoints(K_nan, status)[0, 0]
    status_bad = np.full((1, 4), jaxstiff.results.UNREACHABLE)
    assert not singular_waypoints(K, status_bad).any()


def test_stretched_arm_waypoint_is_flagged_and_an_inner_path_is_not():
    """The planar 3R (links 1 m) reaches (3, 0) only fully stretched: the one waypoint there is
    named in meta and by a warning (its ratio, ~2e8, is the regularisation's); a path well inside
    the workspace gets neither. Found by an independent check: nothing flagged it before."""
    robot = jaxstiff.Robot.from_urdf("planar_3r")
    edge = jaxstiff.Path(np.array([[3.0, 0.0, 0.0]]), np.array([[0.0, 1.0, 0.0]]))
    with pytest.warns(
        SingularPostureWarning, match=r"1 usable waypoints are at a singular posture.*path 0: waypoints 0"
    ):
        res = jaxstiff.shape(robot, edge, "f2", 5.0, task="xy")
    assert res.meta["singular"] == {"cond_threshold": SINGULAR_COND, "count": 1, "waypoints": {"0": "0"}}
    assert res.ratio[0, 0] > SINGULAR_COND
    inner = jaxstiff.Path(np.c_[np.linspace(1.50, 1.58, 5), np.full(5, 0.5), np.zeros(5)])
    with warnings.catch_warnings():
        warnings.simplefilter("error", SingularPostureWarning)
        res = jaxstiff.shape(robot, inner, "f2", 5.0, task="xy")
    assert res.meta["singular"]["count"] == 0 and res.meta["singular"]["waypoints"] == {}
