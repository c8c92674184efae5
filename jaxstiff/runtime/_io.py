"""Small I/O helpers shared by every writer: atomic files and JSON for numpy values.

Every file jaxstiff writes goes through :func:`atomic_write`: a temporary file in the target
folder, then ``os.replace`` (atomic on POSIX), so an interrupted run never leaves a partial file.
The command line turns SIGTERM into the same ``KeyboardInterrupt`` as Ctrl-C
(:func:`interrupt_handlers`), so the temporary file is removed on either.

A SIGKILL (or a power cut) cannot be caught, and leaves the temporary file. The next
:func:`atomic_write` into the same folder removes such leftovers (:func:`clean_stale_temporaries`):
only names of our own pattern (``.tmp-`` + 8 characters of ``tempfile``'s alphabet + the target's
suffix) that are at least :data:`STALE_TMP_S` seconds old AND that no process holds locked. Every
writer holds an exclusive ``flock`` on its temporary file from creation to rename, and the kernel
drops the lock when the process dies, so a live writer (a concurrent sweep, a second command into
the same folder) is never disturbed however slow it is; the age only covers the instant between
``mkstemp`` and ``flock``. Timing alone was rejected: a writer compressing a large array may not
touch its file for many seconds.

:func:`check_regular_file` is the one rule for every input file: missing -> ``FileNotFoundError``
("not found"), present but not a regular file (a folder, FIFO, device such as ``/dev/zero``,
socket; symlinks are followed) -> ``ValueError`` "is not a regular file".
"""

from __future__ import annotations

import contextlib
import fcntl
import hashlib
import json
import math
import os
import re
import signal
import stat
import sys
import tempfile
import threading
import time
from collections.abc import Callable, Iterator
from typing import IO, Any

import numpy as np

__all__ = ["STALE_TMP_S", "TMP_PREFIX", "MAX_URDF_BYTES", "clean_stale_temporaries", "is_own_temporary"]


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


TMP_PREFIX = ".tmp-"  #: prefix of every temporary file of :func:`atomic_write`
STALE_TMP_S = 2.0  #: s: a leftover temporary file younger than this is never removed
#: tempfile.mkstemp's names: the prefix, 8 characters of its alphabet, the target's suffix
_OWN_TMP = re.compile(re.escape(TMP_PREFIX) + r"[a-z0-9_]{8}(\.[A-Za-z0-9]{1,16})?")
_CLEANED: set[str] = set()  # folders already cleaned by this process


def is_own_temporary(name: str) -> bool:
    """True if the file name ``name`` (no folder) is one of :func:`atomic_write`'s temporaries."""
    return _OWN_TMP.fullmatch(name) is not None


def _lock_held_elsewhere(path: str) -> bool:
    """True if another open file description holds a ``flock`` on ``path`` (a live writer)."""
    try:
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK)
    except OSError:
        return True  # (gone, or unreadable: leave it)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:
        return True
    finally:
        os.close(fd)  # (closing releases the probe's lock)
    return False


def clean_stale_temporaries(folder: str | os.PathLike, min_age_s: float = STALE_TMP_S) -> list[str]:
    """Remove the temporaries a killed writer left in ``folder`` (module docstring); the removed paths.

    Only regular files whose names match :func:`is_own_temporary`, last modified at least
    ``min_age_s`` seconds ago, and not ``flock``-ed by a live writer. Errors are ignored (a
    read-only folder, a file removed meanwhile).
    """
    folder = os.fspath(folder)
    removed: list[str] = []
    now = time.time()
    try:
        entries = list(os.scandir(folder))
    except OSError:
        return removed
    for e in entries:
        if not is_own_temporary(e.name):
            continue
        try:
            st = e.stat(follow_symlinks=False)
            if not stat.S_ISREG(st.st_mode) or now - st.st_mtime < min_age_s or _lock_held_elsewhere(e.path):
                continue
            os.unlink(e.path)
            removed.append(e.path)
        except OSError:
            continue
    return removed


