"""Sparse assembly with a sparsity pattern computed once per model.

The static solver's Newton matrix is the bordered (saddle-point) matrix

    [ K   C^T ]      K = sum_e (D^T S D + H(sigma))_e + Euler and moment-load blocks
    [ C   0   ]      C = gradients of the constraints (rigid modes, Euler normalization)

over the unknown coordinates and the constraint multipliers. Every contribution is a batch
of small dense blocks whose global positions never change, so :class:`BorderedPattern`
computes the CSC structure and a scatter map once; afterwards each assembly is a single
``np.bincount`` into the data array (duplicates summed), with no COO->CSC conversion.
Entries that fall on fixed coordinates go to a spare slot cut off after the sum.

:class:`BlockPattern` makes its matrices from a template built once (:func:`csc_with_data`):
scipy's constructor checks the index arrays at every call, 0.1-0.2 ms, more than the
assembly itself of a 10-element model, which assembles thousands of times in a transient.
"""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from spacarpy.numbering import Numbering

#: Largest pattern (entries) whose symmetric product is two bincounts (measured: equal
#: times at about 5 600 entries, see BlockPattern.symmetric_matvec).
SYMV_BINCOUNT_MAX = 4000


def csc_with_data(template: sp.csc_matrix, data: np.ndarray) -> sp.csc_matrix:
    """A CSC matrix with the structure of ``template`` (shared, not copied) and ``data``,
    without the constructor's checks of the structure (made once, for the template):
    a new object with the template's attributes and its own data array."""
    out = object.__new__(type(template))
    out.__dict__.update(template.__dict__)
    out.data = data
    return out


def principal_part(template: sp.csc_matrix, keep: np.ndarray) -> tuple:
    """The structure of ``template[keep][:, keep]`` (``keep`` a boolean mask over its rows
    and columns) and where its entries lie in ``template.data``: ``(sub, sel)``, so that the
    submatrix of any matrix with the template's structure is ``csc_with_data(sub,
    data[sel])``, made once instead of scipy's fancy indexing at every use (two index
    passes and two constructors). The entries keep the template's order."""
    n = template.shape[1]
    new_of = np.cumsum(keep) - 1
    cols = np.repeat(np.arange(n), np.diff(template.indptr))
    sel = np.flatnonzero(keep[template.indices] & keep[cols])
    m = int(np.count_nonzero(keep))
    indptr = np.zeros(m + 1, dtype=template.indptr.dtype)
    np.cumsum(np.bincount(new_of[cols[sel]], minlength=m), out=indptr[1:])
    sub = sp.csc_matrix((np.zeros(sel.size), new_of[template.indices[sel]].astype(
        template.indices.dtype), indptr), shape=(m, m))
    return sub, sel


