"""Hand-made results for the figure tests: no solver run, just the fields the plot functions read.
Plain functions the tests call with their own arrays (tests/figures/test_turning_figure.py,
test_prismatic_plots.py)."""

from __future__ import annotations

import types

import numpy as np


def arc_result(q, kj, path, dq, dk, alpha_deg) -> types.SimpleNamespace:
    """A hand-made one-path f2 result (r = 5) for the turning figure: joint values ``q`` and
    stiffnesses ``kj`` (P, n) along ``path``, rate limits ``dq``, ``dk`` (numbers or per joint), the
    orientation error ``alpha_deg`` (P,) and ratio 5 at every waypoint, all solved."""
    P, n = q.shape
    return types.SimpleNamespace(
        P=P,
        n=n,
        B=1,
        meta={
            "ratio": 5.0,
            "criterion": "f2",
            "limits": {"dq": dq, "dk": dk, "kmin": 1.0, "kmax": 100.0, "first_rate_limit": False},
        },
        q=q[None],
        kj=kj[None],
        q0=q[:1].copy(),
        kj0=kj[:1].copy(),
        status=np.zeros((1, P), int),
        target=path.points[None],
        direction=path.directions[None],
        alpha_deg=np.asarray(alpha_deg, float)[None],
        ratio=np.full((1, P), 5.0),
    )
