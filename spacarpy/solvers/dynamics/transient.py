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

The module is longer than 600 lines: the time step, its error control, the consistent
initial state (with the rates of SPACAR's 5-field inputs and STARTDE) and the gauge of the
Euler-parameter rates work on the same state and are kept together.
"""
from __future__ import annotations

import logging
import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from functools import cached_property
from typing import NamedTuple

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from spacarpy.assembly import csc_with_data, scatter_add
from spacarpy.errors import ConvergenceError, SpacarError
from spacarpy.model import FLEXIBLE, Model
from spacarpy.rotation import tangent_part
from spacarpy.settings import AnalysisSettings
from spacarpy.solvers.dynamics.frame import FRAME_FULL_TURN, FRAME_MIN_TURN, RotatingFrame
from spacarpy.solvers.dynamics.inertia import Inertia
from spacarpy.solvers.statics.equilibrium import StaticProblem
from spacarpy.solvers.statics.errors import StepFailed
from spacarpy.solvers.statics.kinematic_check import check_initial
from spacarpy.solvers.statics.loads import LoadState
from spacarpy.solvers.statics.nodal import node_rows
from spacarpy.solvers.statics.static import solve_static
from spacarpy.time_functions import TIME_FUNCTIONS, TimeFunction

log = logging.getLogger(__name__)

#: A Newton iteration whose residual falls by less than this factor switches the exact
#: inertia tangent on for the rest of the run (see _step).
SLOW_CONTRACTION = 0.1

#: A step's iteration matrix serves its chord iterations (see _step) as long as each of
#: their increments reduces the scaled residual by at least this factor.
KEEP_CONTRACTION = 0.1


@dataclass
class TransientOptions:
    """Settings of a transient run (deck: TIMESTEP, RHOINF, START, TIMEFUNCTION, ITERSTEP)."""

    t_end: float = 1.0
    n_steps: int = 100                       # stored steps
    substeps: int = 1                        # integration steps per stored step
    rho_inf: float = 0.9
    tol: float = 1e-8
    max_iter: int = 20
    max_cuts: int = 10
    start: str = "deck"                      # "deck" (at rest) or "static" (equilibrium)
    phi: TimeFunction = field(default_factory=TimeFunction)
    error: tuple | None = None               # ERROR (abs, rel): adaptive step size
    deformations: str = "modified"
    rotary_inertia: str = "lumped"           # ROTARYINERTIA: the beams' section inertia
    initial_velocities: dict = field(default_factory=dict)   # node -> (3,) VELOCITY
    #: the derivatives of the inertia forces (convective terms, dM/dx a) in the Newton
    #: matrix; False leaves them out (the former iteration matrix: linear convergence at
    #: high angular velocity, kept to measure the difference)
    exact_tangent: bool = True
    #: take each step in a frame turning with the model once it rotates by more than
    #: FRAME_MIN_TURN per step (solvers/dynamics/frame.py); False: always in the global frame (the
    #: former scheme, unstable with little numerical damping at fast rotation)
    rotating_frame: bool = True
    #: a step's later Newton iterations reuse its iteration matrix while that contracts
    #: (chord iterations); False forms a new one at every iteration
    reuse_matrix: bool = True

    @classmethod
    def from_settings(cls, settings: AnalysisSettings) -> TransientOptions:
        """The options of a deck's settings: TIMESTEP, SUBSTEPS, ERROR, RHOINF, START,
        TIMEFUNCTION, VELOCITY, and ITERSTEP's tolerance (at most 1e-10) and iteration limit
        (at least 20)."""
        tr, it = settings.transient, settings.static.iterstep
        t_end, n_steps = tr.timestep
        return cls(t_end=t_end, n_steps=n_steps, substeps=tr.substeps, error=tr.error_tol,
                   rho_inf=tr.rho_inf, tol=min(it.tol, 1e-10), max_iter=max(it.max_iter, 20),
                   start=tr.start, phi=TimeFunction(*tr.time_function),
                   deformations=settings.deformations,
                   rotary_inertia=settings.rotary_inertia,
                   initial_velocities=dict(tr.initial_velocities))


@dataclass
class TransientStep:
    """One stored time step (arrays over all coordinates / elements of each kind)."""

    time: float
    x: np.ndarray
    v: np.ndarray
    a: np.ndarray
    mu: np.ndarray
    iterations: int
    residual: float
    kinetic_energy: float
    elastic_energy: float
    external_work: float
    dissipated_energy: float
    deformation: dict                        # element keyword -> (n_elem, n_def)
    stress: dict                             # keyword -> (n_elem, n_def) stress resultants

    @property
    def energy_balance(self) -> float:
        """T + U + D - W (D the energy the damping dissipated): constant up to the
        integration error."""
        return (self.kinetic_energy + self.elastic_energy + self.dissipated_energy
                - self.external_work)


@dataclass
class TransientResult:
    steps: list = field(default_factory=list)
    static: object = None                    # the StaticResult of START static
    n_steps_taken: int = 0                   # integration steps (adaptive: accepted ones)
    n_rejected: int = 0                      # steps rejected by the error control
    problem: StaticProblem | None = None
    wall_time: float = 0.0
    n_newton: int = 0
    n_matrices: int = 0                      # Newton iteration matrices formed


class Residual(NamedTuple):
    """The equations of motion evaluated at one (t, x, v, a, mu), see
    :meth:`TransientProblem.residual`."""

    ev: object                   # the static part (an equilibrium Evaluation)
    blocks: list                 # mass blocks per inertia batch
    f_in: np.ndarray             # (n_coord,) inertia and damping forces
    r: np.ndarray                # force residual over the free coordinates
    res: float                   # scaled residual norm
    floor: float                 # its round-off floor
    load: LoadState
    f_damp: np.ndarray | None    # (n_coord,) damping forces, None without damping
    damp_blocks: dict            # velocity derivative of the damping per element group
    level: float                 # force level of this state


def alpha_parameters(rho_inf: float) -> tuple[float, float, float, float]:
    """(alpha_m, alpha_f, gamma, beta) of the generalized-alpha method for a spectral radius
    rho_inf at infinite frequency (Chung & Hulbert 1993)."""
    if not 0.0 <= rho_inf <= 1.0:
        raise ValueError(f"rho_inf must lie in [0, 1], got {rho_inf}")
    am = (2 * rho_inf - 1) / (rho_inf + 1)
    af = rho_inf / (rho_inf + 1)
    gamma = 0.5 + af - am
    beta = 0.25 * (gamma + 0.5) ** 2
    return am, af, gamma, beta


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
        self.level = 0.0                 # largest force level of the accepted states
        # the exact inertia tangent, switched on for the rest of the run at the first
        # iteration whose residual fell by less than a factor 10 (see _newton_step)
        self.exact_tangent_on = False
        self.frame_on = False            # the step's rotating frame (frame_rate)
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

        The frame follows the model's fitted rotation once it turns by more than
        ``FRAME_MIN_TURN`` per step, at a rate that rises smoothly from zero there to the
        fitted rate at ``FRAME_FULL_TURN`` times that turn: any rate is an exact change of
        variables, and a frame switched on at once would change the scheme from one step
        to the next and kick the stiff axial modes, which nothing damps at ``RHOINF 1``."""
        if not self.opts.rotating_frame or not self.frame.usable:
            return None
        fit = self.frame.fit_above(x, v, FRAME_MIN_TURN / h)
        if fit is None:                  # surely turns by less than FRAME_MIN_TURN
            return None
        omega, centre, velocity = fit
        turn = math.sqrt(float(omega @ omega)) * h
        if turn <= FRAME_MIN_TURN:
            return None
        motion = self.frame.motion(omega, centre, velocity)
        if not self.frame_on:
            log.info("the model turns by %.3g rad per step: the steps are taken in a "
                     "frame turning with it", turn)
            self.frame_on = True
        s = min((turn - FRAME_MIN_TURN) / ((FRAME_FULL_TURN - 1) * FRAME_MIN_TURN), 1.0)
        # the rate scaled, the axis kept (the screw axis' point and slide do not change)
        return motion._replace(omega=s * s * (3 - 2 * s) * motion.omega)

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
        phi, dphi, ddphi = self.opts.phi(t)
        idx, x = self.num.prescribed_state(1.0, phi)
        eps = 1e-4
        _, xp = self.num.prescribed_state(1.0, phi + eps)
        _, xm = self.num.prescribed_state(1.0, phi - eps)
        d1 = (xp - xm) / (2 * eps)
        d2 = (xp - 2 * x + xm) / eps**2
        v, a = d1 * dphi, d2 * dphi**2 + d1 * ddphi
        n = self.num.prescribed_idx.size             # the INPUTX part comes first
        if n and self.num.prescribed_rate.size:
            dx, dv, da = self.num.input_motion(t)
            x[:n] += dx
            v[:n] += dv
            a[:n] += da
        return idx, x, v, a

    def rigid_rates(self, t: float):
        """(rate, second derivative) of the rigid-mode targets at time t: the prescribed
        deformations' ``phi'(t) delta`` and ``phi''(t) delta`` plus the 5-field INPUTE
        motion's; (n_rigid,) each."""
        _, dphi, ddphi = self.opts.phi(t)
        num = self.num
        if not num.rigid_prescribed.size:
            z = np.zeros(num.n_rigid)
            return z, z
        _, dv, da = num.input_motion(t, rigid=True)
        return num.rigid_delta * dphi + dv, num.rigid_delta * ddphi + da

    def loads(self, t: float) -> LoadState:
        """The load at time t: XF and gravity, ``phi(t)`` times DELXF, and the prescribed
        deformations at ``phi(t)`` (plus the motion of the 5-field INPUTE lines)."""
        if self._load_at is not None and self._load_at[0] == t:
            return self._load_at[1]                  # a step's iterations share its time
        load = self.prob.loads.at(1.0, self.opts.phi(t)[0])
        if self.num.rigid_rate.size:                 # 5-field INPUTE: + v0 t + a0 t^2/2
            load = replace(load, rigid_target=load.rigid_target
                           + self.num.input_motion(t, rigid=True)[0])
        self._load_at = (t, load)
        return load

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
        load = self.loads(t)
        ev = self.prob.evaluate(x, mu, load)
        blocks, f_in = self.inertia.forces(x, v, a,
                                           blocks=mass_blocks or bool(self.model.damping[0]))
        f_damp, damp_blocks = self.damping_forces(x, v, ev.states, blocks)
        if f_damp is not None:
            f_in = f_in + f_damp                   # (damping counted with the inertia)
        r = ev.r + f_in[self.free_idx]
        level = self.prob.force_level(ev.f_ext, ev.f_int, f_in)
        ref = max(self.level, level if trial_level is None else trial_level)
        res, floor = self.prob.residual_norm(r, ev.c, None, None, level=ref if ref > 0 else 1.0)
        return Residual(ev, blocks, f_in, r, res, floor, load, f_damp, damp_blocks, level)

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

    def driving_force(self, ev, f_in):
        """Generalized force the loads, gravity and prescribed motions exert (n_coord,):
        f_ext on the free coordinates, the reaction (f_int + inertia - f_ext) on the
        prescribed ones; its work over a step is the work done on the model."""
        out = ev.f_ext.copy()
        idx = self.presc_idx
        if idx.size:
            out[idx] = (ev.f_int + f_in)[idx]
        return out


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
            or model.initial_rates:
        v = _initial_velocities(tp, x, v, opts.initial_velocities)
    a, mu = _initial_acceleration(tp, x, v, mu, ap0)
    am, af, gamma, beta = alpha_parameters(opts.rho_inf)
    a_tilde = a.copy()
    start = tp.residual(0.0, x, v, a, mu)
    ev, f_in, res = start.ev, start.f_in, start.res
    tp.accept_level(start.level)
    work = dissipated = 0.0
    p_damp = tp.damping_power(x, v, start.f_damp)
    q_prev = tp.driving_force(ev, f_in)

    def store(t, x, v, a, mu, its, res, ev, blocks):
        deformation, stress = prob.element_results(ev)
        step = TransientStep(time=t, x=x.copy(), v=v.copy(), a=a.copy(), mu=mu.copy(),
                             iterations=its, residual=res,
                             kinetic_energy=tp.inertia.kinetic_energy(x, v, blocks),
                             elastic_energy=tp.elastic_energy(ev.states), external_work=work,
                             dissipated_energy=dissipated,
                             deformation=deformation, stress=stress)
        result.steps.append(step)
        if on_step is not None:
            on_step(step)

    store(0.0, x, v, a, mu, 0, res, ev, start.blocks)
    h_out = opts.t_end / opts.n_steps
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
            x_new, v_new, a_new, at_new, mu_new, its, res, ev, f_in, f_damp, blocks = out
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
            v, a, a_tilde = v_new, a_new, at_new
            q_new = tp.driving_force(ev, f_in)
            work += 0.5 * float((q_prev + q_new) @ (x_new - x))
            # prescribed deformations (INPUTE) do work sigma * d(target) through their
            # multipliers (the stress resultants that impose them)
            presc = num.rigid_prescribed
            if presc.size and presc.any():
                dt_target = (tp.loads(t + h).rigid_target - tp.loads(t).rigid_target)
                work += 0.5 * float(((mu + mu_new)[:num.n_rigid] * dt_target)[presc].sum())
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
        store(t_target, x, v, a, mu, its, res, ev, blocks)
        if progress is not None:
            progress(t_target, opts.t_end)
    result.wall_time = time.perf_counter() - t_wall
    result.n_matrices = tp.n_matrices
    return result


def _initial_velocities(tp, x, v, given: dict):
    """The deck's VELOCITY lines (a position node's velocity, an orientation node's angular
    velocity in global axes: dq/dt = 1/2 (0, w) q), made consistent with the constraints:
    the velocities closest to the given ones (Euler-parameter rates weighted by the length
    scale squared) with ``C v = 0``; the coordinates without a VELOCITY line follow the
    constraints (a weight 1e-6 only keeps the system regular); prescribed velocities are
    kept.

    The rigid modes move at the rates of their targets (INPUTE's velocity, DELINPE times
    phi'(0)). With STARTDE lines every flexible (DYNE) mode is a degree of freedom whose
    rate is given, as in SPACAR: the STARTDE rate, or zero; the released (RLSE) modes and
    the other coordinates follow."""
    num, prob, free = tp.num, tp.prob, tp.free
    model = tp.model
    pos_row, rot_row = node_rows(model)
    v0 = v.copy()
    target = np.zeros(num.n_coord, dtype=bool)
    for n, value in given.items():
        w = np.asarray(value, dtype=float)
        if int(n) in pos_row:
            v0[num.pos_idx[pos_row[int(n)]]] = w
            target[num.pos_idx[pos_row[int(n)]]] = True
        else:
            ri = num.rot_idx[rot_row[int(n)]]
            target[ri] = True
            q = x[ri]
            v0[ri] = 0.5 * np.concatenate([[-w @ q[1:]], q[0] * w + np.cross(w, q[1:])])
    ev = prob.evaluate(x, np.zeros(num.n_constraint), tp.loads(0.0))
    n_x = prob.pattern.n_x
    C = tp.constraint_jacobian(ev)
    fixed_part = np.where(free, 0.0, v0)
    rhs_c = -_constraint_rates(prob, x, fixed_part)               # prescribed velocities
    rhs_c[:num.n_rigid] += tp.rigid_rates(0.0)[0]                 # driven deformations
    if model.initial_rates:                                       # STARTDE
        E, rates = _flexible_rows(tp, ev.states, model.initial_rates)
        rhs_e = rates - _flexible_rows(tp, ev.states, {}, fixed_part)[1]
        C = sp.vstack([C, E], format="csc")
        rhs_c = np.concatenate([rhs_c, rhs_e])
    weight = (np.where(prob.rot_mask[free], num.length_scale ** 2, 1.0)
              * np.where(target[free], 1.0, 1e-6))
    big = sp.bmat([[sp.diags(weight), C.T], [C, None]], format="csc")
    try:
        sol = spla.splu(big).solve(np.concatenate([weight * v0[free], rhs_c]))
    except RuntimeError:
        sol = None
    if sol is None or not np.all(np.isfinite(sol)):
        raise SpacarError("the initial velocities (VELOCITY, STARTDE, the rates of INPUTX/"
                          "INPUTE) cannot be met: the flexible modes and the constraints are "
                          "not independent (a statically indeterminate model), or they "
                          "contradict each other")
    out = v0.copy()
    out[free] = sol[:n_x]
    return out


def _flexible_rows(tp, states, given: dict, v=None):
    """The rows ``D_k`` (over the unknowns) of every flexible mode and their target rates
    (``given[(element, mode)]`` or 0); with ``v`` the rates ``D_k v`` instead of the
    targets."""
    num = tp.num
    rows, cols, vals, targets = [], [], [], []
    n_row = 0
    for g, st in zip(num.groups, states):
        el, mode = np.nonzero(g.def_class == FLEXIBLE)
        if not el.size:
            continue
        d = st.D[el, mode]                                      # (n_f, n_ldof)
        if v is not None:
            targets.append(np.einsum("nj,nj->n", d, v[g.idx[el]]))
        else:
            targets.append(np.array([given.get((int(g.ids[e]), int(k) + 1), 0.0)
                                     for e, k in zip(el, mode)]))
        unk = num.unknown_of[g.idx[el]]                          # (n_f, n_ldof)
        keep = unk >= 0
        r = np.broadcast_to(n_row + np.arange(el.size)[:, None], unk.shape)
        rows.append(r[keep])
        cols.append(unk[keep])
        vals.append(d[keep])
        n_row += el.size
    if not n_row:
        return sp.csc_matrix((0, num.n_unknown)), np.zeros(0)
    E = sp.coo_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                      shape=(n_row, num.n_unknown)).tocsc()
    return E, np.concatenate(targets)


