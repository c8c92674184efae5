"""The settings spine: one default, unit and help per setting, the same in the API (``shape()``), the
command line (``jaxstiff shape`` and every command's robot flags), and the sweep config (TOML);
RobotSpec's default locks and tool rotation; units recorded in the result's meta; the progress
facility the commands share."""

from __future__ import annotations

import argparse
import io
import math

import numpy as np
import pytest

import jaxstiff
from jaxstiff.cli import add_robot_flags, build_parser, main, robot_spec_from_args
from jaxstiff.runtime._progress import Progress, progress
from jaxstiff.settings import DEFAULT_LOCKS, RobotSpec, ShapeSettings
from jaxstiff.settings._robot import tcp_transform

S = ShapeSettings()
ROBOT_FLAGS = ("--robot", "--base-link", "--tip-link", "--lock", "--tcp")


def short_path(n: int = 2) -> jaxstiff.Path:
    p = jaxstiff.default_path()
    return jaxstiff.Path(p.points[:n], p.directions[:n])


@pytest.fixture(scope="module")
def default_run():
    """The LWR through a RobotSpec (default lock), two waypoints, every setting at its default."""
    return jaxstiff.shape(RobotSpec(), short_path(2))


#: the required flags of a command (none of them a robot flag)
REQUIRED = {"csc": ["--kxd", "3000,1000", "--out", "x.npz", "--hold", "0.5,0.2", "--q0", "0,0,0"]}


def _parse(command: str, *argv: str) -> argparse.Namespace:
    return build_parser().parse_args([command, *REQUIRED.get(command, []), *argv])


def _parser_defaults(command: str) -> argparse.Namespace:
    return _parse(command)


def _flag_actions(command: str) -> dict[str, argparse.Action]:
    """``{option string: action}`` of a subcommand (argparse's own attributes)."""
    parser = build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return {opt: a for a in sub.choices[command]._actions for opt in a.option_strings}


# ---------------------------------------------------------------------- shape defaults: API == CLI == TOML
def test_shape_settings_defaults_are_shape_defaults_in_the_api(default_run):
    meta = default_run.meta
    recorded = {k: v for k, v in meta["settings"].items() if k != "units"}
    assert recorded == {k: v for k, v in S.meta().items() if k != "units"}
    assert meta["criterion"] == S.criterion and meta["ratio"] == S.ratio and meta["c"] == S.c
    assert meta["task"] == S.task and meta["solver"] == S.solver and meta["starts"] == 1  # SLSQP's own (starts None)
    lim = meta["limits"]
    assert lim["dq"] == [S.dq] * 7 and lim["dk"] == [S.dk] * 7
    assert (lim["kmin"], lim["kmax"], lim["first_rate_limit"]) == (S.kmin, S.kmax, S.first_rate_limit)
    assert meta["first_starts"]["count"] == S.first_starts
    assert meta["cms"]["target_volume"] == S.cms_mean_axis**3
    # shaping.DEFAULTS (meta["defaults"]) is derived from the settings; dq in degrees there
    from jaxstiff.shaping import DEFAULTS

    assert meta["defaults"] == DEFAULTS
    assert DEFAULTS["dq_deg"] == math.degrees(S.dq) == 2.0
    for key in ("dk", "kmin", "kmax", "c", "first_rate_limit", "first_starts", "cms_mean_axis"):
        assert DEFAULTS[key] == getattr(S, key), key


def test_settings_object_and_keywords(default_run):
    """``settings=`` gives the defaults; a keyword wins over it; the meta says what ran."""
    res = jaxstiff.shape(
        jaxstiff.Robot.from_urdf("kuka_lwr4", locked={"lwr_a7": 0.0}),
        short_path(2),
        ratio=4.0,
        settings=ShapeSettings(ratio=3.0, dk=6.0, first_starts=1),
    )
    m = res.meta
    assert m["ratio"] == 4.0 and m["settings"]["ratio"] == 4.0
    assert m["limits"]["dk"] == [6.0] * 7 and m["settings"]["dk"] == 6.0
    assert m["first_starts"]["count"] == 1 and m["settings"]["first_starts"] == 1
    assert "robot_spec" not in m  # a Robot, not a RobotSpec
    with pytest.raises(ValueError, match="settings must be a jaxstiff.settings.ShapeSettings"):
        jaxstiff.shape("kuka_lwr4", short_path(2), settings={"ratio": 3.0})  # type: ignore[arg-type]


