"""The ``jaxstiff`` command. A thin layer: parse flags, call the library, print or write results.

Subcommands register themselves in :data:`COMMANDS` as ``name -> (add_arguments, run)``; each
``run(args)`` returns an exit code. Errors a user can fix (bad files, bad values) are printed as
one line ``jaxstiff: error: ...`` with exit code 2, never as a traceback.
"""

from __future__ import annotations

import argparse
import os
import re
import signal
import sys
import tempfile
import warnings
from typing import Callable

from ._io import interrupt_exit_code, interrupt_handlers, interrupt_pending, raise_if_interrupted

COMMANDS: dict[str, tuple[Callable[[argparse.ArgumentParser], None], Callable[[argparse.Namespace], int], str]] = {}


def command(name: str, help: str):
    """Decorator pair: ``@command(name, help)`` on a function ``add(parser)`` returning ``run``."""

    def deco(add: Callable[[argparse.ArgumentParser], Callable[[argparse.Namespace], int]]):
        COMMANDS[name] = (add, None, help)  # run is bound when the parser is built
        return add

    return deco


def _floats(text: str, what: str) -> list[float]:
    try:
        return [float(v) for v in text.split(",") if v.strip() != ""]
    except ValueError:
        raise ValueError(f"{what}: expected comma-separated numbers, got {text!r}") from None


def parse_locks(items: list[str] | None) -> dict[str, float]:
    """``["JOINT=RAD", ...]`` -> dict (``["none"]``: no joint locked, {}); raises ValueError naming a
    malformed item."""
    out: dict[str, float] = {}
    if items and [x.strip().lower() for x in items] == ["none"]:
        return out
    for item in items or []:
        name, sep, value = item.partition("=")
        if not sep or not name:
            raise ValueError(f"--lock expects JOINT=RAD, got {item!r}")
        if name in out:
            raise ValueError(f"--lock: joint {name!r} is given twice ({name}={out[name]:g} and {item})")
        try:
            out[name] = float(value)
        except ValueError:
            raise ValueError(f"--lock {item!r}: {value!r} is not a number (radians)") from None
    return out


#: --tip-link's help, shared by the commands that read a chain (Robot.from_urdf's rule)
TIP_LINK_HELP = "last link of the chain (default: the leaf reached through the most actuated joints; an error if several tie)"


# ----------------------------------------------------------------------------- robot
@command("robot", "print a robot's chain, limits, and FK/Jacobian at a posture")
def _add_robot(p: argparse.ArgumentParser):
    p.add_argument("--robot", default="kuka_lwr4", help="URDF file or shipped robot name (default: kuka_lwr4)")
    p.add_argument("--base-link", default=None, help="first link of the chain (default: the URDF root)")
    p.add_argument("--tip-link", default=None, help=TIP_LINK_HELP)
    p.add_argument("--lock", action="append", metavar="JOINT=RAD", help="lock a joint at a value (repeatable)")
    p.add_argument("--q", default=None, help="posture, comma-separated rad (m for prismatic joints; default: the nominal posture, mid-range + 30 deg per revolute joint, mid-range for a prismatic one)")

    def run(args) -> int:
        import numpy as np

        from .robot import Robot
        from ._x64 import enable_x64

        enable_x64()
        robot = Robot.from_urdf(args.robot, base_link=args.base_link, tip_link=args.tip_link, locked=parse_locks(args.lock))
        if args.q is None:
            from .ik import nominal_posture

            q = nominal_posture(robot)  # +30 deg (revolute), mid-range (prismatic), within the limits
        else:
            q = np.asarray(_floats(args.q, "--q"), dtype=float)
            if q.shape != (robot.n,):
                raise ValueError(f"--q needs {robot.n} values for {robot.name!r}, got {q.size}")
            for i in np.flatnonzero(~robot.free):
                if q[i] != robot.locked_values[i]:
                    raise ValueError(f"--q gives joint {robot.joint_names[i]!r} = {q[i]:g}, but it is locked at "
                                     f"{robot.locked_values[i]:g} (--lock); give the locked value or drop the lock")
            out = np.flatnonzero((q < robot.lower) | (q > robot.upper))
            if out.size:
                i = int(out[0])
                warnings.warn(f"--q: joint {robot.joint_names[i]!r} = {q[i]:g} is outside its limits "
                              f"[{robot.lower[i]:g}, {robot.upper[i]:g}] (FK and Jacobian shown anyway)", stacklevel=1)
        T, J = robot.fk_and_jacobian(q)
        np.set_printoptions(precision=5, suppress=True, linewidth=120)
        print(robot.describe())
        pris = robot.prismatic
        unit = "deg; m for prismatic joints" if pris.any() else "deg"
        print(f"\nposture q ({unit}): {np.round(np.where(pris, q, np.rad2deg(q)), 4).tolist()}")
        print("\nT_base_tcp (m):")
        print(np.asarray(T) + 0.0)  # + 0.0 turns -0.0 into 0.0
        print("\nJ_base (rows vx vy vz [m/s per rad/s], wx wy wz [rad/s per rad/s]):")
        print(np.asarray(J) + 0.0)
        return 0

    return run


