"""`jaxstiff shape`: a small run end to end (file verified with the independent numpy FK), --help with
units, every bad input of the acceptance list -> one-line error, exit 2, no output file; Ctrl-C -> no file."""

import os
import re
import subprocess
import sys

import numpy as np
import pytest
from helpers import numpy_fk

import jaxstiff
from jaxstiff.cli import main
from jaxstiff.results import _files as R


@pytest.fixture
def small_csv(tmp_path):
    p = jaxstiff.default_path()
    path = jaxstiff.Path(p.points[:3], p.directions[:3])
    f = tmp_path / "small.csv"
    path.to_csv(f)
    return f


@pytest.mark.slow
def test_small_run_end_to_end(tmp_path, small_csv, capsys):
    out = tmp_path / "res.npz"
    rc = main(["shape", "--path", str(small_csv), "--out", str(out), "--first-starts", "2"])
    cap = capsys.readouterr()
    assert rc == 0, cap.err
    assert "a<1deg" in cap.out and "wrote" in cap.out  # the summary table
    assert "3/3 waypoints" in cap.err  # the progress bar
    res = jaxstiff.ShapeResult.load(out)
    assert res.q.shape == (1, 3, 7) and res.meta["robot"]["locked"] == {"lwr_a7": 0.0}
    assert res.meta["path_files"] == [str(small_csv)]
    robot = jaxstiff.Robot.from_urdf(res.meta["robot"]["urdf"], locked=res.meta["robot"]["locked"])
    for p in range(3):
        assert np.linalg.norm(numpy_fk(robot, res.q[0, p])[:3, 3] - res.target[0, p]) < 1e-9
    v = R.verify(res)
    assert v["max_rate_violation"] <= 1e-9 and v["max_bound_violation"] <= 1e-9
    assert [f for f in os.listdir(tmp_path) if f.startswith(".tmp")] == []


def test_two_paths_one_file_and_options(tmp_path, small_csv, capsys):
    p2 = tmp_path / "shifted.csv"
    base = jaxstiff.Path.from_csv(small_csv)
    jaxstiff.Path(base.points + [0.0, 0.0, 0.02], base.directions).to_csv(p2)
    out = tmp_path / "two.npz"
    rc = main(
        [
            "shape",
            "--path",
            str(small_csv),
            "--path",
            str(p2),
            "--out",
            str(out),
            "--quiet",
            "--criterion",
            "f2",
            "--ratio",
            "4",
            "--dq-deg",
            "3",
            "--dk",
            "8",
            "--kmin",
            "2",
            "--kmax",
            "90",
            "--kj0",
            "40",
            "--first-starts",
            "2",
        ]
    )
    cap = capsys.readouterr()
    assert rc == 0, cap.err
    # --quiet: nothing at all, as long as no warning is due. With one first-waypoint start this
    # case is on a knife edge: SLSQP's first waypoint on path 0 ends at the optimum (f2 = 1) or
    # in a local minimum (f2 = 14.3, then the end-of-run warning) depending on gradients that
    # differ in the 16th digit (seen with a closed-form kinematics JVP, docs/notes/speed.md);
    # two starts reach the optimum either way
    assert cap.out == "" and cap.err == ""
    res = jaxstiff.ShapeResult.load(out)
    assert res.B == 2 and res.meta["ratio"] == 4.0
    assert np.allclose(res.meta["limits"]["dq"], np.radians(3.0)) and res.meta["limits"]["kmin"] == 2.0
    free = res.kj[..., :6]  # lwr_a7 is rigid (the default): kj = kj0 = inf
    assert np.all(res.kj0[:, :6] == 40.0) and np.all(free >= 2.0) and np.all(free <= 90.0)
    assert np.all(res.kj0[:, 6] == np.inf) and np.all(res.kj[..., 6] == np.inf)


