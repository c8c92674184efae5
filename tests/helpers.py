"""Shared test helpers: one comparison with explicit tolerances and a NaN check, one finite difference,
an independent numpy forward kinematics (homogeneous 4x4 products, nothing shared with the kernel), and
a bundled robot read once per process."""

from __future__ import annotations

import functools
import importlib.util
import json
import pathlib
import sys
import textwrap
import types

import numpy as np


def assert_close(actual, expected, rtol=1e-10, atol=1e-12, what=""):
    a = np.asarray(actual, dtype=float)
    e = np.asarray(expected, dtype=float)
    assert a.shape == e.shape, f"{what}: shape {a.shape} != {e.shape}"
    assert np.all(np.isfinite(a)), f"{what}: non-finite values in actual"
    np.testing.assert_allclose(a, e, rtol=rtol, atol=atol, err_msg=what)


def central_diff(f, x, h=1e-6):
    """Central finite differences of f: R^n -> R^k (numpy), returns (k, n)."""
    x = np.asarray(x, dtype=float)
    f0 = np.atleast_1d(np.asarray(f(x), dtype=float))
    out = np.zeros((f0.size, x.size))
    for i in range(x.size):
        e = np.zeros_like(x)
        e[i] = h
        out[:, i] = (
            np.atleast_1d(np.asarray(f(x + e), dtype=float)).ravel()
            - np.atleast_1d(np.asarray(f(x - e), dtype=float)).ravel()
        ) / (2 * h)
    return out


def _rot(axis, angle):
    a = np.asarray(axis, float) / np.linalg.norm(axis)
    K = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    return np.eye(3) + np.sin(angle) * K + (1 - np.cos(angle)) * K @ K


def numpy_fk(robot, q):
    """Independent FK from the Robot's constant transforms: plain 4x4 products in numpy."""
    T = np.eye(4)
    for i in range(robot.n):
        T = T @ robot.origin_matrix(i)
        M = np.eye(4)
        if robot.joint_types[i] == 1:
            M[:3, 3] = np.asarray(robot.axes[i]) * q[i]
        else:
            M[:3, :3] = _rot(robot.axes[i], q[i])
        T = T @ M
    return T @ robot.tip_matrix


def joint_motion_traces(robot, B: int, P: int, seed: int = 0):
    """TCP traces (numpy FK) of B straight joint-space motions of a planar arm, P waypoints each, 0.4
    rad inside the limits: reachable by construction. Returns points (B, P, 3), unit tangents in
    the xy plane (B, P, 3) and the start postures (B, n)."""
    rng = np.random.default_rng(seed)
    lo, hi = robot.lower + 0.4, robot.upper - 0.4
    qa = rng.uniform(lo, hi, (B, robot.n))
    qb = np.clip(qa + rng.uniform(-0.15, 0.15, (B, robot.n)), lo, hi)
    s = np.linspace(0, 1, P)
    Q = qa[:, None] + s[None, :, None] * (qb - qa)[:, None]
    pts = np.array([[numpy_fk(robot, q)[:3, 3] for q in Qb] for Qb in Q])
    d = np.gradient(pts, axis=1)
    d[..., 2] = 0.0
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    return pts, d, qa


def numpy_jacobian(robot, q, h=1e-6):
    """Geometric Jacobian (6, n), rows ``[v; w]`` in the base frame, by central differences of
    :func:`numpy_fk`: ``v_i = dp/dq_i`` and ``w_i = vee(dR/dq_i R^T)`` (error ~h^2)."""
    q = np.asarray(q, dtype=float)
    R = numpy_fk(robot, q)[:3, :3]
    J = np.zeros((6, q.size))
    for i in range(q.size):
        e = np.zeros_like(q)
        e[i] = h
        Tp, Tm = numpy_fk(robot, q + e), numpy_fk(robot, q - e)
        J[:3, i] = (Tp[:3, 3] - Tm[:3, 3]) / (2 * h)
        W = (Tp[:3, :3] - Tm[:3, :3]) / (2 * h) @ R.T
        J[3:, i] = 0.5 * np.array([W[2, 1] - W[1, 2], W[0, 2] - W[2, 0], W[1, 0] - W[0, 1]])
    return J


def numpy_held_and_free(J, kj):
    """(held, free) translational stiffness (3, 3), N/m, of the Jacobian J (6, n) and springs kj (n,)
    (``inf``: rigid): ``free = (J_p K_j^-1 J_p^T)^-1``, the inverse of the translational compliance
    (a pure force, tool free to turn); ``held`` the top-left block of ``(J K_j^-1 J^T)^-1`` (tool
    orientation held). Plain numpy inverses."""
    C = (J / np.asarray(kj, dtype=float)) @ J.T
    return np.linalg.inv(C)[:3, :3], np.linalg.inv(C[:3, :3])


@functools.cache
def robot_by_name(name: str):
    """``jaxstiff.Robot.from_urdf(name)`` (a bundled robot's name), read once per process."""
    import jaxstiff  # here, not at the top: the helpers above stay independent of the package

    return jaxstiff.Robot.from_urdf(name)


