"""The rotated vectors of orientation nodes and their derivatives, for element kernels.

An element's nodal vectors ``R(q) u_i`` (its reference vectors u_i carried along by the
rotation of an orientation node with Euler parameters q) are quadratic forms in q (see
:mod:`spacarpy.rotation`): ``d(R(q) u_i)/dq = 2 H(u_i) q`` is linear in q and
``R(q) u_i = (2 H(u_i) q) q / 2``. The kernels need those Jacobians for several nodes and
several vectors per element at once; :func:`nodal_jacobians` gives them in two products
(one with a constant, one per element), where one call per node and vector would cost a few
numpy calls each, the fixed cost that dominates small models.
"""
from __future__ import annotations

import numpy as np

from spacarpy.rotation import hessian_combination, quadratic_form

#: ``2 H_k(e_j)[a, :] q = (q @ TQ_VEC)[(j, k, a)]``: the quadratic forms of the unit vectors
#: (``quadratic_form(e_j)[k, a, b] = H_k(e_j)[a, b]``), laid out as [b, (j, k, a)], times 2.
TQ_VEC = 2.0 * np.ascontiguousarray(quadratic_form(np.eye(3)).transpose(3, 0, 1, 2)
                                    .reshape(4, 36))
#: :func:`~spacarpy.rotation.hessian_combination` as one product: ``(mkj (.., 9) @ TQ_H2)``
#: is ``2 sum_kj mkj[k, j] H_k(e_j)`` flattened to (.., 16).
TQ_H2 = hessian_combination(np.eye(9).reshape(9, 3, 3)).reshape(9, 16)


def nodal_jacobians(q: np.ndarray, u: np.ndarray) -> np.ndarray:
    """``d(R(q_m) u_i)/dq_m`` (n, m, 3 k, 4), rows (i, component), for the Euler parameters
    q (n, m, 4) of m nodes per element and k reference vectors u (n, k, 3) per element
    (the same for every node). ``Y @ q_m / 2`` are the rotated vectors themselves."""
    n, m = q.shape[:2]
    k = u.shape[1]
    p = (q.reshape(n * m, 4) @ TQ_VEC).reshape(n, m, 3, 12)     # [j, (k, a)] = 2 H_k(e_j) q
    return (u[:, None] @ p).reshape(n, m, 3 * k, 4)
