"""Sweep config: a catalogue of bad configs (each message names the key and the problem), and the
expansion of good ones into rows, groups and chunks, checked against independent re-computations
(itertools.product, numpy.linspace, the path generators called directly, numpy eigh)."""

from __future__ import annotations

import copy
import itertools
import math

import numpy as np
import pytest
from helpers import REPO_ROOT, planar_arc_sweep

from jaxstiff import paths as P
from jaxstiff.sweep._config import AXES, SweepConfigError, kxd_matrix, load_config, parse_config


def base() -> dict:
    """A small valid shape sweep: planar 3R, two arcs, 2 x 2 settings."""
    return planar_arc_sweep(
        "t", {"task": "xy", "ratio": [2.0, 3.0], "criterion": ["f1", "f2"]}, end_deg=14.0, chunk_size=3
    )


def csc_base() -> dict:
    return {
        "sweep": {"kind": "csc"},
        "robot": {"name": "planar_3r"},
        "paths": [{"generator": "point", "point": [1.2, 1.0, 0.0], "n": 5}],
        "axes": {"task": "xy", "beta": [0.001, 0.002]},
    }


def _set(cfg: dict, dotted: str, value) -> dict:
    cfg = copy.deepcopy(cfg)
    node = cfg
    parts = dotted.split(".")
    for p in parts[:-1]:
        node = node[int(p)] if isinstance(node, list) else node.setdefault(p, {})
    if value is _DELETE:
        del node[parts[-1]]
    else:
        node[parts[-1]] = value
    return cfg


_DELETE = object()


def _bad_csv(tmp_path):
    f = tmp_path / "bad.csv"
    f.write_text("x,y,z\n1.0,0.0,0.0\n1.0,abc,0.0\n")
    return str(f)