def test_unreachable_waypoints_warn_on_stderr_and_the_file_is_complete(tmp_path, small_csv, capsys):
    base = jaxstiff.Path.from_csv(small_csv)
    far = tmp_path / "far.csv"
    # waypoint 0 mirrored through the base's axis: within reach, but not within the rate limits of waypoint 0
    # (a waypoint out of reach is refused before the solve: tests/model/test_reach.py)
    mirrored = base.points[:1] * [-1.0, -1.0, 1.0]
    jaxstiff.Path(np.vstack([base.points[:1], mirrored]), base.directions[:2]).to_csv(far)
    out = tmp_path / "far.npz"
    rc = main(["shape", "--path", str(far), "--out", str(out), "--quiet", "--first-starts", "1"])
    err = capsys.readouterr().err
    assert rc == 0 and out.exists()
    assert re.search(r"warning: 1 of 2 waypoints have no usable solution .*path 0: 1 of 2", err), err
    status = jaxstiff.ShapeResult.load(out).status[0]
    assert R.is_usable(status[0]) and status[1] == R.UNREACHABLE


def test_help_has_units(capsys):
    with pytest.raises(SystemExit):
        main(["shape", "--help"])
    text = " ".join(capsys.readouterr().out.split())  # argparse wraps lines
    for needle in ("degrees per waypoint", "Nm/rad per waypoint", "metres", "--lock", "--first-rate-limit", "rad"):
        assert needle in text, needle


def _bad(tmp_path, name, text):
    f = tmp_path / name
    f.write_text(text)
    return str(f)


@pytest.mark.parametrize(
    "args, match",
    [
        (lambda t: ["--path", str(t / "missing.csv")], "not found"),
        (lambda t: ["--path", _bad(t, "h.csv", "a,b\n1,2\n3,4\n")], "header must be"),
        (lambda t: ["--path", _bad(t, "n.csv", "x,y,z\n0.6,0.2,0.3\n0.6,nan,0.3\n")], "not finite"),
        (lambda t: ["--path", _bad(t, "one.csv", "x,y,z\n0.6,0.2,0.3\n")], "at least 2 waypoints"),
        (
            lambda t: ["--path", _bad(t, "z.csv", "x,y,z\n0.6,0.2,0.3\n0.6,0.2,0.3\n0.6,0.1,0.3\n")],
            "zero-length segment",
        ),
        (lambda t: ["--ratio", "1"], "ratio must be > 1 and at most 1e+06"),
        (lambda t: ["--ratio", "inf"], "ratio must be > 1 and at most 1e+06"),
        (lambda t: ["--ratio", "1e16"], "ratio must be > 1 and at most 1e+06"),
        (lambda t: ["--ratio", "abc"], "--ratio: expected a number"),
        (lambda t: ["--kmin", "0"], "0 < kmin < kmax"),
        (lambda t: ["--kmin", "60", "--kmax", "50"], "0 < kmin < kmax"),
        (lambda t: ["--dq-deg", "-1"], "--dq-deg must be >= 0"),
        (lambda t: ["--dk", "-2"], "--dk must be >= 0"),
        (lambda t: ["--lock", "elbow=0"], "unknown joint 'elbow'"),
        (lambda t: ["--lock", "lwr_a7"], "JOINT=RAD"),
        (lambda t: ["--lock", "none", "--lock", "lwr_a7=0"], "--lock none (no joint locked) cannot be combined"),
        (lambda t: ["--q0", "0.1,0.2,0.3"], "--q0 needs 7 values"),
        (lambda t: ["--q0", "3.5,0,0,0,0,0,0"], "outside its limits"),
        (lambda t: ["--kj0", "500"], "outside"),
        (lambda t: ["--solver", "magic"], "unknown solver"),
        (lambda t: ["--robot", str(t / "typo.urdf")], "URDF file not found"),  # not "no shipped robot"
        (lambda t: ["--robot", str(t)], "is not a regular file"),  # a folder
        (lambda t: ["--out", str(t / "no" / "dir" / "x.npz")], "folder does not exist"),
        (lambda t: ["--out", str(t)], "is a folder"),
        (
            lambda t: ["--path", str(t)],
            "is a folder; give a CSV file",
        ),  # was "not found"  # was written beside it as <folder>.npz
        (lambda t: ["--out", "/proc/x.npz"], "cannot write into folder /proc"),  # found before the work
        (lambda t: ["--criterion", "f1", "--c", "0"], "c must be > 0 for criterion f1"),  # ran, ignoring R
        (lambda t: ["--solver", "pgd", "--starts", "2.5"], "--starts: expected an integer, got '2.5'"),
        (lambda t: ["--solver", "pgd", "--option", "itres=10"], "unknown option(s) for solver 'pgd': 'itres'"),
        (lambda t: ["--solver", "pgd", "--option", "iters=ten"], "pgd option 'iters' must be an integer"),
        (lambda t: ["--option", "maxiter"], "--option 'maxiter': expected KEY=VALUE"),
        (lambda t: ["--option", "maxiter=5", "--option", "maxiter=6"], "--option 'maxiter' is given twice"),
    ],
)
def test_bad_input_one_line_exit_2_no_file(tmp_path, capsys, args, match):
    out = tmp_path / "out.npz"
    argv = ["shape", "--out", str(out), "--quiet"] + args(tmp_path)
    if "--out" in argv[3:]:
        argv = ["shape", "--quiet"] + args(tmp_path)
    rc = main(argv)
    err = capsys.readouterr().err
    assert rc == 2
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("jaxstiff: error:"), err
    assert match in lines[0], lines[0]
    assert not out.exists()
    assert [f for f in os.listdir(tmp_path) if f.endswith(".npz") or f.startswith(".tmp")] == []


