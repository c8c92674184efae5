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
    # the scan over waypoints: a loop with trip count P whose own kernels run once per waypoint
    scan = [b for b in bodies if b["trip_count"] == P and b["op_name"].endswith("/while") and b["fusions"] > 0]
    assert scan, [(b["trip_count"], b["op_name"]) for b in bodies]
    assert any(b["launches"] % P == 0 for b in scan)
    # loops nested in it (Newton, LM, Adam, Jacobi) run more launches than the scan body itself
    assert max(b["launches"] for b in bodies) > min(b["launches"] for b in scan)
