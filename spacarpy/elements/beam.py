"""The discrete-deformation-mode (DDM) spatial beam of Jonker & Meijaard (2013), vectorized.

Pure functions on arrays with the element index first. Nothing here knows about decks,
nodes or global numbering. The element kind :class:`Beam` at the end wraps them for the
solvers (:mod:`spacarpy.elements.base`).

Symbols
-------
x : (n_elem, 14)
    Element nodal coordinates ``[r^p (3), q^p (4), r^q (3), q^q (4)]`` (Eq. 6): positions
    of the end nodes and Euler parameters of their orientation nodes.
n_x, n_y, n_z : (n_elem, 3)
    The element's reference triad in the initial configuration: n_x along the chord p->q,
    n_y from the deck's orientation vector made orthogonal to n_x, n_z = n_x x n_y.
    The nodal triads are ``n_y^p = R(q^p) n_y`` etc. (Eq. 1); all orientation nodes start at
    the identity, so every element is undeformed in the initial configuration.
l0 : (n_elem,)
    Reference length ``|r^q - r^p|`` in the initial configuration.
e_hat : (n_elem, 6)
    Basic deformations, Eq. (7): elongation, torsion, four bending modes (unit: length).
e : (n_elem, 6)
    Modified deformations with the second-order coupling terms, Eq. (48b)
    (``e = e_hat`` for the basic variant).
D : (n_elem, 6, 14)
    ``de/dx``, exact.
H(w) : (n_elem, 14, 14)
    ``sum_i w_i d^2 e_i / dx^2`` for per-element weights w (n_elem, 6), exact. With w the
    stress resultants this is the element's geometric stiffness (Eq. 61, second term).
S : (n_elem, 6, 6)
    Stiffness matrix of Eq. (37)-(38) mapping deformations to stress resultants.

How the derivatives are organised
---------------------------------
e_hat depends on x only through the five vectors ``y = [d, n_y^p, n_z^p, n_y^q, n_z^q]``
with ``d = r^q - r^p``, and on those only through their Gram matrix ``g_ab = y_a . y_b``:
the length ``l = sqrt(g_dd)``, the torsion ``l0 (g(n_z^p, n_y^q) - g(n_y^p, n_z^q)) / 2``
and the bending modes ``s_j l0 g(d, a_j) / l``. So ``e_hat_i = c1_i sum_ab B1[i,a,b] g_ab``
with constant forms B1 and the weights ``c1 = [0, l0, l0/l, ...]``, one product with the
Gram entries, and ``de_hat_i/dy = 2 K_i y`` with ``K_i = c1_i B1_i + c2_i E_dd`` (c2 from
the dependence of c1 on l). Each nodal vector ``n = R(q) v`` is a quadratic form in q (see
:mod:`spacarpy.rotation`), so ``Y = dy/dx`` is linear in x and ``d^2y/dx^2`` constant.
The chain rule then gives D and H exactly: ``D_hat = G Y`` and ``H_hat(w) = Y^T H_y Y +
sum_k c_k d^2 y_k/dx^2`` with ``G = de_hat/dy``, ``c = G^T w`` and H_y the weighted second
derivative in y (``2 K_w (x) I3`` plus the curvature of the Gram functions in g_dd and
g_da). Small groups form H_y densely (15 x 15: few, larger numpy calls, the fixed cost per
call of small models); large groups evaluate the products block by block (H_y has only the
blocks d-d, d-p, d-q and p-q) on 3x3 to 6x6 matrices (:mod:`spacarpy.elements.beam_blocks`).
The modified deformations are a quadratic map ``e_i = e_hat_i + e_hat^T Q_i e_hat / (2 l0)``
of the basic ones (Eq. 48b), differentiated once more by the chain rule.
"""
from __future__ import annotations

