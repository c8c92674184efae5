"""Batch-shape and argument checks shared by the stiffness, ellipsoid, criteria and CSC modules."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
from jax.core import Tracer
from numpy.typing import ArrayLike

__all__: list[str] = []


def broadcast_batch(*named_shapes: tuple[str, tuple[int, ...]]) -> tuple[int, ...]:
    """The broadcast of the leading (batch) axes, or a ValueError naming the arguments."""
    try:
        return tuple(int(d) for d in jnp.broadcast_shapes(*(s for _, s in named_shapes)))
    except ValueError:
        raise ValueError(
            "batch axes do not broadcast: " + ", ".join(f"{n} {tuple(s)}" for n, s in named_shapes)
        ) from None


def known_floats(x: object, what: str | None = None) -> np.ndarray | None:
    """The values of ``x`` as a float numpy array where they are known here, else None: inside a
    trace (jit, grad, vmap), and for non-numbers unless ``what`` names the argument (then a
    ValueError says it must be numbers). For value checks that a traced call cannot make."""
    if isinstance(x, Tracer):
        return None
    try:
        return np.asarray(x, dtype=float)
    except (TypeError, ValueError):
        if what is None:
            return None  # the function's own checks say so
        raise ValueError(f"{what} must be a number or an array of numbers, got {type(x).__name__}") from None


def check_square(K: ArrayLike, name: str = "K") -> jax.Array:
    K = jnp.asarray(K)
    if K.ndim < 2 or K.shape[-1] != K.shape[-2] or K.shape[-1] not in (2, 3):
        raise ValueError(f"{name} must have shape (..., 2, 2) or (..., 3, 3), got {tuple(K.shape)}")
    if not jnp.issubdtype(K.dtype, jnp.floating):
        raise ValueError(f"{name} must have a floating dtype, got {K.dtype}")
    return K


def is_traced(x: object) -> bool:
    """True inside a trace (jit, grad, vmap): the value of ``x`` is not known here."""
    return isinstance(x, Tracer)


def batched_like(tree, ref: jax.Array):
    """``tree`` (a loop's initial carry) unchanged in value, but batched wherever ``ref`` is: under
    ``vmap`` a carry built from constants (zeros, an identity, a step size) starts unbatched, and
    JAX's batching rule for ``fori_loop`` / ``scan`` then batches the whole loop body twice (once
    to find that the carry becomes batched, again with it batched), and a loop inside that body
    is batched once per pass of every loop around it. pgd's chunk program traced in about twice
    the time for that (docs/notes/speed.md). ``select(p, v, v)`` is ``v`` whatever ``p``
    is (NaN included), and XLA removes it: the compiled program computes the same."""
    if jnp.size(ref) == 0:  # (an empty batch: nothing to batch by)
        return tree
    r = jnp.ravel(ref)[0]
    p = r == r
    return jax.tree.map(lambda v: jax.lax.select(jnp.broadcast_to(p, jnp.shape(v)), v, v), tree)
