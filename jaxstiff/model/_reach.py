"""The reach of a chain: a shell about a fixed point that holds every TCP position the joint limits
allow, and the up-front check that refuses waypoints outside it (numpy only, no JAX).

:func:`chain_reach` (``Robot.reach()``) gives a :class:`Reach`: ``centre`` (3,) m in the base frame,
``outer`` and ``inner`` radii (m). For every posture q within the joint limits (locked joints at
their values) the TCP lies at a distance d from the centre with ``inner <= d <= outer``. Both are
**bounds**, never guesses: a point outside the shell is unreachable; a point inside may still be
unreachable (joint limits, a planar chain's plane), which the solvers then report per waypoint
(status 3).

How the bounds are made (each step is a proof, not a sample):

* **Points.** ``p_i`` is the origin of joint i's frame (before its own motion), ``p_n`` the TCP
  (after the tip transform and tool offset). A revolute joint i turns everything after it about
  an axis through ``p_i``; a prismatic joint shifts it along its axis.
* **Centre.** ``p_0`` never moves. ``p_s`` does not move either when every joint before it is a
  locked joint or a revolute joint whose axis passes through it (the LWR's shoulder ``p_1`` lies
  on ``lwr_a1``'s axis). The centre is the deepest such point.
* **Groups.** The distance ``|p_b - p_a|`` between two points is bounded exactly when at most one
  joint between them changes it: a revolute joint k whose axis passes through ``p_a`` (as seen from
  k's frame) or through ``p_b`` is transparent, a locked joint is a constant; with one active
  revolute joint j the distance is ``|R(a_j, theta) y - x|``, whose extremes over ``theta`` in j's
  range follow in closed form (``A + B cos theta + C sin theta``); with one active prismatic joint
  it is ``|x + q w|`` over q in its range. A single segment ``[p_i, p_i+1]`` is always such a group.
* **Shell.** For a partition of ``p_s .. p_n`` into groups g with distance intervals
  ``[lo_g, hi_g]``: ``d <= sum hi_g`` and ``d >= lo_g - sum_{h != g} hi_h`` (triangle
  inequality, for every q). ``outer`` is the smallest sum over partitions, ``inner`` the largest
  lower bound (at least 0), both by dynamic programming over the points. On the LWR the shoulder
  is the centre and ``[p_1, p_5]`` is one group (``lwr_a3`` and ``lwr_a5`` turn about the links
  themselves, ``lwr_a4`` within +-120 deg): outer 0.868 m, inner 0.317 m.

The padding (1e-12 relative, plus twice every off-axis residue a transparent joint was allowed)
keeps round-off on the safe side. ``Reach`` is a plain numpy record; nothing here is traced.

Check: :func:`check_reach` (used by :func:`jaxstiff.shape`, :func:`jaxstiff.csc_rollout` and
their commands before any solve) raises :class:`UnreachableError` (a ``ValueError``) naming the
path, the waypoint, its distance and the reach, with a hint when the numbers look like millimetres;
:func:`unreachable_mask` gives the same verdict per waypoint (the sweep marks those rows instead).

Example:
    >>> import jaxstiff
    >>> robot = jaxstiff.Robot.from_urdf("kuka_lwr4", locked={"lwr_a7": 0.0})
    >>> r = robot.reach()
    >>> round(r.outer, 3), round(r.inner, 3)
    (0.868, 0.317)
"""

from __future__ import annotations

import dataclasses
import functools
import math
from typing import Any

import numpy as np

from jaxstiff.model._chain import JOINT_PRISMATIC, Chain

__all__ = [
    "Reach",
    "UnreachableError",
    "chain_reach",
    "waypoint_distances",
    "unreachable_mask",
    "check_reach",
    "MM_HINT_REACH",
    "MM_HINT_FACTOR",
    "REACH_MARGIN",
]

#: relative margin of the check: a waypoint is refused only beyond ``outer (1 + REACH_MARGIN) + 1e-9``
#: m or inside ``inner (1 - REACH_MARGIN) - 1e-9`` m (a waypoint on the boundary is a singular posture,
#: reachable in theory: it is left to the solver)
REACH_MARGIN = 1e-6
#: the millimetre hint: a robot whose reach is under this many metres ...
MM_HINT_REACH = 3.0
#: ... and a path whose largest coordinate is over this many times the reach
MM_HINT_FACTOR = 100.0

