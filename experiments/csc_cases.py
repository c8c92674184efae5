"""The CSC cases of the ``csc_*`` experiments, written once (a helper module, not an experiment).

Seed 001 (Part I, Petrovic & Lukic) states the CSC update and two propositions but gives **no
simulation example**: its section 5 is announced in the introduction and the paper ends with the
conclusion. Every case below is therefore **this project's own**: the arms, start postures, paths,
desired stiffnesses, step rules and step sizes were chosen here (SPEC section 6 lets us choose).
The 3R start posture is seed 000's Fig. 2 posture and the LWR path is the project's default path of
seed 000's reproduction; neither paper pairs them with CSC. Each ``setup`` list below is the
interpretation that the experiments print next to their results.

The experiments import this file from their own folder (``python experiments/NAME.py`` puts
``experiments/`` on the import path); it has no command line, so ``jaxstiff reproduce`` does not
run it.
"""

from __future__ import annotations

import dataclasses
import math
import os
from typing import Any

import numpy as np

#: The one sentence every CSC summary starts with.
PROJECT_OWN = (
    "**This case is the project's own.** Seed 001 (Part I) gives no simulation example: the arm, "
    "path, desired stiffness, step rule and step size below were chosen by this project, not taken from the seed."
)


@dataclasses.dataclass
class Case:
    """One CSC case: what ``jaxstiff.csc_rollout`` needs, and the interpretation to print with it."""

    name: str
    robot: Any
    q0: np.ndarray
    path: np.ndarray  # (T, d) TCP targets, m
    K: np.ndarray  # (m, m) or (T, m, m), N/m
    task: str
    setup: list[str]  # Markdown bullets: every choice made here
    extra: dict[str, Any] = dataclasses.field(default_factory=dict)


def rotated_stiffness(diag: tuple[float, ...], angle_deg: float = 30.0) -> np.ndarray:
    """``R diag R^T`` with R the rotation by ``angle_deg`` about z (2x2 for two values, 3x3 for three), N/m."""
    c, s = math.cos(math.radians(angle_deg)), math.sin(math.radians(angle_deg))
    R = np.eye(len(diag))
    R[:2, :2] = [[c, -s], [s, c]]
    return R @ np.diag(np.asarray(diag, dtype=float)) @ R.T


def planar3r_hold(steps: int = 2000, beta: float = 2e-3) -> Case:
    """Planar 3R (links 1 m) holding the TCP at x(q0); K_xd = R(30 deg) diag(3000, 1000) R^T N/m."""
    import jaxstiff

    robot = jaxstiff.Robot.from_urdf("planar_3r")
    q0 = np.deg2rad([75.0, -74.74, -76.30])
    x0 = np.asarray(robot.fk(q0))[:2, 3]
    xs = np.round(x0, 3) + 0.0  # printed without "-0.000"
    setup = [
        "arm: `planar_3r` (three 1 m links), task `xy` (m = 2, n = 3: one redundant degree of freedom)",
        "start posture q0 = (75, -74.74, -76.30) deg: seed 000's Fig. 2 posture (seed 000 does not use it for CSC)",
        f"path: hold the TCP at x(q0) = ({xs[0]:.3f}, {xs[1]:.3f}) m for {steps} steps",
        "desired stiffness K_xd = R(30 deg) diag(3000, 1000) R(30 deg)^T N/m (the project's choice)",
        f"step rule: the `constant` null step of SPEC section 6, beta = {beta:g} rad per step (the seed's "
        "adaptive rule S1-22 gives no null motion while the path stands still)",
        "realised joint stiffness kj = diag(J^T K_xd J) clipped to [1, inf) Nm/rad (SPEC section 6); no joint limits",
    ]
    return Case("planar 3R hold", robot, q0, np.tile(x0, (steps, 1)), rotated_stiffness((3000.0, 1000.0)), "xy", setup)


def planar4r_line(steps: int = 500) -> Case:
    """Planar 4R (links 1 m) along a 1 m line from x(q0) by (-0.6, 0.8) m; the K_xd of :func:`planar3r_hold`."""
    import jaxstiff

    robot = jaxstiff.Robot.from_urdf("planar_4r")
    q0 = np.deg2rad([90.0, -60.0, -60.0, -50.0])
    x0 = np.asarray(robot.fk(q0))[:2, 3]
    path = x0 + np.linspace(0.0, 1.0, steps + 1)[1:, None] * np.array([-0.6, 0.8])
    setup = [
        "arm: `planar_4r` (four 1 m links), task `xy` (m = 2, n = 4: two redundant degrees of freedom)",
        "start posture q0 = (90, -60, -60, -50) deg (the project's choice)",
        f"path: a straight line from x(q0) = ({x0[0]:.3f}, {x0[1]:.3f}) m by (-0.6, +0.8) m (1 m) in {steps} "
        f"steps ({1000.0 / steps:.0f} mm per step)",
        "desired stiffness K_xd = R(30 deg) diag(3000, 1000) R(30 deg)^T N/m, constant (the project's choice)",
        "step rule: the seed's adaptive step (S1-22), null step = beta x primary step; no joint limits",
    ]
    return Case("planar 4R line", robot, q0, path, rotated_stiffness((3000.0, 1000.0)), "xy", setup)


