"""CSC input checks found by a tester: a K_xd that is no stiffness (zero, underflowing, negative),
the size limit of K_xd before anything that overflows (eigenvalues, a float32 cast), non-numeric
arguments named by parameter, and kmin = kmax (refused as by a csc sweep). API and command line;
jit/grad through csc_rollout stays unchecked (traced values)."""

from __future__ import annotations

import warnings

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxstiff
from jaxstiff.cli import main as cli_main
from jaxstiff.csc import csc_rollout_segments

LWR = jaxstiff.Robot.from_urdf("kuka_lwr4")
Q0 = np.deg2rad([0.0, 30.0, 0.0, -60.0, 0.0, 60.0, 0.0])
Q0_DEG = "0,30,0,-60,0,60,0"
K3 = np.diag([3000.0, 1000.0, 2000.0])


def _path(T: int = 4) -> np.ndarray:
    """A short reachable (T, 3) path from the start TCP, 1 cm per step along y."""
    p0 = np.asarray(LWR.fk(Q0))[:3, 3]
    return p0 + np.outer(np.arange(T) * 0.01, [0.0, 1.0, 0.0])


@pytest.fixture(scope="module")
def path_csv(tmp_path_factory):
    f = tmp_path_factory.mktemp("csc_checks") / "xyz.csv"
    np.savetxt(f, _path(), delimiter=",", header="x,y,z", comments="")
    return f


def _cli(path_csv, tmp_path, capsys, *extra):
    out = tmp_path / "c.npz"
    rc = cli_main(["csc", "--path", str(path_csv), "--q0-deg", Q0_DEG, *extra, "--out", str(out)])
    err = capsys.readouterr().err
    return rc, err, out


def _one_line_error(rc, err, out):
    assert rc == 2, err
    assert err.startswith("jaxstiff: error:") and "Traceback" not in err, err
    assert len(err.strip().splitlines()) == 1, err
    assert not out.exists()


# --- 1. a K_xd that is no stiffness ---------------------------------------------------------------


@pytest.mark.parametrize(
    "K,why",
    [
        (np.zeros((3, 3)), "eigenvalues 0 to 0"),
        (np.eye(3) * 1e-200, "every eigenvalue is below 1e-06 N/m: no stiffness at all"),
        (np.diag([3000.0, -1000.0, 2000.0]), "eigenvalues -1000 to 3000"),
    ],
)
@pytest.mark.parametrize("objective", ["offdiag", "frobenius"])
def test_kxd_that_is_no_stiffness_is_refused(K, why, objective):
    with pytest.raises(ValueError, match="K_xd must be symmetric positive semi-definite") as e:
        jaxstiff.csc_rollout(LWR, _path(), K, Q0, objective=objective)
    assert why in str(e.value)
    with pytest.raises(ValueError, match="K_xd must be symmetric positive semi-definite"):
        csc_rollout_segments(LWR, _path(), K, Q0, segment_steps=2, objective=objective)


def test_zero_stiffness_along_an_axis_is_a_wish_and_runs():
    """Positive semi-definite is taken, as before (commit 03c41b1): no stiffness asked for along one
    axis, stiff along the others. Only a K_xd with no stiffness at all, or a negative one, is refused."""
    r = jaxstiff.csc_rollout(LWR, _path(), np.diag([3000.0, 1000.0, 0.0]), Q0)
    assert np.all(np.isfinite(np.asarray(r.u)))


def test_kxd_varying_along_the_path_names_the_bad_matrix():
    K = np.broadcast_to(K3, (4, 3, 3)).copy()
    K[2] = 0.0
    with pytest.raises(ValueError, match=r"K_xd must be symmetric positive semi-definite.*K_xd\[2\]"):
        jaxstiff.csc_rollout(LWR, _path(), K, Q0)


@pytest.mark.parametrize("kxd", ["0,0,0", "1e-200,1e-200,1e-200", "3000,-1000,2000"])
def test_cli_kxd_that_is_no_stiffness_is_refused(path_csv, tmp_path, capsys, kxd):
    for extra in ([], ["--objective", "frobenius"]):
        rc, err, out = _cli(path_csv, tmp_path, capsys, "--kxd", kxd, *extra)
        _one_line_error(rc, err, out)
        assert f"--kxd {kxd!r}" in err and "K_xd must be symmetric positive semi-definite" in err, err


