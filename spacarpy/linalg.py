"""Small batched linear-algebra helpers shared by kernels and solvers (entity index first)."""
from __future__ import annotations

import numpy as np


def batch_matvec(a: np.ndarray, v: np.ndarray) -> np.ndarray:
    """``out[..., i] = a[..., i, j] v[..., j]`` through matmul (batched BLAS, no einsum)."""
    return (a @ v[..., None])[..., 0]


def property_columns(values, n_cols: int, name: str) -> np.ndarray:
    """Element property values (n_elem,) or (n_elem, k <= n_cols) -> (n_elem, n_cols); missing
    and NaN trailing values are 0 (ESTIFF / EM lines may leave values out)."""
    v = np.asarray(values, dtype=float)
    if v.ndim == 1:
        v = v[:, None]
    if v.ndim != 2 or v.shape[1] > n_cols:
        raise ValueError(f"{name}: expected (n_elem,) or (n_elem, <= {n_cols}) values, "
                         f"got shape {v.shape}")
    out = np.zeros((v.shape[0], n_cols))
    out[:, :v.shape[1]] = np.nan_to_num(v, nan=0.0)
    return out
