"""Chain data: the static, hashable description of a serial chain and the helpers that build it.

Every number of the chain is kept as a Python float inside tuples, so a :class:`Chain` is hashable
and ``jax.jit`` compiles one kernel per chain: the geometry becomes compile-time constants, which
lets the kinematics kernel skip every multiplication by a structural zero or one. The kinematics
(:mod:`jaxstiff.model._kinematics`) reads a Chain; :class:`jaxstiff.model._robot.Robot` is a Chain
that also reads URDF files and has FK/Jacobian methods.
"""

from __future__ import annotations

import dataclasses
import enum
import math
import sys
from collections.abc import Collection, Mapping, Sequence
from typing import Any

import numpy as np

from jaxstiff.runtime._dtypes import refuse_half_precision
from jaxstiff.runtime._messages import suggest

__all__ = ["JointType", "JOINT_REVOLUTE", "JOINT_PRISMATIC", "tuple_to_mat", "LOCKED_TOL"]

#: What a locked joint is (SPEC section 1): ``"rigid"`` (the default: no spring, so no compliance
#: term and no stiffness variable; its ``kj`` entry in results is ``+inf``) or ``"spring"`` (it
#: keeps a spring whose stiffness is optimised like a free joint's). ``jaxstiff.settings._shape``'s
#: ``locked_joints`` and the solvers' ``WaypointProblem`` take these names.
LOCKED_JOINT_MODES = ("rigid", "spring")

#: rad (m for prismatic joints): largest difference between a given value of a locked joint and
#: its locked value that :func:`check_locked_values` accepts
LOCKED_TOL = 1e-9


class JointType(enum.IntEnum):
    """Joint type codes, as stored in :attr:`Chain.joint_types` (plain ints in the tuple)."""

    REVOLUTE = 0  #: revolute and continuous joints (values in rad, stiffness in Nm/rad)
    PRISMATIC = 1  #: prismatic joints (values in m, stiffness in N/m)


JOINT_REVOLUTE = int(JointType.REVOLUTE)  #: joint type code of revolute and continuous joints
JOINT_PRISMATIC = int(JointType.PRISMATIC)  #: joint type code of prismatic joints

_SNAP = 1e-14  # |x| below this in a constant rotation/axis entry is a structural zero


def snap(x: float) -> float:
    """Snap round-off around 0 and +-1 (e.g. cos(pi/2) = 6e-17) to the exact value."""
    for exact in (0.0, 1.0, -1.0):
        if abs(x - exact) < _SNAP:
            return exact
    return float(x)


def mat_to_tuple(T: np.ndarray) -> tuple[tuple[float, ...], ...]:
    """4x4 homogeneous transform -> (R rows..., p) tuple of 3 rows of 4 floats (last row implied)."""
    return tuple(tuple(snap(v) for v in T[i, :4]) for i in range(3))


def tuple_to_mat(t: tuple[tuple[float, ...], ...]) -> np.ndarray:
    T = np.eye(4)
    T[:3, :4] = np.asarray(t, dtype=float)
    return T


