"""The Python API under misuse (an adversarial run of 2026-12-07): arguments that changed a run
without a word or failed deep inside with an AttributeError now fail up front with a ValueError
or TypeError naming the argument. No case here runs a solver: each stops at input checking
(the one that would solve is stopped by its own error first)."""

from __future__ import annotations

import os

import numpy as np
import pytest

import jaxstiff
from jaxstiff.results import summary, verify
from jaxstiff.settings import CSCSettings, ShapeSettings


@pytest.fixture(scope="module")
def lwr():
    return jaxstiff.Robot.from_urdf("kuka_lwr4", locked={"lwr_a7": 0.0})


@pytest.fixture(scope="module")
def pts():
    return np.asarray(jaxstiff.default_path().points)[:5]


# ------------------------------------------------------------------ values taken for something else
@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        # "no" read as True: the opposite of what was asked
        (dict(first_rate_limit="no"), r"first_rate_limit must be True or False, got 'no'"),
        # counts cut to an integer: another run than asked
        (dict(first_starts=2.5), r"first_starts must be an integer, got 2.5"),
        (dict(solver="pgd", starts=2.5), r"starts must be an integer, got 2.5"),
        (dict(kmin="5"), r"kmin must be a number, got '5'"),
        # task 'xy' leaves z free: every waypoint of a spatial arm ended "unreachable" after the solve
        (dict(task="xy"), r"task 'xy' is for planar arms.*'kuka_lwr4' can.*use task 'xyz'"),
        # two CMS targets: cms_mean_axis was dropped but recorded in meta
        (dict(cms_volume=1e9, cms_mean_axis=500.0), r"give one CMS target: cms_mean_axis, cms_volume or cms_major"),
    ],
    ids=["bool-string", "first-starts-float", "starts-float", "number-string", "xy-on-lwr", "two-cms-targets"],
)
def test_shape_refuses_what_it_would_have_changed(lwr, pts, kwargs, match) -> None:
    with pytest.raises(ValueError, match=match):
        jaxstiff.shape(lwr, pts, "f2", 5.0, **kwargs)


def test_shape_refuses_a_string_ratio_and_a_complex_path(lwr, pts) -> None:
    with pytest.raises(ValueError, match=r"ratio must be a number, got '5'"):
        jaxstiff.shape(lwr, pts, "f2", "5")
    with pytest.raises(ValueError, match=r"points are complex numbers"):
        jaxstiff.shape(lwr, pts + 0.05j, "f2", 5.0)
    with pytest.raises(ValueError, match=r"directions are complex numbers"):
        jaxstiff.Path(pts, np.ones_like(pts) + 1j)


def test_starts_given_twice_is_refused(lwr, pts) -> None:
    with pytest.raises(TypeError, match=r"starts given twice: 5 in the solver object and starts=3"):
        jaxstiff.shape(lwr, pts, "f2", 5.0, solver=jaxstiff.solvers.PGD(starts=5), starts=3)


def test_a_criterion_that_is_nan_where_the_stiffness_is_plain_is_refused(lwr, pts) -> None:
    import jax.numpy as jnp

    with pytest.raises(ValueError, match=r"returned nan at K = diag\(3000.0, 2000.0, 1000.0\) N/m"):
        jaxstiff.shape(lwr, pts, lambda K, d, r: jnp.nan * jnp.sum(K), 5.0)


def test_progress_must_be_callable(lwr, pts) -> None:
    with pytest.raises(TypeError, match=r"progress must be a function progress\(b, p\)"):
        jaxstiff.shape(lwr, pts, "f2", 5.0, progress=5)


def test_settings_objects_check_types() -> None:
    with pytest.raises(ValueError, match=r"shape.first_rate_limit must be True or False"):
        ShapeSettings(first_rate_limit="no")
    with pytest.raises(ValueError, match=r"shape.first_starts must be an integer, got 2.5"):
        ShapeSettings(first_starts=2.5)
    with pytest.raises(ValueError, match=r"csc.newton must be an integer"):
        CSCSettings(newton=1.5)
    assert ShapeSettings(first_starts=4.0).first_starts == 4.0  # a whole float is a count
    assert ShapeSettings(first_rate_limit=np.bool_(True)).first_rate_limit


@pytest.mark.parametrize("make", ["line", "circle", "default"])
def test_a_path_generator_refuses_a_fractional_count(make) -> None:
    call = {
        "line": lambda n: jaxstiff.paths.line((0, 0, 0), (1, 0, 0), n),
        "circle": lambda n: jaxstiff.paths.circle((0, 0, 0), 1.0, n),
        "default": lambda n: jaxstiff.paths.default_path(n),
    }[make]
    with pytest.raises(ValueError, match=r"must be a whole number, got 2.5"):
        call(2.5)
    with pytest.raises(TypeError, match=r"must be an integer, got '5'"):
        call("5")
    assert call(5.0).P == 5


