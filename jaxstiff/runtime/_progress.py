"""One progress facility for the commands (``shape``, ``csc``, ``sweep``): a bar with ETA on stderr.

* On a terminal: a tqdm bar redrawn in place, at most 5 times a second, left standing at the end.
* Not on a terminal (a log file, a pipe, a test's captured stderr): no bar; one plain line at the
  end (``shape: 3/3 waypoints (path 0) in 1.2 s``), and one every ``log_every`` seconds when given
  (for long runs whose log is read while they go).
* Disabled (``--quiet``): nothing at all.

Use::

    with progress(total=B * P, desc="shape", unit="waypoints", enabled=not quiet) as bar:
        for ...:
            bar.update(1, note=f"path {b}")      # counts may be fractional (a sweep's waypoints)
        bar.write("a message line that does not break the bar")

The library itself never draws: it takes a callback (``shape(progress=...)``); the commands wrap a
:class:`Progress` in one.
"""

from __future__ import annotations

import sys
import time
from types import TracebackType
from typing import TextIO

from tqdm import tqdm

__all__ = ["progress", "is_terminal"]

#: the bar on a terminal: tqdm's fields; n and total as whole numbers even when counts are fractional
BAR_FORMAT = "{desc}: {percentage:3.0f}%|{bar}| {n:.0f}/{total:.0f} {unit} [{elapsed}<{remaining}]{postfix}"


class _Bar(tqdm):
    """tqdm without its monitor thread (no extra thread next to JAX's and the signal handlers)."""

    monitor_interval = 0


def is_terminal(file: TextIO | None) -> bool:
    """True if ``file`` is an interactive terminal (a bar can be redrawn in place)."""
    try:
        return bool(file is not None and file.isatty())
    except (AttributeError, ValueError):  # no isatty, or a closed file
        return False


class Progress:
    """A progress count of ``total`` units with a bar on a terminal (see the module docstring).

    Args:
        total: units of work (waypoints, steps); a float is fine.
        desc: the label in front (the command's name).
        unit: the unit's name, plural (``"waypoints"``).
        initial: units already done (a resumed run).
        enabled: False: draw and write nothing (the count still runs: :attr:`n`).
        file: where to draw (default: ``sys.stderr`` at the time of the call).
        log_every: not on a terminal: a plain line every this many seconds (None: only at the end).
        terminal: force terminal (True) or plain-line (False) mode (default: ``file.isatty()``).
    """

    def __init__(
        self,
        total: float,
        desc: str = "",
        unit: str = "it",
        *,
        initial: float = 0,
        enabled: bool = True,
        file: TextIO | None = None,
        log_every: float | None = None,
        terminal: bool | None = None,
    ):
        self.total, self.desc, self.unit = float(total), desc, unit
        self.enabled = bool(enabled)
        self.file = file if file is not None else sys.stderr
        self.log_every = log_every
        self.terminal = is_terminal(self.file) if terminal is None else bool(terminal)
        self.n = float(initial)
        self.note = ""
        self.t0 = time.perf_counter()
        self._last_line = self.t0
        self._closed = False
        self._bar: tqdm | None = None
        if self.enabled and self.terminal:
            self._bar = _Bar(
                total=self.total,
                initial=self.n,
                desc=desc,
                unit=unit,
                file=self.file,
                leave=True,
                mininterval=0.2,
                bar_format=BAR_FORMAT,
                dynamic_ncols=True,
            )

    def update(self, n: float = 1, note: str | None = None) -> None:
        """``n`` more units done; ``note`` (e.g. ``"path 2"``) is shown after the count."""
        self.n += n
        if note is not None:
            self.note = note
        if self._bar is not None:
            if note is not None:
                self._bar.set_postfix_str(note, refresh=False)
            self._bar.update(n)
        elif self.enabled and self.log_every is not None:
            now = time.perf_counter()
            if now - self._last_line >= self.log_every and self.n < self.total:
                self._last_line = now
                self._print(self.line())

    def set_note(self, note: str) -> None:
        """Change the note after the count without counting."""
        self.note = note
        if self._bar is not None:
            self._bar.set_postfix_str(note)

    def write(self, line: str) -> None:
        """Print a message line (above the bar on a terminal, so the bar is not broken)."""
        if not self.enabled:
            return
        if self._bar is not None:
            self._bar.write(line, file=self.file)
        else:
            self._print(line)

    def line(self) -> str:
        """The plain status line: ``desc: n/total unit (note) in T s``."""
        note = f" ({self.note})" if self.note else ""
        head = f"{self.desc}: " if self.desc else ""
        return f"{head}{self.n:.0f}/{self.total:.0f} {self.unit}{note} in {time.perf_counter() - self.t0:.1f} s"

    def close(self) -> None:
        """End the bar (a terminal keeps it), or write the final plain line. Safe to call twice."""
        if self._closed:
            return
        self._closed = True
        if self._bar is not None:
            self._bar.close()
        elif self.enabled:
            self._print(self.line())

    def _print(self, text: str) -> None:
        self.file.write(text + "\n")
        self.file.flush()

    def __enter__(self) -> Progress:
        return self

    def __exit__(
        self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        if exc_type is not None and self.n == 0 and self._bar is None:
            # an error before any unit was done (a bad input): its message alone, no "0/60 in 0.0 s"
            self._closed = True
        self.close()


def progress(total: float, desc: str = "", unit: str = "it", **kwargs: object) -> Progress:
    """A :class:`Progress` (keyword arguments as there); use it as a context manager."""
    return Progress(total, desc, unit, **kwargs)  # type: ignore[arg-type]
