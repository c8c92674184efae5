"""What a CSC rollout returns: :class:`CSCResult` (arrays, shapes, units) and the status bits.

Row ``k`` of every per-step array is the posture reached by step ``k``, measured against
waypoint ``k``'s target and ``K_xd`` (SPEC section 6).
"""

from __future__ import annotations

import dataclasses
import enum
import os
from typing import Any

import jax
import numpy as np

__all__ = ["CSCResult"]


class CSCStatus(enum.IntFlag):
    """Bits of :attr:`CSCResult.status` (the int values written to result files never change)."""

    OK = 0  #: a plain step
    DAMPED = 1  #: isotropy below ``nu0^(m/2)``: the damped pseudo-inverse was active (near singular)
    JOINT_LIMIT = 2  #: a free joint was clamped at its limit after the step
    NAN = 4  #: the step came out non-finite and was replaced by no motion
    NULL_SMALL = 8  #: ``|dq_N| < null_eps``: at a stationary point of the objective on the self-motion manifold


STATUS_OK = CSCStatus.OK
STATUS_DAMPED = CSCStatus.DAMPED
STATUS_JOINT_LIMIT = CSCStatus.JOINT_LIMIT
STATUS_NAN = CSCStatus.NAN
STATUS_NULL_SMALL = CSCStatus.NULL_SMALL

#: text of each status bit (a result file's ``meta["status_bits"]``, keyed by the bit's int)
STATUS_NAMES: dict[int, str] = {
    int(CSCStatus.DAMPED): "damped (near singular)",
    int(CSCStatus.JOINT_LIMIT): "joint limit reached",
    int(CSCStatus.NAN): "NaN guard (step dropped)",
    int(CSCStatus.NULL_SMALL): "null-space gradient below null_eps",
}


def describe_status(code: int) -> str:
    """Human-readable text of a status bit mask (``0`` -> ``"ok"``)."""
    code = int(code)
    if code == 0:
        return "ok"
    return ", ".join(name for bit, name in STATUS_NAMES.items() if code & bit)


@jax.tree_util.register_dataclass
@dataclasses.dataclass(frozen=True)
class CSCResult:
    """One or a batch of CSC rollouts. Leading axes ``*B`` are the broadcast batch of the inputs.

    Row ``k`` of every per-step array describes the posture reached by step ``k``, i.e. after the
    arm was sent towards waypoint ``k``, measured against waypoint ``k``'s target and ``K_xd``.

    Attributes:
        q: (*B, T, n) joint values (rad; m for prismatic), locked joints included.
        u: (*B, T) off-diagonal norm ``u(q)`` of ``J^T K_xd J`` (S1-19), Nm/rad (over the free
            joints with rigid locked joints). Reported whichever objective the step lowers.
        frobenius: (*B, T) ``|K_xd - K_C|_F`` (S1-10) with the realised ``K_C``, N/m. Reported
            whichever objective the step lowers.
        tracking_error: (*B, T) ``|x_d - x(q)|`` over the task's position rows, m.
        orientation_error: (*B, T) angle of the held-orientation error (task ``"full"``), rad; 0 otherwise.
        kj: (*B, T, n) realised joint stiffness ``clip(diag(J^T K_xd J), kmin, kmax)``, Nm/rad;
            +inf for a rigid locked joint (``locked_joints="rigid"``: no spring, not a variable; the
            compliance ``1/kj`` is 0, so ``J diag(1/kj) J^T`` of the file is right as it is).
        K_C: (*B, T, m, m) realised Cartesian stiffness (S0-4) from ``kj``.
        position: (*B, T, 3) TCP position, m, base frame.
        target: (*B, T, d) the path targets used (d = 2 for ``"xy"``, else 3), m.
        isotropy: (*B, T) ``nu = det(J J^T) / (tr(J J^T)/m)^m`` of the free joints, in [0, 1].
        null_step: (*B, T) length of the null-space step ``|alpha dq_N|`` taken in step k, rad.
        status: (*B, T) int32 bit mask of :class:`CSCStatus` (:data:`STATUS_DAMPED`,
            :data:`STATUS_JOINT_LIMIT`, :data:`STATUS_NAN`, :data:`STATUS_NULL_SMALL`; 0 = plain
            step) of step k, the step that reached row k's posture. It was computed at the posture
            before it, so its :data:`STATUS_DAMPED` goes with ``isotropy`` of row k - 1 (of the
            start posture for k = 0).
        u_start: (*B,) ``u`` at the start posture (with the first waypoint's ``K_xd``).
        frobenius_start: (*B,) ``|K_xd - K_C|_F`` at the start posture.
    """

    q: jax.Array
    u: jax.Array
    frobenius: jax.Array
    tracking_error: jax.Array
    orientation_error: jax.Array
    kj: jax.Array
    K_C: jax.Array
    position: jax.Array
    target: jax.Array
    isotropy: jax.Array
    null_step: jax.Array
    status: jax.Array
    u_start: jax.Array
    frobenius_start: jax.Array

    def as_dict(self) -> dict[str, Any]:
        """The fields as a ``{name: array}`` dict (numpy-convertible)."""
        return {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}

    # ------------------------------------------------------------------ files
    def save(
        self,
        file: str | os.PathLike,
        *,
        joint_names: Any = None,
        meta: dict[str, Any] | None = None,
        **extra: Any,
    ) -> str:
        """Write the result file (the ``jaxstiff csc --out`` format, ``numpy.load(...,
        allow_pickle=False)``) atomically: every field, ``status`` as int64, ``joint_names`` when
        given, the ``extra`` arrays (the command adds ``q0`` and ``K_xd``) and ``meta`` as JSON.
        Returns the path written; an interrupted save leaves no partial file."""
        from jaxstiff.results._npz import atomic_save_npz
        from jaxstiff.runtime._io import meta_dumps

        clash = sorted(set(extra) & {f.name for f in dataclasses.fields(self)} | set(extra) & {"meta", "joint_names"})
        if clash:
            raise ValueError(f"extra arrays must not reuse a field name: {', '.join(clash)}")
        arrays = {name: np.asarray(a) for name, a in self.as_dict().items()}
        arrays["status"] = arrays["status"].astype(np.int64)
        if joint_names is not None:
            arrays["joint_names"] = np.asarray(joint_names, dtype=str)
        arrays.update({k: np.asarray(v) for k, v in extra.items()})
        arrays["meta"] = np.asarray(meta_dumps(dict(meta or {})))
        return atomic_save_npz(file, arrays)

    @staticmethod
    def load(file: str | os.PathLike) -> CSCResult:
        """Read the fields of a file written by :meth:`save` or ``jaxstiff csc`` (no pickles), as
        numpy arrays (float64; ``status`` int32 as a rollout returns it), the schema checked
        (:func:`jaxstiff.results._reader.read_arrays`: keys, shapes against the task, dtypes,
        finiteness, stiffness > 0). The file's extra arrays and its ``meta``:
        :func:`jaxstiff.results._reader.read_arrays`; checked against its robot too:
        :func:`jaxstiff.results._reader.read_result`.

        Raises:
            FileNotFoundError: no such file.
            ValueError: not a CSC result file (a shape result, text, missing fields, wrong shapes,
                dtypes or values): a :class:`~jaxstiff.results._reader.ResultFileError`.
        """
        from jaxstiff.results._reader import read_arrays

        _, arrays, _ = read_arrays(file, "csc")
        data: dict[str, Any] = {f.name: arrays[f.name] for f in dataclasses.fields(CSCResult)}
        data["status"] = data["status"].astype(np.int32)
        return CSCResult(**data)

    def __repr__(self) -> str:
        """A short summary (size, u and Frobenius error at the start and the end, status counts), not the arrays."""
        shape = tuple(np.shape(self.q))
        head = f"CSCResult(batch {shape[:-2]}, {shape[-2]} steps, {shape[-1]} joints"
        try:
            u, fr, st = np.asarray(self.u), np.asarray(self.frobenius), np.asarray(self.status)
            codes, counts = np.unique(st, return_counts=True)
            status = ", ".join(f"{describe_status(int(c))} {int(k)}" for c, k in zip(codes, counts, strict=True))
            return (
                f"{head}; u {np.mean(np.asarray(self.u_start)):.4g} -> {np.mean(u[..., -1]):.4g} Nm/rad, "
                f"|K_xd - K_C|_F {np.mean(np.asarray(self.frobenius_start)):.4g} -> {np.mean(fr[..., -1]):.4g} N/m "
                f"(mean over the batch); status: {status})"
            )
        except Exception:  # traced arrays (inside jit): shapes only
            return head + ")"