def test_shape_command_defaults_are_the_settings():
    a = _parser_defaults("shape")
    assert a.criterion == S.criterion and float(a.ratio) == S.ratio and a.task == S.task and a.solver == S.solver
    assert a.starts == S.starts
    assert math.radians(float(a.dq_deg)) == S.dq and float(a.dq_deg) == math.degrees(S.dq)
    assert (float(a.dk), float(a.kmin), float(a.kmax), float(a.c)) == (S.dk, S.kmin, S.kmax, S.c)
    assert a.first_rate_limit is S.first_rate_limit and int(a.first_starts) == S.first_starts


# ---------------------------------------------------------------------- robot flags: every command the same
def test_add_robot_flags_defaults_are_robot_spec_defaults():
    p = argparse.ArgumentParser()
    add_robot_flags(p)
    spec = robot_spec_from_args(p.parse_args([]))
    assert spec == RobotSpec()
    a = p.parse_args([])
    assert (a.robot, a.base_link, a.tip_link, a.lock, a.tcp) == (RobotSpec().urdf, None, None, None, None)


@pytest.mark.parametrize("command", ["robot", "shape", "csc"])
def test_every_command_has_the_same_robot_flags(command):
    """The same flags from one place; `robot` has no --locked-joints, so its --lock help does not
    point at that flag (a tester found it did)."""
    p = argparse.ArgumentParser()
    add_robot_flags(p, springs=command != "robot")
    want = {opt: a for a in p._actions for opt in a.option_strings}
    got = _flag_actions(command)
    for flag in ROBOT_FLAGS:
        assert flag in got, f"{command}: {flag} missing"
        w, g = want[flag], got[flag]
        assert (g.dest, g.default, g.help, g.metavar, type(g)) == (w.dest, w.default, w.help, w.metavar, type(w)), (
            command,
            flag,
        )


@pytest.mark.parametrize("command", ["robot", "shape", "csc"])
def test_kuka_lwr4_locks_lwr_a7_by_default_in_every_command(command):
    assert DEFAULT_LOCKS["kuka_lwr4"] == {"lwr_a7": 0.0}
    spec = robot_spec_from_args(_parser_defaults(command))
    assert spec.resolved_locks() == {"lwr_a7": 0.0}
    robot = spec.build()
    assert robot.locked_values[robot.joint_names.index("lwr_a7")] == 0.0 and robot.n_free == 6
    assert robot_spec_from_args(_parse(command, "--lock", "none")).build().n_free == 7


def test_robot_command_locks_lwr_a7_by_default(capsys):
    assert main(["robot"]) == 0
    locked = capsys.readouterr().out
    assert main(["robot", "--lock", "none"]) == 0
    free = capsys.readouterr().out
    assert locked != free  # the printed chain says which joints are locked
    assert main(["robot", "--q", "0,0,0,0,0,0,0.5"]) == 2
    assert "locked at 0" in capsys.readouterr().err


def test_sweep_robot_table_defaults_are_robot_spec_defaults(tmp_path):
    from jaxstiff.sweep._plan import build_robot
    from jaxstiff.sweep._schema import RobotTable

    d = RobotSpec()
    for name in ("locked", "tcp", "base_link", "tip_link"):
        assert RobotTable.model_fields[name].default == getattr(d, name), name
    robot, spec = build_robot({"robot": {"name": "kuka_lwr4"}}, str(tmp_path))
    assert spec["locked"] == {"lwr_a7": 0.0} and spec["locked_by_default"] is True
    assert robot.n_free == 6