@dataclasses.dataclass(frozen=True, eq=False, repr=False)
class Chain:
    """A serial chain with n actuated joints, static and hashable.

    Attributes:
        name: robot name from the URDF.
        joint_names: the n actuated (revolute, continuous, prismatic) joints, base to tip.
        joint_types: per joint, :data:`JOINT_REVOLUTE` or :data:`JOINT_PRISMATIC`.
        origins: per joint, the constant transform from the previous joint's moving frame
            (or the base link) to this joint's frame, fixed joints folded in; each as 3 rows
            of 4 floats ``(R | p)``.
        axes: per joint, the unit joint axis in the joint frame.
        tip: constant transform from the last joint's moving frame to the TCP (fixed joints
            after the last actuated joint, then the ``tcp`` offset).
        lower, upper: joint limits (rad or m); ``-inf``/``inf`` for continuous joints.
        locked: per joint, the locked value or ``None`` for a free joint.
        base_link, tip_link: the links the chain runs between.
        source: the file the robot was read from ("" if built in code).
    """

    name: str
    joint_names: tuple[str, ...]
    joint_types: tuple[int, ...]
    origins: tuple[tuple[tuple[float, ...], ...], ...]
    axes: tuple[tuple[float, float, float], ...]
    tip: tuple[tuple[float, ...], ...]
    lower_limits: tuple[float, ...]
    upper_limits: tuple[float, ...]
    locked: tuple[float | None, ...]
    base_link: str = ""
    tip_link: str = ""
    source: str = ""

    # ------------------------------------------------------------------ identity
    # jit hashes its static arguments on every call, and hashing ~100 nested floats costs as much
    # as a small FK call (docs/notes/model.md), so the hash is computed once and cached. The
    # cache is never pickled (string hashes differ between processes).
    def _key(self) -> tuple:
        return tuple(getattr(self, f.name) for f in dataclasses.fields(self))

    def __eq__(self, other: Any) -> bool:
        if self is other:
            return True
        if other.__class__ is not self.__class__:
            return NotImplemented
        return self._key() == other._key()

    def __hash__(self) -> int:
        h = self.__dict__.get("_hash")
        if h is None:
            h = hash(self._key())
            object.__setattr__(self, "_hash", h)
        return h

    def __repr__(self) -> str:
        """One line: name, joints (abbreviated past four), base and tip links, locks, TCP offset;
        :meth:`describe` gives the table, the fields give the numbers."""
        names = self.joint_names
        shown = ", ".join(names) if len(names) <= 4 else f"{names[0]}, {names[1]}, ..., {names[-1]}"
        locks = ", ".join(f"{n}={v:g}" for n, v in zip(names, self.locked, strict=True) if v is not None)
        tcp = self.tip_matrix[:3, 3]
        return (
            f"{type(self).__name__}({self.name!r}, {self.n} joints [{shown}], {self.base_link!r} -> "
            f"{self.tip_link!r}, locked: {locks or 'none'}, tip offset ({tcp[0]:.4g}, {tcp[1]:.4g}, {tcp[2]:.4g}) m)"
        )

    def fingerprint(self) -> str:
        """sha256 (hex) of the chain's content (every field but ``source``): equal for chains
        that trace to the same kinematics in any process (a disk cache key; ``hash`` is
        per-process)."""
        import hashlib

        key = tuple(getattr(self, f.name) for f in dataclasses.fields(self) if f.name != "source")
        return hashlib.sha256(f"{type(self).__name__}{key!r}".encode()).hexdigest()

    def __getstate__(self) -> dict:
        state = dict(self.__dict__)
        state.pop("_hash", None)
        return state

    def __setstate__(self, state: dict) -> None:
        self.__dict__.update(state)

    # ------------------------------------------------------------------ properties
    @property
    def n(self) -> int:
        """Number of actuated joints (locked ones included)."""
        return len(self.joint_names)

    @property
    def lower(self) -> np.ndarray:
        """Lower joint limits, shape (n,)."""
        return np.asarray(self.lower_limits, dtype=float)

    @property
    def upper(self) -> np.ndarray:
        """Upper joint limits, shape (n,)."""
        return np.asarray(self.upper_limits, dtype=float)

    @property
    def free(self) -> np.ndarray:
        """Boolean mask (n,): True where the joint is free (not locked)."""
        return np.asarray([v is None for v in self.locked], dtype=bool)

    @property
    def prismatic(self) -> np.ndarray:
        """Boolean mask (n,): True where the joint is prismatic (its values are lengths, m)."""
        return np.asarray(self.joint_types) == JOINT_PRISMATIC

    @property
    def n_free(self) -> int:
        """Number of free joints."""
        return int(self.free.sum())

    @property
    def locked_values(self) -> np.ndarray:
        """Locked value per joint, NaN for free joints, shape (n,)."""
        return np.asarray([np.nan if v is None else v for v in self.locked], dtype=float)

    @property
    def length_scale(self) -> float:
        """The chain's size (m): the distances between consecutive joint frames and to the TCP, plus
        the spans of bounded prismatic joints (the base's offset to the first joint not counted);
        1.0 for a chain without any. Solvers that weigh position errors against dimensionless
        terms divide by it, so that a robot built ten times larger is solved alike."""
        size = sum(float(np.linalg.norm(self.origin_matrix(i)[:3, 3])) for i in range(1, self.n))
        size += float(np.linalg.norm(self.tip_matrix[:3, 3]))
        span = np.asarray(self.upper_limits, float) - np.asarray(self.lower_limits, float)
        size += float(np.sum(np.where(self.prismatic & np.isfinite(span), span, 0.0)))
        return size if size > 0 else 1.0

    def origin_matrix(self, i: int) -> np.ndarray:
        """Constant 4x4 transform into joint ``i``'s frame (fixed joints folded in)."""
        return tuple_to_mat(self.origins[i])

    @property
    def tip_matrix(self) -> np.ndarray:
        """Constant 4x4 transform from the last joint frame to the TCP."""
        return tuple_to_mat(self.tip)

    def with_locked(self, locked: Mapping[str, float] | None) -> Chain:
        """A copy with a new set of locked joints (``None`` or ``{}`` frees all)."""
        values = check_locked(self.joint_names, self.lower_limits, self.upper_limits, locked)
        return dataclasses.replace(self, locked=values)

    def with_tcp(self, tcp: Sequence[float] | np.ndarray | None) -> Chain:
        """A copy with an extra tool offset appended after the current TCP."""
        T = self.tip_matrix @ tcp_matrix(tcp)
        return dataclasses.replace(self, tip=mat_to_tuple(T))

    def check_q(self, q: Any, name: str = "q") -> Any:
        """Validate a joint array at the Python boundary: floating dtype, last axis n, finite, and
        locked joints at their locked values (:func:`check_locked_values`).

        Returns the array as a JAX/numpy array unchanged in dtype. Raises ValueError naming the problem
        (for text, None or a ragged list one that is also a TypeError).
        """
        return check_q(self, q, name)

    def describe(self) -> str:
        """A human-readable table of the chain: joints, types, axes, limits, locks."""
        lines = [
            f"robot {self.name!r}: {self.n} actuated joints ({self.n_free} free), "
            f"chain {self.base_link!r} -> {self.tip_link!r}",
            f"{'#':>2} {'joint':<20} {'type':<10} {'axis':<22} {'lower':>12} {'upper':>12}  lock",
        ]
        for i, name in enumerate(self.joint_names):
            revolute = self.joint_types[i] == JOINT_REVOLUTE
            lo, hi = self.lower_limits[i], self.upper_limits[i]
            kind = "prismatic" if not revolute else "continuous" if math.isinf(lo) and math.isinf(hi) else "revolute"
            unit = "deg" if revolute else "m"
            if revolute:
                lo, hi = math.degrees(lo), math.degrees(hi)
            axis = "(" + ", ".join(f"{a:+.3f}" for a in self.axes[i]) + ")"
            lock = "" if self.locked[i] is None else f"locked at {self.locked[i]:g} {'rad' if revolute else 'm'}"
            lines.append(
                f"{i:>2} {name:<20} {kind:<10} {axis:<22} {lo:>8.2f} {unit:<3} {hi:>8.2f} {unit:<3}  {lock}".rstrip()
            )
        tip = self.tip_matrix[:3, 3]
        lines.append(f"TCP offset after the last joint frame: ({tip[0]:.4f}, {tip[1]:.4f}, {tip[2]:.4f}) m")
        return "\n".join(lines)