def check_regular_file(path: str | os.PathLike, what: str) -> str:
    """``path`` as a string if it names a regular file (symlinks followed), else a clear error.

    Args:
        path: the file to read.
        what: its name in the message (a flag such as ``--path``, a config key, ``"path file"``).

    Raises:
        FileNotFoundError: nothing there (``"{what}: file not found: {path}"``).
        ValueError: a folder, FIFO, device, socket (``"{what}: {path} is not a regular file: it is a FIFO"``).
    """
    path = os.fspath(path)
    try:
        mode = os.stat(path).st_mode
    except FileNotFoundError:
        raise FileNotFoundError(f"{what}: file not found: {path}") from None
    except OSError as e:
        raise ValueError(f"{what}: cannot read {path}: {e.strerror or e}") from None
    if stat.S_ISREG(mode):
        return path
    kind = (
        "a folder"
        if stat.S_ISDIR(mode)
        else "a FIFO (named pipe)"
        if stat.S_ISFIFO(mode)
        else "a character device"
        if stat.S_ISCHR(mode)
        else "a block device"
        if stat.S_ISBLK(mode)
        else "a socket"
        if stat.S_ISSOCK(mode)
        else "not a file"
    )
    raise ValueError(f"{what}: {path} is not a regular file: it is {kind}; give a file")


#: the largest URDF a result file may point at (the shipped ones are a few kB; a robot with
#: inline meshes a few MB): a bigger "URDF" is refused before it is hashed or parsed
MAX_URDF_BYTES = 64 << 20


def check_urdf_file(path: object, what: str) -> str:
    """``path`` as a string if it names a regular file of at most :data:`MAX_URDF_BYTES`, else a
    one-line error naming ``what`` (a flag, or the result's meta field): the URDF a result file
    records is opened only after this, so a crafted file cannot point the readers at a FIFO,
    a device (``/dev/zero``), a folder, a huge file, or a number (an int "path" is a file
    descriptor: ``0`` would read stdin).

    Raises:
        FileNotFoundError: nothing there.
        ValueError: not a path (a number, a list, empty), not a regular file, or too big.
    """
    if not isinstance(path, (str, os.PathLike)) or isinstance(path, bytes):
        raise ValueError(f"{what}: expected a URDF file name, got {type(path).__name__} {path!r}")
    path = os.fspath(path)
    if not isinstance(path, str) or not path.strip() or "\0" in path:
        raise ValueError(f"{what}: expected a URDF file name, got {path!r}")
    check_regular_file(path, what)
    size = os.stat(path).st_size
    if size > MAX_URDF_BYTES:
        raise ValueError(f"{what}: {path} is {size / 2**20:.0f} MiB; a URDF over {MAX_URDF_BYTES >> 20} MiB is refused")
    return path


class WriteError(OSError):
    """An output that could not be written (a full disk, a read-only file system, a quota): the
    message names the file and the system's reason; ``errno`` is the system's. Raised by
    :func:`atomic_write` after it removed its temporary file, so nothing partial is left."""

    def __init__(self, message: str, errno_: int | None = None):
        super().__init__(message)
        self.errno = errno_  # type: ignore[misc]  # OSError's, set after a one-argument init

    def __str__(self) -> str:
        return str(self.args[0])


def _write_error(exc: OSError, file: str) -> WriteError:
    reason = (exc.strerror or str(exc)).rstrip(".")
    return WriteError(f"cannot write {file}: {reason[:1].lower() + reason[1:]}", exc.errno)


