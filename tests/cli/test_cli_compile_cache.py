"""The global flags `--compile-cache DIR` / `--no-compile-cache` and JAXSTIFF_COMPILE_CACHE=0, each in a
fresh process (JAX decides per process): files in the folder with the cache on, none with it off; the
compile time apart on stderr and in meta["timing_s"] (a number, within the call's total)."""

import json
import os
import subprocess
import sys

import numpy as np
import pytest

import jaxstiff


@pytest.mark.slow
def test_cache_flags_and_compile_time_reported(tmp_path):
    p = jaxstiff.default_path()
    csv = tmp_path / "small.csv"
    jaxstiff.Path(p.points[:3], p.directions[:3]).to_csv(csv)
    env = {k: v for k, v in os.environ.items() if not k.startswith(("JAX_COMPILATION_CACHE", "JAXSTIFF_"))}
    shape = ["shape", "--path", str(csv), "--first-starts", "1"]
    runs = {
        "flag_on": (["--compile-cache", str(tmp_path / "on")], {}),
        "flag_off": (["--no-compile-cache"], {"JAXSTIFF_CACHE_DIR": str(tmp_path / "off_flag")}),
        "env_off": ([], {"JAXSTIFF_COMPILE_CACHE": "0", "JAXSTIFF_CACHE_DIR": str(tmp_path / "off_env")}),
    }
    procs = {
        name: subprocess.Popen(
            [sys.executable, "-m", "jaxstiff.cli", *flags, *shape, "--out", str(tmp_path / f"{name}.npz")],
            env={**env, **extra},
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        for name, (flags, extra) in runs.items()
    }
    outs = {name: pr.communicate(timeout=600) for name, pr in procs.items()}
    for name, pr in procs.items():
        assert pr.returncode == 0, outs[name][1]
    assert len(os.listdir(tmp_path / "on")) >= 1
    for d in ("off_flag", "off_env"):
        assert not (tmp_path / d).exists() or os.listdir(tmp_path / d) == []
    for name in runs:
        err = outs[name][1]
        assert "of which JAX compilation" in err, err
        meta = json.loads(str(np.load(tmp_path / f"{name}.npz")["meta"]))
        t = meta["timing_s"]
        assert isinstance(t["compile"], float) and 0.0 < t["compile"] <= t["total"]
        assert 0.0 <= t["compile_solve"] <= min(t["compile"], t["solve"]) + 1e-6
        assert t["run"] == pytest.approx(t["total"] - t["compile"], abs=1e-6)
        assert 0.0 <= t["compile_in_time_s"] <= t["compile_solve"] + 1e-9
        assert meta["compilation"]["programs"] >= 1
    cache_dirs = {n: json.loads(str(np.load(tmp_path / f"{n}.npz")["meta"]))["compilation"]["cache_dir"] for n in runs}
    assert cache_dirs == {"flag_on": str(tmp_path / "on"), "flag_off": None, "env_off": None}
    assert "no compilation cache" in outs["flag_off"][1]


def test_a_subcommands_own_no_compile_cache_turns_the_command_cache_off(monkeypatch):
    """`jaxstiff sweep ... --no-compile-cache` (the sweep's own flag) turned off only the sweep's
    workers' cache: the command-level cache stayed on and said "programs loaded from the cache"."""
    import argparse
    import contextlib
    import importlib

    cli_main = importlib.import_module("jaxstiff.cli._main")  # (the package exports a function named main)
    from jaxstiff.runtime import _compile_cache as compile_cache

    seen = []

    @contextlib.contextmanager
    def flags(no_cache, cache_dir):
        seen.append(no_cache)
        yield None

    monkeypatch.setattr(compile_cache, "compile_cache_flags", flags)
    base = {"command": "sweep", "global_no_compile_cache": False, "global_compile_cache": None, "quiet": True}
    for own, want in ((True, True), (False, False)):
        args = argparse.Namespace(**base, no_compile_cache=own, _run=lambda a: 0)
        assert cli_main._run_command(args) == 0
        assert seen[-1] is want
    args = argparse.Namespace(**{**base, "global_no_compile_cache": True}, _run=lambda a: 0)  # no own flag
    assert cli_main._run_command(args) == 0 and seen[-1] is True


def test_a_compile_cache_folder_that_cannot_be_used_is_said(monkeypatch, capsys):
    """`--compile-cache /proc/nope` ran without a cache and said so only in the timing line
    (which --quiet drops); it now warns before the command runs. A usable folder: no warning."""
    import argparse
    import contextlib
    import importlib

    cli_main = importlib.import_module("jaxstiff.cli._main")
    from jaxstiff.runtime import _compile_cache as compile_cache

    usable = {"/proc/nope": None, "/tmp/ok": "/tmp/ok"}

    @contextlib.contextmanager
    def flags(no_cache, cache_dir):
        yield None if no_cache else usable[cache_dir]

    monkeypatch.setattr(compile_cache, "compile_cache_flags", flags)
    base = {"command": "shape", "global_no_compile_cache": False, "quiet": True, "_run": lambda a: 0}
    assert cli_main._run_command(argparse.Namespace(**base, global_compile_cache="/proc/nope")) == 0
    assert "warning: --compile-cache /proc/nope: the folder cannot be made or written" in capsys.readouterr().err
    assert cli_main._run_command(argparse.Namespace(**base, global_compile_cache="/tmp/ok")) == 0
    assert "warning" not in capsys.readouterr().err


def test_cache_folder_from_the_environment_that_is_a_file_is_said(tmp_path):
    """JAXSTIFF_CACHE_DIR naming a file: the process runs without a cache and says so once (a
    warning naming the variable and the file), from the Python API and from a command alike."""
    afile = tmp_path / "not_a_folder"
    afile.write_text("x")
    env = {k: v for k, v in os.environ.items() if not k.startswith(("JAX_COMPILATION_CACHE", "JAXSTIFF_"))}
    env["JAXSTIFF_CACHE_DIR"] = str(afile)
    code = (
        "import warnings; warnings.simplefilter('error');"
        "from jaxstiff.runtime._compile_cache import ensure_compile_cache, CacheFolderWarning\n"
        "try:\n    ensure_compile_cache()\nexcept CacheFolderWarning as w:\n    print('WARNED', w)\n"
        "print('AGAIN', ensure_compile_cache())"
    )
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    assert f"WARNED compilation cache folder {afile} ($JAXSTIFF_CACHE_DIR): a file, not a folder" in out.stdout
    assert "AGAIN None" in out.stdout  # once per folder, and no cache in use
    cmd = subprocess.run(
        [sys.executable, "-m", "jaxstiff.cli", "robot", "planar_3r"],
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert cmd.returncode == 0, cmd.stderr
    assert f"warning: compilation cache folder {afile} ($JAXSTIFF_CACHE_DIR): a file, not a folder" in cmd.stderr
    assert afile.read_text() == "x"
