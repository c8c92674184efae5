"""Multi-start projected gradient for the waypoint problem, batched over many paths (``"pgd"``).

The waypoint problem of :mod:`jaxstiff.solvers._problem` (SPEC section 5, S0-10 ... S0-14) solved
for B trajectories x S starts at once in one jitted JAX function: ``vmap`` over trajectories,
``vmap`` over starts, a loop over the P waypoints (the rate limits chain waypoint p to the
last usable waypoint before it, exactly as :func:`jaxstiff.results.reference_states` rebuilds it),
``lax.fori_loop`` over a fixed number of gradient iterations. No Python loop runs over problems;
one compilation serves every chunk of the same shape (chunks are padded to the chunk size).

One waypoint, one start (``x = [q_free, kj]``, box ``[lb, ub]`` = joint/stiffness limits
intersected with the rate box around the reference state, rounded inwards so that
``|x - x_ref| <= dq, dk`` holds exactly in floating point):

1. start point: the reference state clipped into the box (start 0) or a uniform random point
   of a sub-box around it (starts 1..S-1); at the first waypoint without rate limits the joint
   perturbation is large (``posture_spread`` rad), so that after the Newton correction the starts
   are distinct null-space postures of the arm on the same TCP point, and the stiffnesses are
   drawn log-uniformly over ``[kmin, kmax]`` (the minima of f1/f2 often have several joints
   near ``kmin``, which uniform draws almost never visit);
2. Newton corrections onto the path (minimum-norm Gauss-Newton on the free joints, clipped to the
   box; joints that hit a bound are frozen for the rest of the correction, so every Newton step
   respects the box);
3. first waypoint only: a warm-up on a smooth shape surrogate (``surrogate_first``);
4. f1 and f2: ``lm_iters`` (first waypoint ``lm_iters_first``) box-constrained
   Levenberg-Marquardt steps on residuals whose zeros are exactly the criterion's minimum set
   (position rows, alignment of d with an eigenvector of K, log of the axis ratio minus log r;
   :meth:`WaypointOps.lm_residual`). Where the minimum set is reachable this converges to it to ~1e-9
   in a few steps, which first-order steps on the kinked criteria (|alpha|, |r - rho|) do not;
   where it is not, the alignment rows weigh ``lm_walign`` times more than the ratio row, as the
   criteria weigh degrees of alpha;
5. projected Adam steps on the criterion itself (``iters``; after the LM stage ``iters_lm``; first
   waypoint ``iters_first``) in box-scaled variables (each coordinate divided by its box width),
   bound-active coordinates removed, the joint part projected onto the null space of the position
   Jacobian, a geometrically decaying step ``step0 -> step1``; after each step: clip into the
   box, ``newton`` corrections. Its first iterate is the LM point, so it never returns worse;
6. the best iterate (lowest criterion among iterates whose position error is below
   ``accept_tol``) gets a final ``polish`` Newton corrections; the final status is decided on
   that point exactly as :mod:`jaxstiff.results` defines it: every coordinate inside the box
   (by construction: clip), position error <= ``pos_tol``, criterion finite.

Among the usable starts whose criterion is within ``tie_tol`` (relative) of the best, the one
farthest from the joint and stiffness limits (normalised, stiffness in log scale) is kept: f1 and
f2 have whole sets of optimal states, and one with a stiffness pinned at ``kmin``/``kmax`` or a
joint at its limit may leave no room to follow the rest of the path.

Two ways to use the S starts (``options["mode"]``):

* ``"rollout"`` (default): S independent trajectories, each carrying its own state from its own
  first posture (start 0 from q0, then greedy SLSQP's IK postures, then random ones); the
  trajectory with the fewest unusable waypoints, then the lowest total criterion, is kept. Wins
  whenever the first posture decides whether a joint or stiffness limit binds later, which on
  random paths is most of the difference: a greedy choice cannot undo its posture later.
* ``"best"``: at every waypoint all S starts begin around the one carried state and the best
  feasible point is kept and carried (greedy, like the seed, with S chances per waypoint and
  ``starts_first`` at the first). Wins on a single waypoint's local minima, loses when the one
  carried state is cornered against a limit (then every later waypoint can be lost).

Measured comparisons of the two modes: ``docs/notes/solvers.md``.

Status codes: ``0`` SOLVED (feasible), ``3`` UNREACHABLE (no start reached the path within
``pos_tol``), ``4`` NONFINITE. A fixed-iteration method has no convergence flag, so
NOT_CONVERGED (1) and CLIPPED (2) are not produced; ``solver_code`` is the index of the start that
won (``-1`` for none), ``nit`` the iterations per start, ``nfev`` the gradient evaluations over
all starts of that waypoint.

Runs unchanged on a GPU (pure ``jax.numpy``, no host callbacks). On a CPU the batch is split into
at least one chunk per usable core and the chunks run concurrently (option ``threads``;
:mod:`jaxstiff.runtime._threads`, rows bit-identical; measured gain: docs/benchmarks.md); ``time_s`` is the
run's wall time spread evenly over all waypoints.

Modules: :mod:`.ops` (the traceable pieces of one waypoint problem: box, Newton, LM, Adam),
:mod:`.stages` (one start's optimisation: surrogate, LM, projected Adam, final verdict),
:mod:`.kernel` (one trajectory: starts, rollouts/best, the loop over waypoints), :mod:`.batch`
(options, compiled chunks over many paths, the :data:`~jaxstiff.solvers._base.SOLVERS` adapter).
"""

from jaxstiff.solvers._pgd.batch import (
    CODE_MEANING,
    DEFAULT_OPTIONS,
    check_options,
    compiled_kernel,
    pad_rows,
    run_request,
    solve_batch,
)
from jaxstiff.solvers._pgd.kernel import make_kernel
from jaxstiff.solvers._pgd.stages import finish
from jaxstiff.solvers._problem.ops import WaypointOps, adam_direction, box_scales, clip_box, lm_kind, spd_solve

__all__ = [
    "DEFAULT_OPTIONS",
    "CODE_MEANING",
    "check_options",
    "solve_batch",
    "make_kernel",
    "run_request",
    "compiled_kernel",
    "pad_rows",
    "WaypointOps",
    "spd_solve",
    "clip_box",
    "box_scales",
    "lm_kind",
    "adam_direction",
    "finish",
]
