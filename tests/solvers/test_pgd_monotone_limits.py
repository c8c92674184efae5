"""pgd with looser rate limits never ends worse (issue 23, item 4).

A larger box contains the tighter box's answer, so for the same seed and the same starts the
looser run's total criterion must not rise beyond a tolerance. Reported on the Panda (pybullet's
franka_panda, dk 5 vs 20: mean f2 1.218 against 1.0000000000005); at HEAD it did not reproduce
there (both 1.0000000000001, docs/notes/solvers.md 2026-12-02), so this is the property on the
shipped robots, the reference being the same solver with the tighter limits (an invariant, not a
stored number). f2 >= 1 everywhere, so the total criterion's floor is P.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import jaxstiff
from jaxstiff.paths import default_path, line
from jaxstiff.shaping import run_shape

# small, fixed settings: one compilation serves every limit (dq and dk are traced arguments)
OPTS = {"iters": 30, "iters_first": 60, "starts_first": 8, "chunk": 1}
REL_TOL = 1e-6  # of the total criterion: the f2 minimum is reached to ~1e-12 per waypoint


def _total(robot: jaxstiff.Robot, path: jaxstiff.Path, task: str, dq: float, dk: float) -> float:
    res = run_shape(
        robot, path, "f2", 3.0 if task == "xy" else 5.0, task=task, solver="pgd", starts=4, options=OPTS, dq=dq, dk=dk
    )
    assert np.all(res.status == 0), res.status
    return float(res.criterion.sum())


def _default12() -> jaxstiff.Path:
    p = default_path()
    return jaxstiff.Path(p.points[:12], p.directions[:12])


CASES = {
    # planar 3R, task xy, a straight line across its workspace
    "planar_3r": (
        lambda: jaxstiff.Robot.from_urdf("planar_3r"),
        lambda: line((0.9, -0.1, 0.0), (1.0, 0.1, 0.0), 12),
        "xy",
    ),
    # KUKA LWR 4 (7th joint locked), the first 12 waypoints of the shipped default path
    "kuka_lwr4": (lambda: jaxstiff.Robot.from_urdf("kuka_lwr4", locked={"lwr_a7": 0.0}), lambda: _default12(), "full"),
}


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(CASES))
def test_looser_limits_never_raise_the_total_criterion(name: str) -> None:
    make_robot, make_path, task = CASES[name]
    robot, path = make_robot(), make_path()
    dq = math.radians(2.0)
    tight = _total(robot, path, task, dq, 5.0)
    for loose_dq, loose_dk in ((dq, 20.0), (2.0 * dq, 5.0), (2.0 * dq, 20.0)):
        loose = _total(robot, path, task, loose_dq, loose_dk)
        assert loose <= tight * (1.0 + REL_TOL), (name, loose_dq, loose_dk, loose, tight)
