"""The ``jaxstiff`` command line (entry point :func:`main`); one private module a subcommand
(``_shape``, ``_csc``, ...), the shared flags and the command registry in ``_common``; exported:
:func:`main`, :func:`build_parser` and what a command module of one's own registers with.

Importing it applies the command's process-wide settings, first, before JAX is imported: a Ctrl-C
while the command starts up is remembered, not lost (:mod:`jaxstiff.runtime._early_signals`), and
large outputs reuse freed heap memory instead of fresh, page-faulting mmaps (glibc; opt out with
``JAXSTIFF_MALLOC_TUNE=0``; :mod:`jaxstiff.runtime._allocator`). ``import jaxstiff`` does neither.
"""

import jaxstiff.runtime._command_start  # noqa: F401 - first: the settings above

# isort: split

import sys as _sys

from jaxstiff.runtime._moved import former_names, keep_public_names

from ._common import (
    COMMANDS,
    TIP_LINK_HELP,
    add_robot_flags,
    check_out_file,
    command,
    parse_locks,
    robot_spec_from_args,
)
from ._main import build_parser, main

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


__getattr__ = former_names(__name__, {})  # the former modules (jaxstiff.cli.shape, ...)
# ``import jaxstiff.cli.main`` (the former module) leaves the entry point main here
keep_public_names(_sys.modules[__name__], {f"{__name__}.main": f"{__name__}._main"}, __all__)
