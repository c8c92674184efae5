"""Flags an adversarial run found taken wrongly (2026-12-07): an empty item in a comma-separated
list was skipped, so the values after it moved one place (`--kxd 3000,,1000` became a 2 x 2
K_xd and ran task `xy` on a 7-joint arm; `--tcp 0,,0.1` put the 0.1 meant for z into y), and
infinite targets were accepted and written to the result file as inf (`--cms-volume inf`,
`--cms-major inf`, `csc --kmin inf`). Each case now stops at argument checking with one line
naming the flag; no solver runs and nothing is written."""

from __future__ import annotations

import os

import pytest
from helpers import one_cli_error

from jaxstiff.cli import main
from jaxstiff.cli._common import parse_floats


@pytest.mark.parametrize(
    ("argv", "flag", "item"),
    [
        (
            ["csc", "--hold", "0.5,0,0.5", "--steps", "5", "--kxd", "3000,,1000", "--q0-deg", "0,30,0,-60,0,30,0"],
            "--kxd",
            2,
        ),
        (["shape", "--q0", "0,0.5,,0,-1,0,0.5,0"], "--q0", 3),
        (["shape", "--kj0", "10,,20,30,40,50,60"], "--kj0", 2),
        (["robot", "--tcp", "0,,0.1"], "--tcp", 2),
        (["robot", "--q", "0,0,0,0,0,0,0,"], "--q", 8),
    ],
    ids=["kxd", "q0", "kj0", "tcp", "q-trailing"],
)
def test_an_empty_item_in_a_list_is_refused(tmp_path, capsys, argv, flag, item) -> None:
    out = str(tmp_path / "r.npz")
    line = one_cli_error(capsys, [*argv, "--out", out] if argv[0] != "robot" else argv)
    assert f"{flag}: item {item} of " in line and "is empty" in line, line
    assert not os.path.exists(out)


def test_plot_waypoints_with_an_empty_index_is_refused() -> None:
    from jaxstiff.cli._plot import parse_waypoints

    with pytest.raises(ValueError, match="an index is empty"):
        parse_waypoints("1,,3", 10)
    assert parse_waypoints("1, 3", 10) == [1, 3]  # spaces stay allowed


def test_parse_floats_keeps_every_value_in_place() -> None:
    assert parse_floats(" 1, 2.5 ,-3 ", "--x") == [1.0, 2.5, -3.0]
    with pytest.raises(ValueError, match=r"--x: item 1 of ',2' is empty"):
        parse_floats(",2", "--x")
    with pytest.raises(ValueError, match=r"--x: expected comma-separated numbers"):
        parse_floats("1,a", "--x")


@pytest.mark.parametrize(
    ("argv", "says"),
    [
        (["shape", "--cms-volume", "inf"], "cms_volume must be a finite number > 0"),
        (["shape", "--cms-major", "inf"], "cms_major must be a finite number > 0"),
        (["shape", "--kmax", "inf"], "kmax"),
        (
            [
                "csc",
                "--robot",
                "planar_3r",
                "--hold",
                "1.5,0",
                "--steps",
                "5",
                "--kxd",
                "2500,1500@30",
                "--q0-deg",
                "75,-74.74,-76.3",
                "--kmin",
                "inf",
            ],
            "--kmin must be a finite number > 0",
        ),
    ],
    ids=["cms-volume", "cms-major", "shape-kmax", "csc-kmin"],
)
def test_an_infinite_target_or_range_is_refused(tmp_path, capsys, argv, says) -> None:
    out = str(tmp_path / "r.npz")
    line = one_cli_error(capsys, [*argv, "--out", out])
    assert says in line, line
    assert not os.path.exists(out)


def test_settings_refuse_an_infinite_stiffness_range() -> None:
    from jaxstiff.settings import CSCSettings, ShapeSettings

    with pytest.raises(ValueError, match="finite"):
        CSCSettings(kmin=float("inf"))
    with pytest.raises(ValueError, match="finite"):
        ShapeSettings(kmax=float("inf"))
    assert CSCSettings(kmax=float("inf")).kmax == float("inf")  # an open csc range stays allowed


@pytest.mark.parametrize(
    ("argv", "note"),
    [
        (["--c", "50"], "--c is the offset of criterion f1; unused with --criterion f2"),
        (["--dq-m", "0.001"], "--dq-m is the rate limit of prismatic joints; 'kuka_lwr4' has none, so it is unused"),
    ],
    ids=["c-with-f2", "dq-m-without-prismatic"],
)
def test_shape_warns_of_a_flag_it_does_not_read(tmp_path, capsys, monkeypatch, argv, note) -> None:
    """`--c 50` with f2 and `--dq-m` on an arm without prismatic joints gave results bit for bit the
    default run's, without a word; the note now comes before any work (here the solve is replaced
    by one that stops the command, so no solver runs)."""
    import jaxstiff.cli._shape as cli_shape

    def stop(*_a, **_k):
        raise ValueError("stopped before the solve")

    monkeypatch.setattr(cli_shape, "_solve_and_save", stop)
    rc = main(["shape", *argv, "--out", str(tmp_path / "r.npz")])
    err = capsys.readouterr().err
    assert rc == 2 and "stopped before the solve" in err, err
    assert f"jaxstiff: warning: {note}" in err, err
    rc = main(["shape", *argv, "--criterion", "f1", "--out", str(tmp_path / "r.npz")]) if argv[0] == "--c" else 2
    assert "warning" not in capsys.readouterr().err  # f1 reads --c


def test_a_default_lock_off_the_chain_says_it_is_the_default(capsys) -> None:
    """`jaxstiff robot --tip-link lwr_link_5` without --lock: the shipped LWR's default lock of
    lwr_a7 is off that chain; the error said so without saying the user never asked for it."""
    line = one_cli_error(capsys, ["robot", "--tip-link", "lwr_link_5"])
    assert "cannot lock joint 'lwr_a7'" in line and "is the shipped robot's default" in line and "--lock none" in line
    assert main(["robot", "--tip-link", "lwr_link_5", "--lock", "none"]) == 0
    capsys.readouterr()


def test_an_invalid_unused_c_is_refused_without_the_unused_warning(tmp_path, capsys) -> None:
    """`shape --c -1` with f2 warned that --c was unused, then refused its value: the two lines
    contradicted each other. The refusal now comes alone."""
    rc = main(["shape", "--c", "-1", "--out", str(tmp_path / "r.npz")])
    err = capsys.readouterr().err
    assert rc == 2 and "c must be a finite number >= 0, got -1.0" in err, err
    assert "warning" not in err, err
    assert not (tmp_path / "r.npz").exists()
