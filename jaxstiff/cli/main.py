"""The ``jaxstiff`` command. A thin layer: parse flags, call the library, print or write results.

Each subcommand lives in its own module and registers itself in :data:`jaxstiff.cli.common.COMMANDS`
when imported; :func:`build_parser` imports them in the order ``jaxstiff --help`` lists them. Errors
a user can fix (bad files, bad values) are printed as one line ``jaxstiff: error: ...`` with exit
code 2, never as a traceback.
"""

from __future__ import annotations

import argparse
import os
import signal
import sys
import warnings

from ..runtime.io import interrupt_exit_code, interrupt_handlers, interrupt_pending, raise_if_interrupted
from . import check_sim as _check_sim_command  # noqa: F401  (jaxstiff check-sim)
from . import csc as _csc_command  # noqa: F401  (registers jaxstiff csc)
from . import export as _export_command  # noqa: F401  (jaxstiff export)
from . import plot as _plot_command  # noqa: F401  (jaxstiff plot)
from . import reproduce as _reproduce_command  # noqa: F401  (jaxstiff reproduce)
from . import robot as _robot_command  # noqa: F401  (jaxstiff robot)
from . import shape as _shape_command  # noqa: F401  (jaxstiff shape)
from . import sweep as _sweep_command  # noqa: F401  (jaxstiff sweep)
from . import view as _view_command  # noqa: F401  (jaxstiff view)
from .common import COMMANDS, join_negative_values

#: the order of ``jaxstiff --help``
COMMAND_ORDER = ("robot", "shape", "csc", "sweep", "reproduce", "check-sim", "view", "plot", "export")


class _HelpFormatter(argparse.ArgumentDefaultsHelpFormatter):
    """Appends ``(default: X)`` only where it says something: not for a None default, and not where the
    help text already states its default in words."""

    def _get_help_string(self, action):
        text = action.help or ""
        if action.default is None or "default" in text.lower():
            return text
        return super()._get_help_string(action)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="jaxstiff",
        description="Stiffness-ellipsoid shaping and Configuration-based Stiffness Control for redundant arms.",
    )
    from jaxstiff.runtime.version import __version__

    parser.add_argument("--version", action="version", version=f"jaxstiff {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name in sorted(COMMANDS, key=lambda c: COMMAND_ORDER.index(c) if c in COMMAND_ORDER else len(COMMAND_ORDER)):
        add, _, help_ = COMMANDS[name]
        sp = sub.add_parser(name, help=help_, description=help_, formatter_class=_HelpFormatter)
        sp.set_defaults(_run=add(sp))
    return parser


_PACKAGE_DIR = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))  # jaxstiff/
_default_showwarning = warnings.showwarning


def _show_warning(message, category, filename, lineno, file=None, line=None):
    """jaxstiff's own warnings (a URDF joint with an empty range, ...) as one line like the
    commands' other warnings, not Python's file:line: Category + source line; others unchanged."""
    if os.path.abspath(filename).startswith(_PACKAGE_DIR + os.sep):
        print(f"jaxstiff: warning: {message}", file=sys.stderr if file is None else file)
    else:
        _default_showwarning(message, category, filename, lineno, file, line)


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(join_negative_values(sys.argv[1:] if argv is None else list(argv)))
    if getattr(args, "_run", None) is None:
        parser.print_help()
        return 2
    try:
        with warnings.catch_warnings(), interrupt_handlers():
            warnings.showwarning = _show_warning
            raise_if_interrupted()  # a Ctrl-C while the command was starting up: stop before any work
            rc = int(args._run(args) or 0)
        sig = interrupt_pending()
        if sig is not None and rc == 0:  # swallowed inside JAX and not seen at a checkpoint: the work had finished
            print(
                f"jaxstiff: interrupted ({signal.Signals(sig).name}) after the work had finished; its output was written",
                file=sys.stderr,
            )
            return 128 + int(sig)
        return rc
    except BrokenPipeError:  # output piped into `head` and the like: not an error of the user's
        try:
            sys.stdout = open(os.devnull, "w")
        except OSError:
            pass
        return 0
    except (ValueError, FileNotFoundError, OSError) as exc:
        print(f"jaxstiff: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        code = interrupt_exit_code()
        print(f"jaxstiff: interrupted ({signal.Signals(code - 128).name})", file=sys.stderr)
        if argv is None:
            # the process's own entry point: leave without Python's shutdown, which can crash
            # (segfault) while XLA's threads are still busy with the interrupted computation
            sys.stdout.flush()
            sys.stderr.flush()
            os._exit(code)
        return code
