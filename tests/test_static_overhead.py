"""The static Newton iteration's cheaper paths (session 9, docs/performance.md "Static
per-iteration overhead"): each gives what the general path gives, to round-off."""
import numpy as np
import pytest

from spacarpy.bench.cases import cantilever_deck
from spacarpy.deck import model_from_text
from spacarpy.solvers.linalg.triangular import BlockTriangular
from spacarpy.solvers.statics.static import StaticOptions, StaticProblem, solve_static

from helpers import dense_reference, kinematic_chain_pattern


def cantilever(n, n_steps=10):
    return model_from_text(cantilever_deck(n, n_steps=n_steps, tol=1e-9, compact=True),
                           "<cantilever>")


def _blocks(prob, seed=0):
    """Rotated element blocks, the Euler diagonal and a state of a cantilever."""
    rng = np.random.default_rng(seed)
    num, red = prob.num, prob.reduced
    x = num.x0.copy()
    free = ~num.fixed_mask
    x[free] += 0.02 * rng.standard_normal(free.sum())
    mu = 1e3 * rng.standard_normal(num.n_constraint)
    ev = prob.evaluate(x, mu, prob.loads.at(1.0, 0.7))
    k_el, euler_diag, _ = prob.element_blocks(ev, mu)
    return red.rotate(k_el, red.basis(x[red.eu])), euler_diag, rng


@pytest.mark.parametrize("invariant", [True, False])
def test_radial_products_equal_the_full_element_products(invariant):
    """The radial columns (a z with radial entries only) of K z are those of the full
    element-by-element product, also with a clamped orientation node (whose slots belong to
    no Euler node) in the first element."""
    prob = StaticProblem(cantilever(5))
    red = prob.reduced
    assert (red.slot_nodes[0][0] < 0).any()           # the clamped node
    k_rot, euler_diag, rng = _blocks(prob)
    radial = red.eu[:, 0]
    zr = rng.standard_normal(radial.size)
    z = np.zeros(prob.num.n_coord)
    z[radial] = zr
    full = red._k_times(k_rot, euler_diag, z, invariant=invariant)
    cols = red._radial_columns(k_rot, euler_diag, zr)
    scale = np.abs(full).max()
    assert np.abs(cols - full).max() <= 1e-14 * scale


@pytest.mark.parametrize("n_nodes", [5, 40, 100])
def test_banded_full_and_sparse_substitution_agree(n_nodes):
    """A chain's L is banded (the block before): the default takes the band storage, and
    band, full dense and sparse solves all give the dense solver's solution."""
    rng = np.random.default_rng(n_nodes)
    rows, cols, data, n = kinematic_chain_pattern(rng, n_nodes)
    bt = BlockTriangular(rows, cols, n)
    assert bt.band is not None and bt.band < 14 and bt.unpadded
    b = rng.standard_normal(n)
    x_band = bt.factorize(data)(b)
    x_full = BlockTriangular(rows, cols, n, band=False).factorize(data)(b)
    x_sparse = BlockTriangular(rows, cols, n, dense=False).factorize(data)(b)
    x_ref, scale = dense_reference(rows, cols, data, n, b)
    for x in (x_band, x_full, x_sparse):
        assert np.abs(x - x_ref).max() < 1e-10 * scale
    assert np.abs(x_band - x_full).max() < 1e-12 * scale


def test_a_wide_band_takes_the_full_dense_array():
    """Where L's band would be more than half of it (here one block row reaching all the
    way back), the full dense array is kept."""
    n = 12
    rows, cols = np.tril_indices(n)
    bt = BlockTriangular(rows, cols, n)
    assert bt.dense and bt.band is None
    data = np.where(rows == cols, 3.0, 0.1)
    a = np.zeros((n, n))
    a[rows, cols] = data
    b = np.arange(n, dtype=float)
    assert np.allclose(bt.factorize(data)(b), np.linalg.solve(a, b), rtol=1e-12)


def test_the_correction_hands_its_last_states_on_and_they_are_exact(monkeypatch):
    """Most kinematic corrections of a cantilever solve end with the full kernel states of
    the configuration they return (the chord iteration predicted to be the last computes
    them), and those are the states a fresh evaluation gives, bit for bit."""
    prob = StaticProblem(cantilever(10))
    corrector = prob.corrector
    original = corrector.correct
    ends = []

    def checked(x_lin, dx, st_old, size, **kw):
        out = original(x_lin, dx, st_old, size, **kw)
        if kw.get("return_states"):
            x, states = out
            ends.append(states is not None)
            if states is not None:
                for g, st in zip(prob.num.groups, states):
                    fresh = g.kind.state(x[g.idx], g.ref, prob.variant, g.prev)
                    assert np.array_equal(st.e, fresh.e) and np.array_equal(st.D, fresh.D)
        return out
    monkeypatch.setattr(corrector, "correct", checked)
    solve_static(prob.model, problem=prob, options=StaticOptions(n_steps=10, tol=1e-8))
    assert len(ends) >= 30
    assert sum(ends) >= 0.6 * len(ends)        # (all of them ended without, before)


@pytest.mark.parametrize("seed", range(6))
def test_band_storage_solves_shuffled_matrices_with_padded_blocks(seed):
    """Band storage forced on matrices of mixed block sizes (padded blocks, rows and
    columns shuffled, a wide band): the same solutions as a dense solver."""
    rng = np.random.default_rng(100 + seed)
    sizes = rng.integers(1, 6, int(rng.integers(3, 30)))
    start = np.concatenate([[0], np.cumsum(sizes)])
    n = int(start[-1])
    a = np.zeros((n, n))
    for k in range(sizes.size):
        r = slice(start[k], start[k + 1])
        a[r, r] = rng.standard_normal((sizes[k], sizes[k])) + 3.0 * np.eye(sizes[k])
        if k:
            j = int(rng.integers(0, k))
            a[r, start[j]:start[j + 1]] = rng.standard_normal((sizes[k], sizes[j]))
    a = a[rng.permutation(n)][:, rng.permutation(n)]
    rows, cols = np.nonzero(a)
    bt = BlockTriangular(rows, cols, n, band=True)
    assert bt.band is not None and (sizes.min() == sizes.max() or not bt.unpadded)
    solve = bt.factorize(a[rows, cols])
    b = rng.standard_normal(n)
    x = solve(b)
    assert np.abs(x - np.linalg.solve(a, b)).max() < 1e-10 * max(1.0, np.abs(x).max())
