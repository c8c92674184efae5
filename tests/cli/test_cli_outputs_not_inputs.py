"""No command writes over one of its inputs (issue 42: ``check-sim RESULT --json RESULT`` replaced
the result with JSON, ``--json ROBOT.urdf`` the URDF).

Every output flag of every command (and the global ``--compile-cache``) is tried against every
input of that command, as the same path, through a symlink and through a hard link: each must end
in exit 2 before any work, with one line naming both flags, and the file unchanged. The flags are
found from the parser, so a new command or a new path flag that is not declared with
:func:`jaxstiff.cli._common.reads` / :func:`~jaxstiff.cli._common.writes` fails here.
"""

from __future__ import annotations

import argparse
import os
import re

import pytest

from jaxstiff.cli import build_parser, main
from jaxstiff.cli._common import FileFlag, check_outputs_not_inputs, file_flags

#: each command's other required arguments (values that need not exist: the check comes first)
REQUIRED: dict[str, list[str]] = {
    "robot": [],
    "shape": [],
    "csc": ["--kxd", "1,1", "--q0", "0,0,0", "--hold", "1,0", "--out", "unused.npz"],
    "sweep": ["--out", "unused-dir"],
    "reproduce": ["--out", "unused-dir"],
    "check-sim": [],
    "view": [],
    "plot": ["--out", "unused.png"],
    "export": ["--csv", "unused.csv"],
}
#: each command's positional inputs: a placeholder when not under test
#: (command, input flag) -> the required flag it stands in for (one of a mutually exclusive pair)
INSTEAD_OF = {("csc", "--path"): "--hold"}
POSITIONAL = {
    "robot": "URDF",
    "sweep": "CONFIG.toml",
    "check-sim": "RESULT",
    "view": "RESULT",
    "plot": "RESULT",
    "export": "RESULT",
}

_PATHLIKE_METAVAR = re.compile(r"FILE|DIR|OUT|CSV|URDF|TOML|NPZ|PNG|HTML|JSON|\.\w")
_PATHLIKE_HELP = re.compile(r"\b(file|folder|directory|write|writes|written)\b", re.I)


def _parsers():
    parser = build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return parser, dict(sub.choices)


def _looks_like_a_path(a: argparse.Action) -> bool:
    if a.nargs == 0 or a.dest == "help" or a.type not in (None, str) or a.choices is not None:
        return False
    if not a.option_strings:  # every positional argument of the commands is a path
        return True
    return bool(_PATHLIKE_METAVAR.search(str(a.metavar or ""))) or bool(_PATHLIKE_HELP.search(a.help or ""))


def test_every_path_flag_is_declared():
    parser, subs = _parsers()
    assert set(subs) == set(REQUIRED), "a new command: add its required arguments to REQUIRED"
    for name, sp in [("(global)", parser), *subs.items()]:
        for a in sp._actions:
            if isinstance(a, argparse._SubParsersAction):
                continue
            declared = getattr(a, "jaxstiff_file", None) is not None
            if _looks_like_a_path(a):
                assert declared, f"{name} {a.option_strings or a.dest}: a path flag not declared with reads()/writes()"


def _argv(cmd, values: dict[str, str], global_out: str | None = None) -> list[str]:
    """The command line with the given flag values (shown name -> value) and placeholders elsewhere."""
    words = list(REQUIRED[cmd])
    pos = POSITIONAL.get(cmd)
    for flag in values:
        other = INSTEAD_OF.get((cmd, flag))
        if other in words:
            del words[words.index(other) : words.index(other) + 2]
    for flag, v in values.items():
        if flag.startswith("--"):
            if flag in words:
                words[words.index(flag) + 1] = v
            else:
                words += [flag, v]
    head = [values.get(pos, "placeholder-input")] if pos else []
    return (["--compile-cache", global_out] if global_out else []) + [cmd] + head + words


def _pairs():
    parser, subs = _parsers()
    glob = [f for f in file_flags(parser) if f[2].writes]
    for cmd, sp in subs.items():
        flags = file_flags(sp)
        outs = [(shown, role, False) for _, shown, role in flags if role.writes]
        outs += [(shown, role, True) for _, shown, role in glob]
        ins = [shown for _, shown, role in flags if not role.writes]
        for out, role, is_global in outs:
            for inp in ins:
                yield cmd, out, role, is_global, inp


PAIRS = list(_pairs())


def test_every_command_with_an_output_has_pairs():
    cmds = {p[0] for p in PAIRS}
    assert {"shape", "csc", "sweep", "reproduce", "check-sim", "view", "plot", "export", "robot"} <= cmds
    assert ("check-sim", "--json", "RESULT") in {(c, o, i) for c, o, _, _, i in PAIRS}
    assert ("check-sim", "--json", "--urdf") in {(c, o, i) for c, o, _, _, i in PAIRS}


