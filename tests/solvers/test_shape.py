"""shape(): results verified from the result file alone with an independent FK (tests/helpers.numpy_fk),
a finite-difference Jacobian and a numpy recomputation of K_T, alpha, rho, f1/f2 and CMS; derivatives of
the waypoint problem against finite differences and against the numpy baseline; bad input; status codes."""

import hashlib
import json
import math
import re
import warnings
from typing import Any

import jax
import numpy as np
import pytest
from helpers import assert_close, numpy_fk, one_value_joint_urdf

import jaxstiff
from jaxstiff import paths
from jaxstiff.results import _files as R
from jaxstiff.results._target import MissedTargetWarning
from jaxstiff.solvers._problem import WaypointProblem, compiled

LOCK = {"lwr_a7": 0.0}


def short_default(k=6):
    """The first k waypoints of the shipped default path (its analytic directions)."""
    p = jaxstiff.default_path()
    return jaxstiff.Path(p.points[:k], p.directions[:k], name="default-head")


# ----------------------------------------------------------------------------- independent checks
def _vee(W):
    return np.array([W[2, 1] - W[1, 2], W[0, 2] - W[2, 0], W[1, 0] - W[0, 1]]) / 2


def fd_geometric_jacobian(robot, q, h=1e-6):
    """6 x n Jacobian from central differences of the numpy FK: v = dp/dq, w = vee(dR R^T)."""
    J = np.zeros((6, robot.n))
    R0 = numpy_fk(robot, q)[:3, :3]
    for i in range(robot.n):
        e = np.zeros(robot.n)
        e[i] = h
        Tp, Tm = numpy_fk(robot, q + e), numpy_fk(robot, q - e)
        J[:3, i] = (Tp[:3, 3] - Tm[:3, 3]) / (2 * h)
        J[3:, i] = _vee((Tp[:3, :3] - Tm[:3, :3]) / (2 * h) @ R0.T)
    return J


def numpy_KT(robot, q, kj, task):
    J = fd_geometric_jacobian(robot, q)
    rows = {"full": slice(0, 6), "xyz": slice(0, 3), "xy": slice(0, 2)}[task]
    Js = J[rows]
    K = np.linalg.inv(Js @ np.diag(1.0 / kj) @ Js.T)
    return K[:3, :3] if task == "full" else K


def alpha_rho(K, d):
    w, V = np.linalg.eigh(K)
    v1 = V[:, -1]
    d = d[: K.shape[0]] / np.linalg.norm(d[: K.shape[0]])
    sin = np.linalg.norm(np.cross(v1, d)) if len(d) == 3 else abs(v1[0] * d[1] - v1[1] * d[0])
    return math.degrees(math.atan2(sin, abs(float(v1 @ d)))), w[-1] / w[-2]


def verify_file(file, alpha_tol=1e-5):
    """Everything a result file claims, re-checked from the file and the URDF alone. Returns the data."""
    with np.load(file, allow_pickle=False) as z:
        data = {k: z[k] for k in z.files}
    meta = json.loads(str(data["meta"]))
    B, P, n = data["q"].shape
    # the contract's keys and shapes (DESIGN.md)
    for k, shp in {
        "joint_names": (n,),
        "kj": (B, P, n),
        "cms": (B, P),
        "target": (B, P, 3),
        "direction": (B, P, 3),
        "position": (B, P, 3),
        "alpha_deg": (B, P),
        "ratio": (B, P),
        "criterion": (B, P),
        "status": (B, P),
        "kj_scaled": (B, P, n),
    }.items():
        assert data[k].shape == shp, k
    rm = meta["robot"]
    assert hashlib.sha256(open(rm["urdf"], "rb").read()).hexdigest() == rm["sha256"]
    robot = jaxstiff.Robot.from_urdf(
        rm["urdf"], base_link=rm["base_link"], tip_link=rm["tip_link"], locked=rm["locked"], tcp=np.asarray(rm["tcp"])
    )
    assert list(data["joint_names"]) == list(robot.joint_names)
    lim = meta["limits"]
    dq, dk = np.asarray(lim["dq"]), np.asarray(lim["dk"])
    kmin, kmax = lim["kmin"], lim["kmax"]
    r, c, task, crit = meta["ratio"], meta["c"], meta["task"], meta["criterion"]
    usable_codes = (0, 1, 2)
    for b in range(B):
        q_ref, k_ref, at_start = data["q0"][b], data["kj0"][b], True
        for p in range(P):
            q, kj, st = data["q"][b, p], data["kj"][b, p], int(data["status"][b, p])
            # bounds: joint limits, stiffness range, locked joints -- exact within 1e-9
            assert np.all(q >= robot.lower - 1e-9) and np.all(q <= robot.upper + 1e-9)
            # a rigid locked joint (the default, SPEC 1) has kj = +inf and no stiffness bounds/rate limit
            rigid = ~robot.free if meta["settings"].get("locked_joints", "spring") == "rigid" else robot.free & False
            assert np.all(kj[rigid] == np.inf) and np.all(k_ref[rigid] == np.inf)
            ks, ks_ref = kj[~rigid], k_ref[~rigid]
            assert np.all(ks >= kmin - 1e-9) and np.all(ks <= kmax + 1e-9)
            for name, v in rm["locked"].items():
                assert q[list(robot.joint_names).index(name)] == v
            # rate limits against the reference state (last usable waypoint, or the start state)
            if lim["first_rate_limit"] or not at_start:
                assert np.all(np.abs(q - q_ref) <= dq + 1e-9), (b, p)
                assert np.all(np.abs(ks - ks_ref) <= dk[~rigid] + 1e-9), (b, p)
            pos = numpy_fk(robot, q)[:3, 3]
            assert_close(data["position"][b, p], pos, atol=1e-12, what="reported position")
            if st in usable_codes:
                assert np.linalg.norm(pos - data["target"][b, p]) <= 1e-6, (b, p)
                q_ref, k_ref, at_start = q, kj, False
            K = numpy_KT(robot, q, kj, task)
            a, rho = alpha_rho(K, data["direction"][b, p])
            assert abs(a - data["alpha_deg"][b, p]) < alpha_tol + 1e-6 * a, (b, p, a, data["alpha_deg"][b, p])
            assert abs(rho - data["ratio"][b, p]) < 1e-6 * rho
            f = (a + c) / (min(rho, r) / r) if crit == "f1" else (1 + a) * (1 + abs(r - rho))
            assert abs(f - data["criterion"][b, p]) < 1e-5 * f
            # CMS: k^m det(K) = target volume (or k lambda1 = target major), kj_scaled = k kj
            cm = meta["cms"]
            w = np.linalg.eigvalsh(K)
            k_ref_cms = (
                cm["target_major"] / w[-1] if cm["target_major"] else (cm["target_volume"] / np.prod(w)) ** (1 / len(w))
            )
            assert abs(data["cms"][b, p] - k_ref_cms) < 1e-6 * k_ref_cms
            assert_close(data["kj_scaled"][b, p][~rigid], data["cms"][b, p] * ks, rtol=1e-14)
    return data, meta, robot


