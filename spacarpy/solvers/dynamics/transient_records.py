"""The records of a transient: its options (TransientOptions), one time step's output
(TransientStep), the run's result (TransientResult), the residual parts (Residual) and the
generalized-alpha parameters of RHOINF (alpha_parameters)."""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from spacarpy.settings import AnalysisSettings
from spacarpy.solvers.statics.equilibrium import StaticProblem
from spacarpy.solvers.statics.loads import LoadState
from spacarpy.time_functions import TimeFunction

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
    #: the named time functions (TIMEFUNCTION name kind p...): name -> TimeFunction, of the
    #: load increments and prescribed motions that LOADTF gives them
    named_phi: dict = field(default_factory=dict)
    error: tuple | None = None               # ERROR (abs, rel): adaptive step size
    deformations: str = "modified"
    rotary_inertia: str = "lumped"           # ROTARYINERTIA: the beams' section inertia
    initial_velocities: dict = field(default_factory=dict)   # node -> (3,) VELOCITY
    #: the derivatives of the inertia forces (convective terms, dM/dx a) in the Newton
    #: matrix; False leaves them out (the former iteration matrix: linear convergence at
    #: high angular velocity, kept to measure the difference)
    exact_tangent: bool = True
    #: take each step in a frame turning with the model once it has turned by more than
    #: FRAME_ON_ANGLE (solvers/dynamics/frame.py); False: always in the global frame (the
    #: former scheme, unstable with little numerical damping at fast rotation)
    rotating_frame: bool = True
    #: a step's later Newton iterations reuse its iteration matrix while that contracts
    #: (chord iterations); False forms a new one at every iteration
    reuse_matrix: bool = True
    #: update the Euler parameters on the rotation group (solvers/dynamics/lie.py: exact
    #: for a constant angular velocity) in the steps taken in the global frame; False: the
    #: linear update of all coordinates (the former scheme, kept to measure the difference)
    lie_group: bool = True
    #: a user routine's prescribed motion (USERINP): ``user_motion(t) -> (idx, x, v, a)``
    #: for input coordinates ``idx`` (global coordinate numbers), replacing the deck's
    #: values of those coordinates; its ``deformations(t)`` (if any) likewise for the
    #: prescribed deformations (:meth:`user_deformations`)
    user_motion: object = None

    def named_values(self, t: float) -> dict:
        """(phi, phi', phi'') at t of the deck's time function (key None) and of each named
        one (LOADTF)."""
        out = {None: self.phi(t)}
        for name, f in self.named_phi.items():
            out[name] = f(t)
        return out

    def motion_phi(self, t: float, names: tuple) -> np.ndarray:
        """(3, n): phi, phi', phi'' at t of the time function of each of n motions
        (``names``: a LOADTF name, or None for the deck's function)."""
        values = self.named_values(t)
        return np.array([values[name] for name in names], dtype=float).reshape(-1, 3).T

    def prescribed_phi(self, t: float, num) -> tuple:
        """(phi of the INPUTX coordinates, phi of the INPUTR nodes, phi' and phi'' of the
        prescribed coordinates) at t: the deck's function's values, or arrays of each
        motion's own where LOADTF names some (:meth:`Numbering.prescribed_state`'s order)."""
        if not (num.prescribed_tf or num.rotation_tf):
            phi, dphi, ddphi = self.phi(t)
            return phi, phi, dphi, ddphi
        ps, pr = (self.motion_phi(t, tf) for tf in (num.prescribed_tf, num.rotation_tf))
        return (ps[0], pr[0], *(np.concatenate([ps[k], np.repeat(pr[k], 4)])
                                for k in (1, 2)))

    def user_deformations(self, t: float):
        """(rigid-mode constraint rows, e, e', e'') of the prescribed deformations a USERINP
        routine drives at time t, or None."""
        return getattr(self.user_motion, "deformations", lambda t: None)(t)

    def rigid_rates(self, t: float, num):
        """(rate, second derivative) of the rigid-mode targets of ``num`` at time t: the
        prescribed deformations' ``phi'(t) delta`` and ``phi''(t) delta`` (each deformation's
        own function where LOADTF names one), the 5-field INPUTE motion's and a USERINP
        routine's; (n_rigid,) each."""
        if not num.rigid_prescribed.size:
            z = np.zeros(num.n_rigid)
            return z, z
        _, dphi, ddphi = self.motion_phi(t, num.rigid_tf) if num.rigid_tf else self.phi(t)
        _, dv, da = num.input_motion(t, rigid=True)
        rate, accel = num.rigid_delta * dphi + dv, num.rigid_delta * ddphi + da
        if (user := self.user_deformations(t)) is not None:
            rate[user[0]], accel[user[0]] = user[2], user[3]
        return rate, accel

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
                   named_phi={name: TimeFunction(*f) for name, f in tr.named_time_functions},
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
    #: reactions of the fixed and prescribed coordinates (StaticProblem.reactions' order;
    #: inertia and damping forces included): N, N m
    reaction: np.ndarray = field(default_factory=lambda: np.zeros(0))
    #: how the step's last integration step was accepted: "tolerance" (its residual met
    #: the tolerance) or "floor" (within its round-off floor measured at that state, the
    #: increments converged); step 0 (the initial state) is "tolerance"
    converged_by: str = "tolerance"
    #: element keyword -> (n_elem, n_def) deformation rates D v (a WHEEL's slip modes:
    #: the slip velocities)
    deformation_rate: dict = field(default_factory=dict)
    # the WHEELs' lift_off and friction_ratio per element (solvers/statics/contact.py), and
    # the lift-off warning of the step (None: none, or the lift-off goes on from the last)
    contact: dict = field(default_factory=dict)
    warning: str | None = None

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