@pytest.mark.parametrize("link", ["same", "symlink", "hardlink"])
@pytest.mark.parametrize(
    ("cmd", "out", "role", "is_global", "inp"), PAIRS, ids=[f"{p[0]}:{p[1]}<-{p[4]}" for p in PAIRS]
)
def test_output_over_input_is_refused(tmp_path, monkeypatch, capsys, cmd, out, role, is_global, inp, link):
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("JAXSTIFF_COMPILE_CACHE", "0")
    name = "input" + (role.suffix or ".dat")
    (tmp_path / name).write_bytes(b"the input\n")
    if link == "same":
        out_path = name
    elif link == "symlink":
        os.symlink(name, "alias" + (role.suffix or ".dat"))
        out_path = "alias" + (role.suffix or ".dat")
    else:
        os.link(name, "hard" + (role.suffix or ".dat"))
        out_path = "hard" + (role.suffix or ".dat")
    values = {inp: name}
    if not is_global:
        values[out] = out_path
    rc = main(_argv(cmd, values, out_path if is_global else None))
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2
    assert len(err) == 1 and err[0].startswith("jaxstiff: error: "), err
    assert out in err[0] and inp in err[0], err[0]
    assert (tmp_path / name).read_bytes() == b"the input\n"
    assert sorted(os.listdir(tmp_path)) == sorted({name, out_path})  # nothing else written


def test_folder_output_that_would_write_an_input(tmp_path, monkeypatch, capsys):
    """A sweep's --out folder gets summary.md, plots/, ...: a config there would be replaced."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "runs" / "plots").mkdir(parents=True)
    (tmp_path / "runs" / "summary.md").write_text("[robot]\n")
    (tmp_path / "runs" / "plots" / "c.toml").write_text("[robot]\n")
    for config in ("runs/summary.md", "runs/plots/c.toml"):
        assert main(["sweep", config, "--out", "runs", "--dry-run"]) == 2
        err = capsys.readouterr().err
        assert "CONFIG.toml" in err and "--out" in err and config in err
    # an existing file inside an input folder (a sweep folder read by view/export) is an input too
    (tmp_path / "runs" / "chunks").mkdir()
    (tmp_path / "runs" / "results.parquet").write_bytes(b"table")
    assert main(["export", "runs", "--row", "0", "--csv", "runs/results.parquet"]) == 2
    assert "RESULT input folder" in capsys.readouterr().err
    assert (tmp_path / "runs" / "results.parquet").read_bytes() == b"table"


def test_shipped_robot_name_is_its_file(tmp_path, capsys):
    """``--robot planar_3r`` reads the shipped URDF: writing over that file is refused too."""
    from jaxstiff.model import robot_path

    urdf = robot_path("planar_3r")
    before = open(urdf, "rb").read()
    assert main(["--compile-cache", urdf, "robot", "--robot", "planar_3r"]) == 2
    assert "is the --robot file itself" in capsys.readouterr().err
    assert open(urdf, "rb").read() == before


def test_outputs_that_are_not_inputs_pass(tmp_path):
    """No false refusal: distinct files, outputs that do not exist yet, a suffix that makes another
    file, and a resumed sweep reading the config it keeps in its folder."""
    (tmp_path / "a.npz").write_bytes(b"a")
    (tmp_path / "b.npz").write_bytes(b"b")
    (tmp_path / "runs").mkdir()
    (tmp_path / "runs" / "config.toml").write_text("")
    flags = [
        ("out", "--out", FileFlag(writes=True, suffix=".npz")),
        ("json", "--json", FileFlag(writes=True)),
        ("result", "RESULT", FileFlag(writes=False)),
        ("paths", "--path", FileFlag(writes=False)),
    ]
    ok = [
        argparse.Namespace(out=str(tmp_path / "b.npz"), json=None, result=str(tmp_path / "a.npz"), paths=None),
        argparse.Namespace(out=str(tmp_path / "new"), json=str(tmp_path / "x.json"), result=None, paths=None),
        argparse.Namespace(out=str(tmp_path / "a"), json=None, result=None, paths=[str(tmp_path / "a")]),
    ]
    for ns in ok:
        check_outputs_not_inputs(ns, flags)
    # with the .npz the command adds, "--out a" is a.npz: refused when a.npz is an input
    with pytest.raises(ValueError, match="--out"):
        check_outputs_not_inputs(
            argparse.Namespace(out=str(tmp_path / "a"), json=None, result=None, paths=[str(tmp_path / "a.npz")]), flags
        )
    from jaxstiff.cli._sweep import SWEEP_WRITES

    sweep = [("config", "CONFIG.toml", FileFlag(writes=False)), ("out", "--out", FileFlag(True, True, SWEEP_WRITES))]
    check_outputs_not_inputs(
        argparse.Namespace(config=str(tmp_path / "runs" / "config.toml"), out=str(tmp_path / "runs")), sweep
    )
