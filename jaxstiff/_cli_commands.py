"""Imports the modules that register CLI subcommands (kept apart so cli.py stays import-light).

Each module that adds a subcommand is imported here, in the order `jaxstiff --help` lists them;
the core library never imports the CLI.
"""
from . import _cli_shape  # noqa: F401  (jaxstiff shape)
from . import _cli_csc  # noqa: F401  (jaxstiff csc)
from . import _cli_sweep  # noqa: F401  (jaxstiff sweep)
from . import _cli_reproduce  # noqa: F401  (jaxstiff reproduce)
