"""solver="pgd" (batch engine, issue 5) on the planar 3R arm, task "xy".

Independent references: the numpy FK of tests/helpers.py (positions), the numpy-only file
verification of jaxstiff.results.verify after a save/load round trip (bounds, rate limits,
reported values), and SLSQP on the same problem (quality).
"""

from __future__ import annotations

import numpy as np
import pytest
from helpers import numpy_fk, one_value_joint_urdf
from pgd_cases import OPTS, STARTS

import jaxstiff
from jaxstiff.results import _files as R
from jaxstiff.solvers import _pgd as pgd


@pytest.fixture(scope="module")
def batch3(planar_paths, run_planar):
    path, q0 = planar_paths(3, 5)
    return path, q0, run_planar(path, q0)


def test_meta_records_the_starts_and_options_pgd_ran_with(batch3):
    meta = batch3[2].meta
    assert meta["solver"] == "pgd" and meta["starts"] == STARTS
    assert meta["options"] == {**pgd.DEFAULT_OPTIONS, **OPTS, "starts": STARTS}
    # the IK start postures of the first waypoint are some of pgd's own first-waypoint starts
    opts = {**pgd.DEFAULT_OPTIONS, **OPTS}
    s1 = max(STARTS, opts["starts_first"]) if opts["mode"] == "best" else STARTS
    fs = meta["first_starts"]
    assert f"{min(fs['count'], s1)} of the {s1} first-waypoint starts of pgd" in fs["use"], fs


def test_pgd_batch_feasible_and_verified(batch3, tmp_path, check_planar_file):
    path, q0, res = batch3
    assert res.q.shape == (3, 5, 3) and res.status.shape == (3, 5)
    assert np.all(res.status == R.SOLVED)
    assert np.all(np.isfinite(res.criterion))
    check_planar_file(res, tmp_path)


@pytest.mark.slow
def test_pgd_chunking_does_not_change_results(batch3, run_planar):
    path, q0, res = batch3
    one = run_planar(path, q0, options={**OPTS, "chunk": 3})  # same keys per path index, other chunking
    np.testing.assert_allclose(one.q, res.q, atol=1e-12)
    np.testing.assert_allclose(one.kj, res.kj, atol=1e-12)


def test_pgd_quality_close_to_slsqp(batch3, run_planar):
    path, q0, res = batch3
    ref = run_planar(path, q0, solver="slsqp", options=None)
    ok = R.is_usable(ref.status)
    # where f2's minimum (1, at alpha = 0 and rho = r) is reachable, pgd's LM stage lands on it: as
    # good as SLSQP to 1e-6 (SLSQP itself stops at ftol, ~1e-5 above)
    at_min = ok & (ref.criterion <= 1.0 + 1e-4)
    assert at_min.sum() >= 5
    assert np.all(res.criterion[at_min] <= ref.criterion[at_min] + 1e-6)
    # elsewhere (a path where ratio 3 is out of reach) a coarse budget: within 1.5x of SLSQP's mean
    assert res.criterion[ok].mean() <= ref.criterion[ok].mean() * 1.5


@pytest.mark.slow
@pytest.mark.parametrize("mode", ["rollout", "best"])
def test_both_modes_feasible(tmp_path, mode, planar_paths, run_planar, check_planar_file):
    path, q0 = planar_paths(2, 4, seed=3)
    res = run_planar(path, q0, options={**OPTS, "mode": mode})
    assert np.all(R.is_usable(res.status))
    check_planar_file(res, tmp_path)


def test_unreachable_waypoint_is_flagged_and_skipped(tmp_path, planar_paths, run_planar, check_planar_file):
    path, q0 = planar_paths(1, 4, seed=1)
    pts = path.points.copy()
    pts[0, 2, :2] *= -1.0  # within reach, but half a turn away: outside the rate-limited box
    bad = jaxstiff.Path(pts, path.directions)
    res = run_planar(bad, q0)
    assert res.status[0, 2] == R.UNREACHABLE
    assert np.all(R.is_usable(res.status[0, [0, 1, 3]]))
    check_planar_file(res, tmp_path)  # waypoint 3's rate limits refer to waypoint 1


