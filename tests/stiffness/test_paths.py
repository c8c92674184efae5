"""Paths: tangents against closed forms, generators against their geometry, CSV round trip and errors,
the shipped default path's reachability."""

import math
import os

import numpy as np
import pytest
from helpers import assert_close, numpy_fk

import jaxstiff
from jaxstiff import paths
from jaxstiff.paths import Path


def test_default_direction_is_unit_tangent_of_a_circle():
    # equally spaced points on a circle: the central difference is exactly the tangent
    th = np.linspace(0.0, 1.0, 11)
    pts = np.c_[0.5 * np.cos(th), 0.5 * np.sin(th), np.full_like(th, 0.3)]
    p = Path(pts)
    tangent = np.c_[-np.sin(th), np.cos(th), np.zeros_like(th)]
    assert_close(p.directions[1:-1], tangent[1:-1], atol=1e-12, what="interior tangents")
    # ends: one-sided chords, still unit and within half a step of the tangent
    assert_close(np.linalg.norm(p.directions, axis=1), np.ones(11), atol=1e-14)
    assert np.degrees(np.arccos(p.directions[0] @ tangent[0])) < 0.5 * np.degrees(th[1]) + 1e-9


def test_given_directions_are_normalised_and_kept():
    pts = np.array([[0.0, 0, 0], [1.0, 0, 0], [2.0, 0, 0]])
    d = np.array([[0.0, 2, 0], [0.0, 0, 3], [1.0, 1, 0]])
    p = Path(pts, d)
    assert_close(p.directions, d / np.linalg.norm(d, axis=1, keepdims=True))


def test_line_arc_circle_half_sine_spline_geometry():
    ln = paths.line([0, 0, 0], [0.3, 0.4, 0], n=6)
    assert_close(ln.points[-1], [0.3, 0.4, 0])
    assert_close(ln.directions, np.tile([0.6, 0.8, 0.0], (6, 1)))

    a = paths.arc([0.1, 0.2, 0.3], 0.5, 0.0, 90.0, n=7)
    rel = a.points - np.array([0.1, 0.2, 0.3])
    assert_close(np.linalg.norm(rel, axis=1), np.full(7, 0.5), what="on the circle")
    assert_close(np.sum(rel * a.directions, axis=1), np.zeros(7), atol=1e-14, what="tangent perpendicular to radius")
    assert_close(a.points[-1], [0.1, 0.7, 0.3], atol=1e-14)
    assert a.directions[0] @ np.array([0.0, 1.0, 0.0]) > 0.999  # counter-clockwise from +x

    c = paths.circle([0, 0, 0.4], 0.2, n=8)
    assert c.P == 8
    assert np.linalg.norm(c.points[0] - c.points[-1]) > 0.1  # first point not repeated

    hs = paths.half_sine([0.6, 0.25, 0.3], [0.6, -0.25, 0.3], 0.1, n=21)
    assert_close(hs.points[10], [0.7, 0.0, 0.3], atol=1e-14, what="bulge of 0.1 m towards +x at the middle")
    # analytic tangent equals the derivative by central differences of the generator
    s = np.linspace(0, 1, 21)
    assert_close(hs.directions[10], [0.0, -1.0, 0.0], atol=1e-14)
    fd = (hs.points[11] - hs.points[9]) / np.linalg.norm(hs.points[11] - hs.points[9])
    assert np.degrees(np.arccos(np.clip(fd @ hs.directions[10], -1, 1))) < 1e-6
    del s

    ctrl = np.array([[0.5, -0.2, 0.3], [0.6, 0.0, 0.35], [0.5, 0.2, 0.3]])
    sp = paths.spline(ctrl, n=41)
    assert_close(sp.points[0], ctrl[0], atol=1e-12)
    assert_close(sp.points[-1], ctrl[-1], atol=1e-12)
    assert np.min(np.linalg.norm(sp.points - ctrl[1], axis=1)) < 0.01  # passes (near) the middle point


def test_batch_and_stack():
    a, b = paths.line([0, 0, 0], [1, 0, 0], 5), paths.line([0, 0, 0], [0, 1, 0], 5)
    s = Path.stack([a, b])
    assert s.batched and s.B == 2 and s.P == 5 and s.points.shape == (2, 5, 3)
    assert_close(s[1].points, b.points)
    assert a.as_batch().points.shape == (1, 5, 3)
    with pytest.raises(ValueError, match="same number of waypoints"):
        Path.stack([a, paths.line([0, 0, 0], [1, 0, 0], 6)])


@pytest.mark.parametrize(
    "points, directions, match",
    [
        (np.zeros((1, 3)), None, "at least 2 waypoints, or 1 with its direction given"),
        (np.zeros((0, 3)), np.zeros((0, 3)), "at least 2 waypoints"),
        (np.zeros((3, 2)), None, "shape"),
        (np.array([[0, 0, 0], [np.nan, 0, 0]]), None, "NaN"),
        (np.array([[0, 0, 0], [0, 0, 0], [1, 0, 0.0]]), None, "zero-length segment at waypoint 0"),
        (np.array([[0, 0, 0], [1, 0, 0], [1, 0, 0.0]]), None, "zero-length segment"),
        (np.array([[0, 0, 0], [1, 0, 0.0]]), np.array([[1, 0, 0], [0, 0, 0.0]]), "zero-length direction"),
    ],
)
def test_bad_paths(points, directions, match):
    with pytest.raises(ValueError, match=match):
        Path(points, directions)


