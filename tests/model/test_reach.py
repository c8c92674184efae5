"""The reach check (jaxstiff.model._reach): the shell ``inner <= |p_tcp - centre| <= outer`` holds for
every posture within the limits on every arm (random and corner postures, FK from the kinematics
kernel), matches closed forms where the geometry gives them, and refuses waypoints outside it in
``shape``, ``csc_rollout``, their commands and the sweep (a row marked, not the sweep refused), with a
message that names the waypoint, its distance and the reach (and millimetres where they look so).
A waypoint inside the shell that no posture attains still gets status 3, without SLSQP runs.
Timing: scripts/bench_reach.py."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from helpers import DATA_DIR, planar_arc_sweep

import jaxstiff
from jaxstiff.cli import main
from jaxstiff.model._reach import UnreachableError, check_reach, unreachable_mask
from jaxstiff.results import _files as R

ROBOTS = DATA_DIR / "robots"
LWR = jaxstiff.Robot.from_urdf("kuka_lwr4", locked={"lwr_a7": 0.0})

#: every arm the tests have, with a tip link where the file has several candidates
ARMS = [
    ("kuka_lwr4", {"locked": {"lwr_a7": 0.0}}),
    ("kuka_lwr4", {}),
    ("planar_3r", {}),
    ("planar_4r", {}),
    (str(DATA_DIR / "branched_tree.urdf"), {"tip_link": "tool"}),  # a prismatic joint
    (str(DATA_DIR / "branched_tree.urdf"), {"tip_link": "tool", "locked": {"j2": 0.3, "j3": 1.0}}),
    (str(DATA_DIR / "panda_like.urdf"), {}),
    (str(DATA_DIR / "planar_4r_tight_limits.urdf"), {}),
    (str(ROBOTS / "kinova_j2s6s200.urdf"), {"tip_link": "j2s6s200_end_effector"}),
    (str(ROBOTS / "so101.urdf"), {"tip_link": "gripper_frame_link"}),
    (str(ROBOTS / "talos_left_arm.urdf"), {"tip_link": "gripper_left_base_link"}),
    (str(ROBOTS / "ur10.urdf"), {"tip_link": "tool0"}),
    (str(ROBOTS / "z1.urdf"), {"tip_link": "gripperStator"}),
    (str(ROBOTS / "z1.urdf"), {"tip_link": "gripperStator", "tcp": [0.1, 0.02, 0.0]}),
]


def _postures(robot: jaxstiff.Robot, count: int, seed: int) -> np.ndarray:
    """Random postures within the limits (continuous joints: one turn), plus every corner of the
    box of the first six free joints (a shell's extremes often lie at joint limits)."""
    rng = np.random.default_rng(seed)
    lo = np.where(np.isfinite(robot.lower), robot.lower, -np.pi)
    hi = np.where(np.isfinite(robot.upper), robot.upper, np.pi)
    q = rng.uniform(lo, hi, (count, robot.n))
    free = np.flatnonzero(robot.free)[:6]
    corners = np.tile(0.5 * (lo + hi), (2 ** len(free), 1))
    for row, pick in enumerate(itertools.product((0, 1), repeat=len(free))):
        corners[row, free] = np.where(np.asarray(pick) == 1, hi[free], lo[free])
    q = np.vstack([q, corners])
    return np.where(robot.free, q, np.nan_to_num(robot.locked_values))


@pytest.mark.parametrize("urdf,kw", ARMS, ids=lambda v: v if isinstance(v, str) and "/" not in v else None)
def test_every_posture_within_the_limits_passes_the_check(urdf, kw):
    """Conservative: FK points of 20,000 random postures and the box corners all lie in the shell,
    so the check never refuses a reachable waypoint."""
    robot = jaxstiff.Robot.from_urdf(urdf, **kw)
    reach = robot.reach()
    q = _postures(robot, 20_000, seed=len(robot.joint_names))
    p = np.asarray(robot.fk(q))[:, :3, 3]
    d = np.linalg.norm(p - reach.centre, axis=1)
    assert 0.0 <= reach.inner <= reach.outer and np.isfinite(reach.outer)
    assert d.max() <= reach.outer and d.min() >= reach.inner, (d.min(), d.max(), reach)
    assert not unreachable_mask(robot, p).any()
    assert not unreachable_mask(robot, p[:, :2], planar=True).any()
    check_reach(robot, p[:20_000].reshape(100, 200, 3))  # no error
    # and the outer sphere is a real bound, not a huge one: the sampled postures come within 5 % of it
    # (the branched tree's prismatic joint and elbow offset leave 3.4 %)
    assert d.max() >= 0.95 * reach.outer


def test_lwr_shell_matches_its_closed_form():
    """The LWR: the shoulder (lwr_a2 at z = 0.3105 m, on lwr_a1's axis) is the centre; lwr_a3 and
    lwr_a5 turn about the links, so shoulder-wrist is a triangle with sides 0.4 and 0.39 m and the
    elbow lwr_a4 within +-120 deg (angle between the links >= 60 deg), then 0.078 m to the flange."""
    r = LWR.reach()
    np.testing.assert_allclose(r.centre, [0.0, 0.0, 0.3105], atol=1e-15)
    assert r.centre_joint == "lwr_a2"
    assert r.outer == pytest.approx(0.4 + 0.39 + 0.078, abs=1e-9)
    wrist = math.sqrt(0.4**2 + 0.39**2 - 2 * 0.4 * 0.39 * math.cos(math.radians(60.0)))
    assert r.inner == pytest.approx(wrist - 0.078, abs=1e-9)


def test_planar_3r_shell_is_the_disc_of_its_links():
    r = jaxstiff.Robot.from_urdf("planar_3r").reach()
    assert r.outer == pytest.approx(3.0, abs=1e-9) and r.inner == 0.0
    np.testing.assert_allclose(r.centre, 0.0, atol=1e-15)


def test_a_prismatic_first_joint_keeps_its_base_as_centre(tmp_path):
    """A linear axis (prismatic, 0.2..1.0 m along x) carrying a 0.5 m revolute link: the TCP is at
    (s + 0.5 cos t, 0.5 sin t), so |p| is at most 1.5 m (s = 1, t = 0) and at least 0 (s = 0.5, t = pi)."""
    urdf = tmp_path / "gantry.urdf"
    urdf.write_text(
        """<robot name="gantry"><link name="b"/><link name="c"/><link name="l"/><link name="t"/>
        <joint name="s" type="prismatic"><parent link="b"/><child link="c"/><axis xyz="1 0 0"/>
          <limit lower="0.2" upper="1.0" effort="1" velocity="1"/></joint>
        <joint name="r" type="continuous"><parent link="c"/><child link="l"/><axis xyz="0 0 1"/></joint>
        <joint name="tool" type="fixed"><parent link="l"/><child link="t"/><origin xyz="0.5 0 0"/></joint>
        </robot>"""
    )
    robot = jaxstiff.Robot.from_urdf(urdf)
    r = robot.reach()
    assert r.outer == pytest.approx(1.5, abs=1e-9)
    q = _postures(robot, 5000, seed=3)
    d = np.linalg.norm(np.asarray(robot.fk(q))[:, :3, 3] - r.centre, axis=1)
    assert d.max() <= r.outer and d.min() >= r.inner


# ---------------------------------------------------------------------- refused before any solve
def _line(x: float, n: int = 4) -> np.ndarray:
    return np.stack([np.full(n, x), np.linspace(-0.1, 0.1, n), np.full(n, 0.3)], axis=1)


def test_shape_refuses_a_path_beyond_reach_naming_waypoint_distance_and_reach():
    with pytest.raises(UnreachableError) as e:
        jaxstiff.shape(LWR, _line(2.0), "f2", 5.0)
    msg = str(e.value)
    assert "robot 'kuka_lwr4' cannot reach 4 of 4 waypoints" in msg
    assert "waypoint 0 at (2, -0.1, 0.3) m is 2.003 m from the centre (beyond)" in msg  # |(2, -0.1, -0.0105)|
    assert "beyond 0.868 m or inside 0.3171 m" in msg and "'lwr_a2' at (0, 0, 0.3105) m" in msg
    assert "millimetres" not in msg and "\n" not in msg
    assert [(b, k) for b, k, _, _ in e.value.entries] == [(0, 0), (0, 1), (0, 2), (0, 3)]
    assert isinstance(e.value, ValueError)


def test_a_path_in_millimetres_gets_the_hint():
    with pytest.raises(UnreachableError, match=r"look like millimetres \(the largest is 2000.*divide them by 1000"):
        jaxstiff.shape(LWR, _line(2.0) * 1000.0, "f2", 5.0)


def test_a_waypoint_in_the_hole_and_a_batch_name_the_paths():
    """Path 1's waypoint 2 sits 5 cm above the shoulder (inside the 0.317 m hole), path 2's last
    waypoint 1.2 m out; path 0 is fine: the message names paths 1 and 2."""
    ok = jaxstiff.paths.default_path(n=5).points
    bad1, bad2 = ok.copy(), ok.copy()
    bad1[2] = [0.0, 0.0, 0.3605]
    bad2[4] = [1.2, 0.0, 0.3105]
    with pytest.raises(UnreachableError) as e:
        jaxstiff.shape(LWR, np.stack([ok, bad1, bad2]), "f2", 5.0)
    msg = str(e.value)
    assert "2 of 15 waypoints (paths 1, 2)" in msg
    assert "path 1 waypoint 2 at (0, 0, 0.3605) m is 0.05 m from the centre (inside)" in msg
    assert "path 2 waypoint 4 at (1.2, 0, 0.3105) m is 1.2 m from the centre (beyond)" in msg


def test_task_xy_checks_the_plane_only():
    """A planar chain with task xy: z is not matched, so only the radius in the plane counts."""
    planar = jaxstiff.Robot.from_urdf("planar_3r")
    assert not unreachable_mask(planar, [[2.5, 0.0, 7.0]], planar=True).any()
    with pytest.raises(UnreachableError, match=r"waypoint 0 at \(3.5, 0, 0\) m is 3.5 m .* in the xy plane"):
        check_reach(planar, [[3.5, 0.0, 0.0]], planar=True)


def test_command_line_shape_exits_2_with_one_line_and_no_file(tmp_path, capsys):
    csv = tmp_path / "mm.csv"
    jaxstiff.Path(_line(2.0) * 1000.0).to_csv(csv)
    out = tmp_path / "o.npz"
    rc = main(["shape", "--path", str(csv), "--out", str(out)])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and not out.exists()
    assert err[-1].startswith("jaxstiff: error: robot 'kuka_lwr4' cannot reach 4 of 4 waypoints: waypoint 0 at")
    assert "millimetres" in err[-1]


def test_csc_refuses_a_hold_beyond_reach(tmp_path, capsys):
    planar = jaxstiff.Robot.from_urdf("planar_3r")
    with pytest.raises(UnreachableError, match=r"waypoints 0-4 at \(5, 0\) m are 5 m from the centre"):
        jaxstiff.csc_rollout(planar, np.tile([5.0, 0.0], (5, 1)), np.diag([3000.0, 1000.0]), np.full(3, 0.3))
    out = tmp_path / "far.npz"
    argv = "csc --robot planar_3r --lock none --hold 5,0 --kxd 3000,1000 --q0 0.3,0.3,0.3 --steps 20 --out"
    rc = main([*argv.split(), str(out)])
    assert rc == 2 and not out.exists()
    assert "jaxstiff: error: robot 'planar_3r' cannot reach 20 of 20 waypoints" in capsys.readouterr().err


def test_unattainable_waypoint_inside_the_shell_is_given_up_without_slsqp():
    """0.4 m below the base: inside the shell (0.71 m from the shoulder), but no posture gets
    there (the closest of 400,000 random postures is 0.15 m off). Status 3 at every waypoint, and
    no SLSQP iteration was spent on them (they used to take 16 solves of up to 1000 iterations)."""
    pts = np.array([[0.0, 0.0, -0.4], [0.0, 0.01, -0.4], [0.0, 0.02, -0.4]])
    assert not unreachable_mask(LWR, pts).any()
    res = jaxstiff.shape(LWR, pts, "f2", 5.0)
    assert np.all(res.status == R.UNREACHABLE)
    assert np.all(res.nit == 0) and np.all(res.pos_error > 0.1)


def test_sweep_marks_rows_out_of_reach_instead_of_refusing(tmp_path):
    """Arcs of radius 1.5 m and 4 m for a 3 m planar arm: the 4 m rows are not solved, their
    waypoints count as unreachable (status 3); the 1.5 m rows are solved as usual."""
    from jaxstiff.sweep import read_table, run_sweep

    cfg = planar_arc_sweep(
        "reach", {"task": "xy", "criterion": "f2", "ratio": [2.0], "first_starts": 2}, radius=(1.5, 4.0)
    )
    run_sweep(cfg, tmp_path / "run", progress=False, report=False, compile_cache=False)
    df = read_table(str(tmp_path / "run"))
    assert len(df) == 2
    far = df[df["share_unreachable"] == 1.0]
    near = df[df["share_unreachable"] == 0.0]
    assert len(far) == 1 and len(near) == 1
    assert far.iloc[0]["result_file"] == "" and far.iloc[0]["result_index"] == -1
    assert far.iloc[0]["share_usable"] == 0.0 and math.isnan(far.iloc[0]["q0_ik_error_m"])
    assert near.iloc[0]["share_usable"] == 1.0 and near.iloc[0]["result_file"].startswith("arrays/")
    from jaxstiff.view._data import sweep_row_file

    with pytest.raises(ValueError, match=r"sweep row \d+ was not solved \(its path leaves the robot's reach\)"):
        sweep_row_file(str(tmp_path / "run"), int(far.iloc[0]["row_id"]))
