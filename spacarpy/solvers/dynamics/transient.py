"""Transient dynamics (SPACAR's mode 1): generalized-alpha time integration of the index-3
equations of motion.

Unknowns are the free nodal coordinates x (positions and Euler parameters) and the
multipliers mu of the constraints (rigid and prescribed deformation modes, Euler
normalizations), as in the static solver (docs/solver.md):

    M(x) a + h(x, v) + D^T sigma + C^T mu - f(t, x) = 0     (free coordinates)
    c(x, t) = 0

with the inertia forces of :mod:`spacarpy.solvers.dynamics.inertia` (Eq. 60), the elastic and
constraint forces and the tangent of :class:`~spacarpy.solvers.statics.equilibrium.StaticProblem`,
and the loads ``XF + phi(t) DELXF`` (prescribed coordinates and deformations likewise
follow ``phi(t)`` times their increments,
:class:`~spacarpy.time_functions.TimeFunction`). The constraints are kept at
position level (index 3), which the generalized-alpha method of Arnold & Brüls (2007) integrates
with second-order accuracy. Its numerical dissipation is set by the spectral radius at
infinite frequency ``rho_inf`` in [0, 1]: 1 is the undamped trapezoidal rule (energy
conserving for linear systems), smaller values damp the highest frequencies (the stiff axial
and shear modes of beams) while keeping the low ones.

Each step is solved by Newton's method on (x, mu) with the iteration matrix
``[K_t + beta' M + K_h + gamma' C_h, C^T; C, 0]`` (K_t the static tangent including
geometric terms, ``K_h = d(M a + h)/dx`` and ``C_h = dh/dv`` the exact derivatives of the
inertia forces, :meth:`~spacarpy.solvers.dynamics.inertia.Inertia.tangent`): Newton converges
quadratically at any angular velocity (docs/transient.md). A step of a model that turns
fast is taken in a frame turning with it (:mod:`spacarpy.solvers.dynamics.frame`: exact for a rigid
rotation, which keeps the scheme stable at any ``rho_inf``). A step whose Newton iterations
fail is halved (up to ``max_cuts`` times) and retried; it is never skipped.

The transient is cut in four modules: this one holds TransientProblem and the time-stepping
loop (solve_transient) and re-exports the public names; transient_records.py the options and
the step records; transient_start.py the consistent start; transient_step.py one step's Newton
iteration."""
from __future__ import annotations

import copy
import logging
import math
import time
from dataclasses import replace
from functools import cached_property

import numpy as np
import scipy.sparse as sp

from spacarpy.assembly import csc_with_data, scatter_add
from spacarpy.errors import ConvergenceError, SpacarError
from spacarpy.model import Model
from spacarpy.settings import AnalysisSettings
from spacarpy.solvers.dynamics.frame import FRAME_FULL_ANGLE, FRAME_ON_ANGLE, RotatingFrame
from spacarpy.solvers.dynamics.inertia import Inertia
from spacarpy.solvers.dynamics.lie import LieNodes
from spacarpy.solvers.dynamics.transient_records import (  # noqa: F401  (re-exported)
    KEEP_CONTRACTION,
    SLOW_CONTRACTION,
    Residual,
    TransientOptions,
    TransientResult,
    TransientStep,
    alpha_parameters,
)
from spacarpy.solvers.dynamics.transient_start import (
    _consistent_acceleration,
    _initial_acceleration,
    _initial_velocities,
    _project_velocities,
)
from spacarpy.solvers.dynamics.transient_step import (  # noqa: F401  (re-exported)
    KeptMatrix,
    _error_norm,
    _padded,
    _step,
    dense_slips,
)
from spacarpy.solvers.statics.contact import ContactMonitor
from spacarpy.solvers.statics.equilibrium import StaticProblem
from spacarpy.solvers.statics.errors import StepFailed
from spacarpy.solvers.statics.kinematic_check import check_initial
from spacarpy.solvers.statics.loads import LoadState
from spacarpy.solvers.statics.slips import held_slips
from spacarpy.solvers.statics.static import solve_static
from spacarpy.time_functions import TIME_FUNCTIONS, TimeFunction

