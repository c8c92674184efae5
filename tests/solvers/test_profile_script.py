"""scripts/profile_pgd.py (where pgd's run time goes) on a tiny batch: the profile is attributed to
the program's loop bodies consistently (shares add up, the waypoint scan's kernels run once per
waypoint), and the command writes its JSON."""

from __future__ import annotations

import json

import pytest
from helpers import load_script


@pytest.mark.slow
def test_profile_attributes_every_launch_to_a_loop_body(tmp_path):
    script = load_script("scripts/profile_pgd.py")
    P = 3
    out = tmp_path / "profile.json"
    assert script.main(["--B", "4", "--P", str(P), "--starts", "2", "--json", str(out)]) == 0
    res = json.loads(out.read_text())
    bodies = res["bodies"]
    assert res["launches"] == sum(b["launches"] for b in bodies) > 0
    assert sum(b["share"] for b in bodies) == pytest.approx(1.0)
    # the loop over waypoints: the outermost loop (its trip count is traced: the path's length),
    # whose own kernels run once per waypoint (a loop with trip count P was matched before: it
    # was a Newton loop of 3 steps, and P = 3)
    scan = [b for b in bodies if b["op_name"].endswith("/while") and b["op_name"].count("/while") == 1]
    assert len(scan) == 1 and scan[0]["fusions"] > 0, [(b["trip_count"], b["op_name"]) for b in bodies]
    assert scan[0]["launches"] % P == 0, scan[0]
    # loops nested in it (Newton, LM, Adam, Jacobi) run more launches than the scan body itself
    assert max(b["launches"] for b in bodies) > min(b["launches"] for b in scan)
