"""Shaping criteria (seed 000 section IV, seed 001 eq. 10 and 19). All jit-able and vmappable.

* :func:`f1` (S0-9), "at least ratio r, aligned": ``(|alpha| + c) / (min(rho, r) / r)``;
  minimum set alpha = 0 and any rho >= r (value c there).
* :func:`f2` (S0-15), "exactly ratio r, aligned": ``(1 + |alpha|) (1 + |r - rho|)``; unique
  minimum alpha = 0, rho = r (value 1 there).
* :func:`frobenius` (S1-10): ``||K_d - K_C||_F``.
* :func:`offdiag` (S1-19): ``u = sqrt(sum_{i<j} (J^T K_xd J)_ij^2)``.

alpha is in degrees inside f1 and f2, as in the seed; rho = lambda1 / lambda2 >= 1.

Gradients. f1 and f2 are built from :func:`jaxstiff.ellipsoid.eigh_descending` (exact eigenvalue
derivatives everywhere, exact eigenvector derivatives wherever lambda1 > lambda2, finite at
spheres) and an ``atan2`` orientation error (finite gradient at alpha = 0). Their kinks,
``|r - rho|`` at rho = r, ``min(rho, r)`` at rho = r and ``|alpha|`` at alpha = 0, get a
finite one-sided / averaged derivative (JAX's convention for ``abs`` and ``minimum``), which is
a valid subgradient. Values and gradients are finite for every SPD K (rho is capped at 1/eps,
see :func:`jaxstiff.ellipsoid.safe_ratio`).

Your own criterion. Any JAX-traceable function ``crit(K, d, r, c=0.01) -> (...,)`` of the
translational stiffness ``K`` (..., m, m) (N/m), the desired direction ``d`` (..., m) and the
ratio ``r`` (``c`` the seed's f1 offset; ignore it if you do not need it) can be passed wherever
a criterion name is accepted (``shape(..., criterion=my_crit)``), or registered by name with
:func:`register_criterion`. A function without a ``c`` parameter is accepted too
(:func:`get_criterion` wraps it). Keep it finite for every SPD K: build it from
:func:`alpha_and_ratio` / :func:`jaxstiff.ellipsoid`, which are gradient-safe.

Example:
    >>> import jax.numpy as jnp, jaxstiff
    >>> K = jnp.diag(jnp.array([5.0, 1.0]))
    >>> float(jaxstiff.f2(K, jnp.array([1.0, 0.0]), 5.0))
    1.0
    >>> def volume_and_f2(K, d, r, c=0.01):  # a user criterion: f2 plus a size penalty
    ...     return jaxstiff.f2(K, d, r) + 1e-6 * jnp.linalg.det(K)
    >>> jaxstiff.register_criterion("f2_small", volume_and_f2, overwrite=True)
"""

from __future__ import annotations

import functools
import inspect
import math
from collections.abc import Callable
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np
from numpy.typing import ArrayLike

from jaxstiff._numerics.batch import broadcast_batch, check_square, known_floats
from jaxstiff._numerics.eig import eigh_descending
from jaxstiff._numerics.safe import safe_ratio, safe_sqrt
from jaxstiff.stiffness._ellipsoid import alpha_rad, check_direction, refuse_indefinite

__all__ = ["f1", "f2", "frobenius", "offdiag", "get_criterion", "register_criterion"]

Criterion = Callable[..., jax.Array]


def alpha_and_ratio(K: jax.Array, d: jax.Array) -> tuple[jax.Array, jax.Array]:
    """Orientation error alpha (degrees, [0, 90]) and axis ratio rho (>= 1) of K, one decomposition.

    Args:
        K: translational stiffness (..., m, m), m = 2 or 3.
        d: desired direction (..., m) (any length, sign-free).

    Returns:
        ``(alpha, rho)``, each (...,), dtype of K.
    """
    K = check_square(K)
    refuse_indefinite(K)
    return _alpha_and_ratio(K, check_direction(K, d))


@jax.jit
def _alpha_and_ratio(K: jax.Array, d: jax.Array) -> tuple[jax.Array, jax.Array]:
    w, V = eigh_descending(K)
    return alpha_and_ratio_of_eig(w, V, d)


def alpha_and_ratio_of_eig(w: jax.Array, V: jax.Array, d: jax.Array) -> tuple[jax.Array, jax.Array]:
    """:func:`alpha_and_ratio` from K's eigenvalues ``w`` (..., m), descending, and unit eigenvectors
    ``V`` (..., m, m) as columns (traceable; no checks)."""
    alpha = alpha_rad(V[..., :, 0], d) * (180.0 / math.pi)
    return alpha, safe_ratio(w[..., 0], w[..., 1])


