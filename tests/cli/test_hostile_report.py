"""The report of an interrupted shape run is computed only for the waypoints that were run
(issue 24, finding 4: a 10^6-waypoint path took 70 s to exit after SIGTERM because the report
was recomputed for every waypoint). A NOT_RUN waypoint holds its path's reference state, so its
position, K_T and ratio are computed once per state, and alpha and f1/f2 per direction in
numpy; the values are checked against the numpy verification (results.verify) and a full
compiled recomputation."""

from __future__ import annotations

import numpy as np
import pytest

import jaxstiff
import jaxstiff.shaping._steps as steps  # counts the rows the report step computes
from jaxstiff.results import _files as R


def _counting(monkeypatch) -> list[int]:
    """Counts the waypoints the compiled report is asked for (rows, not calls: it is one batched call)."""
    rows = [0]
    original = steps.report_rows

    def counted(problem, X, params):
        rows[0] += len(X)
        return original(problem, X, params)

    monkeypatch.setattr(steps, "report_rows", counted)
    return rows


@pytest.mark.parametrize(
    ("robot_name", "criterion", "task", "path"),
    [
        pytest.param("kuka_lwr4", "f2", "full", None, marks=pytest.mark.slow),
        pytest.param("kuka_lwr4", "f1", "xyz", None, marks=pytest.mark.slow),
    ],
)
def test_report_only_for_waypoints_run(monkeypatch, robot_name, criterion, task, path):
    p = jaxstiff.default_path(30)
    path = jaxstiff.Path(p.points, p.directions)
    robot = jaxstiff.Robot.from_urdf(robot_name)

    def progress(b, k):
        if k == 1:  # (after the 2nd waypoint)
            raise KeyboardInterrupt

    calls = _counting(monkeypatch)
    with pytest.raises(KeyboardInterrupt) as info:
        jaxstiff.shape(robot, path, criterion, 3.0, task=task, first_starts=1, progress=progress)
    res = info.value.result
    not_run = res.status[0] == R.NOT_RUN
    assert not_run.sum() == 28 and R.is_usable(res.status[0, :2]).all()
    # 2 waypoints run, and the 28 NOT_RUN ones share one reference state: 3 rows, not 30
    assert calls[0] == 3
    # the values at the NOT_RUN waypoints are what a full recomputation gives
    check = R.verify(res, robot)
    for k in ("max_position_mismatch", "max_alpha_mismatch"):
        assert check[k] < 1e-8, (k, check[k])
    for k in ("max_ratio_mismatch", "max_criterion_mismatch", "max_cms_mismatch"):
        assert check[k] < 1e-9, (k, check[k])
    for a in (res.position, res.cms, res.alpha_deg, res.ratio, res.criterion):
        assert np.all(np.isfinite(a))
    # the NOT_RUN waypoints hold one state: position and CMS are exactly the same, alpha follows the direction
    first = np.flatnonzero(not_run)[0]
    assert np.all(res.position[0, not_run] == res.position[0, first]) and np.all(
        res.cms[0, not_run] == res.cms[0, first]
    )
    assert np.ptp(res.alpha_deg[0, not_run]) > 0.1
