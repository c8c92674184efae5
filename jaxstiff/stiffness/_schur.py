"""Translational compliance and stiffness in compliance form, correct at singular postures.

The translational compliance ``S`` (SPEC section 2) is well defined and positive semi-definite at
every posture, singular ones included:

* ``"xy"``/``"xyz"``: ``S = C``, the task compliance ``J_s K_j^-1 J_s^T`` itself;
* ``"full"``: ``S = C_TT - C_TR C_RR^-1 C_RT``, the Schur complement that makes ``S^-1`` the
  top-left block ``K_TT`` of ``K_C = C^-1`` (S0-6, S0-7). ``C_RR^-1`` comes from the unrolled
  Cholesky factorisation of the 3x3 rotational block (:func:`jaxstiff._numerics.cholesky.damped_cholesky`,
  whose damping is zero unless the spring joints' axes cannot turn the tool about some axis).

At a singular posture ``S`` loses rank: the stiffness along the lost direction is infinite and
the others are the inverses of the eigenvalues of ``S`` on its range. Inverting ``S`` (or ``C``)
with a damping on the pivots of a factorisation (an earlier version did) mixes the lost direction
with the others: the minor axes came out wrong (114 N/m instead of 37), changed with the batch
size (rounding of ``C`` at 1e-17 was amplified by a 1e-18 pivot) and could even turn negative.
Here the damping acts on the eigenvalues of ``S`` instead, so no rounding is amplified:

``K_T = V diag(1 / h(mu)) V^T``, ``S = V diag(mu) V^T``, ``h(mu) = mu + a exp(-mu / a)``,
``a = delta * trace(S) / t`` (``t`` = 2 or 3; ``delta`` = 1e-8 in float64, 1e-4 in float32; plus
``delta^2 trace(C_TT) / t``, which matters only where S vanishes altogether).

``h(mu) = mu`` to the last bit for ``mu > 40 a`` (``exp(-40) / 40 < 1e-19``): every axis whose
compliance is more than ``40 delta`` times the mean is exact; a lost direction (``mu = 0``) gets
the finite stiffness ``1 / a`` (about ``1e8`` times the mean stiffness in float64), and ``h`` is
smooth and increasing, ``h >= a > 0``, so ``K_T`` is symmetric positive definite with a condition
number below ``t / delta`` (the ellipsoid's eigen-decomposition then keeps the other axes to
~1e-8 relative). :func:`translational_axes` reports the axes themselves without any damping:
``1 / mu``, and ``+inf`` (a rigid direction) where ``mu <= a``.

Derivatives: the JVP of ``K_T`` is exact everywhere (no damping held fixed): with
``dS = P dC P^T`` (``P = [I, -C_TR C_RR^-1]`` for ``"full"``, ``I`` otherwise) it is the
Daleckii-Krein formula ``dK = V (F o (V^T dS V)) V^T`` plus the term of ``a``'s dependence on
``trace(S)``, ``F_ij`` the divided differences of ``1 / h``, finite also at repeated
eigenvalues (a sphere). Where every ``mu > 40 a`` it equals ``-K dS K``.
"""

from __future__ import annotations

from collections.abc import Callable

import jax
import jax.numpy as jnp

from jaxstiff._numerics.cholesky import damped_cholesky, sym_entries, sym_to_array, tri_inverse
from jaxstiff._numerics.eig import eigh_descending, eigh_descending_primal, gap_tol
from jaxstiff._numerics.linalg import mm

__all__ = ["lost_axis_floor", "floor_of"]

_EXP_CAP = 50.0  # exp(-mu/a) is only ever evaluated for -mu/a <= 50 (mu >= -50 a: rounding only)


def lost_axis_floor(dtype: jnp.dtype) -> float:
    """Relative floor ``delta`` of the eigenvalues of ``S`` (1e-8 in float64, 1e-4 in float32)."""
    return 1e-8 if jnp.finfo(dtype).bits >= 64 else 1e-4


