"""The index of the reduced tangent proven by two shifted LDL^T factorizations with a
componentwise backward-error bound (spacarpy/solvers/path/inertia_bracket.py, docs/path.md,
Limits): the perfect column at 10^3 elements before and after its Euler load, where the
normwise bound of the eigenvalues nearest zero decides nothing."""
from __future__ import annotations

import re

import numpy as np
import pytest
import scipy.sparse as sp

from spacarpy.deck import job_from_text
from spacarpy.solvers.linalg.certificate import certified_sign
from spacarpy.solvers.path.inertia_bracket import certified_index, spectral_radius_bound
from spacarpy.solvers.path.stability import near_zero
from spacarpy.solvers.statics.static import solve_static


def test_the_collatz_wielandt_bound_is_above_the_spectral_radius_and_near_it():
    rng = np.random.default_rng(5)
    for n in (5, 40, 300):
        a = sp.random(n, n, density=0.05, random_state=rng)
        a = abs(a + a.T) + sp.identity(n)
        rho = float(np.linalg.eigvalsh(a.toarray()).max())
        got = spectral_radius_bound(lambda v: a @ v, n)
        assert rho <= got <= 1.05 * rho


def _straight_column(factor: float):
    """The perfect 10^3-element column of tests/test_critical_meshes.py under ``factor``
    times its load (1.5 P_E) in one load step: it stays straight (no imperfection)."""
    from spacarpy.bench.cases import arclength_column_deck
    text = arclength_column_deck(1000, imperfection=0.0)
    text = re.sub(r"^ARCLENGTH .*\n", "", text, flags=re.M)
    load = re.search(r"^DELXF 2001 (\S+) 0 0$", text, flags=re.M)
    text = text.replace(load.group(0), f"DELXF 2001 {float(load.group(1)) * factor!r} 0 0")
    job = job_from_text(text, "<column>")
    res = solve_static(job.model, job.settings)
    prob, step = res.problem, res.steps[-1]
    return prob, step.x, step.mu, prob.loads.at(1.0, 1.0)


@pytest.mark.parametrize("factor, index", [(0.35, 0), (0.75, 2)])
def test_the_index_of_the_perfect_column_at_1000_elements_is_proven(factor, index):
    """Below the Euler load (2/3 of the deck's) no negative eigenvalue, above it two (the
    double Euler mode): the eigenvalues nearest zero, 2.5e-13 and -7.1e-14 of the scaled
    tangent, lie within their normwise bound (3.1e-11), the bracket's bound is 3.7e-14."""
    prob, x, mu, load = _straight_column(factor)
    lam, bound = near_zero(prob, x, mu, load)
    assert np.any(certified_sign(lam, bound) == 0)          # the normwise bound: undecided
    got, cert = certified_index(prob, x, mu, load)
    assert got == index
    assert cert.decided and 1e-14 < cert.bound < 1e-13 and cert.margin < 2 * cert.bound