def _error_norm(tp, h, beta, a_tilde_old, a_tilde_new, x, tol) -> float:
    """Largest local error of a step relative to the tolerance ``abs + rel |x|`` over the
    free coordinates that carry mass (positions in m, Euler parameters as they are).

    Coordinates without mass (a rod's massless end node, the length of an Euler-parameter
    vector) are algebraic: their accelerations follow the constraints, not the dynamics,
    and the integrator's recurrences let them oscillate from step to step whatever the step
    size, so they say nothing about the local error and are left out."""
    free = tp.free
    d = tp.inertia.physical(x, a_tilde_new - a_tilde_old)        # no radial Euler part
    e = h * h * abs(beta - 1.0 / 6.0) * d[free]
    massive = tp.mass_diagonal[free] > 1e-12 * max(float(tp.mass_diagonal.max()), 1e-300)
    scale = tol[0] + tol[1] * np.abs(x[free])
    return float(np.abs(e / scale)[massive].max(initial=0.0))


def _initial_acceleration(tp: TransientProblem, x, v, mu, a_presc, t: float = 0.0):
    """Consistent accelerations and multipliers at time t (default 0) from
    ``[M C^T; C 0] [a; mu] = [f - f_el - h - M_fp a_p; -(C_p a_p + (dC/dt) v - c_tt)]``;
    zero accelerations (and the given multipliers) when the mass matrix is singular on the
    constraint null space (massless coordinates)."""
    num, free, prob = tp.num, tp.free, tp.prob
    a = np.zeros(num.n_coord)
    a[tp.presc_idx] = a_presc
    ev = prob.evaluate(x, np.zeros_like(mu), tp.loads(t))       # no constraint forces
    blocks, f_in = tp.inertia.forces(x, v, a)                     # h + M_fp a_p
    M = tp.inertia.assemble(blocks)
    rhs_f = -(ev.f_int - ev.f_ext + f_in)[free]
    n_x = prob.pattern.n_x
    C = tp.constraint_jacobian(ev)
    c_acc = _constraint_rates(prob, x, a)                         # C_p a_p
    if np.any(v):                                                 # (dC/dt) v
        eps = 1e-6 / float(np.abs(v).max())
        c_acc += (_constraint_rates(prob, x + eps * v, v)
                  - _constraint_rates(prob, x - eps * v, v)) / (2 * eps)
    if num.rigid_prescribed.size:                                 # driven deformations
        c_acc[:num.n_rigid] -= tp.rigid_rates(t)[1]
    big = sp.bmat([[M[free][:, free], C.T], [C, None]], format="csc")
    try:
        sol = spla.splu(big).solve(np.concatenate([rhs_f, -c_acc]))
    except RuntimeError:
        sol = None
    if sol is None or not np.all(np.isfinite(sol)):
        log.info("massless coordinates: the initial accelerations start at zero")
        return a, mu
    a[free] = sol[:n_x]
    return a, sol[n_x:]


