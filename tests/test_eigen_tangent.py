"""The sparse eigen solver in the tangent space of the Euler normalizations
(spacarpy/solvers/linear/eigen_tangent.py): the same modes as the dense solve and as the bordered
shift-invert solver it replaces, unloaded and loaded, accurate element-wise products, and
the fallback where the reduced tangent is not positive definite."""
from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

from spacarpy.bench.decks import eigen_cantilever_deck
from spacarpy.deck import model_from_text
from spacarpy.solvers.linear import eigen as E
from spacarpy.solvers.linear import eigen_tangent as ET
from spacarpy.solvers.linear.linearize import MassAssembler, linearize
from spacarpy.solvers.statics.static import StaticOptions, StaticProblem, solve_static


def _lin(text, loaded=False):
    model = model_from_text(text, "<eigen>")
    prob = StaticProblem(model)
    mass = MassAssembler(model, prob.num)
    if loaded:
        res = solve_static(model, problem=prob,
                           options=StaticOptions(max_iter=20, tol=1e-9, n_steps=5))
        st = res.steps[-1]
        lin = linearize(prob, st.x, st.mu, prob.loads.at(1.0, st.load_factor), mass=mass)
    else:
        lin = linearize(prob, prob.num.x0.copy(), np.zeros(prob.num.n_constraint),
                        prob.loads.at(0.0, 0.0), mass=mass)
    return prob, lin


def _loaded_deck(n):
    """The eigen cantilever under a quarter of Table 1's tip force (a deflection of about
    0.4 m: a stressed, strongly rotated state)."""
    from spacarpy.bench.cases import cantilever_deck
    text = cantilever_deck(n, n_steps=5, tol=1e-9, compact=True, shear=10.0)
    lines = [ln for ln in text.splitlines() if not ln.startswith("EXPECT")]
    text = "\n".join(lines).replace("MODE static", "MODE eigen")
    mass = eigen_cantilever_deck(n).split("\nEM ", 1)[1].split("\n", 1)[0]
    return text.replace(" 1293750 0", " 323437.5 0").replace(
        "ITERSTEP", f"EM {mass}\nITERSTEP", 1)


def _bordered(lin, prob, n_modes):
    """The bordered shift-invert solve with Rayleigh quotients (the solver before)."""
    lam, vec = E._sparse(lin, lin.K.shape[0], n_modes)
    lam = E._rayleigh(lin, prob.num, prob.free, lam, vec)
    return np.sort(lam.real)[:n_modes]


@pytest.mark.parametrize("loaded", [False, True], ids=["unloaded", "loaded"])
def test_tangent_modes_equal_the_dense_and_the_bordered_ones(loaded, monkeypatch):
    prob, lin = _lin(_loaded_deck(70) if loaded else eigen_cantilever_deck(70), loaded)
    assert lin.K.shape[0] > E.FEW_MODES_DENSE_LIMIT          # the sparse path
    found = ET.lowest_modes(lin, prob.num, 8)
    assert found is not None                                  # the tangent path applies
    dense = E.eigenmodes(lin, prob.num, prob.free, n_modes=8, dense_limit=10**6)
    bordered = _bordered(lin, prob, 8)

    def no_bordered(*a, **k):
        raise AssertionError("the bordered solver was called")
    monkeypatch.setattr(E, "_sparse", no_bordered)
    md = E.eigenmodes(lin, prob.num, prob.free, n_modes=8)
    # the dense solve's round-off on this pencil is about 1e-9 (test_solver_paths)
    np.testing.assert_allclose(md.frequency, dense.frequency, rtol=1e-8)
    # the bordered solver's Rayleigh quotients take the load part as assembled, and its
    # vectors from the shifted LU: in the loaded state they are up to 2.9e-8 off the dense
    # eigenvalues (the 8th mode; 3.7e-9 with other round-off of the same state's last
    # bits), the tangent solver's within 3e-9; a wrong load term would be 1e-3 off
    np.testing.assert_allclose(md.eigenvalue.real, bordered, rtol=1e-7)
    assert np.array_equal(md.kind, dense.kind)
    assert np.all(md.kind == E.ELASTIC)
    # mass-normalized shapes, K-orthogonal to the eigenvalues
    v = md.shape
    np.testing.assert_allclose(v.T @ (lin.M @ v), np.eye(8), atol=1e-8)
    if loaded:
        # the load stiffens the first y-bending mode (tension along the rotated axis) and
        # splits the y/z pair: the loaded state differs from the unloaded one
        _, lin0 = _lin(eigen_cantilever_deck(70))
        f0 = E.eigenmodes(lin0, prob.num, prob.free, n_modes=8).frequency
        assert abs(md.frequency[0] / f0[0] - 1) > 1e-3