_PAD = 1e-12  # relative padding of every group bound (round-off)
_ON_AXIS = 1e-9  # m: a point this close to a joint axis counts as on it (the residue is padded)
_MAX_GROUP = 12  # joints a group may span (bounds the work on long chains: O(n * 12^2))


@dataclasses.dataclass(frozen=True)
class Reach:
    """Where a chain's TCP can be: ``inner <= |p_tcp - centre| <= outer`` for every posture within
    the joint limits (locked joints at their values). Lengths in m, base frame.

    Attributes:
        centre: (3,) a point that no joint moves (the origin of joint ``centre_joint``'s frame).
        outer: the largest distance from the centre any posture can give (an upper bound).
        inner: the smallest (a lower bound; 0 where no hole can be proved).
        centre_joint: the joint whose frame origin is the centre.
    """

    centre: np.ndarray
    outer: float
    inner: float
    centre_joint: str

    def distance(self, points: Any, planar: bool = False) -> np.ndarray:
        """Distance (m) of each point (..., 3) from the centre; ``planar``: in the xy plane only
        (points may then be (..., 2))."""
        p = np.asarray(points, dtype=float)
        if planar:
            return np.linalg.norm(p[..., :2] - self.centre[:2], axis=-1)
        return np.linalg.norm(p - self.centre, axis=-1)

    def contains(self, points: Any, planar: bool = False) -> np.ndarray:
        """Boolean (...): True where a point passes the check (it is not provably out of reach).
        ``planar`` (task "xy"): only the outer radius in the xy plane counts."""
        d = self.distance(points, planar)
        ok = d <= self.outer * (1.0 + REACH_MARGIN) + 1e-9
        if not planar:
            ok &= d >= self.inner * (1.0 - REACH_MARGIN) - 1e-9
        return ok & np.all(np.isfinite(np.asarray(points, dtype=float)), axis=-1)

    def __repr__(self) -> str:
        c = ", ".join(f"{v:.4g}" for v in self.centre)
        return (
            f"Reach(centre=({c}) m at joint {self.centre_joint!r}, outer={self.outer:.4g} m, inner={self.inner:.4g} m)"
        )


class UnreachableError(ValueError):
    """Waypoints outside a robot's reach (:func:`check_reach`), refused before any solve.

    Attributes:
        entries: ``(path, waypoint, distance_m, "beyond" | "inside")`` for every refused waypoint.
        reach: the robot's :class:`Reach`.
    """

    def __init__(self, message: str, entries: list[tuple[int, int, float, str]], reach: Reach):
        super().__init__(message)
        self.entries = entries
        self.reach = reach


# ---------------------------------------------------------------------- geometry
def _rot(axis: np.ndarray, angle: float) -> np.ndarray:
    """Rotation matrix about a unit axis (Rodrigues)."""
    x, y, z = axis
    c, s = math.cos(angle), math.sin(angle)
    C = 1.0 - c
    return np.array(
        [
            [c + x * x * C, x * y * C - z * s, x * z * C + y * s],
            [y * x * C + z * s, c + y * y * C, y * z * C - x * s],
            [z * x * C - y * s, z * y * C + x * s, c + z * z * C],
        ]
    )


def _off_axis(v: np.ndarray, axis: np.ndarray) -> float:
    """Distance of the point v from the line through the origin along the unit ``axis``."""
    return float(np.linalg.norm(v - np.dot(v, axis) * axis))


