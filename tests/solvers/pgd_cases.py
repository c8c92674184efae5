"""The small, fixed pgd settings shared by the solver tests on the planar 3R arm (pgd, hybrid,
trajectory, lockstep, threads, waypoint capacity): one set of options, so one compilation.

Plain constants, imported by the tests and by the fixtures of tests/solvers/conftest.py (the arm,
its paths, a run with these settings, the check of a saved result)."""

from __future__ import annotations

OPTS = {"iters": 30, "iters_first": 60, "starts_first": 8, "chunk": 2}
STARTS = 4