def test_bad_options_raise(planar_paths, run_planar):
    path, q0 = planar_paths(1, 3)
    with pytest.raises(ValueError, match=r"unknown option\(s\) for solver 'pgd': 'itres' \(did you mean 'iters'\?\)"):
        run_planar(path, q0, options={"itres": 3})
    with pytest.raises(ValueError, match="mode"):
        run_planar(path, q0, options={"mode": "greedy"})
    with pytest.raises(ValueError, match="starts"):
        run_planar(path, q0, starts=0)


def test_list_of_paths_is_the_same_batch(batch3, run_planar):
    path, q0, res = batch3
    again = run_planar([path[b] for b in range(3)], q0)
    np.testing.assert_allclose(again.q, res.q, atol=1e-12)
    assert again.status.shape == (3, 5)


@pytest.mark.slow
@pytest.mark.parametrize("robot_name,task", [("planar_3r", "xy"), ("kuka_lwr4", "full")])
def test_lm_residual_against_numpy_eigen(robot_name, task):
    """The LM stage's residual rows, recomputed in numpy with a full eigen-decomposition: the
    alignment rows vanish exactly when d is an eigenvector of K, and the ratio row is then
    log(rho / r) (f2) or min(log(rho / r), 0) (f1); rho from numpy's eigenvalues."""
    import jax

    from jaxstiff.solvers._problem import WaypointProblem
    from jaxstiff.stiffness import get_criterion

    robot = jaxstiff.Robot.from_urdf(robot_name)
    rng = np.random.default_rng(4)
    with jax.enable_x64(True):
        for kind in ("f1", "f2"):
            ops = pgd.WaypointOps(WaypointProblem(robot, task, get_criterion(kind)))
            for _ in range(3):
                q = rng.uniform(robot.lower * 0.8, robot.upper * 0.8)
                kj = np.exp(rng.uniform(0.0, np.log(100.0), robot.n))
                x = np.r_[q[list(ops.pr.free_idx)], kj]
                K = R.np_translational_stiffness(robot, q, kj, task)
                m = K.shape[0]
                w, V = np.linalg.eigh(K)
                tgt = numpy_fk(robot, q)[:3, 3] + 0.01
                # 1) d along the major axis: d is an eigenvector, alignment rows 0, ratio row log(rho/r)
                # 2) d along a random direction: alignment rows = (K d - (d'Kd) d) / (d'Kd) (trace-free)
                for d, r in ((V[:, -1], 2.0), (rng.normal(size=m), 7.0)):
                    d = d / np.linalg.norm(d)
                    d3 = np.r_[d, np.zeros(3 - m)]
                    e = np.asarray(ops.lm_residual(x, tgt, d3, r, kind, 1.0, 1.0))
                    k = len(ops.rows)
                    np.testing.assert_allclose(e[:k], (numpy_fk(robot, q)[:3, 3] - tgt)[list(ops.rows)], atol=1e-12)
                    Kd = K @ d
                    np.testing.assert_allclose(e[k : k + m], (Kd - (d @ Kd) * d) / (d @ Kd), atol=1e-9)
                    if np.allclose(d, V[:, -1]) or np.allclose(d, -V[:, -1]):
                        rho = w[-1] / w[-2]
                        b = np.log(rho / r) if kind == "f2" else min(np.log(rho / r), 0.0)
                        assert abs(e[-1] - b) < 1e-9, (e[-1], b)


