"""Ctrl-C and SIGTERM while the ``jaxstiff`` command is still starting up.

Importing the package imports JAX, which takes about a second, and JAX's garbage-collection
callback runs often during it: with Python's default handler, a Ctrl-C in that second raised its
KeyboardInterrupt inside the callback, where it was printed and dropped, and the command then ran
to the end. When the process was started as the command (``jaxstiff ...`` or ``python -m
jaxstiff ...``), the package's first import installs handlers that only remember the signal; the
command line (:func:`jaxstiff.runtime._io.interrupt_handlers`) takes it over and stops before any work.
Imported as a library, nothing changes. Standard library only, so that it is in place before the
heavy imports.
"""

from __future__ import annotations

import os
import signal
import sys
import threading

_RECEIVED: list[int] = []


def _started_as_command() -> bool:
    """True for the console script ``jaxstiff`` and for ``python [options] -m jaxstiff``."""
    if sys.argv and os.path.basename(sys.argv[0]) in ("jaxstiff", "jaxstiff.exe"):
        return True
    argv = list(getattr(sys, "orig_argv", ()))
    return any(a == "-m" and b == "jaxstiff" for a, b in zip(argv, argv[1:], strict=False))


def _remember(signum: int, frame: object):  # noqa: ARG001 - the signal module's handler signature
    _RECEIVED.append(signum)


def record_early_signals() -> None:
    """Remember SIGINT/SIGTERM (instead of raising or dying) while the command starts up."""
    if not _started_as_command() or threading.current_thread() is not threading.main_thread():
        return
    for sig in (signal.SIGINT, signal.SIGTERM):
        if signal.getsignal(sig) in (signal.default_int_handler, signal.SIG_DFL):
            signal.signal(sig, _remember)


def early_signal() -> int | None:
    """The first signal received during the start-up, or None."""
    return _RECEIVED[0] if _RECEIVED else None
