"""Sparse factorizations chosen on measurements (docs/performance.md).

The kinematic correction of the static solver factorizes a symmetric positive definite
Gauss-Newton matrix ``W^T W`` on a pattern that never changes. For it,
:class:`SPDFactorization` uses QDLDL (the ``qdldl`` package of the OSQP project): an
LDL^T factorization whose fill-reducing ordering (AMD) and symbolic analysis are done
once per model, after which each factorization is numerical only, where SuperLU repeats
its COLAMD ordering and symbolic work at every call.

The bordered Newton matrix is a saddle-point matrix with zero diagonal blocks and an
indefinite tangent: LDL^T without pivoting breaks down on it (zero pivots), so it stays
with SuperLU's threshold partial pivoting.

The scaled matrix handed to QDLDL shares the structure of the assembled one
(:func:`~spacarpy.assembly.csc_with_data`): scipy's constructor and its checks cost more than
QDLDL's numerical factorization of a 10-element model. A dense Cholesky (LAPACK ``dpotrf``)
was measured and not taken: factorization and three solves of the reduced tangent took
43 us against QDLDL's 36 us at 60 unknowns, 240 against 58 us at 180 and 1090 against
130 us at 360 (docs/performance.md, "Small models").
"""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from spacarpy.assembly import csc_with_data

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
        if _qdldl is None or self._solver is None or not self._factored:
            return None
        return int(np.sum(self._solver.factors()[1] < 0))

    def factorize(self, upper: sp.csc_matrix):
        self._factored = False
        s = self._scaling(upper)
        scaled = csc_with_data(upper, upper.data * s[upper.indices] * s[self._col])
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
