"""Small I/O helpers shared by every writer: atomic files and JSON for numpy values.

Every file jaxstiff writes goes through :func:`atomic_write`: a temporary file in the target
folder, then ``os.replace`` (atomic on POSIX), so an interrupted run never leaves a partial file.
"""

from __future__ import annotations

import contextlib
import os
import tempfile
from typing import IO, Callable

import numpy as np

__all__ = ["atomic_write", "atomic_write_text", "json_default"]


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def atomic_write(file: str | os.PathLike, write: Callable[[IO], None], *, binary: bool = False) -> str:
    """Call ``write(fh)`` on a temporary file beside ``file``, then rename it onto ``file``.

    Raises:
        FileNotFoundError: the target folder does not exist.
    """
    file = os.fspath(file)
    folder = os.path.dirname(os.path.abspath(file))
    if not os.path.isdir(folder):
        raise FileNotFoundError(f"output folder does not exist: {folder}")
    fd, tmp = tempfile.mkstemp(prefix=".tmp-", suffix=os.path.splitext(file)[1], dir=folder)
    try:
        with os.fdopen(fd, "wb" if binary else "w", **({} if binary else {"encoding": "utf-8", "newline": ""})) as fh:
            write(fh)
            fh.flush()
            os.fsync(fh.fileno())
        os.chmod(tmp, 0o666 & ~_umask())  # mkstemp makes 0600; give the file the usual permissions
        os.replace(tmp, file)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise
    return file


def atomic_write_text(file: str | os.PathLike, text: str) -> str:
    """Write ``text`` (UTF-8, newlines as given) to ``file`` atomically."""
    return atomic_write(file, lambda fh: fh.write(text))


def json_default(o):
    """``json.dumps(default=...)`` for numpy arrays and scalars."""
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, (np.floating, np.integer, np.bool_)):
        return o.item()
    raise TypeError(f"not JSON serialisable: {type(o).__name__}")
