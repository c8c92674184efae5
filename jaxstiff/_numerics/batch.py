"""Batch-shape and argument checks shared by the stiffness, ellipsoid, criteria and CSC modules."""

from __future__ import annotations

import warnings

import jax
import jax.numpy as jnp
import numpy as np
from jax.core import Tracer
from numpy.typing import ArrayLike

__all__: list[str] = []


class NotNumbersError(TypeError, ValueError):
    """An argument that should be numbers is not (text, None, an object, a ragged nested list).

    Both a ``TypeError`` and a ``ValueError``: the checks of every module raise this one class, so
    ``except TypeError`` and ``except ValueError`` each catch it wherever it comes from."""


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
    :class:`NotNumbersError` says it must be numbers). For value checks that a traced call cannot make."""
    if isinstance(x, Tracer):
        return None
    try:
        return np.asarray(x, dtype=float)
    except (TypeError, ValueError):
        if what is None:
            return None  # the function's own checks say so
        raise NotNumbersError(f"{what} must be a number or an array of numbers, got {type(x).__name__}") from None


def has_tracer(x: object) -> bool:
    """True where any leaf of ``x`` is a value inside a trace (jit, grad, vmap)."""
    return any(isinstance(leaf, Tracer) for leaf in jax.tree_util.tree_leaves(x))


def shown_value(value: object) -> str:
    """How a message shows what was given: the repr of a short text or None, else its type."""
    if value is None or isinstance(value, (str, bytes)):
        text = repr(value)
        return text if len(text) <= 60 else text[:57] + "..."
    if isinstance(value, np.ndarray):
        return f"an array of dtype {value.dtype} and shape {value.shape}"
    return f"an object of type {type(value).__name__}"


def refuse_non_numeric(name: str, value: object, expected: str, kinds: str = "biufc") -> None:
    """:class:`NotNumbersError` (a ``TypeError`` and a ``ValueError``) naming ``name``, ``expected``
    and what was given, when a concrete ``value`` is not numbers (text, None, objects; a dtype kind outside
    ``kinds``); JAX arrays and anything holding a traced value pass (they are numbers). Where
    JAX would meet the value with its own internal error, the caller names the argument instead."""
    if isinstance(value, jax.Array) or has_tracer(value):
        return
    if value is None or isinstance(value, (str, bytes)):
        raise NotNumbersError(f"{name} must be {expected}, got {shown_value(value)}")
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            a = np.asarray(value)
    except ValueError:  # numpy: "inhomogeneous shape"
        raise NotNumbersError(
            f"{name} must be {expected}, got a ragged nested sequence (rows of different lengths)"
        ) from None
    except Exception as e:
        raise NotNumbersError(f"{name} must be {expected}, got {shown_value(value)} ({e})") from None
    if a.dtype.kind not in kinds:
        if isinstance(value, (list, tuple)):
            raise NotNumbersError(
                f"{name} must be {expected}, got a {type(value).__name__} holding non-numbers ({a.dtype})"
            )
        raise NotNumbersError(f"{name} must be {expected}, got {shown_value(value)}")


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
