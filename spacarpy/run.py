"""Analysis driver: one model, one analysis, one result file.

Ties the pieces together for ``spacarpy run``: static load stepping, and at the requested
load steps the linearized analyses (eigenfrequencies, buckling multipliers), each step
appended to the results file as soon as it is computed.

Analyses
--------
static
    Load steps of ITERSTEP; with ``modes_per_step`` also frequencies (if the model has mass)
    and buckling multipliers (if it is loaded) at every step.
static_linearized (SPACAR 10)
    The static path with, at every step, the frequencies and buckling multipliers (as
    ``modes_per_step``) and the linearized equations of state_space below (M0, C0, K0, B0 and
    A, B, C, D; with no INPUTF/OUT* lines B0, B, C, D have no columns/rows). A model without
    mass, or without SPACAR's degrees of freedom, stores no /state_space (a warning says why).
eigen (SPACAR 4/7)
    The static load path (if any), then natural frequencies and mode shapes about the final
    state (about every step with ``modes_per_step``).
buckling (SPACAR 8)
    The static load path, then the load multipliers about the final state (every step with
    ``modes_per_step``). The multiplier applies to the whole load acting in that state.

state_space (SPACAR 9)
    The static load path, and at every stored step the linearized equations in the degrees
    of freedom (M0, C0, K0, B0) and the first-order system A, B, C, D of the deck's INPUTF
    and OUT* lines (:mod:`spacarpy.solvers.linear.state_space`).

With ``compliance_node`` any of them also stores the 6x6 compliance of that node wherever it
linearizes (for a static run: the final step, or every step with ``modes_per_step``).

transient (SPACAR 1)
    With START static the static load path first (stored in /static), then the time
    integration of TIMESTEP (:mod:`spacarpy.solvers.dynamics.transient`), every time step
    appended to /transient as it is computed.
transient_linearized (SPACAR 3)
    The transient, and at every stored time step the linearized equations about the state
    of the trajectory (:mod:`spacarpy.solvers.dynamics.trajectory`) in /state_space, whose ``step``
    is the row of /transient and ``time`` its time.
inverse_dynamics (SPACAR 2)
    The input forces and reactions of a fully prescribed motion at the times of TIMESTEP,
    in /transient (:mod:`spacarpy.run_inverse`).
"""
from __future__ import annotations

import logging
from dataclasses import dataclass, field, replace

import numpy as np

from spacarpy.elements.registry import KINDS
from spacarpy.errors import EXIT_INPUT, ModelError, SpacarError
from spacarpy.job import Job
from spacarpy.model import RIGID, Model
from spacarpy.settings import AnalysisSettings
from spacarpy.solvers.linear.linearize import MassAssembler, linearize
from spacarpy.solvers.statics.equilibrium import StaticProblem
from spacarpy.solvers.statics.static import solve_static
from spacarpy.version import __version__

log = logging.getLogger(__name__)


class AnalysisInputError(SpacarError):
    """The requested analysis cannot be run on this model (missing mass, not supported)."""

    exit_code = EXIT_INPUT


@dataclass
class RunOptions:
    """How to run, beyond the analysis settings: ``compliance_node``: (position node,
    orientation node) deck numbers whose 6x6 compliance is computed at every linearized step;
    ``progress``: a callback of the transient run; ``ignore_conditioning``: only warn where
    the residual's round-off floor exceeds its limit
    (:func:`~spacarpy.solvers.statics.conditioning.check_residual_floor`);
    ``allow_user_code``, ``user_modules``: the deck's user routines (spacarpy.user_routines);
    ``step_progress``: a callback of the static path, ``step_progress(k, n_steps)`` after
    every stored load step (``k`` = 0 is the initial state; an ARCLENGTH path: its points and
    n_max)."""

    compliance_node: tuple | None = None
    progress: object = None          # transient: progress(t, t_end), e.g. a terminal bar
    step_progress: object = None     # static path: step_progress(k, n_steps)
    ignore_conditioning: bool = False
    #: the deck's user routines (USERSIG, USERINP) run only when allowed (--allow-user-code),
    #: found beside the deck or in these files/folders (--user-module)
    allow_user_code: bool = False
    user_modules: tuple = ()


@dataclass
class RunSummary:
    n_steps: int = 0
    report: str = ""                                    # MODE check: the readable report
    frequencies: list = field(default_factory=list)     # per linearized step
    critical: list = field(default_factory=list)
    n_time: int = 0                                     # transient: stored time steps
    integration_steps: int = 0
    rejected_steps: int = 0
    newton_iterations: int = 0