# folders, for tests in any sub-folder of tests/
TESTS_DIR = pathlib.Path(__file__).resolve().parent  #: tests/
DATA_DIR = TESTS_DIR / "data"  #: tests/data (URDFs made for tests)
REPO_ROOT = TESTS_DIR.parent  #: the repository (experiments/, urdf/, pyproject.toml)


def load_script(relpath: str) -> types.ModuleType:
    """Import a script of the repository (``"scripts/x.py"``, ``"experiments/y.py"``) as a module, with its
    own folder on ``sys.path`` while it loads (experiments import their siblings)."""
    path = REPO_ROOT / relpath
    spec = importlib.util.spec_from_file_location(path.stem, path)
    assert spec is not None and spec.loader is not None, f"cannot load {path}"
    mod = importlib.util.module_from_spec(spec)
    folder = str(path.parent)
    sys.path.insert(0, folder)
    try:
        spec.loader.exec_module(mod)
    finally:
        sys.path.remove(folder)
    return mod


#: a tiny csc sweep: planar 3R holding two points, 2 x 2 settings, chunks of 2 (tests/sweep)
CSC_TOML = textwrap.dedent("""\
    [sweep]
    kind = "csc"
    name = "tiny-csc"
    chunk_size = 2

    [robot]
    name = "planar_3r"

    [[paths]]
    generator = "point"
    point = [[1.2, 1.0, 0.0], [1.0, 1.5, 0.0]]
    n = 20

    [axes]
    task = "xy"
    step = "constant"
    beta = [0.002, 0.004]
    kxd_angle_deg = [0.0, 30.0]
    """)


def one_value_joint_urdf(folder) -> str:
    """The shipped planar 4R with joint_2 limited to [0.5, 0.5] (a range of one value), written into
    ``folder``; its path."""
    import jaxstiff

    src = open(jaxstiff.Robot.from_urdf("planar_4r").source).read()
    marker = '<joint name="joint_2" type="revolute">'
    head, tail = src.split(marker)
    tail = tail.replace('lower="-3.141592653589793" upper="3.141592653589793"', 'lower="0.5" upper="0.5"', 1)
    path = pathlib.Path(folder) / "one_value_joint.urdf"
    path.write_text(head + marker + tail)
    return str(path)


def tamper_result(src: str, dst: str, arrays=None, meta=None) -> str:
    """A copy of result file ``src`` at ``dst`` with ``arrays(dict)`` / ``meta(dict)`` applied to its
    arrays and its meta record (in place); returns ``dst``."""
    with np.load(src, allow_pickle=False) as z:
        data = {k: z[k] for k in z.files}
    m = json.loads(str(data.pop("meta")))
    if arrays:
        arrays(data)
    if meta:
        meta(m)
    np.savez(dst, meta=np.asarray(json.dumps(m)), **data)  # pyright: ignore[reportArgumentType]
    return dst


def one_value_range_planar(folder: pathlib.Path, name: str = "one_value.urdf") -> pathlib.Path:
    """tests/data/planar_4r_tight_limits.urdf with joint a3's range made the one value -0.6 rad
    (a URDF may give lower == upper), written to ``folder / name``."""
    import re

    planar = (DATA_DIR / "planar_4r_tight_limits.urdf").read_text()
    text = re.sub(
        r'(<joint name="a3".*?<limit )lower="[^"]*" upper="[^"]*"',
        r'\1lower="-0.6" upper="-0.6"',
        planar,
        count=1,
        flags=re.S,
    )
    assert text != planar
    path = folder / name
    path.write_text(text)
    return path


def one_cli_error(capsys, argv: list[str]) -> str:
    """Run the command line, which must fail with exit 2 and one line ``jaxstiff: error: ...``; that line."""
    from jaxstiff.cli import main

    rc = main(argv)
    err = capsys.readouterr().err
    lines = err.strip().splitlines()
    assert rc == 2 and len(lines) == 1 and lines[0].startswith("jaxstiff: error: "), err
    return lines[0]


def planar_arc_sweep(name: str, axes: dict, *, radius=(1.5, 2.0), end_deg: float = 12.0, chunk_size: int = 4) -> dict:
    """A small shape-sweep config (a fresh dict each call) on the shipped planar 3R: one arc
    generator about the origin (3 waypoints from 10 deg to ``end_deg``, one path per radius, m)
    and the given ``axes`` (in their order: it sets the rows' order)."""
    return {
        "sweep": {"kind": "shape", "name": name, "chunk_size": chunk_size},
        "robot": {"name": "planar_3r"},
        "paths": [
            {
                "generator": "arc",
                "center": [0.0, 0.0, 0.0],
                "radius": list(radius),
                "start_deg": 10.0,
                "end_deg": end_deg,
                "n": 3,
            }
        ],
        "axes": dict(axes),
    }
