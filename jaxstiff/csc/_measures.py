"""What a rollout reports of a posture: the realised stiffness and the tracking errors.

**Realised stiffness** (SPEC section 6). ``kj = clip(diag(J^T K_xd J), kmin, kmax)`` (the
uni-articular part of S1-8), ``K_C = (J diag(1/kj) J^T)^-1`` (S0-4,
:func:`jaxstiff.cartesian_stiffness`), and ``|K_xd - K_C|_F`` (S1-10). Default actuator range
``[1, inf)`` Nm/rad (:class:`~jaxstiff.settings.CSCSettings`). ``J`` here is the stiffness's task
Jacobian: with rigid locked joints (the default) their columns are zeroed, so they add no
compliance (the step then reports their ``kj`` as 0); with ``locked_joints="spring"`` every column.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp

from jaxstiff._numerics.linalg import mm
from jaxstiff._numerics.safe import safe_sqrt
from jaxstiff.csc._algebra import vector_norm
from jaxstiff.csc._pose import orientation_angle
from jaxstiff.stiffness._core import cartesian_stiffness

__all__ = ["realised_forward", "realised_vjp"]


def _realised_stiffness(J: jax.Array, kj: jax.Array, K_xd: jax.Array, task: str) -> tuple[jax.Array, jax.Array]:
    """``K_C = cartesian_stiffness(J, kj, task)`` (m, m) and ``|K_xd - K_C|_F`` (S1-10).

    With a hand-written VJP (:func:`realised_vjp`; :func:`cartesian_stiffness`'s JVP rule
    ``dK_C = -K_C dC K_C``, damping held, and ``C = J diag(1/kj) J^T``): with ``E = K_xd - K_C``,
    ``E_b = f_b E / |E|_F``, ``S = sym(KC_b - E_b)`` and ``C_b = -K_C S K_C``, the cotangents are
    ``J_b = 2 C_b J diag(1/kj)``, ``kj_b = -diag(J^T C_b J) / kj^2`` and ``K_xd_b = E_b``: four
    small products instead of the transpose of the factorisation's JVP and of the compliance's
    entry-wise rows. Installed as a custom JVP that is its transpose (see :func:`_offdiag_jvp`).
    """
    K_C, frob, _ = realised_forward(J, kj, K_xd, task)
    return K_C, frob


def realised_forward(J: jax.Array, kj: jax.Array, K_xd: jax.Array, task: str) -> tuple:
    """``(K_C, frobenius, residuals)``: the forward formulas of :func:`realised_stiffness`."""
    K_C = cartesian_stiffness(J, kj, task)
    E = K_xd - K_C
    frob = safe_sqrt(jnp.sum(E * E, axis=(-2, -1)))  # as criteria.frobenius
    floor = jnp.sqrt(jnp.finfo(J.dtype).tiny)  # compliance's floor of kj (stiffness._joint_stiffness_array)
    return K_C, frob, (J, jnp.maximum(kj, floor), kj > floor, K_C, E, frob > 0, frob)


def realised_vjp(task: str, res: tuple, cts: tuple) -> tuple:
    """VJP of :func:`realised_stiffness` w.r.t. ``(J, kj, K_xd)`` (derivation there)."""
    J, kj, kj_free, K_C, E, pos, frob = res
    KC_b, f_b = cts
    E_b = (jnp.where(pos, f_b / jnp.where(pos, frob, 1.0), 0.0))[..., None, None] * E
    S = KC_b - E_b
    S = 0.5 * (S + jnp.swapaxes(S, -1, -2))
    CbJ = -mm(mm(K_C, S), mm(K_C, J))  # C_b J, C_b = -K_C S K_C (symmetric)
    inv_kj = 1.0 / kj
    J_b = 2.0 * CbJ * inv_kj[..., None, :]
    kj_b = jnp.where(kj_free, -jnp.sum(J * CbJ, axis=-2) * inv_kj * inv_kj, 0.0)
    return J_b, kj_b, E_b


realised_stiffness = jax.custom_jvp(_realised_stiffness, nondiff_argnums=(3,))


@realised_stiffness.defjvp
def _realised_jvp(task: str, primals: tuple, tangents: tuple) -> tuple:
    J, kj, K_xd = primals
    K_C, frob, res = realised_forward(J, kj, K_xd, task)
    lin = jax.linear_transpose(lambda a, b: realised_vjp(task, res, (a, b)), K_C, frob)
    return (K_C, frob), lin(tuple(tangents))


def posture_measures(
    J: jax.Array,
    K: jax.Array,
    p: jax.Array,
    R: jax.Array | None,
    target: jax.Array,
    *,
    kmin: jax.Array,
    kmax: jax.Array,
    task: str,
    R_hold: jax.Array | None,
) -> tuple:
    """``(kj (n,), K_C (m, m), |K_xd - K_C|_F, tracking error (m), orientation error (rad))`` of one posture.

    Args:
        J: (m, n) task rows of the Jacobian (every joint), K: (m, m) ``K_xd``, N/m.
        p: (d,) task position, m; R: (3, 3) tool rotation (task ``"full"``, else None); target (d,), m.
        kmin, kmax: actuator range, Nm/rad. task: the task. R_hold: the held rotation (task ``"full"``).
    """
    kj = jnp.sum(J * mm(K, J), axis=-2)  # diag(J^T K J)
    kj = jnp.clip(kj, kmin, kmax)
    K_C, frob = realised_stiffness(J, kj, K, task)
    err = vector_norm(target - p)
    oerr = orientation_angle(R, R_hold) if task == "full" else jnp.zeros((), p.dtype)  # type: ignore[arg-type]
    return kj, K_C, frob, err, oerr