#: The analyses that impose held slips (rolling without slip): statics and the
#: linearizations at rest (modes 10, 4, 7, 8, 9), the transient and mode 3 (about the initial
#: steady motion or along a transient: docs/rolling.md).
SLIP_ANALYSES = ("static", "eigen", "buckling", "state_space", "static_linearized",
                 "transient", "transient_linearized")


def refuse_velocity_modes(model: Model, analysis: str) -> None:
    """Refuse a model with velocity-level (non-holonomic) modes, the WHEEL's slips, in an
    analysis that does not handle them: one line (a :class:`ModelError`) rather than a wrong
    result.

    Held slips (rolling without slip, the default) are imposed by statics and the
    linearizations at rest, the transient and mode 3 (:data:`SLIP_ANALYSES`), not yet by
    the others.
    Released ones (``RLSE e 4 5``, sliding freely) leave a purely holonomic model, but its
    stored slip deformations (the accumulated slip) would not be integrated: refused too."""
    for keyword, es in model.elements.items():
        modes = list(KINDS[keyword].velocity_modes)
        if not modes or not es.ids.size:
            continue
        held = es.def_class[:, modes] == RIGID
        numbers = " ".join(str(k + 1) for k in modes)
        if held.all() and analysis in SLIP_ANALYSES:
            continue
        if held.any() and analysis not in SLIP_ANALYSES:
            row = int(np.flatnonzero(held.any(axis=1))[0])
            raise ModelError(f"{keyword} slips (non-holonomic constraints) are not supported "
                             f"in MODE {analysis} yet ({keyword} {es.ids[row]} modes "
                             f"{numbers} are held: rolling without slip)")
        raise ModelError(f"{keyword} elements are not supported in MODE {analysis} yet: no "
                         f"solver integrates the released slips (modes {numbers}) of "
                         f"{keyword} {es.ids[0]}")


def run_job(job: Job, out, options: RunOptions | None = None) -> RunSummary:
    """Run a job (:func:`spacarpy.deck.load`): ``run_model(job.model, job.settings, ...)``."""
    return run_model(job.model, job.settings, out, options)


def run_in_memory(job: Job, out=None, options: RunOptions | None = None):
    """Run a job and return its results as views (:class:`~spacarpy.results.reader.
    ResultsFile`): with ``out``, the file written there, opened; without, the results in
    memory (:class:`~spacarpy.results.in_memory.InMemoryResults`; the run writes a temporary
    file, which is read into memory and removed). The run's :class:`RunSummary` is the
    ``summary`` attribute of what is returned. MODE check writes no results: it returns its
    :class:`RunSummary` (``report``)."""
    import os
    import tempfile

    from spacarpy.results.in_memory import InMemoryResults
    from spacarpy.results.reader import open_results
    if job.settings.analysis == "check":
        return run_job(job, os.devnull, options)
    if out is not None:
        summary = run_job(job, out, options)
        res = open_results(out)
        res.summary = summary
        return res
    with tempfile.TemporaryDirectory(prefix="spacarpy-run-") as tmp:
        path = os.path.join(tmp, "results.h5")
        summary = run_job(job, path, options)
        with open(path, "rb") as f:
            image = f.read()
    name = os.path.basename(job.model.source_path or "") or "model"
    res = InMemoryResults(image, f"<memory: {name}>")
    res.summary = summary
    return res


