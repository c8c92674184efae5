"""The stiffness a pure force at the TCP meets with the tool free to turn (task ``xyz``: the inverse of
the translational compliance) and with its orientation held (task ``full``: the top-left block of the
6x6 stiffness), against an independent numpy computation: the Jacobian from central differences of a
numpy forward kinematics (tests/helpers.py), plain ``numpy.linalg.inv``. On the LWR (lwr_a7 locked,
rigid: kj = inf) and on a third-party arm (tests/data/robots/ur10.urdf, tip tool0). Issue 40, part 1."""

from __future__ import annotations

import math

import jax
import numpy as np
import pytest
from helpers import DATA_DIR, assert_close, numpy_held_and_free, numpy_jacobian

import jaxstiff
from jaxstiff.stiffness import translational_compliance, translational_stiffness

ARMS = {
    "lwr": lambda: jaxstiff.Robot.from_urdf("kuka_lwr4", locked={"lwr_a7": 0.0}),
    "ur10": lambda: jaxstiff.Robot.from_urdf(str(DATA_DIR / "robots" / "ur10.urdf"), tip_link="tool0"),
}


def _postures(robot, count, seed):
    rng = np.random.default_rng(seed)
    lo, hi = np.maximum(robot.lower, -math.pi), np.minimum(robot.upper, math.pi)
    q = rng.uniform(lo, hi, size=(count, robot.n))
    q[:, ~np.asarray(robot.free)] = np.asarray(robot.locked_values)[~np.asarray(robot.free)]
    kj = rng.uniform(1.0, 100.0, size=(count, robot.n))
    kj[:, ~np.asarray(robot.free)] = np.inf  # a rigid locked joint: no spring
    return q, kj


@pytest.mark.parametrize("name", ["lwr", "ur10"])
def test_free_and_held_orientation_stiffness_against_numpy(name):
    robot = ARMS[name]()
    q, kj = _postures(robot, 4, seed=40)
    with jax.enable_x64(True):
        J = np.asarray(robot.jacobian(q))
        free = np.asarray(translational_stiffness(J, kj, task="xyz"))
        held = np.asarray(translational_stiffness(J, kj, task="full"))
        C_free = np.asarray(translational_compliance(J, kj, task="xyz"))
    for k in range(len(q)):
        Jn = numpy_jacobian(robot, q[k])
        held_n, free_n = numpy_held_and_free(Jn, kj[k])
        scale = np.linalg.norm(free_n, 2)
        assert_close(free[k], free_n, rtol=0, atol=1e-6 * scale, what=f"{name} free, posture {k}")
        assert_close(np.linalg.inv(C_free[k]), free_n, rtol=0, atol=1e-6 * scale, what=f"{name} C_TT^-1, {k}")
        assert_close(held[k], held_n, rtol=0, atol=1e-6 * np.linalg.norm(held_n, 2), what=f"{name} held, {k}")
        # holding the orientation is never softer; here it is stiffer by a clear margin (coupled T and R)
        assert np.linalg.eigvalsh(held_n - free_n).min() > -1e-9 * np.linalg.norm(held_n, 2)
        assert np.linalg.norm(held_n - free_n, 2) > 1e-3 * np.linalg.norm(held_n, 2)


def test_held_and_free_of_the_figure_match_numpy():
    """jaxstiff.plots._task_modes.held_and_free (the figure's numbers): angle to d, ratio and major
    axis from numpy's eigen-decomposition of the independent matrices."""
    from jaxstiff.plots import held_and_free

    robot = ARMS["lwr"]()
    q, kj = _postures(robot, 3, seed=7)
    d = np.random.default_rng(1).normal(size=(3, 3))
    with jax.enable_x64(True):
        got = held_and_free(robot, q, kj, d)
    for k in range(3):
        for name, K in zip(("held", "free"), numpy_held_and_free(numpy_jacobian(robot, q[k]), kj[k]), strict=True):
            w, V = np.linalg.eigh(K)
            cos = abs(V[:, -1] @ d[k]) / np.linalg.norm(d[k])
            assert_close(got[name]["ratio"][k], w[-1] / w[-2], rtol=1e-6, what=f"{name} ratio {k}")
            assert_close(got[name]["major"][k], w[-1], rtol=1e-6, what=f"{name} major {k}")
            assert abs(got[name]["alpha_deg"][k] - math.degrees(math.acos(min(cos, 1.0)))) < 1e-4