def test_a_good_kxd_still_runs_and_grad_through_csc_rollout_works():
    r = jaxstiff.csc_rollout(LWR, _path(), K3, Q0)
    assert np.all(np.isfinite(np.asarray(r.u)))
    arm = jaxstiff.Robot.from_urdf("planar_3r")  # README "CSC with a gradient"
    q0 = jnp.deg2rad(jnp.array([75.0, -74.74, -76.30]))
    hold = jnp.broadcast_to(arm.fk(q0)[:2, 3], (20, 2))
    K_xd = jnp.array([[2500.0, 866.0], [866.0, 1500.0]])
    g = jax.grad(lambda b: jaxstiff.csc_rollout(arm, hold, K_xd, q0, b, step="constant").u.mean())(2e-3)
    assert np.isfinite(float(g)) and float(g) != 0.0
    # traced K_xd (its checks are skipped), even a zero one as in test_gradients_finite_at_a_zero_desired_stiffness
    gk = jax.grad(lambda K: jaxstiff.csc_rollout(arm, hold, K, q0, 2e-3, step="constant").u.mean())(K_xd)
    assert np.all(np.isfinite(np.asarray(gk)))
    jax.jit(lambda K: jaxstiff.csc_rollout(arm, hold, K, q0, 2e-3, step="constant").u)(jnp.zeros((2, 2)))


# --- 2. the size limit speaks before anything that overflows ----------------------------------


@pytest.mark.parametrize("scale", [1e308, 1e200])
def test_huge_kxd_gets_the_size_limit(scale):
    for q0 in (Q0, Q0.astype(np.float32)):  # float32: the cast made it inf ("contains NaN or Inf")
        with pytest.raises(ValueError, match=r"K_xd has an entry of 1e\+(308|200) N/m; at most"):
            jaxstiff.csc_rollout(LWR, _path(), np.eye(3) * scale, q0)


def test_kxd_beyond_float32_limit_is_named_for_float32():
    with pytest.raises(ValueError, match=r"K_xd has an entry of 1e\+20 N/m; at most 1e\+15.*float32"):
        jaxstiff.csc_rollout(LWR, _path(), np.eye(3) * 1e20, Q0.astype(np.float32))


@pytest.mark.parametrize("kxd", ["1e308,1e308,1e308", "1e200,1e200,1e200"])
def test_cli_huge_kxd_gets_the_size_limit(path_csv, tmp_path, capsys, kxd):
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)  # no "overflow encountered in add"
        rc, err, out = _cli(path_csv, tmp_path, capsys, "--kxd", kxd)
    _one_line_error(rc, err, out)
    assert "K_xd has an entry of" in err and "at most 1e+100" in err and "overflow encountered" not in err, err


# --- 3. non-numeric arguments are named -------------------------------------------------------


@pytest.mark.parametrize(
    "which,value,exc,match",
    [
        ("q0", "abc", TypeError, r"q0 must be .*\(\.\.\., 7\).*got 'abc'"),
        ("q0", None, TypeError, r"q0 must be .*\(\.\.\., 7\).*got None"),
        ("q0", [[1.0, 2.0], [3.0]], ValueError, r"q0 must be .*got a ragged"),
        ("q0", object(), TypeError, r"q0 must be .*got an object"),
        ("K_xd", "abc", TypeError, r"K_xd must be .*\(m, m\).*got 'abc'"),
        ("K_xd", None, TypeError, r"K_xd must be .*got None"),
        ("K_xd", [[1.0, 2.0], [3.0]], ValueError, r"K_xd must be .*got a ragged"),
        ("K_xd", np.array([["a", "b"], ["c", "d"]]), TypeError, r"K_xd must be .*got an array of dtype <U1"),
        ("path", "abc", TypeError, r"path must be .*\(\.\.\., T, 2 or 3\).*got 'abc'"),
        ("path", None, TypeError, r"path must be .*got None"),
        ("path", [[0.5, 0.0, 0.5], [0.5]], ValueError, r"path must be .*got a ragged"),
        ("path", np.array([["a", "b", "c"]]), TypeError, r"path must be .*got an array of dtype <U1"),
        ("beta", [1.0, [2.0]], ValueError, r"beta must be .*got a ragged"),
        ("beta", object(), TypeError, r"beta must be .*got an object"),
    ],
)
def test_non_numeric_arguments_are_named(which, value, exc, match):
    args = {"path": _path(), "K_xd": K3, "q0": Q0, "beta": 1.0}
    args[which] = value
    call = (LWR, args["path"], args["K_xd"], args["q0"], args["beta"])
    with pytest.raises(exc, match=match):
        jaxstiff.csc_rollout(*call)
    with pytest.raises(exc, match=match):
        csc_rollout_segments(*call, segment_steps=2)