# (id, make config, expected key, fragments the message must contain)
CATALOGUE = [
    ("unknown top-level key", lambda t: {**base(), "axis": {}}, "axis", ["unknown key", "did you mean 'axes'"]),
    ("unknown axis", lambda t: _set(base(), "axes.ratoi", 3.0), "axes.ratoi", ["unknown axis", "did you mean 'ratio'"]),
    ("wrong type", lambda t: _set(base(), "axes.ratio", "five"), "axes.ratio", ["expected a number", "'five'"]),
    ("bool is not a number", lambda t: _set(base(), "axes.ratio", True), "axes.ratio", ["expected a number", "bool"]),
    ("empty axis list", lambda t: _set(base(), "axes.ratio", []), "axes.ratio", ["empty axis"]),
    (
        "empty range",
        lambda t: _set(base(), "axes.ratio", {"start": 2.0, "stop": 4.0, "num": 0}),
        "axes.ratio",
        ["empty axis", "num"],
    ),
    (
        "range without stop",
        lambda t: _set(base(), "axes.ratio", {"start": 2.0, "num": 3}),
        "axes.ratio",
        ["needs 'stop'"],
    ),
    (
        "huge range",
        lambda t: _set(base(), "axes.ratio", {"start": 2.0, "stop": 3.0, "num": 2_000_000_000}),
        "axes.ratio",
        ["num = 2000000000", "the limit is"],
    ),
    (
        "range step going nowhere",
        lambda t: _set(base(), "axes.ratio", {"start": 2.0, "stop": 4.0, "step": -1.0}),
        "axes.ratio",
        ["step"],
    ),
    (
        "unknown robot",
        lambda t: _set(base(), "robot.name", "kuka_lwr5"),
        "robot.name",
        ["unknown robot", "kuka_lwr4", "planar_3r"],
    ),
    (
        "missing urdf file",
        lambda t: {**_set(base(), "robot", {"urdf": "nope.urdf"})},
        "robot.urdf",
        ["file not found", "nope.urdf"],
    ),
    ("name and urdf", lambda t: _set(base(), "robot.urdf", "x.urdf"), "robot", ["exactly one of 'name'"]),
    (
        "unknown locked joint",
        lambda t: _set(base(), "robot.locked", {"no_such_joint": 0.0}),
        "robot.locked",
        ["no_such_joint"],
    ),
    (
        "missing path file",
        lambda t: _set(base(), "paths", [{"file": "missing.csv"}]),
        "paths[0].file",
        ["not found", "missing.csv"],
    ),
    (
        "malformed path file",
        lambda t: _set(base(), "paths", [{"file": _bad_csv(t)}]),
        "paths[0].file",
        ["bad.csv", "abc", "not a number"],
    ),
    (
        "unknown generator",
        lambda t: _set(base(), "paths.0.generator", "spiral"),
        "paths[0].generator",
        ["unknown generator 'spiral'", "arc"],
    ),
    (
        "unknown generator parameter",
        lambda t: _set(base(), "paths.0.radios", 1.0),
        "paths[0].radios",
        ["unknown key", "did you mean 'radius'"],
    ),
    (
        "missing generator parameter",
        lambda t: _set(base(), "paths.0.radius", _DELETE),
        "paths[0].radius",
        ["missing", "needs 'radius' (its required keys: ", "radius"],  # the key that is missing, then the list
    ),
    ("bad generator value", lambda t: _set(base(), "paths.0.radius", -1.0), "paths[0]", ["radius must be > 0"]),
    ("no paths", lambda t: {k: v for k, v in base().items() if k != "paths"}, "paths", ["missing", "[[paths]]"]),
    (
        "q0 seeds without random postures",
        lambda t: _set(base(), "axes.q0_seed", [0, 1]),
        "axes.q0_seed",
        ['no "random" family', "repeat the same rows"],
    ),
    (
        "infinite ratio",
        lambda t: _set(base(), "axes.ratio", [2.0, float("inf")]),
        "axes.ratio",
        ["must be finite", "inf"],
    ),
    ("infinite c", lambda t: _set(base(), "axes.c", float("inf")), "axes.c", ["must be finite"]),
    ("infinite shape kmax", lambda t: _set(base(), "axes.kmax", float("inf")), "axes.kmax", ["must be finite"]),
    ("ratio not above 1", lambda t: _set(base(), "axes.ratio", [0.5, 2.0]), "axes.ratio", ["must be > 1", "0.5"]),
    (
        "kmin not below kmax",
        lambda t: _set(_set(base(), "axes.kmin", [1.0, 50.0]), "axes.kmax", 20.0),
        "axes.kmin",
        ["kmin = 50", "kmax = 20"],
    ),
    (
        "negative rate limit",
        lambda t: _set(base(), "axes.dq_deg", -1.0),
        "axes.dq_deg",
        ["must be a number >= 0", "-1"],
    ),
    (
        "unknown criterion",
        lambda t: _set(base(), "axes.criterion", ["f1", "f3"]),
        "axes.criterion",
        ["unknown value 'f3'", "f1, f2"],
    ),
    (
        "unknown solver",
        lambda t: _set(base(), "axes.solver", "ipopt"),
        "axes.solver",
        ["unknown value 'ipopt'", "slsqp"],
    ),
    ("multi-start with slsqp", lambda t: _set(base(), "axes.starts", [1, 4]), "axes.starts", ["single-start"]),
    ("duplicate axis value", lambda t: _set(base(), "axes.ratio", [2.0, 2.0]), "axes.ratio", ["duplicate value 2.0"]),
    (
        "csc axis in a shape sweep",
        lambda t: _set(base(), "axes.beta", 0.1),
        "axes.beta",
        ["unknown axis", "kind 'csc'"],
    ),
    (
        "shape axis in a csc sweep",
        lambda t: _set(csc_base(), "axes.criterion", "f2"),
        "axes.criterion",
        ["unknown axis", "kind 'shape'"],
    ),
    (
        "unknown kind",
        lambda t: _set(base(), "sweep.kind", "shaping"),
        "sweep.kind",
        ["unknown kind 'shaping'", "did you mean 'shape'"],
    ),
    ("chunk size zero", lambda t: _set(base(), "sweep.chunk_size", 0), "sweep.chunk_size", ["must be >= 1"]),
    (
        "chunk size not an integer",
        lambda t: _set(base(), "sweep.chunk_size", 2.5),
        "sweep.chunk_size",
        ["expected an integer"],
    ),
    ("q0 of the wrong length", lambda t: _set(base(), "axes.q0", [[0.1, 0.2]]), "axes.q0", ["2 values", "3 joints"]),
    ("q0 posture outside its list", lambda t: _set(base(), "axes.q0", [0.1, 0.2, 0.3]), "axes.q0", ["inside a list"]),
    (
        "unknown q0 family",
        lambda t: _set(base(), "axes.q0", "rand"),
        "axes.q0",
        ["unknown q0 family 'rand'", "did you mean 'random'"],
    ),
    (
        "task xy with 3-D directions",
        lambda t: _set(_set(base(), "paths.0.normal", [1.0, 0.0, 0.0]), "axes.task", "xy"),
        "axes.task",
        ["xy plane"],
    ),
    (
        "pgd option in an slsqp sweep",
        lambda t: {**base(), "solver_options": {"iters": 10}},
        "solver_options.iters",
        ["for SLSQP", "maxiter"],
    ),
    (
        "bad option value",
        lambda t: {**_set(base(), "axes.solver", ["slsqp", "pgd"]), "solver_options": {"maxiter": 2.5}},
        "solver_options",
        ["'maxiter' must be an integer"],
    ),
    (
        "trajectory option out of range",
        lambda t: {**_set(base(), "axes.solver", "trajectory"), "solver_options": {"blocks": 0}},
        "solver_options",
        ["trajectory option 'blocks' must be an integer >= 1, got 0"],
    ),
    (
        "trajectory option not a number",
        lambda t: {**_set(base(), "axes.solver", "trajectory"), "solver_options": {"traj_iters": "many"}},
        "solver_options",
        ["'traj_iters' must be an integer", "'many'"],
    ),
    (
        "hybrid option not a choice",
        lambda t: {**_set(base(), "axes.solver", "hybrid"), "solver_options": {"polish_slsqp": "bogus"}},
        "solver_options",
        ["hybrid option 'polish_slsqp' must be one of 'all', 'unusable'"],
    ),
    (
        "pgd integer option given a fraction",
        lambda t: {**_set(base(), "axes.solver", "pgd"), "solver_options": {"newton": 2.5}},
        "solver_options",
        ["pgd option 'newton' must be an integer >= 0, got 2.5"],
    ),
    (
        "unknown solver option",
        lambda t: {**base(), "solver_options": {"maxiters": 10}},
        "solver_options.maxiters",
        ["did you mean 'maxiter'"],
    ),
    (
        "heat map of a fixed axis",
        lambda t: {**base(), "report": {"heatmaps": [["ratio", "dk"]]}},
        "report.heatmaps[0]",
        ["'dk' has one value"],
    ),
    ("csc kxd ratio below 1", lambda t: _set(csc_base(), "axes.kxd_ratio", 0.5), "axes.kxd_ratio", ["must be >= 1"]),
    (
        "task beyond the robot's joints",
        lambda t: _set(base(), "axes.task", ["xy", "full"]),
        "axes.task",
        ["'planar_3r'", "only 3 joint"],
    ),
    (
        "csc task the robot cannot control",
        lambda t: _set(csc_base(), "axes.task", "xyz"),
        "axes.task",
        ["vz", "zero at every posture"],
    ),
    (
        "csc task full",
        lambda t: _set(csc_base(), "axes.task", "full"),
        "axes.task",
        ["unknown value 'full'", "xy, xyz"],
    ),
    (
        "integer range that is not integers",
        lambda t: _set(base(), "axes.first_starts", {"start": 1, "stop": 4, "num": 3}),
        "axes.first_starts",
        ["not integers (1, 2.5, 4)"],
    ),
    (
        "infinite tcp entry",
        lambda t: _set(
            base(),
            "robot.tcp",
            [[1.0, 0.0, 0.0, math.inf], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0]],
        ),
        "robot.tcp",
        ["NaN or Inf: [[1.0, 0.0, 0.0, inf], [0.0, 1.0, 0.0, 0.0]"],
    ),
]