log = logging.getLogger(__name__)

class TransientProblem:
    """The model's static problem plus inertia, prescribed motion in time and energies."""

    def __init__(self, model: Model, opts: TransientOptions, prob: StaticProblem | None = None):
        self.model, self.opts = model, opts
        self.prob = prob or StaticProblem(model, deformations=opts.deformations)
        self.num = self.prob.num
        self.inertia = Inertia(model, self.num, rotary=opts.rotary_inertia)
        self.free = self.prob.free
        # the free coordinates as indices (a boolean mask costs a search per use) and
        # which of them are Euler parameters
        self.free_idx = np.flatnonzero(self.free)
        self.free_rot = self.prob.rot_mask[self.free]
        self.presc_idx, _ = self.num.prescribed_state(1.0, 0.0)
        self.lie = LieNodes.of(self.num, self.free) if opts.lie_group else None   # (lie.py)
        # the slips held at zero (WHEEL rolling without slip): velocity-level constraints
        # with multipliers nu, the tangential contact forces (docs/rolling.md "Transient")
        self.slips = held_slips(self.num)
        if self.slips:
            # the step borders its matrix with the slip rows itself (transient_step.
            # _slip_matrix, rows S + d(Sv)/dx / gamma'): a copy of the static problem without
            # its own (statics') slip rows, so that they are not bordered twice
            self.prob = copy.copy(self.prob)
            self.prob.slips = self.slips.none()
        self.nu = np.zeros(self.slips.n)      # of the last accepted state
        self.step_nu = self.nu                # of the last converged step (_step)
        self.slip_accumulated = np.zeros(self.slips.n)   # integral of s dt (trapezoidal)
        self.level = 0.0                 # largest force level of the accepted states
        # the exact inertia tangent, switched on for the rest of the run at the first
        # iteration whose residual fell by less than a factor 10 (see _newton_step)
        self.exact_tangent_on = False
        # the user loads' difference quotients in the Newton matrix, likewise
        # (transient_step._user_tangent)
        self.user_tangent_on = False
        self.frame_on = False            # the step's rotating frame (frame_rate)
        self.turned = np.zeros(3)        # the net angle turned: sum of h omega (frame_rate)
        self.frame_from_start = None     # the frame at full rate from t = 0 (frame_rate)
        self.step_rate = None            # the fitted rate at the last step's start
        self.fresh_only = False          # the next step forms its matrices afresh (a retry)
        # (h, a) of the last accepted step's start: the predictor's extrapolation
        self.previous_acceleration: tuple[float, np.ndarray] | None = None
        self.n_matrices = 0              # iteration matrices formed (factorizations)
        self._load_at = None             # (t, LoadState) of the last loads(t)
        self._w_squared = None           # (W, W @ W) of the last frame_terms

    @cached_property
    def frame(self) -> RotatingFrame:
        """The nodes that may turn with a step's rotating frame (solvers/dynamics/frame.py)."""
        return RotatingFrame.of(self.num, self.free, self.model.planar)

    def frame_rate(self, x, v, h: float):
        """The motion of the step's frame (a frame.Motion), or None (the global frame).

        The frame follows the model's fitted rotation at its full rate from the first step
        where the model has a prescribed rotation (INPUTR, or INPUTX on an angle or Euler
        parameter: a driven hub or crank) or already turns at t = 0 (VELOCITY lines,
        :meth:`RotatingFrame.turns`); any rate is an exact change of variables, and there is
        no switch to kick the stiff axial modes, which nothing damps at ``RHOINF 1``.
        Otherwise it follows once the model has turned by more than ``FRAME_ON_ANGLE``
        since the start (the length of :attr:`turned`, to which :meth:`advance_turn` adds
        each accepted step's ``h omega``), at a rate rising smoothly from zero there to the
        fitted one at ``FRAME_FULL_ANGLE``. Both are the same for every step size, which
        keeps the scheme's second order in h (a switch-on by the turn per step did not,
        docs/transient.md). Measured: ramped in over the first 0.05 to 0.25 rad, the free
        beam spinning from t = 0 at 0.08 rad per step drifted in energy 230 times faster;
        switched on at 1 to 2 rad, the spin-up's energy error was 10 times larger."""
        self.step_rate = None
        if not self.opts.rotating_frame or not self.frame.usable or self.slips.n:
            return None                  # (no turning frame with slips: docs/transient.md)
        omega, centre, velocity = self.frame.fit(x, v)
        self.step_rate = omega
        if self.frame_from_start is None:
            self.frame_from_start = bool(self.prob.rot_mask[self.presc_idx].any()) \
                or self.frame.turns(x, v, omega, centre)
        angle = math.sqrt(float(self.turned @ self.turned))
        if angle <= FRAME_ON_ANGLE and not self.frame_from_start:
            return None
        motion = self.frame.motion(omega, centre, velocity)
        if not self.frame_on:
            log.info("%s: the steps are taken in a frame turning with it",
                     "the model has a prescribed rotation or turns at t = 0"
                     if self.frame_from_start else f"the model has turned by {angle:.3g} rad")
            self.frame_on = True
        s = 1.0 if self.frame_from_start else \
            min((angle - FRAME_ON_ANGLE) / (FRAME_FULL_ANGLE - FRAME_ON_ANGLE), 1.0)
        # the rate scaled, the axis kept (the screw axis' point and slide do not change)
        return motion._replace(omega=s * s * (3 - 2 * s) * motion.omega)

    def advance_turn(self, h: float) -> None:
        """A step of length h from the state of the last :meth:`frame_rate` was accepted:
        its fitted rate times h joins the net angle turned."""
        if self.step_rate is not None:
            self.turned += h * self.step_rate

    @cached_property
    def mass_diagonal(self) -> np.ndarray:
        """Diagonal of M in the initial configuration (which coordinates carry mass; used
        by the error control only)."""
        return self.inertia.matrix(self.num.x0).diagonal()

    def constraint_jacobian(self, ev) -> sp.csc_matrix:
        """C (n_constraint, n_unknown) at an evaluated state, without the saddle-point
        scaling of the Newton matrix."""
        n_x = self.prob.pattern.n_x
        mu0 = np.zeros(self.num.n_constraint)
        A = self.prob.matrix(ev, mu0, material_only=True)
        return (A[n_x:, :n_x] / self.prob.scale).tocsc()

    def frame_terms(self, mass_blocks, velocity_blocks, W, gamma_p: float):
        """The rotating frame's part of the Newton matrix over the free coordinates: with
        ``dv = (gamma' + W) d`` and ``da = (beta' + 2 gamma' W + W^2) d`` the inertia forces
        add ``M (2 gamma' W + W^2) + C_h W`` (``C_h = dh/dv``, ``velocity_blocks`` from
        :meth:`Inertia.tangent`, or None) and the Rayleigh mass damping ``alpha M W``. The
        stiffness-proportional and EDAMP damping's ``W`` terms are left out (Newton then
        converges linearly at their small rate)."""
        sub, sel = self._free_part
        M_ff = csc_with_data(sub, self.inertia.assemble(mass_blocks).data[sel])
        if self._w_squared is None or self._w_squared[0] is not W:
            self._w_squared = (W, W @ W)             # once per step (W is the step's)
        out = M_ff @ ((2 * gamma_p + self.model.damping[0]) * W + self._w_squared[1])
        if velocity_blocks:
            out = out + csc_with_data(sub, self.inertia.assemble(velocity_blocks).data[sel]) @ W
        return out

    @cached_property
    def _free_part(self) -> tuple:
        """The inertia pattern's principal part over the free coordinates
        (:meth:`~spacarpy.assembly.BlockPattern.principal_part`; :meth:`frame_terms`'
        submatrices)."""
        return self.inertia.pattern.principal_part(self.free)

    # ---------------------------------------------------------------- time-dependent data
    def prescribed(self, t: float):
        """(indices, x, v, a) of the prescribed coordinates at time t: the load path's
        values at ``phi(t)``, plus ``v0 t + a0 t^2/2`` of the 5-field INPUTX lines."""
        if not self.presc_idx.size:                  # (the same at every step)
            x = np.zeros(0)
            return self.presc_idx, x, x, x
        phi, phi_rot, dphi, ddphi = self.opts.prescribed_phi(t, self.num)
        eps = 1e-4
        idx, x = self.num.prescribed_state(1.0, phi, phi_rot)
        _, xp = self.num.prescribed_state(1.0, phi + eps, phi_rot + eps)
        _, xm = self.num.prescribed_state(1.0, phi - eps, phi_rot - eps)
        d1 = (xp - xm) / (2 * eps)
        d2 = (xp - 2 * x + xm) / eps**2
        v, a = d1 * dphi, d2 * dphi**2 + d1 * ddphi
        n = self.num.prescribed_idx.size             # the INPUTX part comes first
        if n and self.num.prescribed_rate.size:
            dx, dv, da = self.num.input_motion(t)
            x[:n] += dx
            v[:n] += dv
            a[:n] += da
        if self.opts.user_motion is not None:        # USERINP: the routine's coordinates
            u_idx, ux, uv, ua = self.opts.user_motion(t)
            rows = np.searchsorted(self._presc_sorted[0], u_idx)
            rows = self._presc_sorted[1][rows]
            x[rows], v[rows], a[rows] = ux, uv, ua
        return idx, x, v, a

    @cached_property
    def _presc_sorted(self):
        """(the prescribed coordinates sorted, their rows in :meth:`prescribed`'s arrays)."""
        order = np.argsort(self.presc_idx, kind="stable")
        return self.presc_idx[order], order

    def rigid_rates(self, t: float):
        """:meth:`TransientOptions.rigid_rates` of this problem's numbering."""
        return self.opts.rigid_rates(t, self.num)

    def loads(self, t: float, v=None) -> LoadState:
        """The load at time t: XF and gravity, ``phi(t)`` times DELXF, and the prescribed
        deformations at ``phi(t)`` (plus the motion of the 5-field INPUTE lines); a user
        routine's loads (USERSIG) at time t and velocities ``v`` (None: at rest)."""
        if self._load_at is not None and self._load_at[0] == t:
            load = self._load_at[1]                  # a step's iterations share its time
        else:
            named = self.prob.loads.uses_named or self.num.rigid_tf      # LOADTF
            load = (self.prob.loads.at_time({n: v[0] for n, v in self.opts.named_values(t).items()})
                    if named else self.prob.loads.at(1.0, self.opts.phi(t)[0]))
            target = load.rigid_target.copy()
            if self.num.rigid_rate.size:             # 5-field INPUTE: + v0 t + a0 t^2/2
                target += self.num.input_motion(t, rigid=True)[0]
            if (user := self.opts.user_deformations(t)) is not None:     # USERINP's
                target[user[0]] = user[1]
            self._load_at = (t, load := replace(load, rigid_target=target))
        if self.prob.loads.user is not None:
            load = replace(load, user=self.prob.loads.bind(t, v))
        return load

    def loads_at(self, t: float, v) -> LoadState:
        """:meth:`loads` with a user routine's loads at velocities v (``loads(t)`` where
        there is none, so that a replaced ``loads`` keeps working)."""
        return self.loads(t, v) if self.prob.loads.user is not None else self.loads(t)

    # ---------------------------------------------------------------- residual
    def residual(self, t, x, v, a, mu, trial_level: float | None = None,
                 mass_blocks: bool = True) -> Residual:
        """Evaluate the equations at (t, x, v, a, mu). The force residual is measured
        against the largest force level met so far in the run (``self.level``: external,
        internal and inertia forces, moments divided by the length scale), not the current
        one, which vanishes whenever a vibrating structure passes its rest position.

        ``trial_level`` is the force level of the step's first evaluation (the predictor;
        None: this is it): the reference grows only with accepted states
        (:meth:`accept_level`) and the predictor, so that a wild Newton iterate cannot
        inflate it and so pass as converged.

        ``mass_blocks=False`` may leave mass blocks out (None) where the force needs no mass
        matrix (:meth:`Inertia.forces`): a step's Newton iterations complete them only when
        they build an iteration matrix, not for the check that ends the step."""
        load = self.loads_at(t, v)
        ev = self.prob.evaluate(x, mu, load)
        blocks, f_in = self.inertia.forces(x, v, a,
                                           blocks=mass_blocks or bool(self.model.damping[0]))
        f_damp, damp_blocks = self.damping_forces(x, v, ev.states, blocks)
        if f_damp is not None:
            f_in = f_in + f_damp                   # (damping counted with the inertia)
        r = ev.r + f_in[self.free_idx]
        level = self.prob.force_level(ev.f_ext, ev.f_int, f_in)
        ref = max(self.level, level if trial_level is None else trial_level)
        res, _ = self.prob.residual_norm(r, ev.c, None, None, level=ref if ref > 0 else 1.0)
        return Residual(ev, blocks, f_in, r, res, load, f_damp, damp_blocks, level)

    def damping_forces(self, x, v, states, mass_blocks):
        """Viscous damping forces (n_coord,) and their velocity derivative per element group:
        Rayleigh ``alpha M v + beta K0 v`` (DAMPING, K0 the material stiffness D^T S D) and
        the deformation-rate damping ``D^T diag(d) D v`` (EDAMP). (None, {}) without damping."""
        alpha, beta = self.model.damping
        groups = [(i, g) for i, g in enumerate(self.num.groups)
                  if beta > 0 or g.damp is not None]
        if not alpha and not groups:
            return None, {}
        vp = self.inertia.physical(x, v)
        n = self.num.n_coord
        f = np.zeros(n)
        if alpha:
            for b, m in zip(self.inertia.batches, mass_blocks):
                if len(m):
                    f += scatter_add(n, b.idx, alpha * np.einsum("nij,nj->ni", m, vp[b.idx]))
        out = {}
        for i, g in groups:
            D = states[i].D
            c = beta * g.S
            if g.damp is not None:
                c = c + g.damp[:, :, None] * np.eye(g.kind.n_def)
            cd = c @ D
            f += scatter_add(n, g.idx, np.einsum("nkj,nk->nj", D,
                                                 np.einsum("nkj,nj->nk", cd, vp[g.idx])))
            out[i] = D.transpose(0, 2, 1) @ cd
        return f, out

    def damping_power(self, x, v, f_damp) -> float:
        """Power dissipated by the damping forces ``f_damp`` (of :meth:`residual`),
        v . f_damp."""
        if f_damp is None:
            return 0.0
        return float(self.inertia.physical(x, v) @ f_damp)

    def accept_level(self, level: float) -> None:
        """A state of force level ``level`` was accepted: it joins the reference."""
        self.level = max(self.level, level)

    def elastic_energy(self, states) -> float:
        """sum of 1/2 e.S.e, plus sigma0.e for the ESIG pre-stress (its potential)."""
        return float(sum(0.5 * np.einsum("ni,nij,nj->", st.e, g.S, st.e)
                         + (float(np.sum(g.sigma0 * st.e)) if g.sigma0 is not None else 0.0)
                         for g, st in zip(self.num.groups, states)))

    def driving_force(self, ev, f_in, x=None, nu=None):
        """Generalized force the loads, gravity and prescribed motions exert (n_coord,):
        f_ext on the free coordinates, the reaction (f_int + inertia - f_ext, plus the
        slips' ``S^T nu`` at (x, nu)) on the prescribed ones; its work over a step is the
        work done on the model."""
        out = ev.f_ext.copy()
        idx = self.presc_idx
        if idx.size:
            react = ev.f_int + f_in
            if self.slips.n and nu is not None:
                react = react + self.slips.force(x, nu)
            out[idx] = react[idx]
        return out

    def slip_results(self, x, v, nu, deformation: dict, stress: dict, rate: dict) -> None:
        """Put the slips into a state's element results, in place: the multipliers nu
        (the tangential ground forces) as the slip modes' stress resultants, the
        accumulated slip ``slip_accumulated`` as their deformations, the slip velocities
        ``S v`` as their rates."""
        rates = self.slips.rates(x, v)
        for part in self.slips.parts:
            g = self.num.groups[part.group]
            mode = np.asarray(g.kind.velocity_modes)[part.slot]
            rows = slice(part.offset, part.offset + part.elem.size)
            # the kind's sign of its stored stress resultants, where it declares one (the
            # ground's force on the wheel, -nu); else the multiplier itself
            sign = np.asarray(getattr(g.kind, "stress_sign", ()) or np.ones(g.kind.n_def))
            stress[g.keyword][part.elem, mode] = sign[mode] * nu[rows]
            deformation[g.keyword][part.elem, mode] = self.slip_accumulated[rows]
            rate[g.keyword][part.elem, mode] = rates[rows]

    def slip_residual(self, x, v, nu, r, gamma_p: float):
        """The slips' part of a step's equations: the force residual r (free coordinates)
        plus ``S^T nu``, and the slip rows ``S(x) v / gamma'`` (in m, like the holonomic
        constraints they are scaled with), their weighted size, and ``S`` over the free
        coordinates (one kernel evaluation for all three, reused by the iteration matrix)."""
        free, dense = self.free_idx, dense_slips(self)       # (arrays for a small model)
        S = self.slips.jacobian(x, dense=dense)
        r = r + (S.T @ nu)[free]
        g = (S @ v) / gamma_p
        return (r, g, float(np.abs(g).max(initial=0.0)) / self.num.length_scale,
                S[:, free] if dense else S.tocsc()[:, free])

    def deformation_work(self, t: float, h: float, mu, mu_new) -> float:
        """Work the prescribed deformations (INPUTE, DELINPE) do on the model from t to
        t + h, by the trapezoidal rule: ``-sigma . d(target)``.

        A rigid mode's multiplier is its stress resultant sigma (c = e - target, C = D:
        the equations hold ``D^T sigma`` on the side of the internal forces), so the
        constraint acts on the model with ``-D^T sigma`` and its power is ``-sigma . e'``,
        ``e' = target'`` along the motion. (A driven wheel's hinge holds sigma = -I alpha:
        the work is +I alpha w, the kinetic energy it gives.)"""
        presc = self.num.rigid_prescribed
        if not (presc.size and presc.any()):
            return 0.0
        d_target = self.loads(t + h).rigid_target - self.loads(t).rigid_target
        n = self.num.n_rigid
        return -0.5 * float(((mu[:n] + mu_new[:n]) * d_target)[presc].sum())