@pytest.mark.parametrize(
    "robot_name,task,locked,mode",
    [
        ("planar_3r", "xy", None, "rigid"),
        ("kuka_lwr4", "full", {"lwr_a7": 0.0}, "rigid"),
        ("kuka_lwr4", "full", {"lwr_a7": 0.0}, "spring"),
        ("kuka_lwr4", "xyz", None, "rigid"),
    ],
)
@pytest.mark.slow
def test_lm_jacobian_closed_form_matches_autodiff(robot_name, task, locked, mode):
    """The LM stage's Jacobian (closed-form kinematic and stiffness derivatives) against forward-mode
    autodiff of the residual through the whole chain, and its residual against :meth:`lm_residual`,
    at random postures and stiffnesses (f1 with the ratio row active and inactive, f2)."""
    import jax

    from jaxstiff.solvers._problem import WaypointProblem
    from jaxstiff.stiffness import get_criterion

    robot = jaxstiff.Robot.from_urdf(robot_name, locked=locked)
    rng = np.random.default_rng(11)
    with jax.enable_x64(True):
        for kind, r in (("f1", 1.5), ("f1", 40.0), ("f2", 5.0)):
            ops = pgd.WaypointOps(WaypointProblem(robot, task, get_criterion(kind), locked_joints=mode))
            for _ in range(4):
                q = rng.uniform(robot.lower * 0.8, robot.upper * 0.8)
                kj = np.exp(rng.uniform(0.0, np.log(100.0), ops.pr.n_spring))  # one per sprung joint
                x = jax.numpy.asarray(np.r_[q[list(ops.pr.free_idx)], kj])
                tgt = jax.numpy.asarray(numpy_fk(robot, q)[:3, 3] + rng.normal(size=3) * 0.01)
                d = jax.numpy.asarray(rng.normal(size=3))
                args = (tgt, d, r, kind, 1e3, 100.0)
                e, jac = ops.lm_residual_and_jacobian(x, *args)
                e_ref = ops.lm_residual(x, *args)
                jac_ref = jax.jacfwd(lambda z, ops=ops, args=args: ops.lm_residual(z, *args))(x)
                assert jac.shape == jac_ref.shape == (e.shape[0], x.shape[0])
                np.testing.assert_allclose(e, e_ref, rtol=1e-9, atol=1e-9)
                # per row, relative to the row's largest entry (the rows differ by orders of magnitude)
                scale = np.abs(np.asarray(jac_ref)).max(axis=1, keepdims=True) + 1e-12
                err = np.abs(np.asarray(jac) - np.asarray(jac_ref)) / scale
                assert err.max() < 1e-9, (kind, r, err.max(), np.unravel_index(err.argmax(), err.shape))


@pytest.mark.slow
def test_unrolled_spd_solve_against_numpy():
    """The unrolled Cholesky solve used in the kernels: numpy's solve on random SPD systems of the
    sizes that occur (1..7), batched by vmap, and finite on an all-zero system."""
    import jax

    rng = np.random.default_rng(5)
    with jax.enable_x64(True):
        for k in range(1, 8):
            M = rng.normal(size=(16, k, k + 2))
            A = M @ np.swapaxes(M, -1, -2) + 1e-3 * np.eye(k)
            b = rng.normal(size=(16, k))
            x = jax.vmap(pgd.spd_solve)(jax.numpy.asarray(A), jax.numpy.asarray(b))
            np.testing.assert_allclose(x, np.linalg.solve(A, b[..., None])[..., 0], rtol=1e-9, atol=1e-12)
        assert np.all(np.isfinite(pgd.spd_solve(jax.numpy.zeros((3, 3)), jax.numpy.zeros(3))))


def test_solver_code_is_the_winning_start_and_meta_says_so(batch3):
    """pgd's solver_code is the index of the start that won (not an SLSQP mode, as a reader of the
    file might think): meta names the meaning, and every usable waypoint's code is a start index."""
    res = batch3[2]
    assert res.meta["solver_code_meaning"].startswith("index of the start that won")
    usable = R.is_usable(res.status)
    assert np.all((res.solver_code[usable] >= 0) & (res.solver_code[usable] < STARTS))


