"""L0 runtime services, no JAX kernels: atomic files and interrupts (:mod:`._io`), start-up signals
(:mod:`._early_signals`), float64 opt-in (:mod:`._x64`), XLA options (:mod:`._xla`), multi-device
batches (:mod:`._sharding`), the version (:mod:`._version`). Importing this package imports nothing heavy."""

from ._allocator import tune_allocator as tune_allocator

__all__ = ["tune_allocator"]
