"""L0 runtime services, no JAX kernels. Exported, for a script that wants what the ``jaxstiff``
command does: :func:`tune_allocator` (the one process-wide opt-in), :func:`kernel_compiler_options`
(jaxstiff's XLA options for one's own ``jax.jit``), :func:`release_compiled` and
:func:`release_if_near_map_limit` (letting compiled programs go in long loops). The code is in
private modules: atomic files and interrupts (``_io``), start-up signals (``_early_signals``),
float64 opt-in (``_x64``), XLA options (``_xla``), multi-device batches (``_sharding``), the
version (``_version``), the former module paths (``_moved``). The names load on first use
(PEP 562): importing this package imports nothing heavy."""

from __future__ import annotations

from typing import TYPE_CHECKING

from ._lazy import lazy_exports

_SOURCES = {
    "._allocator": ("tune_allocator",),
    "._programs": ("release_compiled", "release_if_near_map_limit"),
    "._xla": ("kernel_compiler_options",),
}
__all__ = ["kernel_compiler_options", "release_compiled", "release_if_near_map_limit", "tune_allocator"]

__getattr__, __dir__ = lazy_exports(__name__, globals(), _SOURCES)


if TYPE_CHECKING:
    from ._allocator import tune_allocator as tune_allocator
    from ._programs import release_compiled as release_compiled
    from ._programs import release_if_near_map_limit as release_if_near_map_limit
    from ._xla import kernel_compiler_options as kernel_compiler_options
