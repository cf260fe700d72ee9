"""Inverse dynamics (SPACAR's mode 2): the input forces and reactions of a fully prescribed
motion, from first- and second-order kinematics at every time step, without time
integration.

Every degree of freedom is prescribed (INPUTX on coordinates, INPUTE on deformation modes,
INPUTR; their values follow ``phi(t)`` of TIMEFUNCTION times the DELINPX/DELINPE
increments, plus ``v0 t + a0 t^2/2`` of the 5-field lines), so the constraints
``c(x, t) = 0`` (the rigid and prescribed deformation modes and the Euler normalizations)
are as many as the free coordinates and their Jacobian C is regular: the model is
kinematically determinate by its inputs. At each stored time t:

- positions: Newton's method on ``c(x, t) = 0`` (from the last step's state extrapolated
  to t), to round-off;
- velocities: ``C v_f = e'_target - C_p v_p`` (first-order kinematics);
- accelerations: ``C a_f = e''_target - C_p a_p - (v^T H_k v)_k`` with the kernels' exact
  Hessians H_k of the rigid modes (second-order kinematics; ``2 q'.q'`` for the Euler rows);
- forces: the equations of motion of mode 1 with the multipliers as the only unknowns,
  ``C_f^T mu = -(f_int(mu = 0) + f_inertia + f_damping - f_ext)_f``.

The multipliers are the stress resultants of the rigid and prescribed modes (a driven
hinge's sigma; the motor turns it with the torque ``-sigma``), and the reactions of the
fixed and prescribed coordinates are those of mode 1 (``f_int + f_inertia - f_ext``),
so the results have mode 1's names and units.

Flexible (DYNE) and released (RLSE) modes are degrees of freedom unless the constraints
fix them: a model with degrees of freedom left, or with redundant constraints (whose
multipliers would not be unique), is refused before the first step with a
:class:`~spacarpy.errors.ModelError` that names them (docs/transient.md, "Inverse
dynamics").
"""
from __future__ import annotations

import logging
import math
import time

import numpy as np
import scipy.sparse.linalg as spla

from spacarpy.errors import ConvergenceError, ModelError
from spacarpy.model import Model
from spacarpy.solvers.dynamics.transient import TransientProblem
from spacarpy.solvers.dynamics.transient_records import (
    TransientOptions,
    TransientResult,
    TransientStep,
)
from spacarpy.solvers.statics.equilibrium import StaticProblem

log = logging.getLogger(__name__)

#: Newton iterations allowed for the positions of one time step.
MAX_ITER = 30
#: The positions are accepted when the weighted constraint violation is below this
#: (lengths relative to the model's length scale, angles in rad).
POSITION_TOL = 1e-13
#: ... or, once the increments are at round-off, below this.
POSITION_FLOOR = 1e-9


def determinacy_error(prob: StaticProblem) -> ModelError | None:
    """The refusal of a model that its inputs do not determine (degrees of freedom left:
    flexible, released or unconstrained coordinates) or that has redundant constraints,
    naming the modes, coordinates and nodes; None for a determinate one."""
    from spacarpy.solvers.statics.kinematic_check import (
        KINEMATIC_LIMIT,
        kinematic_analysis,
        mode_name,
    )
    num = prob.num
    n_f, n_c = num.n_unknown, num.n_constraint
    if n_f == n_c and (n_f == 0 or _regular(prob)):
        return None
    head = ("MODE inverse_dynamics (SPACAR 2) needs every degree of freedom prescribed "
            "(INPUTX, INPUTE): ")
    if n_f + n_c > KINEMATIC_LIMIT:
        return ModelError(head + f"the model has {n_f} free coordinates and {n_c} "
                                 f"constraints (rigid and prescribed modes, Euler "
                                 f"normalizations); they must be as many and independent")
    ka = kinematic_analysis(prob, stiff_resists=False)
    parts = []
    if ka.motions:
        flexible = sorted({mode_name(m) for mo in ka.motions for m in mo["modes"]
                           if _is_flexible(prob, m)})
        parts.append(
            f"{len(ka.motions)} degree(s) of freedom remain: "
            + "; ".join(f"motion {i} driven by {mode_name(m['driver'])} (nodes that move: "
                        f"{', '.join(str(n) for n in m['nodes'][:8])}"
                        f"{' ...' if len(m['nodes']) > 8 else ''})"
                        for i, m in enumerate(ka.motions[:4], 1))
            + (f" (and {len(ka.motions) - 4} more)" if len(ka.motions) > 4 else "")
            + (f"; flexible (DYNE) modes are degrees of freedom: {', '.join(flexible[:8])}"
               if flexible else "")
            + ". Prescribe them (INPUTX, INPUTE) or make the modes rigid")
    if ka.redundant:
        parts.append(f"{len(ka.redundant)} redundant constraint(s), whose forces would not "
                     "be unique: " + "; ".join(
                         mode_name(n) + (f" ('RLSE {n[1]} {n[2]}' releases it)"
                                         if n[0] != "EULER" else "")
                         for n in ka.redundant[:8]))
    if not parts:        # square, and regular by the equilibrated rank analysis
        return None
    err = ModelError(head + "; ".join(parts))
    err.mechanism, err.over_constrained = bool(ka.motions), bool(ka.redundant)
    return err


