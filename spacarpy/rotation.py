"""Euler parameters: rotation matrices and their exact derivatives, vectorized.

Symbols (Jonker & Meijaard 2013, Eq. 2-4 and 10)
-------------------------------------------------
q = (lambda0, lambda1, lambda2, lambda3)
    Euler parameters of an orientation node, shape (..., 4); q.q = 1 on the constraint
    manifold.
R(q) = (lambda0^2 - lambda.lambda) I + 2 lambda0 [lambda~] + 2 lambda lambda^T
    The rotation matrix (Eq. 2). R is a *quadratic form* in q: for a fixed vector v,
    ``(R(q) v)_k = q^T H_k(v) q`` with constant symmetric 4x4 matrices ``H_k(v)`` that are
    linear in v. Hence ``d(R v)/dq = 2 H(v) q`` and ``d^2(R v)/dq^2 = 2 H(v)``, exactly.
Lambda(q) = [-lambda, lambda0 I + [lambda~]]  (3x4)
    Maps Euler-parameter variations to virtual rotations in global axes:
    ``delta phi = 2 Lambda(q) delta q`` (Eq. 10), and ``Lambda(q) q = 0``.

All functions take arrays with any leading batch shape and are pure.
"""
from __future__ import annotations

import numpy as np

from spacarpy.linalg import cross3

# Levi-Civita symbol eps[i, j, k].
_EPS = np.zeros((3, 3, 3))
_EPS[0, 1, 2] = _EPS[1, 2, 0] = _EPS[2, 0, 1] = 1.0
_EPS[0, 2, 1] = _EPS[2, 1, 0] = _EPS[1, 0, 2] = -1.0


def _quadratic_form_tensor() -> np.ndarray:
    """Constant tensor T[k, a, b, j] with ``H_k(v)[a, b] = T[k, a, b, j] v_j``.

    From R(q) v = (l0^2 - l.l) v + 2 l0 (l x v) + 2 l (l.v), written symmetrically in q.
    """
    t = np.zeros((3, 4, 4, 3))
    for k in range(3):
        t[k, 0, 0, k] += 1.0                      # l0^2 v_k
        for i in range(3):
            t[k, i + 1, i + 1, k] -= 1.0          # -l_i^2 v_k
            for j in range(3):                    # 2 l0 eps_kij l_i v_j
                t[k, 0, i + 1, j] += _EPS[k, i, j]
                t[k, i + 1, 0, j] += _EPS[k, i, j]
            t[k, k + 1, i + 1, i] += 1.0          # 2 l_k l_i v_i, symmetrized
            t[k, i + 1, k + 1, i] += 1.0
    return t


_T = _quadratic_form_tensor()


def quadratic_form(v: np.ndarray) -> np.ndarray:
    """Matrices H(v), shape (..., 3, 4, 4), with ``(R(q) v)_k = q^T H_k(v) q``."""
    return np.einsum("kabj,...j->...kab", _T, v)


# The quadratic forms of the rotated unit vectors, _TQ_UNIT[j, k, a, b] = H_k(e_j)[a, b]. H is
# linear in its vector, so the forms of any vectors are contractions of this tensor.
_TQ_UNIT = np.einsum("kabj->jkab", _T)
_TQ_Q = _TQ_UNIT.transpose(3, 1, 2, 0).reshape(4, 36)     # [b, (k, a, j)]
_TQ_H = _TQ_UNIT.transpose(1, 0, 2, 3).reshape(9, 16)     # [(k, j), (a, b)]


def vector_jacobians(q: np.ndarray, u: np.ndarray) -> np.ndarray:
    """``d(R(q) u_i)/dq = 2 H(u_i) q``, shape (n, m, 3, 4), for q (n, 4) and m vectors
    u (n, m, 3) per element."""
    n, m = u.shape[:2]
    p = (q @ _TQ_Q).reshape(n, 12, 3)                 # [(k, a), j] = H_k(e_j)[a, :] q
    return 2.0 * (p @ u.transpose(0, 2, 1)).transpose(0, 2, 1).reshape(n, m, 3, 4)