def test_option_flags_reach_the_solver_and_its_record(tmp_path, small_csv, capsys):
    """--option KEY=VALUE sets a solver object's field from the command line (the docs said so
    before the flag existed): the values are typed (int, float, bool, text), the run uses them and
    meta["options"] records them. SLSQP limited to 1 iteration per waypoint cannot converge: the
    statuses say so, where the default run converges."""
    from jaxstiff.cli._shape import read_options

    assert read_options(["iters=60", "ftol=1e-6", "polish_slsqp=all", "surrogate=false", "kj_scale=none"]) == {
        "iters": 60,
        "ftol": 1e-6,
        "polish_slsqp": "all",
        "surrogate": False,
        "kj_scale": None,
    }
    out = tmp_path / "one_iter.npz"
    argv = ["shape", "--path", str(small_csv), "--out", str(out), "--quiet", "--first-starts", "1"]
    assert main([*argv, "--option", "maxiter=1", "--option", "first_maxiter=1"]) in (0, 3), capsys.readouterr().err
    res = jaxstiff.ShapeResult.read(out)
    assert res.meta["options"]["maxiter"] == 1 and res.meta["options"]["first_maxiter"] == 1
    assert res.meta["cli"]["option"] == ["maxiter=1", "first_maxiter=1"]
    assert not np.any(res.status == R.SOLVED)  # one iteration converges nowhere
    assert main([*argv, "--out", str(tmp_path / "default.npz")]) == 0
    assert np.all(jaxstiff.ShapeResult.read(tmp_path / "default.npz").status == R.SOLVED)
    # a choice whose value is the word none ("--option target_step=none", pgd's "first_exact=none"):
    # the command line reads none as None, and the choice was refused ("must be one of 'retry',
    # 'slsqp', 'none', got None"); it is the choice "none" now
    assert main([*argv, "--out", str(tmp_path / "nostep.npz"), "--option", "target_step=none"]) == 0
    assert jaxstiff.ShapeResult.read(tmp_path / "nostep.npz").meta["options"]["target_step"] == "none"
    assert read_options(["first_exact=none", "target_step=None", "kj_scale=none"]) == {
        "first_exact": "none",
        "target_step": "none",
        "kj_scale": None,  # an optional number: None
    }