def check_locked(
    joint_names: Sequence[str],
    lower: Sequence[float],
    upper: Sequence[float],
    locked: Mapping[str, float] | None,
    *,
    off_chain: Collection[str] = (),
    ends: tuple[str, str] | None = None,
    cannot_move: Mapping[str, str] | None = None,
) -> tuple[float | None, ...]:
    """Per joint, the locked value (checked: a known joint, finite, within its limits) or None.

    ``off_chain``: the URDF's joints that are not on the chain (another branch, or above the base), and
    ``ends``: the chain's ``(base_link, tip_link)``; locking one of those joints is refused with a
    message that says so, not "unknown joint" (``parse_urdf_chain`` passes them). ``cannot_move``:
    the URDF's joints no chain can hold as a joint, on the chain or off it, each with why (``"it is a
    fixed joint ..."``, ``"it mimics joint 'j1' ..."``): locking one is refused with that reason, not
    with "unknown" or "choose another chain". An unknown name gets a "did you mean" (the chain's
    joints first, then the URDF's others)."""
    values: list[float | None] = [None] * len(joint_names)
    if not locked:
        return tuple(values)
    if not isinstance(locked, Mapping):
        raise ValueError(f"locked must be a mapping {{joint_name: value}}, got {type(locked).__name__}")
    for name, value in locked.items():
        if name not in joint_names and cannot_move and name in cannot_move:
            raise ValueError(
                f"cannot lock joint {name!r}: {cannot_move[name]}; only the chain's actuated joints can be "
                f"locked: {', '.join(joint_names)}"
            )
        if name not in joint_names and name in off_chain:
            chain = f"from {ends[0]!r} to {ends[1]!r}" if ends else "of the robot"
            raise ValueError(
                f"cannot lock joint {name!r}: it is in the URDF but not on the chain {chain}, whose actuated "
                f"joints are {', '.join(joint_names)} (only those can be locked; for a chain through "
                f"{name!r}, choose base_link / tip_link, command line: --base-link / --tip-link)"
            )
        if name not in joint_names:
            # a near miss among the joints that can be locked first, else among the URDF's others
            near = suggest(str(name), joint_names) or suggest(str(name), [*off_chain, *(cannot_move or ())])
            raise ValueError(
                f"cannot lock unknown joint {name!r}{near}; actuated joints of the chain: {', '.join(joint_names)}"
            )
        try:
            v = float(value)
        except (TypeError, ValueError):
            raise ValueError(f"locked value of joint {name!r} must be a number, got {value!r}") from None
        i = joint_names.index(name)
        if not math.isfinite(v):
            raise ValueError(f"locked value of joint {name!r} must be finite, got {v}")
        if v < lower[i] or v > upper[i]:
            raise ValueError(f"locked value {v:g} of joint {name!r} is outside its limits [{lower[i]:g}, {upper[i]:g}]")
        values[i] = v
    return tuple(values)