def _is_flexible(prob, name) -> bool:
    from spacarpy.model import FLEXIBLE
    kw, e, k = name
    g = prob.num.group(kw)
    if g is None:
        return False
    rows = np.flatnonzero(g.ids == e)
    return bool(rows.size) and g.def_class[rows[0], k - 1] == FLEXIBLE


def _regular(prob) -> bool:
    """Whether the square constraint Jacobian at the deck's configuration has an LU with
    no tiny pivot relative to its rows (a quick test before the rank analysis)."""
    num = prob.num
    ev = prob.evaluate(num.x0.copy(), np.zeros(num.n_constraint), prob.loads.unloaded())
    C = _jacobian(prob, ev)
    try:
        lu = spla.splu(C)
    except RuntimeError:
        return False
    pivots = np.abs(lu.U.diagonal())
    return bool(pivots.min(initial=1.0) > 1e-10 * max(pivots.max(initial=1.0), 1e-300))


def _jacobian(prob, ev):
    """C (n_constraint, n_unknown), CSC: :meth:`TransientProblem.constraint_jacobian
    <spacarpy.solvers.dynamics.transient.TransientProblem.constraint_jacobian>` without a
    transient problem."""
    n_x = prob.pattern.n_x
    A = prob.matrix(ev, np.zeros(prob.num.n_constraint), material_only=True)
    return (A[n_x:, :n_x] / prob.scale).tocsc()


