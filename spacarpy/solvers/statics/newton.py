"""Newton's method on the static equilibrium equations at one load, and the predictor
that carries a converged state to the next load.

Each Newton iteration solves the bordered system ``[[K_T, C^T], [C, 0]]`` (with the held
slips: ``[[K_T, C^T, S^T], [C, 0, 0], [S, 0, 0]]``, so that ``S dx = 0``) (SuperLU, or the
tangent-space LDL^T of :mod:`spacarpy.solvers.statics.reduced` where the only constraints are
Euler normalizations) and then moves the linear update onto the predicted deformations
(:mod:`spacarpy.solvers.statics.kinematic_correction`). A step is converged when the scaled
residual and the scaled last increment are both below the tolerance (forces relative to
the load and internal-force level, moments divided by the model's length scale; positions
relative to that length, Euler parameters absolute), see docs/solver.md.
"""
from __future__ import annotations

import dataclasses
import logging
import time

import numpy as np
import scipy.sparse.linalg as spla

from spacarpy.solvers.statics.errors import StepFailed
from spacarpy.solvers.statics.loads import LoadState

log = logging.getLogger(__name__)


def bordered_solve(prob, A, rhs):
    """Solve the bordered Newton system ``A dz = rhs`` by SuperLU. Returns ``(dz, lu)``, or
    ``(None, None)`` when A is singular (or the solution not finite)."""
    try:
        lu = spla.splu(A, permc_spec="COLAMD")
        prob.timings.factorizations += 1
        dz = lu.solve(rhs)
    except RuntimeError:                  # "Factor is exactly singular"
        return None, None
    if not np.all(np.isfinite(dz)):
        return None, None
    return dz, lu


#: The last allowed iteration is tested with one more increment only where its own
#: increment was already this small (quadratic convergence: the next one is below tol).
_LAST_INCREMENT = 1e-3


class History(list):
    """The scaled residuals of the iterations; ``converged_by`` says how the converged
    state was accepted: "tolerance" (the residual meets it) or "floor" (above it, within
    the residual's measured round-off floor, increments converged)."""

    converged_by: str | None = None


def _increment(prob, ev, x, mu, r, c):
    """The Newton increment ``(dx, dmu)`` at an evaluated state, None where the Newton
    matrix is singular."""
    if prob.reduced is not None:
        t0 = time.perf_counter()
        k_el, euler_diag, _ = prob.element_blocks(ev, mu)
        prob.timings.kernels += time.perf_counter() - t0
        step = prob.reduced.step(ev, x, mu, k_el, euler_diag)
        if step is not None:
            return step
    A = prob.matrix(ev, mu)
    t0 = time.perf_counter()
    rhs = -np.concatenate([r, prob.scale * c, np.zeros(prob.slips.n)])   # S dx = 0
    dz, _ = bordered_solve(prob, A, rhs)
    if dz is None:
        return None
    prob.timings.solve += time.perf_counter() - t0
    return dz[: prob.pattern.n_x], dz[prob.pattern.n_x:] * prob.scale


#: The largest ``[C^T, S^T]`` (entries) that :func:`balanced_multipliers` solves densely.
_DENSE_LSQ = 4_000_000


def balanced_multipliers(prob, x, mu, load: LoadState, states=None) -> np.ndarray:
    """The multipliers (constraints, then slips) that balance the load at ``x`` best, in
    the least-squares sense: the residual is linear in them, ``r(mu) = r(0) + B mu`` with
    ``B = [C^T, S^T]``. A model with rolling wheels starts each Newton solve from them:
    motions held only by the geometric stiffness of the constraint forces (a bicycle
    balanced upright at rest, an inverted pendulum) leave the Newton matrix at ``mu = 0``
    singular, while at the balancing multipliers it is regular."""
    n_x = prob.pattern.n_x
    zero = np.zeros_like(mu)
    ev = prob.evaluate(x, zero, load, states)
    B = prob.matrix(ev, zero)[:n_x, n_x:] / prob.scale
    if not B.shape[1]:
        return mu
    if B.shape[0] * B.shape[1] <= _DENSE_LSQ:
        sol, *_ = np.linalg.lstsq(B.toarray(), -ev.r, rcond=None)
        return sol
    return spla.lsqr(B, -ev.r, atol=1e-15, btol=1e-15, iter_lim=10 * B.shape[1])[0]