@pytest.mark.parametrize("case", CATALOGUE, ids=[c[0] for c in CATALOGUE])
def test_bad_config_names_key_and_problem(case, tmp_path):
    _, make, key, fragments = case
    cfg = make(tmp_path)
    with pytest.raises(SweepConfigError) as info:
        parse_config(cfg, base_dir=tmp_path, source="cfg.toml")
    err = info.value
    msg = str(err)
    assert err.key == key, msg
    assert msg.startswith(f"cfg.toml: {key}: "), msg
    for frag in fragments:
        assert frag in msg, f"{frag!r} not in {msg!r}"
    assert isinstance(err, ValueError)


def test_catalogue_is_large_enough():
    assert len(CATALOGUE) >= 10


def test_toml_syntax_error_and_missing_file(tmp_path):
    f = tmp_path / "broken.toml"
    f.write_text('[sweep]\nkind = "shape"\nname = \n[robot]\n')
    with pytest.raises(SweepConfigError, match=r"broken.toml: not valid TOML.*line 3"):
        load_config(f)
    with pytest.raises(FileNotFoundError, match="sweep config not found"):
        load_config(tmp_path / "absent.toml")


def test_relative_files_resolve_against_the_toml_folder(tmp_path):
    sub = tmp_path / "cfg"
    sub.mkdir()
    P.arc([0.0, 0.0, 0.0], 1.5, 10.0, 14.0, n=3).to_csv(sub / "p.csv")
    (sub / "s.toml").write_text(
        '[robot]\nname = "planar_3r"\n[[paths]]\nfile = "p.csv"\n[axes]\ntask = "xy"\n', encoding="utf-8"
    )
    plan = load_config(sub / "s.toml")
    assert plan.trajectories[0].name == "p"
    np.testing.assert_allclose(
        plan.trajectories[0].points, P.arc([0.0, 0.0, 0.0], 1.5, 10.0, 14.0, n=3).points, atol=1e-15
    )
    assert plan.name == "s"


