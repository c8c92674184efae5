"""Numpy-only re-computation of a result's quantities, independent of the JAX kernels (for
:func:`jaxstiff.results._files.verify`): forward kinematics and the geometric Jacobian by 4x4
products, K_T (S0-4, S0-6), alpha and the axis ratio (S0-8), f1/f2 (S0-9, S0-15), the common-mode
factor; and the robot rebuilt from a result's ``meta``."""

from __future__ import annotations

import os
from typing import TYPE_CHECKING, Any

import numpy as np

from jaxstiff.runtime._io import check_urdf_file, file_sha256

if TYPE_CHECKING:
    from jaxstiff.model._robot import Robot

__all__: list[str] = []


def np_fk_position(robot: Robot, q: np.ndarray) -> np.ndarray:
    """TCP positions (N, 3) by plain 4x4 products in numpy (independent of the JAX kernel)."""
    out = np.empty((q.shape[0], 3))
    for idx, qq in enumerate(q):
        T = np.eye(4)
        for i in range(robot.n):
            T = T @ robot.origin_matrix(i)
            M = np.eye(4)
            a = np.asarray(robot.axes[i], float)
            if robot.joint_types[i] == 1:
                M[:3, 3] = a * qq[i]
            else:
                K = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
                M[:3, :3] = np.eye(3) + np.sin(qq[i]) * K + (1 - np.cos(qq[i])) * (K @ K)
            T = T @ M
        out[idx] = (T @ robot.tip_matrix)[:3, 3]
    return out


def result_urdf(meta: dict[str, Any], urdf: str | os.PathLike | None = None) -> tuple[str, dict[str, Any]]:
    """The URDF file to rebuild a result's robot from (``urdf``, the ``--urdf`` flag, else the
    path in ``meta["robot"]["urdf"]``) and the ``meta["robot"]`` record, checked before the file
    is opened: a regular file of bounded size (:func:`jaxstiff.runtime._io.check_urdf_file`), never
    a FIFO, a device, a folder or a number. Errors name the flag or the meta field."""
    rmeta = meta.get("robot") if isinstance(meta, dict) else None
    if not isinstance(rmeta, dict):
        raise ValueError(f"result meta field 'robot' must be a record (URDF path, links, locks), got {rmeta!r:.60}")
    if urdf is not None:
        return check_urdf_file(urdf, "--urdf"), rmeta
    return check_urdf_file(rmeta.get("urdf"), "result meta field robot.urdf"), rmeta


def check_same_robot(rmeta: dict[str, Any], path: str, chain: Any) -> None:
    """Refuse a URDF given in place of the recorded one (``--urdf``) that is not the result's
    robot. The same bytes (sha256) are the same robot moved; other bytes pass only when the chain
    they give has the recorded name, joints, limits and tip transform (a reformatted copy), else a
    ValueError says what differs."""
    want = rmeta.get("sha256")
    if not want or file_sha256(path) == want:
        return
    diffs = []
    if rmeta.get("name") not in (None, chain.name):
        diffs.append(f"robot {chain.name!r}, the result's is {rmeta.get('name')!r}")
    names = rmeta.get("joint_names")
    if names is not None and list(names) != list(chain.joint_names):
        diffs.append(f"joints {list(chain.joint_names)}, the result's are {list(names)}")
    else:
        for key, have in (("lower", chain.lower), ("upper", chain.upper), ("tip_transform", chain.tip_matrix)):
            rec = rmeta.get(key)
            try:
                same = rec is None or np.allclose(np.asarray(rec, dtype=float), have, rtol=1e-12, atol=1e-12)
            except (TypeError, ValueError):
                same = False
            if not same:
                diffs.append(f"another {key.replace('_', ' ')}")
    if diffs:
        raise ValueError(
            f"--urdf {path} is not the robot of the result (sha256 differs, and it has {'; '.join(diffs)}); "
            "give the URDF the result was made with"
        )


