"""Square sparse matrices of fixed pattern solved by block forward substitution.

The kinematic correction of a tree of elements (every element adds one node) solves
``W step = g`` with a square Jacobian W whose rows are the element deformations and Euler
normalizations and whose columns are the free coordinates. Ordered from the supports
outwards, W is block lower triangular: an element's deformations involve the coordinates of
its own end node (the diagonal block) and of nodes already passed (below the diagonal).
Solving such a system is forward kinematics: node after node, each from its parent. A
general sparse LU (SuperLU) finds that out again at every factorization, with its ordering
and symbolic analysis.

:class:`BlockTriangular` finds the structure once per pattern, from the pattern alone:

1. a maximum bipartite matching of rows to columns (a zero-free diagonal; none exists:
   the pattern is structurally singular, :class:`ValueError`),
2. the strongly connected components of the rows' dependency graph (row i depends on the
   row matched to each column it has an entry in): these are the diagonal blocks of the
   block triangular form (Duff & Reid's algorithm; scipy numbers the components in reverse
   topological order, which is verified, not assumed).

Each factorization then inverts the small diagonal blocks (vectorized, LU with partial
pivoting inside each block) and forms ``L = B^-1 W``, block by block and again vectorized:
a unit lower triangular matrix in the block order, with the pattern of W. A solve is
``x = L^-1 (B^-1 b)`` by scipy's compiled sparse triangular solve, or, up to
:data:`DENSE_MAX` unknowns, by LAPACK's dense ``dtrtrs`` on L filled into a dense array
(scipy's ``spsolve_triangular`` spends about 100 us per call on checks and copies, more
than the arithmetic of a small model; the measurements are at :data:`DENSE_MAX`). Where L
is banded in the block order (a chain: each block row reaches back to the block before
it), the dense path keeps only the band, in LAPACK's band storage, and solves with BLAS's
``dtbsv``: 7 against 46 us for the 700 unknowns of a 100-element cantilever, and no
(n, n) array to fill at each factorization.
Where a diagonal block is singular the whole matrix is (its determinant is the product of
the blocks'), and :class:`~spacarpy.solvers.linalg.sparse.FactorizationError` is raised as SuperLU
would.
"""
from __future__ import annotations

from functools import partial

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from scipy.linalg import blas, lapack
from scipy.sparse.csgraph import connected_components, maximum_bipartite_matching

from spacarpy.elements.chunks import in_chunks
from spacarpy.solvers.linalg.sparse import FactorizationError

#: Largest number of unknowns solved with a dense triangular L. Measured on the 2-core
#: machine (CPU time, best of 5), a chain of 7x7 blocks (the kinematic correction of a
#: cantilever), one factorization and two solves: dense 46 / 352 / 592 / 1286 us against
#: sparse 282 / 434 / 573 / 717 us at 70 / 700 / 1001 / 1400 unknowns.
DENSE_MAX = 800


