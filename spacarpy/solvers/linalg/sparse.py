"""Sparse factorizations chosen on measurements (docs/performance.md).

The kinematic correction of the static solver factorizes a symmetric positive definite
Gauss-Newton matrix ``W^T W`` on a pattern that never changes. For it,
:class:`SPDFactorization` uses QDLDL (the ``qdldl`` package of the OSQP project): an
LDL^T factorization whose fill-reducing ordering (AMD) and symbolic analysis are done
once per model, after which each factorization is numerical only, where SuperLU repeats
its COLAMD ordering and symbolic work at every call.

The bordered Newton matrix is a saddle-point matrix with zero diagonal blocks and an
indefinite tangent: LDL^T without pivoting breaks down on it (zero pivots), so it stays
with SuperLU's threshold partial pivoting, except on wide graphs (:class:`SupernodalLU`).

QDLDL is neither supernodal nor threaded: on a 3D lattice of beams its factor has 340
entries per unknown, and the numerical factorization is 11 times slower than a supernodal
one. :func:`choose` therefore sends patterns whose breadth-first levels are wide (3D
frames, lattices; at least :data:`SUPERNODAL_MIN_UNKNOWNS` unknowns) to MKL PARDISO
(:mod:`spacarpy.solvers.linalg.pardiso`) where it is installed, and keeps QDLDL for chains
and small models (docs/solver.md, "Which factorization when").

The scaled matrix handed to QDLDL shares the structure of the assembled one
(:func:`~spacarpy.assembly.csc_with_data`): scipy's constructor and its checks cost more than
QDLDL's numerical factorization of a 10-element model. A dense Cholesky (LAPACK ``dpotrf``)
was measured and not taken: factorization and three solves of the reduced tangent took
43 us against QDLDL's 36 us at 60 unknowns, 240 against 58 us at 180 and 1090 against
130 us at 360 (docs/performance.md, "Small models").
"""
from __future__ import annotations

import os

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from spacarpy.assembly import csc_with_data
from spacarpy.solvers.linalg import pardiso

try:                                         # optional at import, a core dependency
    import qdldl as _qdldl
except ImportError:                          # pragma: no cover - depends on the install
    _qdldl = None


class FactorizationError(RuntimeError):
    """The matrix could not be factorized (singular, not positive definite)."""