def test_ctrl_c_leaves_no_file(tmp_path, small_csv, capsys, monkeypatch):
    import jaxstiff.shaping as shaping

    real = shaping.SOLVERS["slsqp"]

    def interrupted(req):
        req.progress(0, 0)
        raise KeyboardInterrupt

    monkeypatch.setitem(shaping.SOLVERS, "slsqp", interrupted)
    out = tmp_path / "res.npz"
    rc = main(["shape", "--path", str(small_csv), "--out", str(out), "--quiet"])
    assert rc == 130
    assert "interrupted" in capsys.readouterr().err
    assert sorted(os.listdir(tmp_path)) == ["small.csv"]
    assert shaping.SOLVERS["slsqp"] is not real


@pytest.mark.parametrize("command", ["robot", "shape", "csc", "sweep", "reproduce"])
def test_help_states_each_default_once_and_never_none(command, capsys):
    with pytest.raises(SystemExit):
        main([command, "--help"])
    text = " ".join(capsys.readouterr().out.split())  # argparse wraps lines
    assert "(default: None)" not in text
    assert not re.search(r"\(default: [^)]*\) \(default:", text), text  # stated in words, then by argparse


def _swallowed_sigint():
    """A SIGINT that is only remembered, not raised (as when JAX swallows the KeyboardInterrupt in a
    callback): delivered inside deferred_interrupts, the command's handler records it."""
    import signal

    from jaxstiff.runtime._io import deferred_interrupts, interrupt_pending

    with deferred_interrupts():
        os.kill(os.getpid(), signal.SIGINT)
        for _ in range(100):  # the handler runs at the next bytecode boundary of the main thread
            if interrupt_pending() is not None:
                break
    assert interrupt_pending() == signal.SIGINT


def _main_thread_only():
    import threading

    if threading.current_thread() is not threading.main_thread():
        pytest.skip("signal handlers can only be installed in the main thread")


def test_sigterm_during_the_save_still_writes_the_complete_file(tmp_path, small_csv, capsys, monkeypatch):
    """SIGTERM (a scheduler's kill, `timeout`) is handled like Ctrl-C: exit 143 and a message. When
    it arrives while the finished result is written (before, a partial .tmp-*.npz of 200 MB was
    left behind), the write completes first: the file is whole and verifies, no temporary file
    remains."""
    import signal

    _main_thread_only()
    before = signal.getsignal(signal.SIGTERM), signal.getsignal(signal.SIGINT)
    written = {}
    real_savez = np.savez

    def savez_with_sigterm(fh, **arrays):
        written["tmp"] = [f for f in os.listdir(tmp_path) if f.startswith(".tmp-")]
        os.kill(os.getpid(), signal.SIGTERM)  # in the middle of the write
        real_savez(fh, **arrays)

    monkeypatch.setattr(np, "savez", savez_with_sigterm)
    out = tmp_path / "res.npz"
    rc = main(["shape", "--path", str(small_csv), "--out", str(out), "--quiet", "--first-starts", "1"])
    err = capsys.readouterr().err
    assert rc == 143 and "interrupted (SIGTERM)" in err and "wrote the complete result" in err
    assert len(written["tmp"]) == 1  # the signal came while the temporary file existed
    assert sorted(os.listdir(tmp_path)) == ["res.npz", "small.csv"]
    back = jaxstiff.ShapeResult.load(out)
    assert R.is_usable(back.status).all() and R.verify(back)["max_pos_error"] <= 1e-9
    # the command's handlers are removed again (SIGINT is SIG_IGN, not Python's default handler,
    # where pytest itself was started as a background job)
    assert (signal.getsignal(signal.SIGTERM), signal.getsignal(signal.SIGINT)) == before


def test_atomic_write_removes_its_temporary_file_on_an_interrupt(tmp_path):
    from jaxstiff.runtime._io import atomic_write

    def half_then_ctrl_c(fh):
        fh.write(b"partial")
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        atomic_write(tmp_path / "r.npz", half_then_ctrl_c, binary=True)
    assert os.listdir(tmp_path) == []


