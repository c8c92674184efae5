"""jaxstiff.plots: the shared pieces of the experiment scripts (figure saving, ellipse and arm
geometry, the u / Frobenius and seven-panel figures, the --out parser, summary tables).

References are independent of the code under test: the PNG signature and header read back with
``struct``, the ellipse equation, a closed-form planar forward kinematics, ``csv.DictReader``."""

from __future__ import annotations

import csv
import os
import struct
import subprocess
import sys
import types

import numpy as np
import pytest
from helpers import assert_close, numpy_fk

from jaxstiff import plots

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


def png_size(file):
    """(width, height) in pixels from the IHDR chunk; fails unless the file is a PNG."""
    with open(file, "rb") as fh:
        head = fh.read(24)
    assert head[:8] == PNG_SIGNATURE, f"{file} is not a PNG"
    assert head[12:16] == b"IHDR"
    return struct.unpack(">II", head[16:24])


def leftovers(folder):
    return [f for f in os.listdir(folder) if f.startswith(".tmp")]


@pytest.mark.slow
def test_import_does_not_pull_matplotlib():
    code = "import sys, jaxstiff.plots; print('matplotlib' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "False"


def test_pyplot_is_agg():
    plt = plots.pyplot()
    assert plt.get_backend().lower() == "agg"


@pytest.mark.parametrize("crop", [False, True])
def test_save_figure_writes_a_png_and_closes_the_figure(tmp_path, crop):
    plt = plots.pyplot()
    fig, ax = plt.subplots(figsize=(4, 3))
    ax.plot([0, 1], [0, 1])
    file = tmp_path / "sub" / "fig.png"  # the folder is created
    assert plots.save_figure(fig, file, dpi=50, crop=crop) == str(file)
    w, h = png_size(file)
    if crop:
        assert 0 < w <= 4 * 50 + 10 and 0 < h <= 3 * 50 + 10
    else:
        assert (w, h) == (200, 150)
    assert not plt.fignum_exists(fig.number)
    assert leftovers(file.parent) == []


def test_save_figure_leaves_no_partial_file_when_drawing_fails(tmp_path):
    plt = plots.pyplot()
    fig, _ = plt.subplots()
    file = tmp_path / "fig.png"
    file.write_bytes(b"earlier figure")

    def failing_savefig(fh, **kw):
        fh.write(PNG_SIGNATURE + b"half a figure")
        raise RuntimeError("drawing failed")

    fig.savefig = failing_savefig
    with pytest.raises(RuntimeError, match="drawing failed"):
        plots.save_figure(fig, file)
    assert file.read_bytes() == b"earlier figure"  # the earlier file is untouched
    assert leftovers(tmp_path) == [] and sorted(os.listdir(tmp_path)) == ["fig.png"]
    assert not plt.fignum_exists(fig.number)


def test_ellipse_points_satisfy_the_ellipse_equation():
    rng = np.random.default_rng(3)
    th = 0.7
    R = np.array([[np.cos(th), -np.sin(th)], [np.sin(th), np.cos(th)]])
    K = R @ np.diag([3000.0, 1000.0]) @ R.T  # N/m
    pts = plots.ellipse_points(K, 200)
    assert pts.shape == (200, 2)
    assert_close(pts[0], pts[-1])  # closed
    # {K u : |u| = 1}: x^T K^-2 x = 1, semi-axes 3000 along R e1 and 1000 along R e2
    Kinv = np.linalg.inv(K)
    assert_close(np.einsum("ni,ij,nj->n", pts, Kinv @ Kinv, pts), np.ones(200), rtol=1e-12)
    r = np.linalg.norm(pts, axis=1)
    assert_close(r.max(), 3000.0, rtol=1e-3)
    assert_close(r.min(), 1000.0, rtol=1e-3)
    assert abs(abs(pts[np.argmax(r)] @ R[:, 0]) / r.max() - 1) < 1e-3
    # the same curve as the direct parametrisation K (cos t, sin t)
    u = rng.normal(size=(50, 2))
    x = (K @ (u / np.linalg.norm(u, axis=1, keepdims=True)).T).T
    assert np.all(np.min(np.linalg.norm(x[:, None] - pts[None], axis=-1), axis=1) < 3000 * 2 * np.pi / 199)
    with pytest.raises(ValueError, match="2x2"):
        plots.ellipse_points(np.eye(3))