class BorderedPattern:
    """CSC structure and scatter map of the bordered Newton matrix of one model.

    Parameters
    ----------
    num : Numbering
    moment_rot : (n_m,) int
        Orientation-node indices that carry a moment load (their load derivative adds a
        4x4 block).
    load_parts : list of ((n_b, p), (n_b, q)) int, optional
        The coordinate blocks of configuration-dependent loads (rows they load, columns
        they depend on; :mod:`spacarpy.solvers.statics.follower`): each adds its load
        stiffness there, after every other block (a model without them has the same
        pattern and the same sums as before they existed).
    """

    def __init__(self, num: Numbering, moment_rot: np.ndarray, load_parts=()):
        u = num.unknown_of
        n_x = num.n_unknown
        self.n_x = n_x
        self.n = n_x + num.n_constraint
        eu = u[num.euler_coords]                               # (n_eu, 4)
        mu_ = u[num.rot_idx[moment_rot]]                       # (n_m, 4)
        erow = (n_x + num.n_rigid + np.arange(num.euler_nodes.size))[:, None]
        # (rows, columns) of every batch of blocks, in the order assemble() lists the values
        blocks = [(gu, gu) for gu in (u[g.idx] for g in num.groups)]   # element blocks
        blocks += [(eu.reshape(-1, 1), eu.reshape(-1, 1)),     # Euler diagonal
                   (mu_, mu_)]                                 # moment-load blocks
        for g in num.groups:                                   # C_rigid and its transpose
            ru = u[g.idx][g.rigid_elem]                        # (n_rigid_g, n_ldof)
            rrow = (n_x + g.rigid_offset + np.arange(g.rigid_elem.size))[:, None]
            blocks += [(rrow, ru), (ru, rrow)]
        blocks += [(erow, eu), (eu, erow)]                     # C_euler and its transpose
        blocks += [(u[r], u[c]) for r, c in load_parts]        # load stiffness (followers)
        self.n_parts = len(load_parts)
        self.indices, self.indptr, self.scatter = _csc_pattern(self.n, blocks)
        self.nnz = self.indices.size

    def assemble(self, k_elem, euler_diag, moment_blocks, c_rigid, c_euler,
                 scale: float = 1.0, load_blocks=()) -> sp.csc_matrix:
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
        load_blocks : list of (n_b, p, q), one per load part of the pattern
            Their load stiffness ``-df/dx`` (zeros where a part is not loaded).
        """
        parts = [k.ravel() for k in k_elem]
        parts += [np.repeat(euler_diag, 4), moment_blocks.ravel()]
        for c in c_rigid:
            cr = scale * c.ravel()
            parts += [cr, cr]
        ce = scale * c_euler.ravel()
        parts += [ce, ce]
        if self.n_parts:
            parts += [b.ravel() for b in load_blocks]
        data = np.bincount(self.scatter, weights=np.concatenate(parts),
                           minlength=self.nnz + 1)[:self.nnz]
        return sp.csc_matrix((data, self.indices, self.indptr), shape=(self.n, self.n))


def _csc_pattern(n: int, blocks, upper: bool = False):
    """CSC structure of an ``n x n`` matrix that is a sum of dense blocks, and the scatter map.

    ``blocks`` is a list of batches ``(rows, cols)``, int arrays (n_b, p) and (n_b, q): block
    ``e`` of a batch adds its (p, q) values at rows ``rows[e]`` and columns ``cols[e]``; -1
    drops a row/column (a fixed coordinate). The values of all blocks, each batch raveled in C
    order (n_b, p, q) and the batches concatenated, are the entries the scatter map places.
    With ``upper`` only the upper triangle (row <= column) is kept.

    Returns ``indices`` and ``indptr`` (int32; rows sorted within each column) and
    ``scatter``: the position of every entry in the CSC data array, ``nnz`` for a dropped
    one (a spare slot cut off after the sum, cheaper than masking the values at every
    assembly).

    ``np.unique`` of one int64 key per entry (with ``return_inverse``) would sort all the
    entries, ~2e7 for 1e5 beam elements: seconds, and several arrays of that length.
    Instead:

    * the pattern: with the boolean incidence matrices ``R`` and ``C`` (one row per block,
      marking its rows resp. its columns), ``(C^T R)[c, r]`` is nonzero exactly when some
      block covers (row r, column c). So scipy's sparse product ``C^T R`` (compiled, with a
      dense accumulator, work ~ the number of entries; boolean, so nothing cancels) is the
      pattern stored by columns: its CSR arrays are the CSC arrays we want.
    * the scatter map: rows ``r`` and ``r + 1`` of one block are neighbours in every column
      the block covers (no index lies between them), so their positions differ by one. Only
      the first row of each run of consecutive row indices (a node, often the whole block)
      is looked up, in all the block's columns; the other rows add their offset in the run.
      The lookup samples the pattern, holding each entry's position as its value, with
      fancy indexing (compiled; a search in one short column). Positions are stored minus
      ``nnz``, so an entry outside the pattern (a dropped row/column, sent to the extra
      empty row/column ``n``) reads 0 and lands on the spare slot ``nnz``, also after
      adding an offset (the sum is clipped at ``nnz``). With ``upper`` the entries below
      the diagonal are sent there explicitly (a run may cross the diagonal).
    """
    blocks = [(np.asarray(r), np.asarray(c)) for r, c in blocks]
    pattern = (_incidence([c for _, c in blocks], n).T.tocsr()
               @ _incidence([r for r, _ in blocks], n))
    pattern.sort_indices()
    indptr, indices = pattern.indptr, pattern.indices.astype(np.int32, copy=False)
    del pattern
    if upper:
        keep = indices <= np.repeat(np.arange(n, dtype=indices.dtype), np.diff(indptr))
        indices = indices[keep]
        indptr = np.concatenate([[0], np.cumsum(keep, dtype=indptr.dtype)])[indptr]
        del keep
    nnz = indices.size
    indptr = indptr.astype(np.int32)
    pos_type = np.int32 if nnz < np.iinfo(np.int32).max else np.int64
    lookup = sp.csr_array((np.arange(-nnz, 0, dtype=pos_type), indices,
                           np.append(indptr, indptr[-1])), shape=(n + 1, n + 1))
    index_type = lookup.indices.dtype          # spares scipy a conversion of the queries
    scatter = np.empty(sum(r.shape[0] * r.shape[1] * c.shape[1] for r, c in blocks),
                       dtype=np.intp)
    start = 0
    for r, c in blocks:
        (n_b, p), q = r.shape, c.shape[1]
        stop = start + n_b * p * q
        if stop == start:
            continue
        r = np.where(r < 0, n, r).astype(index_type)
        c = np.where(c < 0, n, c).astype(index_type)
        # runs of consecutive row indices within each block (a dropped row is its own run)
        follows = np.zeros((n_b, p), dtype=bool)
        follows[:, 1:] = (r[:, 1:] == r[:, :-1] + 1) & (r[:, 1:] < n)
        flat = np.arange(n_b * p)
        offset = flat - np.maximum.accumulate(np.where(follows.ravel(), 0, flat))
        run = np.cumsum(~follows.ravel()) - 1          # the run of each row, in row order
        e0, a0 = np.nonzero(~follows)                  # the first row of each run
        first = lookup[c[e0].ravel(), np.repeat(r[e0, a0], q)]
        first = np.asarray(first).reshape(-1, q).astype(np.intp) + nnz
        out = scatter[start:stop].reshape(n_b, p, q)
        np.take(first, run.reshape(n_b, p), axis=0, out=out, mode="clip")   # unbuffered
        out += offset.reshape(n_b, p, 1)
        np.minimum(out, nnz, out=out)
        if upper:
            np.copyto(out, nnz, where=r[:, :, None] > c[:, None, :])
        start = stop
    return indices, indptr, scatter


def _incidence(index_blocks, n: int) -> sp.csr_array:
    """Boolean (n_blocks, n) CSR matrix whose row ``e`` marks the valid (>= 0) indices of
    block ``e``, over all batches ``index_blocks`` ((n_b, k) arrays) in turn."""
    keep = [ix >= 0 for ix in index_blocks]
    indices = np.concatenate([ix[k] for ix, k in zip(index_blocks, keep)])
    indptr = np.concatenate([[0], np.cumsum(np.concatenate([k.sum(axis=1) for k in keep]))])
    # 32-bit indices where they fit: scipy keeps the index type of a sparse array, and the
    # product's index arrays (as long as the pattern) would otherwise be 64-bit
    index_type = np.int32 if max(n, indices.size) < np.iinfo(np.int32).max else np.int64
    return sp.csr_array((np.ones(indices.size, dtype=bool), indices.astype(index_type),
                         indptr.astype(index_type)), shape=(indptr.size - 1, n))


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
        self.indices, self.indptr, self.scatter = _csc_pattern(
            n, [(ix, ix) for ix in index_blocks], upper=upper)
        self.nnz = self.indices.size
        self.diag = np.flatnonzero(self.indices == np.repeat(np.arange(n), np.diff(self.indptr)))
        # per batch, the entries that land in the pattern (with ``upper`` 40 % of a BEAM's
        # 14x14 block): only those are gathered and summed, instead of summing all into the
        # spare slot (the same sums in the same order, on less than half the data)
        kept = self.scatter < self.nnz
        self.kept_scatter = self.scatter[kept]
        ends = np.cumsum([ix.shape[0] * ix.shape[1] ** 2 for ix in index_blocks])
        self.kept = [np.flatnonzero(k) for k in np.split(kept, ends[:-1])]
        self.col = np.repeat(np.arange(n), np.diff(self.indptr))   # column of each entry
        self._template = sp.csc_matrix((np.zeros(self.nnz), self.indices, self.indptr),
                                       shape=(n, n))

    def principal_part(self, keep: np.ndarray) -> tuple:
        """:func:`principal_part` of this pattern: ``(sub, sel)`` such that the submatrix
        over the coordinates ``keep`` of an assembled matrix A is ``csc_with_data(sub,
        A.data[sel])``."""
        return principal_part(self._template, keep)

    def assemble(self, blocks, diag_shift: float = 0.0) -> sp.csc_matrix:
        """Fill the pattern with ``blocks`` (one (n_b, k_b, k_b) array per batch)."""
        data = np.bincount(self.kept_scatter, minlength=self.nnz, weights=np.concatenate(
            [b.reshape(-1)[k] for b, k in zip(blocks, self.kept)]))
        if diag_shift:
            data[self.diag] += diag_shift
        return csc_with_data(self._template, data)

    def symmetric_matvec(self, data: np.ndarray, y: np.ndarray) -> np.ndarray:
        """``A y`` for the symmetric A whose upper triangle has the entries ``data`` (a
        pattern made with ``upper=True``). Small patterns: two ``np.bincount`` without
        forming A's transpose (16 against 40 us at 534 entries); from SYMV_BINCOUNT_MAX
        entries on scipy's products are faster (144 against 401 us at 57 000 entries)."""
        if self.nnz > SYMV_BINCOUNT_MAX:
            a = csc_with_data(self._template, data)
            out = a @ y + a.T @ y
        else:
            out = np.bincount(self.indices, weights=data * y[self.col], minlength=self.n)
            out += np.bincount(self.col, weights=data * y[self.indices], minlength=self.n)
        out[self.indices[self.diag]] -= data[self.diag] * y[self.indices[self.diag]]
        return out


def border_slips(A: sp.csc_matrix, n_x: int, S, K_add=None, scale: float = 1.0
                 ) -> sp.csc_matrix:
    """The bordered matrix ``[[K, C^T], [C, 0]]`` (``A``, K of size ``n_x``) with the slip
    rows appended: ``[[K + K_add, C^T, s S^T], [C, 0, 0], [s S, 0, 0]]`` (``S`` (n_slip, n_x)
    the held slips over the free coordinates, ``K_add`` the tangent of their forces
    ``d(S^T nu)/dx``, ``s = scale`` as for the holonomic rows; docs/rolling.md)."""
    n = A.shape[0]
    S = sp.csr_matrix(S)
    if not S.shape[0]:
        return A
    B = sp.hstack([scale * S, sp.csr_matrix((S.shape[0], n - n_x))]).tocsr()
    top = A
    if K_add is not None:
        pad = sp.csr_matrix(K_add)
        top = A + sp.bmat([[pad, None], [None, sp.csr_matrix((n - n_x, n - n_x))]])
    return sp.bmat([[top, B.T], [B, None]], format="csc")