# ----------------------------------------------------------------------------- fixtures
@pytest.fixture(scope="module")
def lwr():
    return jaxstiff.Robot.from_urdf("kuka_lwr4", locked=LOCK)


@pytest.fixture(scope="module")
def f2_file(lwr, tmp_path_factory):
    res = jaxstiff.shape(lwr, short_default(6), "f2", 5.0, first_starts=3)
    f = tmp_path_factory.mktemp("shape") / "f2.npz"
    res.save(f)
    return f, res


# ----------------------------------------------------------------------------- tests
def test_f2_result_verified_from_the_file_alone(f2_file):
    data, meta, _ = verify_file(f2_file[0])
    assert np.all(R.is_usable(data["status"])) and np.sum(data["status"] == R.SOLVED) >= 5
    # seed quality (Fig. 5): aligned with the tangent, exactly 5:1
    assert np.all(data["alpha_deg"] < 1.0)
    assert np.all(np.abs(data["ratio"] - 5.0) / 5.0 < 0.02)
    assert meta["solver"] == "slsqp" and meta["criterion"] == "f2" and meta["task"] == "full"
    assert meta["robot"]["locked"] == LOCK and meta["limits"]["first_rate_limit"] is False


def test_meta_records_every_input_and_default(f2_file):
    meta = f2_file[1].meta
    for key in (
        "robot",
        "criterion",
        "ratio",
        "c",
        "task",
        "solver",
        "options",
        "limits",
        "q0_source",
        "kj0_source",
        "cms",
        "path",
        "defaults",
        "versions",
        "status_codes",
        "first_starts",
        "pos_tol",
    ):
        assert key in meta, key
    assert math.isclose(meta["limits"]["dq"][0], math.radians(2.0))
    assert meta["limits"]["dk"] == [5.0] * 7 and meta["limits"]["kmin"] == 1.0 and meta["limits"]["kmax"] == 100.0
    assert meta["robot"]["tcp"] == np.eye(4).tolist()
    assert {"jax", "numpy", "scipy", "jaxstiff"} <= set(meta["versions"])
    # solver_code is SLSQP's exit mode here, and status 0 (solved) needs mode 0 (converged)
    res = f2_file[1]
    assert meta["solver_code_meaning"].startswith("SLSQP exit mode")
    assert np.all(res.solver_code[res.status == R.SOLVED] == 0) and np.all(
        (res.solver_code >= -1) & (res.solver_code <= 9)
    )


def test_load_round_trip(f2_file):
    f, res = f2_file
    back = jaxstiff.ShapeResult.load(f)
    for k, v in res.arrays().items():
        np.testing.assert_array_equal(np.asarray(getattr(back, k)), np.asarray(v), err_msg=k)
    assert back.meta["ratio"] == 5.0


def test_rate_limits_bind_when_asked(lwr):
    """first_rate_limit=True with a given start: every joint within dq of q0 at the first waypoint."""
    path = short_default(3)
    from jaxstiff.ik import ik_position

    with jax.enable_x64(True):
        q0, _ = ik_position(lwr, path.points[0])
    res = jaxstiff.shape(lwr, path, "f2", 5.0, q0=q0, kj0=30.0, first_rate_limit=True, dq=math.radians(1.0), dk=2.0)
    assert np.all(np.abs(res.q[0, 0] - q0) <= math.radians(1.0) + 1e-12)
    free = lwr.free  # lwr_a7 is rigid (the default): kj = inf, no rate limit
    assert np.all(res.kj[0, :, ~free] == np.inf)
    assert np.all(np.abs(res.kj[0, 0, free] - 30.0) <= 2.0 + 1e-12)
    assert np.all(np.abs(np.diff(res.kj[0][:, free], axis=0)) <= 2.0 + 1e-12)
    assert np.all(R.is_usable(res.status))