def _constraint_rates(prob, x, v):
    """``C(x) v`` for all constraints (rigid modes and Euler normalizations)."""
    num = prob.num
    rates = []
    for g in num.groups:
        st = g.kind.state(x[g.idx], g.ref, prob.variant, g.prev)
        d = np.einsum("nkj,nj->nk", st.D, v[g.idx])
        rates.append(d[g.rigid_elem, g.rigid_mode])
    q = x[num.euler_coords]
    qd = v[num.euler_coords]
    rates.append(2.0 * np.sum(q * qd, axis=1))
    return np.concatenate(rates)


def _gauge(num, x, v, a, a_tilde):
    """Give the Euler parameters' radial rates their exact values, in place.

    The length of q is a gauge freedom (the orientation is that of q/|q|); its constraint
    ``q.q = 1`` is kept at position level, but the integrator's recurrences for the radial
    velocity and acceleration are only marginally stable (a two-step oscillation that small
    time steps amplify). Their exact values follow from the constraint: ``q.dq = 0`` and
    ``q.ddq = -|dq|^2``; setting them after every step removes the drift without touching
    the orientation or the angular velocity.
    """
    ri = num.euler_coords
    if not ri.size:
        return
    q = x[ri]
    v[ri] = qd = tangent_part(q, v[ri])
    qq = (q * q).sum(axis=1, keepdims=True)
    centripetal = -(qd * qd).sum(axis=1, keepdims=True) / qq
    for acc in (a, a_tilde):
        acc[ri] += (centripetal - (q * acc[ri]).sum(axis=1, keepdims=True) / qq) * q


