"""``jaxstiff.shape`` runs JAX's CPU computations inline (no async dispatch) where it is the
process's first JAX work, keeps async dispatch where ``JAXSTIFF_CPU_ASYNC_DISPATCH=1``,
and changes nothing where JAX has already started; the results are the same to the bit in both
modes (only the per-kernel hand-off differs). Each case is a fresh process, as a user's script is:
the setting is read once, when JAX starts its CPU backend."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import numpy as np
from helpers import numpy_fk

import jaxstiff

#: a user's script: a short reachable path of the planar 3R arm (points from numpy FK, given as
#: numbers, so that nothing before ``shape`` touches JAX unless the case asks), greedy SLSQP
SCRIPT = """
import json, sys
import numpy as np
import jaxstiff
if {jax_first}:
    import jax.numpy as jnp
    jnp.ones(3).block_until_ready()  # the script's own JAX work, before jaxstiff's
res = jaxstiff.shape("planar_3r", jaxstiff.Path(np.array({points})), "f2", 3.0, task="xy", solver="slsqp", dq=0.1)
json.dump({{"async": res.meta["jax_cpu_async_dispatch"], "q": res.q.tolist(), "kj": res.kj.tolist()}}, sys.stdout)
"""


def _points() -> list:
    robot = jaxstiff.Robot.from_urdf("planar_3r")
    q = np.array([0.3, 0.9, -0.7]) + np.linspace(0.0, 1.0, 4)[:, None] * np.array([0.1, -0.08, 0.06])
    return [numpy_fk(robot, qi)[:3, 3].tolist() for qi in q]


def _run(jax_first: bool, env_value: str | None) -> dict:
    env = {k: v for k, v in os.environ.items() if k != "JAXSTIFF_CPU_ASYNC_DISPATCH"}
    if env_value is not None:
        env["JAXSTIFF_CPU_ASYNC_DISPATCH"] = env_value
    code = SCRIPT.format(jax_first=jax_first, points=_points())
    p = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=300)
    assert p.returncode == 0, p.stderr
    return json.loads(p.stdout)


def test_shape_as_the_first_jax_work_dispatches_inline_with_the_same_bits():
    inline = _run(jax_first=False, env_value=None)
    started = _run(jax_first=True, env_value=None)  # JAX started by the script: its choice stands
    assert inline["async"] is False
    assert started["async"] is True
    assert np.array_equal(inline["q"], started["q"]) and np.array_equal(inline["kj"], started["kj"])


def test_the_environment_variable_keeps_async_dispatch():
    assert _run(jax_first=False, env_value="1")["async"] is True
