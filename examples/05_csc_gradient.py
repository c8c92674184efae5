"""Configuration-based Stiffness Control (seed 001) as a differentiable rollout, tuned by its gradient.

A planar 3R arm (links 1 m) holds its TCP on a point while its self-motion lowers u(q), the
off-diagonal norm of J^T K_xd J (S1-19), so that one spring per joint comes closer to the desired
Cartesian stiffness K_xd = R(30 deg) diag(3000, 1000) R(30 deg)^T N/m. The rollout is one
``lax.scan``: ``jax.grad`` gives d(loss)/d(beta) for the null-step length beta (rad per step),
checked here against a central finite difference, and a few gradient steps tune beta.
"""

import jax
import jax.numpy as jnp
import matplotlib
import numpy as np
from _common import figure, size

import jaxstiff

matplotlib.use("Agg")
import matplotlib.pyplot as plt

robot = jaxstiff.Robot.from_urdf("planar_3r")
q0 = jnp.deg2rad(jnp.array([75.0, -74.74, -76.30]))  # rad: seed 000's Fig. 2 posture
T = size(400, 20)  # steps
hold = jnp.broadcast_to(robot.fk(q0)[:2, 3], (T, 2))  # (T, 2): the TCP's point, repeated = hold it
c, s = np.cos(np.pi / 6), np.sin(np.pi / 6)
R = jnp.array([[c, -s], [s, c]])
K_xd = R @ jnp.diag(jnp.array([3000.0, 1000.0])) @ R.T  # N/m, task "xy"


def rollout(beta):
    return jaxstiff.csc_rollout(robot, hold, K_xd, q0, beta, step="constant")  # beta: rad per step


def loss(beta):  # mean relative Frobenius error |K_xd - K_C|_F / |K_xd|_F over the rollout
    return rollout(beta).frobenius.mean() / jnp.linalg.norm(K_xd)


beta = 2e-3
g = jax.grad(loss)(beta)
h = 1e-6
fd = (loss(beta + h) - loss(beta - h)) / (2 * h)  # an independent check of the gradient
print(f"d loss / d beta = {float(g):.6g}  (finite difference {float(fd):.6g})")

grad_log = jax.jit(jax.value_and_grad(lambda th: loss(jnp.exp(th))))  # in log(beta): beta stays > 0
theta, history = np.log(beta), []
for _ in range(size(8, 2)):  # plain gradient descent
    value, g_theta = grad_log(theta)
    history.append((float(np.exp(theta)), float(value)))
    theta = theta - 10.0 * float(g_theta)
for b_, v_ in history:
    print(f"beta {b_:.4g} rad: loss {v_:.4f}")

first, tuned = rollout(history[0][0]), rollout(float(np.exp(theta)))
print("u (Nm/rad) first -> last step:", float(first.u[0]), "->", float(tuned.u[-1]))
print("max TCP tracking error (m):", float(jnp.max(tuned.tracking_error)))  # the hold keeps the point
fig, (a, b) = plt.subplots(1, 2, figsize=(10, 3.6))
for r, lab in ((first, f"beta = {history[0][0]:.2g} rad"), (tuned, f"tuned beta = {float(np.exp(theta)):.2g} rad")):
    a.plot(r.u, label=lab)
    b.plot(r.frobenius / jnp.linalg.norm(K_xd), label=lab)
a.set(xlabel="step", ylabel="u(q) (Nm/rad)", title="off-diagonal joint stiffness u (S1-19)")
b.set(xlabel="step", ylabel="|K_xd - K_C|_F / |K_xd|_F", title="relative Frobenius error")
a.legend(), b.legend()
fig.savefig(figure("05_csc_gradient.png"), dpi=110, bbox_inches="tight")