import weakref
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from spacarpy.elements.base import (
    POS_P,
    POS_Q,
    ROT_AT_P,
    ROT_AT_Q,
    SECTION_MASS,
    Y_AXIS_FIELDS,
    ElementKind,
    Fields,
    Reference,
)
from spacarpy.elements.beam_blocks import blocked_hessian
from spacarpy.elements.beam_layout import BEND_SIGN, BEND_Y, N_LDOF
from spacarpy.elements.beam_mass import (
    beam_convective,
    beam_inertia_force,
    beam_mass_matrix,
    section_axes,
    tangent_gravity,
)
from spacarpy.elements.chunks import in_chunks
from spacarpy.elements.nodal import TQ_H2, nodal_jacobians

N_DEF = 6

def _modified_quadratic_forms() -> np.ndarray:
    """Q[i] (6x6, symmetric) with ``e_i = e_hat_i + e_hat^T Q[i] e_hat / (2 l0)``, Eq. (48b)."""
    q = np.zeros((6, 6, 6))

    def sym(i, a, b, val):
        q[i, a, b] += val
        q[i, b, a] += val

    # e1: (2 e3^2 + e3 e4 + 2 e4^2 + 2 e5^2 + e5 e6 + 2 e6^2) / (30 l0)
    for a, b in ((2, 3), (4, 5)):
        q[0, a, a] = q[0, b, b] = 4.0 / 30.0
        sym(0, a, b, 1.0 / 30.0)
    # e2: (-e3 e6 + e4 e5) / l0
    sym(1, 2, 5, -1.0)
    sym(1, 3, 4, 1.0)
    # e3, e4: +- e2 (e5 + e6) / (6 l0)
    for i, s in ((2, 1.0), (3, -1.0)):
        sym(i, 1, 4, s / 6.0)
        sym(i, 1, 5, s / 6.0)
    # e5, e6: -+ e2 (e3 + e4) / (6 l0)
    for i, s in ((4, -1.0), (5, 1.0)):
        sym(i, 1, 2, s / 6.0)
        sym(i, 1, 3, s / 6.0)
    return q


Q_MODIFIED = _modified_quadratic_forms()


def reference_triads(xp: np.ndarray, xq: np.ndarray, orientation: np.ndarray):
    """Initial element triads and lengths.

    Parameters
    ----------
    xp, xq : (n_elem, 3)
        Initial positions of nodes p and q.
    orientation : (n_elem, 3)
        Initial local y-axis as given in the deck; a row of NaN selects the default: the
        global axis with the smallest component along n_x (SPACAR's rule).

    Returns
    -------
    nx, ny, nz : (n_elem, 3)
    l0 : (n_elem,)
    """
    d = xq - xp
    l0 = np.linalg.norm(d, axis=1)
    nx = d / l0[:, None]
    o = np.array(orientation, dtype=float, copy=True)
    missing = np.isnan(o).any(axis=1)
    if missing.any():
        axis = np.argmin(np.abs(nx[missing]), axis=1)
        o[missing] = np.eye(3)[axis]
    ny = o - np.sum(o * nx, axis=1)[:, None] * nx
    ny /= np.linalg.norm(ny, axis=1)[:, None]
    nz = np.cross(nx, ny)
    return nx, ny, nz, l0


def stiffness_matrix(stiffness: np.ndarray, l0: np.ndarray) -> np.ndarray:
    """S of Eq. (37)-(38) from ``[EA, GJ, EIy, EIz, cy, cz]`` (n_elem, 6) -> (n_elem, 6, 6).

    cy = EIy/(k GA) and cz = EIz/(k GA) are the shear flexibilities of SPACAR's ESTIFF line;
    the shear factor of the bending block with EIy is ``Phi = 12 cy / l0^2``.
    """
    ea, gj, eiy, eiz, cy, cz = stiffness.T
    n = l0.size
    s = np.zeros((n, 6, 6))
    s[:, 0, 0] = ea / l0
    s[:, 1, 1] = gj / l0**3
    for (a, b), ei, c in (((2, 3), eiy, cy), ((4, 5), eiz, cz)):
        phi = 12.0 * c / l0**2
        f = ei / ((1.0 + phi) * l0**3)
        s[:, a, a] = s[:, b, b] = f * (4.0 + phi)
        s[:, a, b] = s[:, b, a] = f * (-2.0 + phi)
    return s