# ---------------------------------------------------------------------------- expansion
def test_rows_are_the_product_of_axes_times_paths():
    cfg = _set(base(), "axes.dq_deg", {"start": 1.0, "stop": 3.0, "num": 3})
    plan = parse_config(cfg)
    names = list(AXES["shape"])
    want_axes = {k: [s.default] for k, s in AXES["shape"].items()}
    want_axes.update(task=["xy"], ratio=[2.0, 3.0], criterion=["f1", "f2"], dq_deg=list(np.linspace(1.0, 3.0, 3)))
    combos = list(itertools.product(*(want_axes[k] for k in names)))
    assert len(plan.trajectories) == 2
    assert plan.n_rows == len(combos) * 2 == 24
    for r, (s_idx, p_idx) in enumerate(plan.rows):
        assert r == s_idx * 2 + p_idx
        assert plan.settings[s_idx] == dict(zip(names, combos[s_idx], strict=True))


def test_generator_lists_make_one_path_per_value():
    plan = parse_config(base())
    for t, radius in zip(plan.trajectories, (1.5, 2.0), strict=True):
        ref = P.arc([0.0, 0.0, 0.0], radius, 10.0, 14.0, n=3)
        np.testing.assert_allclose(t.points, ref.points, atol=1e-15)
        np.testing.assert_allclose(t.directions, ref.directions, atol=1e-15)
    assert [t.name for t in plan.trajectories] == ["arc(radius=1.5)", "arc(radius=2)"]


def test_zip_pairs_generator_lists():
    cfg = base()
    cfg["paths"] = [
        {
            "generator": "line",
            "start": [[1.5, 0.0, 0.0], [1.6, 0.0, 0.0]],
            "end": [[1.5, 0.1, 0.0], [1.6, 0.1, 0.0]],
            "n": 3,
            "zip": True,
        }
    ]
    plan = parse_config(cfg)
    assert len(plan.trajectories) == 2
    for t, x in zip(plan.trajectories, (1.5, 1.6), strict=True):
        np.testing.assert_allclose(t.points, P.line([x, 0.0, 0.0], [x, 0.1, 0.0], n=3).points, atol=1e-15)
    cfg["paths"][0]["zip"] = False
    assert len(parse_config(cfg).trajectories) == 4  # every combination
    cfg["paths"][0].update(zip=True, end=[[1.5, 0.1, 0.0]] * 3)
    with pytest.raises(SweepConfigError, match=r"paths\[0\].zip: .*equal lengths"):
        parse_config(cfg)


def test_repeated_path_names_get_free_suffixes():
    """A renamed duplicate never takes a name another path has ("p", "p", "p#2" gave two "p#2",
    whose rows a per-path report then mixed)."""
    cfg = base()
    pts = [{"generator": "point", "point": [1.2, y, 0.0], "n": 3} for y in (1.0, 1.1, 1.2, 1.3)]
    cfg["paths"] = [{**pt, "name": nm} for pt, nm in zip(pts, ["p", "p", "p#2", "p"], strict=True)]
    names = [t.name for t in parse_config(cfg).trajectories]
    assert names == ["p", "p#3", "p#2", "p#4"]
    assert len(set(names)) == len(names)


