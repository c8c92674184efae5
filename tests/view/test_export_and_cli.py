"""`jaxstiff export` / `plot` / `view --html` on shape, csc, batch (B > 1, rigid locked joint) results,
the summaries of the result classes, and a third-party arm whose meshes are missing."""

from __future__ import annotations

import dataclasses
import os
import warnings

import numpy as np
import pytest
from viewer_files import MISSING_MESHES_URDF, make_csc_file, make_shape_result

import jaxstiff
from jaxstiff.cli import main
from jaxstiff.view._data import load_view_data
from jaxstiff.view._export import csv_columns, export_csv, read_csv


def test_csv_round_trip_shape(shape_file, tmp_path, lwr) -> None:
    out = str(tmp_path / "t.csv")
    assert main(["export", shape_file, "--csv", out]) == 0
    table = read_csv(out)
    res = jaxstiff.ShapeResult.load(shape_file)
    names = list(res.joint_names)
    assert list(table) == ["path", "index"] + [f"q_{j}_rad" for j in names] + [f"kj_{j}_Nm_per_rad" for j in names] + [
        f"kj_scaled_{j}_Nm_per_rad" for j in names
    ] + ["tcp_x_m", "tcp_y_m", "tcp_z_m", "status"]
    np.testing.assert_array_equal(table["status"], res.status.reshape(-1))
    q = np.stack([table[f"q_{j}_rad"] for j in names], axis=-1)
    np.testing.assert_array_equal(q, res.q.reshape(-1, res.n))
    np.testing.assert_array_equal(np.stack([table[f"kj_scaled_{j}_Nm_per_rad"] for j in names], -1), res.kj_scaled[0])
    np.testing.assert_array_equal(np.stack([table[f"kj_{j}_Nm_per_rad"] for j in names], -1), res.kj[0])
    tcp = np.asarray(jaxstiff.fk(lwr, q))[:, :3, 3]  # FK of the CSV's q reproduces the stored TCP
    np.testing.assert_allclose(tcp, res.position.reshape(-1, 3), rtol=0, atol=1e-9)
    np.testing.assert_allclose(np.stack([table["tcp_x_m"], table["tcp_y_m"], table["tcp_z_m"]], -1), tcp, atol=1e-9)


def test_csv_batch_rigid_and_csc(batch_file, csc_file, tmp_path) -> None:
    out = export_csv(batch_file, str(tmp_path / "b.csv"))
    table = read_csv(out)
    data = load_view_data(batch_file)
    assert data.B == 3 and sorted(set(table["path"])) == [0, 1, 2] and len(table["index"]) == 3 * data.P
    assert np.all(np.isinf(table["kj_lwr_a7_Nm_per_rad"]))  # rigid locked joint: inf, written and read back
    assert data.kj_lines(0, 0)[-1][1] == "rigid"
    assert np.all(np.isfinite(data.K))
    c = load_view_data(csc_file)
    assert c.kind == "csc" and "kj_scaled" not in " ".join(csv_columns(c))
    table = read_csv(export_csv(c, str(tmp_path / "c.csv"), path=1))
    np.testing.assert_array_equal(table["q_lwr_a2_rad"], c.q[1, :, 1])


def test_plot_and_html_every_kind(shape_file, batch_file, csc_file, tmp_path, capfd) -> None:
    pytest.importorskip("viser")
    for f in (shape_file, batch_file, csc_file):
        png = str(tmp_path / (os.path.basename(f) + ".png"))
        assert main(["plot", f, "--out", png, "--waypoints", "2"]) == 0
        assert os.path.getsize(png) > 10_000
    html = str(tmp_path / "b.html")
    capfd.readouterr()
    assert main(["view", batch_file, "--html", html, "--path", "2"]) == 0
    # the page is recorded from a server of its own, whose address and "Server stopped" viser printed
    # (a user writing a file was told of a live server on a random port)
    cap = capfd.readouterr()
    assert "Websocket" not in cap.out + cap.err and "(viser)" not in cap.out + cap.err, cap
    text = open(html).read()
    assert text.startswith("<!doctype html>") and "__VISER_EMBED_DATA__" in text
    svg, pdf = str(tmp_path / "x.svg"), str(tmp_path / "x.pdf")
    assert main(["plot", shape_file, "--out", svg]) == 0 and main(["plot", shape_file, "--out", pdf]) == 0
    assert open(svg, encoding="utf-8").read(400).lstrip().startswith("<?xml") and "<svg" in open(svg).read()
    assert open(pdf, "rb").read(5) == b"%PDF-"
    assert main(["plot", shape_file, "--out", str(tmp_path / "x.gif")]) == 2  # a one-line error, no file
    assert not os.path.exists(tmp_path / "x.gif")