class SPDFactorization:
    """Repeated factorizations of SPD matrices that share one sparsity pattern.

    :meth:`factorize` takes the upper triangle (CSC, row <= column, as assembled by
    ``BlockPattern(..., upper=True)``) and returns a ``solve(rhs)`` callable valid until the
    next :meth:`factorize`. The matrix is first scaled symmetrically to a unit diagonal
    (``D A D``, D = diag(A)^-1/2): the static solver's matrices mix positions with Euler
    parameters and element lengths over many decades, and without the scaling the round-off
    of the factorization grows with that spread (at 10^5 elements the kinematic correction's
    steps were noise). Without qdldl, SuperLU factorizes the full symmetric matrix.
    """

    def __init__(self):
        self._solver = None
        self._pattern = None            # (indptr, indices) of the last matrix
        self._col = self._diag = None
        self._factored = False
        self._pardiso = None            # (Pardiso, CSR order of the data, CSC indptr)
        #: "qdldl" or "pardiso" once the first matrix is factorized (:func:`choose`)
        self.backend = None

    def _scaling(self, upper: sp.csc_matrix) -> np.ndarray:
        if self._pattern is None or self._pattern[0] is not upper.indptr:
            col = np.repeat(np.arange(upper.shape[1]), np.diff(upper.indptr))
            self._col, self._diag = col, np.flatnonzero(upper.indices == col)
            self._pattern = (upper.indptr, upper.indices)
        d = np.zeros(upper.shape[0])
        d[upper.indices[self._diag]] = upper.data[self._diag]
        if not np.all(d > 0):
            raise FactorizationError("a diagonal entry is not positive")
        return 1.0 / np.sqrt(d)

    def negative_pivots(self) -> int | None:
        """The number of negative pivots of the last LDL^T factorization: by Sylvester's law
        of inertia (the scaling is a congruence) the number of negative eigenvalues of the
        matrix. None without qdldl or before a factorization."""
        if not self._factored:
            return None
        if self._pardiso is not None:
            return self._pardiso[0].negative_pivots
        if _qdldl is None or self._solver is None:
            return None
        return int(np.sum(self._solver.factors()[1] < 0))

    def perturbed_pivots(self) -> int | None:
        """Pivots the last PARDISO factorization had to perturb (a matrix singular to
        round-off has some); None on the QDLDL path or before a factorization."""
        if not self._factored or self._pardiso is None:
            return None
        return self._pardiso[0].perturbed_pivots

    def factorize(self, upper: sp.csc_matrix):
        self._factored = False
        s = self._scaling(upper)
        scaled = csc_with_data(upper, upper.data * s[upper.indices] * s[self._col])
        if self.backend is None:
            self.backend = choose(scaled)
        if self.backend == "pardiso":
            return self._factorize_pardiso(scaled, s)
        if _qdldl is None:
            full = (scaled + sp.triu(scaled, k=1).T).tocsc()
            try:
                lu = spla.splu(full, permc_spec="COLAMD")
            except RuntimeError as exc:
                raise FactorizationError(str(exc)) from None
            return lambda rhs: s * lu.solve(s * np.asarray(rhs, dtype=float))
        try:
            if self._solver is None:
                self._solver = _qdldl.Solver(scaled, upper=True)
            else:
                self._solver.update(scaled, upper=True)
        except (RuntimeError, ValueError) as exc:
            self._solver = None
            raise FactorizationError(str(exc)) from None
        solver = self._solver
        self._factored = True

        def solve(rhs):
            x = s * solver.solve(np.ascontiguousarray(s * np.asarray(rhs, dtype=float)))
            if not np.all(np.isfinite(x)):
                raise FactorizationError("zero pivot in the LDL^T factorization")
            return x
        return solve

    def _factorize_pardiso(self, scaled: sp.csc_matrix, s: np.ndarray):
        if self._pardiso is None or self._pardiso[2] is not scaled.indptr:
            ia, ja, order = pardiso.upper_csr_order(scaled.indptr, scaled.indices,
                                                    scaled.shape[0])
            self._pardiso = (pardiso.Pardiso(ia, ja), order, scaled.indptr)
        solver, order, _ = self._pardiso
        try:
            solver.factorize(scaled.data[order])
        except pardiso.PardisoError as exc:
            raise FactorizationError(str(exc)) from None
        self._factored = True

        def solve(rhs):
            rhs = np.asarray(rhs, dtype=float)
            w = s if rhs.ndim == 1 else s[:, None]
            x = w * solver.solve(w * rhs)
            if not np.all(np.isfinite(x)):
                raise FactorizationError("zero pivot in the LDL^T factorization")
            return x
        return solve


#: Below this many unknowns QDLDL is always used (PARDISO's start-up and threads do not pay).
SUPERNODAL_MIN_UNKNOWNS = 2000
#: Breadth-first levels explored from unknown 0 to judge the width of the graph.
WIDTH_LEVELS = 30
#: Widest of those levels (unknowns) above which the graph is not chain-like: a chain of
#: beams stays at 6-12 whatever its length, a 3D lattice reaches 200 within 10 levels.
WIDE_GRAPH = 60


def graph_width(upper: sp.csc_matrix, levels: int = WIDTH_LEVELS) -> int:
    """The widest breadth-first level (in unknowns) among the first ``levels`` levels of the
    matrix graph from unknown 0: a cheap measure of the fronts a factorization meets (only
    those levels are explored)."""
    n = upper.shape[0]
    down = (upper.indptr, upper.indices)              # column j: rows i <= j
    # the same triangle by rows: row i holds the columns j >= i
    rows = sp.csr_matrix((np.ones(upper.nnz, dtype=np.int8), upper.indices, upper.indptr),
                         shape=(n, n)).T.tocsr()
    up = (rows.indptr, rows.indices)
    seen = np.zeros(n, dtype=bool)
    frontier = np.array([0])
    seen[0] = True
    widest = 1
    for _ in range(levels):
        found = [_neighbours(ptr, idx, frontier) for ptr, idx in (down, up)]
        nxt = np.unique(np.concatenate(found))
        nxt = nxt[~seen[nxt]]
        if not nxt.size:
            break
        seen[nxt] = True
        widest, frontier = max(widest, nxt.size), nxt
    return widest