def test_an_interrupt_swallowed_inside_jax_stops_the_run_at_the_next_waypoint(tmp_path, small_csv, capsys, monkeypatch):
    """Python delivers Ctrl-C wherever the main thread is; inside JAX's garbage-collection callback
    it is printed and dropped, and the run went on to write its file and exit 0. The handler
    remembers the signal, and the next waypoint raises it again."""
    import jaxstiff.shaping as shaping

    _main_thread_only()
    calls = []

    def solver(req):
        req.progress(0, 0)
        _swallowed_sigint()  # as after a KeyboardInterrupt lost in a callback
        calls.append("before")
        req.progress(0, 1)
        calls.append("after")  # never reached
        raise AssertionError("the run went on")

    monkeypatch.setitem(shaping.SOLVERS, "slsqp", solver)
    out = tmp_path / "res.npz"
    rc = main(["shape", "--path", str(small_csv), "--out", str(out), "--quiet"])
    assert rc == 130 and calls == ["before"] and not out.exists()
    assert "interrupted (SIGINT)" in capsys.readouterr().err


def test_no_usable_waypoint_exits_3_with_the_file_written(tmp_path, small_csv, capsys):
    far = tmp_path / "far.csv"
    # 0.4 m below the base: inside the LWR's reach shell (0.71 m from the shoulder), but no posture
    # within the joint limits gets there (the closest of 400,000 random postures is 0.15 m away)
    jaxstiff.Path(np.array([[0.0, 0.0, -0.4], [0.0, 0.02, -0.4]])).to_csv(far)
    out = tmp_path / "far.npz"
    rc = main(["shape", "--path", str(far), "--out", str(out), "--first-starts", "1"])
    cap = capsys.readouterr()
    err = cap.err
    assert rc == 3 and out.exists()
    assert "nan" not in cap.out and " n/a " in cap.out  # the summary's max position error of no usable waypoint
    assert "2 of 2 waypoints have no usable solution" in err and "robot's reach" in err
    assert not R.is_usable(jaxstiff.ShapeResult.load(out).status).any()


def test_interrupt_keeps_the_finished_waypoints(tmp_path, small_csv, capsys, monkeypatch):
    """Ctrl-C during a two-path SLSQP run, after 5 of 6 waypoints: the file is written with the 5
    finished ones (they verify from the file alone, rate limits included) and the last as
    NOT_RUN (5) at its reference state; exit 130, and stderr says what was kept."""
    import jaxstiff.cli._shape as cs

    _main_thread_only()
    real = cs.WaypointProgress.__call__

    def tick(self, b, p):
        real(self, b, p)
        if self.done == 4:
            _swallowed_sigint()  # raised at the next waypoint's tick

    monkeypatch.setattr(cs.WaypointProgress, "__call__", tick)
    out = tmp_path / "part.npz"
    argv = [
        "shape",
        "--path",
        str(small_csv),
        "--path",
        str(small_csv),
        "--out",
        str(out),
        "--quiet",
        "--first-starts",
        "1",
    ]
    rc = main(argv)
    err = capsys.readouterr().err
    assert rc == 130 and out.exists(), err
    assert "with the 5 of 6 waypoints finished" in err and "interrupted (SIGINT)" in err
    back = jaxstiff.ShapeResult.load(out)
    assert back.meta["interrupted"] is True
    assert (
        R.is_usable(back.status[0]).all() and R.is_usable(back.status[1, :2]).all() and back.status[1, 2] == R.NOT_RUN
    )
    np.testing.assert_array_equal(back.q[1, 2], back.q[1, 1])  # the reference state, unchanged
    v = R.verify(back)
    assert v["max_pos_error"] <= 1e-9 and v["max_bound_violation"] <= 0.0 and v["max_rate_violation"] <= 1e-12
    # interrupted again onto the same --out, where a file already is (an earlier result: found in
    # an audit, a stray Ctrl-C on a re-run replaced a complete file by a part): kept, the part beside it
    before = out.read_bytes()
    rc = main(argv)
    err = capsys.readouterr().err
    beside = tmp_path / "part.interrupted.npz"
    assert rc == 130 and out.read_bytes() == before and beside.exists(), err
    assert f"wrote {beside}" in err and f"the earlier {out} is kept as it was" in err, err
    assert jaxstiff.ShapeResult.load(beside).meta["interrupted"] is True


