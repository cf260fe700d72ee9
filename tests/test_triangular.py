"""Block forward substitution of square sparse matrices (spacarpy.solvers.linalg.triangular)."""
import numpy as np
import pytest

from spacarpy.solvers.linalg.sparse import FactorizationError
from spacarpy.solvers.linalg.triangular import DENSE_MAX, BlockTriangular

from helpers import dense_reference, kinematic_chain_pattern


def _block_triangular(rng, n_blocks, max_size=5, density=0.3):
    """A random block lower triangular matrix with well-conditioned diagonal blocks, its
    rows and columns shuffled."""
    sizes = rng.integers(1, max_size + 1, n_blocks)
    start = np.concatenate([[0], np.cumsum(sizes)])
    n = int(start[-1])
    a = np.zeros((n, n))
    for k in range(n_blocks):
        r = slice(start[k], start[k + 1])
        a[r, r] = rng.standard_normal((sizes[k], sizes[k])) + 3.0 * np.eye(sizes[k])
        for j in range(k):
            if rng.random() < density:
                a[r, start[j]:start[j + 1]] = rng.standard_normal((sizes[k], sizes[j]))
    return a[rng.permutation(n)][:, rng.permutation(n)]


@pytest.mark.parametrize("seed", range(8))
@pytest.mark.parametrize("dense", [True, False])
def test_solves_shuffled_block_triangular_matrices_like_a_dense_solver(seed, dense):
    rng = np.random.default_rng(seed)
    a = _block_triangular(rng, n_blocks=int(rng.integers(1, 40)))
    rows, cols = np.nonzero(a)
    bt = BlockTriangular(rows, cols, a.shape[0], dense=dense)
    assert bt.shape[1] <= 5                    # the structure was found, not one big block
    solve = bt.factorize(a[rows, cols])
    for _ in range(2):                         # a factorization serves several solves
        b = rng.standard_normal(a.shape[0])
        x = solve(b)
        assert np.abs(x - np.linalg.solve(a, b)).max() < 1e-10 * max(1.0, np.abs(x).max())


def test_a_chain_is_solved_by_substitution_with_7x7_blocks():
    """The kinematic correction's pattern for a chain of beams: each node's 7 coordinates
    (a diagonal block) depend on the previous node's (below the diagonal)."""
    rng = np.random.default_rng(1)
    n_nodes, s = 300, 7
    n = n_nodes * s
    a = np.zeros((n, n))
    for k in range(n_nodes):
        r = slice(k * s, (k + 1) * s)
        a[r, r] = rng.standard_normal((s, s)) + 4.0 * np.eye(s)
        if k:
            a[r, (k - 1) * s:k * s] = rng.standard_normal((s, s))
    rows, cols = np.nonzero(a)
    bt = BlockTriangular(rows, cols, n)
    assert bt.shape == (n_nodes, s, s)
    b = rng.standard_normal(n)
    x = bt.factorize(a[rows, cols])(b)
    assert np.abs(a @ x - b).max() < 1e-9 * np.abs(b).max()


def test_a_singular_diagonal_block_is_a_factorization_error():
    a = np.array([[1.0, 2.0, 0.0], [2.0, 4.0, 0.0], [1.0, 1.0, 3.0]])   # block 1 singular
    rows, cols = np.nonzero(a)
    with pytest.raises(FactorizationError):
        BlockTriangular(rows, cols, 3).factorize(a[rows, cols])


def test_patterns_without_small_blocks_or_without_a_matching_are_refused():
    n = 40
    ring = np.arange(n)
    rows = np.concatenate([ring, ring])
    cols = np.concatenate([ring, (ring + 1) % n])   # a cycle: one strongly connected block
    with pytest.raises(ValueError, match="block of 40"):
        BlockTriangular(rows, cols, n, max_block=16)
    assert BlockTriangular(rows, cols, n, max_block=40).shape == (1, 40, 40)
    with pytest.raises(ValueError, match="structurally singular"):
        BlockTriangular([0, 1], [0, 0], 2)          # column 1 is empty


@pytest.mark.parametrize("n_nodes", [DENSE_MAX // 7, DENSE_MAX // 7 + 1])
def test_dense_and_sparse_substitution_agree_at_the_threshold(n_nodes):
    """Just below and just above DENSE_MAX unknowns the default takes the dense and the
    sparse triangular solve in turn; forced either way, both give the dense solver's
    solution and agree with each other to round-off."""
    rng = np.random.default_rng(n_nodes)
    rows, cols, data, n = kinematic_chain_pattern(rng, n_nodes)
    assert BlockTriangular(rows, cols, n).dense == (n <= DENSE_MAX)
    b = rng.standard_normal(n)
    x_dense = BlockTriangular(rows, cols, n, dense=True).factorize(data)(b)
    x_sparse = BlockTriangular(rows, cols, n, dense=False).factorize(data)(b)
    x_ref, scale = dense_reference(rows, cols, data, n, b)
    assert np.abs(x_dense - x_sparse).max() < 1e-12 * scale
    assert np.abs(x_dense - x_ref).max() < 1e-10 * scale