def _simplified_norm(prob, kept, ev, x, r) -> float:
    """Size (:meth:`StaticProblem.increment_norm`) of the simplified Newton increment at the
    state (x, ``ev``) with the force residual r (over the free coordinates): the last
    iteration matrix's factorization (``kept``, a :class:`KeptMatrix`) applied to the new
    residual (Deuflhard's simplified Newton correction), an estimate of the increment that
    state still needs, for one solve instead of a new tangent, factorization and residual;
    inf where there is no estimate."""
    step = None if kept is None else kept.chord(ev, x, r)
    if step is None or not np.all(np.isfinite(step[0])):
        return np.inf
    return prob.increment_norm(step[0])


@dataclass
class KeptMatrix:
    """A step's factorized iteration matrix, kept for its chord (modified Newton)
    iterations and the simplified Newton increment."""

    m_max: float                     # largest entry of the mass blocks it was formed with
    solve: Callable                  # (ev, x, r over the free coordinates) -> (dx, dmu)|None

    def chord(self, ev, x, r):
        """The increment ``(dx over the free coordinates, dmu)`` this matrix gives for the
        residual r at the state (x, ``ev``), or None where its solve fails."""
        return self.solve(ev, x, r)

    def floor(self, beta_p: float, length_scale: float, level: float) -> float:
        """Round-off floor of the force residual: the inertia term beta' M of the iteration
        matrix times the round-off of the coordinates (as the static solver's floor with
        its stiffness)."""
        return (100 * np.finfo(float).eps * beta_p * self.m_max * length_scale
                / max(level, 1e-300))