def solve_transient(model: Model, options: TransientOptions | None = None, *, on_step=None,
                    on_static_step=None, progress=None,
                    problem: StaticProblem | None = None,
                    settings: AnalysisSettings | None = None) -> TransientResult:
    """Integrate the equations of motion from t = 0 to ``t_end`` in ``n_steps`` stored steps.

    ``settings`` give the static load path of START static (ITERSTEP, BIFURCATION; default:
    the defaults).

    ``on_step(TransientStep)`` is called after each stored step (the results writer appends
    it at once), ``on_static_step`` for the steps of the initial static analysis
    (START static), ``progress(t, t_end)`` after each step.

    Raises
    ------
    ConvergenceError
        When a step does not converge after ``max_cuts`` halvings; the steps passed to
        ``on_step`` stay valid.
    """
    opts = options or TransientOptions()
    t_wall = time.perf_counter()
    tp = TransientProblem(model, opts, problem)
    prob, num = tp.prob, tp.num
    if not tp.inertia.has_mass:
        raise SpacarError("MODE transient needs mass: give EM lines for the elements (or XM "
                          "nodal masses)")
    result = TransientResult(problem=prob)
    # ---- initial state
    if opts.start == "static":
        static = solve_static(model, settings, deformations=opts.deformations, problem=prob,
                              on_step=on_static_step)
        result.static = static
        x, mu = static.steps[-1].x.copy(), static.steps[-1].mu.copy()
    else:
        # a mechanism is what dynamics is about; redundant constraints are still an error
        check_initial(prob, allow_mechanism=True)
        x, mu = num.x0.copy(), np.zeros(num.n_constraint)
    if prob.has_commit:                          # hinge turn counts of the start state
        prob.commit(x, mu, tp.loads(0.0))
    idx, xp0, vp0, ap0 = tp.prescribed(0.0)
    x[idx] = xp0
    v = np.zeros(num.n_coord)
    v[idx] = vp0
    if opts.initial_velocities or num.prescribed_rate.size or num.rigid_rate.size \
            or opts.user_motion is not None or model.initial_rates \
            or np.any(vp0) or np.any(tp.rigid_rates(0.0)[0]):    # a drive moving at t = 0
        v = _initial_velocities(tp, x, v, opts.initial_velocities)
    a, mu = _initial_acceleration(tp, x, v, mu, ap0)
    am, af, gamma, beta = alpha_parameters(opts.rho_inf)
    a_tilde = a.copy()
    start = tp.residual(0.0, x, v, a, mu)
    ev, f_in, res = start.ev, start.f_in, start.res
    tp.accept_level(start.level)
    work = dissipated = 0.0
    p_damp = tp.damping_power(x, v, start.f_damp)
    q_prev = tp.driving_force(ev, f_in, x, tp.nu)

    contact = ContactMonitor(num)
    lifted = [False]                 # whether the last stored step had a wheel lifting off

    def store(t, x, v, a, mu, its, res, ev, blocks, f_in, by="tolerance"):
        deformation, stress = prob.element_results(ev)
        rates = {g.keyword: np.einsum("nkj,nj->nk", st.D, v[g.idx])
                 for g, st in zip(num.groups, ev.states)}
        if tp.slips.n:
            deformation = {k: d.copy() for k, d in deformation.items()}
            stress = {k: d.copy() for k, d in stress.items()}
            tp.slip_results(x, v, tp.nu, deformation, stress, rates)
        warning, flags = None, {}
        if contact:
            # the lift-off is warned (log and the file's warnings) where it begins; every
            # stored step flags it (/transient/elements/WHEEL/lift_off)
            # (a normal force within 1e-8 of the run's force level of zero is no lift-off:
            # the multipliers carry round-off of about 1e-11 of it)
            k, tol = len(result.steps), 1e-8 * tp.level
            warning = contact(stress, k, f"time step {k} (t = {t:.6g} s)", quiet=lifted[0],
                              tol=tol)
            flags = contact.flags(stress, tol)
            lifted[0], warning = warning is not None, None if lifted[0] else warning
        step = TransientStep(time=t, x=x.copy(), v=v.copy(), a=a.copy(), mu=mu.copy(),
                             iterations=its, residual=res, converged_by=by,
                             kinetic_energy=tp.inertia.kinetic_energy(x, v, blocks),
                             elastic_energy=tp.elastic_energy(ev.states), external_work=work,
                             dissipated_energy=dissipated,
                             deformation=deformation, stress=stress,
                             reaction=prob.reactions(x, ev.f_int + f_in, ev.f_ext),
                             deformation_rate=rates, contact=flags, warning=warning)
        result.steps.append(step)
        if on_step is not None:
            on_step(step)

    store(0.0, x, v, a, mu, 0, res, ev, start.blocks, f_in)
    a_store = a
    h_out = opts.t_end / opts.n_steps
    driven = bool(tp.presc_idx.size or (num.rigid_prescribed.size
                                        and num.rigid_prescribed.any()))
    h_int = h_out / max(int(opts.substeps), 1)
    t = 0.0
    for k in range(1, opts.n_steps + 1):
        t_target = k * h_out
        h = h_int
        while t_target - t > 1e-9 * h_int:
            # the last step of an interval ends exactly on it (no sliver step from round-off)
            h = t_target - t if t_target - t - h < 1e-6 * h_int else h
            try:
                out = _step(tp, t, h, x, v, a, a_tilde, mu, (am, af, gamma, beta), opts)
            except StepFailed as fail:
                if fail.chord:
                    # a kept iteration matrix, not the step size, may be what failed:
                    # the same step again with new matrices at every iteration
                    log.debug("t = %.6g: %s with a kept iteration matrix; again with new "
                              "ones", t, fail)
                    tp.fresh_only = True
                    continue
                if h / 2 < h_int / 2 ** opts.max_cuts:
                    raise ConvergenceError(
                        f"transient step at t = {t:.6g} s (step {k}) did not converge after "
                        f"{opts.max_cuts} halvings of the time step: {fail}; the "
                        f"{len(result.steps)} time steps stored before it (to t = "
                        f"{result.steps[-1].time:.6g} s) are kept") from None
                log.info("t = %.6g: %s, halving the time step to %.3g", t, fail, h / 2)
                h /= 2
                continue
            x_new, v_new, a_new, at_new, mu_new, its, res, ev, f_in, f_damp, blocks, by = out
            a_out = a_new
            if tp.slips.n:
                # the slips need consistent velocities; the stored accelerations and
                # multipliers (the contact forces) are made consistent with them, and so
                # are those of every step where prescribed motions do work (which the
                # multipliers give)
                v_new = _project_velocities(tp, x_new, v_new, t + h, ev)
            if tp.slips.n and (driven or t_target - (t + h) <= 1e-9 * h_int):
                a_out, mu_new = _consistent_acceleration(tp, x_new, v_new, a_new, mu_new,
                                                         t + h)
                c = tp.residual(t + h, x_new, v_new, a_out, mu_new)
                ev, f_in, f_damp, blocks = c.ev, c.f_in, c.f_damp, c.blocks
            grow = 2.0
            if opts.error is not None:
                # local error estimate of the position update (Zienkiewicz & Xie's
                # h^2 |beta - 1/6| times the change of acceleration), against ERROR abs rel
                err = _error_norm(tp, h, beta, a_tilde, at_new, x_new, opts.error)
                factor = min(2.0, max(0.2, 0.9 * err ** (-1.0 / 3.0))) if err > 0 else 2.0
                if err > 1.0 and h * factor >= h_int / 2 ** opts.max_cuts:
                    log.debug("t = %.6g: local error %.3g > 1, step %.3g -> %.3g", t, err, h,
                              h * factor)
                    result.n_rejected += 1
                    h *= factor
                    continue
                grow = factor
            tp.previous_acceleration = (h, a)
            tp.advance_turn(h)
            if tp.slips.n:
                tp.slip_accumulated = tp.slip_accumulated + 0.5 * h * (
                    tp.slips.rates(x, v) + tp.slips.rates(x_new, v_new))
            v, a, a_tilde, a_store = v_new, a_new, at_new, a_out
            tp.nu = tp.step_nu
            q_new = tp.driving_force(ev, f_in, x_new, tp.nu)
            work += 0.5 * float((q_prev + q_new) @ (x_new - x))
            work += tp.deformation_work(t, h, mu, mu_new)
            p_new = tp.damping_power(x_new, v, f_damp)
            dissipated += 0.5 * (p_damp + p_new) * h
            q_prev, x, mu, p_damp = q_new, x_new, mu_new, p_new
            result.n_newton += its
            if prob.has_commit:
                prob.commit_states(ev.states)
            t += h
            result.n_steps_taken += 1
            h = min(grow * h, h_out if opts.error is not None else h_int)
        t = t_target
        store(t_target, x, v, a_store, mu, its, res, ev, blocks, f_in, by)
        if progress is not None:
            progress(t_target, opts.t_end)
    if contact.report() is not None:
        log.info(contact.report("time step"))
    result.wall_time = time.perf_counter() - t_wall
    result.n_matrices = tp.n_matrices
    return result


__all__ = ["TimeFunction", "TIME_FUNCTIONS", "TransientOptions", "TransientStep",
           "TransientResult", "TransientProblem", "alpha_parameters", "solve_transient"]
