"""The sign of a determinant from SuperLU factors (the parity of a matrix's negative
eigenvalues where it is symmetric: the arc-length path's and the load limit's test)."""
from __future__ import annotations

import numpy as np


def _permutation_sign(perm) -> int:
    """(-1)^(number of transpositions) of a permutation array."""
    perm = np.asarray(perm)
    seen = np.zeros(perm.size, bool)
    sign = 1
    for i in range(perm.size):
        if seen[i]:
            continue
        j, length = i, 0
        while not seen[j]:
            seen[j] = True
            j = perm[j]
            length += 1
        if length % 2 == 0:
            sign = -sign
    return sign


def determinant_sign(lu) -> int:
    """Sign of the determinant of a matrix from its SuperLU factors (L has a unit diagonal)."""
    d = lu.U.diagonal()
    neg = int(np.sum(d < 0))
    return (-1) ** neg * _permutation_sign(lu.perm_r) * _permutation_sign(lu.perm_c)


__all__ = ["determinant_sign"]
