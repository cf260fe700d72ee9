"""The arc-length corrector's two linear solvers (spacarpy/solvers/path/arclength.py): the
tangent-space LDL^T of spacarpy/solvers/statics/reduced.py, used where the only constraints are
Euler
normalizations, and the bordered system by SuperLU (the fallback). Both solve the same Newton
equations exactly, so on a small column they must give the same path points and the same
critical points; the determinant sign taken from the LDL^T's negative pivots,
``(-1)^(m + index)`` (m constraint rows), must equal the bordered LU determinant's sign, and
the pivot count must equal the dense reduced tangent's index."""
from __future__ import annotations

import numpy as np
import pytest

import spacarpy.solvers.path.arclength as arclength
from spacarpy.solvers.path.arclength import determinant_sign, point_at
from spacarpy.solvers.path.stability import stability
from spacarpy.solvers.statics.static import StaticProblem, solve_static

from helpers import perfect_column, perfect_column_path


def _run(monkeypatch, use_reduced: bool):
    monkeypatch.setattr(arclength, "USE_REDUCED", use_reduced)
    model, settings = perfect_column()
    prob = StaticProblem(model)
    assert prob.reduced is not None          # the case where the two solvers differ
    return prob, settings, solve_static(model, settings, problem=prob)


@pytest.mark.slow
def test_both_solvers_give_the_same_path_and_critical_points(monkeypatch):
    _, _, red = _run(monkeypatch, True)
    _, _, lu = _run(monkeypatch, False)
    assert len(red.steps) == len(lu.steps)
    for a, b in zip(red.steps, lu.steps):
        assert a.load_factor == pytest.approx(b.load_factor, abs=1e-8)
        assert np.max(np.abs(a.x - b.x)) < 1e-8
    crit_red = [(k, st.critical) for k, st in enumerate(red.steps) if st.critical is not None]
    crit_lu = [(k, st.critical) for k, st in enumerate(lu.steps) if st.critical is not None]
    assert [k for k, _ in crit_red] == [k for k, _ in crit_lu] and len(crit_red) == 1
    (_, a), (_, b) = crit_red[0], crit_lu[0]
    assert a.kind == b.kind == 2
    assert a.load_factor == pytest.approx(b.load_factor, abs=1e-8)
    assert a.load_factor == pytest.approx(1 / 1.5, rel=1e-5)
    assert np.max(np.abs(a.shape - b.shape)) < 1e-6


@pytest.mark.slow
def test_ldl_pivots_give_the_determinant_sign_and_the_index(monkeypatch):
    """Along the perfect column without switching (it stays straight: index 0 before the
    bifurcation, 1 after it)."""
    monkeypatch.setattr(arclength, "USE_REDUCED", True)
    prob, path, steps = perfect_column_path(setting="warn")
    seen = set()
    for step in steps:
        p = point_at(path, step)
        neg = path.reduced.negative_pivots
        assert p.lu is None and neg is not None       # the LDL^T gave the sign
        ev = prob.evaluate(p.x, p.mu, path.load(p.s))
        lu = path._solve(ev, p.mu, p.x, bordered=True)[4][0]
        assert (-1) ** ((path.m + neg) % 2) == determinant_sign(lu) == p.det
        assert neg == stability(prob, p.x, p.mu, path.load(p.s)).index
        assert neg == (0 if p.s < 1 / 1.5 else 1)
        seen.add(neg)
    assert seen == {0, 1}
