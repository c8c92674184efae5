"""The elliptic-arc generator and the turning rate of a path, against closed forms; the curved path of
the seed-000 ``_curved`` experiments is reachable by the LWR and turns faster than the rate limit."""

import math

import numpy as np
import pytest
from helpers import assert_close, load_script, numpy_fk

from jaxstiff import paths
from jaxstiff.paths import ellipse_arc, ellipse_curvature, turning_deg


def _param(p, c, a, b):
    """Parameter angle t of points on the ellipse (a cos t, b sin t) about c (xy plane), rad."""
    return np.arctan2((p[:, 1] - c[1]) / b, (p[:, 0] - c[0]) / a)


def test_ellipse_arc_geometry_tangent_and_turning_against_closed_forms():
    c, a, b = np.array([0.55, 0.0, 0.3]), 0.2, 0.12
    p = ellipse_arc(c, a, b, 90.0, -90.0, n=41)
    rel = p.points - c
    assert_close(rel[:, 2], np.zeros(41), atol=1e-15, what="in the plane z = 0.3")
    assert_close((rel[:, 0] / a) ** 2 + (rel[:, 1] / b) ** 2, np.ones(41), atol=1e-12, what="on the ellipse")
    assert_close(p.points[[0, 20, 40]], [[0.55, 0.12, 0.3], [0.75, 0.0, 0.3], [0.55, -0.12, 0.3]], atol=1e-9)
    # equal spacing in arc length: the chords are equal to second order in the step
    ds = np.linalg.norm(np.diff(p.points, axis=0), axis=1)
    assert np.ptp(ds) / ds.mean() < 2e-3
    # direction: the closed-form tangent (-a sin t, b cos t), sense of decreasing t
    t = _param(p.points, c, a, b)
    tan = -np.c_[-a * np.sin(t), b * np.cos(t), np.zeros_like(t)]
    assert_close(p.directions, tan / np.linalg.norm(tan, axis=1, keepdims=True), atol=1e-12)
    # turning between waypoints = the difference of the closed-form tangent angles ...
    phi = np.unwrap(np.arctan2(-b * np.cos(t), a * np.sin(t)))
    assert_close(turning_deg(p), np.degrees(np.abs(np.diff(phi))), atol=1e-9, what="turning")
    # ... and about curvature times spacing, largest at the apex (kappa = a / b^2)
    tm = np.degrees(0.5 * (t[1:] + t[:-1]))
    assert_close(np.radians(turning_deg(p)), ellipse_curvature(a, b, tm) * ds, rtol=2e-3, what="kappa ds")
    assert math.isclose(float(ellipse_curvature(a, b, 0.0)), a / b**2, rel_tol=1e-12)
    assert math.isclose(float(ellipse_curvature(a, b, 90.0)), b / a**2, rel_tol=1e-12)
    assert np.argmax(turning_deg(p)) in (19, 20)
    assert math.isclose(float(turning_deg(p).sum()), 180.0, rel_tol=1e-9)  # half an ellipse


def test_ellipse_arc_with_equal_axes_is_the_arc():
    e = ellipse_arc([0.1, 0.2, 0.3], 0.5, 0.5, 10.0, 100.0, n=7, normal=[0.0, 1.0, 1.0])
    a = paths.arc([0.1, 0.2, 0.3], 0.5, 10.0, 100.0, n=7, normal=[0.0, 1.0, 1.0])
    assert_close(e.points, a.points, atol=1e-10)
    assert_close(e.directions, a.directions, atol=1e-10)
    assert_close(turning_deg(e), np.full(6, 15.0), atol=1e-8, what="circle: 90 deg in 6 equal turns")


def test_turning_deg_of_a_batch_and_of_tiny_turns():
    line = paths.line([0, 0, 0], [1, 0, 0], n=4)
    assert_close(turning_deg(line), np.zeros(3), atol=0.0)
    eps = 1e-9  # arccos of a dot product would lose this; atan2 keeps it
    d = np.array([[1.0, 0, 0], [math.cos(eps), math.sin(eps), 0], [0, 1.0, 0]])
    p = paths.Path(np.array([[0.0, 0, 0], [1, 0, 0], [2, 0, 0]]), d)
    assert_close(turning_deg(p), np.degrees([eps, math.pi / 2 - eps]), rtol=1e-7)
    both = paths.Path.stack([p, p])
    assert turning_deg(both).shape == (2, 2)


