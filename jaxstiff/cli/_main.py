"""The ``jaxstiff`` command. A thin layer: parse flags, call the library, print or write results.

Each subcommand lives in its own module and registers itself in :data:`jaxstiff.cli._common.COMMANDS`
when imported; :func:`build_parser` imports them in the order ``jaxstiff --help`` lists them. Errors
a user can fix (bad files, bad values) are printed as one line ``jaxstiff: error: ...`` with exit
code 2, never as a traceback.
"""

from __future__ import annotations

import argparse
import importlib
import os
import signal
import sys
import warnings

from ..runtime._io import WriteError, interrupt_exit_code, interrupt_handlers, interrupt_pending, raise_if_interrupted
from ._common import COMMANDS, check_outputs_not_inputs, file_flags, join_negative_values, writes

#: the order of ``jaxstiff --help``
COMMAND_ORDER = ("robot", "shape", "csc", "sweep", "reproduce", "check-sim", "view", "plot", "export")

#: command -> its module in jaxstiff.cli (imported when the parser is built; it registers the command)
COMMAND_MODULES = {name: name.replace("-", "_") for name in COMMAND_ORDER}


def load_commands(names: list[str] | None = None) -> None:
    """Import the modules of ``names`` (default: every command). ``jaxstiff view RESULT`` loads only
    the view command: the others import JAX and the solvers, and the viewer starts without them."""
    for name in COMMAND_MODULES if names is None else names:
        importlib.import_module(f"jaxstiff.cli._{COMMAND_MODULES[name]}")


def _command_in(argv: list[str]) -> str | None:
    """The subcommand named by ``argv`` (its first word after the global flags), if it is one."""
    i = 0
    while i < len(argv) and argv[i].startswith("--"):
        i += 2 if argv[i] == "--compile-cache" else 1  # the one global flag with a value
    return argv[i] if i < len(argv) and argv[i] in COMMAND_MODULES else None


class _HelpFormatter(argparse.ArgumentDefaultsHelpFormatter):
    """Appends ``(default: X)`` only where it says something: not for a None default, and not where the
    help text already states its default in words."""

    def _get_help_string(self, action):
        text = action.help or ""
        if action.default is None or "default" in text.lower():
            return text
        return super()._get_help_string(action)


def build_parser(command: str | None = None) -> argparse.ArgumentParser:
    """The ``jaxstiff`` parser with every subcommand, or with ``command``'s alone (its modules only)."""
    load_commands(None if command is None else [command])
    parser = argparse.ArgumentParser(
        prog="jaxstiff",
        description="Stiffness-ellipsoid shaping and Configuration-based Stiffness Control for redundant arms.",
    )
    from jaxstiff.runtime._version import __version__

    parser.add_argument("--version", action="version", version=f"jaxstiff {__version__}")
    cache = parser.add_mutually_exclusive_group()
    cache.add_argument(
        "--no-compile-cache",
        dest="global_no_compile_cache",
        action="store_true",
        help="do not use the persistent compilation cache (also: JAXSTIFF_COMPILE_CACHE=0); every run compiles",
    )
    compile_cache = cache.add_argument(
        "--compile-cache",
        dest="global_compile_cache",
        metavar="DIR",
        help="keep compiled programs in DIR (also: JAXSTIFF_CACHE_DIR; default: the user cache folder, "
        "e.g. ~/.cache/jaxstiff/xla; JAX_COMPILATION_CACHE_DIR, if set, wins)",
    )
    writes(compile_cache, folder=True)
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name in sorted(COMMANDS, key=lambda c: COMMAND_ORDER.index(c) if c in COMMAND_ORDER else len(COMMAND_ORDER)):
        add, _, help_ = COMMANDS[name]
        sp = sub.add_parser(name, help=help_, description=help_, formatter_class=_HelpFormatter)
        sp.set_defaults(_run=add(sp))
        # the paths it reads and writes, declared where its flags are added (common.reads / writes)
        sp.set_defaults(_files=file_flags(parser, sp))
    return parser


_PACKAGE_DIR = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))  # jaxstiff/
_default_showwarning = warnings.showwarning


_SHOWN: set[str] = set()  #: jaxstiff warnings printed so far by this process's command