def run_model(model: Model, settings: AnalysisSettings, out,
              options: RunOptions | None = None) -> RunSummary:
    """Run ``settings.analysis`` on ``model`` and write ``out`` (crash-safe, see
    :mod:`spacarpy.results`)."""
    from spacarpy.results import ResultsWriter
    from spacarpy.results.model_data import model_datasets
    from spacarpy.results.stress import SurfaceStress

    opts = options or RunOptions()
    from spacarpy.user_routines import refuse_unless_allowed
    refuse_unless_allowed(model, opts.allow_user_code)      # before any work
    n_modes = settings.linearized.count
    analysis = settings.analysis
    static_lin = analysis == "static_linearized"          # SPACAR mode 10
    inverse = analysis == "inverse_dynamics"                # SPACAR mode 2
    modes_per_step = (settings.linearized.modes_each_step or static_lin) and not inverse
    slips_along = False
    if analysis == "transient_linearized":                  # mode 3 (docs/rolling.md)
        from spacarpy.run_steady import has_held_slips, run_steady_motion
        slips_along = has_held_slips(model)
        if settings.transient.timestep == (0.0, 0):         # about the initial state
            summary = RunSummary()
            run_steady_motion(model, settings, out, summary)
            return summary
    elif settings.transient.timestep == (0.0, 0) and analysis == "transient":
        raise AnalysisInputError("TIMESTEP 0 0 asks for the linearization about the initial "
                                 "state: it needs MODE 3; a transient needs TIMESTEP t_end "
                                 "n_steps")
    if analysis != "check":                                 # mode 0 reports the slips
        refuse_velocity_modes(model, analysis)
    problem = StaticProblem(model, deformations=settings.deformations)
    num = problem.num
    if analysis == "check":
        from spacarpy.solvers.statics.kinematic_check import dof_report
        return RunSummary(report=dof_report(problem))
    if inverse:                  # before the result file: the settings, a determinate model
        from spacarpy.run_inverse import check_inverse
        check_inverse(settings, problem)
    if problem.loads.any:
        from spacarpy.solvers.statics.conditioning import check_residual_floor
        check_residual_floor(problem, ignore=opts.ignore_conditioning)
    user_motion = None       # (the floor above is the deck's loads')
    if model.user_routines:
        from spacarpy.user_routines import loaded_routines
        user_loads, user_motion = loaded_routines(model, num, analysis, model.source_path,
                                                  opts.user_modules)
        if user_loads is not None:
            problem.loads.set_user(user_loads)
            problem.reduced = None      # (its tangent-space steps assume dead loads)
    mass = MassAssembler(model, num, rotary=settings.rotary_inertia)
    # (a deck's model: the deck reader has warned already, naming the GRAVITY line)
    if any(model.gravity) and not mass.has_mass and model.source_path == "<model>":
        log.warning("GRAVITY has no effect: the model has no mass (EM lines for the elements, "
                    "XM nodal masses)")
    transient = analysis in ("transient", "transient_linearized")
    if transient and settings.transient.timestep is None:
        raise AnalysisInputError(f"MODE {analysis} needs the time span: TIMESTEP t_end n_steps "
                                 "in the data module")
    if transient and not mass.has_mass:
        raise AnalysisInputError(f"MODE {analysis} needs mass: give EM lines for the elements "
                                 "(or XM nodal masses)")
    want_eigen = analysis == "eigen" or (modes_per_step and mass.has_mass)
    want_buckling = analysis == "buckling" or (modes_per_step and problem.loads.any)
    if analysis == "eigen" and not mass.has_mass:
        raise AnalysisInputError("MODE eigen needs mass: give EM lines for the beams (or XM "
                                 "nodal masses)")
    if analysis == "buckling" and not problem.loads.any:
        raise AnalysisInputError("MODE buckling needs a load (XF/DELXF): the multipliers "
                                 "scale the stresses that load causes")
    want_ss = analysis in ("state_space", "transient_linearized") or (static_lin
                                                                      and mass.has_mass)
    if static_lin and not mass.has_mass:
        log.warning("SPACAR mode 10 stores the linearized equations (/state_space) only for "
                    "a model with mass (EM lines, XM masses); this one has none, so it stores "
                    "the static path with buckling multipliers at every step")
    signals = settings.linearized.inputs + settings.linearized.outputs
    if signals and not want_ss:
        log.warning("the INPUTF/OUT* lines (%s) define the state space of MODE state_space "
                    "(SPACAR 9); this %s analysis does not use them", signals[0].name,
                    analysis)
    if want_ss and not mass.has_mass:
        raise AnalysisInputError(f"MODE {analysis} needs mass: give EM lines for "
                                 "the elements (or XM nodal masses)")
    want_compliance = opts.compliance_node is not None
    if want_compliance:
        p_node, r_node = (int(v) for v in opts.compliance_node)
        pos_hit = np.flatnonzero(model.position_ids == p_node)
        rot_hit = np.flatnonzero(model.orientation_ids == r_node)
        if not pos_hit.size or not rot_hit.size:
            raise AnalysisInputError(
                f"--compliance {p_node} {r_node}: expected a position node and an orientation "
                f"node of the model")
        compliance_rows = (int(pos_hit[0]), int(rot_hit[0]))
    n_eigen = _eigen_columns(problem, mass, n_modes) if want_eigen else 0
    n_steps = settings.static.iterstep.n_steps
    arc = settings.static.arclength if not transient else None
    if transient and settings.static.arclength is not None:
        raise AnalysisInputError("ARCLENGTH follows a static path: it cannot start a "
                                 "transient analysis (remove it, or use MODE static)")
    summary = RunSummary()

    ss_setup = None
    if slips_along:             # mode 3 with slips: the kinematic states (docs/rolling.md)
        from spacarpy.run_steady import SlipTrajectory
        along_slips = SlipTrajectory(model, settings, problem)
        ss_setup = (along_slips, along_slips.names)
    elif want_ss:
        try:
            ss_setup = _state_space_setup(problem, settings)
        except ModelError as exc:
            if not static_lin:
                raise
            log.warning("SPACAR mode 10: no linearized equations (/state_space) are stored: "
                        "%s", exc)
            want_ss = False
    model_data = model_datasets(model, num)
    surface_stress = SurfaceStress(model_data)
    with ResultsWriter(out, model, program_version=__version__, model_data=model_data,
                       deformations=settings.deformations, analysis=analysis,
                       rotary_inertia=settings.rotary_inertia) as writer:
        writer.begin_static(model.position_ids.size, model.orientation_ids.size,
                            problem.reaction_node, problem.reaction_component,
                            n_eigen_modes=n_eigen,
                            n_buckling_modes=n_modes if want_buckling else 0,
                            compliance_node=opts.compliance_node,
                            transient=transient or inverse, accelerations=inverse,
                            state_space=ss_setup[1] if want_ss else None,
                            arclength=arc is not None)
        from spacarpy.solvers.statics.nonholonomic import check_kinematic
        check_kinematic(problem)   # KINE/KINX against the slips, naming the lines (as the
        #                            static solver's kinematic check, after /model is written)

        def on_step(step):
            k = summary.n_steps
            writer.static_step(
                load_factor=step.load_factor, position=step.x[num.pos_idx],
                euler=step.x[num.rot_idx], warping=step.x[num.warp_idx],
                deformation=step.deformation,
                stress_resultant=step.stress,
                reaction=step.reaction, iterations=step.iterations, residual=step.residual,
                arc_length=step.arc_length, converged_by=int(step.converged_by == "floor"),
                stability=step.stability,
                **surface_stress(step.stress.get("BEAM")))
            summary.n_steps += 1
            if step.warning:
                writer.add_warning(step.warning)
            msg = step_line(k, n_steps, step, settings.static.iterstep.tol)
            if step.critical is not None:
                msg += _critical_point(num, problem.free, step, k, writer)
            if (want_eigen or want_buckling or want_compliance) and \
                    (modes_per_step or (k == n_steps and arc is None)):
                msg += _linearized_step(problem, mass, step, k, writer, n_modes, want_eigen,
                                        want_buckling,
                                        compliance_rows if want_compliance else None, summary)
            if want_ss and not transient:
                msg += _state_space_step(problem, mass, step, k, writer, settings, ss_setup[0])
            log.info(msg)
            if opts.step_progress is not None:
                opts.step_progress(k, arc.n_max if arc is not None else n_steps)

        if transient:
            _run_transient(model, settings, problem, writer, on_step, opts, summary,
                           ss_setup[0] if want_ss else None, user_motion)
        elif inverse:
            from spacarpy.run_inverse import run_inverse
            run_inverse(model, settings, problem, writer, summary, opts.progress)
        else:
            result = solve_static(model, settings, problem=problem, on_step=on_step)
            if arc is not None and not modes_per_step and result.steps and (
                    want_eigen or want_buckling or want_compliance):
                # an arc-length path ends where it ends: linearize about its last point
                k = summary.n_steps - 1
                log.info(f"point {k}:" + _linearized_step(
                    problem, mass, result.steps[-1], k, writer, n_modes, want_eigen,
                    want_buckling, compliance_rows if want_compliance else None, summary))
        writer.finish()
    return summary