# ---------------------------------------------------------------------- tcp with rotation
def _rpy_numpy(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """URDF's fixed-axis rpy: R = Rz(yaw) @ Ry(pitch) @ Rx(roll), from the elementary rotations."""
    cr, sr, cp, sp, cy, sy = np.cos(roll), np.sin(roll), np.cos(pitch), np.sin(pitch), np.cos(yaw), np.sin(yaw)
    Rx = np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]])
    Ry = np.array([[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]])
    Rz = np.array([[cy, -sy, 0], [sy, cy, 0], [0, 0, 1]])
    return Rz @ Ry @ Rx


@pytest.mark.parametrize("command", ["robot", "shape", "csc"])
def test_tcp_with_rotation_matches_numpy_rpy(command):
    tcp = (0.05, -0.02, 0.1, 0.3, -0.7, 1.2)
    spec = robot_spec_from_args(_parse(command, "--tcp", ",".join(map(str, tcp))))
    assert spec.tcp == tcp
    robot, bare = spec.build(), RobotSpec().build()
    T_tool = np.eye(4)
    T_tool[:3, :3] = _rpy_numpy(*tcp[3:])
    T_tool[:3, 3] = tcp[:3]
    np.testing.assert_allclose(tcp_transform(tcp), T_tool, atol=1e-15)
    q = np.where(robot.free, np.random.default_rng(3).uniform(-1.5, 1.5, robot.n), robot.locked_values)
    np.testing.assert_allclose(np.asarray(robot.fk(q)), np.asarray(bare.fk(q)) @ T_tool, atol=1e-12)
    # three values: a translation only
    spec3 = robot_spec_from_args(_parse(command, "--tcp", "0.05,-0.02,0.1"))
    T3 = np.eye(4)
    T3[:3, 3] = tcp[:3]
    np.testing.assert_allclose(np.asarray(spec3.build().fk(q)), np.asarray(bare.fk(q)) @ T3, atol=1e-12)


@pytest.mark.parametrize("command", ["robot", "shape"])
def test_bad_tcp_names_the_flag(command, capsys, tmp_path):
    argv = [command, "--tcp", "0.1,0.2,0.3,0.4"] + (["--out", str(tmp_path / "x.npz")] if command == "shape" else [])
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith("jaxstiff: error: --tcp") and "x,y,z,roll,pitch,yaw" in err


# ---------------------------------------------------------------------- units in meta
def test_units_and_robot_spec_recorded_in_meta(default_run):
    meta = default_run.meta
    arrays = [k for k in default_run.arrays() if k != "joint_names"]
    assert len(arrays) == 18
    for name in arrays:
        assert name in meta["units"], name
    assert meta["units"]["q"] == "rad" and meta["units"]["alpha_deg"] == "deg" and meta["units"]["kj"] == "Nm/rad"
    su = meta["settings"]["units"]
    assert su["dq"].startswith("rad per waypoint") and su["dk"].startswith("Nm/rad per waypoint")
    assert su["kmin"] == su["kmax"] == "Nm/rad" and su["c"] == "deg"
    assert meta["settings"]["dq"] == pytest.approx(math.radians(2.0))
    rs = meta["robot_spec"]
    assert rs["urdf"] == "kuka_lwr4" and rs["locked"] == {"lwr_a7": 0.0} and rs["locked_by_default"] is True


def test_prismatic_joint_units_say_metres(tmp_path):
    from jaxstiff.shaping._steps import array_units  # the units meta["units"] records

    assert array_units(jaxstiff.Robot.from_urdf("planar_3r"))["q"] == "rad"
    src = open(jaxstiff.robot_path("planar_3r")).read()
    f = tmp_path / "pris.urdf"
    f.write_text(src.replace('name="joint_2" type="revolute"', 'name="joint_2" type="prismatic"', 1))
    units = array_units(jaxstiff.Robot.from_urdf(str(f)))
    assert units["q"] == units["q0"] == "rad (m for prismatic joints)" and "N/m" in units["kj"]


