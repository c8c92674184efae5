"""Small batched linear algebra and the fusion boundary.

:func:`mm` is a broadcast-sum matrix product (it fuses on CPU, where ``dot_general`` on tiny
batched matrices does not); :func:`fusion_boundary` is an identity XLA cannot fuse across.
"""

from __future__ import annotations

from typing import Any

import jax
import jax.numpy as jnp
from jax.extend.core import Primitive as _Primitive
from jax.interpreters import ad, batching, mlir

__all__ = ["mm"]


def fusion_boundary(tree: Any) -> Any:
    """Identity that XLA cannot fuse across, also under ``vmap`` and for derivatives.

    Stacking the entries of an unrolled closed form into one array lets XLA's CPU backend fuse
    the whole computation into a single loop over the *output* elements, which re-evaluates the
    shared arithmetic for every one of them (measurements: docs/notes/model.md); an
    ``optimization_barrier`` is removed before fusion on CPU. A conditional is a fusion boundary:
    the entries are computed in one multi-output loop, then stacked. The predicate
    ``isnan(x) | (x == x)`` is true for every x, but not provably so to the compiler (identical
    branches would be folded).

    A plain ``lax.cond`` does not survive ``vmap`` (its predicate becomes batched and the cond a
    ``select``, which fuses again), nor does its boundary reach the tangents and cotangents. So the boundary is a linear
    primitive of its own: on CPU it lowers to the conditional with the predicate taken from the
    first element of the (batched) operand; it batches to itself, and its JVP and transpose are
    itself. On other platforms it lowers to the identity.
    """
    leaves, treedef = jax.tree_util.tree_flatten(tree)
    if not leaves or any(jnp.size(leaf) == 0 for leaf in leaves):
        return tree
    return jax.tree_util.tree_unflatten(treedef, _boundary_p.bind(*[jnp.asarray(v) for v in leaves]))


def _cond_identity(*xs: jax.Array) -> list[jax.Array]:
    x = xs[0].ravel()[0]
    return jax.lax.cond(jnp.isnan(x) | (x == x), lambda *a: list(a), lambda *a: [jnp.zeros_like(v) for v in a], *xs)


def _boundary_jvp(primals: list, tangents: list) -> tuple:
    tangents = [ad.instantiate_zeros(t) for t in tangents]
    return _boundary_p.bind(*primals), _boundary_p.bind(*tangents)


def _boundary_transpose(cts: list, *args: Any) -> list:
    cts = [ad.instantiate_zeros(ct) if type(ct) is ad.Zero else ct for ct in cts]
    return _boundary_p.bind(*cts)


def mm(A: jax.Array, B: jax.Array) -> jax.Array:
    """Small batched matrix product as a broadcast sum (fuses on CPU; dot_general on tiny batches does not)."""
    return jnp.sum(A[..., :, :, None] * B[..., None, :, :], axis=-2)


_boundary_p = _Primitive("jaxstiff_fusion_boundary")
_boundary_p.multiple_results = True
_boundary_p.def_impl(lambda *xs: list(xs))
_boundary_p.def_abstract_eval(lambda *avals: list(avals))
# The conditional only on CPU, where the problem was measured; on a GPU a conditional costs a
# round trip of its predicate to the host per call, so there it is a plain identity (not measured).
mlir.register_lowering(_boundary_p, mlir.lower_fun(lambda *xs: list(xs), multiple_results=True))
mlir.register_lowering(_boundary_p, mlir.lower_fun(_cond_identity, multiple_results=True), platform="cpu")
batching.primitive_batchers[_boundary_p] = lambda args, dims: (_boundary_p.bind(*args), dims)
ad.primitive_jvps[_boundary_p] = _boundary_jvp
ad.primitive_transposes[_boundary_p] = _boundary_transpose
