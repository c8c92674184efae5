"""Readers that cannot be hung or misled by a result file, and the viewer's numeric flags (issue 42).

A result file whose meta ``robot.urdf`` names ``/dev/zero``, a FIFO, a folder, a file over the
size bound, or the integer 0 (a file descriptor: stdin) hung view, plot, export and check-sim in
the URDF's hash read; each must now end at once in exit 2 with one line naming the field. Each
command runs in a thread with a deadline, so a hang fails the test instead of stopping the run.
``--urdf`` with another robot is refused (it was used silently); the same file moved is not.
``view --port`` outside 1-65535 or taken, and ``--scale inf``, are refused before the server starts.
"""

from __future__ import annotations

import json
import os
import shutil
import socket
import threading

import numpy as np
import pytest

from jaxstiff.cli import main
from jaxstiff.runtime._io import MAX_URDF_BYTES

DATA = os.path.join(os.path.dirname(os.path.dirname(__file__)), "data")


def _run(argv: list[str], deadline_s: float = 120.0) -> int:
    """``main(argv)`` in a thread; a run still going at the deadline (a hang) fails the test."""
    box: dict[str, int] = {}
    t = threading.Thread(target=lambda: box.setdefault("rc", main(argv)), daemon=True)
    t.start()
    t.join(deadline_s)
    assert not t.is_alive(), f"jaxstiff {' '.join(argv)}: still running after {deadline_s} s (hangs)"
    return box["rc"]


def _with_urdf(src: str, dst: str, value: object) -> str:
    """A copy of result file ``src`` whose meta robot.urdf is ``value``."""
    with np.load(src, allow_pickle=False) as z:
        arrays = {k: z[k] for k in z.files}
    meta = json.loads(str(arrays["meta"]))
    meta["robot"]["urdf"] = value
    arrays["meta"] = np.asarray(json.dumps(meta))
    np.savez(dst, **arrays)
    return dst


def _hostile_targets(tmp_path) -> dict[str, object]:
    fifo = str(tmp_path / "fifo.urdf")
    os.mkfifo(fifo)
    big = tmp_path / "big.urdf"
    with open(big, "wb") as f:  # sparse: no disk used
        f.truncate(MAX_URDF_BYTES + 1)
    (tmp_path / "folder.urdf").mkdir()
    return {
        "dev-zero": "/dev/zero",
        "fifo": fifo,
        "folder": str(tmp_path / "folder.urdf"),
        "huge": str(big),
        "int-0": 0,
        "list": ["a.urdf"],
    }


COMMANDS = {
    "view": lambda f, t: ["view", f, "--html", str(t / "v.html")],
    "plot": lambda f, t: ["plot", f, "--out", str(t / "p.png")],
    "export": lambda f, t: ["export", f, "--csv", str(t / "e.csv")],
    "check-sim": lambda f, t: ["check-sim", f],
}


@pytest.mark.parametrize("command", sorted(COMMANDS))
def test_a_hostile_recorded_urdf_is_refused_not_read(shape_file, tmp_path, capsys, command) -> None:
    if command == "check-sim":
        pytest.importorskip("mujoco")
    for kind, value in _hostile_targets(tmp_path).items():
        f = _with_urdf(shape_file, str(tmp_path / f"hostile-{kind}.npz"), value)
        assert _run(COMMANDS[command](f, tmp_path)) == 2, kind
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and "robot.urdf" in err[0], (kind, err)
        assert "Traceback" not in err[0]
        if kind == "huge":
            assert "MiB" in err[0]
        if kind in ("fifo", "folder", "dev-zero"):
            assert "not a regular file" in err[0]
    leftovers = {p for p in os.listdir(tmp_path) if p.endswith((".html", ".png", ".csv"))}
    assert not leftovers  # nothing written


