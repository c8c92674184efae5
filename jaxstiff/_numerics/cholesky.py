"""Damped inverse of a small symmetric positive semi-definite matrix (m = 2, 3 or 6), unrolled.

The matrix is handled as a dict ``{(i, j): entry (...,)}`` over ``i <= j`` (:data:`Sym`, a
structure of arrays): every closed form below is elementwise arithmetic on the batch, which XLA
fuses into one loop (:func:`jaxstiff._numerics.linalg.fusion_boundary` separates the entries from
their stacking). The factorisation, its damping and the JVP are described in
:mod:`jaxstiff.stiffness._core` (SPEC section 2); why this form: docs/notes/model.md.
"""

from __future__ import annotations

import functools

import jax
import jax.numpy as jnp

from jaxstiff._numerics.linalg import fusion_boundary, mm

__all__ = ["Sym", "reg_eps", "gram_of_inverse", "damped_inverse_entries"]

# A symmetric matrix as a dict {(i, j): entry (...,)} over i <= j (structure of arrays).
Sym = dict

# Row order of the factorisation: for m = 6 the rotational rows first, so that the translational
# block of the inverse only needs the trailing 3x3 of L (the Cholesky factor of the Schur complement).
CHOLESKY_ORDER: dict[int, tuple[int, ...]] = {2: (0, 1), 3: (0, 1, 2), 6: (3, 4, 5, 0, 1, 2)}


def reg_eps(dtype: jnp.dtype) -> float:
    """Relative damping ``eps``: 1e-12 in float64, 1e-6 in float32."""
    return 1e-12 if jnp.finfo(dtype).bits >= 64 else 1e-6


def _nu0(dtype: jnp.dtype) -> float:
    return 1e-6 if jnp.finfo(dtype).bits >= 64 else 1e-3


def _g(S: Sym, i: int, j: int) -> jax.Array:
    return S[(i, j)] if i <= j else S[(j, i)]


def sym_entries(C: jax.Array) -> Sym:
    """The upper-triangle entries ``{(i, j): C[..., i, j]}`` (i <= j) of a (..., m, m) array."""
    m = C.shape[-1]
    return {(i, j): C[..., i, j] for i in range(m) for j in range(i, m)}


def sym_to_array(S: Sym, m: int, boundary: bool = True) -> jax.Array:
    """The (..., m, m) symmetric array of ``S``; behind a fusion boundary unless ``boundary=False``."""
    if boundary:
        S = fusion_boundary(S)
    return jnp.stack([jnp.stack([_g(S, i, j) for j in range(m)], axis=-1) for i in range(m)], axis=-2)


def damped_cholesky(S: Sym, order: tuple[int, ...]) -> tuple[dict, list]:
    """Unrolled Cholesky ``P C P^T + diag(e) = L L^T`` of a symmetric PSD matrix, with damping.

    ``order`` permutes the rows (``P``). Pivot j is ``p_j = C_jj - sum_k L_jk^2``, the part of
    row j not explained by the rows before it. It is damped by
    ``e_j = eps * t * exp(-max(p_j, 0) / (nu0 * C_jj))`` (``t = trace / m``): exactly zero (to the
    last bit) while the pivot keeps more than ~10 nu0 of its diagonal, i.e. at every
    well-conditioned matrix, ``eps * t`` where a row is (numerically) dependent on the previous
    ones, smooth between. Adding ``e_j`` to pivot j is the same as factorising ``C + e_j E_jj``,
    so the result is the exact Cholesky factor of ``C + diag(e)``: backward stable (errors
    ~``eps_machine * |C|``, far below the damping).

    Returns:
        ``(L, e)``: ``L[(i, j)]`` for i >= j in the permuted order, and the damping per row.
    """
    m = len(order)
    diag = [S[(k, k)] for k in order]
    dtype = diag[0].dtype
    t = sum(diag) / m + jnp.sqrt(jnp.finfo(dtype).tiny)
    eps, nu0 = reg_eps(dtype), _nu0(dtype)
    L: dict = {}
    damping = []
    for j in range(m):
        p = diag[j] - sum(L[(j, k)] * L[(j, k)] for k in range(j)) if j else diag[j]
        p = jnp.maximum(p, 0.0)
        e = eps * t * jnp.exp(-p / (nu0 * (diag[j] + eps * t)))
        Ljj = jnp.sqrt(p + e)
        inv = 1.0 / Ljj
        L[(j, j)] = Ljj
        damping.append(e)
        for i in range(j + 1, m):
            cij = _g(S, order[i], order[j])
            if j:
                cij = cij - sum(L[(i, k)] * L[(j, k)] for k in range(j))
            L[(i, j)] = cij * inv
    return L, damping


