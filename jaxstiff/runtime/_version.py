"""The package version (one place; ``jaxstiff.__version__`` and the result files' meta read it)."""

__version__ = "0.1.0"
