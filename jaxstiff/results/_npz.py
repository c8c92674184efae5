"""The parts of a result file that need no :class:`~jaxstiff.results._files.ShapeResult`: the atomic
``.npz`` write and the per-path parameters read back from ``meta`` (format: :mod:`jaxstiff.results._files`)."""

from __future__ import annotations

import os
from typing import Any

import numpy as np

from jaxstiff.runtime._io import atomic_write

__all__: list[str] = []


def atomic_save_npz(file: str | os.PathLike, arrays: dict[str, np.ndarray]) -> str:
    """``np.savez`` to a temporary file in the target folder, then ``os.replace`` onto ``file``.

    Raises:
        FileNotFoundError: the target folder does not exist.
        ValueError: ``file`` is empty, a folder (``x/`` would have written ``x.npz`` beside it), or
            a name with a suffix other than ``.npz`` (``x.csv`` would have been written as
            ``x.csv.npz``; a name without a suffix gets ``.npz``).
    """
    file = os.fspath(file)
    if not file.strip():
        raise ValueError("the result file's name is empty; give one, like result.npz")
    if os.path.isdir(file) or file.endswith((os.sep, "/")):
        raise ValueError(f"{file} is a folder; give a file name inside it, like {os.path.join(file, 'result.npz')}")
    ext = os.path.splitext(file)[1]
    if ext and ext.lower() != ".npz":  # as the commands' --out: not written under a name not given
        raise ValueError(
            f"{file!r}: a result file is written as .npz, and a name with another suffix would be written as "
            f"{file + '.npz'!r}; give {os.path.splitext(file)[0] + '.npz'!r} or {file + '.npz'!r}"
        )
    if not ext:  # x.NPZ is taken as it is (numpy would write x.NPZ.npz)
        file = file + ".npz"
    # numpy's stub lets **arrays bind savez's allow_pickle (bool); no result key has that name
    return atomic_write(file, lambda fh: np.savez(fh, **arrays), binary=True)  # pyright: ignore[reportArgumentType]


# ---------------------------------------------------------------------- per-path parameters
def path_parameters(meta: dict[str, Any], B: int, n: int) -> dict[str, np.ndarray]:
    """The shaping parameters of every path from a result's ``meta``: ``ratio`` (B,), ``dq`` and
    ``dk`` (B, n) (rate limits per waypoint, rad and Nm/rad), ``c`` (float).

    Reads both forms ``meta`` may hold (module docstring): a number / n numbers shared by every
    path (all files, older ones included), or one value / one row of n per path.

    Raises:
        ValueError: the recorded values do not fit B paths and n joints.
    """
    lim = meta["limits"]
    r = np.asarray(meta.get("ratio", np.nan), float)
    if r.ndim > 1 or (r.ndim == 1 and r.shape != (B,)):
        raise ValueError(f"meta ratio has shape {r.shape}; expected a number or ({B},)")
    out: dict[str, Any] = {"ratio": np.broadcast_to(r, (B,)).copy(), "c": float(meta.get("c", np.nan))}
    for key in ("dq", "dk"):
        a = np.asarray(lim[key], float)
        if a.ndim == 0:
            a = np.full(n, float(a))
        if a.shape not in ((n,), (B, n)):
            raise ValueError(f"meta limits.{key} has shape {a.shape}; expected ({n},) or ({B}, {n})")
        out[key] = np.broadcast_to(a, (B, n)).copy()
    return out
