"""The spatial HINGE element (SPACAR ``HINGE e Rp Rq ax ay az``), vectorized.

A hinge connects two orientation nodes p and q. Its first deformation is the relative rotation
about the hinge axis; the other two are the (small) relative rotations about two axes normal
to it, which are zero (rigid) in an ideal revolute joint. Pure functions on arrays with the
element index first, mirroring :mod:`spacarpy.elements.beam`.

Local coordinates
-----------------
x : (n_elem, 8)
    ``[q^p (4), q^q (4)]``: Euler parameters of the two orientation nodes.

Reference triad
---------------
From the deck's axis vector ``(ax, ay, az)`` in global axes (initial configuration),
:func:`hinge_reference` builds the orthonormal, right-handed triad ``(a, b, c)``:

- ``a`` = the axis vector normalized;
- ``b`` = the global unit axis ``e_k`` with the smallest ``|a_k|`` (the first such k on ties;
  the same rule as the default y-axis of a BEAM), made orthogonal to ``a`` (Gram-Schmidt) and
  normalized;
- ``c = a x b``.

For example axis x -> (b, c) = (y, z); axis y -> (x, -z); axis z -> (x, y).
The nodal triads are ``a^p = R(q^p) a``, ``b^p = R(q^p) b``, ... and likewise for q; all
orientation nodes start at the identity, so the hinge is undeformed initially.

Deformations (1-based, as SPACAR's DYNE/RLSE number them)
---------------------------------------------------------
1. ``e1 = atan2(s, c) + 2 pi k`` with ``s = c^p.b^q - b^p.c^q`` and
   ``c = b^p.b^q + c^p.c^q``: the rotation angle of node q relative to node p about the hinge
   axis, right-handed about ``a`` (rad). If q^q is q^p followed by a rotation by theta about
   the (current) axis, ``e1 = theta`` (mod 2 pi). The integer number of turns k is 0 by default
   (``e1`` in (-pi, pi]); with ``e1_previous`` (typically the value of the previous converged
   state) k is chosen so that e1 is the branch closest to ``e1_previous``, which makes e1
   continuous through +-pi and over multiple turns provided it changes by less than pi between
   the state of ``e1_previous`` and the current one. ``HingeState.turns`` returns the k used.
   e1 is insensitive to the scale of the Euler parameters. The dual stress resultant is the
   moment about the hinge axis (N m).
2. ``e2 = (a^p.cbar^q - c^p.a^q) / 2``: a small relative rotation about ``b^p``;
3. ``e3 = (b^p.a^q - a^p.bbar^q) / 2``: a small relative rotation about ``c^p``;

   with ``bbar^q = cos(e1) b^q - sin(e1) c^q`` and ``cbar^q = cos(e1) c^q + sin(e1) b^q``:
   the triad of q turned back by the joint angle about its axis (cos e1 = c/rho,
   sin e1 = s/rho with rho^2 = s^2 + c^2; no branch enters: they are functions of the
   configuration). At e1 = 0 these are the classic ``(a^p.c^q - c^p.a^q) / 2`` and
   ``(b^p.a^q - a^p.b^q) / 2``: for a relative rotation by phi about b (psi about c) alone,
   ``e2 = sin(phi)`` (``e3 = sin(psi)``), dimensionless, ~ rad.

Modes 2 and 3 are normally rigid (not listed in DYNE/RLSE): together they make the revolute
joint constraint. e1 is singular only where ``s = c = 0``, i.e. when the axis of q is turned
over by 180 degrees with respect to that of p, far away from a working hinge.

Why the turned-back triad (every joint angle)
---------------------------------------------
The classic forms (those above with ``b^q, c^q`` for ``bbar^q, cbar^q``) have, on the joint
(q = p turned by t about a), gradients that are relative rotations about the axes b and c
turned by t/2, of length ``|cos(t/2)|``: a relative rotation dphi of q about b^p changes
them by ``dphi cos^2(t/2)`` and ``-dphi sin(t)/2``. Their stress resultants are then the
physical moments divided by cos(t/2) (1e17 N m at 180 degrees) and the joint constraint
loses its rank there. With the turned-back triad, on the joint ``bbar^q = b^p`` and
``cbar^q = c^p``, and the derivative of (cos e1, sin e1) multiplies ``a^p.b^q`` and
``a^p.c^q``, which vanish on the joint; so the gradients are those of the classic forms at
t = 0: exactly the relative rotations about b^p and c^p, of unit length at every angle
(``de2 = (omega^q - omega^p).b^p``, likewise e3 with c^p). The dual stress resultants sigma_2,
sigma_3 are the joint's moments about b^p and c^p (N m), and the 2 x 8 constraint Jacobian
has the same singular values at every angle. (Rotating the classic forms' gradient pair back
by t/2 about a and dividing by cos(t/2) gives the same modes; the result has no t/2, so it does
not depend on the branch of e1.)

Derivatives (exact)
-------------------
Each of the six forms ``f = [s, c, a^p.b^q, a^p.c^q, b^p.a^q, c^p.a^q]`` is bilinear in the
nodal vectors: ``f = sum_ij C_f[i, j] u_i^p . u_j^q`` with ``u = (a, b, c)`` and constant 3x3
matrices C_f. Every nodal vector is a quadratic form in its Euler parameters, ``u^p = q^p^T
H(u) q^p`` (:mod:`spacarpy.rotation`), so ``du^p/dq^p = 2 H(u) q^p`` and ``d^2u^p/dq^p^2 = 2
H(u)``. For ``e1 = atan2(s, c)``: ``de1 = (c ds - s dc) / rho^2`` and ``d^2 e1 = (c d^2s - s
d^2c) / rho^2 + [ds dc] A [ds dc]^T`` with ``A = [[-2 s c, s^2 - c^2], [s^2 - c^2, 2 s c]] /
rho^4``. With ``k = cos e1``, ``n = sin e1`` (``dk = -n de1``, ``dn = k de1``) and the forms
``A_b = a^p.b^q``, ``A_c = a^p.c^q``, ``B_a``, ``C_a``:
``e2 = (k A_c + n A_b - C_a)/2``, ``de2 = (k dA_c + n dA_b - dC_a)/2 + alpha_2 de1``,
``alpha_2 = (k A_b - n A_c)/2``; ``d^2 e2 = (k d^2A_c + n d^2A_b - d^2C_a)/2 + alpha_2
d^2e1 + de1 g_2^T + g_2 de1^T - beta_2 de1 de1^T`` with ``g_2 = (k dA_b - n dA_c)/2``,
``beta_2 = (k A_c + n A_b)/2``; and ``e3 = (B_a - k A_b + n A_c)/2``, ``alpha_3 = (n A_b +
k A_c)/2``, ``g_3 = (n dA_b + k dA_c)/2``, ``beta_3 = (n A_c - k A_b)/2``.

Properties
----------
ESTIFF: ``ESTIFF e k [k2 k3]``: k the rotational spring stiffness on e1 (N m/rad); the optional
k2, k3 are stiffnesses on e2, e3 (N m). S = diag(k, k2, k3), shape (n_elem, 3, 3).
A hinge has no mass (use XM on the orientation nodes).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from spacarpy.elements.base import ROT_P, ROT_Q, ElementKind, Fields, Reference
from spacarpy.elements.nodal import TQ_H2, nodal_jacobians
from spacarpy.linalg import property_columns

N_LDOF = 8
N_DEF = 3

# Local coordinate slices.
QP, QQ = slice(0, 4), slice(4, 8)


def _bilinear_forms() -> np.ndarray:
    """C[f] (6, 3, 3) with ``f = sum_ij C[f, i, j] u_i^p . u_j^q`` for the forms
    f = s, c, a^p.b^q, a^p.c^q, b^p.a^q, c^p.a^q and the nodal vectors u = (a, b, c)."""
    cf = np.zeros((6, 3, 3))
    cf[0, 2, 1], cf[0, 1, 2] = 1.0, -1.0          # s  = c^p.b^q - b^p.c^q
    cf[1, 1, 1], cf[1, 2, 2] = 1.0, 1.0           # c  = b^p.b^q + c^p.c^q
    cf[2, 0, 1] = 1.0                             # a^p.b^q
    cf[3, 0, 2] = 1.0                             # a^p.c^q
    cf[4, 1, 0] = 1.0                             # b^p.a^q
    cf[5, 2, 0] = 1.0                             # c^p.a^q
    return cf


C_FORMS = _bilinear_forms()
N_FORMS = C_FORMS.shape[0]


def _bending(f: np.ndarray):
    """``cos e1``, ``sin e1`` and the bending modes e2, e3 (each (n,)) from the forms f (n, 6).
    """
    s, co = f[:, 0], f[:, 1]
    rho = np.sqrt(s * s + co * co)
    kap, sig = co / rho, s / rho
    e2 = 0.5 * (kap * f[:, 3] + sig * f[:, 2] - f[:, 5])
    e3 = 0.5 * (f[:, 4] - kap * f[:, 2] + sig * f[:, 3])
    return kap, sig, e2, e3


def hinge_reference(axis: np.ndarray):
    """Reference triads (a, b, c), each (n_elem, 3), from the deck's axis vectors (n_elem, 3).

    See the module docstring for the rule. Raises ValueError for a zero or missing (NaN) axis.
    """
    ax = np.asarray(axis, dtype=float)
    norm = np.linalg.norm(ax, axis=1)
    if not np.all(norm > 0.0):                     # also catches NaN
        raise ValueError("HINGE axis must be a nonzero vector")
    a = ax / norm[:, None]
    k = np.argmin(np.abs(a), axis=1)
    g = np.eye(3)[k]
    b = g - np.sum(g * a, axis=1)[:, None] * a
    b /= np.linalg.norm(b, axis=1)[:, None]
    c = np.cross(a, b)
    return a, b, c


class HingeState(NamedTuple):
    """Deformations and Jacobian at one configuration, plus what the Hessian reuses."""

    e: np.ndarray          # (n, 3)
    D: np.ndarray          # (n, 3, 8)
    turns: np.ndarray      # (n,) int: e1 = atan2(s, c) + 2 pi turns
    f: np.ndarray          # (n, 6) the bilinear forms [s, c, a.b, a.c, b.a, c.a]
    J: np.ndarray          # (n, 6, 8) df/dx
    v: np.ndarray          # (n, 2, 3, 3) rows a, b, c of node p, then of node q
    Y: np.ndarray          # (n, 2, 9, 4) d[a, b, c]/dq of node p, then of node q
    u: np.ndarray          # (n, 3, 3) rows a, b, c (reference triad)
    m: np.ndarray          # (n, 4, 6) rows: de1, de2, de3 and the companion of de1, in f
    mj: np.ndarray         # (n, 4, 8) the same in x (its first three rows are D)
    ks: np.ndarray         # (n, 2) cos e1, sin e1


#: ``sum_ij C[f, i, j] u_j^q`` and ``sum_i C[f, i, j] u_i^p`` side by side: the gradients of
#: the forms with respect to the vectors of node p, then of node q (2, 18, 3).
_C_PQ = np.stack([C_FORMS.reshape(3 * N_FORMS, 3),
                  C_FORMS.transpose(0, 2, 1).reshape(3 * N_FORMS, 3)])
#: The combined forms ``C(w_f)`` of weights w_f (n, 6) and their transposes: (6, 18).
_C_W = np.hstack([C_FORMS.reshape(N_FORMS, 9), C_FORMS.transpose(0, 2, 1).reshape(N_FORMS, 9)])
_SIGN_CS = np.array([1.0, -1.0])


def hinge_state(x: np.ndarray, a: np.ndarray, b: np.ndarray, c: np.ndarray,
                e1_previous: np.ndarray | None = None, u: np.ndarray | None = None
                ) -> HingeState:
    """Deformations e (n_elem, 3) and their exact Jacobian D (n_elem, 3, 8) at x (n_elem, 8).

    Parameters
    ----------
    x : (n_elem, 8)
    a, b, c : (n_elem, 3)
        Reference triads (see :func:`hinge_reference`).
    e1_previous : (n_elem,) or float, optional
        Previous (converged) values of e1; the returned e1 is the branch ``atan2(s, c) +
        2 pi k`` closest to it. Without it, e1 lies in (-pi, pi].
    u : (n_elem, 3, 3), optional
        ``[a, b, c]`` stacked, when the caller keeps it (the kind's reference data).
    """
    n = x.shape[0]
    if u is None:
        u = np.stack([a, b, c], axis=1)
    q2 = x.reshape(n, 2, 4)
    Y = nodal_jacobians(q2, u)                                     # (n, 2, 9, 4)
    v = (Y @ q2[..., None]).reshape(n, 2, 3, 3)
    v *= 0.5
    # gradients of the bilinear forms with respect to the vectors of p and of q
    g = (_C_PQ @ v[:, ::-1]).reshape(n, 2, N_FORMS, 9)
    f = (g[:, 0] @ v[:, 0].reshape(n, 9, 1))[:, :, 0]              # (n, 6)
    J = (g @ Y).transpose(0, 2, 1, 3).reshape(n, N_FORMS, N_LDOF)  # (n, 6, 8)
    s, co = f[:, 0], f[:, 1]
    phi = np.arctan2(s, co)
    kap, sig, e2, e3 = _bending(f)
    e = np.empty((n, N_DEF))
    e[:, 1], e[:, 2] = e2, e3
    if e1_previous is None:
        turns = np.zeros(n, dtype=np.int64)
        e[:, 0] = phi
    else:
        turns = np.floor((e1_previous - phi) / (2.0 * np.pi) + 0.5).astype(np.int64)
        e[:, 0] = phi + 2.0 * np.pi * turns
    # de1 = (c ds - s dc) / rho^2 = [p, q] . [ds, dc]; the companion [q, -p] . [ds, dc] of
    # de1 (the curvature of atan2, see hinge_weighted_hessian); de2 and de3 (module
    # docstring): their terms in cos e1 and sin e1 plus alpha_2,3 de1. The rows of
    # M = de/df (n, 4, 6), applied to df/dx.
    pq = f[:, 1::-1] * _SIGN_CS
    pq /= (s * s + co * co)[:, None]
    m = np.zeros((n, 4, N_FORMS))
    m[:, 0, :2] = pq
    m[:, 3, 0], m[:, 3, 1] = pq[:, 1], -pq[:, 0]
    al2 = 0.5 * (kap * f[:, 2] - sig * f[:, 3])
    al3 = 0.5 * (sig * f[:, 2] + kap * f[:, 3])
    m[:, 1, :2] = al2[:, None] * pq
    m[:, 2, :2] = al3[:, None] * pq
    m[:, 1, 2], m[:, 1, 3], m[:, 1, 5] = 0.5 * sig, 0.5 * kap, -0.5
    m[:, 2, 2], m[:, 2, 3], m[:, 2, 4] = -0.5 * kap, 0.5 * sig, 0.5
    mj = m @ J                                                     # de1, de2, de3, companion
    return HingeState(e=e, D=mj[:, :3], turns=turns, f=f, J=J, v=v, Y=Y, u=u, m=m, mj=mj,
                      ks=np.stack([kap, sig], axis=1))


def hinge_weighted_hessian(st: HingeState, w: np.ndarray) -> np.ndarray:
    """``sum_i w_i d^2 e_i / dx^2`` at the state ``st``; w (n_elem, 3) -> (n_elem, 8, 8).

    The forms f are bilinear in the nodal vectors, so with the weights ``w_f = w . de/df``
    on f their second derivatives are ``2 H`` combinations on each node's block and
    ``Y_p^T (C(w_f) (x) I3) Y_q`` between the nodes. The curvature of ``e1 = atan2(s, c)``
    in (s, c) is ``[[2pq, q^2-p^2], [q^2-p^2, -2pq]]`` with ``[p, q] = [c, -s] / rho^2``,
    which is ``r_perp r^T + r r_perp^T``: in x the symmetric product of de1/dx and its
    companion (rows 0 and 3 of the state's ``mj``), weighted by ``W1 = w_1 + w_2 alpha_2 +
    w_3 alpha_3``. The products of cos e1, sin e1 with the forms of e2 and e3 add
    ``de1 G^T + G de1^T - (w_2 beta_2 + w_3 beta_3) de1 de1^T`` (module docstring)."""
    n = w.shape[0]
    wf = (w[:, None, :] @ st.m[:, :3])[:, 0]                      # weights on f (n, 6)
    cw = (wf @ _C_W).reshape(n, 2, 3, 3)                          # C(w_f), C(w_f)^T
    # coefficients of the nodal-vector Hessians 2 H(u): node p sum_j C_ij u_j^q, node q ...
    m = (cw @ st.v[:, ::-1]).transpose(0, 1, 3, 2) @ st.u[:, None]   # (n, 2, 3, 3)
    hq = (m.reshape(2 * n, 9) @ TQ_H2).reshape(n, 2, 4, 4)
    hx = np.empty((n, N_LDOF, N_LDOF))
    hx[:, QP, QP] = hq[:, 0]
    hx[:, QQ, QQ] = hq[:, 1]
    # mixed block Yp^T (C(w_f) kron I3) Yq
    yp, yq = st.Y[:, 0], st.Y[:, 1]
    pq = yp.transpose(0, 2, 1) @ (cw[:, 0] @ yq.reshape(n, 3, 12)).reshape(n, 9, 4)
    hx[:, QP, QQ] = pq
    hx[:, QQ, QP] = pq.transpose(0, 2, 1)
    # de1 (x) t + t (x) de1 with t = W1 companion + G - (w2 beta2 + w3 beta3)/2 de1
    f, kap, sig = st.f, st.ks[:, 0], st.ks[:, 1]
    w2, w3 = w[:, 1], w[:, 2]
    al2 = 0.5 * (kap * f[:, 2] - sig * f[:, 3])
    al3 = 0.5 * (sig * f[:, 2] + kap * f[:, 3])
    be2 = 0.5 * (kap * f[:, 3] + sig * f[:, 2])
    be3 = 0.5 * (sig * f[:, 3] - kap * f[:, 2])
    w1 = w[:, 0] + w2 * al2 + w3 * al3
    gb = 0.5 * (w2 * kap + w3 * sig)                              # G = gb dA_b + gc dA_c
    gc = 0.5 * (w3 * kap - w2 * sig)
    de1 = st.mj[:, 0]
    t = (w1[:, None] * st.mj[:, 3] + gb[:, None] * st.J[:, 2] + gc[:, None] * st.J[:, 3]
         - (0.5 * (w2 * be2 + w3 * be3))[:, None] * de1)
    outer = de1[:, :, None] * t[:, None, :]
    hx += outer
    hx += outer.transpose(0, 2, 1)
    return hx


def hinge_deformations(x, a, b, c, e1_previous=None, u=None) -> np.ndarray:
    """The deformations (n_elem, 3) of :func:`hinge_state` alone, without their
    derivatives (for the iterations of the kinematic correction)."""
    n = x.shape[0]
    if u is None:
        u = np.stack([a, b, c], axis=1)
    q2 = x.reshape(n, 2, 4)
    v = (nodal_jacobians(q2, u) @ q2[..., None]).reshape(n, 2, 9)
    # f = sum_ij C[f, i, j] u_i^p . u_j^q: the 3x3 products of the two triads, times C
    f = (v[:, 0].reshape(n, 3, 3) @ v[:, 1].reshape(n, 3, 3).transpose(0, 2, 1)).reshape(
        n, 9) @ _C_FLAT_T
    f *= 0.25                                                      # v is twice the vectors
    e = np.empty((n, N_DEF))
    phi = np.arctan2(f[:, 0], f[:, 1])
    if e1_previous is None:
        e[:, 0] = phi
    else:
        e[:, 0] = phi + 2.0 * np.pi * np.floor((e1_previous - phi) / (2.0 * np.pi) + 0.5)
    _, _, e[:, 1], e[:, 2] = _bending(f)
    return e


_C_FLAT_T = np.ascontiguousarray(C_FORMS.reshape(N_FORMS, 9).T)


def hinge_stiffness(props: np.ndarray) -> np.ndarray:
    """S = diag(k, k2, k3) (n_elem, 3, 3) from the ESTIFF values ``k [k2 k3]``, given as
    (n_elem,) or (n_elem, 1..3); missing values are 0."""
    k = property_columns(props, N_DEF, "HINGE ESTIFF")
    return k[:, :, None] * np.eye(N_DEF)


# ------------------------------------------------------------------------------ the kind
@dataclass(frozen=True, slots=True, eq=False)
class HingeReference(Reference):
    """A HINGE group's reference data (also the PLHINGE's), from :meth:`Hinge.reference`.

    a, b, c : (n_elem, 3)
        The reference triad (unit vectors, a along the axis; see :func:`hinge_reference`).
    u : (n_elem, 3, 3) or None
        ``[a, b, c]`` stacked (the kernels' nodal vectors); None: stacked at each call.
    """

    a: np.ndarray
    b: np.ndarray
    c: np.ndarray
    u: np.ndarray | None = None


class Hinge(ElementKind):
    """``HINGE e r s [ax ay az]``: a revolute joint between two orientation nodes (kernels
    above). Its persistent state is the joint angle of the last converged step
    (``prev["e1"]``), which keeps the angle continuous over several turns."""

    keyword = "HINGE"
    slots = ("rot", "rot")
    node_roles = ("r", "s")
    modes = ("rotation about the axis", "rotation about b", "rotation about c")
    mode_units = ("rad", "1", "1")
    stress_units = ("N m",) * 3
    deformation_meaning = ("HINGE deformations: 1 the joint angle (rad), 2-3 the small relative "
                           "rotations (1)")
    stress_meaning = ("HINGE stress resultants: the joint moment about the axis and the "
                      "constraint moments about b and c of node p")
    length_modes = (False,) * 3
    estiff = Fields(("k", "k2", "k3"), ("N m/rad",) * 3, 0, 3, "k [k2 k3]")
    mode_stiffness = (0, 1, 2)
    vector = "axis"
    summary = "hinge (revolute joint) between two orientation nodes"
    node_fields = (ROT_P, ROT_Q)
    vector_fields = (("x component of the hinge axis", "ax"),
                     ("y component of the hinge axis", "ay"),
                     ("z component of the hinge axis", "az"))
    reference_type = HingeReference

    def reference(self, x0, vector):
        a, b, c = hinge_reference(vector)
        # u = [a, b, c] stacked once here rather than at every kernel call
        return HingeReference(a, b, c, np.stack([a, b, c], axis=1)), np.ones((a.shape[0], 3))

    def state(self, x, ref, variant, prev):
        return hinge_state(x, ref.a, ref.b, ref.c, prev.get("e1"), ref.u)

    def deformations(self, x, ref, variant, prev):
        return hinge_deformations(x, ref.a, ref.b, ref.c, prev.get("e1"), ref.u)

    def hessian(self, st, w):
        return hinge_weighted_hessian(st, w)

    def stiffness(self, props, ref):
        return hinge_stiffness(props[:, :3])

    def commit(self, st, prev):
        prev["e1"] = st.e[:, 0].copy()
