"""A branch switch keeps the path on the branch the structure is on (issue 20, the
leaf-spring sweep): where the path from a stored step to the next stays stable when followed
in small sub-steps, the next stored step is where that continuation ends, not the mirror
image the switch's trials may find first."""
from pathlib import Path

import numpy as np
import pytest

from spacarpy.deck import load
from spacarpy.solvers.path.stability import stability
from spacarpy.solvers.statics.newton import Predictor, newton
from spacarpy.solvers.statics.static import StaticOptions, solve_static

DECKS = Path(__file__).resolve().parents[1] / "decks"


@pytest.mark.slow
@pytest.mark.parametrize("phi", ["0.0008", "0.0012"])
def test_stored_steps_follow_the_stable_branch_they_are_on(phi):
    """phi = 0.0008 and 0.0012 buckle (the mirror pair of equal energy) a step before the
    last load; the step after it lands on an unstable equilibrium. Followed in 16 sub-steps
    from each stored step, every sub-step that stays stable (index 0) must end at the next
    stored step to the Newton tolerance; before session 9's change the switch took the mirror
    image there (positions 0.6-1.3 % away)."""
    job = load(DECKS / "leafspring_guidance_sweep.dat", overrides={"phi": phi})
    res = solve_static(job.model, job.settings)
    prob = res.problem
    opts = StaticOptions.from_settings(job.settings)
    checked = 0
    for a, b in zip(res.steps, res.steps[1:]):
        x, mu = a.x.copy(), a.mu.copy()
        pred = Predictor(prob)
        pred(x, mu, prob.loads.at(1.0, a.load_factor))
        stable = True
        for j in range(1, 17):
            load_j = prob.loads.at(1.0, a.load_factor + j / 16 * (b.load_factor - a.load_factor))
            start, states = pred.with_states(x, mu, load_j)
            x, mu, *_ = newton(prob, start, mu, load_j, opts, states)
            x = prob.normalize(x)
            stable = stable and stability(prob, x, mu, load_j).index == 0
        if stable:
            checked += 1
            assert np.abs(x - b.x).max() <= 1e-8 * np.abs(b.x).max(), (a.load_factor,
                                                                       b.load_factor)
    assert checked >= 8          # all but the step over the limit point and the buckle
