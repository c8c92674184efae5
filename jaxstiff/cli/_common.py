"""What the commands share: the subcommand registry, flag parsers, the result-file check.

Subcommands register themselves in :data:`COMMANDS` as ``name -> (add_arguments, run)``; each
``run(args)`` returns an exit code. Errors a user can fix (bad files, bad values) are printed as
one line ``jaxstiff: error: ...`` with exit code 2, never as a traceback (:func:`jaxstiff.cli.main`).
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import re
import tempfile
from collections.abc import Callable
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from jaxstiff.settings._robot import RobotSpec

#: ``add(parser)`` adds a command's flags and returns its ``run(args) -> exit status``
AddCommand = Callable[[argparse.ArgumentParser], Callable[[argparse.Namespace], int]]
COMMANDS: dict[str, tuple[AddCommand, None, str]] = {}


def command(name: str, help: str) -> Callable[[AddCommand], AddCommand]:
    """Decorator pair: ``@command(name, help)`` on a function ``add(parser)`` returning ``run``."""

    def deco(add: AddCommand) -> AddCommand:
        COMMANDS[name] = (add, None, help)  # run is bound when the parser is built
        return add

    return deco


def parse_floats(text: str, what: str) -> list[float]:
    """Comma-separated numbers of the flag ``what``; an error names the flag and the text. An empty
    item ("1,,2") is an error, not skipped: a value left out would shift the ones after it."""
    items = str(text).split(",")
    if str(text).strip() and any(not v.strip() for v in items):
        at = next(i for i, v in enumerate(items) if not v.strip()) + 1
        raise ValueError(f"{what}: item {at} of {text!r} is empty; give one number per item, like 1,0,2")
    try:
        return [float(v) for v in items if v.strip() != ""]
    except ValueError:
        raise ValueError(f"{what}: expected comma-separated numbers, got {text!r}") from None


def parse_locks(items: list[str] | None) -> dict[str, float]:
    """``["JOINT=VALUE", ...]`` -> dict (``["none"]``: no joint locked, {}); raises ValueError naming a
    malformed item. The value follows the last "=" (a joint's name may contain "=")."""
    out: dict[str, float] = {}
    if items and [x.strip().lower() for x in items] == ["none"]:
        return out
    for item in items or []:
        name, sep, value = item.rpartition("=")
        if item.strip().lower() == "none":
            raise ValueError("--lock none (no joint locked) cannot be combined with other --lock JOINT=RAD")
        if not sep or not name:
            raise ValueError(f"--lock expects JOINT=RAD, got {item!r}")
        if name in out:
            raise ValueError(f"--lock: joint {name!r} is given twice ({name}={out[name]:g} and {item})")
        try:
            out[name] = float(value)
        except ValueError:
            raise ValueError(f"--lock {item!r}: {value!r} is not a number (rad, or m for a prismatic joint)") from None
    return out


#: --tip-link's help, shared by the commands that read a chain (Robot.from_urdf's rule)
TIP_LINK_HELP = (
    "last link of the chain (default: the leaf reached through the most actuated joints, never through a gripper or "
    "finger joint; ties: not a finger part nor a sensor frame, then end-effector names tcp, tool, ee, flange, hand; "
    "an error lists the rest; `jaxstiff robot URDF` lists the candidates)"
)


def check_out_file(out: str, flag: str = "--out") -> str:
    """The result file of a command, checked before any work: a ``.npz`` file name (``.npz`` added to
    a name without a suffix; another suffix is refused, since the file would be written under a
    name the user did not give) in an existing, writable folder, and not an existing folder or
    special file (``/dev/null``). Returns the absolute path."""
    from jaxstiff.runtime._io import refuse_special_output

    if out.strip() and os.path.isdir(out):  # checked before ".npz" is added: the folder itself was meant
        raise ValueError(
            f"{flag}: {os.path.abspath(out)} is a folder; give a file name inside it, like "
            f"{os.path.join(out, 'result.npz')}"
        )
    if out.strip():
        refuse_special_output(out, f"{flag}: ", "give a file name like result.npz")
    ext = os.path.splitext(out)[1]
    if ext and ext.lower() != ".npz":
        raise ValueError(
            f"{flag}: {out!r}: a result file is written as .npz, and a name with another suffix would be written "
            f"as {out + '.npz'!r}; give {os.path.splitext(out)[0] + '.npz'!r} or {out + '.npz'!r}"
        )
    name = out if ext else out + ".npz"  # o.NPZ is a file name already
    if not out.strip() or os.path.basename(name) == ".npz" or out.endswith(("/", os.sep)):
        raise ValueError(f"{flag}: expected a file name like result.npz, got {out!r}")
    return check_out_path(os.path.abspath(name), flag, like=os.path.join(out, "result.npz"))


# ---------------------------------------------------------------------- files read and written
@dataclasses.dataclass(frozen=True)
class FileFlag:
    """What a command does with the path of one of its flags (declared once, where the flag is
    added, by :func:`reads` / :func:`writes`; :func:`check_outputs_not_inputs` reads them all).

    Attributes:
        writes: True for an output, False for an input.
        folder: an output folder the command writes into (``names`` inside it); for an input, a
            file or a folder (a sweep folder's files are inputs too).
        names: the files and folders an output folder gets (``plan.json``, ``plots``, ...).
        suffix: appended to an output file's name when missing (``.npz``), as the command does.
        shipped_robot: an input that may name a shipped robot instead of a file (``--robot``).
        stdout: an output file that may be ``-``, standard output.
    """

    writes: bool
    folder: bool = False
    names: tuple[str, ...] = ()
    suffix: str = ""
    shipped_robot: bool = False
    stdout: bool = False


_FILE_ATTR = "jaxstiff_file"


def reads(action: argparse.Action, *, shipped_robot: bool = False) -> argparse.Action:
    """Declare ``action``'s value (a path, or a list of them) an input of its command."""
    setattr(action, _FILE_ATTR, FileFlag(writes=False, shipped_robot=shipped_robot))
    return action


def writes(
    action: argparse.Action,
    *,
    folder: bool = False,
    names: tuple[str, ...] = (),
    suffix: str = "",
    stdout: bool = False,
) -> argparse.Action:
    """Declare ``action``'s value an output of its command: a file (``suffix`` added when missing;
    ``stdout``: ``-`` is standard output), or a folder written into (``names``: what the command
    writes inside it)."""
    setattr(action, _FILE_ATTR, FileFlag(writes=True, folder=folder, names=names, suffix=suffix, stdout=stdout))
    return action


def file_flags(*parsers: argparse.ArgumentParser) -> list[tuple[str, str, FileFlag]]:
    """``(dest, shown name, FileFlag)`` of every declared path flag of ``parsers``."""
    out = []
    for p in parsers:
        for a in p._actions:
            role = getattr(a, _FILE_ATTR, None)
            if role is not None:
                shown = max(a.option_strings, key=len) if a.option_strings else str(a.metavar or a.dest)
                out.append((a.dest, shown, role))
    return out


def _input_file(value: str, role: FileFlag) -> str:
    """The file an input path names (``--robot NAME``: the shipped robot's URDF where no such file is)."""
    if role.shipped_robot and not os.path.exists(value) and os.sep not in value and not value.endswith(".urdf"):
        from jaxstiff.model._shipped import robot_path

        try:
            return robot_path(value)
        except FileNotFoundError:
            return value
    return value


def _same_file(a: str, b: str) -> bool:
    """Whether two existing paths are one file or folder (symlinks followed, hard links seen)."""
    try:
        return os.path.samefile(a, b)
    except (OSError, ValueError):
        return False


def _inside(path: str, folder: str) -> bool:
    """Whether an existing ``path`` lies inside the existing folder ``folder`` (links resolved)."""
    try:
        p, f = os.path.realpath(path), os.path.realpath(folder)
        return os.path.isdir(f) and os.path.commonpath([p, f]) == f and p != f
    except (OSError, ValueError):
        return False


def check_outputs_not_inputs(args: argparse.Namespace, flags: list[tuple[str, str, FileFlag]]) -> None:
    """Refuse a command whose output would replace one of its inputs, before any work.

    ``flags``: the command's declared path flags (:func:`file_flags`). An output file is refused
    when it is an input file (the same file through a symlink or a hard link too) or an existing
    file inside an input folder (a sweep folder); an output folder when it is an input, or when
    one of the files or folders it writes (``FileFlag.names``) is or holds an input. Paths that do
    not exist yet replace nothing. An output file that is a device or a pipe is refused too
    (:func:`jaxstiff.runtime._io.refuse_special_output`). Raises ValueError naming both flags and paths.
    """
    from jaxstiff.runtime._io import refuse_special_output

    inputs: list[tuple[str, str]] = []
    for dest, shown, role in flags:
        value = getattr(args, dest, None)
        if role.writes or value is None:
            continue
        for v in value if isinstance(value, (list, tuple)) else [value]:
            if isinstance(v, str) and v.strip():
                inputs.append((shown, _input_file(v, role)))
    for dest, shown, role in flags:
        value = getattr(args, dest, None)
        out = _output_name(value, role)
        if out is None:
            continue
        if not role.folder:
            refuse_special_output(out, f"{shown} ", "give a file name" + (", or '-' for standard output" * role.stdout))
        targets = [out] + [os.path.join(out, n) for n in role.names]
        for t in targets:
            if not os.path.exists(t):
                continue
            for name, path in inputs:
                if not os.path.exists(path):
                    continue
                if _same_file(t, path):
                    how = "" if os.path.abspath(t) == os.path.abspath(path) else ", through a link"
                    what = f"{shown} {out}" + (f" (it writes {t})" if t != out else "")
                    raise ValueError(
                        f"{what} is the {name} file itself ({path}{how}): writing it would replace that input; "
                        "choose another output"
                    )
                if t == out and not role.folder and _inside(t, path):
                    raise ValueError(
                        f"{shown} {out} is a file of the {name} input folder {path}: writing it would "
                        "replace that input; choose another output"
                    )
                if t != out and _inside(path, t):
                    raise ValueError(
                        f"{shown} {out}: the command writes into {t}, which holds the {name} input {path}; "
                        "choose another output"
                    )


def _output_name(value: object, role: FileFlag) -> str | None:
    """The file or folder an output flag's ``value`` names, as the command writes it (``suffix``
    added); None for no output (not an output flag, empty, ``-`` for standard output)."""
    if not role.writes or not isinstance(value, str) or not value.strip() or (role.stdout and value == "-"):
        return None
    if role.suffix and not value.lower().endswith(role.suffix) and not os.path.isdir(value):
        return value + role.suffix
    return value


def check_out_path(path: str, flag: str, like: str = "") -> str:
    """An output file's path (as it will be written), checked before any work: not an existing
    folder, in an existing folder that can be written into. Returns the absolute path.
    ``like``: an example file name for the message when ``path`` is a folder."""
    from jaxstiff.runtime._io import refuse_special_output

    path = os.path.abspath(path)
    if os.path.isdir(path):
        raise ValueError(f"{flag}: {path} is a folder; give a file name inside it" + (f", like {like}" if like else ""))
    refuse_special_output(path, f"{flag}: ")
    folder = os.path.dirname(os.path.realpath(path))  # a link's file is written where it points
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


def join_negative_values(argv: list[str]) -> list[str]:
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


def add_robot_flags(p: argparse.ArgumentParser, springs: bool = True) -> None:
    """The robot flags every command takes, with :class:`~jaxstiff.settings.RobotSpec`'s defaults:
    ``--robot --base-link --tip-link --lock JOINT=VALUE ... --tcp x,y,z[,roll,pitch,yaw]``.
    ``springs``: the command has ``--locked-joints`` (shape, csc), which ``--lock``'s help names;
    False for a command without it (robot)."""
    from jaxstiff.settings._robot import DEFAULT_LOCKS, DEFAULT_ROBOT

    shipped = "; ".join(f"{r}: {', '.join(f'{j}={v:g}' for j, v in lk.items())}" for r, lk in DEFAULT_LOCKS.items())
    give = (
        " and, by default, does not give: it is rigid (no spring, no stiffness variable; "
        "'--locked-joints spring' keeps its spring)"
        if springs
        else ""
    )
    reads(
        p.add_argument(
            "--robot", default=DEFAULT_ROBOT, help=f"URDF file or shipped robot name (default: {DEFAULT_ROBOT})"
        ),
        shipped_robot=True,
    )
    p.add_argument("--base-link", default=None, help="first link of the chain (default: the URDF root)")
    p.add_argument("--tip-link", default=None, help=TIP_LINK_HELP)
    p.add_argument(
        "--lock",
        action="append",
        metavar="JOINT=VALUE",
        help=f"lock a joint at a value, rad (m for a prismatic joint); repeatable. A locked joint does "
        f"not move{give}. Default: the shipped "
        f"robot's locks ({shipped}; seed 000), none for other URDFs; '--lock none' frees every joint",
    )
    p.add_argument(
        "--tcp",
        default=None,
        metavar="X,Y,Z[,ROLL,PITCH,YAW]",
        help="tool offset after the tip link, in the tip frame: m, and rad for the URDF-style "
        "roll-pitch-yaw rotation (default: none)",
    )


def robot_spec_from_args(args: argparse.Namespace) -> RobotSpec:
    """The :class:`~jaxstiff.settings.RobotSpec` of the robot flags (errors name the flag)."""
    from jaxstiff.settings._robot import RobotSpec

    locked = None if not args.lock else parse_locks(args.lock)
    tcp = None
    if args.tcp is not None:
        tcp = tuple(parse_floats(args.tcp, "--tcp"))
        if len(tcp) not in (3, 6):
            raise ValueError(
                f"--tcp expects 3 values x,y,z (m) or 6 values x,y,z,roll,pitch,yaw (m, rad), got {args.tcp!r}"
            )
    try:
        return RobotSpec(urdf=args.robot, base_link=args.base_link, tip_link=args.tip_link, locked=locked, tcp=tcp)
    except ValueError as e:
        raise ValueError(str(e).replace("robot.tcp", "--tcp").replace("robot.locked", "--lock")) from None


def rollout_row_bytes(n: int, task: str) -> int:
    """Bytes one step of one CSC rollout holds until the file is written: the result row (q, kj:
    n each; K_C: m x m for m = 2, 3, 6 task rows; position 3, target d; 7 scalars; float64)
    twice (the finished segments and their concatenation) and its target (d = 2 for task xy, else 3)."""
    m = {"xy": 2, "xyz": 3, "full": 6}[task]
    from jaxstiff.settings._shape import task_dim

    d = task_dim(task)
    return 2 * 8 * (2 * n + m * m + 3 + d + 7) + 8 * d


def check_rollout_size(B: int, T: int, n: int, task: str, flag: str) -> None:
    """Refuse B CSC rollouts of T steps (n joints) whose result cannot fit in memory, naming ``flag``.
    The segments of a long run stream the work, not the result (the file holds it whole), so the
    estimate is the result's; a run longer than a segment but with a result that fits is accepted."""
    from jaxstiff.runtime._plan_size import check_plan_size

    check_plan_size(f"{B} rollout(s) x {T} steps ({n} joints, task {task!r})", B * T, rollout_row_bytes(n, task), flag)