def test_a_path_given_twice_is_refused_as_a_repeated_axis_value_is():
    """The same path twice (a file listed twice, or a generator that makes it again) ran every
    setting twice without a word, where a repeated axis value is refused."""
    cfg = base()
    pt = {"generator": "point", "point": [1.2, 1.0, 0.0], "n": 3}
    cfg["paths"] = [pt, {**pt, "name": "again"}]
    with pytest.raises(SweepConfigError, match=r"paths\[1\]: path 'again' is the same path as .*give each path once"):
        parse_config(cfg)


def test_step_range_is_inclusive():
    plan = parse_config(_set(base(), "axes.ratio", {"start": 2.0, "stop": 3.0, "step": 0.25}))
    assert plan.axes["ratio"] == [2.0, 2.25, 2.5, 2.75, 3.0]


def test_range_values_are_the_decimals_meant():
    """1.1 + 0.1 is 1.2000000000000002 in floating point: a table filtered on ratio == 1.2
    found nothing, and the last value lay above stop. Values within round-off of a short decimal
    are that decimal; others (linspace's thirds) stay as numpy gives them."""
    plan = parse_config(_set(base(), "axes.ratio", {"start": 1.1, "stop": 1.7, "step": 0.1}))
    assert plan.axes["ratio"] == [1.1, 1.2, 1.3, 1.4, 1.5, 1.6, 1.7]
    assert 1.1 + 0.1 != 1.2  # (the round-off that was stored)
    plan = parse_config(_set(base(), "axes.ratio", {"start": 2.0, "stop": 3.0, "num": 4}))
    assert plan.axes["ratio"] == np.linspace(2.0, 3.0, 4).tolist() and plan.axes["ratio"][1] != 2.333333333333


def test_groups_share_static_settings_and_chunks_stay_inside_groups():
    cfg = base()
    cfg["paths"].append({"generator": "line", "start": [1.5, 0.0, 0.0], "end": [1.5, 0.1, 0.0], "n": 4})
    plan = parse_config(cfg)
    static = [k for k, s in AXES["shape"].items() if s.static]
    for r in range(plan.n_rows):
        g = plan.groups[plan.row_group[r]]
        st = plan.row_settings(r)
        assert all(g[k] == st[k] for k in static) and g["P"] == plan.row_trajectory(r).P
    keys = {json_key(plan, r) for r in range(plan.n_rows)}
    assert len(plan.groups) == len(keys) == 4  # 2 criteria x 2 waypoint counts
    seen = []
    for c in plan.chunks:
        assert 1 <= len(c.rows) <= 3
        assert {plan.row_group[r] for r in c.rows} == {c.group}
        # whole settings: each group has one path per P, so a chunk never splits a setting
        settings = [plan.rows[r][0] for r in c.rows]
        assert all(
            sum(1 for r in range(plan.n_rows) if plan.rows[r][0] == s and plan.row_group[r] == c.group)
            == settings.count(s)
            for s in set(settings)
        )
        seen += c.rows
    assert sorted(seen) == list(range(plan.n_rows))


def test_shape_chunks_hold_whole_settings_or_split_large_ones():
    cfg = base()
    cfg["paths"][0]["radius"] = [1.5, 1.6, 1.7, 1.8, 1.9]  # 5 paths, chunk_size 3: settings are split 3 + 2
    plan = parse_config(cfg)
    assert [len(c.rows) for c in plan.chunks] == [3, 2] * 4
    cfg["sweep"]["chunk_size"] = 11  # 2 whole settings (10 rows) per chunk
    plan = parse_config(cfg)
    assert [len(c.rows) for c in plan.chunks] == [10, 10]


def json_key(plan, r):
    st = plan.row_settings(r)
    return (st["criterion"], st["task"], st["solver"], st["starts"], plan.row_trajectory(r).P)


def test_plan_hash_tracks_what_changes_results():
    h0 = parse_config(base()).plan_hash
    assert parse_config(base()).plan_hash == h0
    assert parse_config(_set(base(), "axes.ratio", [2.0, 3.5])).plan_hash != h0
    assert parse_config(_set(base(), "paths.0.n", 4)).plan_hash != h0
    assert parse_config(_set(base(), "sweep.chunk_size", 2)).plan_hash != h0
    assert parse_config({**base(), "report": {"metrics": ["share_ratio"]}}).plan_hash == h0


