"""The ``jaxstiff`` command's process-wide settings, applied when this module is imported (by
:mod:`jaxstiff.cli`, first, before JAX): start-up signal handlers that keep a Ctrl-C while JAX
loads (:mod:`._early_signals`) and glibc's allocator setting (:mod:`._allocator`; opt out with
``JAXSTIFF_MALLOC_TUNE=0``). ``import jaxstiff`` does not import it. Standard library only."""

from jaxstiff.runtime._allocator import tune_allocator
from jaxstiff.runtime._early_signals import record_early_signals

__all__: list[str] = []

record_early_signals()
tune_allocator()
