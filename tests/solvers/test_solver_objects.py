"""Solver objects (``jaxstiff.solvers.PGD(...)`` and the others) and ``shape``'s short signature.

Independent references: a run with an object is compared bit for bit with the same run given as a
name and an options dict (the form the command line and sweep files use); the options a stage ran
with are read back from the result's ``meta``; the errors are matched on the names they must give.
"""

from __future__ import annotations

import inspect
import warnings

import numpy as np
import pytest
from helpers import numpy_fk

import jaxstiff
from jaxstiff.results._target import MissedTargetWarning
from jaxstiff.settings import ShapeSettings
from jaxstiff.shaping import run_shape
from jaxstiff.solvers import PGD, SLSQP, SLSQPFD, Hybrid, Registered, Trajectory
from jaxstiff.solvers._configs import solver_call, solver_from_name

PLANAR = jaxstiff.Robot.from_urdf("planar_3r")
SMALL = {"starts": 2, "iters": 5, "iters_first": 10, "starts_first": 2, "chunk": 8}


def _path(P: int = 4, seed: int = 0):
    rng = np.random.default_rng(seed)
    qa = rng.uniform(PLANAR.lower + 0.4, PLANAR.upper - 0.4)
    Q = qa + np.linspace(0, 1, P)[:, None] * rng.uniform(-0.15, 0.15, 3)
    pts = np.array([numpy_fk(PLANAR, q)[:3, 3] for q in Q])
    d = np.gradient(pts, axis=0)
    d[:, 2] = 0.0
    return jaxstiff.Path(pts, d / np.linalg.norm(d, axis=-1, keepdims=True)), qa


def _run(solver, **kw):
    path, q0 = _path()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", MissedTargetWarning)
        return jaxstiff.shape(PLANAR, path, "f2", 3.0, solver=solver, q0=q0, task="xy", first_starts=2, **kw)


def _same(a, b):
    for k in ("q", "kj", "status", "criterion"):
        np.testing.assert_array_equal(getattr(a, k), getattr(b, k), err_msg=k)
    for k in ("options", "starts", "warm_options", "solver"):
        assert a.meta.get(k) == b.meta.get(k), k


def test_shape_has_at_most_ten_parameters():
    assert len(inspect.signature(jaxstiff.shape).parameters) <= 10


def test_misspelt_option_is_a_type_error_naming_it():
    with pytest.raises(TypeError, match="iter"):
        PGD(iter=3)  # type: ignore[call-arg]
    with pytest.raises(TypeError, match="max_iter"):
        SLSQP(max_iter=3)  # type: ignore[call-arg]


@pytest.mark.parametrize(
    "make, match",
    [
        (lambda: PGD(iters=0), "iters"),
        (lambda: PGD(mode="worst"), "mode"),
        (lambda: SLSQP(ftol=-1.0), "ftol"),
        (lambda: Trajectory(traj_iters=0), "traj_iters"),
        (lambda: Hybrid(chain="both"), "chain"),
    ],
)
def test_bad_value_is_a_value_error_naming_the_option(make, match):
    with pytest.raises(ValueError, match=match):
        make()


def test_stages_must_be_solver_objects():
    with pytest.raises(TypeError, match="Hybrid.pgd"):
        Hybrid(pgd={"iters": 3})  # type: ignore[arg-type]
    with pytest.raises(TypeError, match="Trajectory.warm"):
        Trajectory(warm={"iters": 3})  # type: ignore[arg-type]
    with pytest.raises(TypeError, match="Trajectory.warm"):
        Trajectory(warm=SLSQPFD())  # type: ignore[arg-type]


def test_a_warm_start_by_name_is_that_solver_with_its_defaults():
    """The docs give ``warm="hybrid"`` as a choice, as ``shape(solver="hybrid")`` takes a name; it was
    a TypeError. A name is the default object; a misspelt one gets the choices."""
    assert Trajectory(warm="hybrid") == Trajectory(warm=Hybrid())  # type: ignore[arg-type]
    assert Trajectory(warm="slsqp").options() == {"warm": "slsqp"}  # type: ignore[arg-type]
    assert Trajectory(warm="pgd") == Trajectory()  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="unknown warm start 'hybird' \\(did you mean 'hybrid'\\?\\)"):
        Trajectory(warm="hybird")  # type: ignore[arg-type]


def test_defaults_pass_no_options():
    for cls in (SLSQP, SLSQPFD, PGD, Hybrid, Trajectory):
        assert solver_call(cls()) == (cls.name, {})