@pytest.mark.slow
def test_f1_short_run_and_verification(lwr, tmp_path):
    res = jaxstiff.shape(lwr, short_default(3), "f1", 5.0, first_starts=3)
    res.save(tmp_path / "f1.npz")
    data, meta, _ = verify_file(tmp_path / "f1.npz")
    assert meta["criterion"] == "f1"
    assert np.all(data["alpha_deg"] < 1.0) and np.all(data["ratio"] >= 4.9)


def test_unreachable_waypoint_gets_status_and_the_run_goes_on(lwr, tmp_path):
    pts = short_default(4).points.copy()
    # waypoint 1 mirrored through the base's axis: the arm reaches it (lwr_a1 turned by 180 deg), but not
    # within 20 deg of waypoint 1's posture (a point 2 m away is now refused before the solve: test_reach.py)
    pts[2] = [-pts[1, 0], -pts[1, 1], pts[1, 2]]
    path = jaxstiff.Path(pts, np.tile([0.0, -1.0, 0.0], (4, 1)))
    res = jaxstiff.shape(lwr, path, "f2", 5.0, first_starts=2, dq=math.radians(20), dk=20.0)
    assert res.status[0, 2] == R.UNREACHABLE
    assert R.is_usable(res.status[0, [0, 1, 3]]).all()
    res.save(tmp_path / "u.npz")
    verify_file(tmp_path / "u.npz")  # rate limits of waypoint 3 refer to waypoint 1
    assert R.verify(res)["max_rate_violation"] <= 1e-9


def test_slsqp_fd_baseline_agrees(lwr, f2_file, tmp_path):
    """The seed's own method (numpy + finite differences) solves the same problem to the same quality."""
    res_jax = f2_file[1]
    path = short_default(3)
    res = jaxstiff.shape(
        lwr, path, "f2", 5.0, solver="slsqp-fd", q0=res_jax.q[0, 0], kj0=res_jax.kj[0, 0], first_rate_limit=True
    )
    res.save(tmp_path / "fd.npz")
    data, meta, _ = verify_file(tmp_path / "fd.npz")
    assert meta["solver"] == "slsqp-fd"
    assert np.all(R.is_usable(data["status"]))
    assert np.all(data["alpha_deg"] < 1.0) and np.all(np.abs(data["ratio"] - 5) < 0.1)


def test_problem_derivatives_match_finite_differences_and_numpy(lwr):
    """fused(): gradient vs central differences of the numpy objective of the baseline (an independent
    numpy implementation), constraint Jacobian vs differences of the independent FK."""
    from jaxstiff.solvers._slsqp_fd import numpy_objective

    rng = np.random.default_rng(3)
    for crit, mode in ((jaxstiff.f1, "rigid"), (jaxstiff.f2, "rigid"), (jaxstiff.f2, "spring")):
        prob = WaypointProblem(lwr, "full", crit, locked_joints=mode)
        nk, nx = prob.n_spring, prob.nx  # 6 + 6 (lwr_a7 rigid) or 6 + 7 (lwr_a7 keeps its spring)
        obj_np = numpy_objective(prob)
        with jax.enable_x64(True):
            fused = compiled(prob)
            for _ in range(3):
                x = np.r_[rng.uniform(-1.5, 1.5, 6), rng.uniform(5, 90, nk)]
                params = prob.params([0.6, 0.1, 0.3], rng.normal(size=3), 5.0, 0.01)
                f, g, cval, A = prob.unpack(np.asarray(fused(x, params)))
                assert math.isclose(f, obj_np(x, params), rel_tol=1e-9)
                h = np.r_[np.full(6, 1e-6), np.full(nk, 1e-5)]
                g_fd = np.array(
                    [
                        (obj_np(x + h[i] * np.eye(nx)[i], params) - obj_np(x - h[i] * np.eye(nx)[i], params))
                        / (2 * h[i])
                        for i in range(nx)
                    ]
                )
                # FD error scales with the gradient's size (rigid lwr_a7: 6 joints carry all 6 task rows)
                atol = max(1e-6, 1e-5 * float(np.abs(g_fd).max()))
                assert_close(g, g_fd, rtol=1e-5, atol=atol, what=f"{crit.__name__} {mode} gradient")
                q = np.r_[x[:6], 0.0]
                assert_close(cval, numpy_fk(lwr, q)[:3, 3] - params[:3], atol=1e-14)
                A_fd = np.zeros((3, nx))
                for i in range(6):
                    e = np.zeros(7)
                    e[i] = 1e-6
                    A_fd[:, i] = (numpy_fk(lwr, q + e)[:3, 3] - numpy_fk(lwr, q - e)[:3, 3]) / 2e-6
                assert_close(A, A_fd, atol=1e-9, what="constraint Jacobian")


def test_no_recompilation_across_waypoints_and_runs(lwr):
    prob = WaypointProblem(lwr, "full", jaxstiff.f2)
    with jax.enable_x64(True):
        fn = compiled(prob)
        jaxstiff.shape(lwr, short_default(3), "f2", 5.0, first_starts=1)
        n1 = fn._cache_size()
        jaxstiff.shape(lwr, short_default(4), "f2", 4.0, first_starts=1)
        assert fn._cache_size() == n1 == 1
    assert compiled(WaypointProblem(jaxstiff.Robot.from_urdf("kuka_lwr4", locked=LOCK), "full", jaxstiff.f2)) is fn


def test_objective_finite_at_singular_posture(lwr):
    """q = 0: the LWR stands straight up (singular). Values and gradients stay finite."""
    prob = WaypointProblem(lwr, "full", jaxstiff.f2)
    with jax.enable_x64(True):
        out = np.asarray(
            compiled(prob)(
                np.r_[np.zeros(6), np.full(prob.n_spring, 50.0)], prob.params(np.zeros(3), [1, 0, 0], 5, 0.01)
            )
        )
    assert np.all(np.isfinite(out))