class BeamState(NamedTuple):
    """Deformations and first derivatives at one configuration, plus what H(w) reuses."""

    e: np.ndarray          # (n, 6) deformations of the chosen variant
    D: np.ndarray          # (n, 6, 14)
    e_hat: np.ndarray      # (n, 6) basic deformations
    D_hat: np.ndarray      # (n, 6, 14)
    J: np.ndarray | None   # (n, 6, 6) de/de_hat (None for the basic variant)
    # intermediates for the second derivatives
    y: np.ndarray          # (n, 5, 3) the vectors [d, n_y^p, n_z^p, n_y^q, n_z^q]
    G: np.ndarray          # (n, 6, 15)  de_hat/dy
    Y: np.ndarray          # (n, 2, 6, 4) d[n_y, n_z]/dq of node p and node q
    c12: np.ndarray        # (n, 12) [c1 | c2]: e_hat's first derivatives in the Gram
    #                        entries, the forms B1 and g_dd (see :func:`beam_state`)
    length: np.ndarray     # (n,) current chord length
    l0: np.ndarray         # (n,)
    u: np.ndarray          # (n, 2, 3) reference vectors [n_y, n_z] (nodal ones = R(q) u)
    z: np.ndarray | None   # (n, 15, 14) dy/dx, formed for small groups (``dense``) only


def _gram_forms() -> np.ndarray:
    """B1 (6, 5, 5), symmetric: ``e_hat_i = c1_i sum_ab B1[i, a, b] g_ab`` (i >= 1) for the
    Gram matrix ``g_ab = y_a . y_b`` of y = [d, n_y^p, n_z^p, n_y^q, n_z^q] and the weights
    ``c1 = [0, l0, l0/l, l0/l, l0/l, l0/l]`` (l the current chord length)."""
    b1 = np.zeros((6, 5, 5))
    # torsion: (n_z^p . n_y^q - n_y^p . n_z^q) / 2
    b1[1, 2, 3] = b1[1, 3, 2] = 0.25
    b1[1, 1, 4] = b1[1, 4, 1] = -0.25
    # bending: s_j d . a_j
    for j, (s, a) in enumerate(zip(BEND_SIGN, BEND_Y)):
        b1[2 + j, 0, a] = b1[2 + j, a, 0] = 0.5 * s
    return b1


_B1 = _gram_forms().reshape(6, 25)
_B1T = np.ascontiguousarray(_B1.T)                       # (25, 6)
_B1X2 = 2.0 * _B1
#: Q_MODIFIED as products: ``(e_hat @ _QM)[(i, j)] = sum_k Q[i, j, k] e_hat_k`` and
#: ``(w @ _QW)[(j, k)] = sum_i w_i Q[i, j, k]``.
_QM = np.ascontiguousarray(Q_MODIFIED.reshape(36, 6).T)  # (6, 36)
_QW = Q_MODIFIED.reshape(6, 36)
#: Which Gram weights c1 are l0 / l (the bending modes).
_BENDING_MODES = np.array([0.0, 0.0, 1.0, 1.0, 1.0, 1.0])


def _basic(x, u, l0):
    """The vectors y (n, 5, 3), the nodal Jacobians Y (n, 2, 6, 4), chord length, Gram
    weights c1 (n, 6) and the basic deformations (Eq. 7), shared by :func:`beam_state` and
    :func:`beam_deformations`."""
    n = x.shape[0]
    x2 = x.reshape(n, 2, 7)
    q2 = x2[:, :, 3:]
    Y = nodal_jacobians(q2, u)
    y = np.empty((n, 5, 3))
    np.subtract(x2[:, 1, :3], x2[:, 0, :3], out=y[:, 0])
    y[:, 1:] = (Y @ q2[..., None]).reshape(n, 4, 3)
    y[:, 1:] *= 0.5
    g = (y @ y.transpose(0, 2, 1)).reshape(n, 25)
    length = np.sqrt(g[:, 0])
    c1 = (l0 / length)[:, None] * _BENDING_MODES                # [0, l0, l0/l, ...]
    c1[:, 1] = l0
    e_hat = (g @ _B1T) * c1
    np.subtract(length, l0, out=e_hat[:, 0])
    return y, Y, length, c1, e_hat