class InverseDynamics:
    """The kinematics and forces of a :class:`TransientProblem` whose inputs determine its
    motion: :meth:`state` gives one time step."""

    def __init__(self, tp: TransientProblem):
        self.tp, self.prob, self.num = tp, tp.prob, tp.num

    # ------------------------------------------------------------- prescribed motion
    def prescribed(self, t: float):
        """(indices, x, v, a) of the prescribed coordinates at t, with exact derivatives
        (INPUTX values are linear in phi; INPUTR turns by ``initial + phi angle``)."""
        num, tp = self.num, self.tp
        phi, phi_rot, dphi, ddphi = tp.opts.prescribed_phi(t, num)   # (LOADTF: arrays)
        idx, x = num.prescribed_state(1.0, phi, phi_rot)
        n = num.prescribed_idx.size
        dphi, ddphi = (np.broadcast_to(d, x.shape) for d in (dphi, ddphi))
        v, a = np.zeros(x.size), np.zeros(x.size)
        v[:n], a[:n] = num.prescribed_delta * dphi[:n], num.prescribed_delta * ddphi[:n]
        if num.prescribed_rate.size:
            dx, dv, da = num.input_motion(t)
            x[:n] += dx
            v[:n] += dv
            a[:n] += da
        if num.rotation_angle.size:             # q = (cos th/2, sin th/2 n)
            th = num.rotation_initial + phi_rot * num.rotation_angle
            w, dw = num.rotation_angle * dphi[n::4], num.rotation_angle * ddphi[n::4]
            c, s = np.cos(th / 2)[:, None], np.sin(th / 2)[:, None]
            dq = 0.5 * np.hstack([-s, c * num.rotation_axis])
            q = np.hstack([c, s * num.rotation_axis])
            v[n:] = (dq * w[:, None]).ravel()
            a[n:] = (-0.25 * q * (w * w)[:, None] + dq * dw[:, None]).ravel()
        return idx, x, v, a

    # ------------------------------------------------------------- kinematics
    def positions(self, x, t: float):
        """Newton's method on the constraints at t from ``x`` (prescribed coordinates set):
        (x, evaluation, iterations)."""
        prob, num, tp = self.prob, self.num, self.tp
        free = tp.free_idx
        load = tp.loads(t)
        mu0 = np.zeros(num.n_constraint)
        x = x.copy()
        w = prob.constraint_weight
        step = math.inf
        for it in range(MAX_ITER + 1):
            ev = prob.evaluate(x, mu0, load)
            err = float(np.abs(w * ev.c).max(initial=0.0))
            if err <= POSITION_TOL or (step < 1e-15 and err <= POSITION_FLOOR):
                return x, ev, it
            if it == MAX_ITER:
                break
            dx = self._solve(ev, -ev.c, t)
            x[free] += dx
            step = prob.increment_norm(dx)
        raise ConvergenceError(f"inverse dynamics: the positions at t = {t:.6g} s do not "
                               f"meet the constraints after {MAX_ITER} Newton iterations "
                               f"(violation {err:.3g}): the prescribed motion leaves the "
                               "model's reach or passes a singular configuration")

    def _solve(self, ev, rhs, t: float, trans: bool = False):
        """Solve with C at ``ev`` (C^T with ``trans``), refusing a singular one."""
        if getattr(self, "_lu_of", None) is not ev:
            try:
                self._lu = spla.splu(self.tp.constraint_jacobian(ev))
            except RuntimeError:
                self._lu = None
            self._lu_of = ev
        out = None if self._lu is None else self._lu.solve(rhs, trans="T" if trans else "N")
        if out is None or not np.all(np.isfinite(out)):
            raise ConvergenceError(f"inverse dynamics: the constraints are singular at t = "
                                   f"{t:.6g} s: the inputs do not determine the motion "
                                   "there (a dead point of the mechanism)")
        return out

    def constraint_rates(self, states, x, v):
        """``C(x) v`` over all coordinates (rigid modes, then Euler rows)."""
        out = [np.einsum("nj,nj->n", st.D[g.rigid_elem, g.rigid_mode], v[g.idx[g.rigid_elem]])
               for g, st in zip(self.num.groups, states) if g.rigid_elem.size]
        eu = self.num.euler_coords
        out.append(2.0 * np.sum(x[eu] * v[eu], axis=1))
        return np.concatenate(out)

    def convective(self, states, x, v):
        """``v^T H_k v`` of every constraint (the kernels' exact Hessians; ``2 q'.q'``)."""
        out = []
        for g, st in zip(self.num.groups, states):
            if not g.rigid_elem.size:
                continue
            conv = np.zeros(g.rigid_elem.size)
            vl = v[g.idx]
            for k in np.unique(g.rigid_mode):
                sel = np.flatnonzero(g.rigid_mode == k)
                w = np.zeros((g.n_elem, g.def_class.shape[1]))
                w[g.rigid_elem[sel], k] = 1.0
                H = g.kind.hessian(st, w)
                rows = g.rigid_elem[sel]
                conv[sel] = np.einsum("ni,nij,nj->n", vl[rows], H[rows], vl[rows])
            out.append(conv)
        eu = self.num.euler_coords
        out.append(2.0 * np.sum(v[eu] * v[eu], axis=1))
        return np.concatenate(out)

    def state(self, t: float, x_guess):
        """The time step at t: (x, v, a, mu, residual record, position iterations)."""
        tp, num = self.tp, self.num
        free = tp.free_idx
        idx, xp, vp, ap = self.prescribed(t)
        x = x_guess.copy()
        x[idx] = xp
        x, ev, its = self.positions(x, t)
        rates, accels = tp.rigid_rates(t)
        n_r = num.n_rigid
        v = np.zeros(num.n_coord)
        v[idx] = vp
        rhs = -self.constraint_rates(ev.states, x, v)
        rhs[:n_r] += rates
        v[free] = self._solve(ev, rhs, t)
        a = np.zeros(num.n_coord)
        a[idx] = ap
        rhs = -self.constraint_rates(ev.states, x, a) - self.convective(ev.states, x, v)
        rhs[:n_r] += accels
        a[free] = self._solve(ev, rhs, t)
        mu0 = np.zeros(num.n_constraint)
        r0 = tp.residual(t, x, v, a, mu0, trial_level=0.0)
        mu = self._solve(ev, -r0.r, t, trans=True)
        res = tp.residual(t, x, v, a, mu)
        return x, v, a, mu, res, its