class BlockTriangular:
    """Block forward substitution for square matrices with the pattern ``(rows, cols)``.

    ``rows, cols`` (nnz,) are the positions of the data given to :meth:`factorize`, in that
    order, without duplicates. Raises ValueError when the pattern is structurally singular
    or its largest diagonal block has more than ``max_block`` rows (the dense block
    inverses would then cost more than a sparse LU)."""

    def __init__(self, rows, cols, n: int, max_block: int = 16, dense: bool | None = None,
                 band: bool | None = None):
        rows = np.asarray(rows, dtype=np.int64)
        cols = np.asarray(cols, dtype=np.int64)
        self.n = n
        if n == 0:
            raise ValueError("empty matrix")
        # (int8 data: only the structure counts, and at 10^5 elements it has 5e6 entries)
        pattern = sp.csr_matrix((np.ones(rows.size, dtype=np.int8), (rows, cols)),
                                shape=(n, n))
        if pattern.nnz != rows.size:
            raise ValueError("duplicate entries in the pattern")
        match = maximum_bipartite_matching(pattern, perm_type="column")   # row -> column
        if (match < 0).any():
            raise ValueError("structurally singular pattern")
        row_of_col = np.empty(n, dtype=np.int64)
        row_of_col[match] = np.arange(n)
        dep = row_of_col[cols]                     # the row each entry's column belongs to
        graph = sp.csr_matrix((pattern.data, row_of_col[pattern.indices], pattern.indptr),
                              shape=(n, n))
        n_blocks, block = connected_components(graph, directed=True, connection="strong")
        block = block.astype(np.int64)
        if not np.all(block[rows] >= block[dep]):
            raise ValueError("components not in topological order")
        size = np.bincount(block, minlength=n_blocks)
        if size.max() > max_block:
            raise ValueError(f"a diagonal block of {size.max()} rows")
        s = int(size.max())
        start = np.concatenate([[0], np.cumsum(size)[:-1]])
        # rows in block order; column c takes the position of its matched row
        order = np.argsort(block, kind="stable")
        rank = np.empty(n, dtype=np.int64)
        rank[order] = np.arange(n)
        local = rank - start[block]                # position of a row inside its block
        self.col_order = match[order]              # permuted position -> original column
        # the right side by blocks: (n_blocks, s) original rows, padded with row 0 (weight 0)
        self.rhs_rows = np.zeros((n_blocks, s), dtype=np.int64)
        self.rhs_rows[block, local] = np.arange(n)
        self.rhs_valid = np.zeros((n_blocks, s), dtype=bool)
        self.rhs_valid[block, local] = True
        self.unpadded = bool(self.rhs_valid.all())

        # diagonal-block entries -> (block, i, j); padding rows/columns carry 1 on the
        # diagonal so that every padded block is invertible exactly when the true one is
        b_row, b_col = block[rows], block[dep]
        diag = b_row == b_col
        self.diag_entries = np.flatnonzero(diag)
        self.shape = (n_blocks, s, s)
        # (flat indices into the dense arrays: much faster than index tuples)
        self.diag_at = np.ravel_multi_index((b_row[diag], local[rows[diag]], local[dep[diag]]),
                                            self.shape)
        pad_k, pad_i = np.nonzero(~self.rhs_valid)
        self.pad_at = np.ravel_multi_index((pad_k, pad_i, pad_i), self.shape)

        # below-diagonal entries -> (block row, i, slot): the slots of a block row are its
        # distinct columns outside the block
        off = np.flatnonzero(~diag)
        key_block, key_col = b_row[off], cols[off]
        keys, slot_of = np.unique(key_block * n + key_col, return_inverse=True)
        pairs = np.stack([keys // n, keys % n])                    # (block, column), sorted
        first = np.searchsorted(pairs[0], pairs[0], side="left")   # first pair of each block
        slot = np.arange(pairs.shape[1]) - first                   # slot number in its row
        width = int(slot.max()) + 1 if slot.size else 0
        self.off_entries = off
        self.off_shape = (n_blocks, s, width)
        self.off_at = np.ravel_multi_index((key_block, local[rows[off]], slot[slot_of]),
                                           self.off_shape)
        # L's entries: every (block row k, i < size_k, slot) product, then the unit diagonal
        n_slots = np.bincount(pairs[0], minlength=n_blocks)
        kk, ii, jj = np.nonzero((np.arange(s)[None, :, None] < size[:, None, None])
                                & (np.arange(width)[None, None, :] < n_slots[:, None, None]))
        self.product_at = np.ravel_multi_index((kk, ii, jj), self.off_shape)
        col_of_slot = np.zeros((n_blocks, max(width, 1)), dtype=np.int64)
        col_of_slot[pairs[0], slot] = pairs[1]
        l_rows = np.concatenate([start[kk] + ii, np.arange(n)])
        l_cols = np.concatenate([rank[row_of_col[col_of_slot[kk, jj]]], np.arange(n)])
        lay = sp.csc_matrix((np.arange(1, l_rows.size + 1, dtype=float), (l_rows, l_cols)),
                            shape=(n, n))
        self.l_source = lay.data.astype(np.int64) - 1
        self.l_indices, self.l_indptr = lay.indices, lay.indptr
        # the dense path (``dense``: forced on or off; None: up to DENSE_MAX unknowns):
        # the flat positions of L's entries in an (n, n) Fortran-ordered array
        self.dense = n <= DENSE_MAX if dense is None else bool(dense)
        # ... and there, where L is banded in the block order (a chain of elements: each
        # block row reaches back to the block before it), in LAPACK's band storage
        # (``band``: forced on or off; None: where the band is less than half of L)
        self.band = None                           # the lower bandwidth, where banded
        if self.dense:
            l_col = np.repeat(np.arange(n), np.diff(self.l_indptr))
            kd = int((self.l_indices - l_col).max(initial=0))
            if (kd + 1 < n // 2) if band is None else band:
                self.band = kd
                self.l_flat = self.l_indices.astype(np.int64) - l_col + (kd + 1) * l_col
            else:
                self.l_flat = self.l_indices.astype(np.int64) + n * l_col

    def _diagonal_blocks(self, data) -> np.ndarray:
        """The dense diagonal blocks (n_blocks, s, s) of the matrix with entries ``data``,
        the padding of smaller blocks 1 on the diagonal."""
        blocks = np.zeros(self.shape)
        flat = blocks.reshape(-1)
        flat[self.diag_at] = np.asarray(data, dtype=float)[self.diag_entries]
        flat[self.pad_at] = 1.0
        return blocks

    def regular(self, data, rcond: float = 1e-8) -> bool:
        """Whether the matrix with entries ``data`` is regular, with every diagonal block's
        smallest singular value above ``rcond`` times its largest (a block triangular
        matrix is singular exactly when a diagonal block is)."""
        blocks = self._diagonal_blocks(data)
        sv = in_chunks(partial(np.linalg.svd, compute_uv=False), len(blocks), blocks)
        return bool(np.all(sv[:, -1] > rcond * sv[:, 0]))

    def factorize(self, data):
        """Factorize the matrix with entries ``data`` (in the order of the pattern); returns
        ``solve(b) -> x``."""
        data = np.asarray(data, dtype=float)
        blocks = self._diagonal_blocks(data)
        try:
            inv = in_chunks(np.linalg.inv, len(blocks), blocks)    # on the thread pool
        except np.linalg.LinAlgError:
            raise FactorizationError("singular diagonal block") from None
        if not np.all(np.isfinite(inv)):
            raise FactorizationError("non-finite diagonal block inverse")
        below = np.zeros(self.off_shape)
        below.reshape(-1)[self.off_at] = data[self.off_entries]
        products = (inv @ below).reshape(-1)[self.product_at]
        l_data = np.concatenate([products, np.ones(self.n)])[self.l_source]
        rhs_rows, rhs_valid, col_order = self.rhs_rows, self.rhs_valid, self.col_order
        if self.band is not None:
            kd = self.band
            ab = np.zeros((kd + 1, self.n), order="F")
            ab.reshape(-1, order="F")[self.l_flat] = l_data

            def triangular(rhs):
                return blas.dtbsv(kd, ab, rhs, lower=1, diag=1, overwrite_x=1)
        elif self.dense:
            dense = np.zeros((self.n, self.n), order="F")
            dense.reshape(-1, order="F")[self.l_flat] = l_data

            def triangular(rhs):
                y, info = lapack.dtrtrs(dense, rhs, lower=1, unitdiag=1, overwrite_b=1)
                if info:                        # pragma: no cover - unit diagonal
                    raise FactorizationError("singular triangular factor")
                return y
        else:
            lower = sp.csc_matrix((l_data, self.l_indices, self.l_indptr),
                                  shape=(self.n, self.n))

            def triangular(rhs):
                # (L holds its unit diagonal, so the solver's setdiag(1) leaves it as it is)
                return spla.spsolve_triangular(lower, rhs, lower=True, unit_diagonal=True,
                                               overwrite_A=True, overwrite_b=True)

        if self.unpadded:                          # blocks of one size: no padding
            rhs_rows = rhs_rows.reshape(-1)

            def solve(b):
                bb = np.asarray(b, dtype=float)[rhs_rows].reshape(inv.shape[:2] + (1,))
                y = triangular((inv @ bb).reshape(-1))       # in block order
                x = np.empty(self.n)
                x[col_order] = y
                return x
            return solve

        def solve(b):
            bb = np.where(rhs_valid, np.asarray(b, dtype=float)[rhs_rows], 0.0)
            scaled = (inv @ bb[:, :, None])[:, :, 0][rhs_valid]      # in block order
            y = triangular(scaled)
            x = np.empty(self.n)
            x[col_order] = y
            return x
        return solve