def _increment_fault(tp, dx, dmu) -> str | None:
    """What is wrong with a Newton increment (not finite, or an Euler-parameter change above
    0.5), or None: a new matrix's increment then fails the step, a chord increment drops
    the kept matrix."""
    if not (np.all(np.isfinite(dx)) and np.all(np.isfinite(dmu))):
        return "non-finite Newton increment"
    if np.abs(dx[tp.free_rot]).max(initial=0.0) > 0.5:
        return "Newton increment too large"
    return None


def _iteration_matrix(tp, opts, slow_newton, t1, x1, v1, a1, mu1, ev, r, blocks,
                      damp_blocks, motion, W, beta_p, gamma_p) -> tuple[KeptMatrix, tuple]:
    """Form and factorize the iteration matrix at (x1, v1, a1, mu1): the tangent-space
    LDL^T of the static solver (solvers/statics/reduced.py) where it applies, else the bordered
    SuperLU. ``slow_newton``: the last Newton increment reduced the residual by less than
    SLOW_CONTRACTION (switches the exact inertia tangent on). Returns the matrix and its
    Newton increment ``(dx, dmu)`` for the residual r."""
    num, prob = tp.num, tp.prob
    n_x = prob.pattern.n_x
    tp.n_matrices += 1
    blocks = tp.inertia.complete(x1, blocks)             # the mass blocks
    m_max = max([float(np.abs(b).max(initial=0.0)) for b in blocks] + [0.0])
    # iteration matrix [K_t + beta' M, C^T; C, 0] on the Newton matrix's fixed pattern;
    # the constraint rows scaled like its largest entry (the inertia term grows as
    # 1/h^2), which keeps the saddle-point system well conditioned
    # beta' M + gamma' C: the Rayleigh alpha M rides on the mass blocks, the stiffness-
    # proportional and deformation-rate damping are element blocks
    # with the exact tangent: + d(M a + h)/dx + gamma' d h/dv (solvers/dynamics/inertia.py), not
    # symmetric, so the bordered system below takes it (the reduced step's LDL^T needs
    # a symmetric matrix)
    # The tangent costs kernel evaluations and the LDL^T path; where the former matrix
    # converges quadratically anyway (no fast rotation) it brings nothing. So it is taken
    # from the first iteration whose residual fell by less than SLOW_CONTRACTION on
    # (Newton without it converges linearly there), and then for the rest of the run.
    if opts.exact_tangent and not tp.exact_tangent_on and slow_newton:
        tp.exact_tangent_on = True
        log.info("the convective inertia terms slow Newton down at t = %.6g s: the "
                 "exact iteration matrix is used from here on", t1)
    if motion is not None and opts.exact_tangent:
        tp.exact_tangent_on = True   # the frame's W terms are not symmetric anyway
    c_h = [] if motion is not None else None
    tangent = (tp.inertia.tangent(x1, v1, a1, gamma_p, velocity_part=c_h)
               if opts.exact_tangent and tp.exact_tangent_on else None)
    exact = tangent is not None and any(t is not None for t in tangent)
    extra, nodal = tp.inertia.iteration_parts(
        blocks, beta_p + gamma_p * tp.model.damping[0], tangent)
    for i, cb in damp_blocks.items():
        extra[i] = extra.get(i, 0.0) + gamma_p * cb
    if prob.reduced is not None and nodal is None and not exact and motion is None:
        # the static solver's tangent-space step (solvers/statics/reduced.py) with the inertia
        # and damping blocks: no Euler multipliers, an LDL^T instead of SuperLU
        k_el, euler_diag, _ = prob.element_blocks(ev, mu1, extra=extra)
        r_full = np.zeros(num.n_coord)
        r_full[tp.free_idx] = r
        step = prob.reduced.step(ev, x1, mu1, k_el, euler_diag, residual=r_full,
                                  invariant=False)
        if step is not None:
            last = prob.reduced.last

            def solve(ev, x, r):                    # the tangent-space LDL^T's
                full = np.zeros(num.n_coord)
                full[tp.free_idx] = r
                return prob.reduced.chord(last, ev, x, residual=full)
            return KeptMatrix(m_max, solve), step
    scale = max(prob.scale, beta_p * m_max)
    S = prob.matrix(ev, mu1, extra=extra, scale=scale)
    if motion is not None:
        coriolis = tp.frame_terms(blocks, c_h, W, gamma_p)
        nodal = coriolis if nodal is None else nodal + coriolis
    if nodal is not None:
        S = S + _padded(nodal, S.shape[0])
    try:
        lu = spla.splu(S, permc_spec="COLAMD")
    except RuntimeError:
        raise StepFailed("singular iteration matrix") from None

    def solve(ev, x, r):                                # the bordered SuperLU's
        dz = lu.solve(-np.concatenate([r, scale * ev.c]))
        return dz[:n_x], dz[n_x:] * scale
    return KeptMatrix(m_max, solve), solve(ev, x1, r)


