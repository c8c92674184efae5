"""Result files for the viewer tests, built from arrays (no solver run): q is drawn at random inside
the limits, the stored TCP positions come from :func:`jaxstiff.fk` (JAX, independent of the
viewer's numpy FK), alpha and the axis ratio are those of (q, kj) with the task (the readers check
the ratio against the task); the criterion and the CMS factor are placeholders the viewer only
displays."""

from __future__ import annotations

import json
import os

import numpy as np

import jaxstiff
from jaxstiff.settings._robot import robot_meta

DATA = os.path.join(os.path.dirname(__file__), "data")
MISSING_MESHES_URDF = os.path.join(DATA, "arm4_missing_meshes.urdf")


def make_shape_result(
    robot: jaxstiff.Robot,
    B: int,
    P: int,
    seed: int = 0,
    rigid: bool = False,
    task: str = "full",
    spread: tuple[float, float] = (0.3, 0.7),
) -> jaxstiff.ShapeResult:
    """``spread``: q is drawn in this fraction of each joint's range (a narrow one: a short path)."""
    rng = np.random.default_rng(seed)
    lo, hi = np.maximum(robot.lower, -2.0), np.minimum(robot.upper, 2.0)
    q = lo + (hi - lo) * rng.uniform(*spread, (B, P, robot.n))
    q[..., ~robot.free] = robot.locked_values[~robot.free]
    kj = rng.uniform(5.0, 80.0, (B, P, robot.n))
    if rigid:
        kj[..., ~robot.free] = np.inf
    position = np.asarray(jaxstiff.fk(robot, q))[..., :3, 3]
    d = rng.normal(size=(B, P, 3))
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    z = np.zeros((B, P))
    from jaxstiff.results._numpy_check import np_alpha_ratio
    from jaxstiff.view._kinematics import stiffness_T

    K = stiffness_T(robot, q, kj, task)
    alpha, ratio = np_alpha_ratio(K[..., :2, :2] if task == "xy" else K, d)
    meta = {
        "robot": robot_meta(robot),
        "task": task,
        "criterion": "f2",
        "ratio": 5.0,
        "c": 1.0,
        "solver": "test",
        "settings": {"locked_joints": "rigid" if rigid else "spring"},
        # rate limits the random steps keep (q moves < 1.6 rad, kj < 75 Nm/rad between waypoints):
        # the reader checks them
        "limits": {"kmin": 1.0, "kmax": 100.0, "dq": 2.0, "dk": 80.0, "first_rate_limit": False},
        "cms": {"target_volume": 1e6, "target_major": None},
        "path": {"name": ";".join(f"p{b}" for b in range(B))},
    }
    return jaxstiff.ShapeResult(
        joint_names=np.asarray(robot.joint_names),
        q=q,
        kj=kj,
        cms=np.full((B, P), 2.0),
        kj_scaled=2.0 * kj,
        target=position + 1e-12,
        direction=d,
        position=position,
        pos_error=np.full((B, P), 1e-12),
        alpha_deg=alpha,
        ratio=ratio,
        criterion=z + 1.5,
        status=np.zeros((B, P), dtype=np.int64),
        q0=q[:, 0],
        kj0=kj[:, 0],
        solver_code=np.zeros((B, P), dtype=np.int64),
        nit=np.zeros((B, P), dtype=np.int64),
        nfev=np.zeros((B, P), dtype=np.int64),
        time_s=z + 0.01,
        meta=json.loads(json.dumps(meta)),
    )


def make_csc_file(
    robot: jaxstiff.Robot,
    file: str,
    B: int = 1,
    T: int = 12,
    seed: int = 1,
    status: np.ndarray | None = None,
    status_bits: dict[str, str] | None = None,
) -> str:
    """A csc result file in the ``jaxstiff csc`` layout (K_C from the numpy stiffness of q, kj).

    ``status``: the (B, T) status bit masks (default 0); ``status_bits``: meta's names of the bits
    (default one of them; ``{}``: none in meta, as in files written before they were recorded)."""
    from jaxstiff.view._kinematics import stiffness_T

    rng = np.random.default_rng(seed)
    q = np.clip(rng.uniform(-1, 1, (B, T, robot.n)), robot.lower, robot.upper)
    q[..., ~robot.free] = robot.locked_values[~robot.free]
    kj = rng.uniform(10, 100, (B, T, robot.n))
    pos = np.asarray(jaxstiff.fk(robot, q))[..., :3, 3]
    z = np.zeros((B, T))
    arrays = dict(
        q=q,
        u=z + 3.0,
        frobenius=z + 4.0,
        tracking_error=z,
        orientation_error=z,
        kj=kj,
        K_C=stiffness_T(robot, q, kj, "xyz"),
        position=pos,
        target=pos,
        isotropy=z + 0.5,
        null_step=z,
        status=np.zeros((B, T), dtype=np.int64) if status is None else np.asarray(status, dtype=np.int64),
        u_start=np.full(B, 3.0),
        frobenius_start=np.full(B, 4.0),
        joint_names=np.asarray(robot.joint_names),
        q0=q[0, 0],
        K_xd=np.diag([3000.0, 1000.0, 2000.0]),
    )
    meta = {
        "kind": "csc",
        "robot": robot_meta(robot),
        "task": "xyz",
        "step": "adaptive",
        "beta": 1.0,
        "status_bits": {"1": "damped (near singular)"} if status_bits is None else status_bits,
        "paths": [f"p{b}.csv" for b in range(B)],
    }
    if not meta["status_bits"]:
        del meta["status_bits"]
    np.savez(file, meta=np.asarray(json.dumps(meta)), **arrays)  # pyright: ignore[reportArgumentType]
    return file
