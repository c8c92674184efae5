"""Forward kinematics and the geometric Jacobian of a long chain as one ``lax.scan`` over its joints.

The same quantities as the unrolled kernel of :mod:`jaxstiff.model.kinematics` (SPEC section 1),
computed by a loop instead of straight-line code: the chain's constant geometry is stacked into
per-joint arrays (origin rotation and offset, unit axis, its outer product and cross-product
matrix, a prismatic flag) and ``lax.scan`` walks them carrying the world rotation ``R`` and
position ``p`` of the current frame (batch axes leading). One joint's work is traced once, so the
compiled program's size, and its compile time and memory, no longer grow with the number of
joints; the price is the loop (one iteration per joint) and the arithmetic on structural zeros
that the unrolled kernel drops at trace time. :mod:`jaxstiff.model.kinematics` calls this kernel
for long chains: more than :data:`UNROLL_MAX_JOINTS` joints, or more than
:data:`FRAMED_MAX_JOINTS` for a chain with a joint whose axis or origin rotation is not
axis-aligned (:func:`kernel_for`; measurements and the choice of the crossover:
docs/notes/model.md, ``scripts/bench_long_chain.py``).

Per joint i: ``p += R p0_i``, ``M = R R0_i``, ``z_i = M a_i``; a revolute joint then turns,
``R = M (A_i + (I - A_i) cos q_i + S_i sin q_i)`` (Rodrigues with ``A_i = a_i a_i^T`` and
``S_i = [a_i]x``), a prismatic one slides, ``p += z_i q_i`` and ``R = M``. The Jacobian columns
are ``[z_i x (p_tcp - p_i); z_i]`` (revolute) and ``[z_i; 0]`` (prismatic). Joint cosines and
sines come from :func:`jaxstiff._numerics.trig.joint_cos_sin`, as in the unrolled kernel.
"""

from __future__ import annotations

import functools

import jax
import jax.numpy as jnp
import numpy as np

from jaxstiff._numerics.batch import batched_like
from jaxstiff._numerics.trig import joint_cos_sin
from jaxstiff.model._chain import JOINT_PRISMATIC, Chain

__all__ = ["FRAMED_MAX_JOINTS", "SOLVER_UNROLL_MAX_JOINTS", "axis_aligned", "uses_scan", "chain_arrays"]

#: Axis-aligned chains (:func:`axis_aligned`) with at most this many joints use the unrolled
#: kernel; longer ones use the scan (other chains: :data:`FRAMED_MAX_JOINTS`) (measured crossover: docs/notes/model.md, ``scripts/bench_long_chain.py``).
UNROLL_MAX_JOINTS = 12


def axis_aligned(robot: Chain) -> bool:
    """Whether every joint axis and every origin rotation (tip included) of ``robot`` has only
    entries 0 and +-1 (after :func:`jaxstiff.model.chain.snap`): the structurally sparse geometry
    of most real arms, where the unrolled kernel drops most of its arithmetic at trace time."""
    rotations = [*(o[r][:3] for o in robot.origins for r in range(3)), *(robot.tip[r][:3] for r in range(3))]
    return all(v in (0.0, 1.0, -1.0) for row in (*rotations, *robot.axes) for v in row)


#: Chains that are not :func:`axis_aligned` are walked unrolled in joint-axis frames
#: (:mod:`jaxstiff.model.kinematics_framed`) up to this many joints, and by the scan beyond: the
#: framed program's compile time grows with its length (a generic 7-joint chain, every axis and
#: frame rotated, about 2.5 s on a 2-core CPU; 12 joints about 10 s; docs/notes/model.md).
FRAMED_MAX_JOINTS = 8