def hessian_combination(mkj: np.ndarray) -> np.ndarray:
    """``2 sum_kj mkj[k, j] H_k(e_j)``, shape (n, 4, 4), for mkj (n, 3, 3). The second
    derivative ``sum_i c_i . d^2(R u_i)/dq^2`` is this with ``mkj = sum_i c_i u_i^T``."""
    return 2.0 * (mkj.reshape(-1, 9) @ _TQ_H).reshape(-1, 4, 4)


def rotate(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """``R(q) v`` for batches: q (..., 4), v (..., 3) -> (..., 3). Exact for unnormalized q."""
    l0 = q[..., :1]
    lam = q[..., 1:]
    return ((l0 * l0 - np.sum(lam * lam, axis=-1, keepdims=True)) * v
            + 2.0 * l0 * cross3(lam, v)
            + 2.0 * lam * np.sum(lam * v, axis=-1, keepdims=True))


def rotation_matrix(q: np.ndarray) -> np.ndarray:
    """R(q), shape (..., 3, 3), Eq. (2)."""
    eye = np.broadcast_to(np.eye(3), q.shape[:-1] + (3, 3))
    return np.stack([rotate(q, eye[..., :, j]) for j in range(3)], axis=-1)


def lambda_matrix(q: np.ndarray) -> np.ndarray:
    """Lambda(q) = [-lambda, lambda0 I + [lambda~]], shape (..., 3, 4), Eq. (10): one
    product with a constant (Lambda is linear in q, its entries are +-q_i, exactly)."""
    return (q @ _LAMBDA_TENSOR).reshape(q.shape[:-1] + (3, 4))


def skew(v: np.ndarray) -> np.ndarray:
    """The tilde matrix [v~] with [v~] w = v x w, shape (..., 3, 3), Eq. (3)."""
    out = np.zeros(v.shape[:-1] + (3, 3))
    out[..., 0, 1] = -v[..., 2]
    out[..., 0, 2] = v[..., 1]
    out[..., 1, 0] = v[..., 2]
    out[..., 1, 2] = -v[..., 0]
    out[..., 2, 0] = -v[..., 1]
    out[..., 2, 1] = v[..., 0]
    return out


def _lambda_entries(q: np.ndarray) -> np.ndarray:
    """Lambda(q) entry by entry (for the constant of :func:`lambda_matrix`)."""
    out = np.zeros((3, 4))
    out[:, 0] = -q[1:]
    out[:, 1:] = q[0] * np.eye(3) + skew(q[1:])
    return out


#: ``Lambda(q) = (q @ _LAMBDA_TENSOR).reshape(3, 4)``.
_LAMBDA_TENSOR = np.stack([_lambda_entries(e).ravel() for e in np.eye(4)])


def moment_matrix(t: np.ndarray) -> np.ndarray:
    """B(T), shape (..., 4, 4), with ``Lambda(q)^T T = B(T) q`` for a moment T (..., 3).

    The generalized force of a dead moment on the Euler parameters is ``2 B(T) q``; its
    derivative ``2 B(T)`` is constant and skew-symmetric.
    """
    out = np.zeros(t.shape[:-1] + (4, 4))
    out[..., 0, 1:] = -t
    out[..., 1:, 0] = t
    out[..., 1:, 1:] = skew(t)
    return out


def from_axis_angle(axis: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """Euler parameters of a rotation by ``angle`` (rad) about the unit vector ``axis``."""
    axis = np.asarray(axis, dtype=float)
    angle = np.asarray(angle, dtype=float)
    axis = axis / np.linalg.norm(axis, axis=-1, keepdims=True)
    half = 0.5 * angle[..., None]
    return np.concatenate([np.cos(half), np.sin(half) * axis], axis=-1)


def tangent_part(q: np.ndarray, qd: np.ndarray) -> np.ndarray:
    """Rates (n, 4) of Euler parameters q (n, 4) without their component along q: the rates
    of a unit quaternion satisfy ``q . dq = 0``; the radial part only changes the length."""
    qq = (q * q).sum(axis=-1, keepdims=True)          # (methods: no dispatch wrapper)
    return qd - (q * qd).sum(axis=-1, keepdims=True) / qq * q