def _modified(e_hat, l0, variant):
    """Modified deformations (Eq. 48b) and their quadratic-form matrices ``Q e_hat / l0``."""
    if variant != "modified":
        raise ValueError(f"unknown deformation variant {variant!r}")
    n = e_hat.shape[0]
    qe = (e_hat @ _QM).reshape(n, 6, 6)
    qe /= l0[:, None, None]
    e = (qe @ e_hat[:, :, None])[:, :, 0]
    e *= 0.5
    e += e_hat
    return e, qe


def beam_state(x: np.ndarray, ny: np.ndarray, nz: np.ndarray, l0: np.ndarray,
               variant: str = "modified", u: np.ndarray | None = None,
               dense: bool = False) -> BeamState:
    """Deformations e (Eq. 7 or 48) and their exact Jacobian D at configurations x.

    Parameters
    ----------
    x : (n_elem, 14)
    ny, nz : (n_elem, 3)
        Reference triad vectors (see :func:`reference_triads`).
    l0 : (n_elem,)
    variant : {"modified", "basic"}
    u : (n_elem, 2, 3), optional
        ``[ny, nz]`` stacked, when the caller keeps it (the kind's reference data).
    dense : bool
        Form ``dy/dx`` (kept in the state) and ``D_hat`` in one product: fewer numpy calls
        for small groups, as :func:`beam_weighted_hessian`'s ``dense``; equal to round-off.
    """
    n = x.shape[0]
    if u is None:
        u = np.stack([ny, nz], axis=1)
    y, Y, length, c1, e_hat = _basic(x, u, l0)
    # G = de_hat/dy = 2 K y with K_i = c1_i B1_i + c2_i E_dd (the chain rule through the
    # Gram matrix; c2 = de_hat/dg_dd beyond c1's part: 1/(2 l) and -e_b/(2 l^2))
    c12 = np.empty((n, 12))
    c12[:, :6] = c1
    c2 = c12[:, 6:]
    np.divide(1.0, length, out=c2[:, 0])
    c2[:, 1] = 0.0
    np.divide(e_hat[:, 2:], (-length * length)[:, None], out=c2[:, 2:])
    k = c1[:, :, None] * _B1X2                                     # (n, 6, 25)
    k[:, :, 0] = c2
    G = (k.reshape(n, 30, 5) @ y).reshape(n, 6, 15)
    c2 *= 0.5
    if dense:                       # D_hat = G dy/dx in one product (small groups)
        z = _dy_dx(Y)
        D_hat = G @ z
    else:                           # block by block: less arithmetic per element
        z = None
        D_hat = np.empty((n, 6, N_LDOF))
        d4 = D_hat.reshape(n, 6, 2, 7)
        np.negative(G[:, :, :3], out=d4[:, :, 0, :3])
        d4[:, :, 1, :3] = G[:, :, :3]
        d4[:, :, :, 3:] = (G[:, :, 3:].reshape(n, 6, 2, 6).transpose(0, 2, 1, 3)
                           @ Y).transpose(0, 2, 1, 3)
    if variant == "basic":
        e, D, J = e_hat, D_hat, None
    else:
        e, qe = _modified(e_hat, l0, variant)
        J = qe + _EYE6
        D = J @ D_hat
    return BeamState(e=e, D=D, e_hat=e_hat, D_hat=D_hat, J=J, y=y, G=G, Y=Y, c12=c12,
                     length=length, l0=l0, u=u, z=z)


_EYE6 = np.eye(6)
#: dy/dx with the nodal blocks still empty (d = r^q - r^p), and where the nodal blocks go:
#: rows 3 + 6 m + r, columns 3 + 7 m + a of node m's Y[m, r, a] in the flattened (15, 14).
_Z0 = np.zeros((15, N_LDOF))
_Z0[:3, :3], _Z0[:3, 7:10] = -np.eye(3), np.eye(3)
_Z_Y = np.array([(3 + 6 * m + r) * N_LDOF + 3 + 7 * m + a
                 for m in range(2) for r in range(6) for a in range(4)])


