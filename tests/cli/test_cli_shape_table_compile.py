"""The shape table says when its per-waypoint times include JAX compilation (issue 23: a 58 s run
showed 2.3 ms/waypoint; the trajectory solver's times include its compilation)."""

from __future__ import annotations

import types

import numpy as np

import jaxstiff
from jaxstiff.cli._shape import summary_table


def _res(inside: float) -> types.SimpleNamespace:
    P = 4
    return types.SimpleNamespace(
        B=1,
        P=P,
        meta={"criterion": "f2", "ratio": 5.0, "solver": "trajectory", "timing_s": {"compile_in_time_s": inside}},
        alpha_deg=np.zeros((1, P)),
        ratio=np.full((1, P), 5.0),
        status=np.zeros((1, P), int),
        pos_error=np.zeros((1, P)),
        time_s=np.full((1, P), 0.5),  # 2 s in all
    )


def test_footnote_when_compilation_is_inside_the_times():
    text = summary_table(_res(1.5))
    assert "include up to 1.5 s of JAX compilation" in text and "'trajectory'" in text
    assert "median ms/wp" in text.splitlines()[0]  # the column is the median: a note says what it leaves out
    assert "compilation" not in summary_table(_res(0.0))
    assert "compilation" not in summary_table(_res(0.05))  # under 5% of 2 s: not worth a line
    short = _res(0.06)
    short.time_s = np.full((1, 4), 0.01)  # 6 % of 40 ms, but 0.06 s reads as "up to 0.1 s" at best: no line
    assert "compilation" not in summary_table(short)


def test_shape_shares_count_usable_waypoints_only():
    # an independent check read "usable 17 %, in target 67 %": unreachable waypoints (status 3)
    # whose off-path posture happens to have the wanted shape counted as in target
    res = _res(0.0)
    res.status = np.array([[0, 3, 3, 4]])
    row = summary_table(res).splitlines()[1].split()
    assert row[2:7] == ["25%", "25%", "25%", "25%", "25%"]  # solved, usable, alpha, rho, in target


def test_pgd_times_are_run_time_only_and_its_progress_line_counts_the_waypoints(tmp_path, capsys):
    # pgd's time_s is its compiled program's run alone: no footnote, however long the compilation;
    # and the batch solvers tick no waypoint, so the final line read "shape: 0/3 waypoints"
    from jaxstiff.cli import main

    csv = tmp_path / "p.csv"
    np.savetxt(
        csv, np.c_[np.linspace(1.5, 1.52, 3), np.full(3, 0.5), np.zeros(3)], delimiter=",", header="x,y,z", comments=""
    )
    out = tmp_path / "r.npz"
    args = ["shape", "--robot", "planar_3r", "--task", "xy", "--ratio", "3", "--path", str(csv), "--solver", "pgd"]
    assert main([*args, "--starts", "2", "--out", str(out)]) == 0
    err = capsys.readouterr().err
    assert "shape: 3/3 waypoints" in err and "0/3" not in err
    res = jaxstiff.ShapeResult.load(out)
    assert res.meta["timing_s"]["compile_in_time_s"] == 0.0
    assert "compilation" not in summary_table(res)