def newton(prob, x, mu, load: LoadState, opts, states=None):
    """Newton iterations from (x, mu) under ``load`` (``opts``: max_iter, tol; a
    :class:`~spacarpy.solvers.statics.static.StaticOptions`). ``states`` are the kernel states at
    exactly this x where the caller has them (:meth:`Predictor.with_states`). Returns (x,
    mu, its, res, history) on success, raises :class:`~spacarpy.solvers.statics.errors.StepFailed`
    otherwise."""
    history = History()
    dx_norm = np.inf
    if prob.slips:
        mu, states = balanced_multipliers(prob, x, mu, load, states), None
    for it in range(opts.max_iter + 1):
        ev = prob.evaluate(x, mu, load, states)
        r, c = ev.r, ev.c
        # the unloaded initial configuration: its forces are pure round-off, measured
        # against the model's internal force scale instead of against themselves
        level = prob.force_scale if it == 0 and prob.null_state(x, load) else None
        res, _ = prob.residual_norm(r, c, ev.f_int, ev.f_ext, level=level)
        history.append(res)
        log.debug("iteration %d: residual %.3g, last increment %.3g", it, res, dx_norm)
        if not np.isfinite(res):
            raise StepFailed("non-finite residual", history)
        # converged: the residual below the tolerance and the last increment too (an
        # untouched configuration needs no increment); or, with converged increments, every
        # equation within a small multiple of its round-off floor measured at this state
        # (short, stiff elements: the force residual cannot be resolved better, while the
        # positions are), docs/solver.md
        by = None
        if res <= opts.tol and (it == 0 or dx_norm <= opts.tol):
            by = "tolerance"
        elif it > 0 and dx_norm <= opts.tol and prob.at_floor(ev, x, mu, opts.tol):
            by = "floor"
        elif it == opts.max_iter and res <= opts.tol and dx_norm <= _LAST_INCREMENT:
            # the last allowed iteration meets the tolerance, its increment not yet: one
            # more Newton increment tells whether it has converged (it is not applied)
            dx_next = _increment(prob, ev, x, mu, r, c)
            if dx_next is not None and prob.increment_norm(dx_next[0]) <= opts.tol:
                by = "tolerance"
        if by is not None:
            prob.check_element_range(ev.states)
            # (the stored rule: "tolerance" only where the tolerance clears the floors)
            history.converged_by = prob.accepted_by(ev, x, mu, res, opts.tol, level)
            return x, mu, it, res, history
        if it == opts.max_iter:
            break
        if it >= 3 and res > 1e3 * history[1] and res > 1e3 * opts.tol:
            raise StepFailed("diverging", history)
        prob.timings.iterations += 1
        step = _increment(prob, ev, x, mu, r, c)
        if step is None:
            # a limit point, a bifurcation or a bad iterate
            raise StepFailed("singular Newton matrix", history)
        dx, dmu = step
        if not (np.isfinite(dx).all() and np.isfinite(dmu).all()):
            raise StepFailed("non-finite increment", history)
        dx_norm = prob.increment_norm(dx)
        if dx_norm > 0.5 and prob.num.n_unknown:
            # an Euler-parameter or position jump of order one per iteration: not a
            # Newton step any more, cut the load step instead of wandering off
            if np.abs(dx[prob.rot_mask[prob.free]]).max(initial=0.0) > 0.5:
                raise StepFailed("increment too large", history)
        x_lin = x.copy()
        x_lin[prob.free] += dx
        states = None
        if prob.kinematic_correction:
            x_lin, states = prob.corrector.correct(x_lin, dx, ev.states, dx_norm,
                                                   return_states=True)
        x = x_lin
        mu = mu + dmu
    raise StepFailed(f"no convergence in {opts.max_iter} iterations", history)


class Predictor:
    """Carries a converged state to a new load: sets the prescribed coordinates to their
    values there and moves the rest of the model along kinematically (every deformation
    kept at its current value, prescribed deformations moved to their new targets, Euler
    normalizations restored), a start for Newton.

    It remembers the rigid-mode targets of the load it last moved to: the prescribed
    deformations are corrected only where the new load changes them."""

    def __init__(self, prob):
        self.prob = prob
        self.rigid_target = np.zeros(prob.num.n_rigid)

    def __call__(self, x, mu, load: LoadState):
        return self.with_states(x, mu, load)[0]

    def with_states(self, x, mu, load: LoadState):
        """The start at ``load`` and the kernel states there: ``(x, states)``, states None
        where they were not computed at that x (give them to :func:`newton`, whose first
        residual then does not evaluate the kernels again)."""
        prob = self.prob
        num = prob.num
        idx, target = num.prescribed_state(load.a, load.s)
        same_e = np.array_equal(load.rigid_target, self.rigid_target)
        if (not idx.size or np.array_equal(target, x[idx])) and same_e:
            return x, None
        if prob.slips:
            # a kinematic move would slide the wheels: only the prescribed coordinates
            # move, Newton's increments (S dx = 0) take the rest along rolling
            moved = x.copy()
            moved[idx] = target
            self.rigid_target = load.rigid_target
            return moved, None
        unloaded = dataclasses.replace(load, force=np.zeros(num.n_coord),
                                       moment=np.zeros((prob.loads.moment_rot.size, 3)),
                                       user=None, follow=())
        states = prob.evaluate(x, mu, unloaded).states
        self.rigid_target = load.rigid_target
        moved = x.copy()
        moved[idx] = target
        return prob.correct_kinematics(moved, np.zeros(num.n_unknown), states, max_iter=8,
                                       rigid_target=None if same_e else load.rigid_target,
                                       return_states=True)


__all__ = ["History", "Predictor", "balanced_multipliers", "bordered_solve", "newton"]
