"""What pgd's cold first call compiles: its chunk program's tracing, lowering and XLA compile timed
apart, the size of the traced program (jaxpr equations, loops included) and of the compiled one
(fusions: XLA:CPU compiles one kernel per fusion, and its compile time follows their number), and
the loop bodies and conditional branches of the compiled program as a tree, with their fusions.

    python scripts/profile_compile.py [--B 64] [--P 50] [--starts 8] [--robot NAME_OR_URDF] [--json FILE]

Reading the tree: each line is a loop body (``while``) or a branch of a conditional (``cond``), its
own fusions and those of everything inside it; the op name says where it sits in the traced
program. A computation that appears twice with the same size is a loop compiled twice (the
ninth session of docs/notes/speed.md found the Adam loop and the Newton loop that way). XLA's own
phase times: run with ``TF_CPP_MIN_LOG_LEVEL=0 TF_CPP_VMODULE=cpu_compiler=2``.

The problem is ``scripts/bench_batch.py``'s (random reachable paths, f2, ratio 5); ``--robot`` a
shipped robot's name or a URDF file (default: the LWR with its 7th joint locked). The program is
pgd's own, captured where pgd compiles it (``scripts/profile_pgd.py``), compiled here once, with
the compile cache off for this process.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import sys
import time

os.environ["JAXSTIFF_COMPILE_CACHE"] = "0"  # a cold compile, whatever the user's cache holds

import jax  # noqa: E402

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from profile_pgd import capture_program, hlo_computations  # noqa: E402

from jaxstiff.runtime import kernel_compiler_options  # noqa: E402


def jaxpr_equations(jaxpr) -> int:
    """Equations of a jaxpr, those of the jaxprs inside its loops, conditionals and calls included."""
    n = 0
    for eqn in jaxpr.eqns:
        n += 1
        for p in eqn.params.values():
            for sub in p if isinstance(p, (list, tuple)) else (p,):
                inner = getattr(sub, "jaxpr", sub)
                if hasattr(inner, "eqns"):
                    n += jaxpr_equations(inner)
    return n


def hlo_tree(hlo: str) -> dict:
    """The compiled program's entry computation with its loop bodies and conditional branches as a
    tree: ``{"name", "kind", "op_name", "own_fusions", "fusions" (own + inside), "children"}``."""
    comps = hlo_computations(hlo)
    m = re.search(r"^ENTRY %?([\w.\-]+) ", hlo, re.M)
    if m is None:
        raise RuntimeError("no ENTRY computation in the compiled program's text")
    entry = m.group(1)

    def kids(name: str) -> list[tuple[str, str, str]]:
        out = []
        for line in comps.get(name, []):
            op = re.search(r'op_name="([^"]+)"', line)
            op_name = op.group(1) if op else ""
            if " while(" in line:
                body = re.search(r"body=%?([\w.\-]+)", line)
                if body:
                    out.append(("while", body.group(1), op_name))
            elif " conditional(" in line:
                branches = re.search(r"branch_computations=\{([^}]*)\}", line)
                names = (
                    [b.strip().lstrip("%") for b in branches.group(1).split(",")]
                    if branches
                    else [m.group(1) for m in re.finditer(r"(?:true|false)_computation=%?([\w.\-]+)", line)]
                )
                out.extend(("cond", b, op_name) for b in names)
        return out

    def node(name: str, kind: str, op_name: str) -> dict:
        own = sum(bool(re.search(r"= \S+ fusion\(", line)) for line in comps.get(name, []))
        children = [node(b, k, o) for k, b, o in kids(name)]
        return {
            "name": name,
            "kind": kind,
            "op_name": op_name,
            "own_fusions": own,
            "fusions": own + sum(c["fusions"] for c in children),
            "children": children,
        }

    return node(entry, "entry", "")


def profile(B: int, P: int, starts: int, robot: str | None = None) -> dict:
    with jax.enable_x64(True):
        fn, args = capture_program(B, P, starts, robot=robot)
        t0 = time.perf_counter()
        traced = fn.trace(*args)
        t1 = time.perf_counter()
        lowered = traced.lower()
        t2 = time.perf_counter()
        compiled = lowered.compile(kernel_compiler_options())
        t3 = time.perf_counter()
    hlo = compiled.as_text()
    tree = hlo_tree(hlo)
    return {
        "B": B,
        "P": P,
        "starts": starts,
        "robot": robot or "kuka_lwr4 (lwr_a7 locked)",
        "trace_s": t1 - t0,
        "lower_s": t2 - t1,
        "xla_s": t3 - t2,
        "jaxpr_equations": jaxpr_equations(traced.jaxpr.jaxpr),
        "fusions": len(re.findall(r"= \S+ fusion\(", hlo)),
        "while_loops": hlo.count(" while("),
        "tree": tree,
    }


def _print_tree(node: dict, depth: int = 0, min_fusions: int = 2) -> None:
    if node["fusions"] < min_fusions and depth:
        return
    op = node["op_name"][-70:]
    print(f"{'  ' * depth}{node['kind']:5s} own {node['own_fusions']:4d}  all {node['fusions']:5d}  {op}")
    for c in node["children"]:
        _print_tree(c, depth + 1, min_fusions)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--B", type=int, default=64, help="paths (one chunk)")
    ap.add_argument("--P", type=int, default=50, help="waypoints per path")
    ap.add_argument("--starts", type=int, default=8, help="pgd starts (rollouts)")
    ap.add_argument("--robot", help="shipped robot name or URDF file (default: the LWR, 7th joint locked)")
    ap.add_argument("--json", help="write the whole result here")
    a = ap.parse_args(argv)
    res = profile(a.B, a.P, a.starts, a.robot)
    print(
        f"pgd chunk program, B={a.B} P={a.P} starts={a.starts}, {res['robot']}: tracing {res['trace_s']:.2f} s, "
        f"lowering {res['lower_s']:.2f} s, XLA {res['xla_s']:.2f} s; {res['jaxpr_equations']} jaxpr equations, "
        f"{res['fusions']} fusions, {res['while_loops']} loops"
    )
    _print_tree(res["tree"])
    if a.json:
        with open(a.json, "w") as fh:
            json.dump(res, fh, indent=1)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