def test_zero_length_segment_allowed_with_directions():
    pts = np.array([[0, 0, 0], [0, 0, 0], [1, 0, 0.0]])
    p = Path(pts, np.tile([1.0, 0, 0], (3, 1)))
    assert p.P == 3


def test_csv_round_trip(tmp_path):
    p = paths.arc([0, 0, 0.4], 0.6, -30, 30, n=9)
    f = tmp_path / "arc.csv"
    p.to_csv(f)
    q = Path.from_csv(f)
    assert_close(q.points, p.points, rtol=0, atol=0, what="repr() keeps every bit")
    assert_close(q.directions, p.directions, rtol=0, atol=1e-16)
    assert [x for x in os.listdir(tmp_path) if x.startswith(".tmp")] == []
    # without directions: the tangent comes back
    p.to_csv(tmp_path / "xyz.csv", directions=False)
    r = Path.from_csv(tmp_path / "xyz.csv")
    assert_close(r.points, p.points, rtol=0, atol=0)
    cosang = np.sum(r.directions * p.directions, axis=1)
    assert np.all(cosang[1:-1] > 1 - 1e-12)  # central differences on a circle: exact tangents
    assert np.all(np.degrees(np.arccos(cosang[[0, -1]])) < 7.5 / 2 + 1e-9)  # ends: half a 7.5 deg step


@pytest.mark.parametrize(
    "text, match",
    [
        ("", "empty file"),
        ("\n  \n", "empty file"),
        ("# only a note\n# x,y,z\n", "only comment lines"),
        ("a,b,c\n1,2,3\n4,5,6\n", "header must be"),
        ("x,y,z\n1,2,3\n", "at least 2 waypoints"),
        ("x,y,z\n1,2,3\n4,five,6\n", r":3: column y: 'five' is not a number"),
        ("x,y,z\n1,2,3\n4,5\n", r":3: expected 3 values"),
        ("x,y,z\n1,2,3\n4,nan,6\n", "not finite"),
        ("x,y,z\n1,2,3\n1,2,3\n", r"bad.csv: zero-length segment at waypoint 0 \(line 2\)"),
        (
            "# note\nx,y,z,dx,dy,dz\n1,2,3,1,0,0\n4,5,6,0,0,0\n",
            r"bad.csv: zero-length direction at waypoint 1 \(line 4\)",
        ),
        ("x,y,z\n1,2,3\n4,1_0,6\n", r":3: column y: '1_0' is not a number"),  # float() takes it as 10
        ("x,y,z\n1,2,3\n4,\uff15,6\n", r":3: column y: '\uff15' is not a number"),  # full-width 5
        ("x,y,z\n1,2,3\n4,5\x0b,6\n7,8\n", r"bad.csv:4: expected 3 values"),  # a vertical tab is no line end
    ],
)
def test_csv_errors_name_the_problem(tmp_path, text, match):
    f = tmp_path / "bad.csv"
    f.write_text(text)
    with pytest.raises(ValueError, match=match):
        Path.from_csv(f)


def test_csv_missing_file(tmp_path):
    with pytest.raises(FileNotFoundError, match="nope.csv"):
        Path.from_csv(tmp_path / "nope.csv")


def test_csv_comments_and_zero_segment_with_directions(tmp_path):
    f = tmp_path / "c.csv"
    f.write_text("# a comment\nx,y,z,dx,dy,dz\n0.5,0,0.3,0,1,0\n0.5,0,0.3,0,1,0\n0.5,0.1,0.3,0,1,0\n")
    assert Path.from_csv(f).P == 3


def test_default_path_geometry_and_reachability():
    """The shipped default path: in a horizontal plane, inside the LWR's workspace with the elbow far
    from straight (null-space room), and every waypoint reached by IK (checked with the numpy FK)."""
    p = jaxstiff.default_path()
    assert p.P == 60 and p.name == "default"
    assert np.ptp(p.points[:, 2]) == 0.0 and np.all(np.abs(p.directions[:, 2]) < 1e-15)
    shoulder = np.array([0.0, 0.0, 0.3105])  # URDF: lwr_a2 origin
    upper, fore = 0.4, 0.39 + 0.078  # URDF link lengths
    dist = np.linalg.norm(p.points - shoulder, axis=1)
    # elbow bend angle from the law of cosines: well inside (0, 120 deg) = the A4 range
    bend = 180 - np.degrees(np.arccos((upper**2 + fore**2 - dist**2) / (2 * upper * fore)))
    assert bend.min() > 40 and bend.max() < 100, bend
    # the tangent turns smoothly: < 5 deg between consecutive waypoints
    turn = np.degrees(np.arccos(np.clip(np.sum(p.directions[1:] * p.directions[:-1], axis=1), -1, 1)))
    assert turn.max() < 5.0

    import jax

    from jaxstiff.ik import ik_position

    robot = jaxstiff.Robot.from_urdf("kuka_lwr4", locked={"lwr_a7": 0.0})
    with jax.enable_x64(True):
        q = None
        for k in range(0, 60, 6):
            q, err = ik_position(robot, p.points[k], q)
            pos = numpy_fk(robot, q)[:3, 3]
            assert np.linalg.norm(pos - p.points[k]) < 1e-9
            assert np.all(q >= robot.lower) and np.all(q <= robot.upper)
            assert q[6] == 0.0


