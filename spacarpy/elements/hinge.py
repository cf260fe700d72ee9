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
2. ``e2 = (a^p.c^q - c^p.a^q) / 2``: a small relative rotation about ``b``; for a relative
   rotation by phi about b, ``e2 = sin(phi)`` (dimensionless, ~ rad).
3. ``e3 = (b^p.a^q - a^p.b^q) / 2``: a small relative rotation about ``c``; for a relative
   rotation by psi about c, ``e3 = sin(psi)`` (dimensionless, ~ rad).

Modes 2 and 3 are normally rigid (not listed in DYNE/RLSE): together they make the revolute
joint constraint. e1 is singular only where ``s = c = 0``, i.e. when the axis of q is turned
over by 180 degrees with respect to that of p, far away from a working hinge.

Derivatives (exact)
-------------------
Each of ``f = [s, c, e2, e3]`` is bilinear in the nodal vectors: ``f = sum_ij C_f[i, j]
u_i^p . u_j^q`` with ``u = (a, b, c)`` and constant 3x3 matrices C_f. Every nodal vector is a
quadratic form in its Euler parameters, ``u^p = q^p^T H(u) q^p`` (:mod:`spacarpy.rotation`),
so ``du^p/dq^p = 2 H(u) q^p`` and ``d^2u^p/dq^p^2 = 2 H(u)``. For ``e1 = atan2(s, c)``, with
``rho^2 = s^2 + c^2``: ``de1 = (c ds - s dc) / rho^2`` and ``d^2 e1 = (c d^2s - s d^2c) / rho^2
+ [ds dc] A [ds dc]^T`` with ``A = [[-2 s c, s^2 - c^2], [s^2 - c^2, 2 s c]] / rho^4``.

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
    """C[f] (4, 3, 3) with ``f = sum_ij C[f, i, j] u_i^p . u_j^q`` for f = s, c, e2, e3 and the
    nodal vectors u = (a, b, c)."""
    cf = np.zeros((4, 3, 3))
    cf[0, 2, 1], cf[0, 1, 2] = 1.0, -1.0          # s  = c^p.b^q - b^p.c^q
    cf[1, 1, 1], cf[1, 2, 2] = 1.0, 1.0           # c  = b^p.b^q + c^p.c^q
    cf[2, 0, 2], cf[2, 2, 0] = 0.5, -0.5          # e2 = (a^p.c^q - c^p.a^q) / 2
    cf[3, 1, 0], cf[3, 0, 1] = 0.5, -0.5          # e3 = (b^p.a^q - a^p.b^q) / 2
    return cf


C_FORMS = _bilinear_forms()









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
    f: np.ndarray          # (n, 4) the bilinear forms [s, c, e2, e3]
    J: np.ndarray          # (n, 4, 8) df/dx
    v: np.ndarray          # (n, 2, 3, 3) rows a, b, c of node p, then of node q
    Y: np.ndarray          # (n, 2, 9, 4) d[a, b, c]/dq of node p, then of node q
    u: np.ndarray          # (n, 3, 3) rows a, b, c (reference triad)
    m: np.ndarray          # (n, 4, 4) rows: de1, de2, de3 and the companion of de1, in f
    mj: np.ndarray         # (n, 4, 8) the same in x (its first three rows are D)


#: ``sum_ij C[f, i, j] u_j^q`` and ``sum_i C[f, i, j] u_i^p`` side by side: the gradients of
#: the forms with respect to the vectors of node p, then of node q (2, 12, 3).
_C_PQ = np.stack([C_FORMS.reshape(12, 3), C_FORMS.transpose(0, 2, 1).reshape(12, 3)])
#: The combined forms ``C(w_f)`` of weights w_f (n, 4) and their transposes: (4, 18).
_C_W = np.hstack([C_FORMS.reshape(4, 9), C_FORMS.transpose(0, 2, 1).reshape(4, 9)])
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
    # gradients of the four bilinear forms with respect to the vectors of p and of q
    g = (_C_PQ @ v[:, ::-1]).reshape(n, 2, 4, 9)
    f = (g[:, 0] @ v[:, 0].reshape(n, 9, 1))[:, :, 0]              # (n, 4)
    J = (g @ Y).transpose(0, 2, 1, 3).reshape(n, 4, N_LDOF)        # (n, 4, 8)
    s, co = f[:, 0], f[:, 1]
    phi = np.arctan2(s, co)
    e = f[:, 1:].copy()
    if e1_previous is None:
        turns = np.zeros(n, dtype=np.int64)
        e[:, 0] = phi
    else:
        turns = np.floor((e1_previous - phi) / (2.0 * np.pi) + 0.5).astype(np.int64)
        e[:, 0] = phi + 2.0 * np.pi * turns
    # de1 = (c ds - s dc) / rho^2 = [p, q] . [ds, dc]; with de2, de3 and the companion
    # [q, -p] . [ds, dc] of de1 (the curvature of atan2, see hinge_weighted_hessian) as the
    # rows of M (n, 4, 4) applied to df/dx
    pq = f[:, 1::-1] * _SIGN_CS
    pq /= (s * s + co * co)[:, None]
    m = (pq @ _M_PQ).reshape(n, 4, 4)
    m += _M_CONST
    mj = m @ J                                                     # de1, de2, de3, companion
    return HingeState(e=e, D=mj[:, :3], turns=turns, f=f, J=J, v=v, Y=Y, u=u, m=m, mj=mj)


#: The rows [de1, de2, de3, companion of de1] of M = dq/df as products with [p, q].
_M_PQ = np.zeros((2, 4, 4))
_M_PQ[0, 0, 0] = _M_PQ[1, 0, 1] = _M_PQ[1, 3, 0] = 1.0
_M_PQ[0, 3, 1] = -1.0
_M_PQ = _M_PQ.reshape(2, 16)
_M_CONST = np.zeros((4, 4))
_M_CONST[1, 2] = _M_CONST[2, 3] = 1.0


def hinge_weighted_hessian(st: HingeState, w: np.ndarray) -> np.ndarray:
    """``sum_i w_i d^2 e_i / dx^2`` at the state ``st``; w (n_elem, 3) -> (n_elem, 8, 8).

    The forms f are bilinear in the nodal vectors, so with the weights ``w_f`` on f (w_1
    times de1/df for s and c) their second derivatives are ``2 H`` combinations on each
    node's block and ``Y_p^T (C(w_f) (x) I3) Y_q`` between the nodes. The curvature of
    ``e1 = atan2(s, c)`` in (s, c) is ``[[2pq, q^2-p^2], [q^2-p^2, -2pq]]`` with
    ``[p, q] = [c, -s] / rho^2``, which is ``r_perp r^T + r r_perp^T``: in x the symmetric
    product of de1/dx and its companion (rows 0 and 3 of the state's ``mj``)."""
    n = w.shape[0]
    wf = (w[:, None, :] @ st.m[:, :3])[:, 0]                      # weights on f (n, 4)
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
    # curvature of atan2: w_1 (a b^T + b a^T) with b = de1/dx, a its companion
    ab = st.mj[:, ::3]                                            # (n, 2, 8): b, a
    hx += (ab * w[:, :1, None]).transpose(0, 2, 1) @ ab[:, ::-1]
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
    e[:, 1:] = f[:, 2:]
    return e


_C_FLAT_T = np.ascontiguousarray(C_FORMS.reshape(4, 9).T)


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
    stress_meaning = "HINGE stress resultants: the joint moment and the constraint moments"
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
