"""The shape table says when its per-waypoint times include JAX compilation (issue 23: a 58 s run
showed 2.3 ms/waypoint; the trajectory solver's times include its compilation)."""

from __future__ import annotations

import types

import numpy as np

from jaxstiff.cli.shape import summary_table


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
    assert "includes up to 1.5 s of JAX compilation" in text and "'trajectory'" in text
    assert "compilation" not in summary_table(_res(0.0))
    assert "compilation" not in summary_table(_res(0.05))  # under 5% of 2 s: not worth a line
    short = _res(0.06)
    short.time_s = np.full((1, 4), 0.01)  # 6 % of 40 ms, but 0.06 s reads as "up to 0.1 s" at best: no line
    assert "compilation" not in summary_table(short)
