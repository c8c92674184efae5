"""The solvers' shortcuts through the translational compliance S (issue 23's speed work), checked
against the public route they replace: ``stiffness_eig_of_compliance`` against the ellipsoid of
``translational_stiffness`` and against central differences; ``stiffness_and_tangents`` against
the JVP of ``stiffness_of_compliance`` with ``dS = P dC P^T`` formed in numpy; and
``WaypointProblem.objective`` (f1/f2 from S's decomposition) against the criterion of K_T."""

from __future__ import annotations

import functools

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from helpers import assert_close

import jaxstiff
from jaxstiff.solvers._problem import WaypointProblem
from jaxstiff.stiffness import compliance
from jaxstiff.stiffness._schur import (
    schur_compliance,
    stiffness_and_tangents,
    stiffness_eig_of_compliance,
    stiffness_of_compliance,
)


@functools.cache
def _lwr() -> jaxstiff.Robot:
    return jaxstiff.Robot.from_urdf("kuka_lwr4")


def _compliances(task: str, n: int = 64, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    r = _lwr()
    q = rng.uniform(np.asarray(r.lower) * 0.9, np.asarray(r.upper) * 0.9, size=(n, 7))
    kj = rng.uniform(1.0, 100.0, size=(n, 7))
    J = r.jacobian(jnp.asarray(q))
    return np.asarray(compliance(J, jnp.asarray(kj), task))


@pytest.mark.parametrize("task", ["full", "xyz", "xy"])
def test_eig_matches_the_ellipsoid_of_K(task):
    C = jnp.asarray(_compliances(task))
    lam, V = stiffness_eig_of_compliance(C)
    ell = jaxstiff.ellipsoid(stiffness_of_compliance(C))
    assert_close(np.asarray(lam), np.asarray(ell.axes), rtol=1e-9, what="axes")
    cos = np.abs(np.sum(np.asarray(V) * np.asarray(ell.directions), axis=-2))  # column by column
    assert_close(cos, np.ones_like(cos), rtol=1e-8, atol=1e-8, what="directions")


@pytest.mark.parametrize("task", ["full", "xyz"])
def test_eig_jvp_matches_central_differences(task):
    C = _compliances(task, n=32, seed=1)
    mu = np.linalg.eigvalsh(np.asarray(schur_compliance(jnp.asarray(C))[0]))
    C = C[mu[:, 0] > 1e-4 * mu[:, -1]][:8]  # regular postures: central differences are exact there
    assert len(C) == 8
    rng = np.random.default_rng(2)
    for c in C:
        T = rng.normal(size=c.shape)
        mu_min = np.linalg.eigvalsh(np.asarray(schur_compliance(jnp.asarray(c))[0]))[0]
        T = (T + T.T) * mu_min  # scaled to the smallest compliance: central differences stay second-order small
        (lam, V), (dlam, dV) = jax.jvp(stiffness_eig_of_compliance, (jnp.asarray(c),), (jnp.asarray(T),))
        h = 1e-6
        lp, Vp = stiffness_eig_of_compliance(jnp.asarray(c + h * T))
        lm, Vm = stiffness_eig_of_compliance(jnp.asarray(c - h * T))
        assert_close(np.asarray(dlam), (np.asarray(lp) - np.asarray(lm)) / (2 * h), rtol=1e-5, atol=1e-6, what="dlam")
        # eigenvector signs are arbitrary: align the perturbed ones with V before differencing
        sp = np.sign(np.sum(np.asarray(Vp) * np.asarray(V), axis=-2))
        sm = np.sign(np.sum(np.asarray(Vm) * np.asarray(V), axis=-2))
        fd = (np.asarray(Vp) * sp - np.asarray(Vm) * sm) / (2 * h)
        assert_close(np.asarray(dV), fd, rtol=1e-4, atol=1e-6, what="dV")


def test_stiffness_and_tangents_equals_the_jvp_of_the_stiffness():
    rng = np.random.default_rng(3)
    for c in _compliances("full", n=6, seed=4):
        dCs = rng.normal(size=(5, 6, 6))
        dCs = dCs + np.swapaxes(dCs, -1, -2)

        def tangents_of(G, dCs=dCs):
            # P dC P^T in numpy from the G the function hands over (P = [I, -C_TR C_RR^-1])
            P = np.concatenate([np.eye(3), -np.asarray(G)], axis=1)
            tr = np.trace(dCs[:, :3, :3], axis1=-2, axis2=-1)
            return jnp.asarray(np.einsum("ab,tbc,dc->tad", P, dCs, P)), jnp.asarray(tr)

        _, G = schur_compliance(jnp.asarray(c))
        assert_close(np.asarray(G) @ np.asarray(c)[3:, 3:], np.asarray(c)[:3, 3:], rtol=1e-9, what="G C_RR = C_TR")
        K, dK = stiffness_and_tangents(jnp.asarray(c), tangents_of)
        for t in range(5):
            K1, dK1 = jax.jvp(stiffness_of_compliance, (jnp.asarray(c),), (jnp.asarray(dCs[t]),))
            assert_close(np.asarray(K), np.asarray(K1), rtol=1e-12, what="K")
            assert_close(np.asarray(dK[t]), np.asarray(dK1), rtol=1e-8, atol=1e-10 * np.abs(dK1).max(), what="dK")


@pytest.mark.parametrize(
    ("task", "crit"),
    [  # the fast lane keeps one case; each compiles the whole objective (the slow lane runs all)
        pytest.param("full", "f2", marks=pytest.mark.slow),
        pytest.param("full", "f1", marks=pytest.mark.slow),
        ("xyz", "f2"),
        pytest.param("xy", "f1", marks=pytest.mark.slow),
    ],
)
def test_objective_shortcut_equals_the_criterion_of_K(task, crit):
    robot = jaxstiff.Robot.from_urdf("kuka_lwr4", locked={"lwr_a7": 0.0})
    f = getattr(jaxstiff, crit)
    pr = WaypointProblem(robot, task, f)
    rng = np.random.default_rng(5)
    q = rng.uniform(np.asarray(robot.lower) * 0.9, np.asarray(robot.upper) * 0.9, size=(32, 7))
    q[:, 6] = 0.0
    kj = rng.uniform(1.0, 100.0, size=(32, 7))
    d = rng.normal(size=(32, 3))

    def routes(q, kj, d):
        fast = pr.objective(q, kj, d, 5.0, 0.01)
        K = pr.stiffness(q, kj)
        slow = f(K, d[: pr.m], 5.0, 0.01)
        return fast, slow

    fast, slow = jax.vmap(routes)(jnp.asarray(q), jnp.asarray(kj), jnp.asarray(d))
    fast, slow = np.asarray(fast), np.asarray(slow)
    # near a singular posture (f2 ~ 1e9: rho ~ 1e8) K_T's own decomposition is the less accurate one
    assert_close(fast, slow, rtol=1e-6, what="objective")
    regular = slow < 1e4
    assert regular.sum() > 16
    assert_close(fast[regular], slow[regular], rtol=1e-10, what="objective, regular postures")
    g_fast = jax.vmap(jax.grad(lambda q, kj, d: routes(q, kj, d)[0], argnums=(0, 1)))(
        jnp.asarray(q), jnp.asarray(kj), jnp.asarray(d)
    )
    g_slow = jax.vmap(jax.grad(lambda q, kj, d: routes(q, kj, d)[1], argnums=(0, 1)))(
        jnp.asarray(q), jnp.asarray(kj), jnp.asarray(d)
    )
    for a, b in zip(g_fast, g_slow, strict=True):
        a, b = np.asarray(a)[regular], np.asarray(b)[regular]
        assert_close(a, b, rtol=1e-7, atol=1e-9 * np.abs(b).max(), what="gradient, regular postures")
