"""A parameter sweep: paths x settings, run in chunks that survive a kill, written as a table.

The same config as a TOML file (experiments/sweeps/quick.toml is a bigger one) runs with
``jaxstiff sweep FILE --out DIR``; ``--resume`` finishes an interrupted sweep and
``--backend ray [--address ...]`` spreads its chunks over a Ray cluster (``pip install ".[dist]"``).
Here: how the reachable axis ratio depends on where the path lies and on the joint rate limit.
"""

import os
import shutil

from _common import OUT, TINY, figure, size

import jaxstiff.sweep

config = {
    "sweep": {"kind": "shape", "name": "example", "chunk_size": 64},
    "robot": {"name": "kuka_lwr4", "locked": {"lwr_a7": 0.0}},
    "paths": [
        {"generator": "default", "n": 24},  # the shipped half-sine path
        {  # arcs around the base, 40 degrees long, at 2 radii (m) and 2 heights (m)
            "generator": "arc",
            "center": [[0.0, 0.0, 0.25], [0.0, 0.0, 0.45]][: size(2, 1)],
            "radius": [0.5, 0.7],
            "start_deg": -20.0,
            "end_deg": 20.0 if size(1, 0) else -20.0 + 40.0 / 23 * 5,  # tiny: the first 6 of 24 steps
            "n": size(24, 6),
        },
    ],
    "axes": {
        "solver": "pgd",
        "criterion": "f2",
        "ratio": [2.0, 3.0, 5.0, 8.0][: size(4, 2)],
        "dq_deg": [1.0, 2.0, 4.0][: size(3, 2)],  # joint rate limit, deg per waypoint
        "dk": 5.0,  # stiffness rate limit, Nm/rad per waypoint
        "starts": size(4, 2),
    },
    "report": {"heatmaps": [["ratio", "path"], ["ratio", "dq_deg"]], "metrics": ["share_both"]},
}

if TINY:
    del config["paths"][0]  # (the tests' size: one short arc)
out = os.path.join(OUT, "04_sweep_run")
shutil.rmtree(out, ignore_errors=True)  # a fresh store (or: resume=True to finish an interrupted one)
outcome = jaxstiff.sweep.run_sweep(config, out, progress=False)
print(f"{outcome.n_rows} rows in {outcome.n_chunks} chunk(s), {outcome.wall_s:.1f} s -> {outcome.table_file}")

table = jaxstiff.sweep.read_table(out)  # a pandas DataFrame, one row per path x setting
print(
    table[["path", "ratio", "dq_deg", "share_both", "median_alpha_deg", "mean_ratio"]].round(3).to_string(index=False)
)
print(table.groupby("ratio")["share_both"].mean().round(3))  # share of waypoints in target per ratio

heat = os.path.join(out, "plots", "heatmap_share_both_path_vs_ratio.png")  # written by the report
shutil.copyfile(heat, figure("04_sweep.png"))
