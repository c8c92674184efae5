"""Small I/O helpers shared by every writer: atomic files and JSON for numpy values.

Every file jaxstiff writes goes through :func:`atomic_write`: a temporary file in the target
folder, then ``os.replace`` (atomic on POSIX), so an interrupted run never leaves a partial file.
The command line turns SIGTERM into the same ``KeyboardInterrupt`` as Ctrl-C
(:func:`interrupt_handlers`), so the temporary file is removed on either.
"""

from __future__ import annotations

import contextlib
import hashlib
import os
import signal
import sys
import tempfile
import threading
from collections.abc import Callable, Iterator
from typing import IO, Any

import numpy as np

__all__ = [
    "atomic_write",
    "atomic_write_text",
    "json_default",
    "interrupt_handlers",
    "interrupt_pending",
    "raise_if_interrupted",
    "deferred_interrupts",
    "interrupt_exit_code",
]


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
        fh_ctx = os.fdopen(fd, "wb") if binary else os.fdopen(fd, "w", encoding="utf-8", newline="")
        with fh_ctx as fh:
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

    def write(fh: IO) -> None:
        fh.write(text)

    return atomic_write(file, write)


def json_default(o: object) -> object:
    """``json.dumps(default=...)`` for numpy arrays and scalars."""
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, (np.floating, np.integer, np.bool_)):
        return o.item()
    raise TypeError(f"not JSON serialisable: {type(o).__name__}")


# ----------------------------------------------------------------------------- interrupts
_PENDING: dict[str, int | None] = {"signal": None}
_DEFER = {"depth": 0}


def _on_signal(signum: int, frame: object):  # noqa: ARG001 - the signal module's handler signature
    _PENDING["signal"] = signum
    if not _DEFER["depth"]:
        raise KeyboardInterrupt


def _drop_interrupt_unraisable(hook: Callable) -> Callable:
    """An unraisable-exception hook that stays quiet about a KeyboardInterrupt (one raised by the
    handler inside a callback that cannot propagate it, e.g. JAX's garbage-collection callback):
    the signal is remembered and raised again at the next checkpoint."""

    def quiet(unraisable: Any) -> None:
        if not isinstance(unraisable.exc_value, KeyboardInterrupt):
            hook(unraisable)

    return quiet


@contextlib.contextmanager
def deferred_interrupts() -> Iterator[None]:
    """Inside the block, SIGINT/SIGTERM under :func:`interrupt_handlers` are only remembered (for
    :func:`interrupt_pending`), not raised: for work that is cheap to finish and costly to lose,
    such as assembling and writing a result whose computation is complete. Outside
    :func:`interrupt_handlers` (library use) it changes nothing."""
    _DEFER["depth"] += 1
    try:
        yield
    finally:
        _DEFER["depth"] -= 1


@contextlib.contextmanager
def interrupt_handlers() -> Iterator[None]:
    """SIGINT and SIGTERM raise ``KeyboardInterrupt`` and are remembered while the block runs.

    Remembering matters because Python delivers the exception wherever the main thread happens to
    be, and JAX runs some of its own code (a garbage-collection callback) where an exception is
    printed and dropped: :func:`raise_if_interrupted` at the commands' checkpoints (between
    waypoints, before a result file is written) raises it again. Outside the main thread (where
    handlers cannot be installed) the block runs with the process's handlers unchanged.
    """
    from jaxstiff.runtime.early_signals import early_signal

    _PENDING["signal"] = early_signal()  # (one received while the command was starting up)
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    old = {sig: signal.signal(sig, _on_signal) for sig in (signal.SIGINT, signal.SIGTERM)}
    old_hook = sys.unraisablehook
    sys.unraisablehook = _drop_interrupt_unraisable(old_hook)
    try:
        yield
    finally:
        sys.unraisablehook = old_hook
        for sig, handler in old.items():
            signal.signal(sig, handler)


def interrupt_pending() -> int | None:
    """The signal number of an interrupt received inside :func:`interrupt_handlers`, else None."""
    return _PENDING["signal"]


def interrupt_exit_code() -> int:
    """The exit status of an interrupted command, as a shell reports it: 128 + the signal (130 for
    Ctrl-C, 143 for SIGTERM); Ctrl-C's when no signal was recorded (a KeyboardInterrupt raised
    outside :func:`interrupt_handlers`)."""
    return 128 + int(_PENDING["signal"] or signal.SIGINT)


def raise_if_interrupted() -> None:
    """Raise ``KeyboardInterrupt`` if an interrupt arrived (and was perhaps swallowed) earlier."""
    if _PENDING["signal"] is not None:
        raise KeyboardInterrupt


def file_sha256(path: str | os.PathLike) -> str:
    """Hex sha256 of a file (the robot URDF recorded in ``meta``)."""
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for chunk in iter(lambda: fh.read(1 << 16), b""):
            h.update(chunk)
    return h.hexdigest()