class _HelpFormatter(argparse.ArgumentDefaultsHelpFormatter):
    """Appends ``(default: X)`` only where it says something: not for a None default, and not where the
    help text already states its default in words."""

    def _get_help_string(self, action):
        text = action.help or ""
        if action.default is None or "default" in text.lower():
            return text
        return super()._get_help_string(action)


def build_parser() -> argparse.ArgumentParser:
    # importing these modules registers their subcommands
    from . import _cli_commands  # noqa: F401

    parser = argparse.ArgumentParser(
        prog="jaxstiff",
        description="Stiffness-ellipsoid shaping and Configuration-based Stiffness Control for redundant arms.",
    )
    from . import __version__

    parser.add_argument("--version", action="version", version=f"jaxstiff {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name, (add, _, help_) in COMMANDS.items():
        sp = sub.add_parser(name, help=help_, description=help_, formatter_class=_HelpFormatter)
        sp.set_defaults(_run=add(sp))
    return parser


_PACKAGE_DIR = os.path.dirname(os.path.abspath(__file__))
_default_showwarning = warnings.showwarning


def _show_warning(message, category, filename, lineno, file=None, line=None):
    """jaxstiff's own warnings (a URDF joint with an empty range, ...) as one line like the
    commands' other warnings, not Python's file:line: Category + source line; others unchanged."""
    if os.path.abspath(filename).startswith(_PACKAGE_DIR + os.sep):
        print(f"jaxstiff: warning: {message}", file=sys.stderr if file is None else file)
    else:
        _default_showwarning(message, category, filename, lineno, file, line)


def check_out_file(out: str, flag: str = "--out") -> str:
    """The result file of a command, checked before any work: a file name (``.npz`` added when
    missing) in an existing, writable folder, and not an existing folder. Returns the absolute path."""
    if out.strip() and os.path.isdir(out):  # checked before ".npz" is added: the folder itself was meant
        raise ValueError(f"{flag}: {os.path.abspath(out)} is a folder; give a file name inside it, like "
                         f"{os.path.join(out, 'result.npz')}")
    name = out if out.endswith(".npz") else out + ".npz"
    if not out.strip() or os.path.basename(name) == ".npz" or out.endswith(("/", os.sep)):
        raise ValueError(f"{flag}: expected a file name like result.npz, got {out!r}")
    path = os.path.abspath(name)
    if os.path.isdir(path):
        raise ValueError(f"{flag}: {path} is a folder; give a file name inside it, like {os.path.join(out, 'result.npz')}")
    folder = os.path.dirname(path)
    if not os.path.isdir(folder):
        raise FileNotFoundError(f"{flag}: folder does not exist: {folder}")
    # a real probe, not os.access (which says yes to root on a read-only mount): create and remove
    # a temporary file where the result will go, so the work does not start for nothing
    try:
        fd, probe = tempfile.mkstemp(prefix=".probe-", dir=folder)
        os.close(fd)
        os.unlink(probe)
    except OSError as e:
        raise ValueError(f"{flag}: cannot write into folder {folder}: {e.strerror or e}") from None
    return path


_NEGATIVE_VALUE = re.compile(r"^-\.?\d")


def _join_negative_values(argv: list[str]) -> list[str]:
    """``--hold -0.5,0.2`` as ``--hold=-0.5,0.2``: argparse takes a token that starts with '-' and
    is not a plain number (a comma list is not) for an option and refuses the value. No option
    name starts with a digit, so such a token after a long option is always its value."""
    out: list[str] = []
    for tok in argv:
        if out and out[-1].startswith("--") and "=" not in out[-1] and _NEGATIVE_VALUE.match(tok):
            out[-1] = f"{out[-1]}={tok}"
        else:
            out.append(tok)
    return out


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(_join_negative_values(sys.argv[1:] if argv is None else list(argv)))
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
            print(f"jaxstiff: interrupted ({signal.Signals(sig).name}) after the work had finished; its output was written",
                  file=sys.stderr)
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


if __name__ == "__main__":  # pragma: no cover
    # run the imported module's main, not this __main__ copy: subcommands register on jaxstiff.cli
    from jaxstiff.cli import main as _main

    sys.exit(_main())