START_FIELDS = ("u_start", "frobenius_start")  #: per rollout, no step axis


def step_axis(name: str, ndim: int) -> int:
    """Axis of the steps in a CSCResult field with ``ndim`` dimensions: (*B, T, m, m), (*B, T, n) or (*B, T)."""
    return ndim - (3 if name == "K_C" else 2 if name in ("q", "kj", "position", "target") else 1)


def concat_results(parts: list[CSCResult]) -> CSCResult:
    """Join segments along the step axis; the start values are the first segment's."""
    out = {}
    for f in dataclasses.fields(CSCResult):
        arrays = [getattr(r, f.name) for r in parts]
        out[f.name] = (
            arrays[0] if f.name in START_FIELDS else np.concatenate(arrays, axis=step_axis(f.name, arrays[0].ndim))
        )
    return CSCResult(**out)


def array_units(robot: Any, task: str) -> dict[str, Any]:
    """Units of a csc result file's arrays (its meta ``units``); per joint where prismatic joints differ.

    ``orientation_error`` is in rad (shape files store their angle ``alpha_deg`` in degrees)."""
    pris = robot.prismatic
    per_joint = pris.any()
    q = [("m" if p else "rad") for p in pris] if per_joint else "rad"
    kj = [("N/m" if p else "Nm/rad") for p in pris] if per_joint else "Nm/rad"
    return {
        "q": q,
        "q0": q,
        "kj": kj,
        "u": "Nm/rad"
        if not per_joint
        else (
            "norm of J^T K_xd J's off-diagonal entries: Nm/rad between revolute "
            "joints, N/m between prismatic ones, N (= Nm/m) across"
        ),
        "u_start": "as u",
        "K_C": "N/m" if task != "full" else "6x6 [[N/m, N/rad], [Nm/m, Nm/rad]]",
        "K_xd": "as K_C",
        "frobenius": "as K_C (Frobenius norm of K_xd - K_C)",
        "frobenius_start": "as frobenius",
        "position": "m",
        "target": "m",
        "tracking_error": "m",
        "orientation_error": "rad",
        "isotropy": "1 (in [0, 1])",
        "null_step": "rad (m for prismatic joints)",
        "status": "bit mask (status_bits)",
    }