def test_element_wise_products_are_the_reduced_matrix():
    """``products`` is the assembled reduced tangent times Y and its quadratic form, in a
    stressed state, and T is an orthonormal basis of the null space of C."""
    prob, lin = _lin(_loaded_deck(12), loaded=True)
    tan = ET._Tangent(lin, prob.num)
    full = tan.upper + sp.triu(tan.upper, 1).T
    y = np.random.default_rng(1).standard_normal((tan.n, 3))
    ky, gram = tan.products(y)
    scale = np.abs(full).max() * np.abs(y).max()
    assert np.abs(ky - full @ y).max() < 1e-12 * scale
    assert np.abs(gram - y.T @ (full @ y)).max() < 1e-11 * scale * np.abs(y).sum(axis=0).max()
    # the map T is orthonormal and ends in the null space of C
    np.testing.assert_allclose((tan.T.T @ tan.T).toarray(), np.eye(tan.n), atol=1e-14)
    assert np.abs(lin.C @ tan.T).max() < 1e-12


def test_a_free_floating_beam_takes_the_bordered_solver_or_finds_its_rigid_modes():
    """Without the clamp the reduced tangent is singular (six rigid-body modes): the
    tangent solver does not decide on round-off pivots; the modes are the dense solve's."""
    text = eigen_cantilever_deck(70).replace("FIX 1\nFIX 2\n", "")
    prob, lin = _lin(text)
    md = E.eigenmodes(lin, prob.num, prob.free, n_modes=10)
    dense = E.eigenmodes(lin, prob.num, prob.free, n_modes=10, dense_limit=10**6)
    assert np.sum(md.kind == E.RIGID_BODY) == 6 == np.sum(dense.kind == E.RIGID_BODY)
    el = md.kind == E.ELASTIC
    np.testing.assert_allclose(md.frequency[el], dense.frequency[dense.kind == E.ELASTIC],
                               rtol=1e-7)


@pytest.mark.slow
def test_frequencies_of_1000_and_10000_elements_agree():
    """The same cantilever at 10^3 and 10^4 elements: the ten lowest frequencies agree to
    1e-7 (measured: 6e-12 and 2.2e-10 for the two lowest bending pairs, 1.4e-9 for the third, 1e-7
    for the torsion mode, whose lumped rotary inertia converges with h^2)."""
    f = {}
    for n in (1000, 10000):
        prob, lin = _lin(eigen_cantilever_deck(n))
        md = E.eigenmodes(lin, prob.num, prob.free, n_modes=10)
        assert np.all(md.kind == E.ELASTIC)
        f[n] = md.frequency
    np.testing.assert_allclose(f[10000], f[1000], rtol=2e-7)
    # the first two bending pairs: discretization and solver error 6e-12 and 2.2e-10
    np.testing.assert_allclose(f[10000][:2], f[1000][:2], rtol=1e-10)
    np.testing.assert_allclose(f[10000][2:4], f[1000][2:4], rtol=1e-9)
    assert f[10000][0] == pytest.approx(20.7271436041, rel=1e-10)


def test_negative_pivots_alone_do_not_decide(monkeypatch):
    """A round-off negative pivot of the LDL^T (as the loaded 10^5-element cantilever had)
    does not send a positive definite pencil to the bordered solver: the refined Ritz
    values decide, and the modes are those of the pivots' ordinary case."""
    prob, lin = _lin(_loaded_deck(70), loaded=True)
    lam, vec = ET.lowest_modes(lin, prob.num, 8)
    monkeypatch.setattr(ET.SPDFactorization, "negative_pivots", lambda self: 1)

    def no_bordered(*a, **k):
        raise AssertionError("the bordered solver was called")
    monkeypatch.setattr(E, "_sparse", no_bordered)
    lam1, vec1 = ET.lowest_modes(lin, prob.num, 8)
    np.testing.assert_array_equal(lam1, lam)
    # rigid-body modes (negative pivots, and Ritz values of round-off size) still go to
    # the bordered solver
    text = eigen_cantilever_deck(70).replace("FIX 1\nFIX 2\n", "")
    prob, lin = _lin(text)
    assert ET.lowest_modes(lin, prob.num, 10) is None
