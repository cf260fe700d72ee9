"""The BEAM's weighted second derivatives block by block, for large element groups.

``sum_i w_hat_i d^2 e_hat_i / dx^2`` of the basic deformations (Eq. 7) at a state of
:func:`spacarpy.elements.beam.beam_state` (its fields y, G, Y, u, length, l0; see that
module's docstring for the chain rule). The weighted second derivative in
``y = [d, n_y^p, n_z^p, n_y^q, n_z^q]`` has only the blocks d-d, d-p, d-q and p-q, so the
products are evaluated on 3x3 to 6x6 matrices: less arithmetic and memory per element than
the dense form of :mod:`spacarpy.elements.beam` (which small groups take, for its fewer numpy
calls); the two agree to round-off (tests/test_kernel_paths.py).
"""
from __future__ import annotations

import numpy as np

from spacarpy.elements.beam_layout import BEND_SIGN, BEND_Y, N_LDOF, QP, QQ, RP, RQ
from spacarpy.rotation import hessian_combination


def blocked_hessian(st, w_hat: np.ndarray) -> np.ndarray:
    """``sum_i w_hat_i d^2 e_hat_i / dx^2`` (n, 14, 14) at the BEAM state ``st`` for the
    weights w_hat (n, 6) on the basic deformations."""
    n = w_hat.shape[0]
    length, l0 = st.length, st.l0
    n1 = st.y[:, 0] / length[:, None]
    outer = n1[:, :, None] * n1[:, None, :]
    proj_op = np.eye(3) - outer                                       # (n,3,3)
    # the bending modes e_j = s_j l0 (n1 . a_j) with weights c_j = s_j l0 w_j: their
    # second derivatives in d are linear in a_j, so the four sum to one term in
    # b = sum_j c_j a_j and p = sum_j c_j (n1 . a_j)
    coef = (BEND_SIGN * l0[:, None]) * w_hat[:, 2:6]                 # (n, 4)
    a = st.y[:, BEND_Y]
    b = np.einsum("nj,njk->nk", coef, a)
    p = np.einsum("nj,nk,njk->n", coef, n1, a)[:, None, None]
    bn1 = b[:, :, None] * n1[:, None, :]
    dd = -(bn1 + bn1.transpose(0, 2, 1)) - p * np.eye(3) + 3.0 * p * outer
    hdd = ((w_hat[:, 0] / length)[:, None, None] * proj_op
           + (1.0 / length**2)[:, None, None] * dd)
    # (d, nodal vector) blocks: c_j / length times the projector, in y's vector order
    cl = (coef / length[:, None])[:, _VEC_MODE]                       # [nyp nzp nyq nzq]
    hdpq = (proj_op[:, :, None, :] * cl[:, None, :, None]).reshape(n, 3, 12)
    hdp, hdq = hdpq[:, :, :6], hdpq[:, :, 6:]
    c2 = (0.5 * l0 * w_hat[:, 1])[:, None, None] * np.eye(3)
    hpq = np.zeros((n, 6, 6))
    hpq[:, 3:6, 0:3] = c2                                             # n_z^p . n_y^q
    hpq[:, 0:3, 3:6] = -c2                                            # n_y^p . n_z^q
    yp, yq = st.Y[:, 0], st.Y[:, 1]
    hx = np.zeros((n, N_LDOF, N_LDOF))
    hx[:, RP, RP] = hx[:, RQ, RQ] = hdd
    hx[:, RP, RQ] = hx[:, RQ, RP] = -hdd
    dp = hdp @ yp                                                     # (n,3,4)
    dq = hdq @ yq
    hx[:, RP, QP], hx[:, RQ, QP] = -dp, dp
    hx[:, RP, QQ], hx[:, RQ, QQ] = -dq, dq
    pq = yp.transpose(0, 2, 1) @ (hpq @ yq)                           # (n,4,4)
    hx[:, QP, QQ] = pq
    hx[:, QP, RP], hx[:, QP, RQ] = -dp.transpose(0, 2, 1), dp.transpose(0, 2, 1)
    hx[:, QQ, RP], hx[:, QQ, RQ] = -dq.transpose(0, 2, 1), dq.transpose(0, 2, 1)
    hx[:, QQ, QP] = pq.transpose(0, 2, 1)
    # the nodal vectors are quadratic in q: d^2 n_k/dq^2 = 2 H_k
    c = (w_hat[:, None, :] @ st.G)[:, 0]                                    # (n, 15)
    # sum_k c_k d^2(R u)_k/dq^2 over both vectors = hessian_combination(sum_i c_i u_i^T)
    hx[:, QP, QP] += hessian_combination(c[:, 3:9].reshape(n, 2, 3).transpose(0, 2, 1) @ st.u)
    hx[:, QQ, QQ] += hessian_combination(c[:, 9:15].reshape(n, 2, 3).transpose(0, 2, 1) @ st.u)
    return hx


#: The bending modes' nodal vectors in y's order [n_y^p, n_z^p, n_y^q, n_z^q].
_VEC_MODE = np.argsort(BEND_Y)