def test_a_second_interrupt_while_the_finished_part_is_assembled_still_writes_it(
    tmp_path, small_csv, capsys, monkeypatch
):
    """A user who presses Ctrl-C twice: the second arrives while shape() assembles the finished
    waypoints into a result (before, a KeyboardInterrupt there lost every finished waypoint and
    wrote nothing). It is now only remembered until the file is written; exit 130."""
    import signal

    import jaxstiff.cli._shape as cs
    import jaxstiff.shaping._shape as sh
    from jaxstiff.runtime._io import interrupt_pending

    _main_thread_only()
    real_tick, real_assemble = cs.WaypointProgress.__call__, sh.assemble_result
    seen = []

    def tick(self, b, p):
        real_tick(self, b, p)
        if self.done == 1:
            _swallowed_sigint()  # the first Ctrl-C: raised at the next waypoint's tick

    def assemble(*a, **k):
        os.kill(os.getpid(), signal.SIGINT)  # the second one, a real signal through the command's handler
        for _ in range(1000):  # the handler runs at the next bytecode boundary of the main thread
            seen.append(interrupt_pending())
        return real_assemble(*a, **k)

    monkeypatch.setattr(cs.WaypointProgress, "__call__", tick)
    monkeypatch.setattr(sh, "assemble_result", assemble)
    out = tmp_path / "part.npz"
    rc = main(["shape", "--path", str(small_csv), "--out", str(out), "--first-starts", "1"])
    err = capsys.readouterr().err
    assert seen and rc == 130 and out.exists(), err
    assert "with the 2 of 3 waypoints finished before it" in err and "saving what was finished first" in err
    back = jaxstiff.ShapeResult.load(out)
    assert back.meta["interrupted"] is True
    assert R.is_usable(back.status[0, :2]).all() and back.status[0, 2] == R.NOT_RUN


def test_library_interrupt_carries_the_finished_part():
    """shape() raises ShapeInterrupted, a KeyboardInterrupt that holds the finished part."""
    from jaxstiff.shaping import ShapeInterrupted

    p = jaxstiff.default_path()
    path = jaxstiff.Path(p.points[:3], p.directions[:3])
    calls = []

    def progress(b, k):
        calls.append(k)
        if k == 1:
            raise KeyboardInterrupt

    lwr = jaxstiff.Robot.from_urdf("kuka_lwr4", locked={"lwr_a7": 0.0})
    with pytest.raises(KeyboardInterrupt) as info:
        jaxstiff.shape(lwr, path, "f2", 5.0, first_starts=1, progress=progress)
    assert isinstance(info.value, ShapeInterrupted) and calls == [0, 1]
    res = info.value.result
    assert list(res.status[0, 2:]) == [R.NOT_RUN] and R.is_usable(res.status[0, :2]).all()
    assert res.meta["interrupted"] is True and np.all(np.isfinite(res.alpha_deg))