def refuse_special_output(path: str, who: str = "", hint: str = "give a file name") -> None:
    """Refuse an output ``path`` that exists and is neither a regular file nor a folder (a device
    such as ``/dev/null``, a pipe; links followed): written beside it and renamed onto it, as every
    output is (:func:`atomic_write`), it would be replaced by a plain file, and a pipe would get
    nothing. ``who`` starts the message (a flag), ``hint`` ends it."""
    if os.path.exists(path) and not os.path.isfile(path) and not os.path.isdir(path):
        raise ValueError(f"{who}{path} is not a regular file (a device or a pipe); {hint}")


def atomic_write(file: str | os.PathLike, write: Callable[[IO], None], *, binary: bool = False) -> str:
    """Call ``write(fh)`` on a temporary file beside ``file``, then rename it onto ``file``.

    The temporary file is ``flock``-ed while it is written and removed on any exception (Ctrl-C
    and SIGTERM under :func:`interrupt_handlers` included); leftovers of killed writers in the
    folder are removed first, once per folder and process (:func:`clean_stale_temporaries`).

    A symbolic link stays: the file it points to is written (in that file's folder).

    Raises:
        FileNotFoundError: the target folder does not exist.
        IsADirectoryError: ``file`` is a folder.
        ValueError: ``file`` exists and is not a regular file (a device, a pipe:
            :func:`refuse_special_output`).
        WriteError: the system refused the write (no space left, a read-only file system): named
            with ``file``, not with the temporary file's name.
    """
    given = file = os.fspath(file)
    if os.path.islink(file):
        file = os.path.realpath(file)
    folder = os.path.dirname(os.path.abspath(file))
    if not os.path.isdir(folder):
        raise FileNotFoundError(f"output folder does not exist: {folder}")
    if os.path.isdir(file):  # before any work on the temporary file, whose name would show in the error
        raise IsADirectoryError(f"{os.path.abspath(given)} is a folder; give a file name inside it")
    refuse_special_output(os.path.abspath(given))
    if folder not in _CLEANED:
        clean_stale_temporaries(folder)
        _CLEANED.add(folder)
    try:
        fd, tmp = tempfile.mkstemp(prefix=TMP_PREFIX, suffix=os.path.splitext(file)[1], dir=folder)
    except OSError as exc:
        raise _write_error(exc, os.path.abspath(given)) from None
    try:
        with contextlib.suppress(OSError):  # (a file system without locks: the age rule alone)
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        fh_ctx = os.fdopen(fd, "wb") if binary else os.fdopen(fd, "w", encoding="utf-8", newline="")
        with fh_ctx as fh:
            write(fh)
            fh.flush()
            os.fsync(fh.fileno())
        os.chmod(tmp, 0o666 & ~_umask())  # mkstemp makes 0600; give the file the usual permissions
        os.replace(tmp, file)
    except BaseException as exc:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        if isinstance(exc, OSError) and not isinstance(exc, WriteError):
            raise _write_error(exc, os.path.abspath(given)) from None
        raise
    return given


def save_or_rescue(save: Callable[[str], str], out: str, what: str = "the result") -> str:
    """``save(out)``; where the system refuses it (:class:`WriteError`: a full disk, a read-only
    file system), the finished work is not thrown away: ``save`` is tried again in the first of the
    user's cache folder, the temporary folder and the home folder that takes it, and a
    :class:`WriteError` says where the file went (or that no place took it)."""
    try:
        return save(out)
    except WriteError as exc:
        first = exc
    from platformdirs import user_cache_dir

    name = f"rescued-{time.strftime('%Y%m%d-%H%M%S')}-{os.getpid()}-{os.path.basename(out)}"
    tried = []
    for folder in (
        os.path.join(user_cache_dir("jaxstiff", appauthor=False), "rescued"),
        tempfile.gettempdir(),
        os.path.expanduser("~"),
    ):
        try:
            os.makedirs(folder, exist_ok=True)
            written = save(os.path.join(folder, name))
        except OSError:
            tried.append(folder)
            continue
        raise WriteError(
            f"{first}; {what} was written instead to {written}: move it where you want it", first.errno
        ) from None
    raise WriteError(
        f"{first}; {what} could not be written elsewhere either ({', '.join(tried)}): it is lost", first.errno
    ) from None