@pytest.mark.parametrize(
    "robot_name,task", [("planar_3r", "xy"), pytest.param("kuka_lwr4", "full", marks=pytest.mark.slow)]
)
def test_lm_stage_never_raises_the_residual_and_stays_in_the_box(robot_name, task):
    """The LM stage itself: zero iterations return the start unchanged; after k iterations the
    residual norm is never above the start's nor above that after k - 1 (a step is kept only if it
    lowers the norm), every iterate lies in the box, and from a start near a minimum point of f2
    (its own residual moved off zero by a perturbation) it brings the residual back near zero."""
    import jax
    import jax.numpy as jnp

    from jaxstiff.solvers._problem import WaypointProblem
    from jaxstiff.solvers._problem.ops import box_scales
    from jaxstiff.stiffness import get_criterion

    robot = jaxstiff.Robot.from_urdf(robot_name)
    rng = np.random.default_rng(21)
    with jax.enable_x64(True):
        ops = pgd.WaypointOps(WaypointProblem(robot, task, get_criterion("f2")))
        q = rng.uniform(robot.lower * 0.6, robot.upper * 0.6)
        kj = np.exp(rng.uniform(np.log(5.0), np.log(80.0), ops.nk))
        x0 = jnp.asarray(np.r_[q[list(ops.pr.free_idx)], kj])
        tgt = jnp.asarray(numpy_fk(robot, q)[:3, 3])
        K = R.np_translational_stiffness(robot, q, kj, task)
        w, V = np.linalg.eigh(K)
        d = jnp.asarray(np.r_[V[:, -1], np.zeros(3 - K.shape[0])])
        r = 0.8 * w[-1] / w[-2]  # the start misses the ratio by 20 %: residual row log(1.25)
        half = np.r_[np.full(ops.nf, 0.3), np.full(ops.nk, 30.0)]
        lb, ub = x0 - half, x0 + half
        s = box_scales(lb, ub, ops.nf, 99.0)
        args = (tgt, d, r, "f2", 1e3, 100.0)

        def norm(x):
            e = np.asarray(ops.lm_residual(x, *args))
            return float(np.sqrt(e @ e))

        lm = jax.jit(lambda x, it: ops.lm(x, lb, ub, *args[:4], it, args[4], args[5], s))
        assert np.array_equal(np.asarray(lm(x0, 0)), np.asarray(x0))
        prev = norm(x0)
        assert prev > 0.2
        for k in range(1, 9):
            xk = np.asarray(lm(x0, k))
            assert np.all(xk >= np.asarray(lb)) and np.all(xk <= np.asarray(ub)), k
            nk = norm(xk)
            assert nk <= prev * (1 + 1e-12), (k, nk, prev)
            prev = nk
        assert norm(lm(x0, 30)) < 1e-6


def test_pick_leaves_out_a_joint_whose_range_is_one_value(tmp_path):
    """pgd's kept start (mode "best"): the room to the limits of a joint limited to [a, a] is 0 / 0;
    it made every start's room 0, so the first tied start won whatever its room on other joints."""
    import jax.numpy as jnp

    from jaxstiff.settings import PGDOptions
    from jaxstiff.solvers._pgd.kernel import PGDKernel
    from jaxstiff.solvers._problem import WaypointProblem

    urdf = one_value_joint_urdf(tmp_path)
    with pytest.warns(UserWarning, match="empty range"):
        robot = jaxstiff.Robot.from_urdf(str(urdf))
    problem = WaypointProblem(robot, "xy", jaxstiff.f2)
    opts = {f: getattr(PGDOptions(), f) for f in PGDOptions.__dataclass_fields__}
    kernel = PGDKernel(problem, {**opts, "mode": "best"}, False)
    k = np.full(problem.n_spring, 10.0)  # the middle of [1, 100] in log scale
    near_limit = problem.x_of(np.array([3.0, 0.5, 0.0, 0.0]), k)  # joint 1 0.14 rad from its limit
    middle = problem.x_of(np.array([0.2, 0.5, 0.1, -0.1]), k)
    x = jnp.asarray(np.stack([near_limit, middle]))
    both = jnp.array([True, True])
    i = kernel.pick(x, jnp.array([1.0, 1.0]), jnp.zeros(2), both, both, jnp.asarray(1.0), jnp.asarray(100.0))
    assert int(i) == 1
