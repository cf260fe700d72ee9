"""The driver of inverse dynamics (SPACAR mode 2, analysis ``inverse_dynamics``): the
prescribed motion's time steps from :mod:`spacarpy.solvers.dynamics.inverse`, each appended
to ``/transient`` as soon as it is computed, with mode 1's names and units plus the
accelerations (docs/transient.md, "Inverse dynamics")."""
from __future__ import annotations

import logging

from spacarpy.errors import EXIT_INPUT, SpacarError

log = logging.getLogger(__name__)


class InverseInputError(SpacarError):
    """The deck asks inverse dynamics for something it cannot do (no TIMESTEP)."""

    exit_code = EXIT_INPUT


def check_inverse(settings, problem) -> None:
    """Refuse what inverse dynamics cannot run, before the result file is made: no TIMESTEP,
    ARCLENGTH, a model its inputs do not determine (:func:`~spacarpy.solvers.dynamics.
    inverse.determinacy_error`); say what it ignores (the integrator's settings)."""
    from spacarpy.solvers.dynamics.inverse import determinacy_error
    tr = settings.transient
    if tr.timestep is None or tr.timestep[1] < 1:
        raise InverseInputError("MODE inverse_dynamics (SPACAR 2) needs the time span: "
                                "TIMESTEP t_end n_steps in the data module")
    if settings.static.arclength is not None:
        raise InverseInputError("ARCLENGTH follows a static path: it has no place in MODE "
                                "inverse_dynamics (remove it)")
    ignored = [name for name, used in (("START static", tr.start == "static"),
                                       ("ERROR", tr.error_tol is not None),
                                       ("SUBSTEPS", tr.substeps != 1),
                                       ("VELOCITY", bool(tr.initial_velocities)))
               if used]
    err = determinacy_error(problem)
    if err is not None:
        raise err
    if ignored:
        log.warning("MODE inverse_dynamics computes every time step from the prescribed "
                    "motion (no time integration): %s ignored", ", ".join(ignored))


def run_inverse(model, settings, problem, writer, summary, progress=None) -> None:
    """Solve the time steps of TIMESTEP and write each to ``/transient`` (``writer`` made
    with ``begin_static(transient=True, accelerations=True)``)."""
    from spacarpy.solvers.dynamics.inverse import solve_inverse
    from spacarpy.solvers.dynamics.transient_records import TransientOptions
    num = problem.num
    opts = TransientOptions.from_settings(settings)
    n_steps = opts.n_steps
    width = len(str(n_steps))

    def on_step(step):
        writer.transient_step(
            time=step.time, position=step.x[num.pos_idx], euler=step.x[num.rot_idx],
            velocity=step.v[num.pos_idx], euler_rate=step.v[num.rot_idx],
            acceleration=step.a[num.pos_idx], euler_acceleration=step.a[num.rot_idx],
            deformation=step.deformation, stress_resultant=step.stress,
            kinetic_energy=step.kinetic_energy, elastic_energy=step.elastic_energy,
            external_work=step.external_work, iterations=step.iterations,
            residual=step.residual, dissipated_energy=step.dissipated_energy,
            reaction=step.reaction, deformation_rate=step.deformation_rate)
        k = summary.n_time
        summary.n_time += 1
        if k % max(n_steps // 20, 1) == 0 or k == n_steps:
            log.info(f"time step {k:>{width}}/{n_steps}  t = {step.time:.6g} s  "
                     f"{step.iterations:2d} iterations  residual {step.residual:.2e}  "
                     f"kinetic energy {step.kinetic_energy:.6g} J")

    result = solve_inverse(model, opts, on_step=on_step, progress=progress, problem=problem)
    summary.newton_iterations = result.n_newton
    summary.integration_steps = result.n_steps_taken


__all__ = ["InverseInputError", "check_inverse", "run_inverse"]