def test_urdf_flag_must_be_the_results_robot(shape_file, tmp_path, capsys) -> None:
    from jaxstiff.model import robot_path

    ur10 = os.path.join(DATA, "robots", "ur10.urdf")
    renamed = str(tmp_path / "renamed.urdf")  # the LWR's chain under another robot's name
    with open(renamed, "w") as f:
        f.write(open(robot_path("kuka_lwr4")).read().replace('<robot name="kuka_lwr4"', '<robot name="other_arm"'))
    for command in ("plot", "export"):
        argv = COMMANDS[command](shape_file, tmp_path)
        assert _run(argv + ["--urdf", ur10]) == 2
        assert "ur10.urdf" in capsys.readouterr().err  # (its links are not the result's)
        assert _run(argv + ["--urdf", renamed]) == 2
        err = capsys.readouterr().err
        assert "not the robot of the result" in err and "'other_arm'" in err and "'kuka_lwr4'" in err, err
    # the same robot moved (a byte copy), and a reformatted copy (other bytes, same chain): accepted
    moved = str(tmp_path / "moved.urdf")
    shutil.copy(robot_path("kuka_lwr4"), moved)
    assert _run(["export", shape_file, "--csv", str(tmp_path / "a.csv"), "--urdf", moved]) == 0
    text = open(moved).read()
    reformatted = str(tmp_path / "reformatted.urdf")
    with open(reformatted, "w") as f:
        f.write(text.replace("<robot", "<!-- a comment -->\n<robot", 1))
    assert _run(["export", shape_file, "--csv", str(tmp_path / "b.csv"), "--urdf", reformatted]) == 0
    assert open(tmp_path / "a.csv").read() == open(tmp_path / "b.csv").read()
    # a joint limit edited: another robot as far as the result is concerned
    with open(reformatted, "w") as f:
        f.write(text.replace('lower="-2.9670597283903604"', 'lower="-2.5"', 1))
    capsys.readouterr()
    assert _run(["export", shape_file, "--csv", str(tmp_path / "c.csv"), "--urdf", reformatted]) == 2
    assert "another lower" in capsys.readouterr().err
    assert not os.path.exists(tmp_path / "c.csv")


@pytest.mark.parametrize("port", ["0", "99999", "-1"])
def test_view_port_out_of_range_is_refused(shape_file, capsys, port) -> None:
    pytest.importorskip("viser")
    assert _run(["view", shape_file, "--port", port], deadline_s=60) == 2
    err = capsys.readouterr().err
    assert "--port must be a TCP port number 1-65535" in err and port in err


def test_view_port_taken_or_host_not_ours_is_refused(shape_file, capsys) -> None:
    pytest.importorskip("viser")
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        s.listen()
        port = s.getsockname()[1]
        assert _run(["view", shape_file, "--port", str(port)], deadline_s=60) == 2
    err = capsys.readouterr().err
    assert f"--port {port}: cannot serve on 127.0.0.1:{port}" in err
    assert _run(["view", shape_file, "--host", "no-such-host.invalid"], deadline_s=60) == 2
    assert "--host 'no-such-host.invalid'" in capsys.readouterr().err


@pytest.mark.parametrize("scale", ["inf", "nan", "0", "-3", "-inf"])
def test_view_scale_must_be_positive_and_finite(shape_file, tmp_path, capsys, scale) -> None:
    pytest.importorskip("viser")
    assert _run(["view", shape_file, f"--scale={scale}", "--html", str(tmp_path / "v.html")]) == 2
    assert "--scale must be a positive finite number" in capsys.readouterr().err
    assert not os.path.exists(tmp_path / "v.html")


def test_export_writes_no_csv_when_it_refuses(lwr, tmp_path, capsys) -> None:
    """A csc file whose meta status_bits is malformed was refused after its CSV was written."""
    from viewer_files import make_csc_file

    f = make_csc_file(lwr, str(tmp_path / "c.npz"), status_bits={"one": "damped"})
    out = tmp_path / "c.csv"
    assert _run(["export", f, "--csv", str(out)]) == 2
    assert "status_bits" in capsys.readouterr().err
    assert not out.exists()
    assert _run(["export", f, "--csv", str(out), "--path", "3"]) == 2
    assert "--path 3" in capsys.readouterr().err and not out.exists()
