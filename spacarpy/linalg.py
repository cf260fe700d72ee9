"""Small batched linear-algebra helpers shared by kernels and solvers (entity index first)."""
from __future__ import annotations

import numpy as np


def batch_matvec(a: np.ndarray, v: np.ndarray) -> np.ndarray:
    """``out[..., i] = a[..., i, j] v[..., j]`` through matmul (batched BLAS, no einsum)."""
    return (a @ v[..., None])[..., 0]