def solve_inverse(model: Model, options: TransientOptions | None = None, *, on_step=None,
                  progress=None, problem: StaticProblem | None = None) -> TransientResult:
    """The input forces of the prescribed motion at the ``n_steps + 1`` times
    ``0, t_end / n_steps, ..., t_end`` (see the module's docstring).

    ``on_step(TransientStep)`` is called after each step (the results writer appends it at
    once; ``step.a`` holds the accelerations), ``progress(t, t_end)`` after each step.

    Raises
    ------
    ModelError
        Before any step, for a model its inputs do not determine.
    ConvergenceError
        At a step whose positions cannot be found or whose constraints are singular; the
        steps passed to ``on_step`` stay valid.
    """
    opts = options or TransientOptions()
    t_wall = time.perf_counter()
    tp = TransientProblem(model, opts, problem)
    prob, num = tp.prob, tp.num
    err = determinacy_error(prob)
    if err is not None:
        raise err
    solver = InverseDynamics(tp)
    result = TransientResult(problem=prob)
    h = opts.t_end / opts.n_steps
    x, v, a = num.x0.copy(), np.zeros(num.n_coord), np.zeros(num.n_coord)
    work = dissipated = p_prev = 0.0
    q_prev = mu_prev = None
    for k in range(opts.n_steps + 1):
        t = k * h
        guess = x.copy()
        if k:            # the last state carried to t: Newton starts within h^3
            guess[tp.free_idx] += (h * v + 0.5 * h * h * a)[tp.free_idx]
        x_new, v, a, mu, res, its = solver.state(t, guess)
        ev = res.ev
        tp.accept_level(res.level)
        q_new = tp.driving_force(ev, res.f_in)
        p_new = tp.damping_power(x_new, v, res.f_damp)
        if k:            # the work of the inputs (trapezoidal rule), as mode 1 counts it
            work += 0.5 * float((q_prev + q_new) @ (x_new - x))
            work += tp.deformation_work(t - h, h, mu_prev, mu)
            dissipated += 0.5 * (p_prev + p_new) * h
        x, q_prev, mu_prev, p_prev = x_new, q_new, mu, p_new
        if prob.has_commit:
            prob.commit_states(ev.states)
        deformation, stress = prob.element_results(ev)
        rates = {g.keyword: np.einsum("nkj,nj->nk", st.D, v[g.idx])
                 for g, st in zip(num.groups, ev.states)}
        step = TransientStep(
            time=t, x=x.copy(), v=v.copy(), a=a.copy(), mu=mu.copy(), iterations=its,
            residual=res.res, kinetic_energy=tp.inertia.kinetic_energy(x, v, res.blocks),
            elastic_energy=tp.elastic_energy(ev.states), external_work=work,
            dissipated_energy=dissipated, deformation=deformation, stress=stress,
            reaction=prob.reactions(x, ev.f_int + res.f_in, ev.f_ext),
            deformation_rate=rates)
        result.steps.append(step)
        result.n_newton += its
        result.n_steps_taken += 1
        if on_step is not None:
            on_step(step)
        if progress is not None:
            progress(t, opts.t_end)
    result.wall_time = time.perf_counter() - t_wall
    return result


__all__ = ["InverseDynamics", "determinacy_error", "solve_inverse"]