def schur_compliance(C: jax.Array) -> tuple[jax.Array, jax.Array | None]:
    """Translational compliance ``S`` (..., t, t) of a task compliance ``C`` (..., m, m).

    Returns:
        ``(S, G)``: for m = 6 the Schur complement ``C_TT - C_TR C_RR^-1 C_RT`` (exactly
        symmetric) and ``G = C_TR C_RR^-1`` (..., 3, 3); for m = 2 or 3, ``(C, None)``.
    """
    m = C.shape[-1]
    if m != 6:
        return C, None
    E = sym_entries(C)
    R = {(i, j): E[(i + 3, j + 3)] for i in range(3) for j in range(i, 3)}
    L, _ = damped_cholesky(R, (0, 1, 2))
    W = tri_inverse(L, 3)  # L_R^-1, lower triangular
    # X = L_R^-1 C_RT, so that C_TR C_RR^-1 C_RT = X^T X
    X = {(i, b): sum(W[(i, k)] * E[(b, 3 + k)] for k in range(i + 1)) for i in range(3) for b in range(3)}
    S = {(a, b): E[(a, b)] - sum(X[(i, a)] * X[(i, b)] for i in range(3)) for a in range(3) for b in range(a, 3)}
    # G = X^T L_R^-1: G[a, k] = sum_{i >= k} X[i, a] W[i, k]
    G = jnp.stack(
        [jnp.stack([sum(X[(i, a)] * W[(i, k)] for i in range(k, 3)) for k in range(3)], axis=-1) for a in range(3)],
        axis=-2,
    )
    return sym_to_array(S, 3), G


def floor_of(S: jax.Array, C: jax.Array) -> jax.Array:
    """The absolute floor ``a`` (...,) of the eigenvalues of ``S`` (> 0):
    ``delta (trace(S) + delta trace(C_TT)) / t``; the second term keeps ``a`` at the scale of ``C``
    when ``S`` vanishes altogether (every translation lost), where ``trace(S)`` is rounding."""
    t = S.shape[-1]
    delta = lost_axis_floor(S.dtype)
    tr = sum(S[..., i, i] for i in range(t)) + delta * sum(C[..., i, i] for i in range(t))
    return delta * jnp.maximum(tr, 0.0) / t + jnp.sqrt(jnp.finfo(S.dtype).tiny)


def _exp_neg(mu: jax.Array, a: jax.Array) -> jax.Array:
    return jnp.exp(jnp.minimum(-mu / a, _EXP_CAP))


def _outer_sum(V: jax.Array, k: jax.Array) -> jax.Array:
    """``V diag(k) V^T`` (..., t, t), exactly symmetric."""
    t = V.shape[-1]
    entries = {
        (i, j): sum(V[..., i, c] * V[..., j, c] * k[..., c] for c in range(t)) for i in range(t) for j in range(i, t)
    }
    return sym_to_array(entries, t)


def _decompose(C: jax.Array):
    S, G = schur_compliance(C)
    mu, V = eigh_descending_primal(S)
    a = floor_of(S, C)[..., None]
    h = mu + a * _exp_neg(mu, a)
    return S, G, mu, V, a, h


@jax.custom_jvp
def stiffness_of_compliance(C: jax.Array) -> jax.Array:
    """Translational stiffness ``K_T`` (..., t, t) from the task compliance ``C`` (..., m, m).

    ``V diag(1 / h(mu)) V^T`` of the translational compliance ``S = V diag(mu) V^T``
    (:func:`schur_compliance`), with the eigenvalue floor of the module docstring: exact where
    every ``mu > 40 a``, symmetric positive definite and finite everywhere; the lost direction of
    a singular posture gets the stiffness ``1 / a``. The JVP is exact (Daleckii-Krein).
    """
    _, _, _, V, _, h = _decompose(C)
    return _outer_sum(V, 1.0 / h)


