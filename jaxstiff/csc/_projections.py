"""The CSC step's projections: the damped pseudo-inverse ``J+`` (S1-16) and ``I - J+ J`` (S1-14).

For the free-joint task Jacobian ``J`` (m, n; locked and frozen joints' columns zeroed):

.. code-block:: text

    J+    = J^T (J J^T + lam^2 I)^-1                   (S1-16, damped near singularities)
    dq_P  = J+ dx                                      (S1-13, particular solution)
    dq_N  = (I - J+ J) v                               (S1-14, S1-15; v = grad u, S1-20)

**Damping rule** (the seed leaves it open; SPEC section 6). With ``A = J J^T`` (m x m), the
isotropy ``nu = det A / (tr A / m)^m`` is in [0, 1]: 1 for an isotropic Jacobian, 0 at a
singularity, scale-free (for m = 2 it is about ``4 sigma_min^2 / sigma_max^2`` near a
singularity). It is a product of m ratios, so it is compared with ``nu_th = nu0^(m/2)`` (1e-2 for
m = 2, 1e-3 for m = 3, 1e-6 for m = 6 with the default ``nu0 = 1e-2``; for the 6-row task this
also allows for rows in m/rad next to rows in rad/rad). Below ``nu_th`` the damping
``lam^2 = damping^2 * (tr A / m) * (1 - nu / nu_th)^2`` switches on (a Nakamura-Hanafusa style
rule, made scale-free by ``tr A / m``); above it ``lam = 0`` and ``J+`` is the exact
Moore-Penrose inverse (S1-16). ``lam^2`` and its first derivative are continuous at ``nu_th``.
Status bit :data:`~jaxstiff.csc.STATUS_DAMPED` marks the steps where it is active. While damped,
``I - J+ J`` is no longer an exact projector; the closed loop pulls the TCP back.
"""

from __future__ import annotations

from typing import Any, NamedTuple, TypeAlias

import jax
import jax.numpy as jnp

from jaxstiff._numerics.linalg import mm
from jaxstiff.csc._algebra import det_cofactors, det_small, mtv, mv, outer, spd_inverse, spd_inverse_primal

__all__ = ["Damping", "damping_rule", "damped_inverse", "projections_forward", "projections_vjp"]

Scalar: TypeAlias = jax.typing.ArrayLike  #: a scalar setting (a float or a traced 0-d array)


def damped_pinv(Jf: jax.Array, nu0: Scalar, damping: Scalar) -> tuple[jax.Array, jax.Array, jax.Array]:
    """Damped pseudo-inverse of the free-joint task Jacobian (m, n) -> (J+ (n, m), nu, damped)."""
    Ainv, nu, damped = damped_inverse(Jf, nu0, damping)
    Jp = jnp.sum(Jf[..., :, :, None] * Ainv[..., :, None, :], axis=-3)  # J^T A^-1, (n, m)
    return Jp, nu, damped


def damped_inverse(Jf: jax.Array, nu0: Scalar, damping: Scalar) -> tuple[jax.Array, jax.Array, jax.Array]:
    """``(J J^T + lam^2 I)^-1`` (m, m) of the damping rule (module docstring), isotropy nu, damped flag."""
    d = damping_rule(Jf, nu0, damping)
    return spd_inverse(d.A), d.nu, d.damped


class Damping(NamedTuple):
    """The damping rule term by term (module docstring): what the projections' VJP needs."""

    A0: jax.Array  # J J^T
    A: jax.Array  # J J^T + lam^2 I (I where J = 0)
    scale: jax.Array  # tr(J J^T) / m
    safe_scale: jax.Array
    pos: jax.Array  # scale > 0
    nu_raw: jax.Array  # det(J J^T) / scale^m
    nu: jax.Array  # the isotropy, in [0, 1]
    thr: jax.Array  # nu0^(m/2)
    damped: jax.Array  # nu < thr
    t: jax.Array  # 1 - nu / thr
    w: jax.Array  # t^2 where damped, else 0: lam^2 = damping^2 scale w


def isotropy_threshold(nu0: Scalar, m: int) -> Any:
    """``nu_th = nu0^(m/2)``: nu0 for m = 2, nu0^1.5 for m = 3, nu0^3 for m = 6 (module docstring)."""
    return nu0 ** (m / 2.0)


def damping_rule(Jf: jax.Array, nu0: Scalar, damping: Scalar) -> Damping:
    """The damping rule of the module docstring for a task Jacobian Jf (m, n), term by term."""
    m = Jf.shape[-2]
    A0 = jnp.sum(Jf[..., :, None, :] * Jf[..., None, :, :], axis=-1)  # J J^T
    scale = jnp.trace(A0, axis1=-2, axis2=-1) / m
    pos = scale > 0
    safe_scale = jnp.where(pos, scale, 1.0)
    nu_raw = det_small(A0) / safe_scale**m
    nu = jnp.where(pos, jnp.clip(nu_raw, 0.0, 1.0), 0.0)
    thr = isotropy_threshold(nu0, m)
    damped = nu < thr
    t = 1.0 - nu / thr
    w = jnp.where(damped, t * t, 0.0)
    lam2 = damping**2 * scale * w + jnp.finfo(Jf.dtype).tiny * 1e3
    eye = jnp.eye(m, dtype=Jf.dtype)
    # J = 0 (every joint frozen): any A gives J+ = 0; I keeps the inverse finite (tiny I underflows)
    A = jnp.where(pos[..., None, None], A0 + lam2[..., None, None] * eye, eye)
    return Damping(A0, A, scale, safe_scale, pos, nu_raw, nu, thr, damped, t, w)


