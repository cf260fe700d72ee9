"""Nodal compliance: the 6x6 matrix relating a small load on a node to its small motion.

At an equilibrium, a small force dF and moment dT on a position node and its orientation
node cause, to first order, a displacement dr and a rotation dphi with

    [dr; dphi] = C [dF; dT],     C = B K_T^-1 B^T restricted to the degrees of freedom,

computed here from the bordered tangent ``[[K_T, C^T], [C, 0]]`` (constraints kept exactly):
six solves with one LU. The rotation is the global virtual rotation ``dphi = 2 Lambda(q) dq``
and a moment enters as the generalized force ``2 Lambda(q)^T dT``. ``local`` expresses the
same matrix in the node's current body axes (``R^T`` applied to both force and motion), as
SPACAR Light's CMloc; ``global`` is its CMglob. K_T is the full tangent K0 + G0 + N0, so
stress stiffening under load is included.
"""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from spacarpy.rotation import lambda_matrix, rotation_matrix


def nodal_compliance(lin, num, free, pos_row: int, rot_row: int):
    """Compliance (global, local), each (6, 6), of position node row ``pos_row`` with
    orientation node row ``rot_row`` (rows of ``num.pos_idx`` / ``num.rot_idx``)."""
    n_x = lin.K.shape[0]
    n_c = lin.C.shape[0]
    a = sp.bmat([[lin.K, lin.C.T], [lin.C, None]], format="csc") if n_c else lin.K.tocsc()
    u = np.full(num.n_coord, -1, dtype=np.int64)
    u[free] = np.arange(n_x)
    q = lin.x[num.rot_idx[rot_row]]
    lam = lambda_matrix(q)                                     # (3, 4)
    b = np.zeros((6, num.n_coord))                             # maps coordinates -> [dr, dphi]
    b[0:3, num.pos_idx[pos_row]] = np.eye(3)
    b[3:6, num.rot_idx[rot_row]] = 2.0 * lam
    bf = b[:, free]                                            # (6, n_x)
    rhs = np.zeros((a.shape[0], 6))
    rhs[:n_x] = bf.T                                           # generalized forces B^T
    sol = spla.splu(a).solve(rhs)
    c_glob = bf @ sol[:n_x]
    c_glob = 0.5 * (c_glob + c_glob.T) if np.allclose(c_glob, c_glob.T, atol=1e-12 *
                                                       np.abs(c_glob).max()) else c_glob
    r = rotation_matrix(q / np.linalg.norm(q))
    rr = np.kron(np.eye(2), r)
    c_loc = rr.T @ c_glob @ rr
    return c_glob, c_loc