def f1_of(alpha: jax.Array, rho: jax.Array, r: ArrayLike, c: ArrayLike) -> jax.Array:
    """f1 (S0-9) from alpha (degrees) and rho: ``(alpha + c) r / min(rho, r)`` (traceable; no checks)."""
    r, c = jnp.asarray(r, dtype=alpha.dtype), jnp.asarray(c, dtype=alpha.dtype)
    return (alpha + c) * r / jnp.minimum(rho, r)


def f2_of(alpha: jax.Array, rho: jax.Array, r: ArrayLike) -> jax.Array:
    """f2 (S0-15) from alpha (degrees) and rho: ``(1 + alpha) (1 + |r - rho|)`` (traceable; no checks)."""
    r = jnp.asarray(r, dtype=alpha.dtype)
    return (1.0 + alpha) * (1.0 + jnp.abs(r - rho))


def _check_ratio(r: ArrayLike, K: jax.Array | None = None, d: jax.Array | None = None) -> None:
    """A known ``r`` (a number or an array, not a value inside a trace) must be finite and >= 1 everywhere
    and, with K and d given, broadcast against their batch axes."""
    a = known_floats(r, "ratio r")
    if a is None:
        return
    ok = np.isfinite(a) & (a >= 1.0)  # NaN and inf fail (an infinite ratio is no ellipsoid: f1, f2 gave inf)
    if not np.all(ok):
        bad = a if a.ndim == 0 else a[~ok].flat[0]
        where = "" if a.ndim == 0 else f" at index {tuple(int(i) for i in np.argwhere(~ok)[0])}"
        raise ValueError(f"ratio r must be finite and >= 1 (rho = lambda1 / lambda2 is >= 1), got {float(bad)}{where}")
    if K is not None and d is not None:
        broadcast_batch(("K", K.shape[:-2]), ("d", d.shape[:-1]), ("r", a.shape))


def _check_offset(c: ArrayLike) -> None:
    a = known_floats(c, "offset c")
    if a is not None and not np.all(a >= 0.0):
        raise ValueError(f"offset c must be >= 0 degrees (f1's minimum is at alpha = 0 only for c >= 0), got {c}")


def _inputs(K: ArrayLike, d: ArrayLike) -> tuple[jax.Array, jax.Array]:
    K = check_square(K)
    refuse_indefinite(K)  # the rule of ellipsoid(): an indefinite K has no major axis or ratio
    return K, check_direction(K, d)


@jax.jit
def _f1(K: jax.Array, d: jax.Array, r: ArrayLike, c: ArrayLike) -> jax.Array:
    alpha, rho = _alpha_and_ratio(K, d)
    return f1_of(alpha, rho, r, c)


@jax.jit
def _f2(K: jax.Array, d: jax.Array, r: ArrayLike) -> jax.Array:
    alpha, rho = _alpha_and_ratio(K, d)
    return f2_of(alpha, rho, r)


def f1(K: jax.Array, d: jax.Array, r: ArrayLike, c: float = 0.01) -> jax.Array:
    """Seed 000 criterion f1 (S0-9): ``(|alpha| + c) / (min(rho, r) / r)``, alpha in degrees.

    Minimum set: alpha = 0 and any rho >= r, where f1 = c.

    Args:
        K: translational stiffness (..., m, m), m = 2 or 3, N/m.
        d: desired direction (..., m).
        r: wanted minimum axis ratio (>= 1), scalar or (...,).
        c: offset (degrees) that keeps f1 sensitive to rho when alpha = 0 (seed: 0.01).

    Returns:
        (...,) dimensionless (degrees).
    """
    K, d = _inputs(K, d)
    _check_ratio(r, K, d)
    _check_offset(c)
    return _f1(K, d, r, c)


def f2(K: jax.Array, d: jax.Array, r: ArrayLike, c: float = 0.0) -> jax.Array:
    """Seed 000 criterion f2 (S0-15): ``(1 + |alpha|) (1 + |r - rho|)``, alpha in degrees.

    Unique minimum f2 = 1 at alpha = 0, rho = r. ``c`` is accepted and ignored so that f1, f2 and
    user criteria share one call signature.

    Args:
        K: translational stiffness (..., m, m), m = 2 or 3, N/m.
        d: desired direction (..., m).
        r: wanted axis ratio (>= 1), scalar or (...,).

    Returns:
        (...,).
    """
    del c
    K, d = _inputs(K, d)
    _check_ratio(r, K, d)
    return _f2(K, d, r)