def lwr_path(substeps: int = 10, joint_limits: str = "sum", jl_gain: float = 0.3) -> Case:
    """KUKA LWR 4 (A7 locked) along the default path refined ``substeps`` times, K_xd along the tangent.

    ``extra`` holds ``base`` (the 60-waypoint Path), ``tangents`` (T, 3), ``wp_index`` (rows of the
    original waypoints) and ``z`` (the path's height, m).
    """
    import jaxstiff
    from jaxstiff.ik import ik_position
    from jaxstiff.paths import default_path

    robot = jaxstiff.Robot.from_urdf("kuka_lwr4", locked={"lwr_a7": 0.0})
    base = default_path()
    W = np.asarray(base.points, dtype=float)
    tang_w = np.asarray(base.directions, dtype=float)
    t = np.linspace(0.0, 1.0, substeps + 1)[1:]
    pts = np.vstack([W[:1]] + [W[j] + t[:, None] * (W[j + 1] - W[j]) for j in range(len(W) - 1)])
    tang = np.vstack([tang_w[:1]] + [tang_w[j] + t[:, None] * (tang_w[j + 1] - tang_w[j]) for j in range(len(W) - 1)])
    tang /= np.linalg.norm(tang, axis=1, keepdims=True)
    K = np.stack([_tangent_stiffness(d) for d in tang])
    # IK from a bent-elbow guess: the nominal start of jaxstiff.ik ends with A2 at its +120 deg limit here
    q0, ik_err = ik_position(robot, W[0], q_start=np.deg2rad([-30.0, 30.0, 0.0, 90.0, 0.0, -30.0, 0.0]))
    if ik_err > 1e-9:
        raise RuntimeError(f"lwr_path: IK of the first waypoint failed ({ik_err:.1e} m)")
    z = float(W[0, 2])
    setup = [
        "arm: `kuka_lwr4` with joint A7 (flange rotation) locked at 0, as in seed 000's reproduction: the TCP "
        "lies on the A7 axis, so A7 cannot move it; 6 free joints, task `xyz` (m = 3): 3 redundant degrees of "
        "freedom. A7 is rigid (jaxstiff's default for a locked joint, SPEC section 1: no spring, kj_7 = +inf in "
        "the result); as a spring it would add nothing to the translational compliance either (its position "
        "column of J is zero)",
        f"path: the project's default path (`jaxstiff.paths.default_path`: a half-sine bump in the plane z = "
        f"{z:.2f} m, from (0.60, 0.25) to (0.60, -0.25) m through (0.70, 0) m, 60 waypoints about 9 mm apart), "
        f"refined to {substeps} CSC steps per segment ({len(pts)} steps); seed 000 gives no path",
        "desired stiffness along the path: K_xd = R_t diag(3000, 1000, 1000) R_t^T N/m, 3000 N/m along the "
        "tangent, 1000 N/m across it and vertically (the project's choice)",
        f"start posture: damped least-squares IK of the first waypoint from the guess (-30, 30, 0, 90, 0, -30, 0) "
        f"deg, q0 = ({', '.join(f'{v:.1f}' for v in np.rad2deg(q0))}) deg",
        f"step rule: the seed's adaptive step (S1-22), one Newton correction per step; joint-limit avoidance "
        f"`joint_limits={joint_limits}`, `jl_gain={jl_gain:g}` (the seed's conclusion asks for joint-limit "
        "avoidance as a further secondary task but gives no rule: this one is the project's)",
    ]
    extra = {"base": base, "tangents": tang, "wp_index": np.arange(0, len(pts), substeps), "z": z}
    return Case("LWR default path", robot, np.asarray(q0), pts, K, "xyz", setup, extra)


def _tangent_stiffness(d: np.ndarray) -> np.ndarray:
    e1 = np.array([d[0], d[1], 0.0]) / np.linalg.norm(d[:2])
    Rt = np.stack([e1, [-e1[1], e1[0], 0.0], [0.0, 0.0, 1.0]], axis=1)
    return Rt @ np.diag([3000.0, 1000.0, 1000.0]) @ Rt.T


def status_counts(status: np.ndarray) -> dict[str, int]:
    """``{description: count}`` of a rollout's CSC status codes."""
    import jaxstiff

    codes, counts = np.unique(np.asarray(status), return_counts=True)
    return {jaxstiff.csc.describe_status(int(c)): int(n) for c, n in zip(codes, counts, strict=True)}


def write_summary(out: str, title: str, case_setup: list[str], body: list[str], figures: list[str]) -> str:
    """Write ``out/summary.md``: the title, :data:`PROJECT_OWN`, the setup bullets, the body, the figures."""
    from jaxstiff.runtime._io import atomic_write_text

    lines = [f"# {title}", "", PROJECT_OWN, "", "Setup (every interpretation made here):", ""]
    lines += [f"- {s}" for s in case_setup]
    lines += ["", *body, ""]
    lines += [f"![{f}]({f})\n" for f in figures]
    path = os.path.join(out, "summary.md")
    atomic_write_text(path, "\n".join(lines) + "\n")
    return path