def _neighbours(indptr, indices, nodes):
    """The entries of the compressed rows/columns ``nodes``, concatenated."""
    start, stop = indptr[nodes], indptr[nodes + 1]
    counts = stop - start
    if not counts.sum():
        return np.zeros(0, dtype=indices.dtype)
    offs = np.repeat(start - np.concatenate([[0], np.cumsum(counts)[:-1]]), counts)
    return indices[np.arange(counts.sum()) + offs]


def choose(upper: sp.csc_matrix) -> str:
    """The factorization for a pattern: "qdldl" or "pardiso" (docs/solver.md, "Which
    factorization when"). ``SPACARPY_FACTORIZATION=qdldl|pardiso`` forces one (PARDISO only
    where MKL is installed)."""
    forced = os.environ.get("SPACARPY_FACTORIZATION", "auto")
    if forced in ("qdldl", "pardiso"):
        return forced if (forced == "qdldl" or pardiso.available()) else "qdldl"
    if _qdldl is not None and (upper.shape[0] < SUPERNODAL_MIN_UNKNOWNS
                               or graph_width(upper) < WIDE_GRAPH):
        return "qdldl"
    return "pardiso" if pardiso.available() else "qdldl"


class SupernodalLU:
    """PARDISO's LU (nested dissection, supernodal, threaded) of a general square matrix,
    with SuperLU's ``solve`` interface; for wide (3D) bordered matrices, where SuperLU's
    COLAMD fills to about 1 800 entries per row (docs/solver.md). ``perturbed`` counts the
    pivots PARDISO had to perturb: a matrix that is singular to round-off has some."""

    def __init__(self, A: sp.spmatrix):
        csr = sp.csr_matrix(A)
        sym = 0.5 * (csr + csr.T)
        scale = float(np.abs(csr.data).max()) if csr.nnz else 0.0
        if abs(csr - sym).max() <= 1e-12 * scale:
            # symmetric to round-off (the bordered matrix): LDL^T with Bunch-Kaufman pivots
            # and symmetric matching, 3 times faster than the LU and with the inertia
            # with every diagonal entry stored, zero ones too, as PARDISO's symmetric types
            # require (a sum of sparse matrices would drop the constraint rows' zeros)
            n = csr.shape[0]
            t = sp.triu(sym, format="coo")
            diag = np.arange(n)
            upper = sp.coo_matrix((np.concatenate([t.data, np.zeros(n)]),
                                   (np.concatenate([t.row, diag]),
                                    np.concatenate([t.col, diag]))), shape=csr.shape).tocsr()
            upper.sum_duplicates()
            self._p = pardiso.Pardiso(upper.indptr, upper.indices, matching=True)
            self._p.factorize(upper.data)
        else:
            csr.sort_indices()
            self._p = pardiso.Pardiso(csr.indptr, csr.indices, mtype=pardiso.UNSYMMETRIC)
            self._p.factorize(csr.data)
        self.perturbed = self._p.perturbed_pivots
        #: negative eigenvalues (symmetric matrices only, else None)
        self.negative = self._p.negative_pivots
        self.shape = csr.shape

    def solve(self, rhs):
        return self._p.solve(np.asarray(rhs, dtype=float))


def supernodal_lu(A: sp.spmatrix) -> SupernodalLU | None:
    """:class:`SupernodalLU` of ``A``, for a pattern :func:`choose` sent to PARDISO, where no
    pivot had to be perturbed; None otherwise (the caller keeps SuperLU)."""
    try:
        lu = SupernodalLU(A)
    except pardiso.PardisoError:
        return None
    return lu if lu.perturbed == 0 else None
