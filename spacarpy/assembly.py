"""Sparse assembly with a sparsity pattern computed once per model.

The static solver's Newton matrix is the bordered (saddle-point) matrix

    [ K   C^T ]      K = sum_e (D^T S D + H(sigma))_e + Euler and moment-load blocks
    [ C   0   ]      C = gradients of the constraints (rigid modes, Euler normalization)

over the unknown coordinates and the constraint multipliers. Every contribution is a batch
of small dense blocks whose global positions never change, so :class:`BorderedPattern`
computes the CSC structure and a scatter map once; afterwards each assembly is a single
``np.bincount`` into the data array (duplicates summed), with no COO->CSC conversion.
Entries that fall on fixed coordinates are dropped by a precomputed mask.
"""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from spacarpy.numbering import Numbering


class BorderedPattern:
    """CSC structure and scatter map of the bordered Newton matrix of one model.

    Parameters
    ----------
    num : Numbering
    moment_rot : (n_m,) int
        Orientation-node indices that carry a moment load (their load derivative adds a
        4x4 block).
    """

    def __init__(self, num: Numbering, moment_rot: np.ndarray):
        u = num.unknown_of
        n_x = num.n_unknown
        self.n_x = n_x
        self.n = n_x + num.n_constraint
        eu = u[num.rot_idx[num.euler_nodes]]                   # (n_eu, 4)
        mu_ = u[num.rot_idx[moment_rot]]                       # (n_m, 4)
        erow = n_x + num.n_rigid + np.arange(num.euler_nodes.size)
        rows, cols = [], []
        for g in num.groups:                                   # element blocks
            gu = u[g.idx]
            k = gu.shape[1]
            rows.append(np.repeat(gu, k, axis=1).ravel())
            cols.append(np.tile(gu, (1, k)).ravel())
        rows += [eu.ravel(), np.repeat(mu_, 4, axis=1).ravel()]
        cols += [eu.ravel(), np.tile(mu_, (1, 4)).ravel()]
        for g in num.groups:                                   # C_rigid and its transpose
            ru = u[g.idx][g.rigid_elem]                        # (n_rigid_g, n_ldof)
            rrow = n_x + g.rigid_offset + np.arange(g.rigid_elem.size)
            rows += [np.repeat(rrow, ru.shape[1]), ru.ravel()]
            cols += [ru.ravel(), np.repeat(rrow, ru.shape[1])]
        rows += [np.repeat(erow, 4), eu.ravel()]                # C_euler and its transpose
        cols += [eu.ravel(), np.repeat(erow, 4)]
        rows = np.concatenate(rows).astype(np.int64)
        cols = np.concatenate(cols).astype(np.int64)
        valid = (rows >= 0) & (cols >= 0)
        key = cols[valid] * self.n + rows[valid]                # column-major order = CSC
        uniq, inverse = np.unique(key, return_inverse=True)
        self.indices = (uniq % self.n).astype(np.int32)
        counts = np.bincount(uniq // self.n, minlength=self.n)
        self.indptr = np.concatenate([[0], np.cumsum(counts)]).astype(np.int32)
        self.nnz = uniq.size
        self.scatter = _scatter_map(valid, inverse, self.nnz)

    def assemble(self, k_elem, euler_diag, moment_blocks, c_rigid, c_euler,
                 scale: float = 1.0) -> sp.csc_matrix:
        """Fill the pattern.

        Parameters
        ----------
        k_elem : list of (n_elem_g, n_ldof_g, n_ldof_g), one per element group
        euler_diag : (n_eu,)  value added to the 4 diagonal entries of each Euler node
        moment_blocks : (n_m, 4, 4)
        c_rigid : list of (n_rigid_g, n_ldof_g), one per element group
        c_euler : (n_eu, 4)
        scale : float
            Factor applied to the constraint rows and columns (balances the saddle point).
        """
        parts = [k.ravel() for k in k_elem]
        parts += [np.repeat(euler_diag, 4), moment_blocks.ravel()]
        for c in c_rigid:
            cr = scale * c.ravel()
            parts += [cr, cr]
        ce = scale * c_euler.ravel()
        parts += [ce, ce]
        data = np.bincount(self.scatter, weights=np.concatenate(parts),
                           minlength=self.nnz + 1)[:self.nnz]
        return sp.csc_matrix((data, self.indices, self.indptr), shape=(self.n, self.n))


def _scatter_map(valid: np.ndarray, inverse: np.ndarray, nnz: int) -> np.ndarray:
    """Target of every local entry in the CSC data array; dropped entries (fixed
    coordinates, the lower triangle of a symmetric pattern) go to a spare slot ``nnz`` that
    is cut off after the sum (cheaper than masking the values at every assembly)."""
    out = np.full(valid.size, nnz, dtype=np.intp)
    out[valid] = inverse.ravel()
    return out


def scatter_add(n: int, idx: np.ndarray, vals: np.ndarray) -> np.ndarray:
    """Sum per-element vectors into a global vector: ``out[idx] += vals`` with repeats."""
    return np.bincount(idx.ravel(), weights=vals.ravel(), minlength=n).astype(float,
                                                                           copy=False)


class BlockPattern:
    """CSC structure and scatter map of a square matrix built from batches of dense blocks.

    Parameters
    ----------
    n : int
        Matrix size.
    index_blocks : list of (n_b, k_b) int arrays
        For each batch, the global row/column index of every local entry of its (k_b, k_b)
        blocks; -1 drops the row/column (a fixed coordinate).
    upper : bool
        Keep only the upper triangle (row <= column) of a symmetric matrix: half the
        scatter work, and the input a symmetric factorization (LDL^T) takes.
    """

    def __init__(self, n: int, index_blocks, upper: bool = False):
        self.n = n
        rows = [np.repeat(ix, ix.shape[1], axis=1).ravel() for ix in index_blocks]
        cols = [np.tile(ix, (1, ix.shape[1])).ravel() for ix in index_blocks]
        rows, cols = np.concatenate(rows), np.concatenate(cols)
        valid = (rows >= 0) & (cols >= 0)
        if upper:
            valid &= rows <= cols
        key = cols[valid] * n + rows[valid]
        uniq, inverse = np.unique(key, return_inverse=True)
        self.indices = (uniq % n).astype(np.int32)
        self.indptr = np.concatenate([[0], np.cumsum(np.bincount(uniq // n, minlength=n))]
                                     ).astype(np.int32)
        self.nnz = uniq.size
        self.scatter = _scatter_map(valid, inverse, self.nnz)
        self.diag = np.flatnonzero(self.indices == np.repeat(np.arange(n), np.diff(self.indptr)))

    def assemble(self, blocks, diag_shift: float = 0.0) -> sp.csc_matrix:
        """Fill the pattern with ``blocks`` (one (n_b, k_b, k_b) array per batch)."""
        data = np.bincount(self.scatter, weights=np.concatenate([b.ravel() for b in blocks]),
                           minlength=self.nnz + 1)[:self.nnz]
        if diag_shift:
            data[self.diag] += diag_shift
        return sp.csc_matrix((data, self.indices, self.indptr), shape=(self.n, self.n))
