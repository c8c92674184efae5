"""ShapeResult files: contract keys and shapes, no pickles, atomic writes, load errors, status helpers,
summary numbers against hand counts, reference states of the rate limits."""

import json
import os

import numpy as np
import pytest

import jaxstiff
from jaxstiff.results import _files as R


def make_result(B=2, P=4, n=3, status=None, first_rate_limit=False):
    rng = np.random.default_rng(0)
    st = np.zeros((B, P), dtype=np.int64) if status is None else np.asarray(status)
    return R.ShapeResult(
        joint_names=np.array([f"j{i}" for i in range(n)]),
        q=rng.normal(size=(B, P, n)),
        kj=rng.uniform(1, 100, (B, P, n)),
        cms=np.ones((B, P)),
        kj_scaled=rng.uniform(1, 100, (B, P, n)),
        target=rng.normal(size=(B, P, 3)),
        direction=np.tile([1.0, 0, 0], (B, P, 1)),
        position=rng.normal(size=(B, P, 3)),
        pos_error=np.full((B, P), 1e-12),
        alpha_deg=np.array([[0.5, 2.0, 0.1, 0.9], [3.0, 0.2, 0.3, 0.4]])[:B, :P],
        ratio=np.array([[5.0, 5.05, 4.8, 5.2], [5.0, 4.95, 5.11, 5.0]])[:B, :P],
        criterion=np.ones((B, P)),
        status=st,
        q0=np.zeros((B, n)),
        kj0=np.full((B, n), 50.0),
        solver_code=np.zeros((B, P), dtype=np.int64),
        nit=np.full((B, P), 10),
        nfev=np.full((B, P), 20),
        time_s=np.array([[0.01, 0.02, 0.03, 0.04], [0.05, 0.06, 0.07, 0.08]])[:B, :P],
        meta={"ratio": 5.0, "criterion": "f2", "limits": {"first_rate_limit": first_rate_limit}, "note": "ü"},
    )


def test_save_load_round_trip_without_pickles(tmp_path):
    res = make_result()
    f = res.save(tmp_path / "r.npz")
    with np.load(f, allow_pickle=False) as z:
        keys = set(z.files)
        assert z["joint_names"].dtype.kind == "U" and z["status"].dtype == np.int64
        assert z["q"].shape == (2, 4, 3) and z["cms"].shape == (2, 4) and z["target"].shape == (2, 4, 3)
        meta = json.loads(str(z["meta"]))
    # the DESIGN.md contract
    assert {
        "joint_names",
        "q",
        "kj",
        "cms",
        "target",
        "direction",
        "position",
        "alpha_deg",
        "ratio",
        "criterion",
        "status",
        "meta",
    } <= keys
    assert meta["note"] == "ü"
    back = jaxstiff.ShapeResult.load(f)
    for k, v in res.arrays().items():
        np.testing.assert_array_equal(getattr(back, k), v, err_msg=k)
    assert back.meta == res.meta


def test_save_appends_npz_and_uses_normal_permissions(tmp_path):
    f = make_result().save(tmp_path / "r")
    assert f.endswith("r.npz") and os.path.isfile(f)
    mask = os.umask(0)
    os.umask(mask)
    assert os.stat(f).st_mode & 0o777 == 0o666 & ~mask


def test_interrupted_save_leaves_no_file(tmp_path, monkeypatch):
    def boom(*a, **k):
        raise KeyboardInterrupt

    monkeypatch.setattr(np, "savez", boom)
    with pytest.raises(KeyboardInterrupt):
        make_result().save(tmp_path / "r.npz")
    assert os.listdir(tmp_path) == []


def test_existing_file_is_replaced_atomically(tmp_path):
    f = tmp_path / "r.npz"
    f.write_bytes(b"old")
    make_result().save(f)
    assert jaxstiff.ShapeResult.load(f).P == 4
    assert sorted(os.listdir(tmp_path)) == ["r.npz"]


def test_load_errors(tmp_path):
    with pytest.raises(FileNotFoundError, match="nope.npz"):
        jaxstiff.ShapeResult.load(tmp_path / "nope.npz")
    np.savez(tmp_path / "other.npz", a=np.zeros(3))
    with pytest.raises(ValueError, match="missing keys: joint_names"):
        jaxstiff.ShapeResult.load(tmp_path / "other.npz")
    (tmp_path / "junk.npz").write_bytes(b"\x00\x01binary")
    with pytest.raises(ValueError, match="not a readable .*not a zip archive"):
        jaxstiff.ShapeResult.load(tmp_path / "junk.npz")
    (tmp_path / "path.csv").write_text("x,y,z\n1,2,3\n")  # numpy alone would talk about pickles here
    with pytest.raises(ValueError, match=r"path.csv: not a readable .*text, e.g. a CSV"):
        jaxstiff.ShapeResult.load(tmp_path / "path.csv")
    with pytest.raises(FileNotFoundError, match="folder does not exist"):
        make_result().save(tmp_path / "no" / "such" / "dir.npz")


def test_shapes_are_checked():
    with pytest.raises(ValueError, match="cms must have shape"):
        R.ShapeResult(**{**make_result().arrays(), "cms": np.ones(3), "meta": {}})


def test_status_helpers():
    st = np.array([0, 1, 2, 3, 4, 5])
    np.testing.assert_array_equal(R.is_usable(st), [True, True, True, False, False, False])
    assert set(R.STATUS_NAMES) == {0, 1, 2, 3, 4, 5}
    assert R.USABLE == (R.SOLVED, R.NOT_CONVERGED, R.CLIPPED)