def robot_from_meta(meta: dict[str, Any], urdf: str | os.PathLike | None = None, check_sha: bool = True) -> Robot:
    """Rebuild the robot of a result from its ``meta`` (URDF path, links, locked joints, tcp).

    Args:
        urdf: use this URDF file instead of the recorded path (e.g. on another machine); it must
            be the result's robot (:func:`check_same_robot`).
        check_sha: refuse a recorded URDF whose sha256 differs from the recorded one, and a
            ``urdf`` that is another robot.
    """
    from jaxstiff.model._robot import Robot  # deferred: verification itself needs numpy only

    path, rmeta = result_urdf(meta, urdf)
    if check_sha and urdf is None and rmeta.get("sha256") and file_sha256(path) != rmeta["sha256"]:
        raise ValueError(f"{path}: sha256 differs from the one recorded in the result ({rmeta['sha256'][:12]}...)")
    robot = Robot.from_urdf(
        path,
        base_link=rmeta.get("base_link") or None,
        tip_link=rmeta.get("tip_link") or None,
        locked=rmeta.get("locked") or None,
        tcp=np.asarray(rmeta["tcp"]) if rmeta.get("tcp") is not None else None,
    )
    if check_sha and urdf is not None:
        check_same_robot(rmeta, path, robot)
    return robot


def np_jacobian_rows(robot: Robot, q: np.ndarray) -> np.ndarray:
    """Geometric Jacobian (6, n) in numpy from 4x4 products (independent of the kernel)."""
    T = np.eye(4)
    zs, ps, kinds = [], [], []
    for i in range(robot.n):
        T = T @ robot.origin_matrix(i)
        a = np.asarray(robot.axes[i], float)
        zs.append(T[:3, :3] @ a)
        ps.append(T[:3, 3].copy())
        kinds.append(robot.joint_types[i])
        M = np.eye(4)
        if robot.joint_types[i] == 1:
            M[:3, 3] = a * q[i]
        else:
            K = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
            M[:3, :3] = np.eye(3) + np.sin(q[i]) * K + (1 - np.cos(q[i])) * (K @ K)
        T = T @ M
    p_tcp = (T @ robot.tip_matrix)[:3, 3]
    J = np.zeros((6, robot.n))
    for i in range(robot.n):
        if kinds[i] == 1:
            J[:3, i] = zs[i]
        else:
            J[:3, i] = np.cross(zs[i], p_tcp - ps[i])
            J[3:, i] = zs[i]
    return J


def np_translational_stiffness(robot: Robot, q: np.ndarray, kj: np.ndarray, task: str) -> np.ndarray:
    """Translational stiffness K_T (m, m), N/m, of posture q with joint stiffnesses kj (S0-4, S0-6)."""
    J = np_jacobian_rows(robot, q)
    rows = {"xy": [0, 1], "xyz": [0, 1, 2], "full": list(range(6))}[task]
    Js = J[rows]
    C = Js @ np.diag(1.0 / kj) @ Js.T
    K = np.linalg.inv(C)
    if task == "full":
        K = K[:3, :3]
    return 0.5 * (K + K.T)


def np_alpha_ratio(K: np.ndarray, d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(alpha_deg, ratio)`` (...,) of K_T (..., m, m) against the direction d (..., 3) (S0-8)."""
    w, V = np.linalg.eigh(K)
    m = K.shape[-1]
    v1 = V[..., :, -1]
    dd = d[..., :m] / np.linalg.norm(d[..., :m], axis=-1, keepdims=True)
    cosang = np.abs(np.sum(v1 * dd, axis=-1))
    if m == 2:
        sinang = np.abs(v1[..., 0] * dd[..., 1] - v1[..., 1] * dd[..., 0])
    else:
        sinang = np.linalg.norm(np.cross(v1, dd), axis=-1)
    return np.degrees(np.arctan2(sinang, cosang)), w[..., -1] / w[..., -2]


def np_criterion(
    name: str, alpha: np.ndarray, rho: np.ndarray, r: float | np.ndarray, c: float | np.ndarray
) -> np.ndarray:
    """f1 (S0-9, ``name == "f1"``) or f2 (S0-15) from alpha (deg) and the axis ratio rho."""
    if name == "f1":
        return (np.abs(alpha) + c) / (np.minimum(rho, r) / r)
    return (1.0 + np.abs(alpha)) * (1.0 + np.abs(r - rho))


def np_cms(K: np.ndarray, cms_meta: dict[str, Any]) -> np.ndarray:
    """Common-mode factor of K_T (..., m, m): the recorded major axis or volume (meta ``cms``)."""
    w = np.linalg.eigvalsh(K)
    if cms_meta.get("target_major") is not None:
        return float(cms_meta["target_major"]) / w[..., -1]
    m = K.shape[-1]
    return (float(cms_meta["target_volume"]) / np.prod(w, axis=-1)) ** (1.0 / m)
