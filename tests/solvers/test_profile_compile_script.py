"""scripts/profile_compile.py (what pgd's cold first call compiles) on a tiny batch: the phases are
timed, the tree of loop bodies and branches adds up, and no loop body of pgd's program is compiled
twice (issue 23's cold compile: the surrogate's and the criterion's Adam loops, and four Newton
loops, were separate copies until the ninth session; the check fails on that program)."""

from __future__ import annotations

import collections
import json

import pytest
from helpers import load_script


def _walk(node):
    yield node
    for c in node["children"]:
        yield from _walk(c)


@pytest.mark.slow
def test_compile_profile_adds_up_and_no_loop_is_compiled_twice(tmp_path):
    script = load_script("scripts/profile_compile.py")
    out = tmp_path / "compile.json"
    assert script.main(["--B", "4", "--P", "3", "--starts", "2", "--json", str(out)]) == 0
    res = json.loads(out.read_text())
    assert res["trace_s"] > 0 and res["lower_s"] > 0 and res["xla_s"] > 0
    assert res["jaxpr_equations"] > 1000 and res["while_loops"] > 3
    tree = res["tree"]
    for n in _walk(tree):
        assert n["fusions"] == n["own_fusions"] + sum(c["fusions"] for c in n["children"])
    # the tree holds nearly every fusion (a few sit in called computations outside loops and branches)
    assert 0.9 * res["fusions"] <= tree["fusions"] <= res["fusions"]
    # a loop body of some size that appears twice at the same place of the traced program is the
    # same loop compiled twice
    bodies = collections.Counter(
        (n["op_name"], n["own_fusions"]) for n in _walk(tree) if n["kind"] == "while" and n["own_fusions"] > 10
    )
    assert bodies and not [k for k, v in bodies.items() if v > 1], bodies