# ------------------------------------------------------------------ csc
def test_csc_refuses_a_string_beta_and_remat() -> None:
    arm = jaxstiff.Robot.from_urdf("planar_3r")
    q0 = np.deg2rad([75.0, -74.74, -76.30])
    hold = np.broadcast_to(np.asarray(arm.fk(q0))[:2, 3], (5, 2))
    K = np.array([[2500.0, 866.0], [866.0, 1500.0]])
    with pytest.raises(TypeError, match=r"remat must be True or False, got 'no'"):
        jaxstiff.csc_rollout(arm, hold, K, q0, 0.002, step="constant", remat="no")
    with pytest.raises(TypeError, match=r"beta must be a number or an array"):
        jaxstiff.csc_rollout(arm, hold, K, q0, "0.002", step="constant")
    from jaxstiff.csc import csc_rollout_segments

    with pytest.raises(TypeError, match=r"progress must be a function"):
        csc_rollout_segments(arm, hold, K, q0, 0.002, segment_steps=2, step="constant", progress=5)


# ------------------------------------------------------------------ robots, files, results
def test_a_tcp_offset_beyond_float64_lengths_is_refused() -> None:
    with pytest.raises(ValueError, match=r"tcp offset \(0, 0, 1e\+200\): beyond 1e\+150 m"):
        jaxstiff.Robot.from_urdf("kuka_lwr4", tcp=(0, 0, 1e200))


def test_save_refuses_a_folder_and_an_empty_name(tmp_path) -> None:
    from jaxstiff.results._npz import atomic_save_npz

    folder = tmp_path / "out"
    folder.mkdir()
    for bad, match in ((str(folder), "is a folder"), (str(folder) + os.sep, "is a folder"), ("", "name is empty")):
        with pytest.raises(ValueError, match=match):
            atomic_save_npz(bad, {"a": np.zeros(2)})
    assert sorted(os.listdir(tmp_path)) == ["out"] and not os.listdir(folder)  # nothing written
    assert atomic_save_npz(str(folder / "r"), {"a": np.zeros(2)}) == str(folder / "r.npz")


def test_wrong_types_name_the_argument(tmp_path) -> None:
    with pytest.raises(TypeError, match=r"verify: res must be a ShapeResult or a result file's path, got NoneType"):
        verify(None)  # type: ignore[arg-type]
    with pytest.raises(TypeError, match=r"summary: res must be a ShapeResult"):
        summary(42)  # type: ignore[arg-type]
    with pytest.raises(TypeError, match=r"robot_path: name must be a str"):
        jaxstiff.robot_path(None)  # type: ignore[arg-type]
    with pytest.raises(TypeError, match=r"Path.stack takes Path objects; item 0 is a ndarray"):
        jaxstiff.Path.stack([np.zeros((3, 3)), np.zeros((3, 3))])  # type: ignore[list-item]
    with pytest.raises(TypeError, match=r"Registered.opts must be a mapping"):
        jaxstiff.solvers.Registered("pgd", [1, 2])  # type: ignore[arg-type]


def test_a_q0_outside_a_prismatic_joints_limits_is_given_in_metres():
    """shape()'s q0 check said "rad" for every joint; a prismatic joint's value is a length."""
    from helpers import DATA_DIR

    robot = jaxstiff.Robot.from_urdf(os.path.join(DATA_DIR, "branched_tree.urdf"), tip_link="tool")
    j2 = robot.joint_names.index("j2")
    assert bool(robot.prismatic[j2])
    q = np.zeros(robot.n)
    q[j2] = 0.9
    p = jaxstiff.Path(np.array([[0.3, 0.0, 0.2], [0.3, 0.01, 0.2]]))
    with pytest.raises(ValueError, match=rf"q0\[{j2}\] = 0\.9 m for joint 'j2' is outside its limits"):
        jaxstiff.shape(robot, p, "f2", 3.0, task="xyz", q0=q)