@dataclasses.dataclass(frozen=True)
class _Joints:
    """The chain as numpy arrays: origins (n+1, 4, 4; the last is the tip), axes, kinds, ranges."""

    O: list[np.ndarray]
    axes: list[np.ndarray]
    prismatic: list[bool]
    locked: list[float | None]
    lo: list[float]
    hi: list[float]

    @staticmethod
    def of(chain: Chain) -> _Joints:
        O = [chain.origin_matrix(i) for i in range(chain.n)] + [chain.tip_matrix]
        return _Joints(
            O=O,
            axes=[np.asarray(a, float) / np.linalg.norm(a) for a in chain.axes],
            prismatic=[t == JOINT_PRISMATIC for t in chain.joint_types],
            locked=list(chain.locked),
            lo=[float(v) for v in chain.lower_limits],
            hi=[float(v) for v in chain.upper_limits],
        )

    def value(self, i: int) -> float:
        """Joint i's locked value, 0 for a free joint (where its motion does not matter)."""
        v = self.locked[i]
        return 0.0 if v is None else float(v)

    def motion(self, i: int, q: float) -> np.ndarray:
        """Joint i's own 4x4 motion at value q."""
        M = np.eye(4)
        if self.prismatic[i]:
            M[:3, 3] = self.axes[i] * q
        else:
            M[:3, :3] = _rot(self.axes[i], q)
        return M


def _angle_extremes(lo: float, hi: float, phi: float) -> tuple[bool, bool]:
    """Whether ``phi`` (the maximiser of cos(theta - phi)) and ``phi + pi`` (its minimiser) lie in
    [lo, hi] modulo 2 pi."""
    if not (math.isfinite(lo) and math.isfinite(hi)) or hi - lo >= 2.0 * math.pi:
        return True, True

    def inside(t: float) -> bool:
        k = math.ceil((lo - t) / (2.0 * math.pi))
        return t + 2.0 * math.pi * k <= hi

    return inside(phi), inside(phi + math.pi)


def _revolute_interval(x: np.ndarray, y: np.ndarray, axis: np.ndarray, lo: float, hi: float) -> tuple[float, float]:
    """min and max over theta in [lo, hi] of ``|R(axis, theta) y - x|``."""
    A = np.dot(axis, x) * np.dot(axis, y)
    B = float(np.dot(x, y) - A)
    C = float(np.dot(x, np.cross(axis, y)))
    base = float(np.dot(x, x) + np.dot(y, y))
    rho, phi = math.hypot(B, C), math.atan2(C, B)
    has_max, has_min = _angle_extremes(lo, hi, phi)
    g = [A + B * math.cos(t) + C * math.sin(t) for t in (lo, hi) if math.isfinite(t)]
    gmax = A + rho if has_max else max(g)
    gmin = A - rho if has_min else min(g)
    dmin = math.sqrt(max(base - 2.0 * gmax, 0.0))
    dmax = math.sqrt(max(base - 2.0 * gmin, 0.0))
    return dmin, dmax


def _prismatic_interval(u: np.ndarray, w: np.ndarray, lo: float, hi: float) -> tuple[float, float]:
    """min and max over q in [lo, hi] of ``|u + q w|`` (w a unit vector)."""
    ends = [float(np.linalg.norm(u + q * w)) for q in (lo, hi)]
    qs = min(max(-float(np.dot(u, w)), lo), hi)
    return float(np.linalg.norm(u + qs * w)), max(ends)


def _free(J: _Joints, k: int) -> bool:
    return J.locked[k] is None


