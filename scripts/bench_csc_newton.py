"""What one Newton correction per CSC step buys and costs (issue 23, item 6).

The project's own CSC cases of experiments/csc_cases.py (seed 001 has no simulation example): the
planar 3R holding a point (seed 000's Fig. 2 posture, a constant null step of 0.005 rad), the
planar 4R line and the LWR along the default path (10 sub-steps per waypoint), each with
``newton`` 0, 1 and 2: the largest TCP error (m), the first call (compilation included) and the
run time per step (compiled, best of 5), side by side in one process. Float64.

    python scripts/bench_csc_newton.py [--steps 400]
"""

from __future__ import annotations

import argparse
import time

import jax
import numpy as np

jax.config.update("jax_enable_x64", True)

import os  # noqa: E402
import sys  # noqa: E402

import jaxstiff  # noqa: E402

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "experiments"))
import csc_cases  # noqa: E402


def _run(robot, path, K, q0, beta, step, newton, task=None):
    def go():
        r = jaxstiff.csc_rollout(robot, path, K, q0, beta, step=step, newton=newton, task=task)
        jax.block_until_ready(r.q)
        return r

    t0 = time.perf_counter()
    r = go()
    first = time.perf_counter() - t0
    best = min(_timed(go) for _ in range(5))
    return r, first, best


def _timed(f):
    t0 = time.perf_counter()
    f()
    return time.perf_counter() - t0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--steps", type=int, default=400)
    a = ap.parse_args()
    cases = [
        (csc_cases.planar3r_hold(a.steps, 0.005), 0.005, "constant"),
        (csc_cases.planar4r_line(a.steps), 1.0, "adaptive"),
        (csc_cases.lwr_path(), 1.0, "adaptive"),
    ]
    print(f"{'case':<18}{'steps':>6}{'newton':>7}{'max |e| (m)':>13}{'first call (s)':>16}{'per step (us)':>15}")
    for case, beta, step in cases:
        T = len(case.path)
        for newton in (0, 1, 2):
            args = (case.robot, case.path, case.K, case.q0, beta, step, newton, case.task)
            r, first, best = _run(*args)
            err = float(np.max(np.asarray(r.tracking_error)))
            print(f"{case.name:<18}{T:>6}{newton:>7}{err:>13.3g}{first:>16.2f}{1e6 * best / T:>15.1f}")


if __name__ == "__main__":
    main()