def _jvp_inputs(primals: tuple, tangents: tuple):
    """``(mu, V, a, h, dS, diag_dC)`` of a JVP rule on C: the decomposition of S, the tangent of S and
    the diagonal of the tangent of C_TT."""
    (C,), (dC,) = primals, tangents
    S, G, mu, V, a, h = _decompose(C)
    dC, dS = _tangent_of_S(C, G, dC)
    return mu, V, a, h, dS, jnp.diagonal(dC, axis1=-2, axis2=-1)[..., : S.shape[-1]]


@stiffness_of_compliance.defjvp
def _stiffness_of_compliance_jvp(primals: tuple, tangents: tuple):
    mu, V, a, h, dS, diag_dC = _jvp_inputs(primals, tangents)
    return _outer_sum(V, 1.0 / h), _stiffness_tangent(mu, V, a, h, dS, jnp.sum(diag_dC, axis=-1))


def _stiffness_tangent(mu, V, a, h, dS: jax.Array, tr_dC: jax.Array) -> jax.Array:
    """``dK_T`` (..., t, t) for the tangent ``dS`` of S and the trace of the tangent of C_TT
    (Daleckii-Krein with the divided differences of 1/h, plus the floor's dependence on traces)."""
    t = mu.shape[-1]
    Vt = jnp.swapaxes(V, -1, -2)
    A = mm(mm(Vt, dS), V)
    # divided differences of h: (h_i - h_j) / (mu_i - mu_j) = 1 - e^(-lo/a) (1 - e^(-d)) / d, d = (hi - lo) / a
    lo = jnp.minimum(mu[..., :, None], mu[..., None, :])
    d = jnp.abs(mu[..., :, None] - mu[..., None, :]) / a[..., None]
    pos = d > 0
    phi = jnp.where(pos, -jnp.expm1(-d) / jnp.where(pos, d, 1.0), 1.0)
    Dh = 1.0 - _exp_neg(lo, a[..., None]) * phi
    F = -Dh / (h[..., :, None] * h[..., None, :])
    # a = delta (trace(S) + delta trace(C_TT)) / t: dh/da = e^(-mu/a) (1 + mu/a)
    delta = lost_axis_floor(mu.dtype)
    da = delta * (jnp.sum(jnp.diagonal(dS, axis1=-2, axis2=-1), axis=-1) + delta * tr_dC) / t
    dk = -(_exp_neg(mu, a) * (1.0 + mu / a)) / (h * h) * da[..., None]
    inner = F * A + dk[..., :, None] * jnp.eye(t, dtype=A.dtype)
    dK = mm(mm(V, inner), Vt)
    return 0.5 * (dK + jnp.swapaxes(dK, -1, -2))


def stiffness_and_tangents(
    C: jax.Array, tangents_of: Callable[[jax.Array | None], tuple[jax.Array, jax.Array]]
) -> tuple[jax.Array, jax.Array]:
    """``K_T`` (t, t) of one compliance C (m, m) and its tangents (T, t, t): the JVP of
    :func:`stiffness_of_compliance` for callers that form the tangents of S more cheaply than
    ``P dC P^T`` (pgd's LM stage: from ``P J`` and ``P dJ``). ``tangents_of(G)`` gets
    ``G = C_TR C_RR^-1`` (None for m = 2 or 3; ``P = [I, -G]``) and returns the tangents of S
    (T, t, t), symmetric, and of trace(C_TT) (T,). One decomposition for all T tangents."""
    _, G, mu, V, a, h = _decompose(C)
    dS, tr_dC = tangents_of(G)
    dK = jax.vmap(lambda dS1, tr1: _stiffness_tangent(mu, V, a, h, dS1, tr1))(dS, tr_dC)
    return _outer_sum(V, 1.0 / h), dK