def _damped_projections(Jf: jax.Array, dx: jax.Array, vs: tuple, nu0: Scalar, damping: Scalar) -> tuple:
    """``(J+ dx, tuple((I - J+ J) v for v in vs), nu)`` with ``J+ = J^T (J J^T + lam^2 I)^-1`` of the
    damping rule (module docstring; :func:`damped_inverse` gives the same ``(J J^T + lam^2 I)^-1``)
    and the isotropy ``nu``, for the free-joint task Jacobian ``Jf`` (m, n), dx (m,), vs of (n,).

    The core of a CSC step, with a hand-written VJP (:func:`projections_vjp`): with the
    forward's ``y = A^-1 dx`` and ``z = A^-1 J v`` (``A = J J^T + lam^2 I``), the cotangents
    ``dqP_b``, ``Pv_b`` give ``dx_b = A^-1 J dqP_b``, ``r_b = -A^-1 J Pv_b``, ``v_b = Pv_b + J^T r_b``,
    ``A_b = -dx_b y^T - sum r_b z^T`` (no matrix product: ``A^-1`` is symmetric), and
    ``J_b = y dqP_b^T + sum (r_b v^T - z Pv_b^T) + (A0_b + A0_b^T) J`` where ``A0_b`` adds to
    ``A_b`` the damping rule's chain (``lam^2`` through ``tr A0 / m`` and ``nu = det A0 / (tr A0 /
    m)^m``, the determinant's cofactors; zero while undamped). It is installed, like
    :func:`offdiag_value_and_grad`'s, as a custom JVP that is its transpose, so forward mode keeps
    working and reverse mode runs the VJP's own arithmetic (fewer, larger kernels than the
    transpose of the forward formulas).
    """
    dqP, Pvs, nu, _ = projections_forward(Jf, dx, vs, nu0, damping)
    return dqP, Pvs, nu


def projections_forward(Jf: jax.Array, dx: jax.Array, vs: tuple, nu0: Scalar, damping: Scalar) -> tuple:
    """``(dq_P, Pvs, nu, residuals)``: the forward formulas of :func:`damped_projections`."""
    d = damping_rule(Jf, nu0, damping)
    cof = det_cofactors(d.A0)[1] if Jf.shape[-2] in (2, 3) else None  # d det / dA0 (XLA shares it with det)
    Ainv = spd_inverse_primal(d.A)
    y = mv(Ainv, dx)
    dqP = mtv(Jf, y)
    zs = tuple(mv(Ainv, mv(Jf, v)) for v in vs)
    Pvs = tuple(v - mtv(Jf, z) for v, z in zip(vs, zs, strict=True))
    return dqP, Pvs, d.nu, (Jf, d, cof, Ainv, y, zs, vs, nu0, damping)


def projections_vjp(res: tuple, cts: tuple) -> tuple:
    """VJP of :func:`damped_projections` w.r.t. ``(Jf, dx, vs, nu0, damping)`` (derivation there)."""
    Jf, d, cof, Ainv, y, zs, vs, nu0, damping = res
    A0, scale, safe_scale, pos, nu_raw, nu, damped, t, w, thr = (
        d.A0,
        d.scale,
        d.safe_scale,
        d.pos,
        d.nu_raw,
        d.nu,
        d.damped,
        d.t,
        d.w,
        d.thr,
    )
    dqP_b, Pv_bs, nu_b = cts
    m = Jf.shape[-2]
    dx_b = mv(Ainv, mv(Jf, dqP_b))
    J_b = outer(y, dqP_b)
    A_b = -outer(dx_b, y)
    vs_b = []
    for v, z, Pv_b in zip(vs, zs, Pv_bs, strict=True):
        r_b = -mv(Ainv, mv(Jf, Pv_b))
        J_b = J_b + outer(r_b, v) - outer(z, Pv_b)
        A_b = A_b - outer(r_b, z)
        vs_b.append(Pv_b + mtv(Jf, r_b))
    # A = A0 + lam2 I, lam2 = damping^2 scale w (+ tiny), w = t^2 (damped), t = 1 - nu / thr
    lam2_b = jnp.trace(A_b, axis1=-2, axis2=-1)
    damping_b = lam2_b * 2.0 * damping * scale * w
    scale_b = lam2_b * damping**2 * w
    t_b = jnp.where(damped, 2.0 * t * lam2_b * damping**2 * scale, 0.0)
    nu_b = nu_b - t_b / thr
    thr_b = t_b * nu / (thr * thr)
    nu0_b = thr_b * (m / 2.0) * nu0 ** (m / 2.0 - 1.0)
    # nu = clip(det / scale^m, 0, 1) where scale > 0
    nr_b = jnp.where(pos & (nu_raw > 0) & (nu_raw < 1), nu_b, 0.0)
    det_b = nr_b / safe_scale**m
    scale_b = scale_b - m * nr_b * nu_raw / safe_scale
    if cof is not None:
        det_grad = det_b[..., None, None] * cof
    else:
        det_grad = jax.vjp(jnp.linalg.det, A0)[1](det_b)[0]
    A0_b = A_b + det_grad + (scale_b / m)[..., None, None] * jnp.eye(m, dtype=A0.dtype)
    J_b = J_b + mm(A0_b + jnp.swapaxes(A0_b, -1, -2), Jf)
    return J_b, dx_b, tuple(vs_b), nu0_b, damping_b


damped_projections = jax.custom_jvp(_damped_projections)


@damped_projections.defjvp
def _damped_projections_jvp(primals: tuple, tangents: tuple) -> tuple:
    """Forward mode as the transpose of :func:`projections_vjp` (see :func:`_offdiag_jvp`)."""
    dqP, Pvs, nu, res = projections_forward(*primals)
    lin = jax.linear_transpose(lambda *cts: projections_vjp(res, cts), dqP, Pvs, nu)
    return (dqP, Pvs, nu), lin(tuple(tangents))
