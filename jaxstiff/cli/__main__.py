"""``python -m jaxstiff.cli``: the ``jaxstiff`` command."""

import sys

from jaxstiff.cli._main import main

sys.exit(main())
