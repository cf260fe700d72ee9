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
    Reference length |r^q - r^p| in the initial configuration.
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
e_hat depends on x only through 15 intermediate quantities
``y = [d, n_y^p, n_z^p, n_y^q, n_z^q]`` with ``d = r^q - r^p``. Each nodal vector
``n = R(q) v`` is a quadratic form in q (see :mod:`spacarpy.rotation`), so ``dy/dx`` is
linear in x and ``d^2y/dx^2`` constant. The chain rule then gives D and H exactly:
``D_hat = G Y``, ``H_hat(w) = Y^T (sum_j w_j d^2 e_hat_j/dy^2) Y + sum_k c_k d^2 y_k/dx^2``
with ``G = de_hat/dy``, ``Y = dy/dx`` and ``c = G^T w``. Y is block sparse (d depends on the
positions only, the nodal vectors of p on q^p only, those of q on q^q only) and the weighted
second derivative in y has only the blocks d-d, d-p, d-q and p-q, so both products are
evaluated block by block on 3x3 to 6x6 matrices instead of 15x14. The modified deformations are a
quadratic map ``e_i = e_hat_i + e_hat^T Q_i e_hat / (2 l0)`` of the basic ones (Eq. 48b),
differentiated once more by the chain rule.
"""
from __future__ import annotations

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
)
from spacarpy.elements.beam_layout import N_LDOF, QP, QQ, RP, RQ
from spacarpy.elements.beam_mass import (
    beam_convective,
    beam_inertia_force,
    beam_mass_matrix,
    tangent_gravity,
)
from spacarpy.elements.chunks import in_chunks
from spacarpy.linalg import batch_matvec
from spacarpy.rotation import hessian_combination, vector_jacobians

N_DEF = 6

# Intermediate slices y = [d, nyp, nzp, nyq, nzq].
YD, YNYP, YNZP, YNYQ, YNZQ = (slice(0, 3), slice(3, 6), slice(6, 9), slice(9, 12),
                              slice(12, 15))


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
    y: np.ndarray          # (n, 15)
    G: np.ndarray          # (n, 6, 15)  de_hat/dy
    Yp: np.ndarray         # (n, 6, 4) d[n_y^p, n_z^p]/dq^p
    Yq: np.ndarray         # (n, 6, 4) d[n_y^q, n_z^q]/dq^q
    n1: np.ndarray         # (n, 3) unit chord
    length: np.ndarray     # (n,) current chord length
    l0: np.ndarray         # (n,)
    u: np.ndarray          # (n, 2, 3) reference vectors [n_y, n_z] (nodal ones = R(q) u)


def beam_state(x: np.ndarray, ny: np.ndarray, nz: np.ndarray, l0: np.ndarray,
               variant: str = "modified") -> BeamState:
    """Deformations e (Eq. 7 or 48) and their exact Jacobian D at configurations x.

    Parameters
    ----------
    x : (n_elem, 14)
    ny, nz : (n_elem, 3)
        Reference triad vectors (see :func:`reference_triads`).
    l0 : (n_elem,)
    variant : {"modified", "basic"}
    """
    n = x.shape[0]
    u, Yp, Yq, y, length, n1, e_hat, proj = _basic(x, ny, nz, l0)
    nyp, nzp, nyq, nzq = y[:, YNYP], y[:, YNZP], y[:, YNYQ], y[:, YNZQ]
    lc = l0[:, None]
    G = np.zeros((n, 6, 15))
    G[:, 0, YD] = n1
    G[:, 1, YNZP] = 0.5 * lc * nyq
    G[:, 1, YNYQ] = 0.5 * lc * nzp
    G[:, 1, YNYP] = -0.5 * lc * nzq
    G[:, 1, YNZQ] = -0.5 * lc * nyp
    # bending modes: e_j = s_j l0 (n1 . a_j), all four at once
    sl0 = _BEND_SIGN * lc                                           # (n, 4) s_j l0
    a = _bending_vectors(y)
    G[:, 2:6, YD] = (sl0 / length[:, None])[:, :, None] * (a - proj[:, :, None] * n1[:, None])
    G[:, _BEND_ROWS, _BEND_COLS] = (sl0[:, :, None] * n1[:, None]).reshape(n, 12)
    D_hat = np.empty((n, 6, N_LDOF))
    D_hat[:, :, RP] = -G[:, :, YD]
    D_hat[:, :, RQ] = G[:, :, YD]
    D_hat[:, :, QP] = G[:, :, 3:9] @ Yp
    D_hat[:, :, QQ] = G[:, :, 9:15] @ Yq

    if variant == "basic":
        e, D, J = e_hat, D_hat, None
    else:
        e, qe = _modified(e_hat, l0, variant)
        J = np.eye(6) + qe
        D = J @ D_hat
    return BeamState(e=e, D=D, e_hat=e_hat, D_hat=D_hat, J=J, y=y, G=G, Yp=Yp, Yq=Yq, n1=n1,
                     length=length, l0=l0, u=u)


def _basic(x, ny, nz, l0):
    """The nodal vectors and basic deformations (Eq. 7) shared by :func:`beam_state` and
    :func:`beam_deformations`: (u, Yp, Yq, y, length, n1, e_hat, bending projections)."""
    n = x.shape[0]
    qp, qq = x[:, QP], x[:, QQ]
    d = x[:, RQ] - x[:, RP]
    # nodal vectors n = R(q) v = q^T H(v) q (quadratic in q) and their derivatives 2 H(v) q;
    # Yp = d[n_y^p, n_z^p]/dq^p (n, 6, 4), and n = (2 H q) . q / 2
    u = np.stack([ny, nz], axis=1)                                  # (n, 2, 3)
    Yp = vector_jacobians(qp, u).reshape(n, 6, 4)
    Yq = vector_jacobians(qq, u).reshape(n, 6, 4)
    vp = 0.5 * batch_matvec(Yp, qp)                                 # [n_y^p, n_z^p]
    vq = 0.5 * batch_matvec(Yq, qq)
    y = np.concatenate([d, vp, vq], axis=1)
    nyp, nzp, nyq, nzq = vp[:, :3], vp[:, 3:], vq[:, :3], vq[:, 3:]
    length = np.linalg.norm(d, axis=1)
    n1 = d / length[:, None]
    e_hat = np.empty((n, 6))
    e_hat[:, 0] = length - l0
    e_hat[:, 1] = 0.5 * l0 * (np.sum(nzp * nyq, 1) - np.sum(nyp * nzq, 1))
    # bending modes: e_j = s_j l0 (n1 . a_j)
    proj = np.einsum("nk,njk->nj", n1, _bending_vectors(y))           # (n, 4)
    e_hat[:, 2:6] = (_BEND_SIGN * l0[:, None]) * proj
    return u, Yp, Yq, y, length, n1, e_hat, proj


def _modified(e_hat, l0, variant):
    """Modified deformations (Eq. 48b) and their quadratic-form matrices ``Q e_hat / l0``."""
    if variant != "modified":
        raise ValueError(f"unknown deformation variant {variant!r}")
    n = e_hat.shape[0]
    qe = (e_hat @ Q_MODIFIED.reshape(36, 6).T).reshape(n, 6, 6) / l0[:, None, None]
    return e_hat + 0.5 * batch_matvec(qe, e_hat), qe


def beam_deformations(x: np.ndarray, ny: np.ndarray, nz: np.ndarray, l0: np.ndarray,
                      variant: str = "modified") -> np.ndarray:
    """The deformations e (n_elem, 6) of :func:`beam_state` alone, without their
    derivatives (for the iterations of the kinematic correction, a third of the work)."""
    e_hat = _basic(x, ny, nz, l0)[6]
    return e_hat if variant == "basic" else _modified(e_hat, l0, variant)[0]


# (mode index, sign, slice of the nodal vector in y, name) for e3..e6 of Eq. (7).
_BENDING = ((2, -1.0, YNZP, "nzp"), (3, 1.0, YNZQ, "nzq"), (4, 1.0, YNYP, "nyp"),
            (5, -1.0, YNYQ, "nyq"))
#: The same as arrays: signs of e3..e6, the nodal vector of each among y's four
#: [n_y^p, n_z^p, n_y^q, n_z^q], and the (row, column) of G where its n1 goes.
_BEND_SIGN = np.array([b[1] for b in _BENDING])
_BEND_VEC = np.array([(b[2].start - 3) // 3 for b in _BENDING])
_BEND_ROWS = np.repeat([b[0] for b in _BENDING], 3)
_BEND_COLS = np.concatenate([np.arange(b[2].start, b[2].stop) for b in _BENDING])
#: The bending modes' nodal vectors in the order [n_y^p, n_z^p, n_y^q, n_z^q].
_VEC_MODE = np.argsort(_BEND_VEC)


def _bending_vectors(y: np.ndarray) -> np.ndarray:
    """The nodal vectors a_j of the bending modes e3..e6 (n, 4, 3), from y (n, 15)."""
    return y[:, 3:15].reshape(-1, 4, 3)[:, _BEND_VEC]


def beam_weighted_hessian(st: BeamState, w: np.ndarray) -> np.ndarray:
    """``sum_i w_i d^2 e_i / dx^2`` at the state ``st``; w (n_elem, 6) -> (n_elem, 14, 14)."""
    if st.J is None:
        return _basic_hessian(st, w)
    # e = e_hat + e_hat^T Q e_hat / (2 l0): weights on e_hat and the quadratic part
    hx = _basic_hessian(st, batch_matvec(st.J.transpose(0, 2, 1), w))
    hx += st.D_hat.transpose(0, 2, 1) @ (_quadratic_weights(st, w) @ st.D_hat)
    return hx


def _quadratic_weights(st: BeamState, w: np.ndarray) -> np.ndarray:
    """``sum_i w_i Q_i / l0`` (n, 6, 6): the second derivative of the modified deformations
    with respect to the basic ones, weighted."""
    return (w @ Q_MODIFIED.reshape(6, 36)).reshape(-1, 6, 6) / st.l0[:, None, None]


def beam_tangent(st: BeamState, S: np.ndarray, w: np.ndarray) -> np.ndarray:
    """The element tangent ``D^T S D + sum_i w_i d^2 e_i / dx^2`` (n_elem, 14, 14).

    For the modified deformations ``D = J D_hat``, so the material part and the quadratic
    part of the second derivatives share the outer factors:
    ``D_hat^T (J^T S J + sum_i w_i Q_i / l0) D_hat``, one product with the 14-column D_hat
    instead of two (the largest products of the tangent)."""
    if st.J is None:
        hx = _basic_hessian(st, w)
        hx += st.D.transpose(0, 2, 1) @ (S @ st.D)
        return hx
    jt = st.J.transpose(0, 2, 1)
    hx = _basic_hessian(st, batch_matvec(jt, w))
    inner = jt @ (S @ st.J) + _quadratic_weights(st, w)
    hx += st.D_hat.transpose(0, 2, 1) @ (inner @ st.D_hat)
    return hx


def _basic_hessian(st: BeamState, w_hat: np.ndarray) -> np.ndarray:
    """``sum_i w_hat_i d^2 e_hat_i / dx^2`` (basic deformations, Eq. 7) at the state ``st``."""
    n = w_hat.shape[0]
    # weighted second derivatives of e_hat with respect to y, by blocks:
    # hdd (d, d), hdp (d, [n_y^p n_z^p]), hdq (d, [n_y^q n_z^q]), hpq (p vectors, q vectors)
    length, n1, y = st.length, st.n1, st.y
    outer = n1[:, :, None] * n1[:, None, :]
    proj_op = np.eye(3) - outer                                       # (n,3,3)
    # the bending modes e_j = s_j l0 (n1 . a_j) with weights c_j = s_j l0 w_j: their
    # second derivatives in d are linear in a_j, so the four sum to one term in
    # b = sum_j c_j a_j and p = sum_j c_j (n1 . a_j)
    coef = (_BEND_SIGN * st.l0[:, None]) * w_hat[:, 2:6]              # (n, 4)
    a = _bending_vectors(y)
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
    c2 = (0.5 * st.l0 * w_hat[:, 1])[:, None, None] * np.eye(3)
    hpq = np.zeros((n, 6, 6))
    hpq[:, 3:6, 0:3] = c2                                             # n_z^p . n_y^q
    hpq[:, 0:3, 3:6] = -c2                                            # n_y^p . n_z^q

    hx = np.zeros((n, N_LDOF, N_LDOF))
    hx[:, RP, RP] = hx[:, RQ, RQ] = hdd
    hx[:, RP, RQ] = hx[:, RQ, RP] = -hdd
    dp = hdp @ st.Yp                                                  # (n,3,4)
    dq = hdq @ st.Yq
    hx[:, RP, QP], hx[:, RQ, QP] = -dp, dp
    hx[:, RP, QQ], hx[:, RQ, QQ] = -dq, dq
    pq = st.Yp.transpose(0, 2, 1) @ (hpq @ st.Yq)                     # (n,4,4)
    hx[:, QP, QQ] = pq
    hx[:, QP, RP], hx[:, QP, RQ] = -dp.transpose(0, 2, 1), dp.transpose(0, 2, 1)
    hx[:, QQ, RP], hx[:, QQ, RQ] = -dq.transpose(0, 2, 1), dq.transpose(0, 2, 1)
    hx[:, QQ, QP] = pq.transpose(0, 2, 1)
    # the nodal vectors are quadratic in q: d^2 n_k/dq^2 = 2 H_k
    c = batch_matvec(st.G.transpose(0, 2, 1), w_hat)                       # (n, 15)
    # sum_k c_k d^2(R u)_k/dq^2 over both vectors = hessian_combination(sum_i c_i u_i^T)
    hx[:, QP, QP] += hessian_combination(c[:, 3:9].reshape(n, 2, 3).transpose(0, 2, 1) @ st.u)
    hx[:, QQ, QQ] += hessian_combination(c[:, 9:15].reshape(n, 2, 3).transpose(0, 2, 1) @ st.u)
    return hx


# ------------------------------------------------------------------------------ the kind
#: Largest |e_hat_k| / l0 (torsion, bending) accepted in a converged BEAM state: the basic
#: deformations of Eq. (7) are sines of relative rotations, near 1 (90 degrees) they
#: saturate, the Jacobian loses rank and Newton can land on a spurious equilibrium.
MAX_BEAM_ROTATION = 0.95


def check_saturation(st: BeamState, ref: dict):
    """(element row, message) of the most rotated element past :data:`MAX_BEAM_ROTATION`,
    or None."""
    rel = np.abs(st.e_hat[:, 1:]) / ref["l0"][:, None]
    if rel.size and rel.max() > MAX_BEAM_ROTATION:
        i, k = np.unravel_index(np.argmax(rel), rel.shape)
        return int(i), (
            f"deformation mode {k + 2} reached |e/l0| = {rel[i, k]:.3f}, a relative rotation "
            f"of about {np.degrees(np.arcsin(min(rel[i, k], 1.0))):.0f} degrees inside one "
            f"element. The deformation measures of Eq. (7) saturate at 90 degrees, so this "
            f"state is not a valid beam solution; use more elements.")
    return None


def beam_gravity(x: np.ndarray, ref: dict, mass: np.ndarray, g: np.ndarray):
    """Hermite centre line (Eq. 57): int r = l0 [r^p/2 + l0 n_x^p/12 + r^q/2 - l0 n_x^q/12]."""
    n = x.shape[0]
    m = mass[:, 0] * ref["l0"]
    f = np.zeros((n, 14))
    k = np.zeros((n, 14, 14))
    f[:, 0:3] = f[:, 7:10] = 0.5 * m[:, None] * g
    for qs, sign in ((slice(3, 7), 1.0), (slice(10, 14), -1.0)):
        fq, kq = tangent_gravity(x[:, qs], ref["nx"], g, sign * m * ref["l0"] / 12.0)
        f[:, qs] = fq
        k[:, qs, qs] = kq
    return f, k


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

    def reference(self, x0, vector):
        nx, ny, nz, l0 = reference_triads(x0[0], x0[2], vector)
        return dict(nx=nx, ny=ny, nz=nz, l0=l0), np.repeat(l0[:, None], 6, axis=1)

    def state(self, x, ref, variant, prev):
        return in_chunks(beam_state, len(x), x, ref["ny"], ref["nz"], ref["l0"], variant)

    def deformations(self, x, ref, variant, prev):
        return in_chunks(beam_deformations, len(x), x, ref["ny"], ref["nz"], ref["l0"], variant)

    def hessian(self, st, w):
        return in_chunks(beam_weighted_hessian, len(w), st, w)

    def tangent(self, st, S, w):
        return in_chunks(beam_tangent, len(w), st, S, w)

    def stiffness(self, props, ref):
        return stiffness_matrix(props, ref["l0"])

    def mass(self, x, ref, m, rotary="lumped"):
        return in_chunks(beam_mass_matrix, len(x), x, ref["nx"], ref["ny"], ref["nz"],
                         ref["l0"], m, rotary)

    def convective(self, x, v, ref, m, rotary="lumped"):
        return in_chunks(beam_convective, len(x), x, v, ref["nx"], ref["ny"], ref["nz"],
                         ref["l0"], m, rotary)

    def inertia_force(self, x, v, a, ref, m, rotary="lumped"):
        return in_chunks(beam_inertia_force, len(x), x, v, a, ref["nx"], ref["ny"], ref["nz"],
                         ref["l0"], m, rotary)

    def check(self, st, ref):
        return check_saturation(st, ref)

    def gravity(self, x, ref, mass, g):
        return beam_gravity(x, ref, mass, g)
