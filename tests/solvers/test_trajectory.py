"""solver="trajectory" (issue 5): never worse than its greedy warm start in total, exactly feasible."""

from __future__ import annotations

import pytest
from pgd_cases import OPTS

from jaxstiff.results import _files as R
from jaxstiff.solvers import _pgd as pgd

TOPTS = {**OPTS, "traj_iters": 16, "blocks": 2, "chunk": 2}


@pytest.mark.slow
def test_trajectory_beats_or_keeps_warm_start(tmp_path, planar_paths, run_planar, check_planar_file):
    path, q0 = planar_paths(2, 5, seed=5)
    # pgd alone with the same settings: the warm start
    warm = run_planar(path, q0, options={k: v for k, v in TOPTS.items() if k in pgd.DEFAULT_OPTIONS})
    traj = run_planar(path, q0, solver="trajectory", options=TOPTS)
    for b in range(2):
        nw, nt = (~R.is_usable(warm.status[b])).sum(), (~R.is_usable(traj.status[b])).sum()
        assert nt <= nw
        if nt == nw:
            assert (
                traj.criterion[b][R.is_usable(traj.status[b])].sum()
                <= warm.criterion[b][R.is_usable(warm.status[b])].sum() + 1e-9
            )
    check_planar_file(traj, tmp_path)
    assert traj.meta["solver_code_meaning"].startswith("the warm start's (pgd): index of the start")


def test_slsqp_warm_start_with_several_starts_names_the_trajectory_solver(planar_paths, run_planar):
    """warm='slsqp' takes one start: starts=2 is refused by a message about the solver the user
    chose and its option (it named 'slsqp', a solver the user never asked for)."""
    path, q0 = planar_paths(1, 3, seed=5)
    with pytest.raises(ValueError, match=r"solver 'trajectory' with option warm='slsqp' is single-start.*starts=2"):
        run_planar(path, q0, solver="trajectory", starts=2, options={"warm": "slsqp"})