def kernel_for(robot: Chain) -> str:
    """Which kinematics kernel runs ``robot``: ``"unrolled"`` (an :func:`axis_aligned` chain of at
    most :data:`UNROLL_MAX_JOINTS` joints: the constant geometry is 0 and +-1 and folds away),
    ``"framed"`` (any other chain of at most :data:`FRAMED_MAX_JOINTS` joints: rotated frames,
    folded in joint-axis frames, :mod:`jaxstiff.model.kinematics_framed`) or ``"scan"`` (longer
    chains: one ``lax.scan`` over the joints, whose compile time does not grow with the chain).
    The choice depends on the chain only, never on the batch."""
    if axis_aligned(robot):
        return "unrolled" if robot.n <= UNROLL_MAX_JOINTS else "scan"
    return "framed" if robot.n <= FRAMED_MAX_JOINTS else "scan"


def uses_scan(robot: Chain) -> bool:
    """Whether the kinematics of ``robot`` run as the scan over joints (:func:`kernel_for`): an
    axis-aligned chain of more than :data:`UNROLL_MAX_JOINTS` joints, any other of more than
    :data:`FRAMED_MAX_JOINTS`."""
    return kernel_for(robot) == "scan"


#: In the solvers' programs (pgd's batch program, SLSQP's kernels, the reports) an axis-aligned
#: chain with more joints than this uses the scan too (:func:`solver_uses_scan`).
SOLVER_UNROLL_MAX_JOINTS = 4


def solver_uses_scan(robot: Chain) -> bool:
    """Whether the solvers' programs compute the kinematics of ``robot`` by the scan: wherever
    :func:`uses_scan` says so, and for every chain of more than :data:`SOLVER_UNROLL_MAX_JOINTS`
    joints. A solver program traces the kinematics several times (pgd: position and Jacobian in its
    LM stage, gradient steps and Newton corrections), so unrolled they are 38 % of pgd's traced
    equations for the LWR and most of its compile time, while they are a small share of its run
    time (the measured compile and run times, pgd 1000 x 100 waypoints on the LWR: docs/benchmarks.md
    and docs/notes/speed.md). Short chains (the planar arms) keep the
    unrolled kernel: it is small to compile and several times faster to run there (docs/notes/model.md)."""
    return uses_scan(robot) or robot.n > SOLVER_UNROLL_MAX_JOINTS


@functools.lru_cache(maxsize=64)
def chain_arrays(robot: Chain) -> dict[str, np.ndarray]:
    """The chain's constant geometry stacked per joint (float64 numpy, cached per chain).

    Returns a dict: ``R0`` (n, 3, 3) and ``p0`` (n, 3) the origin transforms, ``axis`` (n, 3),
    ``A`` (n, 3, 3) = ``a a^T``, ``S`` (n, 3, 3) = ``[a]x``, ``prismatic`` (n,) bool, ``tip_R``
    (3, 3) and ``tip_p`` (3,).
    """
    org = np.asarray(robot.origins, dtype=float).reshape(robot.n, 3, 4)
    a = np.asarray(robot.axes, dtype=float).reshape(robot.n, 3)
    zero = np.zeros(robot.n)
    S = np.stack(
        [
            np.stack([zero, -a[:, 2], a[:, 1]], -1),
            np.stack([a[:, 2], zero, -a[:, 0]], -1),
            np.stack([-a[:, 1], a[:, 0], zero], -1),
        ],
        axis=-2,
    )
    tip = np.asarray(robot.tip, dtype=float)
    return {
        "R0": org[:, :, :3],
        "p0": org[:, :, 3],
        "axis": a,
        "A": a[:, :, None] * a[:, None, :],
        "S": S,
        "prismatic": np.asarray(robot.joint_types) == JOINT_PRISMATIC,
        "tip_R": tip[:, :3],
        "tip_p": tip[:, 3],
    }


def _matvec(M: jax.Array, v: jax.Array) -> jax.Array:
    """(..., 3, 3) @ (..., 3) as a broadcast multiply and sum (fuses; no dot kernel per batch)."""
    return jnp.sum(M * v[..., None, :], axis=-1)


def _matmul(A: jax.Array, B: jax.Array) -> jax.Array:
    """(..., 3, 3) @ (..., 3, 3) as a broadcast multiply and sum."""
    return jnp.sum(A[..., :, :, None] * B[..., None, :, :], axis=-2)