def _show_warning(message, category, filename, lineno, file=None, line=None):
    """jaxstiff's own warnings (a URDF joint with an empty range, ...) as one line like the
    commands' other warnings, not Python's file:line: Category + source line; others unchanged."""
    if os.path.abspath(filename).startswith(_PACKAGE_DIR + os.sep):
        text = str(message)
        if text in _SHOWN:  # one robot read twice by a command (its checks, then its run) warns once
            return
        _SHOWN.add(text)
        print(f"jaxstiff: warning: {text}", file=sys.stderr if file is None else file)
    else:
        _default_showwarning(message, category, filename, lineno, file, line)


#: commands that only read files (no JAX kernels): no compilation cache, no compile time line
_NO_COMPILATION = ("view", "plot", "export")


def _backend_failure(exc: BaseException) -> str | None:
    """The one-line message for an exception raised while JAX started its backend (a platform in
    ``JAX_PLATFORMS`` it cannot start, say ``cuda`` without the plugin: a bare AssertionError from
    deep inside JAX), else None. Found from the traceback, not by starting the backend early: the
    commands choose backend settings (synchronous CPU dispatch) before it starts."""
    tb = exc.__traceback__
    while tb is not None:
        code = tb.tb_frame.f_code
        if code.co_filename.endswith(os.path.join("jax", "_src", "xla_bridge.py")) and code.co_name in (
            "backends",
            "_init_backend",
            "get_backend",
        ):
            wanted = os.environ.get("JAX_PLATFORMS")
            detail = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
            return (
                f"JAX could not start a backend (JAX_PLATFORMS={wanted!r}): {detail}; unset JAX_PLATFORMS to "
                "run on the CPU, or install the JAX plugin for that platform (pip install 'jaxstiff[gpu]')"
            )
        tb = tb.tb_next
    return None


def _run_command(args: argparse.Namespace) -> int:
    """The command, with the compilation cache of the global flags turned on before it (so its first
    compilation can use it), and its compile time on stderr afterwards (unless ``--quiet``)."""
    if args.command in _NO_COMPILATION:
        return int(args._run(args) or 0)
    import time

    from ..runtime._compile_cache import CompileClock, compile_cache_flags

    t0 = time.perf_counter()
    # a subcommand's own --no-compile-cache (the sweep's) turns the cache off here as well
    no_cache = bool(args.global_no_compile_cache or getattr(args, "no_compile_cache", False))
    with compile_cache_flags(no_cache, args.global_compile_cache) as cache_dir:
        if args.global_compile_cache and not no_cache and cache_dir is None:
            print(
                f"jaxstiff: warning: --compile-cache {args.global_compile_cache}: the folder cannot be made or "
                "written; running without a compilation cache",
                file=sys.stderr,
            )
        with CompileClock() as clock:
            rc = int(args._run(args) or 0)
    if clock.programs and not getattr(args, "quiet", False):
        where = (
            f"{clock.cache_hits} of {clock.programs} programs loaded from the cache {cache_dir}"
            if cache_dir
            else f"{clock.programs} programs, no compilation cache"
        )
        print(
            f"jaxstiff: {args.command}: {time.perf_counter() - t0:.1f} s, of which JAX compilation "
            f"{clock.seconds:.1f} s ({where})",
            file=sys.stderr,
        )
    return rc


def main(argv: list[str] | None = None) -> int:
    words = join_negative_values(sys.argv[1:] if argv is None else list(argv))
    parser = build_parser(_command_in(words))
    args = parser.parse_args(words)
    if getattr(args, "_run", None) is None:
        parser.print_help()
        return 2
    try:
        with warnings.catch_warnings(), interrupt_handlers():
            _SHOWN.clear()
            warnings.showwarning = _show_warning
            raise_if_interrupted()  # a Ctrl-C while the command was starting up: stop before any work
            check_outputs_not_inputs(args, args._files)  # before any work: no output replaces an input
            rc = _run_command(args)
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
    except WriteError as exc:  # the work ran, its output could not be written: not bad input
        print(f"jaxstiff: error: {exc}", file=sys.stderr)
        return 1
    except (ValueError, FileNotFoundError, OSError) as exc:
        print(f"jaxstiff: error: {exc}", file=sys.stderr)
        return 2
    except (RuntimeError, AssertionError) as exc:
        msg = _backend_failure(exc)
        if msg is None:
            raise
        print(f"jaxstiff: error: {msg}", file=sys.stderr)
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
