"""`python -m jaxstiff ...` is the `jaxstiff` command."""

import sys

from jaxstiff.cli import _main as main

sys.exit(main())