def frobenius(K: jax.Array, K_d: jax.Array) -> jax.Array:
    """``||K_d - K||_F`` (...,) (S1-10), with a finite (zero) gradient where ``K = K_d``.

    Args:
        K: realised stiffness (..., m, m).
        K_d: desired stiffness (..., m, m), broadcast against K.
    """
    K, K_d = jnp.asarray(K), jnp.asarray(K_d)
    for name, a in (("K", K), ("K_d", K_d)):
        if a.ndim < 2 or a.shape[-1] != a.shape[-2]:
            raise ValueError(f"{name} must be square matrices (..., m, m), got shape {tuple(a.shape)}")
    if K.shape[-1] != K_d.shape[-1]:
        raise ValueError(f"K {tuple(K.shape)} and K_d {tuple(K_d.shape)} must be matrices of the same size m")
    broadcast_batch(("K", K.shape[:-2]), ("K_d", K_d.shape[:-2]))
    return _frobenius(K, K_d)


@jax.jit
def _frobenius(K: jax.Array, K_d: jax.Array) -> jax.Array:
    D = K_d - K
    return safe_sqrt(jnp.sum(D * D, axis=(-2, -1)))


def offdiag(J: jax.Array, K_xd: jax.Array) -> jax.Array:
    """Norm of the off-diagonal joint stiffness ``u = sqrt(sum_{i<j} (J^T K_xd J)_ij^2)`` (S1-19).

    The joint stiffness ``J^T K_xd J`` (S1-8) that uni-articular actuators cannot realise off its
    diagonal; CSC (SPEC section 6) moves through the null space to make it small.

    Args:
        J: task-row Jacobian (..., m, n).
        K_xd: desired Cartesian stiffness (..., m, m).

    Returns:
        (...,) Nm/rad, with a gradient that is finite also where u = 0.
    """
    J = jnp.asarray(J)
    if not jnp.issubdtype(J.dtype, jnp.floating):
        raise ValueError(f"J must have a floating dtype (float32 or float64), got {J.dtype}")
    if J.ndim < 2:
        raise ValueError(f"J must be a task-row Jacobian (..., m, n), got shape {tuple(J.shape)}")
    K_xd = jnp.asarray(K_xd, dtype=J.dtype)
    if K_xd.shape[-2:] != (J.shape[-2], J.shape[-2]):
        raise ValueError(
            f"K_xd must have shape (..., {J.shape[-2]}, {J.shape[-2]}) to match J {tuple(J.shape)}, got {tuple(K_xd.shape)}"
        )
    broadcast_batch(("J", J.shape[:-2]), ("K_xd", K_xd.shape[:-2]))
    return _offdiag(J, K_xd)


@jax.jit
def _offdiag(J: jax.Array, K_xd: jax.Array) -> jax.Array:
    KJ = jnp.sum(K_xd[..., :, :, None] * J[..., None, :, :], axis=-2)  # K_xd J (..., m, n)
    Kq = jnp.sum(J[..., :, :, None] * KJ[..., :, None, :], axis=-3)  # J^T K_xd J (..., n, n)
    return offdiag_of(Kq)


def offdiag_of(Kq: jax.Array) -> jax.Array:
    """``sqrt(sum_{i<j} Kq_ij^2)`` of a joint stiffness ``Kq`` (..., n, n) (S1-19)."""
    n = Kq.shape[-1]
    upper = jnp.triu(jnp.ones((n, n), dtype=Kq.dtype), k=1)  # i < j
    return safe_sqrt(jnp.sum(upper * Kq * Kq, axis=(-2, -1)))


CRITERIA: dict[str, Criterion] = {"f1": f1, "f2": f2}
_BUILTIN = frozenset(CRITERIA)


def accepts_c(fn: Callable) -> bool:
    """Whether a criterion takes the ``c`` keyword (a parameter named ``c`` or ``**kwargs``); a
    callable whose signature Python cannot read is called with it (the one rule of every caller:
    :func:`get_criterion`'s wrapper and :meth:`WaypointProblem.criterion_value
    <jaxstiff.solvers._problem.WaypointProblem.criterion_value>`)."""
    try:
        params = inspect.signature(fn).parameters.values()
    except (TypeError, ValueError):
        return True
    return any(p.name == "c" or p.kind == inspect.Parameter.VAR_KEYWORD for p in params)


_WRAPPED: dict = {}


