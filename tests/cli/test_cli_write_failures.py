"""Outputs the system refuses, and output names that would not be the file written.

A tester with a full disk (a 40 kB tmpfs) found that `jaxstiff shape` solved, then exited 2
("bad input") with only "[Errno 28] No space left on device": the finished result was lost and no
file was named; on a read-only folder the message named the temporary file. `--out q.txt` wrote
`q.txt.npz` without a word, and `--out /dev/null` created `/dev/null.npz`. `plot --out` created
missing folders where every other command refuses them. Here the refusals are simulated by
making the write raise the system's own error (no root, no tmpfs needed).
"""

from __future__ import annotations

import errno
import os

import numpy as np
import pytest
from helpers import one_cli_error

import jaxstiff
from jaxstiff.cli import main
from jaxstiff.runtime import _io


def _full_disk_in(monkeypatch, folder):
    """Every atomic write into ``folder`` fails as on a full disk (ENOSPC while writing)."""
    real = _io.atomic_write

    def atomic_write(file, write, *, binary=False):
        if os.path.dirname(os.path.abspath(file)) == os.path.abspath(folder):

            def full(fh):
                raise OSError(errno.ENOSPC, "No space left on device")

            return real(file, full, binary=binary)
        return real(file, write, binary=binary)

    monkeypatch.setattr(_io, "atomic_write", atomic_write)
    import jaxstiff.results._npz as npz

    monkeypatch.setattr(npz, "atomic_write", atomic_write)


def test_atomic_write_names_the_file_not_its_temporary(tmp_path):
    def full(fh):
        raise OSError(errno.ENOSPC, "No space left on device")

    with pytest.raises(_io.WriteError) as e:
        _io.atomic_write(tmp_path / "r.npz", full, binary=True)
    assert str(e.value) == f"cannot write {tmp_path / 'r.npz'}: no space left on device"
    assert e.value.errno == errno.ENOSPC and isinstance(e.value, OSError)
    assert os.listdir(tmp_path) == []  # the temporary file is gone


@pytest.fixture
def short_path(tmp_path):
    p = jaxstiff.default_path()
    f = tmp_path / "short.csv"
    jaxstiff.Path(p.points[:2], p.directions[:2]).to_csv(f)
    return f


def test_a_full_disk_keeps_the_finished_result_elsewhere_and_says_where(tmp_path, short_path, capsys, monkeypatch):
    out_dir = tmp_path / "full"
    out_dir.mkdir()
    rescue = tmp_path / "cache"
    monkeypatch.setattr("platformdirs.user_cache_dir", lambda *a, **k: str(rescue))
    _full_disk_in(monkeypatch, out_dir)
    rc = main(["shape", "--path", str(short_path), "--out", str(out_dir / "x.npz"), "--quiet", "--first-starts", "1"])
    err = capsys.readouterr().err
    assert rc == 1, err  # not 2: the input was fine, the work ran
    assert f"cannot write {out_dir / 'x.npz'}: no space left on device" in err
    kept = sorted((rescue / "rescued").iterdir())
    assert len(kept) == 1 and kept[0].name.endswith("-x.npz") and f"written instead to {kept[0]}" in err
    res = jaxstiff.ShapeResult.read(kept[0])  # the whole result, readable
    assert res.q.shape == (1, 2, 7) and np.all(np.isfinite(res.q))
    assert os.listdir(out_dir) == []


def test_when_no_place_takes_the_result_the_message_says_it_is_lost(tmp_path, monkeypatch):
    def refuse(file):
        raise _io.WriteError(f"cannot write {file}: no space left on device", errno.ENOSPC)

    monkeypatch.setattr("platformdirs.user_cache_dir", lambda *a, **k: str(tmp_path / "cache"))
    monkeypatch.setattr("tempfile.gettempdir", lambda: str(tmp_path / "tmp"))
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    with pytest.raises(_io.WriteError, match="could not be written elsewhere either .*: it is lost"):
        _io.save_or_rescue(refuse, str(tmp_path / "x.npz"))


@pytest.mark.parametrize(
    "out, match",
    [
        ("q.txt", "a result file is written as .npz"),
        ("/dev/null", "/dev/null is not a regular file"),
    ],
)
def test_an_out_name_that_would_not_be_the_file_written_is_refused(tmp_path, capsys, out, match):
    before = set(os.listdir(tmp_path))
    line = one_cli_error(capsys, ["shape", "--quiet", "--out", out if out.startswith("/") else str(tmp_path / out)])
    assert match in line, line
    assert set(os.listdir(tmp_path)) == before
    assert not os.path.exists("/dev/null.npz")


def test_an_out_name_without_a_suffix_still_gets_npz():
    from jaxstiff.cli._common import check_out_file

    assert check_out_file("result").endswith(os.sep + "result.npz")
    assert check_out_file("run1.NPZ").endswith(os.sep + "run1.NPZ")


def test_plot_refuses_a_missing_folder_as_every_command_does(tmp_path, capsys):
    line = one_cli_error(capsys, ["plot", str(tmp_path / "no.npz"), "--out", str(tmp_path / "nd" / "b" / "x.png")])
    assert "folder does not exist" in line, line
    assert not (tmp_path / "nd").exists()


def test_csc_keeps_its_finished_rollout_elsewhere_too(tmp_path, capsys, monkeypatch):
    out_dir = tmp_path / "full"
    out_dir.mkdir()
    rescue = tmp_path / "cache"
    monkeypatch.setattr("platformdirs.user_cache_dir", lambda *a, **k: str(rescue))
    _full_disk_in(monkeypatch, out_dir)
    argv = ["csc", "--robot", "planar_3r", "--hold", "1.5,0.5", "--kxd", "3000,1000", "--q0-deg", "75,-74.74,-76.3"]
    rc = main([*argv, "--steps", "5", "--out", str(out_dir / "c.npz")])
    err = capsys.readouterr().err
    assert rc == 1 and f"cannot write {out_dir / 'c.npz'}: no space left on device" in err, err
    (kept,) = (rescue / "rescued").iterdir()
    assert f"written instead to {kept}" in err
    data = np.load(kept, allow_pickle=False)
    assert data["q"].shape[:2] == (1, 5) and np.all(np.isfinite(data["u"]))