@pytest.mark.parametrize(
    "args, match",
    [
        (([0, 0, 0], 0.0, 0.1, 0, 90), "semi_x must be a finite number > 0"),
        (([0, 0, 0], 0.1, -1.0, 0, 90), "semi_y must be a finite number > 0"),
        (([0, 0, 0], 0.1, 0.1, 30, 30), "start and end angles coincide"),
        (([0, 0], 0.1, 0.1, 0, 90), "center must be 3 finite numbers"),
    ],
)
def test_ellipse_arc_errors(args, match):
    with pytest.raises(ValueError, match=match):
        ellipse_arc(*args)


def _curved_experiment():
    return load_script("experiments/fig4_f1_curved.py")


@pytest.mark.slow
def test_curved_experiment_path_turns_faster_than_the_rate_limit_and_is_reachable():
    """The ``_curved`` path: in a horizontal plane, its turning peaks above the 2 deg per waypoint joint
    rate limit (and stays below it at the ends), and IK reaches its waypoints with the elbow bent."""
    import jax

    import jaxstiff
    from jaxstiff.ik import ik_position
    from jaxstiff.settings import ShapeSettings

    p = _curved_experiment().curved_path()
    assert p.P == 60 and np.ptp(p.points[:, 2]) == 0.0
    t = turning_deg(p)
    dq_deg = math.degrees(ShapeSettings().dq)
    assert t.max() > 3 * dq_deg and t.min() < dq_deg
    shoulder, upper, fore = np.array([0.0, 0.0, 0.3105]), 0.4, 0.39 + 0.078  # URDF: lwr_a2, link lengths
    dist = np.linalg.norm(p.points - shoulder, axis=1)
    bend = 180 - np.degrees(np.arccos((upper**2 + fore**2 - dist**2) / (2 * upper * fore)))
    assert bend.min() > 40 and bend.max() < 105, bend
    robot = jaxstiff.Robot.from_urdf("kuka_lwr4", locked={"lwr_a7": 0.0})
    with jax.enable_x64(True):
        q = None
        for k in range(0, 60, 10):
            q, _ = ik_position(robot, p.points[k], q)
            assert np.linalg.norm(numpy_fk(robot, q)[:3, 3] - p.points[k]) < 1e-9
            assert np.all(q >= robot.lower) and np.all(q <= robot.upper) and q[6] == 0.0


def test_rounding_spread_reruns_the_moved_paths_and_reports_each_count(monkeypatch):
    """The curved figures' rounding check runs the same criterion and ratio on the path moved by each
    shift and reports where each holds (a stand-in shape whose count encodes the shift it was given)."""
    from types import SimpleNamespace

    import jaxstiff

    mod = _curved_experiment()
    P = 30
    target = np.column_stack([np.linspace(0.4, 0.6, P), np.zeros(P), np.full(P, 0.3)])

    def result(k, crit="f2", r=5.0):
        alpha = np.where(np.arange(P) < k, 0.1, 5.0)
        return SimpleNamespace(
            alpha_deg=alpha[None],
            ratio=np.full((1, P), r),
            meta={"criterion": crit, "ratio": r},
            P=P,
            target=target[None],
            direction=np.tile([1.0, 0.0, 0.0], (1, P, 1)),
        )

    calls = []

    def fake_shape(robot, path, crit, r):
        shift = float(path.points[0, 0] - target[0, 0])
        calls.append((crit, r, shift))
        return result(10 + round(shift * 1e13), crit, r)

    monkeypatch.setattr(jaxstiff, "shape", fake_shape)
    text = " ".join(mod.rounding_spread(result(7), robot=None))
    assert [c[:2] for c in calls] == [("f2", 5.0)] * len(mod.ROUNDING_SHIFTS)
    np.testing.assert_allclose([c[2] for c in calls], mod.ROUNDING_SHIFTS, rtol=1e-3)
    for s in mod.ROUNDING_SHIFTS:
        k = 10 + round(s * 1e13)
        assert f"{s:+.0e} m: holds at {k} (gives way at {k}-{P - 1})" in text
    assert "(this run: 7)" in text