def _padded(a, n: int) -> sp.csc_matrix:
    """``block_diag([a, 0])`` of size n (n x n, ``a`` in its leading block), made from a's
    arrays without scipy's ``block_diag`` (a COO round trip: 0.5 ms a call)."""
    a = sp.csc_matrix(a)
    indptr = np.concatenate([a.indptr, np.full(n - a.shape[1], a.indptr[-1])])
    return sp.csc_matrix((a.data, a.indices, indptr), shape=(n, n))


def _step(tp: TransientProblem, t, h, x, v, a, a_tilde, mu, params, opts):
    """One generalized-alpha step from t to t + h (Arnold & Brüls 2007)."""
    am, af, gamma, beta = params
    num, free, prob, fi = tp.num, tp.free, tp.prob, tp.free_idx
    t1 = t + h
    motion = tp.frame_rate(x, v, h)
    if motion is None:
        yd, ydd, aty = v, a, a_tilde
    else:
        # the step in the frame turning with the model (solvers/dynamics/frame.py):
        # y = x at its start
        yd, ydd, aty = tp.frame.to_frame(motion, x, v, a, a_tilde)
    at_new = (af * ydd - am * aty) / (1 - am)          # a_tilde with a_{n+1} = 0
    # predictor: the accelerations extrapolated linearly from the last two steps, which
    # leaves Newton a residual 3 to 30 times smaller than a_{n+1} = 0 does; but not where
    # the exact inertia tangent is on (fast rotation, a turning frame): there Newton from
    # such a predictor overshoots (measured: 3.2 -> 4.3 iterations per step), from
    # a_{n+1} = 0 it converges quadratically
    smooth = not tp.exact_tangent_on and motion is None
    a1 = np.zeros_like(a)
    if smooth:
        a1 += a
        if tp.previous_acceleration is not None:
            h_prev, a_prev = tp.previous_acceleration
            a1 += (h / h_prev) * (a - a_prev)
    at_pred = at_new + (1 - af) / (1 - am) * a1
    x1 = x + h * yd + h * h * (0.5 - beta) * aty + h * h * beta * at_pred
    v1 = yd + h * (1 - gamma) * aty + h * gamma * at_pred
    W = None
    if motion is not None:
        x1, v1, a1 = tp.frame.from_frame(motion, h, x1, v1, a1)
        W = tp.frame.matrix(motion.omega, free)
    idx, xp, vp, ap = tp.prescribed(t1)
    if idx.size:
        x1[idx], v1[idx], a1[idx] = xp, vp, ap
    # (no normalization of the predicted Euler parameters: Newton's correction of q.q = 1
    # must pass through the velocity and acceleration updates, which gives them their
    # centripetal radial parts)
    mu1 = mu.copy()
    beta_p = (1 - am) / (h * h * beta * (1 - af))
    gamma_p = gamma / (h * beta)
    dx_norm = np.inf
    history = []
    trial_level = None               # the force level of the step's predictor
    floor_dyn = 0.0                  # round-off floor of the inertia forces (iteration 0)
    kept = None                      # the step's last iteration matrix (KeptMatrix)
    chord_ok = opts.reuse_matrix and not tp.fresh_only and smooth
    last_chord = False               # whether the last increment came from a kept matrix
    used_chord = False
    for it in range(opts.max_iter + 1):
        ev, blocks, f_in, r, res, floor, _, f_damp, damp_blocks, level = tp.residual(
            t1, x1, v1, a1, mu1, trial_level, mass_blocks=False)
        trial_level = level if trial_level is None else trial_level
        history.append(res)
        if not np.isfinite(res):
            raise StepFailed("non-finite residual", history, chord=used_chord)
        # converged: residual and last increment below the tolerance, or a residual so far
        # below it that the equations hold to round-off (the increments of directions the
        # residual hardly sees, such as Euler parameters of nearly massless nodes, may then
        # stall above the tolerance without meaning anything)
        # A residual below the tolerance whose last increment was not yet is tested by the
        # simplified Newton increment (the last factorization applied to this residual:
        # one solve, where a full iteration costs a tangent, a factorization and another
        # residual), which estimates the increment this state still needs
        if it > 0 and res <= max(opts.tol, floor, floor_dyn) and (
                dx_norm <= max(opts.tol, 1e-13) or res <= 1e-3 * opts.tol
                or _simplified_norm(prob, kept, ev, x1, r) <= max(opts.tol, 1e-13)):
            if motion is None:
                a_tilde_new = at_new + (1 - af) / (1 - am) * a1
            else:
                y1, yd1, ydd1 = tp.frame.back(motion, h, x1, v1, a1)
                a_tilde_new = tp.frame.from_frame(
                    motion, h, y1, yd1, at_new + (1 - af) / (1 - am) * ydd1)[2]
            _gauge(num, x1, v1, a1, a_tilde_new)
            tp.accept_level(level)
            tp.fresh_only = False
            return x1, v1, a1, a_tilde_new, mu1, it, res, ev, f_in, f_damp, blocks
        if it == opts.max_iter:
            break
        # Chord iterations: the step's iteration matrix serves again while each of its
        # increments reduces the residual by KEEP_CONTRACTION at least (or the next one
        # at that rate reaches the tolerance); a new one is formed where it does not. A
        # chord iteration costs a residual and one solve, a Newton iteration also the
        # tangent, the mass blocks and a factorization.
        if (last_chord and history[-1] > KEEP_CONTRACTION * history[-2]
                and history[-1] ** 2 > opts.tol * history[-2]):
            kept = None
        fresh_last = it > 0 and not last_chord
        step = None
        if kept is not None and chord_ok:
            step = kept.chord(ev, x1, r)
            if step is None or _increment_fault(tp, *step):
                step = kept = None
        last_chord = step is not None
        used_chord = used_chord or last_chord
        if step is None:
            slow_newton = (fresh_last and it >= 2
                           and history[-1] > SLOW_CONTRACTION * history[-2] > 0.0)
            try:
                kept, step = _iteration_matrix(
                    tp, opts, slow_newton, t1, x1, v1, a1, mu1, ev, r, blocks,
                    damp_blocks, motion, W, beta_p, gamma_p)
            except StepFailed as fail:
                raise StepFailed(fail.reason, history, chord=used_chord) from None
            if it == 0:
                floor_dyn = kept.floor(beta_p, num.length_scale, tp.level)
            fault = _increment_fault(tp, *step)
            if fault:
                raise StepFailed(fault, history, chord=used_chord)
        dx, dmu = step
        dx_norm = prob.increment_norm(dx)
        x1[fi] += dx
        v1[fi] += gamma_p * dx
        a1[fi] += beta_p * dx
        if motion is not None:
            wd = W @ dx
            v1[fi] += wd
            a1[fi] += 2 * gamma_p * wd + W @ wd
        mu1 = mu1 + dmu
    hist = ", ".join(f"{v:.2e}" for v in history)
    raise StepFailed(f"no convergence in {opts.max_iter} iterations (residuals {hist})",
                     history, chord=used_chord)


__all__ = ["TimeFunction", "TIME_FUNCTIONS", "TransientOptions", "TransientStep",
           "TransientResult", "TransientProblem", "alpha_parameters", "solve_transient"]
