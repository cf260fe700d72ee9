"""Sparsity patterns and scatter maps of spacarpy.assembly against the straightforward
construction (np.unique of one key per entry), on random batches of blocks and on models."""
from pathlib import Path

import numpy as np
import pytest

from spacarpy.assembly import BlockPattern, BorderedPattern, _csc_pattern
from spacarpy.deck import load_deck
from spacarpy.numbering import number_model
from spacarpy.solvers.statics.static import Loads

DECKS = Path(__file__).resolve().parents[1] / "decks"


def reference_pattern(n, rows, cols, upper=False):
    """indices, indptr, scatter from flat (row, col) lists; -1 drops an entry."""
    rows, cols = np.asarray(rows, dtype=np.int64), np.asarray(cols, dtype=np.int64)
    valid = (rows >= 0) & (cols >= 0)
    if upper:
        valid &= rows <= cols
    uniq, inverse = np.unique(cols[valid] * n + rows[valid], return_inverse=True)
    indices = (uniq % n).astype(np.int32)
    indptr = np.concatenate([[0], np.cumsum(np.bincount(uniq // n, minlength=n))]).astype(
        np.int32)
    scatter = np.full(rows.size, uniq.size, dtype=np.intp)
    scatter[valid] = inverse.ravel()
    return indices, indptr, scatter


def flat_entries(blocks):
    """(rows, cols) of every entry, batch by batch, each block in C order (n_b, p, q)."""
    rows, cols = [], []
    for r, c in blocks:
        shape = (r.shape[0], r.shape[1], c.shape[1])
        rows.append(np.broadcast_to(r[:, :, None], shape).ravel())
        cols.append(np.broadcast_to(c[:, None, :], shape).ravel())
    return np.concatenate(rows), np.concatenate(cols)


def assert_same(got, expected):
    for g, e in zip(got, expected):
        assert g.dtype == e.dtype and g.shape == e.shape
        np.testing.assert_array_equal(g, e)


def random_blocks(rng, n, n_batches=4):
    blocks = []
    for _ in range(n_batches):
        n_b, p = int(rng.integers(0, 40)), int(rng.integers(1, 7))
        if rng.random() < 0.5:
            r = rng.integers(-1, n, size=(n_b, p))          # -1: a dropped row/column
        else:                                               # runs of consecutive indices
            r = rng.integers(0, n, size=(n_b, 1)) + np.arange(p)
            r[(r >= n) | (rng.random(r.shape) < 0.2)] = -1
        if rng.random() < 0.5:                              # clique block
            blocks.append((r, r))
        else:                                               # rectangular block
            blocks.append((r, rng.integers(-1, n, size=(n_b, int(rng.integers(1, 5))))))
    return blocks


@pytest.mark.parametrize("seed", range(20))
@pytest.mark.parametrize("upper", [False, True])
def test_random_batches_match_reference(seed, upper):
    rng = np.random.default_rng(seed)
    n = int(rng.integers(1, 30))
    blocks = random_blocks(rng, n)
    if upper:                    # BlockPattern's case: symmetric (clique) batches only
        blocks = [(r, r) for r, _ in blocks]
    got = _csc_pattern(n, blocks, upper=upper)
    assert_same(got, reference_pattern(n, *flat_entries(blocks), upper=upper))


@pytest.mark.slow
@pytest.mark.parametrize("upper", [False, True])
def test_large_batches_and_values(upper):
    """Overlapping blocks of consecutive indices (runs that straddle the diagonal) with
    holes; the assembled matrix is the dense sum of the blocks."""
    rng = np.random.default_rng(7)
    n = 3000
    start = rng.integers(0, n - 12, size=4000)
    ix = start[:, None] + np.arange(12)[None, :]                   # overlapping blocks
    ix[rng.random(ix.shape) < 0.05] = -1
    small = rng.integers(-1, n, size=(50, 3))
    index_blocks = [ix, small, np.zeros((0, 4), dtype=np.int64)]
    pat = BlockPattern(n, index_blocks, upper=upper)
    blocks = [(b, b) for b in index_blocks]
    assert_same((pat.indices, pat.indptr, pat.scatter),
                reference_pattern(n, *flat_entries(blocks), upper=upper))
    vals = [rng.standard_normal((b.shape[0], b.shape[1], b.shape[1])) for b in index_blocks]
    dense = np.zeros((n, n))
    for b, v in zip(index_blocks, vals):
        for e in range(b.shape[0]):
            for i, r in enumerate(b[e]):
                for j, c in enumerate(b[e]):
                    if r >= 0 and c >= 0 and (not upper or r <= c):
                        dense[r, c] += v[e, i, j]
    np.testing.assert_allclose(pat.assemble(vals).toarray(), dense, rtol=1e-12, atol=1e-12)


def test_duplicate_index_in_a_block():
    ix = np.array([[0, 2, 2], [1, 1, -1]])
    got = _csc_pattern(3, [(ix, ix)])
    assert_same(got, reference_pattern(3, *flat_entries([(ix, ix)])))


def bordered_reference(num, moment_rot):
    """The bordered pattern as BorderedPattern built it with np.unique."""
    u = num.unknown_of
    n_x = num.n_unknown
    n = n_x + num.n_constraint
    eu = u[num.rot_idx[num.euler_nodes]]
    mu_ = u[num.rot_idx[moment_rot]]
    erow = n_x + num.n_rigid + np.arange(num.euler_nodes.size)
    rows, cols = [], []
    for g in num.groups:
        gu = u[g.idx]
        k = gu.shape[1]
        rows.append(np.repeat(gu, k, axis=1).ravel())
        cols.append(np.tile(gu, (1, k)).ravel())
    rows += [eu.ravel(), np.repeat(mu_, 4, axis=1).ravel()]
    cols += [eu.ravel(), np.tile(mu_, (1, 4)).ravel()]
    for g in num.groups:
        ru = u[g.idx][g.rigid_elem]
        rrow = n_x + g.rigid_offset + np.arange(g.rigid_elem.size)
        rows += [np.repeat(rrow, ru.shape[1]), ru.ravel()]
        cols += [ru.ravel(), np.repeat(rrow, ru.shape[1])]
    rows += [np.repeat(erow, 4), eu.ravel()]
    cols += [eu.ravel(), np.repeat(erow, 4)]
    return reference_pattern(n, np.concatenate(rows), np.concatenate(cols))


@pytest.mark.parametrize("deck", ["four_bar_linkage.dat", "slider_crank_flexible.dat",
                                  "planar_four_bar.dat", "hinged_rod_spring.dat",
                                  "leafspring_guidance_buckling.dat",
                                  "table3_lateral_buckling_2el_modified.dat"])
def test_model_patterns_match_reference(deck):
    model = load_deck(DECKS / deck)
    num = number_model(model)
    loads = Loads(model, num)
    pat = BorderedPattern(num, loads.moment_rot)
    assert_same((pat.indices, pat.indptr, pat.scatter),
                bordered_reference(num, loads.moment_rot))
    u = num.unknown_of
    index_blocks = [u[g.idx] for g in num.groups] + [u[num.rot_idx[num.euler_nodes]]]
    kin = BlockPattern(num.n_unknown, index_blocks, upper=True)
    flat = flat_entries([(b, b) for b in index_blocks])
    assert_same((kin.indices, kin.indptr, kin.scatter),
                reference_pattern(num.n_unknown, *flat, upper=True))


@pytest.mark.parametrize("seed", range(5))
@pytest.mark.parametrize("bincount", [True, False])
def test_assembled_matrices_are_independent_and_valid(seed, bincount, monkeypatch):
    """BlockPattern makes its matrices from one template (no constructor checks): each is
    a valid CSC matrix of its own data, equal to the constructor's, unchanged by later
    assemblies; the symmetric product of an upper pattern is A y of the full matrix."""
    import scipy.sparse as sp

    import spacarpy.assembly as assembly
    monkeypatch.setattr(assembly, "SYMV_BINCOUNT_MAX", 10**9 if bincount else -1)
    rng = np.random.default_rng(seed)
    n = int(rng.integers(2, 30))
    index_blocks = [r for r, _ in random_blocks(rng, n)]
    pat = BlockPattern(n, index_blocks, upper=True)
    vals = [rng.standard_normal((b.shape[0], b.shape[1], b.shape[1])) for b in index_blocks]
    vals = [v + v.transpose(0, 2, 1) for v in vals]
    a = pat.assemble(vals)
    a.check_format(full_check=True)
    ref = sp.csc_matrix((a.data.copy(), pat.indices, pat.indptr), shape=(n, n))
    before = a.toarray()
    pat.assemble([2.0 * v for v in vals], diag_shift=1.0)          # a second assembly
    np.testing.assert_array_equal(a.toarray(), before)
    np.testing.assert_array_equal(ref.toarray(), before)
    y = rng.standard_normal(n)
    full = before + np.triu(before, 1).T
    np.testing.assert_allclose(pat.symmetric_matvec(a.data, y), full @ y,
                               rtol=1e-13, atol=1e-13 * max(1.0, np.abs(full).max()))


@pytest.mark.parametrize("seed", range(4))
def test_principal_part_is_scipys_fancy_indexing(seed):
    """principal_part's structure and selection give template[keep][:, keep] exactly: the
    same entries (explicit zeros of the pattern included) in the same order, any mask."""
    import scipy.sparse as sp

    from spacarpy.assembly import csc_with_data, principal_part
    rng = np.random.default_rng(seed)
    n = 12
    a = sp.random(n, n, density=0.4, format="csc", random_state=seed)
    a.data[rng.random(a.nnz) < 0.2] = 0.0          # explicit zeros stay in the pattern
    a.sort_indices()
    keep = rng.random(n) < 0.6
    keep[0] = True
    sub, sel = principal_part(a, keep)
    got = csc_with_data(sub, a.data[sel])
    want = a[keep][:, keep].tocsc()
    assert got.shape == want.shape
    np.testing.assert_array_equal(got.indptr, want.indptr)
    np.testing.assert_array_equal(got.indices, want.indices)
    np.testing.assert_array_equal(got.data, want.data)


def test_padding_of_the_nodal_block_is_block_diag():
    """The transient iteration matrix's nodal block padded to the bordered size equals
    scipy's block_diag([a, 0]) entry for entry (csc or csr input)."""
    import scipy.sparse as sp

    from spacarpy.solvers.dynamics.transient import _padded
    a = sp.random(7, 7, density=0.5, format="csr", random_state=3)
    want = sp.block_diag([a, sp.csc_matrix((4, 4))], format="csc")
    for given in (a, a.tocsc()):
        got = _padded(given, 11)
        assert got.shape == (11, 11) and (got != want).nnz == 0
        np.testing.assert_array_equal(got.toarray(), want.toarray())