def _tangent_of_S(C: jax.Array, G: jax.Array | None, dC: jax.Array) -> tuple[jax.Array, jax.Array]:
    """``(dC sym, dS)``: the symmetric tangent of C and the tangent of S (``P dC P^T`` for full)."""
    dC = 0.5 * (dC + jnp.swapaxes(dC, -1, -2))
    if G is None:
        return dC, dC
    P = jnp.concatenate([jnp.broadcast_to(jnp.eye(3, dtype=G.dtype), G.shape), -G], axis=-1)  # (..., 3, 6)
    return dC, mm(mm(P, dC), jnp.swapaxes(P, -1, -2))


@jax.custom_jvp
def stiffness_eig_of_compliance(C: jax.Array) -> tuple[jax.Array, jax.Array]:
    """Eigen-decomposition of ``K_T = stiffness_of_compliance(C)`` without forming ``K_T``.

    Returns ``(lam, V)``: the eigenvalues ``1 / h(mu)`` (..., t), descending (N/m), and their unit
    eigenvectors (..., t, t) as columns, which are those of ``S`` (``mu`` ascending). One
    eigen-decomposition (of ``S``) instead of two (``S``, then ``K_T`` in :func:`jaxstiff.ellipsoid`):
    the solvers' criterion f1/f2 reads its axes and major direction from here. The JVP is the
    first-order perturbation of ``S``'s eigenpairs (``dS = P dC P^T``), with the eigenvector
    coupling of eigenvalues closer than the relative gap tolerance of
    :func:`jaxstiff._numerics.eig.eigh_descending` dropped (there the directions are not defined).
    """
    _, _, _, V, _, h = _decompose(C)
    return (1.0 / h)[..., ::-1], V[..., :, ::-1]


@stiffness_eig_of_compliance.defjvp
def _stiffness_eig_of_compliance_jvp(primals: tuple, tangents: tuple):
    mu, V, a, h, dS, diag_dC = _jvp_inputs(primals, tangents)
    t = mu.shape[-1]
    A = mm(mm(jnp.swapaxes(V, -1, -2), dS), V)  # V^T dS V
    dmu = jnp.diagonal(A, axis1=-2, axis2=-1)
    delta = lost_axis_floor(mu.dtype)
    da = (delta * jnp.sum(dmu + delta * diag_dC, axis=-1) / t)[..., None]  # trace(dS) = sum(dmu)
    e = _exp_neg(mu, a)
    dh = (1.0 - e) * dmu + e * (1.0 + mu / a) * da
    dlam = -dh / (h * h)
    gap = mu[..., None, :] - mu[..., :, None]  # gap[i, j] = mu_j - mu_i
    scale = jnp.max(jnp.abs(mu), axis=-1)[..., None, None]
    ok = jnp.abs(gap) > gap_tol(mu.dtype) * scale + jnp.finfo(mu.dtype).tiny
    dV = mm(V, jnp.where(ok, 1.0 / jnp.where(ok, gap, 1.0), 0.0) * A)
    return ((1.0 / h)[..., ::-1], V[..., :, ::-1]), (dlam[..., ::-1], dV[..., :, ::-1])


def axes_of_compliance(C: jax.Array) -> tuple[jax.Array, jax.Array]:
    """Stiffness axes (..., t), descending, and their unit directions (..., t, t) as columns.

    The axes are ``1 / mu`` for the eigenvalues ``mu`` of ``S`` (:func:`schur_compliance`), without
    any damping, and ``+inf`` (a rigid direction: the posture is singular for the task) where
    ``mu <= a = delta * trace(S) / t``. Derivatives are finite (zero for an infinite axis).
    """
    S, _ = schur_compliance(C)
    mu, V = eigh_descending(S)
    a = jax.lax.stop_gradient(floor_of(S, C))[..., None]
    ok = mu > a
    axes = jnp.where(ok, 1.0 / jnp.where(ok, mu, 1.0), jnp.inf)
    return axes[..., ::-1], V[..., :, ::-1]
