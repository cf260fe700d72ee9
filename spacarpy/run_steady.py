"""The drivers of mode 3 for models with slips (docs/rolling.md).

With ``TIMESTEP 0 0`` the linearized equations about the initial steady motion
(:mod:`spacarpy.solvers.linear.steady_motion`) written to one result file (the state at t = 0
as the one row of /transient: positions, velocities, deformations, the constraint forces as
stress resultants, the WHEEL contact forces among them; its linearization in /state_space with
the kinematic states, the inputs and outputs and the poles); along a trajectory,
:class:`SlipTrajectory`, the same linearization at each stored step of the transient run."""
from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np

from spacarpy.elements.registry import KINDS
from spacarpy.errors import EXIT_INPUT, SpacarError
from spacarpy.model import RIGID
from spacarpy.solvers.linear.state_space import StateSpace
from spacarpy.solvers.linear.steady_motion import SteadyMotion
from spacarpy.version import __version__

log = logging.getLogger(__name__)

#: Projected residual at the initial state, relative to its largest force, above which the
#: state is not a steady motion (a warning).
STEADY_TOL = 1e-8

__all__ = ["SlipTrajectory", "SteadyInputError", "has_held_slips", "run_steady_motion"]


class SteadyInputError(SpacarError):
    """The deck asks mode 3 for something the steady-motion linearization does not do."""

    exit_code = EXIT_INPUT


@dataclass
class _SteadyStateSpace(StateSpace):
    """Mode 9's state space plus the kinematic blocks of a steady motion."""

    K0p: np.ndarray
    G: np.ndarray
    Gq: np.ndarray
    Gp: np.ndarray


def has_held_slips(model) -> bool:
    """Whether the model holds slips (a WHEEL rolling without slip)."""
    return any(
        (es.def_class[:, list(KINDS[kw].velocity_modes)] == RIGID).any()
        for kw, es in model.elements.items() if KINDS[kw].velocity_modes and es.ids.size)


def _state_space(mm) -> _SteadyStateSpace:
    return _SteadyStateSpace(M0=mm.M0, C0=mm.C0, K0=mm.K0, B0=mm.B0, A=mm.A, B=mm.B, C=mm.C,
                             D=mm.D, K0p=mm.K0p, G=mm.G, Gq=mm.Gq, Gp=mm.Gp)


def _names(mm, settings) -> dict:
    """The /state_space names: the degrees of freedom, the state ``[q; q'; p]``, the inputs
    and outputs, the kinematic states."""
    parts = [name.split() for name in mm.dof_names]     # "BEAM 3 2" or "DYNX 4 1"
    dynx = [w[0] == "DYNX" for w in parts]
    labels = [f"node {w[1]} coordinate {w[2]}" if d else f"{w[0]} {w[1]} mode {w[2]}"
              for w, d in zip(parts, dynx)]
    extra = ({"dof_node": [int(w[1]) if d else 0 for w, d in zip(parts, dynx)]}
             if any(dynx) else {})
    lin = settings.linearized
    return dict(dof_element=[0 if d else int(w[1]) for w, d in zip(parts, dynx)],
                dof_mode=[int(w[2]) for w in parts], **extra,
                state_name=labels + [f"rate of {s}" for s in labels] + mm.kinematic_names,
                input_name=lin.input_names, output_name=lin.output_names,
                kinematic_name=mm.kinematic_names)


class SlipTrajectory:
    """Mode 3 along a trajectory with slips: called with each stored transient step, the
    linearized equations about that state (:meth:`~spacarpy.solvers.linear.steady_motion.
    SteadyMotion.at_state`: q'' from the equations of motion there), the state
    ``[q; q'; p]`` with the kinematic coordinates, as with ``TIMESTEP 0 0``."""

    def __init__(self, model, settings, problem=None):
        from spacarpy.solvers.dynamics.transient import TransientOptions
        self.problem = problem          # the transient's: its committed hinge turns
        lin = settings.linearized
        self.sm = SteadyMotion(model, deformations=settings.deformations,
                               rotary_inertia=settings.rotary_inertia,
                               options=TransientOptions.from_settings(settings),
                               inputs=lin.inputs, outputs=lin.outputs)
        self.names = _names(self.sm, settings)

    def __call__(self, step) -> _SteadyStateSpace:
        prev = [g.prev for g in self.problem.num.groups] if self.problem is not None else None
        self.sm.at_state(step.time, step.x, step.v, prev)
        return _state_space(self.sm.matrices())


