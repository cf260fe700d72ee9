"""Linearized buckling: load multipliers mu with det(K0 + mu (G0 + N0)) = 0 on the DOFs.

K0 is the material stiffness at the state; G0 + N0 is the load-proportional part of the
tangent (stress resultants including the multipliers of rigid modes, Euler-parameter and
moment-load terms), so ``mu`` multiplies the *whole* load acting in that state (SPACAR's
``eig(-K0, G0)``). Dense reduction to the constraint null space for small models, sparse
shift-invert about mu = 0 on the bordered pencil for large ones. A state whose stresses
cannot make the structure unstable (e.g. one basic-deformation element in Table 3) has no
finite multiplier: :attr:`Buckling.critical` is then ``inf``.
"""
from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from spacarpy.solvers.eigen import DENSE_LIMIT, null_space_basis

log = logging.getLogger(__name__)


@dataclass
class Buckling:
    """Finite load multipliers (smallest magnitude first) and buckling shapes.

    Attributes
    ----------
    multiplier : (n_mode,) float
        Real multipliers of the load in the linearized state (NaN-padded to the requested
        number when fewer finite ones exist).
    shape : (n_x, n_mode) float
        Shapes over the free coordinates, largest component 1.
    critical : float
        Smallest positive multiplier, ``inf`` when there is none.
    """

    multiplier: np.ndarray
    shape: np.ndarray
    critical: float


def buckling_modes(lin, n_modes: int = 6, dense_limit: int = DENSE_LIMIT) -> Buckling:
    n_x = lin.K.shape[0]
    G = lin.G
    if n_x <= dense_limit:
        T = null_space_basis(lin.C, n_x)
        k0 = T.T @ (lin.K_mat @ T)
        g0 = T.T @ (G @ T)
        mu, v = sla.eig(k0, -g0)
        v = T @ v
    else:
        n_c = lin.C.shape[0]
        a = sp.bmat([[lin.K_mat, lin.C.T], [lin.C, None]], format="csc")
        b = sp.block_diag([-G, sp.csc_matrix((n_c, n_c))], format="csc")
        lu = spla.splu(a)
        op = spla.LinearOperator(a.shape, matvec=lambda x: lu.solve(b @ x), dtype=float)
        nu, v = spla.eigs(op, k=min(n_modes + 4, n_x - 1), which="LM")
        with np.errstate(divide="ignore", invalid="ignore"):
            mu = 1.0 / nu
        v = v[:n_x]
    finite = np.isfinite(mu) & (np.abs(mu.imag) <= 1e-8 * np.abs(mu))
    if np.any(np.isfinite(mu) & ~finite):
        log.warning("complex buckling multipliers ignored (non-symmetric load terms)")
    mu_f = mu[finite].real
    v_f = v[:, finite].real
    order = np.argsort(np.abs(mu_f))
    mu_f, v_f = mu_f[order][:n_modes], v_f[:, order][:, :n_modes]
    big = np.abs(v_f).max(axis=0, initial=0.0)
    v_f = v_f / np.where(big > 0, big, 1.0)
    positive = mu_f[mu_f > 0]
    critical = float(positive.min()) if positive.size else np.inf
    pad = n_modes - mu_f.size
    if pad > 0:
        mu_f = np.concatenate([mu_f, np.full(pad, np.nan)])
        v_f = np.concatenate([v_f, np.full((n_x, pad), np.nan)], axis=1)
    return Buckling(multiplier=mu_f, shape=v_f, critical=critical)