def test_plan_hash_sees_file_contents_not_their_folder(tmp_path):
    """A sweep folder moved, copied or reached through a symlink must resume: the hash holds the
    URDF's and the CSV's sha256, not their absolute paths (those made --resume refuse the same
    files elsewhere); a changed file content still changes it."""
    import os
    import shutil

    import jaxstiff

    a = tmp_path / "a"
    a.mkdir()
    shutil.copy(jaxstiff.robot_path("planar_3r"), a / "arm.urdf")
    P.arc([0.0, 0.0, 0.0], 1.5, 10.0, 14.0, n=3).to_csv(a / "p.csv")
    (a / "s.toml").write_text(
        '[robot]\nurdf = "arm.urdf"\n[[paths]]\nfile = "p.csv"\n[axes]\ntask = "xy"\n', encoding="utf-8"
    )
    h0 = load_config(a / "s.toml").plan_hash
    shutil.copytree(a, tmp_path / "b")
    os.symlink(a, tmp_path / "link")
    assert load_config(tmp_path / "b" / "s.toml").plan_hash == h0
    assert load_config(tmp_path / "link" / "s.toml").plan_hash == h0
    P.arc([0.0, 0.0, 0.0], 1.5, 10.0, 15.0, n=3).to_csv(tmp_path / "b" / "p.csv")
    assert load_config(tmp_path / "b" / "s.toml").plan_hash != h0


def test_defaults_match_shape_defaults():
    """A sweep row with every axis at its default is the same problem as a bare shape() call."""
    from jaxstiff.shaping import DEFAULTS

    ax = AXES["shape"]
    assert ax["dq_deg"].default == DEFAULTS["dq_deg"]
    assert ax["dk"].default == DEFAULTS["dk"]
    assert ax["kmin"].default == DEFAULTS["kmin"] and ax["kmax"].default == DEFAULTS["kmax"]
    assert ax["c"].default == DEFAULTS["c"]
    assert ax["first_rate_limit"].default == DEFAULTS["first_rate_limit"]
    assert ax["first_starts"].default == DEFAULTS["first_starts"]


@pytest.mark.parametrize("task,angle", [("xy", 30.0), ("xy", -75.0), ("xyz", 30.0), ("xyz", 120.0)])
def test_kxd_matrix_axes_and_direction(task, angle):
    K = kxd_matrix(task, 3000.0, 3.0, angle)
    w, V = np.linalg.eigh(K)
    assert np.allclose(K, K.T, atol=0)
    np.testing.assert_allclose(w[-1], 3000.0, rtol=1e-13)
    np.testing.assert_allclose(w[:-1], 1000.0, rtol=1e-13)
    v = V[:, -1]
    t = math.radians(angle)
    d = np.array([math.cos(t), math.sin(t), 0.0])[: K.shape[0]]
    assert abs(abs(v @ d) - 1.0) < 1e-12


def test_shipped_quick_sweep():
    """experiments/sweeps/quick.toml (the README example): >= 200 rows over the shipped LWR and
    the shipped default path; its heat maps name real axes (the run itself is timed, not tested)."""
    import os

    from jaxstiff.paths import default_path

    f = os.path.join(REPO_ROOT, "experiments", "sweeps", "quick.toml")
    plan = load_config(f)
    assert plan.n_rows >= 200
    assert plan.robot.name.lower().startswith("kuka") and plan.robot.n_free == 6
    d = [t for t in plan.trajectories if t.name == "default"][0]
    np.testing.assert_allclose(d.points, default_path(n=d.P).points, atol=1e-15)
    assert ("ratio", "path") in plan.heatmaps


def test_csc_sweep_reads_a_csv_path_that_holds_still(tmp_path):
    """A CSC rollout takes one step per row and holds still where rows repeat; its sweep reads the
    points alone (a shape sweep, which needs tangents, still refuses the pause, naming the line)."""
    f = tmp_path / "pause.csv"
    f.write_text("x,y,z\n1.2,1.0,0\n1.2,1.05,0\n1.2,1.05,0\n1.2,1.1,0\n")
    plan = parse_config(_set(csc_base(), "paths", [{"file": str(f)}]))
    t = plan.trajectories[0]
    np.testing.assert_array_equal(t.points, [[1.2, 1.0, 0], [1.2, 1.05, 0], [1.2, 1.05, 0], [1.2, 1.1, 0]])
    assert t.directions.shape == (4, 3) and np.all(np.isfinite(t.directions))
    with pytest.raises(ValueError, match=r"paths\[0\]\.file.*zero-length segment at waypoint 1 \(line 3\)"):
        parse_config(_set(base(), "paths", [{"file": str(f)}]))