def test_plot_pick_list_draws_those_waypoints(shape_file, tmp_path, capsys) -> None:
    """--waypoints 0,3,5: those ellipses (an uneven list, which a spacing cannot express); the
    picture differs from the spacing form's; an index past the end is a one-line error, no file."""
    from matplotlib.image import imread

    a, b = str(tmp_path / "picks.png"), str(tmp_path / "every.png")
    assert main(["plot", shape_file, "--out", a, "--waypoints", "0,3,5"]) == 0
    assert main(["plot", shape_file, "--out", b, "--waypoints", "2"]) == 0
    ia, ib = imread(a), imread(b)
    assert ia.shape != ib.shape or np.abs(ia - ib).max() > 0.1  # (cropped to the drawing: sizes may differ)
    capsys.readouterr()
    bad = str(tmp_path / "bad.png")
    assert main(["plot", shape_file, "--out", bad, "--waypoints", "0,999"]) == 2
    assert "index 999 is out of range" in capsys.readouterr().err and not os.path.exists(bad)


def test_missing_meshes_capsules_one_warning(tmp_path) -> None:
    viser = pytest.importorskip("viser")
    from jaxstiff.view._scene import Scene

    robot = jaxstiff.Robot.from_urdf(MISSING_MESHES_URDF)
    f = make_shape_result(robot, 1, 4, task="xyz").save(str(tmp_path / "arm4.npz"))
    data = load_view_data(f)
    server = viser.ViserServer(host="127.0.0.1", port=0 or 8093, verbose=False)
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            scene = Scene(server, data)
            scene.show(0, 3)
        msgs = [str(w.message) for w in caught if "mesh" in str(w.message)]
        assert len(msgs) == 1 and "capsules" in msgs[0] and "3 link mesh" in msgs[0]
        assert scene.capsules and not scene.meshes
    finally:
        server.stop()


def test_result_summaries_are_short(shape_file) -> None:
    res = jaxstiff.ShapeResult.load(shape_file)
    text = repr(res)
    assert len(text.splitlines()) == 1 and "8 waypoints" in text and "kuka_lwr4" in text and "solved 8" in text
    z = np.load(shape_file)  # a CSCResult from arrays of the right shapes
    B, P, n = z["q"].shape
    fields = {f.name: np.zeros((B, P)) for f in dataclasses.fields(jaxstiff.CSCResult)}
    fields.update(q=z["q"], kj=z["kj"], status=np.zeros((B, P), int), u_start=np.ones(B), frobenius_start=np.ones(B))
    text = str(jaxstiff.CSCResult(**fields))
    assert len(text.splitlines()) == 1 and f"{P} steps" in text and "ok" in text


def test_export_names_unusable_rows(shape_file, tmp_path, capsys) -> None:
    """Rows of waypoints without a usable solution (status 3-5) were written like solved ones, with
    nothing to tell them apart (found by an independent check): the status column carries the code
    and the command warns, naming them; a file without such rows gets no warning."""
    res = jaxstiff.ShapeResult.load(shape_file)
    status = np.array(res.status, copy=True)
    status[0, 1:3] = (3, 5)
    bad = tmp_path / "bad.npz"
    fields = {f: getattr(res, f) for f in res.arrays()} | {"status": status, "meta": res.meta}
    jaxstiff.ShapeResult(**fields).save(bad)
    out = str(tmp_path / "bad.csv")
    capsys.readouterr()
    assert main(["export", str(bad), "--csv", out]) == 0
    err = capsys.readouterr().err
    assert "2 rows are not usable solutions" in err and "path 0: waypoints 1-2" in err, err
    np.testing.assert_array_equal(read_csv(out)["status"], status.reshape(-1))
    assert main(["export", shape_file, "--csv", str(tmp_path / "ok.csv")]) == 0
    assert "warning" not in capsys.readouterr().err
    # --out, as every other command names its output, writes the same file
    assert main(["export", shape_file, "--out", str(tmp_path / "ok2.csv")]) == 0
    assert (tmp_path / "ok2.csv").read_bytes() == (tmp_path / "ok.csv").read_bytes()