@pytest.mark.parametrize(
    "name, flat",
    [
        ("slsqp", {"maxiter": 50, "driver": "scipy"}),
        ("slsqp-fd", {"ftol": 1e-6}),
        ("pgd", {"iters": 7, "mode": "best"}),
        ("hybrid", {"iters": 7, "maxiter": 40, "chain": "pgd"}),
        ("trajectory", {"traj_iters": 9, "warm": "hybrid", "maxiter": 40}),
    ],
)
def test_a_name_and_a_flat_dict_make_the_same_object(name, flat):
    obj = solver_from_name(name, flat)
    assert obj.name == name
    got = solver_call(obj)[1]
    if name == "trajectory":  # the warm start's options travel apart
        own = {k: v for k, v in flat.items() if k in ("traj_iters", "warm")}
        assert {k: v for k, v in got.items() if k != "warm_options"} == own
        assert got["warm_options"] == {"maxiter": 40}
    else:
        assert got == flat
    with pytest.raises(ValueError, match="did you mean 'iters'"):
        solver_from_name("pgd", {"itres": 3})


def test_registered_solver_keeps_its_free_options():
    assert solver_call(Registered("mine", {"anything": 1})) == ("mine", {"anything": 1})
    assert isinstance(solver_from_name("mine", {"x": 2}), Registered)


def test_pgd_object_equals_name_and_options_bit_for_bit():
    a = _run(PGD(**SMALL))
    with pytest.warns(DeprecationWarning, match="solver object"):
        b = _run("pgd", options=SMALL)
    _same(a, b)
    assert a.meta["options"]["iters"] == 5 and a.meta["starts"] == 2


def test_default_object_equals_the_name():
    _same(_run(SLSQP()), _run("slsqp"))


def test_trajectory_stages_keep_their_own_options():
    res = _run(Trajectory(warm=PGD(**SMALL, polish=4), polish=10, traj_iters=6, blocks=2))
    assert res.meta["warm_options"]["polish"] == 4 and res.meta["options"]["polish"] == 10
    assert res.meta["warm_options"]["iters"] == 5 and res.meta["options"]["traj_iters"] == 6
    # where a flat dict can say it (a shared option set alike on both stages), the two agree
    flat = {**SMALL, "newton": 3, "traj_iters": 6, "blocks": 2}
    obj = Trajectory(warm=PGD(**SMALL, newton=3), newton=3, chunk=8, traj_iters=6, blocks=2)
    with pytest.warns(DeprecationWarning):
        b = _run("trajectory", options=flat)
    _same(_run(obj), b)


def test_unknown_keyword_names_the_nearest_setting():
    path, q0 = _path()
    with pytest.raises(TypeError, match="'task'"):
        jaxstiff.shape(PLANAR, path, "f2", 3.0, q0=q0, tsk="xy")
    with pytest.raises(TypeError, match="run_shape.*'tsk'.*did you mean 'task'"):
        run_shape(PLANAR, path, "f2", 3.0, q0=q0, tsk="xy")
    with pytest.raises(TypeError, match="solver object or in options"):
        _run(PGD(iters=3), options={"iters": 4})


def test_inline_settings_equal_a_settings_object():
    a = _run(SLSQP(), cms_mean_axis=300.0, kmax=50.0)
    b = _run(SLSQP(), settings=ShapeSettings(cms_mean_axis=300.0, kmax=50.0))
    _same(a, b)
    np.testing.assert_array_equal(a.kj_scaled, b.kj_scaled)
    assert a.meta["settings"]["cms_mean_axis"] == 300.0


def test_settings_meta_gives_the_mean_axis_a_cms_target_amounts_to():
    """A volume target V of the planar task (m = 2) is a geometric-mean axis V^(1/2); a major-axis
    target has none. Checked against the stored factors: prod(eig(cms K)) = V at every waypoint."""
    vol = _run(SLSQP(), cms_volume=4.0e4)
    assert vol.meta["settings"]["cms_mean_axis"] == pytest.approx(200.0, rel=1e-15)
    assert vol.meta["cms"] == {"target_volume": 4.0e4, "target_major": None}
    jac = np.stack([jaxstiff.jacobian(PLANAR, q)[:2] for q in vol.q[0]])
    for Jp, kj in zip(jac, vol.kj_scaled[0], strict=True):
        K = np.linalg.inv(Jp @ np.diag(1.0 / kj) @ Jp.T)
        assert np.prod(np.linalg.eigvalsh(K)) == pytest.approx(4.0e4, rel=1e-9)
    major = _run(SLSQP(), cms_major=300.0)
    assert major.meta["settings"]["cms_mean_axis"] is None
    assert major.meta["cms"]["target_major"] == 300.0