def _dy_dx(Y: np.ndarray) -> np.ndarray:
    """``dy/dx`` (n, 15, 14) from the nodal Jacobians Y (n, 2, 6, 4)."""
    n = Y.shape[0]
    z = np.repeat(_Z0[None], n, axis=0)
    z.reshape(n, 15 * N_LDOF)[:, _Z_Y] = Y.reshape(n, 48)
    return z


def beam_deformations(x: np.ndarray, ny: np.ndarray, nz: np.ndarray, l0: np.ndarray,
                      variant: str = "modified", u: np.ndarray | None = None) -> np.ndarray:
    """The deformations e (n_elem, 6) of :func:`beam_state` alone, without their
    derivatives (for the iterations of the kinematic correction, a third of the work)."""
    if u is None:
        u = np.stack([ny, nz], axis=1)
    e_hat = _basic(x, u, l0)[4]
    return e_hat if variant == "basic" else _modified(e_hat, l0, variant)[0]


def beam_weighted_hessian(st: BeamState, w: np.ndarray, dense: bool = False) -> np.ndarray:
    """``sum_i w_i d^2 e_i / dx^2`` at the state ``st``; w (n_elem, 6) -> (n_elem, 14, 14).

    ``dense``: form it densely (:func:`_dense`, fewer numpy calls: small groups) rather
    than block by block (:mod:`spacarpy.elements.beam_blocks`); the two agree to round-off."""
    if st.J is None:
        return _second_derivatives(st, w, None, dense)
    # e = e_hat + e_hat^T Q e_hat / (2 l0): weights on e_hat and the quadratic part
    return _second_derivatives(st, (w[:, None, :] @ st.J)[:, 0], _quadratic_weights(st, w),
                               dense)


def _quadratic_weights(st: BeamState, w: np.ndarray) -> np.ndarray:
    """``sum_i w_i Q_i / l0`` (n, 6, 6): the second derivative of the modified deformations
    with respect to the basic ones, weighted."""
    qw = (w @ _QW).reshape(-1, 6, 6)
    qw /= st.l0[:, None, None]
    return qw


def beam_tangent(st: BeamState, S: np.ndarray, w: np.ndarray, dense: bool = False
                 ) -> np.ndarray:
    """The element tangent ``D^T S D + sum_i w_i d^2 e_i / dx^2`` (n_elem, 14, 14).

    For the modified deformations ``D = J D_hat``, so the material part and the quadratic
    part of the second derivatives share the outer factors:
    ``D_hat^T (J^T S J + sum_i w_i Q_i / l0) D_hat``, and with ``D_hat = G dy/dx`` that is
    one more term of the y-space matrix (:func:`_second_derivatives`); ``dense`` as for
    :func:`beam_weighted_hessian`."""
    if st.J is None:
        return _second_derivatives(st, w, S, dense)
    jt = st.J.transpose(0, 2, 1)
    inner = jt @ (S @ st.J)
    inner += _quadratic_weights(st, w)
    return _second_derivatives(st, (w[:, None, :] @ st.J)[:, 0], inner, dense)


#: Groups of up to this many elements get their second derivatives formed densely in y
#: (few, larger numpy calls: the fixed cost per call of small models); larger ones block by
#: block (less arithmetic and memory per element). The choice is the group's, not a
#: chunk's (:class:`Beam`), so that chunks give the whole call's bits; both are exact and
#: tests/test_kernel_paths.py compares them. Measured in whole static solves of the
#: cantilever (CPU time, best of 7, the two limits alternated; session 9): dense against
#: block 0.093 against 0.100 s at 100 elements, 0.099 against 0.111 s at 128, 0.143 against
#: 0.136 s at 160.
DENSE_MAX = 128


def _second_derivatives(st: BeamState, w_hat: np.ndarray, inner: np.ndarray | None,
                        dense: bool):
    """``sum_i w_hat_i d^2 e_hat_i / dx^2 + D_hat^T inner D_hat`` (n, 14, 14)."""
    if dense:
        return _dense(st, w_hat, inner)
    hx = blocked_hessian(st, w_hat)
    if inner is not None:
        hx += st.D_hat.transpose(0, 2, 1) @ (inner @ st.D_hat)
    return hx