def test_planar_task_xy(tmp_path):
    """Planar 3R, task xy: the 2x2 ellipse, position matched in x and y."""
    robot = jaxstiff.Robot.from_urdf("planar_3r")
    path = paths.arc([0.0, 0.0, 0.0], 1.5, 20.0, 40.0, n=4)  # at 2 m the limits allow 22 deg at best
    res = jaxstiff.shape(robot, path, "f2", 3.0, task="xy", first_starts=4, dq=math.radians(10), dk=20.0)
    res.save(tmp_path / "xy.npz")
    data, meta, _ = verify_file(tmp_path / "xy.npz")
    assert meta["task"] == "xy" and np.all(R.is_usable(data["status"]))
    assert np.all(data["alpha_deg"] < 1.0) and np.all(np.abs(data["ratio"] - 3) < 0.06)


def test_task_xy_warns_when_the_path_is_off_the_tcp_plane():
    """Task xy matches x and y only: a path at z = 0.3 m for a chain moving in z = 0 ends every
    waypoint 0.3 m off (status unreachable, by the 3-D distance). That is now said in a warning
    naming the target's and the TCP's z (it came back silently as an unreachable path)."""
    robot = jaxstiff.Robot.from_urdf("planar_3r")
    pts = np.array([[1.5, 0.5 + 0.02 * i, 0.3] for i in range(3)])
    with pytest.warns(
        UserWarning, match=r"task 'xy' matches x and y only, and 3 of 3 waypoints .*target z = 0\.3 m, TCP z = 0 m"
    ):
        res = jaxstiff.shape(robot, paths.Path(pts), "f2", 3.0, task="xy", first_starts=2)
    assert np.all(res.status == R.UNREACHABLE) and np.allclose(res.pos_error, 0.3)
    # the same path in the plane: solved, no warning
    pts[:, 2] = 0.0
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        res = jaxstiff.shape(robot, paths.Path(pts), "f2", 3.0, task="xy", first_starts=2)
    assert np.all(res.status == R.SOLVED)


@pytest.mark.slow
def test_continuous_joint_runs_without_numpy_warnings(tmp_path):
    """A continuous joint has limits (-inf, inf): mid-range and limit margins must not compute
    inf - inf (numpy RuntimeWarning, and NaN if it were used)."""
    import warnings

    src = open(jaxstiff.robot_path("planar_3r")).read()
    f = tmp_path / "cont.urdf"
    f.write_text(src.replace('name="joint_1" type="revolute"', 'name="joint_1" type="continuous"', 1))
    robot = jaxstiff.Robot.from_urdf(str(f))
    assert robot.lower[0] == -math.inf and robot.upper[0] == math.inf
    path = paths.arc([0.0, 0.0, 0.0], 1.5, 20.0, 40.0, n=3)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        # the greedy solver may end a later waypoint on its rate-limit box (10 deg, 20 Nm/rad per
        # waypoint here) and say so; that is not what this test is about
        warnings.filterwarnings("ignore", category=MissedTargetWarning)
        # the rollout starts 1 m from its held point on purpose (the step from far off is part of the
        # test) and says so; a numpy RuntimeWarning is what this test is about
        warnings.filterwarnings("ignore", message="the start posture's TCP lies")
        res = jaxstiff.shape(robot, path, "f2", 3.0, task="xy", first_starts=2, dq=math.radians(10), dk=20.0)
        roll = jaxstiff.csc_rollout(
            robot,
            np.tile([1.2, 1.0], (20, 1)),
            np.diag([3000.0, 1000.0]),
            np.radians([75.0, -74.74, -76.30]),
            1e-3,
            step="constant",
        )
    assert np.all(R.is_usable(res.status)) and np.all(np.isfinite(res.criterion))
    assert res.alpha_deg[0, 0] < 1.0  # the first waypoint has no rate limit
    assert np.all(np.isfinite(np.asarray(roll.q))) and np.all(np.isfinite(np.asarray(roll.u)))