def atomic_write_text(file: str | os.PathLike, text: str) -> str:
    """Write ``text`` (UTF-8, newlines as given) to ``file`` atomically."""

    def write(fh: IO) -> None:
        fh.write(text)

    return atomic_write(file, write)


#: how :func:`meta_dumps` writes a number that is not finite (strict JSON has no such numbers)
NONFINITE_TEXT = {"Infinity": math.inf, "-Infinity": -math.inf, "NaN": math.nan}


def nonfinite_text(x: float) -> str:
    """How a result file's ``meta`` spells a number that is not finite: ``"Infinity"``,
    ``"-Infinity"`` or ``"NaN"`` (:data:`NONFINITE_TEXT`; read back as floats by :func:`meta_loads`)."""
    return "NaN" if x != x else ("Infinity" if x > 0 else "-Infinity")


def _strict(o: Any) -> Any:
    if isinstance(o, np.ndarray):
        o = o.tolist()
    elif isinstance(o, (np.floating, np.integer, np.bool_)):
        o = o.item()
    if isinstance(o, float) and not math.isfinite(o):
        return nonfinite_text(o)
    if isinstance(o, dict):
        return {k: _strict(v) for k, v in o.items()}
    if isinstance(o, (list, tuple)):
        return [_strict(v) for v in o]
    return o


def _unstrict(o: Any) -> Any:
    if isinstance(o, str):
        return NONFINITE_TEXT.get(o, o)
    if isinstance(o, dict):
        return {k: _unstrict(v) for k, v in o.items()}
    if isinstance(o, list):
        return [_unstrict(v) for v in o]
    return o


def meta_dumps(meta: dict[str, Any]) -> str:
    """A result file's ``meta`` as strict JSON (RFC 8259, readable by any JSON parser): a number that
    is not finite (a continuous joint's limits, a rigid joint's stiffness) is written as the string
    ``"Infinity"``, ``"-Infinity"`` or ``"NaN"``; numpy arrays and scalars as lists and numbers."""
    return json.dumps(_strict(meta), sort_keys=True, allow_nan=False, default=json_default)


def meta_loads(text: str) -> dict[str, Any]:
    """:func:`meta_dumps`'s inverse (the strings ``"Infinity"``, ``"-Infinity"``, ``"NaN"`` back to
    floats); also reads the files of older versions, which wrote bare ``Infinity`` tokens."""
    return _unstrict(json.loads(text))


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
#: "" (interrupts raise), "held" (:func:`hold_interrupts`: remembered only), "told" (held, and the
#: user was told why a second one did not stop the run)
_HELD = {"state": ""}


def _on_signal(signum: int, frame: object):  # noqa: ARG001 - the signal module's handler signature
    _PENDING["signal"] = signum
    if _HELD["state"]:
        if _HELD["state"] == "held":  # once: the user pressed again and waits
            _HELD["state"] = "told"
            print("\njaxstiff: saving what was finished first (stop at once: Ctrl-\\)", file=sys.stderr, flush=True)
        return
    if not _DEFER["depth"]:
        raise KeyboardInterrupt


def hold_interrupts() -> None:
    """From now until the end of :func:`interrupt_handlers`, SIGINT/SIGTERM are only remembered: for
    a run that an interrupt has already stopped and that is now keeping what was finished (a
    solver's finished waypoints, up to the file that holds them), so that a second Ctrl-C, pressed
    before that file is written, does not lose them. Outside :func:`interrupt_handlers` (library
    use) it changes nothing."""
    if not _HELD["state"]:
        _HELD["state"] = "held"


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
    from jaxstiff.runtime._early_signals import early_signal

    _PENDING["signal"] = early_signal()  # (one received while the command was starting up)
    _HELD["state"] = ""
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
        _HELD["state"] = ""


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
