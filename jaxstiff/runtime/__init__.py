"""L0 runtime services, no JAX kernels: atomic files and interrupts (:mod:`.io`), start-up signals
(:mod:`.early_signals`), float64 opt-in (:mod:`.x64`), XLA options (:mod:`.xla`), multi-device
batches (:mod:`.sharding`), the version (:mod:`.version`). Importing this package imports nothing heavy."""

from .allocator import tune_allocator as tune_allocator

__all__ = ["tune_allocator"]