@pytest.mark.parametrize(
    "task, match", [("full", r"only 3 joint.*use task 'xy'"), ("xyz", r"row\(s\) vz .* zero at every posture")]
)
def test_task_the_robot_cannot_control_is_refused(tmp_path, capsys, task, match):
    """Planar 3R with task full/xyz: the z stiffness would be the 1e-12 regularisation's (ratios
    ~1e10 written as if solved). Refused in the library and, with exit 2 and no file, in the CLI."""
    robot = jaxstiff.Robot.from_urdf("planar_3r")
    path = paths.arc([0.0, 0.0, 0.0], 1.5, 20.0, 40.0, n=2)
    with pytest.raises(ValueError, match=match):
        jaxstiff.shape(robot, path, "f2", 3.0, task=task)
    from jaxstiff.cli import main

    out = tmp_path / "r.npz"
    assert main(["shape", "--robot", "planar_3r", "--task", task, "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert re.search(match, err) and "Traceback" not in err and not out.exists()


@pytest.mark.slow
def test_full_task_with_locked_joints_keeps_their_springs(tmp_path):
    """Two of the LWR's joints locked (five free, fewer than the six rows of task 'full'). Kept as
    springs (``locked_joints="spring"``) the stiffness has seven springs (SPEC section 1), so the
    task is defined and solved; the file verifies from the URDF alone (numpy K_T with all seven
    columns). Rigid (the default) only five joints give: refused before any work (it ran and
    stored a K_T of ~1e15 N/m)."""
    robot = jaxstiff.Robot.from_urdf("kuka_lwr4", locked={"lwr_a3": 0.0, "lwr_a7": 0.2})
    q = np.where(robot.free, np.deg2rad([20.0, 40.0, 0.0, -70.0, 25.0, 50.0, 0.0]), robot.locked_values)
    x0 = numpy_fk(robot, q)[:3, 3]
    path = jaxstiff.Path(x0 + np.array([[0.0, 0.0, 0.0], [0.01, 0.0, 0.0]]), np.array([[1.0, 0.0, 0.0]] * 2))
    with pytest.raises(ValueError, match=r"only 5 joint\(s\) have a spring"):
        jaxstiff.shape(robot, path, "f2", 3.0, task="full", q0=q, first_starts=2)
    # dq 10 deg: the second waypoint (1 cm on) is reachable from whichever optimal posture the first
    # waypoint picks; with the default 2 deg it depended on that pick, which moves with the CPU's
    # rounding (an AMD EPYC took a rescued posture from which the next centimetre needs more than
    # 2 deg per joint: status 3). This test is about the springs, not the greedy chain
    res = jaxstiff.shape(
        robot, path, "f2", 3.0, task="full", q0=q, first_starts=2, locked_joints="spring", dq=np.radians(10.0)
    )
    f = tmp_path / "locked_full.npz"
    res.save(f)
    data, meta, _ = verify_file(f)
    assert meta["task"] == "full" and np.all(R.is_usable(data["status"]))


@pytest.mark.parametrize(
    "kwargs, match",
    [
        (dict(ratio=1.0), r"ratio must be > 1 and at most 1e\+06"),
        (dict(ratio=float("inf")), r"ratio must be > 1 and at most 1e\+06"),
        (
            dict(ratio=1.7e308),
            r"ratio must be > 1 and at most 1e\+06",
        ),  # ran to non-finite criteria, blamed on the path
        (dict(kmax=float("inf")), "need finite 0 < kmin < kmax"),
        (dict(ratio=float("nan")), r"ratio must be > 1 and at most 1e\+06"),
        (dict(kmin=0.0), "0 < kmin < kmax"),
        (dict(kmin=50.0, kmax=50.0), "0 < kmin < kmax"),
        (dict(dq=-0.1), r"dq .* must be >= 0"),
        (dict(dk=-1.0), r"dk .* must be >= 0"),
        (dict(q0=np.zeros(3)), "q0 must have 7 values"),
        (dict(q0=np.r_[np.zeros(6), 0.0] + [3.5, 0, 0, 0, 0, 0, 0]), r"q0\[0\] = 3.5 .* 'lwr_a1' is outside"),
        (dict(q0=np.r_[np.full(6, 0.3), 0.2]), "locked at 0"),
        (dict(q0=np.r_[0.1, np.nan, np.zeros(5)]), r"q0 contains NaN or Inf: joint 'lwr_a2' has nan"),
        (dict(kj0=500.0), r"kj0\[0\] = 500 .* outside"),
        (dict(solver="nope"), "unknown solver 'nope'"),
        (dict(criterion="f9"), "unknown criterion"),
        (dict(task="xz"), "unknown task"),
        (dict(options={"iters": 5}), r"unknown option\(s\) for solver 'slsqp': 'iters' \(did you mean 'maxiter'\?\)"),
        (dict(options={"maxiter": 0}), "SLSQP option 'maxiter' must be an integer >= 1"),
        (dict(solver="hybrid", options={"driver": "fast"}), "SLSQP option 'driver' must be 'lean' or 'scipy'"),
        (dict(solver="trajectory", options={"warm": "nope"}), "option warm must be"),
        (dict(starts=4), "single-start"),
        (dict(cms_volume=-1.0), "cms_volume must be a finite number > 0"),
        (dict(cms_major=float("inf")), "cms_major must be a finite number > 0"),
        (dict(first_starts=0), "first_starts must be >= 1"),
    ],
)
def test_bad_input_is_a_clear_value_error(lwr, kwargs, match):
    kw: dict[str, Any] = dict(criterion="f2", ratio=5.0)
    kw.update(kwargs)
    crit, ratio = kw.pop("criterion"), kw.pop("ratio")
    with pytest.raises(ValueError, match=match):
        jaxstiff.shape(lwr, short_default(2), crit, ratio, **kw)


@pytest.mark.slow
def test_verify_can_fail(f2_file):
    """The library's own verifier flags a tampered result (bounds, rates, reported values)."""
    res = f2_file[1]
    import dataclasses

    q = res.q.copy()
    q[0, 3, 1] += 0.2  # breaks the rate limit and the position
    bad = dataclasses.replace(res, q=q)
    v = R.verify(bad)
    assert v["max_rate_violation"] > 0.1 and v["max_pos_error"] > 1e-3 and v["max_position_mismatch"] > 1e-3
    good = R.verify(res)
    assert good["max_rate_violation"] <= 1e-9 and good["max_pos_error"] <= 1e-9 and good["max_bound_violation"] <= 1e-9
    assert good["max_alpha_mismatch"] < 1e-6 and good["max_criterion_mismatch"] < 1e-8


def test_lean_driver_equals_scipy_minimize(lwr, f2_file):
    """The lean SLSQP loop runs scipy's own routine: the same iterates as scipy.optimize.minimize."""
    from jaxstiff.solvers._problem import Limits, clip_to_box
    from jaxstiff.solvers._slsqp import make_slsqp_solver

    res = f2_file[1]
    prob = WaypointProblem(lwr, "full", jaxstiff.f2)
    lim = Limits(np.full(7, math.radians(2)), np.full(7, 5.0), 1.0, 100.0, True)
    with jax.enable_x64(True):
        lean, ref = make_slsqp_solver(prob), make_slsqp_solver(prob, {"driver": "scipy"})
        assert lean.driver == "lean" and ref.driver == "scipy.optimize.minimize"
        for p in (1, 2):
            lb, ub = lim.box(prob, res.q[0, p - 1], res.kj[0, p - 1], True)
            x0 = clip_to_box(np.asarray(prob.x_of(res.q[0, p - 1], res.kj[0, p - 1])), lb, ub)
            prm = prob.params(res.target[0, p], res.direction[0, p], 5.0, 0.01)
            a, b = lean(x0, lb, ub, prm), ref(x0, lb, ub, prm)
            np.testing.assert_array_equal(a.x, b.x)
            assert (a.nit, a.code, a.nfev) == (b.nit, b.code, b.nfev)


def test_lean_driver_stops_a_stalled_infeasible_solve_and_otherwise_runs_as_scipy():
    """An equality constraint no point of the box satisfies (sin(3 x0) + x1^2 = 3, at most 2 in
    [-1, 1]^2) with a kink in the objective, from 41 starts: scipy's SLSQP takes line-search
    steps of nothing there, for a few or for hundreds of iterations, and ends (mode 8 or 4, or the
    iteration limit) after them or after it gets moving again. Which starts stall, and for how
    long, depends on the CPU's floating point (an Intel Xeon and an AMD EPYC differ). The lean
    driver ends a solve whose iterates have stopped moving for STALL_ITERS iterations while the
    constraint is violated (STALLED, never later than scipy's own exit, at the point scipy ends
    at) and runs every other solve exactly as ``scipy.optimize.minimize`` does; some starts stall
    (6 of 41 on the EPYC, saving 749 iterations). On a problem it solves, it runs
    to scipy's own exit."""
    from scipy.optimize import Bounds, minimize

    from jaxstiff.solvers._slsqp import STALL_ITERS, STALLED, _slsqp_lean

    def stuck(x):
        return (
            abs(x[0] - 0.5) + x[1] ** 2,
            np.array([np.sign(x[0] - 0.5), 2 * x[1]]),
            np.array([np.sin(3 * x[0]) + x[1] ** 2 - 3.0]),
            np.array([[3 * np.cos(3 * x[0]), 2 * x[1]]]),
        )

    def solvable(x):
        return (x @ x, 2 * x, np.array([x[0] + 2 * x[1] - 1.0]), np.array([[1.0, 2.0]]))

    def scipy_ref(fgca, x0):
        return minimize(
            lambda y: fgca(y)[:2],
            x0,
            jac=True,
            bounds=Bounds(lb, ub),  # pyright: ignore[reportArgumentType] (stub: float; arrays are documented)
            constraints=[{"type": "eq", "fun": lambda y: fgca(y)[2], "jac": lambda y: fgca(y)[3]}],
            method="SLSQP",
            options={"maxiter": 500, "ftol": 1e-10},
        )

    lb, ub = -np.ones(2), np.ones(2)
    stalled = saved = 0
    # (0.1, 0.2) first: the Xeon's solve from there stood still from its 7th iteration to its 194th
    starts = np.vstack([[0.1, 0.2], np.random.default_rng(0).uniform(-1.0, 1.0, size=(40, 2))])
    for x0 in starts:
        x, mode, nit = _slsqp_lean(stuck, x0, lb, ub, 1, 500, 1e-10)
        ref = scipy_ref(stuck, x0)
        assert ref.status != 0 and abs(stuck(x)[2][0]) > 0.5  # infeasible everywhere
        if mode == STALLED:
            stalled, saved = stalled + 1, saved + ref.nit - nit
            assert STALL_ITERS < nit <= ref.nit
            np.testing.assert_allclose(x, ref.x, rtol=0, atol=1e-9)  # where scipy ends anyway
        else:
            assert (mode, nit) == (ref.status, ref.nit)
            np.testing.assert_allclose(x, ref.x, rtol=0, atol=1e-12)
    assert stalled >= 1 and saved >= 50  # iterations scipy would have spent at those points
    x0 = np.array([0.1, 0.2])
    x, mode, nit = _slsqp_lean(solvable, x0, lb, ub, 1, 500, 1e-10)
    ref = scipy_ref(solvable, x0)
    assert (mode, nit) == (ref.status, ref.nit) == (0, ref.nit)
    np.testing.assert_allclose(x, ref.x, atol=1e-9)


def test_newton_projection_stops_cleanly_when_no_joint_moves_the_tcp():
    """J = 0 (no free joint moves the TCP) used to solve with a 1e-312 damping: inf * 0 = NaN
    (a numpy warning) and a NaN step. The projection must stop and return a finite point in its box."""
    import warnings

    from jaxstiff.solvers._problem import newton_project

    robot = jaxstiff.Robot.from_urdf("planar_3r")
    prob = WaypointProblem(robot, "xy", jaxstiff.f2)
    x = np.r_[0.1, 0.2, 0.3, 10.0, 10.0, 10.0]
    lb, ub = np.r_[-1.0, -1.0, -1.0, 1.0, 1.0, 1.0], np.r_[1.0, 1.0, 1.0, 100.0, 100.0, 100.0]
    dead = lambda q: (np.zeros(3), np.zeros((6, 3)))  # noqa: E731
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        out = newton_project(prob, x, np.array([1.0, 1.0, 0.0]), lb, ub, pos_and_jac=dead)
    assert np.array_equal(out, x)


def test_task_xy_names_the_path_and_waypoint_that_leaves_the_plane():
    planar = jaxstiff.Robot.from_urdf("planar_3r")
    pts = np.array([[1.5, 0.0, 0.0], [1.5, 0.2, 0.0], [1.5, 0.4, 0.01]])  # climbs at its end
    path = jaxstiff.Path(pts, name="climb")
    with pytest.raises(
        ValueError,
        match=r"task 'xy' needs directions in the xy plane \(dz = 0\); path 0 \(climb\) "
        r"has dz = 0\.\d+ at waypoint 1 \(its z changes along the path",
    ):
        jaxstiff.shape(planar, path, "f2", 5.0, task="xy")


def test_task_xy_on_a_spatial_arm_is_refused_before_any_solve(lwr):
    """Task 'xy' constrains the TCP's x and y only; on the LWR, whose joints move the TCP along z,
    every waypoint came back 'unreachable' (0.3-0.6 m off in z) after the whole solve."""
    with pytest.raises(ValueError, match=r"task 'xy' is for planar arms.*'kuka_lwr4' can.*vz row reaches"):
        jaxstiff.shape(lwr, short_default(3), "f2", 5.0, task="xy")


def test_meta_tcp_is_the_offset_given(tmp_path):
    """meta.robot.tcp is recovered from the URDF's bare tip by a solve; on a chain with rpy origins
    its round-off (0.09999999999999996 for 0.1) is not passed on: the offset reads as given."""
    from jaxstiff.settings._robot import robot_meta

    urdf = tmp_path / "r.urdf"
    urdf.write_text(
        '<robot name="r"><link name="b"/><link name="l1"/><link name="l2"/><link name="t"/>'
        '<joint name="j1" type="revolute"><parent link="b"/><child link="l1"/><origin xyz="0 0 0.1" rpy="0.3 -0.7 1.1"/>'
        '<axis xyz="0 0 1"/><limit lower="-2" upper="2" effort="1" velocity="1"/></joint>'
        '<joint name="j2" type="revolute"><parent link="l1"/><child link="l2"/><origin xyz="0.4 0 0" rpy="0.2 0.5 -0.9"/>'
        '<axis xyz="0 1 0"/><limit lower="-2" upper="2" effort="1" velocity="1"/></joint>'
        '<joint name="f" type="fixed"><parent link="l2"/><child link="t"/><origin xyz="0.3 0.01 0.02" rpy="0.77 -1.23 2.01"/>'
        "</joint></robot>"
    )
    assert robot_meta(jaxstiff.Robot.from_urdf(str(urdf)))["tcp"] == np.eye(4).tolist()
    want = np.eye(4)
    want[:3, 3] = [0.05, -0.02, 0.1]
    assert robot_meta(jaxstiff.Robot.from_urdf(str(urdf), tcp=[0.05, -0.02, 0.1]))["tcp"] == want.tolist()


@pytest.mark.slow
@pytest.mark.parametrize("solver", ["slsqp", "pgd"])
def test_one_waypoint_with_its_direction(solver):
    """A single waypoint is a path when its direction is given (no tangent needed): the ellipsoid
    is shaped there, checked from the posture with the numpy FK and eigen-decomposition (the LWR,
    task full, with SLSQP; the planar 3R, task xy, with the batch solver, whose compilation is
    then short)."""
    if solver == "slsqp":
        robot, task, x, d = (
            jaxstiff.Robot.from_urdf("kuka_lwr4", locked={"lwr_a7": 0.0}),
            "full",
            [0.6, 0.0, 0.3],
            [0.0, 0.6, 0.8],
        )
    else:
        robot, task, x, d = jaxstiff.Robot.from_urdf("planar_3r"), "xy", [1.5, 0.5, 0.0], [0.6, 0.8, 0.0]
    d = np.asarray(d)
    res = jaxstiff.shape(robot, jaxstiff.Path(np.array([x]), d[None]), "f2", 4.0, task=task, solver=solver)
    assert res.status.shape == (1, 1) and R.is_usable(res.status).all()
    q, kj = res.q[0, 0], res.kj[0, 0]
    assert np.linalg.norm(numpy_fk(robot, q)[:3, 3] - x) < 1e-9
    J = np.asarray(robot.jacobian(q))
    if task == "full":  # K_T is the top-left 3x3 of the 6x6 K_C (S0-4)
        K = np.linalg.inv(J @ np.diag(1.0 / kj) @ J.T)[:3, :3]
    else:
        K = np.linalg.inv(J[:2] @ np.diag(1.0 / kj) @ J[:2].T)
    w, V = np.linalg.eigh(K)
    assert abs(w[-1] / w[-2] - 4.0) < 0.08
    assert math.degrees(math.acos(min(1.0, abs(V[:, -1] @ d[: len(w)])))) < 1.0


@pytest.mark.parametrize("solver", ["slsqp", pytest.param("slsqp-fd", marks=pytest.mark.slow)])
def test_slsqp_result_does_not_depend_on_the_stiffness_units(solver):
    """f2 sees only the stiffnesses' ratios, so the stiffness range [1e4, 1e6] with every stiffness
    input times 1e4 is the same problem as [1, 100]: the same postures, the stiffnesses times 1e4.
    With a fixed SLSQP stiffness unit of 100 the scaled problem stalled at ratio 2.7 instead of 5
    (found by an independent check); the unit is now the range's top (meta records it)."""
    robot = jaxstiff.Robot.from_urdf("planar_3r")
    pts = np.c_[np.linspace(1.50, 1.58, 9), np.full(9, 0.5), np.zeros(9)]
    path = jaxstiff.Path(pts)
    kw = dict(task="xy", solver=solver)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", MissedTargetWarning)
        a = jaxstiff.shape(robot, path, "f2", 5.0, **kw)
        b = jaxstiff.shape(robot, path, "f2", 5.0, kmin=1e4, kmax=1e6, dk=5e4, **kw)
    assert a.meta["options"]["kj_scale"] == 100.0 and b.meta["options"]["kj_scale"] == 1e6
    # SLSQP's own accuracy (ftol 1e-8; finite differences: the seed's method, about 1 %) sets the
    # tolerances: the two runs round differently, and by CPU (an AMD EPYC without AVX-512 stopped
    # one scaled waypoint at ratio 5.00054, f2 1.00054, where another CPU gave 5 to 1e-5); the
    # defect this guards against ended at 2.7
    tol, atol_deg = (1e-3, 0.01) if solver == "slsqp" else (0.02, 1.0)
    np.testing.assert_allclose(a.ratio, 5.0, rtol=tol)
    np.testing.assert_allclose(b.ratio, 5.0, rtol=tol)
    assert np.max(a.alpha_deg) < atol_deg and np.max(b.alpha_deg) < atol_deg
    # the postures need not agree: f2's minimum set is a manifold and the greedy chain may drift
    # along it differently at the rounding level (4e-3 rad apart after 9 waypoints here)
    assert np.all((b.kj >= 1e4) & (b.kj <= 1e6))


@pytest.mark.slow  # a 12 s solver run; the fast lane keeps tests/solvers/test_first_waypoint.py
def test_first_waypoint_rescue_finds_the_minimum_the_usual_starts_miss(tmp_path, monkeypatch):
    """The planar 3R with 3 m links on a line at (4.5..4.74, 1.5) (the CSV of an independent check):
    from some start postures greedy SLSQP's first waypoint ends at a local minimum (f2 17-80000,
    status 0) while f2 = 1 is reachable. Where every start ends above the criterion's least value,
    greedy SLSQP solves the first waypoint again from postures and stiffnesses drawn over the whole
    ranges. (The rescue leaves a first waypoint at the minimum alone: the README job's file was
    bit-identical with and without it.)

    The case used to rest on the eight usual starts of one path, which all ended at the local
    minimum on one CPU and not on another (their SLSQP iterates round differently). Now each start
    posture is given alone (``q0``, ``first_starts=1``), from several postures: those that end at a
    local minimum without the rescue must end no higher with it, and at least one must reach f2 = 1
    at every waypoint."""
    from jaxstiff.solvers import _greedy as greedy

    with open(jaxstiff.robot_path("planar_3r")) as fh:
        text = fh.read().replace('<origin xyz="1 0 0"', '<origin xyz="3 0 0"')
    urdf = tmp_path / "planar_3r_3m.urdf"
    urdf.write_text(text)
    robot = jaxstiff.Robot.from_urdf(str(urdf))
    xs = [float(f"{3.0 * v:.6f}") for v in np.linspace(1.50, 1.58, 9)]  # as the CSV held them
    path = jaxstiff.Path(np.c_[xs, np.full(9, 1.5), np.zeros(9)])
    stuck = rescued = 0
    for q0 in ([-1.5, -2.0, 0.0], [-1.5, -2.0, 1.5], [-1.5, -1.0, 0.0]):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", MissedTargetWarning)
            with monkeypatch.context() as mp:
                mp.setattr(greedy, "maybe_off_target", lambda *a: False)  # the given start alone
                usual = jaxstiff.shape(robot, path, "f2", 5.0, task="xy", q0=q0, first_starts=1)
            res = jaxstiff.shape(robot, path, "f2", 5.0, task="xy", q0=q0, first_starts=1)
        assert np.all(R.is_usable(res.status))
        if usual.criterion[0, 0] <= 10.0:
            continue
        stuck += 1
        assert res.criterion[0, 0] <= usual.criterion[0, 0]
        rescued += bool(np.max(res.criterion) < 1.001 and np.max(res.alpha_deg) < 0.5)
    assert stuck >= 1, "no start posture ends at the local minimum any more: pick others"
    assert rescued >= 1


def test_a_joint_with_a_one_value_range_leaves_the_tie_break_finite(tmp_path):
    """A URDF joint limited to one value (lower == upper): the first waypoint's tie-break (room to
    the joint limits) divided by its zero span, printed numpy's 'invalid value encountered in
    divide' and compared NaN margins (the first candidate won whatever its room)."""
    import warnings

    urdf = one_value_joint_urdf(tmp_path)
    robot = jaxstiff.Robot.from_urdf(str(urdf))
    q = np.array([0.3, 0.5, 0.6, 0.4])
    start = np.asarray(robot.fk(q))[:3, 3]
    pts = start + np.linspace(0.0, 0.03, 4)[:, None] * np.array([1.0, 0.5, 0.0])
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)  # numpy's divide warning is a RuntimeWarning
        warnings.simplefilter("ignore", UserWarning)  # the robot's own notes (empty range, target)
        res = jaxstiff.shape(robot, pts, "f2", 3.0, task="xy", q0=q)
    assert np.all(res.status[0] <= 2) and np.allclose(res.q[0, :, 1], 0.5)