def test_csc_sweep_without_a_null_space_warns():
    """A csc sweep on an arm with as many free joints as task rows is allowed (CSC then only
    tracks), but its beta axis changes nothing: the plan says so. With a spare joint, no warning."""
    import warnings

    two_free = _set(csc_base(), "robot.locked", {"joint_3": 0.0})
    with pytest.warns(
        UserWarning, match=r"axes.task 'xy': robot 'planar_3r' has 2 free joints for 2 task rows: no null space"
    ):
        parse_config(two_free)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        parse_config(csc_base())


# ---------------------------------------------------------------------------- defaults from the settings spine
def test_sweep_defaults_are_the_settings_defaults():
    """Every axis that mirrors a setting has the settings' default (one default everywhere,
    issue 20); the conversions the table needs are the documented ones: dq_deg in degrees,
    starts None -> 0, csc task None -> "xyz" (the sweep's K_xd is 3x3 unless task = xy)."""
    from jaxstiff.settings import CSCSettings, ShapeSettings

    shape, csc = ShapeSettings(), CSCSettings()
    want_shape = {
        "criterion": shape.criterion,
        "task": shape.task,
        "locked_joints": shape.locked_joints,
        "solver": shape.solver,
        "starts": 0 if shape.starts is None else shape.starts,
        "ratio": shape.ratio,
        "c": shape.c,
        "dq_deg": math.degrees(shape.dq),
        "dk": shape.dk,
        "kmin": shape.kmin,
        "kmax": shape.kmax,
        "first_rate_limit": shape.first_rate_limit,
        "first_starts": shape.first_starts,
    }
    want_csc = {
        "task": "xyz" if csc.task is None else csc.task,
        "step": csc.step,
        "kmin": csc.kmin,
        "kmax": csc.kmax,
        "newton": csc.newton,
        "joint_limits": csc.joint_limits,
        "jl_gain": csc.jl_gain,
        "objective": csc.objective,
        "locked_joints": csc.locked_joints,
        "beta": csc.beta,
    }
    for kind, want in (("shape", want_shape), ("csc", want_csc)):
        mirrored = {k for k, s in AXES[kind].items() if s.setting}
        assert mirrored == set(want), kind  # every axis with a settings twin is checked here
        for k, v in want.items():
            assert (
                AXES[kind][k].default == pytest.approx(v, rel=1e-15)
                if isinstance(v, float)
                else AXES[kind][k].default == v
            ), k
    assert AXES["shape"]["dq_deg"].default == 2.0  # exactly, as the table column shows it
    assert csc.beta == 1.0 and AXES["csc"]["beta"].default == 1.0  # (the sweep's own default was 0.5)


def test_csc_jl_gain_follows_the_settings_rule():
    """jl_gain not given: 0.3 with joint-limit avoidance on, else 0 (CSCSettings.resolved_jl_gain),
    per row when the joint_limits axis mixes both; a given gain is used as given."""
    plan = parse_config(csc_base())
    assert plan.axes["jl_gain"] == [0.0] and plan.axes["beta"] == [0.001, 0.002]
    plan = parse_config(_set(csc_base(), "axes.joint_limits", "priority"))
    assert plan.axes["jl_gain"] == [0.3]
    plan = parse_config(_set(csc_base(), "axes.joint_limits", ["off", "sum"]))
    assert plan.axes["jl_gain"] == [None]
    assert {(s["joint_limits"], s["jl_gain"]) for s in plan.settings} == {("off", 0.0), ("sum", 0.3)}
    assert {(g["joint_limits"], g["jl_gain"]) for g in plan.groups} == {("off", 0.0), ("sum", 0.3)}
    plan = parse_config(_set(_set(csc_base(), "axes.joint_limits", "sum"), "axes.jl_gain", 0.1))
    assert plan.axes["jl_gain"] == [0.1]
    assert parse_config(_set(csc_base(), "axes.beta", _DELETE)).axes["beta"] == [1.0]