# --- 4. kmin = kmax: refused, as a csc sweep refuses it ---------------------------------------


def test_kmin_equal_kmax_is_refused():
    with pytest.raises(ValueError, match=r"kmax \(10\) must be above kmin \(10\)"):
        jaxstiff.csc_rollout(LWR, _path(), K3, Q0, kmin=10.0, kmax=10.0)
    with pytest.raises(ValueError, match=r"csc.kmax \(10\) must be above csc.kmin \(10\)"):
        jaxstiff.settings.CSCSettings(kmin=10.0, kmax=10.0)  # the settings object refuses it too
    jaxstiff.csc_rollout(LWR, _path(), K3, Q0, kmin=10.0, kmax=10.5)  # a range, however narrow, runs


def test_cli_kmin_equal_kmax_is_refused(path_csv, tmp_path, capsys):
    rc, err, out = _cli(path_csv, tmp_path, capsys, "--kxd", "3000,1000,2000", "--kmin", "10", "--kmax", "10")
    _one_line_error(rc, err, out)
    assert "--kmax (10) must be above --kmin (10)" in err, err


def test_csc_sweep_refuses_kmin_equal_kmax_too():
    from jaxstiff.sweep._axes import cross_checks

    axes = {"kmin": [10.0], "kmax": [10.0], "q0_seed": [0], "q0": ["seed"], "task": ["xyz"]}
    with pytest.raises(Exception, match="kmin = 10 is not below kmax = 10"):
        cross_checks("csc", axes, [], LWR)


def test_a_start_far_from_the_path_is_warned():
    """A start posture 1 m from a held point: the first step jumped joints by 43 deg, every step's
    status said 'ok', and nothing was said (found by a newcomer trial). Started on the path, no
    such warning; the distance named is the TCP's own (numpy FK, independent of the rollout)."""
    import warnings

    import jaxstiff
    from jaxstiff.csc import CSCWarning

    robot = jaxstiff.Robot.from_urdf("planar_3r")
    q0 = np.deg2rad([75.0, -74.74, -76.30])
    tcp = np.asarray(robot.fk(q0))[:2, 3]
    K = np.diag([3000.0, 1000.0])
    far = np.tile([0.5, 0.5], (5, 1))
    with pytest.warns(CSCWarning, match=r"start posture's TCP lies (\S+) m from the path's first target") as w:
        jaxstiff.csc_rollout(robot, far, K, q0, beta=2e-3, step="constant")
    msg = next(str(x.message) for x in w if "start posture" in str(x.message))
    gap = float(msg.split("lies ")[1].split(" m")[0])
    assert abs(gap - np.linalg.norm(tcp - [0.5, 0.5])) < 1e-2 * gap
    with warnings.catch_warnings(record=True) as rec:
        warnings.simplefilter("always")
        jaxstiff.csc_rollout(robot, np.tile(tcp, (5, 1)), K, q0, beta=2e-3, step="constant")
    assert not [x for x in rec if "start posture" in str(x.message)]


def test_cli_q0_ik_starts_on_the_path(tmp_path, capsys):
    """`--q0 ik`: the command line had no way to start on the path (a newcomer's LWR run started
    0.35 m off it). The stored q0 puts the TCP on the first target (numpy FK, independent of the
    IK), no far-start warning is given, and several paths (one q0 for all) are refused."""
    import jaxstiff
    from jaxstiff.cli import main
    from jaxstiff.model._host import tcp_position

    path = tmp_path / "p.csv"
    jaxstiff.paths.line((0.5, -0.1, 0.4), (0.5, 0.1, 0.4), 6).to_csv(str(path))
    out = tmp_path / "r.npz"
    base = ["csc", "--robot", "kuka_lwr4", "--path", str(path), "--kxd", "3000,1000,2000@30", "--beta", "1"]
    capsys.readouterr()
    assert main(base + ["--q0", "ik", "--out", str(out)]) == 0
    err = capsys.readouterr().err
    assert "start posture's TCP" not in err, err
    with np.load(out) as d:
        q0 = d["q0"]
    robot = jaxstiff.Robot.from_urdf("kuka_lwr4", locked={"lwr_a7": 0.0})
    assert np.linalg.norm(tcp_position(robot, q0[None])[0] - [0.5, -0.1, 0.4]) < 1e-9
    assert main(base + ["--path", str(path), "--q0", "ik", "--out", str(tmp_path / "two.npz")]) == 2
    assert "--q0 ik takes one --path (or --hold), got 2 paths" in capsys.readouterr().err
