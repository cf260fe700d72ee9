"""Linearized buckling: load multipliers mu with det(K0 + mu (G0 + N0)) = 0 on the DOFs.

K0 is the material stiffness at the state; G0 + N0 is the load-proportional part of the
tangent (stress resultants including the multipliers of rigid modes, Euler-parameter and
moment-load terms), so ``mu`` multiplies the *whole* load acting in that state (SPACAR's
``eig(-K0, G0)``). Dense reduction to the constraint null space for small models, sparse
shift-invert about mu = 0 on the bordered pencil for large ones.

Classification (round-off never decides it). A mode whose load term does not load it has an
infinite multiplier; computed, it comes out as ``inf``, ``nan`` or, with the round-off of
another machine's BLAS, as 1e16. A multiplier ``mu`` with unit eigenvector ``v`` is
**infinite** when ``|v^T G v|`` is within its round-off::

    |v^T G v| <= SAFETY eps (n ||G||_F + |v|^T (|K| + |K0|) |v|),

n the number of coordinates, eps machine epsilon, SAFETY :data:`SAFETY`: the first term is
the eigensolver's backward error in G, the second the round-off of ``G = K - K0`` itself
(entry by entry eps times the stiffness: 3.5e-10 beside ||G|| = 639 in the clamped column
deck). Equivalently, ``|mu|`` exceeds the bound ``|v^T K0 v|`` divided by that right-hand
side (:func:`infinite_bound`). Such a multiplier has no correct digit; it is reported as
infinite. A load term that vanishes (``G = 0``) makes every multiplier infinite. A state
whose stresses cannot make the structure unstable (one basic-deformation element in Table 3)
has no finite multiplier: :attr:`Buckling.critical` is then ``inf``. A mode that the material
stiffness K0 does not resist beyond its round-off (a mechanism: ``|v^T K0 v|`` within
``SAFETY eps (n ||K0||_F + |v|^T |K0| |v|)``) has the multiplier 0 exactly (:func:`_zero`);
it is never the critical one.

Order (deterministic): the finite multipliers by magnitude; multipliers whose magnitudes agree
to :data:`TIE_RTOL` (the ``+mu, -mu`` pairs of a load whose reversal is symmetric) form one
group, ordered by signed value (negative first); then the infinite ones, stored as NaN (the
schema's "none"). Shapes are scaled so that their largest component is +1.
"""
from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from spacarpy.solvers.linalg.certificate import UNDETERMINED, certified_sign, round_off_bound
from spacarpy.solvers.linear.eigen import DENSE_LIMIT, canonical_sign, null_space_basis

log = logging.getLogger(__name__)

#: Safety factor of the infinity bound. A load term that does not load a mode gives
#: ``|v^T G v|`` of 0.4 to 8 times ``eps ||G||`` on the Table 3 decks (12 coordinates), so
#: the bound ``SAFETY n eps ||G||`` is 15 times above it there.
SAFETY = 10.0
#: Largest ``|Im mu| / |mu|`` of a real multiplier. A non-symmetric pencil (follower loads)
#: turns a double real multiplier (a ring's two n = 2 modes) under round-off into a pair
#: split by about the square root of it: 2.2e-8 measured on a 3D ring of 128 beams under
#: follower pressure, where 1e-8 dropped the lowest pair as complex. A pair closer than
#: 1e-6 to the real axis is at coalescence to the analysis' accuracy: a real double root.
REAL_RTOL = 1e-6
#: Relative tolerance within which two multipliers' magnitudes count as equal for ordering.
TIE_RTOL = 1e-9
#: Codes of :attr:`Buckling.kind` (those of ``MODE_KIND_NAMES``: 0 finite, 4 infinite).
FINITE, INFINITE = 0, 4


@dataclass
class Buckling:
    """Finite load multipliers (ordered as in the module docstring) and buckling shapes.

    Attributes
    ----------
    multiplier : (n_mode,) float
        Real multipliers of the load in the linearized state, NaN where the multiplier is
        infinite (and beyond the number of degrees of freedom).
    kind : (n_mode,) int8
        :data:`FINITE` or :data:`INFINITE` for each entry of ``multiplier``.
    shape : (n_x, n_mode) float
        Shapes over the free coordinates, largest component +1 (NaN for infinite ones).
    critical : float
        Smallest positive multiplier, ``inf`` when there is none.
    """

    multiplier: np.ndarray
    kind: np.ndarray
    shape: np.ndarray
    critical: float


def _quad(v, A):
    """|v^H A v| of each column of ``v``."""
    return np.abs(np.einsum("ij,ij->j", v.conj(), A @ v))


def round_off(lin, v, g_norm: float, n: int) -> np.ndarray:
    """The round-off ``SAFETY eps (n ||G||_F + |v|^T (|K| + |K0|) |v|)`` of ``v^T G v`` for
    each unit column ``v`` (free coordinates) of ``v``."""
    a = abs(lin.K) + abs(lin.K_mat)
    return round_off_bound(n * g_norm + _quad(np.abs(v), a), 1, SAFETY)


def infinite_bound(lin, v) -> np.ndarray:
    """The magnitude above which the multiplier of each unit shape ``v`` (free coordinates,
    one a column) is infinite: ``|v^T K0 v| / round_off``."""
    G = lin.G
    r = round_off(lin, v, float(sp.linalg.norm(G)), v.shape[0])
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(r > 0, _quad(v, lin.K_mat) / r, 0.0)