def _group(J: _Joints, a: int, b: int) -> tuple[float, float] | None:
    """Bounds of ``|p_b - p_a|`` over every posture, or None when more than one joint between
    them changes it (see the module docstring)."""
    pad = 0.0
    # p_a in the coordinates of frame (a+1) before its motion
    if J.prismatic[a] and _free(J, a):
        j, x = a, np.zeros(3)  # the prismatic joint a itself moves p_b relative to p_a
    else:
        Ma = J.motion(a, J.value(a))
        x = (np.linalg.inv(Ma @ J.O[a + 1]) @ np.r_[0.0, 0.0, 0.0, 1.0])[:3]
        j = a + 1
        while j < b:
            if not _free(J, j):
                x = (np.linalg.inv(J.motion(j, J.value(j)) @ J.O[j + 1]) @ np.r_[x, 1.0])[:3]
            elif not J.prismatic[j] and (e := _off_axis(x, J.axes[j])) <= _ON_AXIS:
                pad += 2.0 * e
                x = (np.linalg.inv(J.O[j + 1]) @ np.r_[x, 1.0])[:3]
            else:
                break
            j += 1
        if j == b:  # nothing between moves p_b relative to p_a: x is p_a seen from p_b's frame
            d = float(np.linalg.norm(x))
            return max(d - pad, 0.0), d + pad
    # p_b in the coordinates of frame j after its motion, absorbing the joints after j
    y = J.O[b][:3, 3].copy()
    k = b - 1
    while k > j:
        if not _free(J, k):
            y = (J.O[k] @ J.motion(k, J.value(k)) @ np.r_[y, 1.0])[:3]
        elif not J.prismatic[k] and (e := _off_axis(y, J.axes[k])) <= _ON_AXIS:
            pad += 2.0 * e
            y = (J.O[k] @ np.r_[y, 1.0])[:3]
        else:
            return None  # a second joint changes the distance
        k -= 1
    if J.prismatic[j]:
        lo, hi = _prismatic_interval(y - x, J.axes[j], J.lo[j], J.hi[j])
    else:
        lo, hi = _revolute_interval(x, y, J.axes[j], J.lo[j], J.hi[j])
    return max(lo - pad, 0.0), hi + pad


def _centre_index(J: _Joints, n: int) -> int:
    """The deepest point p_s that no joint moves (module docstring)."""
    best = 0
    for s in range(1, n + 1):
        y, fixed = J.O[s][:3, 3].copy(), True
        for k in range(s - 1, -1, -1):
            if not _free(J, k):
                y = (J.O[k] @ J.motion(k, J.value(k)) @ np.r_[y, 1.0])[:3]
            elif not J.prismatic[k] and _off_axis(y, J.axes[k]) <= 1e-12:
                y = (J.O[k] @ np.r_[y, 1.0])[:3]
            else:
                fixed = False
                break
        if not fixed:
            break
        best = s
    return best


def _point_at_rest(J: _Joints, s: int) -> np.ndarray:
    """p_s in the base frame with every free joint at 0 (exact for a fixed point)."""
    T = np.eye(4)
    for k in range(s):
        T = T @ J.O[k] @ J.motion(k, J.value(k))
    return (T @ J.O[s])[:3, 3]


@functools.lru_cache(maxsize=64)
def chain_reach(chain: Chain) -> Reach:
    """The :class:`Reach` of a chain (module docstring: how the bounds are proved). Cached per chain."""
    J, n = _Joints.of(chain), chain.n
    s = _centre_index(J, n)
    groups: dict[tuple[int, int], tuple[float, float]] = {}
    for a in range(s, n):
        for b in range(a + 1, min(n, a + _MAX_GROUP) + 1):
            g = _group(J, a, b)
            if g is not None:
                lo, hi = g
                groups[(a, b)] = (max(lo - _PAD * (1.0 + hi), 0.0), hi + _PAD * (1.0 + hi))
    inf = math.inf
    pre = {s: 0.0}  # smallest sum of hi over partitions of [p_s, p_i]
    for b in range(s + 1, n + 1):
        pre[b] = min((pre[a] + groups[(a, b)][1] for a in range(s, b) if (a, b) in groups), default=inf)
    suf = {n: 0.0}  # ... of [p_i, p_n]
    for a in range(n - 1, s - 1, -1):
        suf[a] = min((groups[(a, b)][1] + suf[b] for b in range(a + 1, n + 1) if (a, b) in groups), default=inf)
    outer = pre[n]
    inner = max((lo - pre[a] - suf[b] for (a, b), (lo, _) in groups.items()), default=0.0)
    centre = _point_at_rest(J, s)
    name = chain.joint_names[s] if s < n else chain.tip_link or "tcp"
    return Reach(centre=centre, outer=float(outer), inner=float(max(inner, 0.0)), centre_joint=name)


# ---------------------------------------------------------------------- the check
def waypoint_distances(chain: Chain, points: Any, planar: bool = False) -> np.ndarray:
    """Distances (m) of the waypoints (..., 3) from the centre of the chain's reach."""
    return chain_reach(chain).distance(points, planar)


