"""Sparse factorizations chosen on measurements (docs/performance.md).

The kinematic correction of the static solver factorizes a symmetric positive definite
Gauss-Newton matrix ``W^T W`` on a pattern that never changes. For it,
:class:`SPDFactorization` uses QDLDL (the ``qdldl`` package of the OSQP project): an
LDL^T factorization whose fill-reducing ordering (AMD) and symbolic analysis are done
once per model, after which each factorization is numerical only. On the 10^4-element
cantilever (70 000 unknowns) it factorizes in 12-15 ms where SuperLU needs 80 ms (COLAMD
ordering and symbolic work repeated at every call) and solves in 2-3 ms instead of 8.

The bordered Newton matrix is a saddle-point matrix with zero diagonal blocks and an
indefinite tangent: LDL^T without pivoting breaks down on it (zero pivots), so it stays
with SuperLU's threshold partial pivoting.
"""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

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
    next :meth:`factorize`. Without qdldl, SuperLU factorizes the full symmetric matrix.
    """

    def __init__(self):
        self._solver = None

    def factorize(self, upper: sp.csc_matrix):
        if _qdldl is None:
            full = (upper + sp.triu(upper, k=1).T).tocsc()
            try:
                return spla.splu(full, permc_spec="COLAMD").solve
            except RuntimeError as exc:
                raise FactorizationError(str(exc)) from None
        try:
            if self._solver is None:
                self._solver = _qdldl.Solver(upper, upper=True)
            else:
                self._solver.update(upper, upper=True)
        except (RuntimeError, ValueError) as exc:
            self._solver = None
            raise FactorizationError(str(exc)) from None
        solver = self._solver

        def solve(rhs):
            x = solver.solve(np.ascontiguousarray(rhs, dtype=float))
            if not np.all(np.isfinite(x)):
                raise FactorizationError("zero pivot in the LDL^T factorization")
            return x
        return solve