def test_a_path_file_name_is_read_as_the_command_reads_it(tmp_path):
    """`jaxstiff.shape("kuka_lwr4", "path.csv")`, the likeliest slip, gave "could not convert string to
    float: 'path.csv'". A file name (or a list of them) is now read with Path.from_csv; a bad
    array says what a path may be."""
    import numpy as np

    import jaxstiff

    p = jaxstiff.default_path()
    f = tmp_path / "two.csv"
    jaxstiff.Path(p.points[:2], p.directions[:2]).to_csv(f)
    from jaxstiff.shaping._inputs import robot_and_path

    _, _, one = robot_and_path("kuka_lwr4", str(f))
    assert one.points.shape == (1, 2, 3) and np.allclose(one.points[0], p.points[:2])
    _, _, two = robot_and_path("kuka_lwr4", [f, str(f)])
    assert two.points.shape == (2, 2, 3)
    with pytest.raises(FileNotFoundError, match="missing.csv"):
        robot_and_path("kuka_lwr4", str(tmp_path / "missing.csv"))
    with pytest.raises(ValueError, match="path must be a jaxstiff.Path, a path file's name"):
        robot_and_path("kuka_lwr4", [[1.0, 2.0], [3.0]])


def test_kinematics_name_q_and_robot_where_jax_would_have_spoken():
    """`jaxstiff.fk(robot, "abc")`, the arguments swapped, `None` and a ragged list reached JAX's or
    numpy's internal errors ("Error interpreting argument ... as an abstract array"); a JAX array,
    traced or not, still passes."""
    import jax
    import jax.numpy as jnp

    import jaxstiff

    robot = jaxstiff.Robot.from_urdf("planar_3r")
    with pytest.raises(TypeError, match=r"fk: q must be joint values, an array of numbers of shape \(\.\.\., 3\)"):
        jaxstiff.fk(robot, "abc")
    with pytest.raises(TypeError, match="robot must be a jaxstiff.Robot, got ArrayImpl \\(the arguments swapped"):
        jaxstiff.fk(jnp.zeros(3), robot)
    with pytest.raises(TypeError, match="jacobian: q must be joint values"):
        jaxstiff.jacobian(robot, None)
    with pytest.raises(ValueError, match="q must be joint values, numbers of shape .*rows of different lengths"):
        robot.fk([[0.0] * 3, [0.0] * 2])
    assert jax.jit(lambda q: jaxstiff.fk(robot, q))(jnp.zeros(3)).shape == (4, 4)
    assert jaxstiff.fk(robot, [0.0, 0.0, 0.0]).shape == (4, 4)


def test_position_and_jacobian_takes_a_list_of_rows_and_names_a_bad_one():
    """`rows=[0, 1]` raised JAX's "Non-hashable static arguments are not supported"; `rows=2` "'int'
    object is not iterable"."""
    import jax.numpy as jnp

    import jaxstiff

    robot = jaxstiff.Robot.from_urdf("planar_3r")
    _, J = jaxstiff.position_and_jacobian(robot, jnp.zeros(3), [0, 1])
    _, J2 = jaxstiff.position_and_jacobian(robot, jnp.zeros(3), (0, 1))
    assert J.shape == (2, 3) and bool(jnp.all(J == J2))
    with pytest.raises(ValueError, match="rows must be a non-empty tuple of Jacobian row indices in 0..5, got 2"):
        jaxstiff.position_and_jacobian(robot, jnp.zeros(3), 2)


def test_start_states_that_are_not_numbers_are_named():
    """`shape(..., kj0="abc")` and `q0="abc"` said only "could not convert string to float"."""
    import jaxstiff

    with pytest.raises(ValueError, match=r"kj0 must be numbers \(Nm/rad\), got 'abc'"):
        jaxstiff.shape("kuka_lwr4", kj0="abc")
    with pytest.raises(ValueError, match=r"q0 must be numbers \(rad; m for prismatic joints\), got 'abc'"):
        jaxstiff.shape("kuka_lwr4", q0="abc")


def test_not_numbers_is_one_error_caught_as_type_or_value_error():
    """Text where numbers go was a TypeError from `fk`, the csc inputs and the criteria's ratio
    check, and a ValueError from `shape`'s start states and `Robot.check_q`: a user's `except`
    caught one entry point's and not another's. Every such check raises one class now, a subclass
    of both."""
    import jax.numpy as jnp

    import jaxstiff

    robot = jaxstiff.Robot.from_urdf("planar_3r")
    calls = {
        "fk": lambda: jaxstiff.fk(robot, "abc"),
        "check_q text": lambda: robot.check_q(["a", "b", "c"]),
        "check_q None": lambda: robot.check_q(None),
        "shape q0": lambda: jaxstiff.shape("kuka_lwr4", q0="abc"),
        "shape kj0": lambda: jaxstiff.shape("kuka_lwr4", kj0=["a"] * 7),
        "f2 ratio": lambda: jaxstiff.f2(jnp.eye(3), jnp.array([1.0, 0.0, 0.0]), "five"),
    }
    kinds = set()
    for name, call in calls.items():
        with pytest.raises(TypeError) as info:
            call()
        assert isinstance(info.value, ValueError), name
        assert "abc" in str(info.value) or "number" in str(info.value), (name, str(info.value))
        kinds.add(type(info.value))
    assert len(kinds) == 1, kinds