@pytest.mark.slow
def test_a_signal_while_the_command_starts_up_stops_it():
    """Ctrl-C in the second the command spends importing JAX used to land in JAX's GC callback,
    be printed and dropped, and the command ran to the end with exit 0. Started as the command
    (argv[0] 'jaxstiff'), the command line's first import (jaxstiff.cli -> runtime.command_start)
    now remembers the signal and the command stops before any work with exit 130; imported as a
    library (``import jaxstiff``), the handlers are left alone."""
    # a background job inherits SIGINT ignored, and Python then leaves it so: start as a terminal would
    dfl = "import signal; signal.signal(signal.SIGINT, signal.default_int_handler)\n"
    code = dfl + (
        "import os, signal, sys\n"
        "sys.argv[0] = 'jaxstiff'\n"
        "import jaxstiff.runtime._command_start  # what the console script's import of jaxstiff.cli runs first\n"
        "os.kill(os.getpid(), signal.SIGINT)  # during the start-up: remembered, not raised\n"
        "from jaxstiff.cli import main\n"
        "sys.exit(main(['robot', '--robot', 'planar_3r']))\n"
    )
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert res.returncode == 130 and "interrupted (SIGINT)" in res.stderr, (res.returncode, res.stderr)
    assert "planar_3r" not in res.stdout  # no work was done
    lib = dfl + (
        "import signal, jaxstiff\n"
        "assert signal.getsignal(signal.SIGINT) is signal.default_int_handler\n"
        "assert signal.getsignal(signal.SIGTERM) is signal.SIG_DFL\n"
    )
    assert subprocess.run([sys.executable, "-c", lib], capture_output=True, timeout=120).returncode == 0


def test_a_bad_input_prints_no_progress_line_and_npz_in_capitals_is_kept(tmp_path, small_csv, capsys):
    """Without --quiet a refused input printed 'shape: 0/60 waypoints in 0.0 s' before its error;
    --out r.NPZ wrote r.NPZ.npz (numpy's suffix test is case-sensitive); --criterion F2 is f2."""
    assert main(["shape", "--kmin", "10", "--kmax", "5", "--out", str(tmp_path / "x.npz")]) == 2
    err = capsys.readouterr().err
    assert err.strip().splitlines() == [
        "jaxstiff: error: need finite 0 < kmin < kmax (Nm/rad), got kmin=10.0, kmax=5.0"
    ]
    (tmp_path / "o").mkdir()
    out = tmp_path / "o" / "r.NPZ"
    argv = ["shape", "--path", str(small_csv), "--criterion", "F2", "--out", str(out), "--quiet"]
    assert main(argv) == 0
    assert sorted(os.listdir(tmp_path / "o")) == ["r.NPZ"]
    assert jaxstiff.ShapeResult.load(out).meta["criterion"] == "f2"


def test_the_shape_command_runs_jax_with_synchronous_cpu_dispatch(tmp_path, small_csv):
    """`jaxstiff shape` sets synchronous CPU dispatch before JAX starts its backend (SLSQP's tiny
    kernels cost twice as much per waypoint with async dispatch); a backend check that started
    the backend earlier for every command silently undid it (the README job 3.4 -> 6.7-10 ms per
    waypoint). In a fresh process, as a user runs it: meta records the setting in force."""
    out = tmp_path / "r.npz"
    p = subprocess.run(
        [sys.executable, "-m", "jaxstiff", "shape", "--path", str(small_csv), "--out", str(out), "--quiet"],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert p.returncode == 0, p.stderr
    assert jaxstiff.ShapeResult.load(out).meta["jax_cpu_async_dispatch"] is False


def test_a_backend_jax_cannot_start_is_one_line(tmp_path):
    """JAX_PLATFORMS naming a platform JAX cannot start gave a 59-line traceback ending in a bare
    AssertionError from inside JAX (exit 1); now one line naming the setting, exit 2, no file."""
    env = {**os.environ, "JAX_PLATFORMS": "nosuchplatform"}
    out = tmp_path / "r.npz"
    p = subprocess.run(
        [sys.executable, "-m", "jaxstiff", "shape", "--out", str(out)],
        env=env,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert p.returncode == 2, p.stderr
    lines = p.stderr.strip().splitlines()
    assert len(lines) == 1 and "JAX could not start a backend (JAX_PLATFORMS='nosuchplatform')" in lines[0], p.stderr
    assert not out.exists()
