"""The unrolled kinematics of a chain whose joint frames are rotated: walked in frames aligned with
the joint axes, so that the constant geometry folds at trace time (SPEC section 1).

A URDF joint frame is usually rotated (origin rpy, fixed joints in between, a rotated tool), and
its axis need not be a coordinate axis. Walked as written, every joint multiplies the running
rotation by a dense constant matrix and by a dense Rodrigues rotation; the straight-line program
is then dense enough that XLA's CPU backend, which evaluates it once per output entry, takes
seconds to minutes to compile it and runs it slowly (docs/notes/model.md). Here the geometry is
re-expressed once, in numpy, before tracing:

* each joint i gets a constant frame ``Q_i`` whose third column is its unit axis ``a_i``, so the
  joint's motion is ``Rz(q_i)``: four products and two sums on two columns, one column untouched;
* the constant rotation between consecutive joint frames, ``Q_i^T R0_{i+1} Q_{i+1}``, is split as
  ``Rz(alpha) Rx(beta) Rz(gamma)`` (z-x-z Euler angles); ``Rz(gamma)`` is absorbed into the choice of
  ``Q_{i+1}`` (its free turn about the axis) and ``Rz(alpha)`` into a constant offset of the joint
  angle (``q_i + alpha``, like a Denavit-Hartenberg theta offset), so what remains between two
  revolute joints is one rotation about x, ``Rx(beta)``: at most four products more, none where
  the axes are parallel or perpendicular;
* fixed joints, origin offsets and the tool are already folded into one constant per joint
  (:class:`jaxstiff.model.chain.Chain`); their translations are expressed in these frames, and
  the TCP's rotation is one constant 3x3 after the last joint.

With ``G_i`` the world rotation of joint i's aligned frame (``z_i = G_i e_z`` its world axis),
``H_i = G_i Rz(q_i + theta_i)`` (``H_i = G_i`` and ``p_i += z_i q_i`` for a prismatic joint):
``G_{i+1} = H_i C_i``, ``p_{i+1} = p_i + H_i t_i`` (:class:`FramedPlan`; for the last joint
``C_{n-1}`` and ``t_{n-1}`` lead to the TCP), ``R_tcp = H_{n-1} C_{n-1}``,
``p_tcp = p_{n-1} + H_{n-1} t_{n-1}``; the Jacobian columns are ``[z_i x (p_tcp - p_i); z_i]``
(revolute) and ``[z_i; 0]`` (prismatic), as in :mod:`jaxstiff.model.kinematics`.

How they are computed is set by how XLA's CPU backend runs them: the output entries are stacked
into the pose and the Jacobian, and the fused loop evaluates each entry from the joint cosines and
sines on its own, without sharing the arithmetic of one entry with another (materialising the
shared frames between them costs more: docs/notes/model.md). The cost is the sum over the entries
of the arithmetic each one depends on, so every entry is given the shortest recursion there is:

* row k of the rotations, forward: ``g <- g Rz(q_i + theta_i) C_i`` on a row 3-vector from row k of ``G_0`` (four
  products for the joint, at most four for ``Rx(beta)``); the rows of ``G_i`` give the axes ``z_i``
  and the last one the row of ``R_tcp``. A row needs no other row.
* the TCP's offset from joint i in joint i's frame, backward from the tip:
  ``e_i = G_i^T (p_tcp - p_i) = Rz(q_i + theta_i) (t_i + C_i e_{i+1})`` (a prismatic joint adds
  ``q_i e_z`` instead of turning), so ``p_tcp = p_0 + G_0 e_0`` and, with ``z_i = G_i e_z``,
  ``z_i x (p_tcp - p_i) = G_i (e_z x e_i) = G_i[:, 1] e_i,x - G_i[:, 0] e_i,y``: the entry in row
  k reads row k of ``G_i`` (joints before i) and ``e_i`` (joints from i on), where the cross
  product of world vectors would read two full rows of every frame and the whole position walk.

All constants enter as Python floats (:mod:`jaxstiff.model.scalars` folds 0, 1 and -1), and for
batches on the CPU the joint cosines and sines are computed once, apart from the rest
(:func:`jaxstiff._numerics.linalg.fusion_boundary`), instead of once per output entry.
"""

from __future__ import annotations

import functools
import math
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from jaxstiff._numerics.linalg import fusion_boundary
from jaxstiff._numerics.trig import POLY_MIN_BATCH, joint_cos_sin
from jaxstiff.model._chain import JOINT_PRISMATIC, Chain, snap
from jaxstiff.model._scalars import Scalar, add, dot3, mul, sub

__all__ = ["FramedPlan", "framed_plan"]