def test_a_stiffness_range_beyond_float64_is_refused():
    """`--kmin 1e-300 --kmax 1e-290` ran, stored inf in cms and kj_scaled (and ratios no reader could
    reproduce), and every reader then refused the file: the range is refused up front, named."""
    import jaxstiff
    from jaxstiff.settings import ShapeSettings

    with pytest.raises(ValueError, match=r"shape.kmin \(Nm/rad\) must lie within \[1e-100, 1e\+100\].*got 1e-300"):
        jaxstiff.shape("kuka_lwr4", kmin=1e-300, kmax=1e-290)
    with pytest.raises(ValueError, match=r"shape.kmax .*got 1e\+300"):
        ShapeSettings(kmax=1e300)
    assert ShapeSettings(kmin=1e-100, kmax=1e100).kmax == 1e100


def test_inputs_that_reached_numpy_or_os_are_named(tmp_path):
    """Found by a bad-input audit: a ragged list of points gave numpy's "inhomogeneous shape" from
    inside numpy, a string "could not convert string to float", `Robot.from_urdf(3)` "expected str,
    bytes or os.PathLike object", `fk(robot, [0, 0, 0])` "must have a floating dtype, got int32"
    (while `robot.fk([0, 0, 0])` took it), a list of paths of different lengths numpy's text, and
    `save("x.csv")` wrote x.csv.npz without a word."""
    import jaxstiff

    with pytest.raises(ValueError, match=r"path: points must be numbers .* rows of different lengths"):
        jaxstiff.Path([[0.4, 0.2, 0.0], [0.5, 0.2]])
    with pytest.raises(TypeError, match=r"got '0.4,0.2,0'; a path file is read with jaxstiff.Path.from_csv"):
        jaxstiff.Path("0.4,0.2,0")
    for bad in (3, None):
        with pytest.raises(TypeError, match="a URDF must be given as a file name or a shipped robot's name"):
            jaxstiff.Robot.from_urdf(bad)
    robot = jaxstiff.Robot.from_urdf("planar_3r")
    np.testing.assert_array_equal(np.asarray(jaxstiff.fk(robot, [0, 0, 0])), np.asarray(robot.fk([0.0, 0.0, 0.0])))
    pts = np.array([[0.4, 0.2, 0.0], [0.45, 0.25, 0.0], [0.5, 0.2, 0.0]])
    with pytest.raises(ValueError, match=r"a list of 2 paths of different lengths \(3, 2 waypoints\)"):
        jaxstiff.shape("planar_3r", [pts, pts[:2]], task="xy")
    res = jaxstiff.shape("planar_3r", pts, task="xy")
    with pytest.raises(ValueError, match=r"x.csv': a result file is written as .npz.*x.npz' or '.*x.csv.npz'"):
        res.save(tmp_path / "x.csv")
    assert os.listdir(tmp_path) == []
    assert res.save(tmp_path / "x").endswith("x.npz")


def test_an_empty_urdf_is_called_empty(tmp_path):
    """`<robot name="x"></robot>` was reported as "the joints form a loop; no root link"."""
    import jaxstiff

    f = tmp_path / "empty.urdf"
    f.write_text('<robot name="x"></robot>')
    with pytest.raises(ValueError, match=r"empty.urdf: the URDF has no <link>"):
        jaxstiff.Robot.from_urdf(f)


def test_fk_of_a_list_holding_a_traced_value():
    """`jax.jit(lambda a: fk(robot, [a, 0, 0]))` raised TracerArrayConversionError from the float32
    check, which turned the list into a numpy array. Checked against the closed form of the planar
    3R (links of 1 m): x = 3 cos a at q = (a, 0, 0), dx/da = -3 sin a."""
    import jax

    import jaxstiff

    robot = jaxstiff.Robot.from_urdf("planar_3r")
    a = 0.1
    x = jax.jit(lambda t: jaxstiff.fk(robot, [t, 0.0, 0.0])[0, 3])(a)
    g = jax.grad(lambda t: jaxstiff.fk(robot, [t, 0.0, 0.0])[0, 3])(a)
    assert abs(float(x) - 3 * np.cos(a)) < 1e-6 and abs(float(g) + 3 * np.sin(a)) < 1e-6