def _multipliers(sm: SteadyMotion, x, force):
    """The constraint multipliers (mu in the numbering's order, nu of the held slips) that
    balance ``force = M a + h - f`` over the free coordinates (least squares; exact at a
    steady motion, whose projected residual vanishes)."""
    num, free = sm.num, sm.free
    st = sm._states(x)
    rows = []
    for gi, g in enumerate(num.groups):
        for r, m in zip(g.rigid_elem, g.rigid_mode):
            rows.append(sm._mode_rows([(gi, int(r), int(m))], st)[0])
    eu_rows, _ = sm._euler_rows(x)
    S = sm.slips.jacobian(x).toarray() if sm.slips.n else np.zeros((0, num.n_coord))
    J = np.vstack([np.array(rows).reshape(-1, num.n_coord), eu_rows, S])[:, free]
    lam = np.linalg.lstsq(J.T, -force[free], rcond=None)[0]
    return lam[:num.n_constraint], lam[num.n_constraint:]


def run_steady_motion(model, settings, out, summary) -> None:
    """Linearize ``model`` about its initial steady motion and write ``out``."""
    from spacarpy.results import ResultsWriter
    from spacarpy.results.model_data import model_datasets
    from spacarpy.solvers.statics.nonholonomic import check_kinematic

    lin = settings.linearized
    sm = SteadyMotion(model, deformations=settings.deformations,
                      rotary_inertia=settings.rotary_inertia, inputs=lin.inputs,
                      outputs=lin.outputs)
    prob, num = sm.prob, sm.num
    mm = sm.matrices()
    try:
        np.linalg.cholesky(mm.M0)
    except np.linalg.LinAlgError:
        weak = [name for name, m in zip(mm.dof_names, np.diag(mm.M0)) if not m > 0]
        raise SteadyInputError(
            "the linearization about a steady motion needs inertia in every degree of "
            f"freedom, but the mass matrix is singular there ({', '.join(weak or mm.dof_names)})"
            ": give XM masses and inertias (or EM for the beams)") from None
    n = mm.M0.shape[0]
    ss = _state_space(mm)
    x, v, a, _, _ = sm.motion(sm.q0, sm.dq0, sm.p0)
    force = sm._force(x, v, a)
    mu, nu = _multipliers(sm, x, force)
    load = sm.load
    ev = prob.evaluate(x, mu, load)
    deformation, stress = prob.element_results(ev)
    stress = {key: val.copy() for key, val in stress.items()}
    for i, (kw, e, m) in enumerate(zip(sm.slips.keywords, sm.slips.ids, sm.slips.modes)):
        g = next(g for g in num.groups if g.keyword == kw)
        sign = getattr(g.kind, "stress_sign", ()) or (1.0,) * g.kind.n_def   # as statics
        stress[kw][int(np.flatnonzero(g.ids == e)[0]), int(m) - 1] = nu[i] * sign[int(m) - 1]
    mass_v = sm._force(x, v, a + v) - force                       # M v
    kinetic = 0.5 * float(v @ mass_v)
    f_in = sm.tp.inertia.forces(x, v, a, blocks=False)[1]
    reaction = prob.reactions(x, ev.f_int + f_in, ev.f_ext)    # inertia included
    projected = float(np.abs(sm.evaluate(sm.q0, sm.dq0, sm.p0)[:n]).max(initial=0.0))
    level = float(np.abs(force).max(initial=0.0))
    if projected > STEADY_TOL * max(level, 1e-300):
        log.warning("the initial state is not a steady motion: with q'' = 0 the equations of "
                    "the degrees of freedom leave %.3g (of forces up to %.3g); the matrices "
                    "linearize about a state that does not persist", projected, level)
    names = _names(mm, settings)
    model_data = model_datasets(model, num)
    with ResultsWriter(out, model, program_version=__version__, model_data=model_data,
                       deformations=settings.deformations, analysis=settings.analysis,
                       rotary_inertia=settings.rotary_inertia) as writer:
        writer.begin_static(model.position_ids.size, model.orientation_ids.size,
                            prob.reaction_node, prob.reaction_component, transient=True,
                            state_space=names)
        check_kinematic(prob)
        writer.transient_step(
            time=0.0, position=x[num.pos_idx], euler=x[num.rot_idx], warping=x[num.warp_idx],
            velocity=v[num.pos_idx], euler_rate=v[num.rot_idx], deformation=deformation,
            stress_resultant=stress, kinetic_energy=kinetic, elastic_energy=0.0,
            external_work=0.0, iterations=0, residual=projected, reaction=reaction)
        writer.state_space_step(0, ss, time=0.0)
        writer.finish()
    summary.n_time = 1