def test_summary_counts_by_hand():
    res = make_result(status=[[0, 0, 3, 1], [0, 2, 0, 4]])
    s = R.summary(res)
    alpha = res.alpha_deg.ravel()
    ratio = res.ratio.ravel()
    usable = np.isin(res.status.ravel(), [0, 1, 2])  # waypoints 2 (status 3) and 7 (status 4) are not
    a_ok = (alpha < 1.0) & usable  # 0.5, 0.1, 0.9 | 0.2, 0.3, 0.4 -> 6 of 8, 4 of them usable
    r_ok = (np.abs(ratio - 5) / 5 < 0.02) & usable  # 5, 5.05 | 5, 4.95, 5.0 -> 5 of 8 (4.8, 5.2, 5.11 fail)
    assert (alpha < 1.0).sum() == 6 and (np.abs(ratio - 5) / 5 < 0.02).sum() == 5
    assert s["share_alpha"] == a_ok.mean() and s["share_ratio"] == r_ok.mean()
    assert s["share_both"] == np.mean(a_ok & r_ok) == res.in_target.mean()
    assert not res.in_target.ravel()[~usable].any()  # an unreachable waypoint is never in target
    assert s["share_usable"] == 6 / 8 and s["share_solved"] == 4 / 8
    assert s["median_time_s"] == 0.045
    # f1 counts "at least 0.98 r"
    res.meta["criterion"] = "f1"
    assert R.summary(res)["share_ratio"] == np.mean((ratio >= 4.9) & usable)


@pytest.mark.parametrize("first_rate_limit", [False, True])
def test_reference_states_skip_unusable_waypoints(first_rate_limit):
    res = make_result(status=[[0, 3, 4, 0], [3, 0, 0, 1]], first_rate_limit=first_rate_limit)
    Q, K, rate = R.reference_states(res, 0)
    np.testing.assert_array_equal(Q[0], res.q0[0])
    np.testing.assert_array_equal(Q[1], res.q[0, 0])
    np.testing.assert_array_equal(Q[2], res.q[0, 0])  # waypoint 1 unreachable: still waypoint 0
    np.testing.assert_array_equal(Q[3], res.q[0, 0])
    np.testing.assert_array_equal(rate, [first_rate_limit, True, True, True])
    Q, K, rate = R.reference_states(res, 1)
    np.testing.assert_array_equal(Q[1], res.q0[1])  # waypoint 0 unusable: the start state
    np.testing.assert_array_equal(K[1], res.kj0[1])
    np.testing.assert_array_equal(rate, [first_rate_limit, first_rate_limit, True, True])


def test_meta_is_strict_json_and_non_finite_numbers_come_back(tmp_path):
    """A continuous joint's limits (+-inf) and a NaN in meta: the file's meta parses with a strict
    JSON parser (no bare Infinity/NaN tokens, which JavaScript's JSON.parse and jq refuse), and
    ShapeResult.load gives the same floats back."""
    import math

    res = make_result()
    res.meta["robot"] = {"lower": [-1.0, -math.inf], "upper": [1.0, math.inf], "name": "Infinity-arm"}
    res.meta["limits"]["kmax"] = math.inf
    res.meta["extra_nan"] = [float("nan"), np.float64(2.5)]
    f = res.save(tmp_path / "r.npz")
    with np.load(f, allow_pickle=False) as z:
        text = str(z["meta"])

    def refuse(token):
        raise ValueError(f"bare {token} in meta")

    raw = json.loads(text, parse_constant=refuse)  # strict: RFC 8259 numbers only
    assert raw["robot"]["lower"][1] == "-Infinity" and raw["limits"]["kmax"] == "Infinity"
    back = R.ShapeResult.load(f).meta
    assert back["robot"]["lower"] == [-1.0, -math.inf] and back["robot"]["upper"] == [1.0, math.inf]
    assert back["limits"]["kmax"] == math.inf and math.isnan(back["extra_nan"][0]) and back["extra_nan"][1] == 2.5
    assert back["robot"]["name"] == "Infinity-arm"  # only the exact spellings are numbers


def test_settings_in_meta_spell_infinity_as_the_file_does(tmp_path):
    """`shape --dq-deg inf --dk inf`: meta["limits"] said "Infinity" while meta["settings"] said
    "inf", which ShapeResult.load left a string (np.clip(x, 0, meta[...]) then raised). Every
    non-finite number of a written meta is one of the three documented spellings, and comes back
    from ShapeResult.load as a float."""
    import math

    res = jaxstiff.shape("kuka_lwr4", jaxstiff.default_path().points[:3], "f2", 5.0, dq=math.inf, dk=math.inf)
    f = res.save(tmp_path / "r.npz")
    with np.load(f, allow_pickle=False) as z:
        raw = json.loads(str(z["meta"]))

    def strings(o):
        if isinstance(o, dict):
            for v in o.values():
                yield from strings(v)
        elif isinstance(o, list):
            for v in o:
                yield from strings(v)
        elif isinstance(o, str):
            yield o

    spelt = set(strings(raw))
    assert not spelt & {"inf", "-inf", "nan"}, spelt & {"inf", "-inf", "nan"}  # str(float)'s spellings
    assert raw["settings"]["dq"] == "Infinity" and raw["settings"]["dk"] == "Infinity"
    back = R.ShapeResult.load(f).meta
    assert back["settings"]["dq"] == math.inf and back["settings"]["dk"] == math.inf