def _run_transient(model, settings, problem, writer, on_static_step, opts, summary,
                   ss_layout=None, user_motion=None):
    from spacarpy.solvers.dynamics.transient import (
        TransientOptions,
        TransientProblem,
        solve_transient,
    )
    num = problem.num
    topts = replace(TransientOptions.from_settings(settings), user_motion=user_motion)
    along = None
    if callable(ss_layout):                     # SPACAR 3 with slips (run_steady.py)
        along = ss_layout
    elif ss_layout is not None:                 # SPACAR 3: linearize every stored time step
        from spacarpy.solvers.dynamics.trajectory import TrajectoryLinearizer
        along = TrajectoryLinearizer(TransientProblem(model, topts, problem), ss_layout,
                                     settings.linearized.inputs, settings.linearized.outputs)
    n_steps = topts.n_steps
    width = len(str(n_steps))

    def on_step(step):
        writer.transient_step(
            time=step.time, position=step.x[num.pos_idx], euler=step.x[num.rot_idx],
            warping=step.x[num.warp_idx],
            velocity=step.v[num.pos_idx], euler_rate=step.v[num.rot_idx],
            deformation=step.deformation,
            stress_resultant=step.stress,
            kinetic_energy=step.kinetic_energy, elastic_energy=step.elastic_energy,
            external_work=step.external_work, iterations=step.iterations,
            residual=step.residual, dissipated_energy=step.dissipated_energy,
            reaction=step.reaction,
            converged_by=int(step.converged_by == "floor"),
            deformation_rate=step.deformation_rate, contact=step.contact)
        if step.warning is not None:
            writer.add_warning(step.warning)
        k = summary.n_time
        if along is not None:
            writer.state_space_step(k, along(step), time=step.time)
        summary.n_time += 1
        if k % max(n_steps // 20, 1) == 0 or k == n_steps:
            log.info(f"time step {k:>{width}}/{n_steps}  t = {step.time:.6g} s  "
                     f"{step.iterations:2d} iterations  energy T + U - W = "
                     f"{step.energy_balance:.6g} J"
                     + (f"  residual {step.residual:.2e} (above the tolerance "
                        f"{topts.tol:.0e}, within its round-off floor measured at this "
                        "state; the increments are below the tolerance)"
                        if step.converged_by == "floor" else ""))

    result = solve_transient(model, topts, on_step=on_step, on_static_step=on_static_step,
                             settings=settings,
                             progress=opts.progress, problem=problem)
    summary.newton_iterations = result.n_newton
    summary.integration_steps = result.n_steps_taken
    summary.rejected_steps = result.n_rejected


def _eigen_columns(problem, mass, n_modes: int) -> int:
    """The modes stored per linearized step: ``n_modes``, or fewer when the model has fewer
    (:func:`spacarpy.solvers.linear.eigen.finite_mode_count` in the initial configuration; the
    number at each step is stored in /eigen/n_modes_available). Not counted where the
    eigen solver is the sparse one (a few modes of a larger model)."""
    from spacarpy.solvers.linear.eigen import default_dense_limit, finite_mode_count
    num = problem.num
    if num.n_unknown > default_dense_limit(num.n_unknown, n_modes):
        return n_modes
    lin = linearize(problem, num.x0.copy(), np.zeros(num.n_constraint),
                    problem.loads.unloaded(), mass=mass)
    count = finite_mode_count(lin, n_modes)
    if count is None:
        return n_modes
    n_available, n_dof = count
    if n_available < n_modes:
        without = n_dof - n_available
        log.info("the model has %d mode(s): %d degree(s) of freedom%s; %d asked for, %d stored "
                 "per step", n_available, n_dof,
                 f", {without} of them without inertia" if without else "", n_modes,
                 max(n_available, 1))
    if n_available == 0:
        log.warning("no mode: every degree of freedom of the model is without inertia")
    return max(min(n_modes, n_available), 1)


def _linearized_step(problem, mass, step, k, writer, n_modes, want_eigen, want_buckling,
                     compliance_rows, summary):
    # imported here: a run without linearized steps does not need them (start-up)
    from spacarpy.solvers.linear.buckling import buckling_modes
    from spacarpy.solvers.linear.compliance import nodal_compliance
    from spacarpy.solvers.linear.eigen import KIND_NAMES, eigenmodes
    num = problem.num
    lin = linearize(problem, step.x, step.mu, problem.loads.at(1.0, step.load_factor),
                    mass=mass if want_eigen else None)
    text = ""
    if compliance_rows is not None:
        c_glob, c_loc = nodal_compliance(lin, num, problem.free, *compliance_rows)
        writer.compliance_step(k, c_glob, c_loc)
    if want_eigen:
        md = eigenmodes(lin, num, problem.free, n_modes=n_modes)
        shape_pos, shape_rot = _node_shapes(num, problem.free, md.shape)
        writer.eigen_step(k, md.eigenvalue, md.frequency, md.kind, shape_pos, shape_rot,
                          n_available=-1 if md.n_available is None else md.n_available,
                          bound=np.nan if md.bound is None else md.bound)
        summary.frequencies.append(md.frequency)
        shown = ", ".join(f"{f:.4g}" if kd in (0, 2) else KIND_NAMES[int(kd)]
                          for f, kd in zip(md.frequency[:4], md.kind[:4]))
        text += f"  f [Hz]: {shown}"
    if want_buckling:
        bk = buckling_modes(lin, n_modes=n_modes)
        shape_pos, shape_rot = _node_shapes(num, problem.free, np.nan_to_num(bk.shape))
        writer.buckling_step(k, bk.multiplier, bk.critical, shape_pos, shape_rot, kind=bk.kind)
        summary.critical.append(bk.critical)
        text += (f"  critical load multiplier {bk.critical:.6g}" if np.isfinite(bk.critical)
                 else "  no finite buckling multiplier")
    return text


def _state_space_setup(problem, settings):
    """The degrees of freedom of the state space (chosen at the deck's configuration, so a
    model without SPACAR's degrees of freedom stops before any step) and the names the
    result file stores."""
    from spacarpy.solvers.linear.state_space import dof_layout
    num = problem.num
    lin = linearize(problem, num.x0.copy(), np.zeros(num.n_constraint),
                    problem.loads.at(1.0, 0.0))
    layout = dof_layout(lin, num, problem.free)
    lin_set = settings.linearized
    names = dict(**layout.file_names, state_name=layout.state_names,
                 input_name=lin_set.input_names, output_name=lin_set.output_names)
    return layout, names


def _state_space_step(problem, mass, step, k, writer, settings, layout) -> str:
    from spacarpy.solvers.linear.state_space import state_space
    lin = linearize(problem, step.x, step.mu, problem.loads.at(1.0, step.load_factor),
                    mass=mass)
    ss = state_space(lin, problem.num, problem.free, problem.model, layout,
                     settings.linearized.inputs, settings.linearized.outputs)
    writer.state_space_step(k, ss)
    return f"  state space: {ss.A.shape[0]} states, {ss.B.shape[1]} inputs, {ss.C.shape[0]} outputs"
def _critical_point(num, free, step, k, writer) -> str:
    """Store the critical point refined at stored step ``k`` and describe it."""
    from spacarpy.solvers.path.arclength import CRITICAL_KINDS
    cp = step.critical
    shape_pos, shape_rot = _node_shapes(num, free, cp.shape[:, None])
    writer.critical_step(k, cp.kind, cp.load_factor, cp.arc_length, shape_pos[0], shape_rot[0],
                         cp.margin, cp.bound)
    return (f"  <- {CRITICAL_KINDS[cp.kind]} at load factor {cp.load_factor:.10g} "
            f"(margin {cp.margin:.3g}, round-off bound {cp.bound:.3g})")


def step_line(k: int, n_steps: int, step, tol: float) -> str:
    """The progress line of stored load step ``k``. A step is also accepted when its residual
    stays above the tolerance within its round-off floor measured at that state while the
    increments are below the tolerance (solvers/statics/newton.py); the line then says so, so that
    a residual of 5e-4 beside a tolerance of 1e-9 is not read as a failed convergence."""
    if getattr(step, "arc_length", None) is not None:     # ARCLENGTH: points, not steps
        line = (f"point {k:>3}  arc length {step.arc_length:.4g}  load factor "
                f"{step.load_factor:.6f}  {step.iterations:2d} iterations  residual "
                f"{step.residual:.2e}")
    else:
        line = (f"step {k:>{len(str(n_steps))}}/{n_steps}  load factor "
                f"{step.load_factor:.4f}  {step.iterations:2d} iterations  residual "
                f"{step.residual:.2e}")
    if getattr(step, "converged_by", "tolerance") == "floor":
        line += (f" ({'above' if step.residual > tol else 'at'} the tolerance {tol:.0e}, "
                 "within its round-off floor measured at this state; the increments are "
                 "below the tolerance)")
    return line


def _node_shapes(num, free, shapes):
    """Free-coordinate shapes (n_x, n_mode) -> positions (n_mode, n_pos, 3) and Euler
    parameters (n_mode, n_rot, 4), zero on fixed coordinates."""
    full = np.zeros((shapes.shape[1], num.n_coord))
    full[:, free] = shapes.T
    return full[:, num.pos_idx], full[:, num.rot_idx]