#: The two weight rows of :func:`_dense`: w_hat itself (for ``c = G^T w_hat``) and the
#: weights of the curvature vectors (half the elongation's, no torsion).
_W2 = np.array([[1.0] * 6, [0.5, 0.0, 1.0, 1.0, 1.0, 1.0]])
#: ``kron(K, I3)`` of a 5x5 K (flattened) as a product with a constant: (25, 225).
_KRON3 = np.einsum("ac,bd,ij->cdaibj", np.eye(5), np.eye(5), np.eye(3)).reshape(25, 225)
#: [c1 | c2] (n, 12) weights -> 2 K_w (x) I3 (n, 225) in one product.
_KW_KRON = np.vstack([_B1X2, np.outer(np.full(6, 2.0), np.eye(25)[0])]) @ _KRON3


def _dense(st: BeamState, w_hat: np.ndarray, inner: np.ndarray | None) -> np.ndarray:
    """:func:`_second_derivatives` densely in y (few numpy calls: small groups).

    ``e_hat_i = f_i(g)`` of the Gram entries g (quadratic in y), so the weighted second
    derivative in y is ``2 K_w (x) I3`` (``K_w = sum_i w_i K_i``, the forms of the first
    derivatives) plus the curvature of f in g_dd and g_da, ``D h^T + h D^T`` with
    ``D = [d, 0, 0, 0, 0]`` and ``h = -(sum_i w'_i G_i) / l^2 + kappa D`` (w' = w_hat with
    half the elongation's weight and none of the torsion's; ``kappa = (w_b . e_b) / (2
    l^4)`` over the bending modes); ``D_hat^T inner D_hat`` adds ``G^T inner G``. The y
    matrix H (15 x 15) maps to x as ``Z^T H Z`` with ``Z = dy/dx``, plus
    ``sum_k c_k d^2 y_k/dx^2`` with ``c = G^T w_hat`` (the nodal vectors are quadratic in
    the Euler parameters)."""
    n = w_hat.shape[0]
    y, G, inv2 = st.y, st.G, 1.0 / (st.length * st.length)
    wc = (w_hat[:, None, :] * st.c12.reshape(n, 2, 6)).reshape(n, 12)
    h = (wc @ _KW_KRON).reshape(n, 15, 15)                       # 2 K_w (x) I3
    cw = (w_hat[:, None, :] * _W2) @ G                           # (n, 2, 15): c, w'^T G
    hv = cw[:, 1] * (-inv2)[:, None]
    d = y[:, 0]
    kappa = (w_hat[:, None, 2:] @ st.e_hat[:, 2:, None])[:, 0, 0] * (0.5 * inv2 * inv2)
    hv[:, :3] += kappa[:, None] * d
    outer = d[:, :, None] * hv[:, None, :]                        # (n, 3, 15): rows of D h^T
    h[:, :3] += outer
    h[:, :, :3] += outer.transpose(0, 2, 1)
    if inner is not None:
        h += G.transpose(0, 2, 1) @ (inner @ G)
    z = _dy_dx(st.Y) if st.z is None else st.z
    hx = z.transpose(0, 2, 1) @ (h @ z)
    # sum_k c_k d^2 y_k/dq^2 of both nodes: hessian_combination(sum_i c_i u_i^T)
    c = cw[:, 0, 3:].reshape(n, 2, 2, 3).transpose(0, 1, 3, 2)    # (n, node, k, i)
    hx += ((c @ st.u[:, None]).reshape(n, 18) @ _TQ_H14).reshape(n, N_LDOF, N_LDOF)
    return hx


#: TQ_H2 of both nodes placed in their Euler-parameter blocks of the 14 x 14: (18, 196).
_TQ_H14 = np.zeros((2, 9, N_LDOF, N_LDOF))
_TQ_H14[0, :, 3:7, 3:7] = TQ_H2.reshape(9, 4, 4)
_TQ_H14[1, :, 10:14, 10:14] = TQ_H2.reshape(9, 4, 4)
_TQ_H14 = _TQ_H14.reshape(18, N_LDOF * N_LDOF)