def _walk(robot: Chain, q: jax.Array, want_jacobian: bool, poly: bool | None):
    """The scan. Returns (R_tcp (..., 3, 3), p_tcp (..., 3), z (n, ..., 3) or None, p_i (n, ..., 3) or None)."""
    g = {
        k: jnp.asarray(v, dtype=q.dtype) if v.dtype != bool else jnp.asarray(v) for k, v in chain_arrays(robot).items()
    }
    batch = q.shape[:-1]
    cos_q, sin_q = joint_cos_sin(q, poly)
    xs = (
        g["R0"],
        g["p0"],
        g["axis"],
        g["A"],
        g["S"],
        g["prismatic"],
        *(jnp.moveaxis(x, -1, 0) for x in (q, cos_q, sin_q)),
    )
    eye = jnp.eye(3, dtype=q.dtype)

    def step(carry, x):
        R, p = carry
        R0, p0, a, A, S, prismatic, qi, c, s = x
        p = p + _matvec(R, jnp.broadcast_to(p0, batch + (3,)))
        M = _matmul(R, jnp.broadcast_to(R0, batch + (3, 3)))
        z = _matvec(M, jnp.broadcast_to(a, batch + (3,)))
        rot = A + (eye - A) * c[..., None, None] + S * s[..., None, None]
        out = (z, p) if want_jacobian else None
        R = jnp.where(prismatic, M, _matmul(M, rot))
        p = jnp.where(prismatic, p + z * qi[..., None], p)
        return (R, p), out

    init = (jnp.broadcast_to(eye, batch + (3, 3)), jnp.zeros(batch + (3,), q.dtype))
    (R, p), frames = jax.lax.scan(step, batched_like(init, q), xs)
    p = p + _matvec(R, jnp.broadcast_to(g["tip_p"], batch + (3,)))
    R = _matmul(R, jnp.broadcast_to(g["tip_R"], batch + (3, 3)))
    z, p_i = frames if frames is not None else (None, None)
    return R, p, z, p_i


def _jacobian(robot: Chain, p: jax.Array, z: jax.Array, p_i: jax.Array) -> jax.Array:
    """(..., 6, n) from the per-joint axes ``z`` and points ``p_i`` (n, ..., 3) and the TCP ``p``."""
    prismatic = jnp.asarray(chain_arrays(robot)["prismatic"]).reshape((-1,) + (1,) * p.ndim)
    v = jnp.where(prismatic, z, jnp.cross(z, p[None] - p_i))
    w = jnp.where(prismatic, jnp.zeros_like(z), z)
    return jnp.moveaxis(jnp.concatenate([v, w], axis=-1), 0, -1)


def scan_pose(robot: Chain, q: jax.Array, poly: bool | None = None) -> tuple[jax.Array, jax.Array]:
    """TCP rotation (..., 3, 3) and position (..., 3) in the base frame by the scan over joints.

    Args:
        robot: the chain.
        q: joint values (..., n), rad or m (not checked here: :func:`jaxstiff.model.kinematics.fk` checks).
        poly: joint cos/sin from the polynomial (True), XLA (False) or chosen by batch size (None).
    """
    R, p, _, _ = _walk(robot, q, False, poly)
    return R, p


def scan_pose_and_jacobian(
    robot: Chain, q: jax.Array, poly: bool | None = None
) -> tuple[jax.Array, jax.Array, jax.Array]:
    """``(R (..., 3, 3), p (..., 3), J (..., 6, n))`` by the scan over joints; J's rows
    ``[vx, vy, vz, wx, wy, wz]`` in the base frame, as :func:`jaxstiff.model.kinematics.jacobian`."""
    R, p, z, p_i = _walk(robot, q, True, poly)
    assert z is not None and p_i is not None  # want_jacobian=True returns the frames
    return R, p, _jacobian(robot, p, z, p_i)