def tcp_transform(tcp: Sequence[float]) -> np.ndarray:
    """4x4 tool transform of ``(x, y, z[, roll, pitch, yaw])`` (m, rad; R = Rz(yaw) Ry(pitch) Rx(roll))."""
    v = [float(x) for x in tcp]
    if len(v) not in (3, 6):
        raise ValueError(f"tcp must be 3 values x,y,z or 6 values x,y,z,roll,pitch,yaw, got {len(v)}")
    T = np.eye(4)
    T[:3, 3] = v[:3]
    if len(v) == 6:
        r, p, y = v[3:]
        cr, sr, cp, sp, cy, sy = math.cos(r), math.sin(r), math.cos(p), math.sin(p), math.cos(y), math.sin(y)
        T[:3, :3] = np.array(
            [
                [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
                [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
                [-sp, cp * sr, cp * cr],
            ]
        )
    return T


#: the largest tool offset taken, m (the path's coordinates have the same bound: their squares,
#: summed into lengths, stay finite in float64)
TCP_MAX_M = 1e150


def tcp_matrix(tcp: Sequence[float] | np.ndarray | None) -> np.ndarray:
    """A tool offset as a 4x4 transform: None (identity), a 3-vector (m), a 6-vector ``(x, y, z,
    roll, pitch, yaw)`` (m, rad; :func:`tcp_transform`, as the commands' ``--tcp``) or a 4x4
    transform (checked)."""
    if tcp is None:
        return np.eye(4)
    try:
        T = np.asarray(tcp, dtype=float) if not isinstance(tcp, str) else None
    except (TypeError, ValueError):
        T = None
    shown = np.asarray(tcp).tolist() if isinstance(tcp, np.ndarray) else tcp  # (one line, not numpy's repr)
    if T is None or T.shape not in ((3,), (6,), (4, 4)):
        raise ValueError(
            f"tcp must be a 3-vector (m), a 6-vector x,y,z,roll,pitch,yaw (m, rad) or a 4x4 transform, got {shown!r}"
        )
    if not np.all(np.isfinite(T)):
        raise ValueError(f"tcp contains NaN or Inf: {shown!r}")
    offset = T[:3, 3] if T.shape == (4, 4) else T[:3]
    if np.max(np.abs(offset)) > TCP_MAX_M:
        raise ValueError(
            f"tcp offset {shown!r}: beyond {TCP_MAX_M:g} m (the reach and lengths built from it overflow float64)"
        )
    if T.shape == (6,):
        return tcp_transform(T.tolist())
    if T.shape == (3,):
        M = np.eye(4)
        M[:3, 3] = T
        return M
    R = T[:3, :3]
    if not np.allclose(R @ R.T, np.eye(3), atol=1e-9) or not np.allclose(T[3], [0, 0, 0, 1]):
        raise ValueError("tcp 4x4 transform must have an orthonormal rotation block and last row (0, 0, 0, 1)")
    return T


def check_q(robot: Chain, q: Any, name: str = "q") -> Any:
    """Validate a joint array at the Python boundary (see :meth:`Chain.check_q`)."""
    import jax.numpy as jnp

    from jaxstiff._numerics.batch import NotNumbersError

    if isinstance(q, (list, tuple)):
        try:
            q = np.asarray(q, dtype=float)
        except (TypeError, ValueError):  # a ragged nested list, or text or None in it
            raise NotNumbersError(
                f"{name} must be joint values, numbers of shape (..., {robot.n}) (rad; m for prismatic joints): got a "
                "nested sequence that is not one (rows of different lengths, or not numbers)"
            ) from None
    if not hasattr(q, "dtype") or not hasattr(q, "shape"):
        raise NotNumbersError(f"{name} must be an array of numbers of shape (..., {robot.n}), got {type(q).__name__}")
    if not jnp.issubdtype(q.dtype, jnp.floating):
        raise ValueError(
            f"{name} must have a floating dtype (float32 or float64), got {q.dtype}; convert with q.astype(float)"
        )
    refuse_half_precision(f"robot {robot.name!r}", **{name: q})  # the one rule (jaxstiff.runtime._dtypes)
    if q.ndim == 0 or q.shape[-1] != robot.n:
        raise ValueError(
            f"{name} must have shape (..., {robot.n}) for robot {robot.name!r} "
            f"({robot.n} actuated joints), got shape {tuple(q.shape)}"
        )
    if not is_traced(q):
        a = np.asarray(q)
        if not np.all(np.isfinite(a)):
            idx = tuple(int(i) for i in np.argwhere(~np.isfinite(a))[0])
            raise ValueError(
                f"{name} contains NaN or Inf: {name}{list(idx)} = {a[idx]} "
                f"(joint {robot.joint_names[idx[-1]]!r} of robot {robot.name!r})"
            )
        check_locked_values(robot, a, name)
    return q


def check_locked_values(robot: Chain, q: Any, name: str = "q") -> None:
    """Refuse a joint array whose locked joints are not at their locked values.

    A locked joint stays in ``q`` (SPEC section 1), and every entry point (``Robot.fk``,
    ``jacobian``, ``fk_and_jacobian``, ``jaxstiff.shape``'s ``q0``, ``jaxstiff.ik``, CSC) checks
    ``q`` with this one function, so a value that is not the locked one is never silently used
    (nor silently replaced).

    Args:
        robot: the chain (its ``locked`` values).
        q: (..., n) joint values, rad (m for prismatic joints); anything ``numpy.asarray`` reads.
            A JAX tracer (inside ``jit``, ``grad``, ``vmap``) is not checked: its values are unknown.
        name: how the error message calls the array (a flag or parameter name).

    Raises:
        ValueError: if some ``|q[..., i] - locked_i| > LOCKED_TOL`` (1e-9; for a float32 or
            float16 ``q``, the rounding of the locked value in that dtype, ``2 eps max(1, |locked_i|)``,
            if larger) for a locked joint i,
            naming the first such entry, the joint, the given and the locked value, e.g.
            ``q[..., 6] = 0.3 for joint 'lwr_a7' of robot 'kuka_lwr4', which is locked at 0; pass the
            locked value (0) there, or build the robot without locking the joint (locked=... /
            --lock)``. (The shape of ``q`` is not checked here: :func:`check_q` does that.)
    """
    if is_traced(q) or all(v is None for v in robot.locked):
        return
    dt = getattr(q, "dtype", None)
    eps = float(np.finfo(dt).eps) if dt is not None and np.issubdtype(dt, np.floating) else 0.0
    a = np.asarray(q, dtype=float)
    if a.ndim == 0 or a.shape[-1] != robot.n:
        return
    for i, v in enumerate(robot.locked):
        if v is None:
            continue
        tol = max(LOCKED_TOL, 2.0 * eps * max(1.0, abs(v)))  # 0.2 in float32 is 0.2 + 3e-9
        bad = ~(np.abs(a[..., i] - v) <= tol)
        if np.any(bad):
            at = tuple(int(j) for j in np.argwhere(bad)[0]) if a.ndim > 1 else ()
            where = f"{name}[{', '.join(map(str, at))}{', ' if at else ''}{i}]" if a.ndim > 1 else f"{name}[{i}]"
            got = float(a[at + (i,)])
            raise ValueError(
                f"{where} = {got:g} for joint {robot.joint_names[i]!r} of robot {robot.name!r}, which is locked at "
                f"{v:g}; pass the locked value ({v:g}) there, or build the robot without locking the joint "
                "(locked=... / --lock)"
            )


def is_traced(x: object) -> bool:
    """True inside a JAX trace (jit, grad, vmap). Without JAX loaded nothing is traced: the chain's
    checks then import no JAX (``jaxstiff view`` reads a URDF and draws with numpy only)."""
    if "jax" not in sys.modules:
        return False
    from jaxstiff._numerics.batch import is_traced as traced

    return traced(x)
