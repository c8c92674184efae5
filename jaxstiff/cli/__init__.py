"""The ``jaxstiff`` command line (entry point :func:`main`); one module a subcommand.

Importing it applies the command's process-wide settings, first, before JAX is imported: a Ctrl-C
while the command starts up is remembered, not lost (:mod:`jaxstiff.runtime._early_signals`), and
large outputs reuse freed heap memory instead of fresh, page-faulting mmaps (glibc; opt out with
``JAXSTIFF_MALLOC_TUNE=0``; :mod:`jaxstiff.runtime._allocator`). ``import jaxstiff`` does neither.
"""

import jaxstiff.runtime._command_start  # noqa: F401 - first: the settings above

# isort: split

from ._common import COMMANDS as COMMANDS
from ._common import TIP_LINK_HELP as TIP_LINK_HELP
from ._common import add_robot_flags as add_robot_flags
from ._common import check_out_file as check_out_file
from ._common import command as command
from ._common import parse_locks as parse_locks
from ._common import robot_spec_from_args as robot_spec_from_args
from ._main import build_parser as build_parser
from ._main import main as main

__all__ = [
    "COMMANDS",
    "TIP_LINK_HELP",
    "add_robot_flags",
    "build_parser",
    "check_out_file",
    "command",
    "main",
    "parse_locks",
    "robot_spec_from_args",
]