def test_default_path_n_and_spec():
    p = jaxstiff.default_path(n=5)
    assert p.P == 5
    assert_close(p.points[0], paths.DEFAULT_PATH_SPEC["start"])
    assert_close(p.points[-1], paths.DEFAULT_PATH_SPEC["end"], atol=1e-15)
    assert math.isclose(float(p.points[2, 0]), 0.7, abs_tol=1e-12)


def test_csv_with_a_byte_order_mark_reads_like_one_without(tmp_path):
    """Spreadsheet programs write UTF-8 with a BOM; the header must still be recognised."""
    text = "x,y,z,dx,dy,dz\n0.6,0.2,0.3,1,0,0\n0.6,0.1,0.3,0,1,0\n"
    (tmp_path / "bom.csv").write_bytes(b"\xef\xbb\xbf" + text.encode())
    (tmp_path / "plain.csv").write_text(text)
    a, b = Path.from_csv(tmp_path / "bom.csv"), Path.from_csv(tmp_path / "plain.csv")
    np.testing.assert_array_equal(np.asarray(a.points), np.asarray(b.points))
    np.testing.assert_array_equal(np.asarray(a.directions), np.asarray(b.directions))


def test_out_and_back_path_has_the_line_of_its_segments_at_the_turn():
    """The central difference cancels where a path turns straight back; the turn's direction is
    then the line both segments lie on (alpha does not see the sign), not an error."""
    pts = np.array([[0.5, 0.0, 0.4], [0.5, 0.1, 0.4], [0.5, 0.0, 0.4], [0.5, 0.0, 0.5]])
    d = jaxstiff.Path(pts).directions
    assert np.allclose(np.abs(d[1]), [0.0, 1.0, 0.0], atol=1e-15)
    assert np.allclose(d[0], [0.0, 1.0, 0.0]) and np.allclose(np.linalg.norm(d, axis=-1), 1.0)


def test_read_csv_gives_the_rows_without_geometry_checks(tmp_path):
    """paths.read_csv (the points a CSC rollout steps through): repeated rows and one row are fine,
    numbers as written, line numbers of the rows; Path.from_csv of the same file refuses the pause."""
    f = tmp_path / "pause.csv"
    f.write_text("x,y,z\r\n1.5,1.0,0\r\n# hold\r\n1.5,1.05,0\r\n1.5,1.05,0\r\n-1e-1,+2.,.5\r\n")
    pts, dirs, lines = paths.read_csv(f)
    np.testing.assert_array_equal(pts, [[1.5, 1.0, 0], [1.5, 1.05, 0], [1.5, 1.05, 0], [-0.1, 2.0, 0.5]])
    assert dirs is None and lines == [2, 4, 5, 6]
    with pytest.raises(ValueError, match=r"pause.csv: zero-length segment at waypoint 1 \(line 4\)"):
        Path.from_csv(f)
    one = tmp_path / "one.csv"
    one.write_text("x,y,z,dx,dy,dz\n1,2,3,0,0,1\n")
    pts, dirs, lines = paths.read_csv(one)
    assert pts.shape == (1, 3) and dirs is not None and dirs.tolist() == [[0.0, 0.0, 1.0]] and lines == [2]


def test_csv_with_empty_trailing_columns_reads_like_one_without(tmp_path):
    """A spreadsheet export 'x,y,z,' with rows '1,2,3,': the empty column is dropped; a value in it
    is still an error (a row of 4 values for 3 columns)."""
    f = tmp_path / "t.csv"
    f.write_text("x,y,z,\n1,2,3,\n4,5,6,\n")
    np.testing.assert_array_equal(Path.from_csv(f).points, [[1, 2, 3], [4, 5, 6]])
    f.write_text("x,y,z,\n1,2,3,\n4,5,6,7\n")
    with pytest.raises(ValueError, match=r"t.csv:3: expected 3 values"):
        Path.from_csv(f)


def test_tangents_of_one_waypoint_name_the_problem():
    """`tangents(np.zeros((1, 3)))` raised `IndexError: index 1 is out of bounds` (a tester's find)."""
    from jaxstiff.paths import tangents

    with pytest.raises(ValueError, match=r"tangents need at least 2 waypoints \(P, 3\), got shape \(1, 3\)"):
        tangents(np.zeros((1, 3)))
