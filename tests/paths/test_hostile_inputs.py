"""One rule each for the inconsistent checks of issue 24, finding 5 (the parts in paths, the
commands and the sweep): values beyond float64's range of lengths, files that are not regular
files, format_csv given a Path, half-precision inputs."""

from __future__ import annotations

import os
import warnings

import numpy as np
import pytest

import jaxstiff
from jaxstiff.cli import main
from jaxstiff.paths import Path, format_csv, line, read_csv
from jaxstiff.runtime._io import check_regular_file
from jaxstiff.sweep._config import SweepConfigError, load_config, parse_config

CSC = ["csc", "--robot", "planar_3r", "--kxd", "3000,1000@30", "--q0-deg", "75,-74.74,-76.30"]


# ------------------------------------------------------------------ values beyond float64 lengths
def test_csv_with_1e300_is_refused_by_line_and_column(tmp_path):
    f = tmp_path / "big.csv"
    f.write_text("x,y,z,dx,dy,dz\n0.5,0,0.3,1,0,0\n0.6,0,0.3,1e300,0,0\n")
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # (no numpy overflow warning first)
        with pytest.raises(ValueError, match=r"big.csv:3: column dx: value '1e300' is beyond \+-1e\+150"):
            Path.from_csv(f)
        with pytest.raises(ValueError, match=r":3: column dx"):
            read_csv(f)


def test_path_api_refuses_huge_values_by_name():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(ValueError, match=r"points value 1e\+300 at waypoint 1, column y"):
            Path([[0, 0, 0], [0, 1e300, 0]])
        with pytest.raises(ValueError, match=r"directions value -1e\+200 at waypoint 0, column z"):
            Path([[0, 0, 0], [1, 0, 0]], [[0, 0, -1e200], [1, 0, 0]])
    big = Path([[0, 0, 0], [1e150, 0, 0]])  # the limit itself: its lengths are finite
    assert np.all(np.isfinite(big.directions))


# ------------------------------------------------------------------ files that are not regular files
@pytest.fixture(params=["fifo", "devzero", "folder"])
def not_regular(request, tmp_path):
    p = tmp_path / f"in_{request.param}"
    if request.param == "fifo":
        os.mkfifo(p)
    elif request.param == "devzero":
        os.symlink("/dev/zero", p)
    else:
        p.mkdir()
    return str(p), {"fifo": "a FIFO", "devzero": "a character device", "folder": "a folder"}[request.param]


def test_one_rule_for_files(not_regular, tmp_path):
    path, kind = not_regular
    with pytest.raises(ValueError, match=f"is not a regular file: it is {kind}"):
        check_regular_file(path, "--x")
    with pytest.raises(ValueError, match=f"is not a regular file: it is {kind}"):
        Path.from_csv(path)
    with pytest.raises(FileNotFoundError, match="--x: file not found"):
        check_regular_file(tmp_path / "missing.csv", "--x")


def test_csc_path_not_regular(not_regular, tmp_path, capsys):
    path, kind = not_regular
    rc = main([*CSC, "--path", path, "--out", str(tmp_path / "o.npz")])
    assert rc == 2 and f"is not a regular file: it is {kind}" in capsys.readouterr().err


def test_sweep_files_not_regular(not_regular, tmp_path):
    path, kind = not_regular
    cfg = {
        "sweep": {"kind": "shape"},
        "robot": {"name": "planar_3r"},
        "paths": [{"file": path}],
        "axes": {"task": "xy", "ratio": [2.0]},
    }
    with pytest.raises(SweepConfigError, match=f"is not a regular file: it is {kind}") as e:
        parse_config(cfg)
    assert e.value.key == "paths[0].file"
    cfg["robot"] = {"urdf": path}
    with pytest.raises(SweepConfigError, match=f"is not a regular file: it is {kind}") as e:
        parse_config(cfg)
    assert e.value.key == "robot.urdf"
    if kind != "a folder":
        with pytest.raises(ValueError, match=f"sweep config: .* is not a regular file: it is {kind}"):
            load_config(path)


# ------------------------------------------------------------------ format_csv
def test_format_csv_takes_a_path_and_refuses_what_it_cannot_write(tmp_path):
    p = line([0.5, 0, 0.3], [0.6, 0.1, 0.3], 4)
    text = format_csv(p)
    assert text == format_csv(p.points, p.directions) and len(text.splitlines()) == 5
    f = tmp_path / "p.csv"
    f.write_text(text)
    back = Path.from_csv(f)
    assert np.array_equal(back.points, p.points) and np.array_equal(back.directions, p.directions)
    with pytest.raises(ValueError, match=r"points of shape \(P, 3\), got \(1, 4, 3\)"):
        format_csv(p.as_batch())
    with pytest.raises(ValueError, match=r"points of shape \(P, 3\)"):
        format_csv(np.zeros((0, 3)))
    with pytest.raises(ValueError, match="directions must have the shape"):
        format_csv(p.points, p.directions[:2])


# ------------------------------------------------------------------ half precision
def test_half_precision_refused_at_the_boundaries():
    pts = np.array([[0.5, 0.0, 0.3], [0.55, 0.05, 0.3]])
    with pytest.raises(ValueError, match="points has dtype float16"):
        Path(pts.astype(np.float16))
    with pytest.raises(ValueError, match="directions has dtype float16"):
        Path(pts, np.ones((2, 3), np.float16))
    lwr = jaxstiff.Robot.from_urdf("kuka_lwr4")
    with pytest.raises(ValueError, match="shape: q0 has dtype float16"):
        jaxstiff.shape(lwr, Path(pts), "f2", 5.0, q0=np.zeros(7, np.float16))
    with pytest.raises(ValueError, match="shape: kj0 has dtype bfloat16"):
        import jax.numpy as jnp

        jaxstiff.shape(lwr, Path(pts), "f2", 5.0, kj0=jnp.ones(7, jnp.bfloat16))
    planar = jaxstiff.Robot.from_urdf("planar_3r")
    q0 = np.deg2rad([75, -74.74, -76.30])
    for kw, name in (
        ({"q0": q0.astype(np.float16)}, "q0"),
        ({"K_xd": np.diag([3000.0, 1000]).astype(np.float16)}, "K_xd"),
    ):
        args = {"q0": q0, "K_xd": np.diag([3000.0, 1000]), **kw}
        with pytest.raises(ValueError, match=f"csc_rollout: {name} has dtype float16"):
            jaxstiff.csc_rollout(planar, np.tile([1.5, 0.0], (5, 1)), args["K_xd"], args["q0"], 1e-3, step="constant")


# ------------------------------------------------------------------ bounded messages (for the URDF parser's lists)
def test_short_list_and_text_bound_a_message():
    from jaxstiff.runtime._messages import short_list, short_text

    names = [f"link_{i}" for i in range(2_000_000)]
    msg = short_list(names)
    assert len(msg) < 200 and msg.endswith("... and 1999990 more (2000000 in all)") and msg.startswith("link_0, link_1")
    assert short_list(["a", "b"]) == "a, b" and short_list([]) == ""
    t = short_text("1 " * 10**6)
    assert len(t) < 120 and t.endswith("(2000000 characters)")
    assert short_text("1 2 3") == repr("1 2 3")
