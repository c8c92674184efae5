"""jaxstiff.shape warns where waypoints have no usable solution (before, only the command line said
so: a script got status 3 at 14 of 15 waypoints and a warning about the one usable waypoint)."""

import warnings

import numpy as np
import pytest

import jaxstiff
from jaxstiff.results._target import UnusableWaypointsWarning, unusable_warning

META = {"limits": {"first_rate_limit": False}}


def test_the_text_counts_the_waypoints_names_the_worst_path_and_the_likelier_cause():
    status = np.array([[0, 0, 3, 3], [0, 3, 0, 0]])
    err = np.array([[0.0, 0.0, 0.02, 0.05], [0.0, 0.3, 0.0, 0.0]])
    text = unusable_warning(status, err, META)
    assert text is not None and text.startswith("3 of 8 waypoints have no usable solution (path 0: 2 of 4;")
    assert "largest position error 0.3 m" in text and "joint rate limit" in text  # every first waypoint was reached
    # where the walk lost the path, and that the stiffness limits are not what binds (a newcomer widened
    # kmin/kmax on such a path, as the old text's "rate limits (dq, dk)" suggested, and lost more)
    assert "(path 0: before waypoint 2)" in text and "dk, kmin, kmax do not bound the TCP's motion" in text
    # a first waypoint not reached (it has no rate limit): the units or the reach
    text = unusable_warning(np.array([[3, 3]]), np.array([[0.5, 0.5]]), META)
    assert text is not None and "check the path's units and the robot's reach" in text and "rate limit" not in text
    limited = {"limits": {"first_rate_limit": True}}
    text = unusable_warning(np.array([[3, 0]]), np.array([[0.5, 0.0]]), limited)
    assert text is not None and "first_rate_limit" in text
    # every waypoint usable, or only not run (an interrupted run): nothing to say
    assert unusable_warning(np.array([[0, 1, 2]]), np.zeros((1, 3)), META) is None
    assert unusable_warning(np.array([[0, 5, 5]]), np.zeros((1, 3)), META) is None


@pytest.mark.slow
def test_shape_warns_where_the_rate_limits_leave_waypoints_unusable():
    robot = jaxstiff.Robot.from_urdf("kuka_lwr4", locked={"lwr_a7": 0.0})
    p = jaxstiff.default_path()
    # a 0.2 m jump after the first waypoint: 2 deg per waypoint cannot follow it
    pts = np.array([p.points[0], p.points[0] + [0.0, 0.2, 0.0], p.points[0] + [0.0, 0.2, 0.01]])
    with warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        res = jaxstiff.shape(robot, jaxstiff.Path(pts), "f2", 5.0, first_starts=1)
    unusable = ~jaxstiff.results.is_usable(res.status)
    assert unusable[0, 1:].all() and not unusable[0, 0]
    msgs = [str(x.message) for x in w if issubclass(x.category, UnusableWaypointsWarning)]
    assert (
        len(msgs) == 1
        and msgs[0].startswith("2 of 3 waypoints have no usable solution")
        and "joint rate limit" in msgs[0]
        and "before waypoint 1" in msgs[0]
    )