def tri_inverse(L: dict, m: int, start: int = 0) -> dict:
    """Inverse W of the lower-triangular block ``L[start:, start:]`` (W[(i, j)], i >= j)."""
    W: dict = {}
    for i in range(start, m):
        W[(i, i)] = 1.0 / L[(i, i)]
        for j in range(i - 1, start - 1, -1):
            W[(i, j)] = -sum(L[(i, k)] * W[(k, j)] for k in range(j, i)) * W[(i, i)]
    return W


def gram_of_inverse(W: dict, m: int, idx: list[int]) -> Sym:
    """``(W^T W)[idx, idx]``, W lower triangular: ``sum_k W_ka W_kb`` over k >= max(a, b)."""
    out: Sym = {}
    for ia, a in enumerate(idx):
        for b in idx[ia:]:
            out[(a, b)] = sum(W[(k, a)] * W[(k, b)] for k in range(max(a, b), m))
    return out


def damped_inverse_entries(S: Sym, m: int, translational_only: bool = False) -> tuple[Sym, int]:
    """Entries of ``(C + diag(e))^-1`` (or of its translational 3x3 block for m = 6), and their size."""
    order = CHOLESKY_ORDER[m]
    L, _ = damped_cholesky(S, order)
    if m == 6 and translational_only:
        W = tri_inverse(L, 6, start=3)
        K = gram_of_inverse(W, 6, [3, 4, 5])
        return {(a - 3, b - 3): v for (a, b), v in K.items()}, 3
    W = tri_inverse(L, m)
    Kp = gram_of_inverse(W, m, list(range(m)))
    pos = {row: i for i, row in enumerate(order)}  # original row -> permuted position
    return {(a, b): _g(Kp, pos[a], pos[b]) for a in range(m) for b in range(a, m)}, m


def damped_inverse_primal(C: jax.Array, translational_only: bool) -> jax.Array:
    """:func:`damped_inverse` without its custom JVP (for callers that do not differentiate)."""
    m = C.shape[-1]
    return sym_to_array(*damped_inverse_entries(sym_entries(C), m, translational_only))


@functools.partial(jax.custom_jvp, nondiff_argnums=(1,))
def damped_inverse(C: jax.Array, translational_only: bool = False) -> jax.Array:
    """``(C + diag(e))^-1`` (or its top-left 3x3 block) of a compliance ``C`` (..., m, m).

    The JVP is that of the matrix inverse, ``dK = -K dC K`` (``-P^T dC P`` with ``P = K[:, :3]``
    for the block), with the damping ``e`` held constant: exact wherever the damping is zero
    (every well-conditioned posture), finite everywhere, and cheaper in reverse mode than
    differentiating through the unrolled factorisation.
    """
    return damped_inverse_primal(C, translational_only)


@damped_inverse.defjvp
def _damped_inverse_jvp(translational_only: bool, primals: tuple[jax.Array], tangents: tuple[jax.Array]):
    (C,), (dC,) = primals, tangents
    K = damped_inverse_primal(C, False)
    dC = 0.5 * (dC + jnp.swapaxes(dC, -1, -2))
    if translational_only:
        P = K[..., :, :3]
        return K[..., :3, :3], -mm(mm(jnp.swapaxes(P, -1, -2), dC), P)
    return K, -mm(mm(K, dC), K)
