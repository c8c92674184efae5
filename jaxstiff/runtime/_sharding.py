"""Split a batch across all local JAX devices (``jax.sharding``); a leaf helper for batched kernels.

A batched kernel (``vmap`` over a leading axis, then ``jit``) runs on several devices when its
batch inputs are placed with a :class:`jax.sharding.NamedSharding` over a 1-D device mesh: XLA
partitions the computation along that axis (GSPMD), each device computes its rows, and the
outputs come back sharded the same way (``np.asarray`` gathers them). On one device this is a
plain ``device_put``. The batch is padded (the last row repeated) to a multiple of the device
count, or to a fixed size so that every call has the same shape and compiles once.

On CPU, ``XLA_FLAGS=--xla_force_host_platform_device_count=N`` (set before JAX starts) simulates N
devices; on a GPU node every local GPU is one device.

Used by :mod:`jaxstiff.sweep` (CSC chunks); any batched solver can use :func:`shard_rows` the same way.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

__all__ = ["device_count", "padded_size"]


def device_count() -> int:
    """Number of local JAX devices (the ways a batch is split)."""
    import jax

    return jax.local_device_count()


def padded_size(B: int, size: int | None = None) -> int:
    """``max(B, size)`` rounded up to a multiple of :func:`device_count`."""
    nd = device_count()
    target = max(int(B), int(size or B))
    return -(-target // nd) * nd


def shard_rows(arrays: Mapping[str, Any], size: int | None = None) -> tuple[dict[str, Any], int]:
    """Pad arrays along axis 0 and place them sharded across all local devices.

    Args:
        arrays: name -> array with the batch on axis 0 (all the same length B >= 1).
        size: pad to at least this many rows (e.g. a chunk size: one compilation for every chunk);
            rounded up to a multiple of the device count. Padding repeats the last row, so the
            padded rows are valid inputs; drop them from the outputs (``out[:B]``).

    Returns:
        ``(placed, devices)``: jax arrays sharded with ``NamedSharding(Mesh(devices, ("batch",)),
        PartitionSpec("batch"))`` (plain device arrays on one device), and the device count.

    Raises:
        ValueError: arrays of different lengths, or an empty batch.
    """
    import jax
    import jax.numpy as jnp
    from jax.sharding import Mesh, NamedSharding, PartitionSpec

    if not arrays:
        raise ValueError("shard_rows: no arrays")
    lengths = {k: int(np.shape(a)[0]) for k, a in arrays.items()}
    B = next(iter(lengths.values()))
    if B < 1 or any(v != B for v in lengths.values()):
        raise ValueError(f"shard_rows: arrays need the same batch length >= 1, got {lengths}")
    devices = jax.local_devices()
    nd = len(devices)
    target = padded_size(B, size)
    sharding = NamedSharding(Mesh(np.array(devices), ("batch",)), PartitionSpec("batch")) if nd > 1 else None
    out = {}
    for k, a in arrays.items():
        a = np.asarray(a)
        if target > B:
            a = np.concatenate([a, np.repeat(a[-1:], target - B, axis=0)], axis=0)
        out[k] = jax.device_put(a, sharding) if sharding is not None else jnp.asarray(a)
    return out, nd