def unreachable_mask(chain: Chain, points: Any, planar: bool = False) -> np.ndarray:
    """Boolean (...): True where a waypoint (..., 3) lies provably out of the chain's reach
    (:meth:`Reach.contains`; non-finite points are left to the input checks)."""
    p = np.asarray(points, dtype=float)
    finite = np.all(np.isfinite(p), axis=-1)
    return ~chain_reach(chain).contains(p, planar) & finite


def _fmt(p: np.ndarray) -> str:
    return "(" + ", ".join(f"{v:.4g}" for v in p) + ")"


def _mm_hint(reach: Reach, points: np.ndarray) -> str:
    """A hint when the path looks as if it were written in millimetres."""
    big = float(np.max(np.abs(points[np.isfinite(points)]), initial=0.0))
    if reach.outer < MM_HINT_REACH and big > MM_HINT_FACTOR * reach.outer:
        return (
            f"; the coordinates look like millimetres (the largest is {big:.6g}, over {MM_HINT_FACTOR:g} times the "
            f"reach): paths are in metres, divide them by 1000"
        )
    return ""


def check_reach(chain: Chain, points: Any, planar: bool = False, shown: int = 3) -> None:
    """Refuse waypoints outside the chain's reach, before any solve.

    Args:
        chain: the robot.
        points: (P, 3) one path or (B, P, 3) a batch, m, base frame (task "xy": (..., 2) allowed).
        planar: task "xy": only the distance in the xy plane against ``outer`` counts (a planar
            chain's z is not matched).
        shown: how many refused waypoints the message names (the count says how many in all).

    Raises:
        UnreachableError: some waypoint lies beyond ``outer`` or inside ``inner``; the message
            names the robot, the path and waypoint, its position and distance from the centre,
            and the reach; ``entries`` lists every one.
    """
    p = np.asarray(points, dtype=float)
    batch: np.ndarray = p.reshape((-1,) + p.shape[-2:]) if p.ndim >= 2 else p.reshape(1, 1, -1)
    bad = unreachable_mask(chain, batch, planar)
    if not bad.any():
        return
    reach = chain_reach(chain)
    d = reach.distance(batch, planar)
    entries = [
        (int(i[0]), int(i[1]), float(d[i[0], i[1]]), "beyond" if d[i[0], i[1]] > reach.outer else "inside")
        for i in np.argwhere(bad)
    ]
    many = len(batch) > 1
    runs: list[list[Any]] = []  # [path, first, last, distance, kind]: consecutive equal points (a hold) as one
    for b, k, dist, kind in entries:
        last = runs[-1] if runs else None
        if last is not None and last[0] == b and last[2] == k - 1 and np.array_equal(batch[b, k], batch[b, k - 1]):
            last[2] = k
        else:
            runs.append([b, k, k, dist, kind])
    parts = []
    for b, k0, k1, dist, kind in runs[:shown]:
        name = (f"path {b} " if many else "") + (f"waypoint {k0}" if k0 == k1 else f"waypoints {k0}-{k1}")
        verb = "is" if k0 == k1 else "are"
        parts.append(f"{name} at {_fmt(batch[b, k0])} m {verb} {dist:.4g} m from the centre ({kind})")
    paths = sorted({b for b, _, _, _ in entries})
    count = f"{len(entries)} of {bad.size} waypoints" + (
        f" (paths {', '.join(map(str, paths[:10]))}{', ...' if len(paths) > 10 else ''})" if many else ""
    )
    rest = sum(r[2] - r[1] + 1 for r in runs[shown:])
    more = f"; ... and {rest} more" if rest else ""
    shell = (
        f"beyond {reach.outer:.4g} m"
        if planar or reach.inner == 0.0
        else f"beyond {reach.outer:.4g} m or inside {reach.inner:.4g} m"
    )
    msg = (
        f"robot {chain.name!r} cannot reach {count}: " + "; ".join(parts) + more + f" (its reach: no posture puts "
        f"the TCP {shell} from the origin of joint {reach.centre_joint!r} at {_fmt(reach.centre)} m"
        + (", in the xy plane" if planar else "")
        + "; Robot.reach()); refused before any solve"
        + _mm_hint(reach, batch)
    )
    raise UnreachableError(msg, entries, reach)