def test_chain_points_match_closed_form_planar_arm():
    import jaxstiff

    robot = jaxstiff.Robot.from_urdf("planar_4r")  # four 1 m links in the xy plane
    q = np.random.default_rng(0).uniform(-2, 2, size=4)
    pts = plots.chain_points(robot, q)
    c = np.cumsum(q)
    ref = np.vstack([[0.0, 0.0], np.cumsum(np.stack([np.cos(c), np.sin(c)], -1), axis=0)])
    assert pts.shape == (5, 3)
    assert_close(pts[:, :2], ref, atol=1e-12)
    assert_close(pts[:, 2], np.zeros(5), atol=1e-12)
    assert_close(pts[-1], numpy_fk(robot, q)[:3, 3], atol=1e-12)


def test_figure_u_frobenius(tmp_path):
    k = np.arange(11)
    u = np.stack([100 - k, 100 - 2 * k]).astype(float)
    fr = np.stack([50 - k, 50 - 3 * k]).astype(float)
    file = plots.figure_u_frobenius(k, u, fr, ["beta = 0", "beta = 1"], tmp_path / "u.png", suptitle="test", dpi=40)
    assert png_size(file) == (12 * 40, int(4.5 * 40))
    with pytest.raises(ValueError, match=r"len\(labels\), len\(steps\)"):
        plots.figure_u_frobenius(k, u, fr[:, :5], ["a", "b"], tmp_path / "bad.png")
    with pytest.raises(ValueError, match="frobenius"):
        plots.figure_u_frobenius(k, u, fr, ["only one label"], tmp_path / "bad.png")
    assert not os.path.exists(tmp_path / "bad.png")


def test_figure_u_frobenius_marks_the_joint_limit_steps(tmp_path, monkeypatch):
    """A csc run that clamps a joint at its limit kinks u there; the figure marks those steps (a
    user saw the kink unexplained). The markers sit on the curve at exactly the flagged steps."""
    import matplotlib.axes

    k = np.arange(11)
    u = np.stack([100.0 - k, 100.0 - 2 * k])
    fr = np.stack([50.0 - k, 50.0 - 3 * k])
    flagged = np.zeros((2, 11), bool)
    flagged[1, [6, 7, 9]] = True
    drawn = []
    plot = matplotlib.axes.Axes.plot

    def spy(self, *args, **kwargs):
        drawn.append((args, kwargs))
        return plot(self, *args, **kwargs)

    monkeypatch.setattr(matplotlib.axes.Axes, "plot", spy)
    plots.figure_u_frobenius(k, u, fr, ["a", "b"], tmp_path / "u.png", dpi=40, limit_steps=flagged)
    marks = [(a, kw) for a, kw in drawn if len(a) > 2 and a[2] == "x"]
    assert len(marks) == 2  # path b on both panels; path a has none
    for (x, y, _), kw in marks:
        np.testing.assert_array_equal(x, [6, 7, 9])
        assert np.array_equal(y, u[1, [6, 7, 9]]) or np.array_equal(y, fr[1, [6, 7, 9]])
        assert kw["label"] == "b: joint at its limit (3 steps)"
    with pytest.raises(ValueError, match="limit_steps"):
        plots.figure_u_frobenius(k, u, fr, ["a", "b"], tmp_path / "bad.png", limit_steps=flagged[:1])


@pytest.mark.slow
def test_figure_shape_path_on_a_small_result(tmp_path):
    """The seven panels from a hand-made result (no solver run): the LWR along 6 waypoints of a line."""
    import jaxstiff

    robot = jaxstiff.Robot.from_urdf("kuka_lwr4", locked={"lwr_a7": 0.0})
    n, P = robot.n, 6
    q = np.deg2rad([10.0, 30.0, 0.0, -60.0, 0.0, 40.0, 0.0])[None] + np.linspace(0, 0.2, P)[:, None]
    q[:, 6] = 0.0  # lwr_a7 at its locked value
    pos = np.stack([numpy_fk(robot, qi)[:3, 3] for qi in q])
    d = np.diff(pos, axis=0, append=2 * pos[-1:] - pos[-2:-1])
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    kj = np.full((P, n), 50.0) + np.arange(n)
    kj[:, 6] = np.inf  # lwr_a7 rigid (the default for a locked joint): +inf in the file
    res = types.SimpleNamespace(
        P=P,
        n=n,
        joint_names=np.array(robot.joint_names),
        meta={"ratio": 5.0, "criterion": "f1", "c": 0.01, "task": "full"},
        q=q[None],
        kj=kj[None],
        kj_scaled=2 * kj[None],
        cms=np.full((1, P), 2.0),
        target=pos[None],
        direction=d[None],
        criterion=np.full((1, P), 0.5),
        alpha_deg=np.linspace(0, 3, P)[None],
        ratio=np.linspace(3, 6, P)[None],
    )
    file = plots.figure_shape_path(res, robot, tmp_path / "fig4.png", "test", every=2, dpi=20)
    w, h = png_size(file)
    assert w > 100 and h > 100
    assert leftovers(tmp_path) == []