# ---------------------------------------------------------------------- progress
def test_progress_not_on_a_terminal_writes_one_line_at_the_end():
    f = io.StringIO()
    with progress(3, "shape", "waypoints", file=f) as bar:
        for _ in range(3):
            bar.update(1, note="path 0")
        assert f.getvalue() == ""  # nothing while it runs
    lines = f.getvalue().splitlines()
    assert len(lines) == 1 and lines[0].startswith("shape: 3/3 waypoints (path 0) in ")


def test_progress_log_every_and_disabled():
    f = io.StringIO()
    with Progress(4, "sweep", "waypoints", file=f, log_every=0.0, initial=1) as bar:
        bar.update(1.5)
        bar.write("a message")
    out = f.getvalue().splitlines()
    assert out[0].startswith("sweep: 2/4 waypoints") and out[1] == "a message" and out[-1].startswith("sweep: 2/4")
    f = io.StringIO()
    with progress(3, "shape", "waypoints", file=f, enabled=False) as bar:
        bar.update(3)
        bar.write("hidden")
    assert f.getvalue() == "" and bar.n == 3


def test_progress_on_a_terminal_draws_a_bar():
    f = io.StringIO()
    with progress(6, "shape", "waypoints", file=f, terminal=True) as bar:
        for b in range(2):
            for _ in range(3):
                bar.update(1, note=f"path {b}")
    text = f.getvalue()
    assert "\r" in text and "6/6 waypoints" in text and "path 1" in text and text.endswith("\n")


def test_task_dim_is_the_size_of_the_task_translational_rows():
    """settings.shape.task_dim, the one rule for the size of K_T and of a task's position targets,
    against the task's Jacobian rows: the translational ones among them (rows 0-2)."""
    from jaxstiff.settings._shape import TASKS, task_dim
    from jaxstiff.stiffness import task_rows

    for task in TASKS:
        assert task_dim(task) == len([i for i in task_rows(task) if i < 3])
    assert [task_dim(t) for t in ("xy", "xyz", "full")] == [2, 3, 3]


def test_numpy_and_jax_numbers_are_taken_as_their_values():
    """A value read out of an array is a numpy scalar (np.float32, np.int64) or a 0-d array; the
    settings refused them with a false reason ("must be > 1 and finite ..., got np.float32(5.0)")
    where jaxstiff.shape and the solver objects took them. Now each is its Python number; NaN is
    still refused with the field's own message."""
    import jax.numpy as jnp
    import numpy as np

    from jaxstiff.settings import CSCSettings, ShapeSettings

    s = ShapeSettings(ratio=np.float32(5), kmin=np.int64(2), dq=np.array(0.03))
    assert (s.ratio, s.kmin, s.dq) == (5.0, 2, 0.03) and type(s.ratio) is float and type(s.kmin) is int
    assert ShapeSettings(ratio=jnp.asarray(4.0)) == ShapeSettings(ratio=4.0)
    assert CSCSettings(kmin=np.float32(2), beta=np.int64(1)) == CSCSettings(kmin=2.0, beta=1)
    with pytest.raises(ValueError, match=r"shape.ratio must be > 1 and at most 1e\+06 .*got nan"):
        ShapeSettings(ratio=np.float64("nan"))


def test_a_wanted_ratio_has_an_upper_bound_per_path_too():
    """A ratio of 1.7e308 ran to non-finite criteria (status 4 everywhere) with a warning that blamed
    the path's units; 1e16 gave 'unreachable' waypoints. At most MAX_RATIO (1e6) now, also per path."""
    from jaxstiff.settings._shape import MAX_RATIO, ratio_per_path

    assert ratio_per_path(MAX_RATIO, 1) == MAX_RATIO
    with pytest.raises(ValueError, match="for every path, got 1000000000.0 for path 1"):
        ratio_per_path([5.0, 1e9], 2)
    with pytest.raises(ValueError, match="at most 1e\\+06"):
        ratio_per_path(1.7e308, 1)