Rows3 = tuple[tuple[float, float, float], tuple[float, float, float], tuple[float, float, float]]


class FramedPlan(NamedTuple):
    """The chain's constants in joint-axis frames (Python floats, snapped; see the module doc).

    ``G0``: world rotation of joint 0's aligned frame; ``p0``: its origin (m). Per joint i:
    ``theta[i]`` the joint-angle offset (rad, 0 for prismatic joints); ``C[i]`` the constant
    rotation from ``H_i`` to ``G_{i+1}`` (for the last joint: to the TCP) and ``t[i]`` the
    translation to the next joint origin (to the TCP) in the frame ``H_i`` (m).
    """

    G0: Rows3
    p0: tuple[float, float, float]
    theta: tuple[float, ...]
    C: tuple[Rows3, ...]
    t: tuple[tuple[float, float, float], ...]


def _rz(angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _axis_frame(axis) -> np.ndarray:
    """A rotation whose third column is the unit ``axis`` (a signed permutation for a coordinate axis)."""
    a = np.asarray(axis, dtype=float)
    k = int(np.argmax(np.abs(a)))
    e = np.zeros(3)
    # a coordinate axis only if its other entries are exactly 0: (0, 1, 6e-8) is a unit vector in
    # float64 too (1 + 3.6e-15 rounds to 1), and a frame built for (0, 1, 0) would not be a rotation
    if abs(a[k]) == 1.0 and np.count_nonzero(a) == 1:
        e[(k + 1) % 3] = 1.0
        x = e
    else:
        e[int(np.argmin(np.abs(a)))] = 1.0
        x = np.cross(e, a)
        x /= np.linalg.norm(x)
    return np.stack([x, np.cross(a, x), a], axis=1)


def _rows(M: np.ndarray) -> Rows3:
    r = [tuple(snap(float(v)) for v in M[i]) for i in range(3)]
    return (r[0], r[1], r[2])  # type: ignore[return-value]


def _vec(v: np.ndarray) -> tuple[float, float, float]:
    return (snap(float(v[0])), snap(float(v[1])), snap(float(v[2])))


def _split(D: np.ndarray) -> tuple[float, float, np.ndarray]:
    """``D = Rz(alpha) F Rz(gamma)`` with ``F = Rx(beta)``: returns alpha, gamma and F (its structural
    zeros and one set exactly). Robust where beta is near 0 or pi: gamma only has to zero
    ``(D Rz(-gamma))[2, 0]``, and alpha is read from the first column of ``D Rz(-gamma)``, which
    is of unit length."""
    gamma = math.atan2(D[2, 0], D[2, 1]) if (D[2, 0] != 0.0 or D[2, 1] != 0.0) else 0.0
    E = D @ _rz(-gamma)
    alpha = math.atan2(E[1, 0], E[0, 0])
    F = _rz(-alpha) @ E
    F[0, :] = (1.0, 0.0, 0.0)
    F[1:, 0] = 0.0
    return alpha, gamma, F


def _sparsest_turn(G: np.ndarray) -> float:
    """The turn ``phi`` about the first joint's axis for which ``G Rz(phi)`` has the most entries that
    snap to 0 (0 if none beats ``G``): each row's first two entries turned onto one coordinate.

    The first joint's frame is free to turn about its axis (the joint-angle offset takes the turn
    back), and every output entry is walked from a row of ``G_0``: a row with one nonzero of the
    two entries the joint mixes costs two products at the first joint instead of four."""

    def zeros(phi: float) -> int:
        return sum(snap(float(v)) == 0.0 for v in (G @ _rz(phi))[:, :2].ravel())

    best, best_zeros = 0.0, zeros(0.0)
    for a, b in G[:, :2]:
        if a == 0.0 and b == 0.0:
            continue
        for phi in (math.atan2(-a, b), math.atan2(b, a)):  # first entry to 0, second entry to 0
            z = zeros(phi)
            if z > best_zeros:
                best, best_zeros = phi, z
    return best


@functools.lru_cache(maxsize=64)
def framed_plan(robot: Chain) -> FramedPlan:
    """The constants of :func:`framed_chain` for ``robot`` (numpy, float64, cached per chain)."""
    n = robot.n
    R0 = [robot.origin_matrix(i)[:3, :3] for i in range(n)]
    P0 = [robot.origin_matrix(i)[:3, 3] for i in range(n)]
    Q = _axis_frame(robot.axes[0])
    if robot.joint_types[0] != JOINT_PRISMATIC:
        Q = Q @ _rz(_sparsest_turn(R0[0] @ Q))
    G0 = R0[0] @ Q
    theta, C, t = [], [], []
    for i in range(n):
        prismatic = robot.joint_types[i] == JOINT_PRISMATIC
        if i + 1 < n:
            Q_next = _axis_frame(robot.axes[i + 1])
            alpha, gamma, F = _split(Q.T @ R0[i + 1] @ Q_next)
            Q_next = Q_next @ _rz(-gamma)
            if prismatic:  # no turn to absorb alpha into: keep it in the constant
                th, Ci = 0.0, Q.T @ R0[i + 1] @ Q_next
            else:
                th, Ci = snap(alpha), F
            ti = _rz(-th) @ Q.T @ P0[i + 1]
            Q = Q_next
        else:
            th = 0.0
            Ci, ti = Q.T @ robot.tip_matrix[:3, :3], Q.T @ robot.tip_matrix[:3, 3]
        theta.append(th)
        C.append(_rows(Ci))
        t.append(_vec(ti))
    return FramedPlan(_rows(G0), _vec(P0[0]), tuple(theta), tuple(C), tuple(t))


def framed_chain(robot: Chain, q: jax.Array, want_jacobian: bool = True, poly: bool | None = None):
    """Walk the chain in joint-axis frames. Returns ``(R_tcp 3x3, p_tcp 3, columns)`` as scalar entries
    (Python floats or arrays of q's batch shape), ``columns`` the n Jacobian columns of six entries
    ``[v; w]`` (none unless ``want_jacobian``); ``poly`` as in :func:`jaxstiff.model.kinematics._chain`.

    Every output entry is computed by a short recursion of its own (see the module doc): a row of
    the rotations forward from the base, the TCP's offset backward from the tip."""
    plan = framed_plan(robot)
    theta = np.asarray(plan.theta)
    qa = q + jnp.asarray(theta, dtype=q.dtype) if np.any(theta != 0.0) else q
    batch = q.size // max(q.shape[-1], 1)
    if poly is None:
        poly = jax.default_backend() == "cpu" and batch >= POLY_MIN_BATCH
    cos_q, sin_q = joint_cos_sin(qa, poly)
    if poly:  # the polynomial once, not once in every output entry that reads it
        cos_q, sin_q = fusion_boundary((cos_q, sin_q))
    n = robot.n
    revolute = [robot.joint_types[i] != JOINT_PRISMATIC for i in range(n)]
    cs = [(cos_q[..., i], sin_q[..., i]) for i in range(n)]
    # forward, one row of the rotations at a time: row k of G_i for every joint, and of R_tcp
    rows: list[list[list[Scalar]]] = [[] for _ in range(n)]
    R: list[list[Scalar]] = []
    for k in range(3):
        g: list[Scalar] = list(plan.G0[k])
        for i in range(n):
            rows[i].append(g)
            h = g
            if revolute[i]:  # row k of H_i = G_i Rz(q_i + theta_i)
                c, s = cs[i]
                h = [add(mul(g[0], c), mul(g[1], s)), sub(mul(g[1], c), mul(g[0], s)), g[2]]
            Ci = plan.C[i]
            g = [dot3(h, (Ci[0][j], Ci[1][j], Ci[2][j])) for j in range(3)]
        R.append(g)
    # backward: e_i = G_i^T (p_tcp - p_i), the TCP's offset from joint i in joint i's frame
    e: list[Scalar] = [0.0, 0.0, 0.0]
    offsets: list[list[Scalar]] = [[] for _ in range(n)]
    for i in reversed(range(n)):
        Ci, ti = plan.C[i], plan.t[i]
        v = [add(ti[k], dot3(Ci[k], e)) for k in range(3)]
        if revolute[i]:
            c, s = cs[i]
            e = [sub(mul(c, v[0]), mul(s, v[1])), add(mul(s, v[0]), mul(c, v[1])), v[2]]
        else:
            e = [v[0], v[1], add(v[2], q[..., i])]
        offsets[i] = e
    p = [add(plan.p0[k], dot3(plan.G0[k], e)) for k in range(3)]
    cols: list[list[Scalar]] = []
    if not want_jacobian:
        return R, p, cols
    for i in range(n):
        z = [rows[i][k][2] for k in range(3)]
        if revolute[i]:  # z_i x (p_tcp - p_i) = G_i (e_z x e_i) = G_i[:, 1] e_i,x - G_i[:, 0] e_i,y
            ex, ey = offsets[i][0], offsets[i][1]
            cols.append([sub(mul(rows[i][k][1], ex), mul(rows[i][k][0], ey)) for k in range(3)] + z)
        else:
            cols.append(z + [0.0, 0.0, 0.0])
    return R, p, cols
