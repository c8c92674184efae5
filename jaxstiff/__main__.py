"""`python -m jaxstiff ...` is the `jaxstiff` command."""

import sys

from jaxstiff.cli import main

sys.exit(main())