def test_wrong_kind_of_file_and_output_folders_are_named(shape_file, csc_file, tmp_path, capsys) -> None:
    """A CSC file where a shape result is needed says so (it listed 12 missing keys); an output
    that is a folder is named without the temporary file's name (it showed '[Errno 21] ...
    .tmp-xxxx -> out'); check-sim's --json folder is checked before the simulation runs."""
    with pytest.raises(ValueError, match=r"a CSC result \(jaxstiff csc\); this needs a shape result"):
        jaxstiff.ShapeResult.load(csc_file)
    folder = tmp_path / "out"
    folder.mkdir()
    capsys.readouterr()
    assert main(["export", shape_file, "--csv", str(folder)]) == 2
    err = capsys.readouterr().err
    assert f"{folder} is a folder; give a file name inside it" in err and ".tmp" not in err, err
    assert main(["check-sim", shape_file, "--json", str(tmp_path / "nodir" / "x.json")]) == 2
    cap = capsys.readouterr()  # out and err of the same call: the simulation never ran
    assert "--json: folder does not exist: " in cap.err and "agree" not in cap.out, cap
    assert os.listdir(folder) == []


@pytest.mark.parametrize("every", ["0", "-2"])
def test_view_every_below_one_is_refused(csc_file, tmp_path, capsys, every) -> None:
    """``--every 0`` was clamped to 1 without a word (an independent check)."""
    pytest.importorskip("viser")
    html = tmp_path / "v.html"
    assert main(["view", csc_file, "--html", str(html), "--every", every]) == 2
    err = capsys.readouterr().err.strip()
    assert err == f"jaxstiff: error: --every must be a whole number >= 1 (every N-th waypoint's ellipsoid), got {every}"
    assert not html.exists()


@pytest.mark.parametrize("meta_bits", [True, False])  # the file's meta["status_bits"], or the library's
def test_export_of_a_csc_file_explains_the_status_bit_mask(lwr, tmp_path, capsys, meta_bits) -> None:
    """A csc file's status is a bit mask, not the shape codes: export says so (an independent check
    read status 10 as a shape code)."""
    from jaxstiff.csc import STATUS_NAMES

    bits = {str(k): v for k, v in STATUS_NAMES.items()} if meta_bits else {}  # as jaxstiff csc writes it
    src = make_csc_file(lwr, str(tmp_path / "c.npz"), T=3, status=np.array([[0, 10, 2]]), status_bits=bits)
    out = str(tmp_path / "c.csv")
    assert main(["export", src, "--csv", out]) == 0
    text = " ".join(capsys.readouterr().out.split())
    assert "status column (csc file): a bit mask per step, not the shape codes 0-5: 0 a plain step; " in text
    assert (
        "1 damped (near singular), 2 joint limit reached, 4 NaN guard (step dropped), "
        "8 null-space gradient below null_eps; a step with several flags has their sum" in text
    ), text
    assert read_csv(out)["status"].tolist() == [0, 10, 2]  # the column itself is unchanged


@pytest.mark.parametrize("command", [["export", "--csv"], ["view", "--html"]])
def test_an_output_that_is_the_input_file_is_refused_and_the_input_kept(shape_file, tmp_path, capsys, command) -> None:
    import shutil

    src = str(tmp_path / "mine.npz")
    shutil.copy(shape_file, src)
    before = open(src, "rb").read()
    same = os.path.join(str(tmp_path), ".", "mine.npz")  # another spelling of the same file
    assert main([command[0], src, command[1], same]) == 2
    err = capsys.readouterr().err
    assert "is the RESULT file itself" in err and "mine.npz" in err
    assert open(src, "rb").read() == before  # not overwritten
    assert load_view_data(src).kind == "shape"