# ------------------------------------------------------------------------------ the kind
#: Largest ``|e_hat_k| / l0`` (torsion, bending) accepted in a converged BEAM state: the basic
#: deformations of Eq. (7) are sines of relative rotations, near 1 (90 degrees) they
#: saturate, the Jacobian loses rank and Newton can land on a spurious equilibrium.
MAX_BEAM_ROTATION = 0.95


def check_saturation(st: BeamState, ref: BeamReference):
    """(element row, message) of the most rotated element past :data:`MAX_BEAM_ROTATION`,
    or None."""
    rel = np.abs(st.e_hat[:, 1:]) / ref.l0[:, None]
    if rel.size and rel.max() > MAX_BEAM_ROTATION:
        i, k = np.unravel_index(np.argmax(rel), rel.shape)
        return int(i), (
            f"deformation mode {k + 2} reached |e/l0| = {rel[i, k]:.3f}, a relative rotation "
            f"of about {np.degrees(np.arcsin(min(rel[i, k], 1.0))):.0f} degrees inside one "
            f"element. The deformation measures of Eq. (7) saturate at 90 degrees, so this "
            f"state is not a valid beam solution; use more elements.")
    return None


def beam_gravity(x: np.ndarray, ref: BeamReference, mass: np.ndarray, g: np.ndarray):
    """Hermite centre line (Eq. 57): int r = l0 [r^p/2 + l0 n_x^p/12 + r^q/2 - l0 n_x^q/12]."""
    n = x.shape[0]
    m = mass[:, 0] * ref.l0
    f = np.zeros((n, 14))
    k = np.zeros((n, 14, 14))
    f[:, 0:3] = f[:, 7:10] = 0.5 * m[:, None] * g
    for qs, sign in ((slice(3, 7), 1.0), (slice(10, 14), -1.0)):
        fq, kq = tangent_gravity(x[:, qs], ref.nx, g, sign * m * ref.l0 / 12.0)
        f[:, qs] = fq
        k[:, qs, qs] = kq
    return f, k


@dataclass(frozen=True, slots=True, eq=False)
class BeamReference(Reference):
    """A BEAM group's reference data (also the PLBEAM's), from :meth:`Beam.reference`.

    nx, ny, nz : (n_elem, 3)
        The reference triad (unit vectors, see :func:`reference_triads`).
    l0 : (n_elem,)
        Initial lengths (m).
    axes : (n_elem, 3, 3) or None
        ``[nx, ny, nz]`` stacked as rows once (the mass kernels' section forms).
    u : (n_elem, 2, 3) or None
        ``[ny, nz]`` stacked (the kernels' nodal vectors); None: stacked at each call.
    """

    nx: np.ndarray
    ny: np.ndarray
    nz: np.ndarray
    l0: np.ndarray
    axes: np.ndarray | None = None
    u: np.ndarray | None = None

    def take(self, rows) -> BeamReference:
        return _with_forms(self, Reference.take(self, rows), lambda f: f[rows])

    def tile(self, reps: int) -> BeamReference:
        if reps == 1:
            return self
        return _with_forms(self, Reference.tile(self, reps),
                           lambda f: np.concatenate([f] * reps))


#: The section inertia forms (:func:`~spacarpy.elements.beam_mass.section_axes`) of a
#: :class:`BeamReference`, made on first use and kept beside the record (keyed by its
#: identity, dropped with it) rather than in it: they depend on the element axes alone, but
#: most beams have no section inertia and the forms are twice the record's size.
_SECTION_FORMS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def _with_forms(ref: BeamReference, out: BeamReference, op) -> BeamReference:
    """``out`` (a part or copies of ``ref``) with ``op`` of ref's section forms, if made."""
    forms = _SECTION_FORMS.get(ref)
    if forms is not None:
        _SECTION_FORMS[out] = op(forms)
    return out


def _section(ref: BeamReference, m: np.ndarray):
    """The section inertia forms of a group's reference data (made on first use, see
    :data:`_SECTION_FORMS`), or None for EM values without section inertia."""
    if not np.count_nonzero(m[:, 1:]):
        return None
    forms = _SECTION_FORMS.get(ref)
    if forms is None:
        forms = _SECTION_FORMS[ref] = section_axes(
            np.stack([ref.nx, ref.ny, ref.nz], axis=1) if ref.axes is None else ref.axes)
    return forms