def _normalise(fn: Callable) -> Criterion:
    """``fn`` itself if it takes ``c``, else one cached wrapper that drops ``c`` (the same object
    on every call, so a solver that jits with the criterion as a static argument compiles once)."""
    if accepts_c(fn):
        return fn
    try:
        return _WRAPPED[fn]
    except TypeError:  # unhashable callable: wrap without caching
        pass
    except KeyError:
        pass

    @functools.wraps(fn)
    def with_c(K: jax.Array, d: jax.Array, r: ArrayLike, c: float = 0.01) -> jax.Array:
        del c
        return fn(K, d, r)

    try:
        _WRAPPED[fn] = with_c
    except TypeError:
        pass
    return with_c


def register_criterion(name: str, fn: Criterion, *, overwrite: bool = False) -> None:
    """Make ``fn(K, d, r[, c])`` available by name to ``shape``, the CLI and sweeps.

    Args:
        name: the name to use (``criterion="name"``, ``--criterion name``).
        fn: JAX-traceable ``(K (..., m, m), d (..., m), r, c=...) -> (...,)``; to be minimised.
        overwrite: allow replacing an existing user criterion (built-ins f1, f2 never).
    """
    if not isinstance(name, str) or not name:
        raise ValueError(f"criterion name must be a non-empty string, got {name!r}")
    if not callable(fn):
        raise ValueError(f"criterion {name!r} must be callable, got {type(fn).__name__}")
    if name in _BUILTIN:
        raise ValueError(f"criterion {name!r} is built in and cannot be replaced; choose another name")
    if name in CRITERIA and not overwrite:
        raise ValueError(f"criterion {name!r} is already registered; pass overwrite=True to replace it")
    CRITERIA[name] = _normalise(fn)


def check_criterion_call(fn: Criterion, name: str, m: int, dtype: Any = "float64") -> None:
    """Raise ValueError, naming the criterion, unless ``fn(K (m, m), d (m,), r, c=c)`` (as
    :func:`get_criterion` returns it) traces to one real number. Abstract evaluation only (nothing
    runs); a wrong signature or output shape otherwise surfaces as a TypeError deep inside the
    solver's gradient."""
    K = jax.ShapeDtypeStruct((m, m), jnp.dtype(dtype))
    d = jax.ShapeDtypeStruct((m,), jnp.dtype(dtype))
    want = f"a criterion takes K ({m}, {m}), d ({m},), r and optionally c, and returns one real number to minimise"
    try:
        out = jax.eval_shape(lambda K, d: fn(K, d, 5.0, c=0.01), K, d)
    except Exception as exc:  # the user's function: any error it raises is its own
        raise ValueError(f"criterion {name!r} failed on a {m}x{m} K ({type(exc).__name__}: {exc}); {want}") from None
    shape = getattr(out, "shape", None)
    kind = getattr(getattr(out, "dtype", None), "kind", "")
    if shape != () or kind not in "fiub" or not kind:
        got = f"shape {shape}, dtype {getattr(out, 'dtype', type(out).__name__)}"
        raise ValueError(f"criterion {name!r} must return one real number per K ({got}); {want}")
    # one value at a plain, well-posed stiffness: a criterion that is NaN or inf there would leave
    # every waypoint non-finite after the whole solve
    axes = [3000.0, 2000.0, 1000.0, 500.0, 400.0, 300.0][:m]
    # (numpy float64 in: JAX takes it as its default float, without the warning an explicit float64
    # request gives while x64 is off)
    Kp, dp = jnp.asarray(np.diag(axes)), jnp.asarray(np.eye(m)[0])
    try:
        value = float(fn(Kp, dp, 5.0, c=0.01))
    except Exception as exc:  # the user's function: any error it raises is its own
        raise ValueError(
            f"criterion {name!r} failed on K = diag{tuple(axes)} N/m ({type(exc).__name__}: {exc})"
        ) from None
    if not math.isfinite(value):
        raise ValueError(
            f"criterion {name!r} returned {value} at K = diag{tuple(axes)} N/m, d = (1, 0, ...), r = 5: "
            "a criterion must be finite wherever the stiffness is well-posed (every waypoint would end non-finite)"
        )


def get_criterion(criterion: str | Criterion) -> Criterion:
    """Resolve a criterion name (``"f1"``, ``"f2"``, registered ones) or pass a callable through.

    The result is always callable as ``crit(K, d, r, c=c)``.
    """
    if callable(criterion):
        return _normalise(criterion)
    try:
        return CRITERIA[criterion]
    except (KeyError, TypeError):
        raise ValueError(
            f"unknown criterion {criterion!r}; choose one of {', '.join(CRITERIA)} or pass a function"
        ) from None
