"""Small batched linear-algebra helpers shared by kernels and solvers (entity index first)."""
from __future__ import annotations

import numpy as np


def batch_matvec(a: np.ndarray, v: np.ndarray) -> np.ndarray:
    """``out[..., i] = a[..., i, j] v[..., j]`` through matmul (batched BLAS, no einsum)."""
    return (a @ v[..., None])[..., 0]


def cross3(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``np.cross(a, b)`` of vectors along the last axis (length 3, broadcasting), with
    numpy's arithmetic (``a1 b2 - a2 b1``, ...: the same bits) but without its axis
    handling, which costs 20-50 us a call on small arrays (the rotating frame calls it
    about 20 times a step)."""
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    out = np.empty(np.broadcast_shapes(a.shape, b.shape),
                   dtype=np.result_type(a.dtype, b.dtype))
    np.subtract(a1 * b2, a2 * b1, out=out[..., 0])
    np.subtract(a2 * b0, a0 * b2, out=out[..., 1])
    np.subtract(a0 * b1, a1 * b0, out=out[..., 2])
    return out


def property_columns(values, n_cols: int, name: str) -> np.ndarray:
    """Element property values (n_elem,) or (n_elem, k <= n_cols) -> (n_elem, n_cols); missing
    and NaN trailing values are 0 (ESTIFF / EM lines may leave values out). Values that are
    that already (float, all columns, no NaN: what a model's groups hold) are returned as
    they are, not copied (the mass kernels call this at every evaluation); callers only
    read the result."""
    v = np.asarray(values, dtype=float)
    if v.ndim == 2 and v.shape[1] == n_cols and not np.isnan(v).any():
        return v
    if v.ndim == 1:
        v = v[:, None]
    if v.ndim != 2 or v.shape[1] > n_cols:
        raise ValueError(f"{name}: expected (n_elem,) or (n_elem, <= {n_cols}) values, "
                         f"got shape {v.shape}")
    out = np.zeros((v.shape[0], n_cols))
    out[:, :v.shape[1]] = np.nan_to_num(v, nan=0.0)
    return out
