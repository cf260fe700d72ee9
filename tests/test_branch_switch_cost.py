"""The cost of the leaf-spring sweep's Newton iterations (issue 20): the kinematic correction
of a closed loop stops at its least-squares point instead of confirming it with extra
factorizations and kernel evaluations, and the path it gives is the same."""
import logging
from pathlib import Path

import numpy as np
import pytest

from spacarpy.deck import load
from spacarpy.solvers.statics.equilibrium import StaticProblem
from spacarpy.solvers.statics.kinematic_correction import NormalEquations
from spacarpy.solvers.statics.static import solve_static

DECKS = Path(__file__).resolve().parents[1] / "decks"


def _solve(job, stationary_check: bool, caplog):
    prob = StaticProblem(job.model, deformations=job.settings.deformations)
    assert isinstance(prob.corrector.system, NormalEquations)      # a closed loop
    if not stationary_check:
        prob.corrector._stationary = lambda *a: False
    caplog.clear()
    with caplog.at_level(logging.DEBUG, logger="spacarpy.solvers.statics.kinematic_correction"):
        res = solve_static(job.model, job.settings, problem=prob)
    evaluations = sum(r.getMessage().startswith("kinematic correction: mismatch")
                      for r in caplog.records)
    return res, evaluations


@pytest.mark.parametrize("phi", ["0.0005", "0.0007"])
def test_closed_loop_correction_stops_at_its_least_squares_point(phi, caplog):
    """Newton's targets for a closed loop's deformations are consistent to first order
    only, so the Gauss-Newton mismatch stalls at the least-squares fit. There the
    correction stops (the next step is below round-off) instead of refactorizing twice:
    the same iterations per load step, the same positions to round-off, and a quarter or
    more fewer kernel evaluations in the correction."""
    job = load(DECKS / "leafspring_guidance_sweep.dat", overrides={"phi": phi})
    (new, n_new), (old, n_old) = (_solve(job, check, caplog) for check in (True, False))
    assert [s.iterations for s in new.steps] == [s.iterations for s in old.steps]
    x_new = np.array([s.x for s in new.steps])
    x_old = np.array([s.x for s in old.steps])
    assert np.abs(x_new - x_old).max() <= 1e-13 * np.abs(x_old).max()
    assert n_new < 0.8 * n_old, (n_new, n_old)