class Beam(ElementKind):
    """``BEAM e p r q s [oy_x oy_y oy_z]``: the spatial DDM beam (kernels above; its
    mass, with the section rotary inertia lumped or consistent, in
    :mod:`spacarpy.elements.beam_mass`). Large kernels run chunk by
    chunk (:func:`spacarpy.elements.chunks.in_chunks`)."""

    keyword = "BEAM"
    slots = ("pos", "rot", "pos", "rot")
    node_roles = ("p", "r", "q", "s")
    modes = ("elongation", "torsion", "bending y at p", "bending y at q", "bending z at p",
             "bending z at q")
    mode_units = ("m",) * 6
    stress_units = ("N",) * 6
    deformation_meaning = "generalized deformations of each BEAM element"
    stress_meaning = ("generalized stress resultants (dual to the deformations) of each BEAM "
                      "element")
    length_modes = (True,) * 6
    #: the 7th value (BEAMW's warping stiffness) is accepted with a warning and ignored
    estiff = Fields(("EA", "GJ", "EIy", "EIz", "cy", "cz"),
                    ("N", "N m^2", "N m^2", "N m^2", "m^2", "m^2"), 4, 7,
                    "EA GJ EIy EIz")
    mode_stiffness = (0, 1, 2, 2, 3, 3)
    em = SECTION_MASS
    vector = "local y-axis"
    summary = "spatial beam element between two position nodes"
    node_fields = (POS_P, ROT_AT_P, POS_Q, ROT_AT_Q)
    vector_fields = Y_AXIS_FIELDS
    reference_type = BeamReference

    def reference(self, x0, vector):
        nx, ny, nz, l0 = reference_triads(x0[0], x0[2], vector)
        # the axes stacked once here rather than at every kernel call: axes = [n_x, n_y, n_z]
        # (rows) and u = [n_y, n_z]
        axes = np.stack([nx, ny, nz], axis=1)
        return (BeamReference(nx, ny, nz, l0, axes, axes[:, 1:]),
                np.repeat(l0[:, None], 6, axis=1))

    def state(self, x, ref, variant, prev):
        return in_chunks(beam_state, len(x), x, ref.ny, ref.nz, ref.l0, variant,
                         ref.u, len(x) <= DENSE_MAX)

    def deformations(self, x, ref, variant, prev):
        return in_chunks(beam_deformations, len(x), x, ref.ny, ref.nz, ref.l0, variant,
                         ref.u)

    def hessian(self, st, w):
        return in_chunks(beam_weighted_hessian, len(w), st, w, len(w) <= DENSE_MAX)

    def tangent(self, st, S, w):
        return in_chunks(beam_tangent, len(w), st, S, w, len(w) <= DENSE_MAX)

    def stiffness(self, props, ref):
        return stiffness_matrix(props, ref.l0)

    def inertia_geometry(self, ref) -> tuple:
        """``(tangents, n_y, n_z, length)`` of the mass kernels: the end tangents (one for
        both ends here, the chord's) and the length the mass is spread over."""
        return ref.nx, ref.ny, ref.nz, ref.l0

    def mass(self, x, ref, m, rotary="lumped"):
        return in_chunks(beam_mass_matrix, len(x), x, *self.inertia_geometry(ref), m, rotary,
                         _section(ref, m))

    def convective(self, x, v, ref, m, rotary="lumped"):
        return in_chunks(beam_convective, len(x), x, v, *self.inertia_geometry(ref), m,
                         rotary, _section(ref, m))

    def inertia_force(self, x, v, a, ref, m, rotary="lumped"):
        return in_chunks(beam_inertia_force, len(x), x, v, a, *self.inertia_geometry(ref), m,
                         rotary, _section(ref, m))

    def check(self, st, ref):
        return check_saturation(st, ref)

    def gravity(self, x, ref, mass, g):
        return beam_gravity(x, ref, mass, g)