def _infinite(mu, v, vx, lin, G, g_norm, n):
    """True for the multipliers that are infinite (module docstring); ``v`` the eigenvectors
    of the pencil (K0, -G) with n coordinates, ``vx`` the same over the free coordinates."""
    norm = np.linalg.norm(v, axis=0)
    norm = np.where(norm > 0, norm, 1.0)
    gv = _quad(v / norm, G)
    with np.errstate(invalid="ignore"):
        bound = round_off(lin, vx / norm, g_norm, n)
    return ~np.isfinite(mu) | (certified_sign(gv, bound) == UNDETERMINED)


def _zero(v, K0, k_norm: float) -> np.ndarray:
    """True for the eigenvectors ``v`` (columns; of the pencil whose first matrix is K0, n
    coordinates) that K0 does not resist beyond its round-off: ``|v^T K0 v| <= SAFETY eps
    (n ||K0||_F + |v|^T |K0| |v|)`` for unit v. Their multiplier ``-v^T K0 v / v^T G v`` is
    zero to round-off (a mechanism of the material stiffness: the lean and steer of a
    bicycle at rest), stored as exactly 0: computed, it came out as -3e-15 or +3e-15 with
    another BLAS, and a positive one would be the 'critical' multiplier."""
    norm = np.linalg.norm(v, axis=0)
    u = v / np.where(norm > 0, norm, 1.0)
    n = v.shape[0]
    with np.errstate(invalid="ignore"):
        bound = round_off_bound(n * k_norm + _quad(np.abs(u), abs(K0)), 1, SAFETY)
        return certified_sign(_quad(u, K0), bound) == UNDETERMINED


def canonical_order(mu: np.ndarray) -> np.ndarray:
    """Indices ordering finite real ``mu`` by magnitude, ties (to :data:`TIE_RTOL`) by
    signed value."""
    order = np.argsort(np.abs(mu), kind="stable")
    mag = np.abs(mu[order])
    # a new group wherever the magnitude rises by more than TIE_RTOL from the previous one
    new = np.ones(mag.size, dtype=bool)
    new[1:] = mag[1:] - mag[:-1] > TIE_RTOL * np.maximum(mag[1:], np.finfo(float).tiny)
    group = np.cumsum(new)
    return order[np.lexsort((mu[order], group))]


def buckling_modes(lin, n_modes: int = 6, dense_limit: int = DENSE_LIMIT) -> Buckling:
    """Load multipliers and shapes of the linearization ``lin`` (see the module docstring)."""
    n_x = lin.K.shape[0]
    G = lin.G
    if G.nnz == 0 or not np.any(G.data):            # no load term: nothing can buckle
        return Buckling(multiplier=np.full(n_modes, np.nan),
                        kind=np.full(n_modes, INFINITE, dtype=np.int8),
                        shape=np.full((n_x, n_modes), np.nan), critical=np.inf)
    if n_x <= dense_limit:
        T = null_space_basis(lin.C, n_x)
        k0 = T.T @ (lin.K_mat @ T)
        g0 = T.T @ (G @ T)
        with np.errstate(divide="ignore", invalid="ignore"):
            mu, v = sla.eig(k0, -g0)
        v_red, v = v, T @ v
        infinite = _infinite(mu, v_red, v, lin, g0, float(np.linalg.norm(g0)), k0.shape[0])
        zero = _zero(v_red, k0, float(np.linalg.norm(k0)))
    else:
        n_c = lin.C.shape[0]
        a = sp.bmat([[lin.K_mat, lin.C.T], [lin.C, None]], format="csc")
        b = sp.block_diag([-G, sp.csc_matrix((n_c, n_c))], format="csc")
        lu = spla.splu(a)
        op = spla.LinearOperator(a.shape, matvec=lambda x: lu.solve(b @ x), dtype=float)
        nu, v = spla.eigs(op, k=min(n_modes + 4, a.shape[0] - 2), which="LM")
        with np.errstate(divide="ignore", invalid="ignore"):
            mu = 1.0 / nu
        v = v[:n_x]
        infinite = _infinite(mu, v, v, lin, G, float(sp.linalg.norm(G)), n_x)
        zero = _zero(v, lin.K_mat, float(sp.linalg.norm(lin.K_mat)))
    real = ~infinite & (np.abs(mu.imag) <= REAL_RTOL * np.abs(mu))
    if np.any(~infinite & ~real):
        log.warning("complex buckling multipliers ignored: the load terms are not symmetric "
                    "(follower loads, moments); a buckling analysis finds divergence (real "
                    "multipliers) only, flutter shows as complex w^2 in MODE eigen")
    mu_f = np.where(zero[real], 0.0, mu[real].real)
    v_f = canonical_sign(v[:, real])
    positive = mu_f[mu_f > 0]
    critical = float(positive.min()) if positive.size else np.inf
    order = canonical_order(mu_f)[:n_modes]
    mu_f, v_f = mu_f[order], v_f[:, order]
    kind = np.full(n_modes, INFINITE, dtype=np.int8)
    kind[:mu_f.size] = FINITE
    pad = n_modes - mu_f.size
    if pad > 0:
        mu_f = np.concatenate([mu_f, np.full(pad, np.nan)])
        v_f = np.concatenate([v_f, np.full((n_x, pad), np.nan)], axis=1)
    return Buckling(multiplier=mu_f, kind=kind, shape=v_f, critical=critical)