def test_view_html_into_a_folder_or_a_missing_folder_is_refused_before_viser_starts(
    shape_file, tmp_path, capsys, monkeypatch
) -> None:
    """``view --html DIR`` started viser's server and built the scene before the write failed
    (stop 34's review); now the target is checked first, like every other output flag."""
    viser = pytest.importorskip("viser")

    def no_server(*a, **k):
        raise AssertionError("viser's server was started")

    monkeypatch.setattr(viser, "ViserServer", no_server)
    folder = tmp_path / "pages"
    folder.mkdir()
    assert main(["view", shape_file, "--html", str(folder)]) == 2
    assert f"--html: {folder} is a folder; give a file name inside it, like shape.html" in capsys.readouterr().err
    assert main(["view", shape_file, "--html", str(tmp_path / "nodir" / "v.html")]) == 2
    assert "--html: folder does not exist: " in capsys.readouterr().err
    assert os.listdir(folder) == []


@pytest.mark.parametrize(
    "command",
    [["export", "--csv", "x.csv"], ["plot", "--out", "x.png"], ["view", "--html", "x.html"], ["export", "--out", "x"]],
)
def test_an_output_that_is_a_pipe_is_refused_and_kept(shape_file, tmp_path, capsys, command) -> None:
    """`export --csv fifo.csv`, `plot --out` and `view --html` onto a pipe or a device exited 0 and
    replaced it with a plain file (the file written beside it was renamed onto it; run as root on
    /dev/stdout it replaced the link /dev/stdout itself); `shape --out` alone refused it."""
    import stat

    folder = tmp_path / "outs"
    folder.mkdir()
    fifo = folder / command[2]
    os.mkfifo(fifo)
    capsys.readouterr()
    assert main([command[0], shape_file, command[1], str(fifo)]) == 2
    err = capsys.readouterr().err
    assert "not a regular file (a device or a pipe)" in err, err
    assert stat.S_ISFIFO(os.lstat(fifo).st_mode)  # still the pipe
    assert os.listdir(folder) == [command[2]]  # and nothing written beside it


def test_an_output_through_a_link_writes_the_linked_file_and_keeps_the_link(shape_file, tmp_path, capsys) -> None:
    """A symbolic link as the output was replaced by a plain file, the file it pointed to left as
    it was: the link stays now, and the file it points to gets the output (in its own folder)."""
    elsewhere, here = tmp_path / "elsewhere", tmp_path / "here"
    elsewhere.mkdir()
    here.mkdir()
    target = elsewhere / "real.csv"
    target.write_text("old\n")
    link = here / "link.csv"
    link.symlink_to(target)
    assert main(["export", shape_file, "--csv", str(link)]) == 0
    assert link.is_symlink() and os.readlink(link) == str(target)
    assert read_csv(target)["index"].size > 0 and target.read_text() != "old\n"
    assert "wrote " + str(link) in capsys.readouterr().out
    # a link to a result file: shape's --out keeps it too
    res_link = here / "res.npz"
    res_link.symlink_to(elsewhere / "res_real.npz")  # dangling until written
    jaxstiff.ShapeResult.load(shape_file).save(res_link)
    assert res_link.is_symlink() and (elsewhere / "res_real.npz").is_file()
    assert sorted(os.listdir(here)) == ["link.csv", "res.npz"]
    assert sorted(os.listdir(elsewhere)) == ["real.csv", "res_real.npz"]


def test_export_to_standard_output(shape_file, tmp_path, capsys) -> None:
    """`--csv -` wrote a file named '-'; it is standard output now (the CSV alone: what the command
    says goes to stderr), the same text as the file."""
    capsys.readouterr()
    assert main(["export", shape_file, "--csv", "-"]) == 0
    cap = capsys.readouterr()
    file = tmp_path / "same.csv"
    assert main(["export", shape_file, "--csv", str(file)]) == 0
    assert cap.out == file.read_text(), cap.out[:200]
    assert "wrote the CSV to standard output" in cap.err
    assert not os.path.exists("-")