def test_shipped_robot_gets_the_commands_default_lock():
    """[robot] goes through RobotSpec: kuka_lwr4 without 'locked' has lwr_a7 locked at 0, as in
    every command (the sweep left it free before); locked = {} frees it; the spec records it."""
    from jaxstiff.settings import DEFAULT_LOCKS, RobotSpec

    cfg = {"robot": {"name": "kuka_lwr4"}, "paths": [{"generator": "default", "n": 4}]}
    plan = parse_config(cfg)
    want = RobotSpec(urdf="kuka_lwr4").build()
    assert plan.robot.n_free == want.n_free == 6
    assert (
        dict(zip(plan.robot.joint_names, plan.robot.locked, strict=True))["lwr_a7"]
        == DEFAULT_LOCKS["kuka_lwr4"]["lwr_a7"]
    )
    assert plan.robot_spec["locked"] == {"lwr_a7": 0.0} and plan.robot_spec["locked_by_default"] is True
    free = parse_config(_set(cfg, "robot.locked", {}))
    assert free.robot.n_free == 7 and "locked_by_default" not in free.robot_spec
    assert free.plan_hash != plan.plan_hash


def test_robot_tcp_takes_three_or_six_values():
    """tcp = [x, y, z] (m) or [x, y, z, roll, pitch, yaw] (m, rad; RobotSpec's), or a 4x4 transform."""
    from jaxstiff.settings._robot import tcp_transform

    six = [0.1, 0.0, 0.0, 0.0, 0.0, math.pi / 2]
    plan = parse_config(_set(base(), "robot.tcp", six))
    bare = parse_config(base()).robot
    np.testing.assert_allclose(plan.robot.tip_matrix, bare.tip_matrix @ tcp_transform(six), atol=1e-15)
    three = parse_config(_set(base(), "robot.tcp", [0.1, 0.0, 0.0])).robot
    np.testing.assert_allclose(three.tip_matrix, bare.tip_matrix @ tcp_transform([0.1, 0.0, 0.0]), atol=1e-15)
    with pytest.raises(SweepConfigError, match=r"robot.tcp: expected 3 numbers .* 6 numbers .*got \[0.1, 0.0\]"):
        parse_config(_set(base(), "robot.tcp", [0.1, 0.0]))


def test_q0_posture_outside_limits_names_the_unit_of_the_joint():
    """A q0 posture outside a prismatic joint's limits gave its value in rad (found with a Fetch
    URDF's torso lift): m for a prismatic joint, rad for a revolute one."""
    import jaxstiff
    from jaxstiff.sweep._axes import q0_values

    robot = jaxstiff.Robot.from_urdf(str(REPO_ROOT / "tests" / "data" / "branched_tree.urdf"), tip_link="tool")
    j2 = robot.joint_names.index("j2")
    assert bool(robot.prismatic[j2]) and not bool(robot.prismatic[0])
    q = [0.0] * robot.n
    q[j2] = 0.9
    with pytest.raises(SweepConfigError, match=rf"q\[{j2}\] = 0\.9 m is outside the limits \[0, 0\.5\] of joint 'j2'"):
        q0_values([q], "axes.q0", robot)
    q[j2], q[0] = 0.1, 99.0
    with pytest.raises(SweepConfigError, match=r"q\[0\] = 99 rad is outside the limits"):
        q0_values([q], "axes.q0", robot)


def test_a_path_beyond_reach_is_said_before_the_run(recwarn):
    """A sweep path written in millimetres ran, every waypoint status 3 and every metric NaN, with
    no word (jaxstiff shape refuses the same path): the plan says which path, how many waypoints,
    the reach, and the millimetre hint; a path in reach gets no such warning."""
    cfg = {
        "sweep": {"kind": "shape"},
        "robot": {"name": "kuka_lwr4"},
        "paths": [
            {"generator": "line", "start": [600, -100, 300], "end": [600, 100, 300], "n": 4},
            {"generator": "default", "n": 4},
        ],
        "axes": {"ratio": [3.0]},
    }
    with pytest.warns(
        UserWarning, match=r"path 'line': 4 of 4 waypoints lie beyond the reach of robot 'kuka_lwr4'"
    ) as w:
        parse_config(cfg)
    msgs = [str(x.message) for x in w if "beyond the reach" in str(x.message)]
    assert len(msgs) == 1 and "look like millimetres" in msgs[0], msgs
    cfg["paths"] = cfg["paths"][1:]
    recwarn.clear()
    parse_config(cfg)
    assert not [x for x in recwarn if "beyond the reach" in str(x.message)]