def test_stiffness_axes_reassemble_the_stiffness():
    import jaxstiff

    robot = jaxstiff.Robot.from_urdf("kuka_lwr4", locked={"lwr_a7": 0.0})
    q = np.deg2rad([[10.0, 30.0, 0.0, -60.0, 0.0, 40.0, 0.0], [0.0, 45.0, 10.0, -80.0, 5.0, 20.0, 0.0]])
    kj = np.array([[50.0, 60, 70, 80, 90, 100, 110], [10.0, 20, 30, 40, 50, 60, 70]])
    lam, V = plots.stiffness_axes(robot, q, kj, "full")
    K = np.asarray(jaxstiff.translational_stiffness(jaxstiff.jacobian(robot, q), kj, task="full"))
    assert lam.shape == (2, 3) and V.shape == (2, 3, 3)
    assert np.all(np.diff(lam, axis=1) <= 0)  # descending
    assert_close(np.einsum("pij,pj,pkj->pik", V, lam, V), K, rtol=1e-9, atol=1e-9 * np.abs(K).max())


def test_experiment_parser():
    ap = plots.experiment_parser("fig9_demo", "line one\n  line two")
    assert ap.parse_args([]).out == os.path.join("out", "fig9_demo")
    assert ap.parse_args(["--out", "/tmp/x"]).out == "/tmp/x"
    assert "line one\n  line two" in ap.format_help()  # description kept as written


def test_tables(tmp_path):
    rows = [{"k": "0.5", "ratio": "2.5", "note": "a, b"}, {"k": "1", "ratio": "3", "note": 'say "x"'}]
    assert plots.markdown_table(rows) == [
        "| k | ratio | note |",
        "|---|---|---|",
        "| 0.5 | 2.5 | a, b |",
        '| 1 | 3 | say "x" |',
    ]
    file = plots.save_table_csv(rows, tmp_path / "summary.csv")
    with open(file, newline="", encoding="utf-8") as fh:
        assert list(csv.DictReader(fh)) == rows
    with open(file, "rb") as fh:
        assert fh.read().startswith(b"k,ratio,note\r\n")  # csv's usual line ends, as before
    with pytest.raises(ValueError, match="no rows"):
        plots.save_table_csv([], tmp_path / "empty.csv")
    assert plots.text_table(rows, width=6, sep="|") == [
        "     k| ratio|  note",
        "   0.5|   2.5|  a, b",
        '     1|     3|say "x"',
    ]
    with pytest.raises(ValueError, match="no rows"):
        plots.markdown_table([])
    with pytest.raises(ValueError, match="no rows"):
        plots.text_table([], width=4)
    assert sorted(os.listdir(tmp_path)) == ["summary.csv"]


@pytest.mark.slow
def test_figure_shape_path_planar_result_and_unusable_waypoints(tmp_path):
    """A task 'xy' result (2 x 2 K_T) is drawn (its ellipses flat in the path's plane; it failed
    with a broadcast error, found by an independent check); unusable waypoints are gaps in the
    panels (NaN), not the reference state the file holds for them; a path without any usable
    waypoint is refused by name."""
    import jaxstiff
    from jaxstiff.plots._shape_path import usable_only

    robot = jaxstiff.Robot.from_urdf("planar_3r")
    pts = np.c_[np.linspace(1.50, 1.58, 6), np.full(6, 0.5), np.zeros(6)]
    res = jaxstiff.shape(robot, jaxstiff.Path(pts), "f2", 5.0, task="xy")
    file = plots.figure_shape_path(res, robot, tmp_path / "xy.png", "xy", every=2, dpi=30)
    from PIL import Image

    img = np.asarray(Image.open(file).convert("L"), float)
    assert img.std() > 10.0  # not blank
    ok = np.array([True, True, False, True, False, True])
    masked = usable_only(res, 0, ok)
    assert np.all(np.isnan(masked.alpha_deg[0, ~ok])) and np.array_equal(masked.alpha_deg[0, ok], res.alpha_deg[0, ok])
    assert masked.target is res.target  # what is not masked is the result's own
    bad = types.SimpleNamespace(**{k: getattr(res, k) for k in ("P", "n", "meta", "q", "kj", "kj_scaled", "cms")})
    bad.status = np.full((1, 6), 3)
    with pytest.raises(ValueError, match="path 0 has no usable waypoint"):
        plots.figure_shape_path(bad, robot, tmp_path / "none.png", "none")
    assert not (tmp_path / "none.png").exists()
