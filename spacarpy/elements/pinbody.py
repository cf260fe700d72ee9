"""The pin-body element PINBODY (SPACAR type 9, ``PINBODY e p r q``), vectorized.

"A pinbody element generates a node within a rigid body by which another finite element can
be connected" (Meijaard et al. 2007, ESM p. 53): the position node q is a point of the rigid
body whose position node is p and whose orientation node is r. Unlike an RBEAM it has no axis
of its own, so p and q may coincide (zero length is allowed).

Local coordinates
-----------------
x : (n_elem, 10)
    ``[r^p (3), q^r (4), r^q (3)]``: position of p, Euler parameters of r, position of q.

Deformations (1-based, as DYNE/RLSE number them), all in m
----------------------------------------------------------
The components of ``d = r^q - r^p`` along the body axes of r, minus their reference values
(orientation nodes start at the identity, so the body axes are the global axes g_k there):

    e_k = (R(q^r) g_k) . d - g_k . d0,   k = 1, 2, 3,   d0 = r^q_0 - r^p_0.

That is the RBEAM kernel (:mod:`spacarpy.elements.rbeam`) with the body triad fixed to the
global axes and the reference offset d0 in place of ``l0 n_x``: the same exact Jacobian
``D = [-R g_k, d^T 2 H(g_k) q^r, R g_k]`` and weighted Hessian. All three modes are rigid by
default (the pin is a point of the body); RLSE frees a mode (it then measures the point's
displacement in the body frame), and ``ESTIFF e k1 [k2 k3]`` (N/m) gives S = diag(k1, k2, k3)
to modes made flexible with DYNE. The stress resultants are the forces (N) on q along the
body axes. No mass of its own (EM is an error): masses go on the nodes with XM.

Scale: ``|d0|`` per element; a pin of zero length takes the largest ``|d0|`` of its group,
or 1 m where every pin of the group has zero length.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from spacarpy.elements.base import POS_P, POS_Q, ROT_AT_P, ElementKind, Fields, Reference
from spacarpy.elements.rbeam import RBeamState, rbeam_state, rbeam_stiffness, rbeam_weighted_hessian

N_DEF = 3
_AXES = np.eye(3)


@dataclass(frozen=True, slots=True, eq=False)
class PinBodyReference(Reference):
    """A PINBODY group's reference data, from :meth:`PinBody.reference`.

    d0 : (n_elem, 3)
        The reference offset ``r^q_0 - r^p_0`` (m), in global axes.
    u : (n_elem, 3, 3)
        The body axes in the reference configuration (the global axes), stacked.
    """

    d0: np.ndarray
    u: np.ndarray


def pinbody_state(x: np.ndarray, ref: PinBodyReference) -> RBeamState:
    """Deformations e (n, 3) and their exact Jacobian D (n, 3, 10) at x (n, 10)."""
    n = x.shape[0]
    zero = np.zeros(n)
    st = rbeam_state(x, ref.u[:, 0], ref.u[:, 1], ref.u[:, 2], zero, ref.u)
    st.e[:] -= ref.d0
    return st


def pinbody_weighted_hessian(st: RBeamState, w: np.ndarray) -> np.ndarray:
    """``sum_k w_k d^2 e_k / dx^2`` (n, 10, 10): the RBEAM's."""
    return rbeam_weighted_hessian(st, w)


class PinBody(ElementKind):
    """``PINBODY e p r q``: node q a point of the rigid body of p and r (kernels above)."""

    keyword = "PINBODY"
    slots = ("pos", "rot", "pos")
    node_roles = ("p", "r", "q")
    modes = ("displacement along the body x-axis", "displacement along the body y-axis",
             "displacement along the body z-axis")
    mode_units = ("m",) * 3
    stress_units = ("N",) * 3
    deformation_meaning = "PINBODY deformations (position of q in the body of p and r)"
    stress_meaning = "PINBODY constraint forces on q along the body axes"
    length_modes = (True,) * 3
    estiff = Fields(("k1", "k2", "k3"), ("N/m",) * 3, 0, 3, "[k1 k2 k3]")
    mode_stiffness = (0, 1, 2)
    em = None
    vector = None
    summary = "pin-body: node q a point of the rigid body of p and r"
    node_fields = (POS_P, ROT_AT_P, POS_Q)
    zero_length = True
    reference_type = PinBodyReference

    def reference(self, x0, vector):
        d0 = np.asarray(x0[2], dtype=float) - np.asarray(x0[0], dtype=float)
        n = d0.shape[0]
        length = np.linalg.norm(d0, axis=1)
        fill = length.max(initial=0.0) or 1.0
        scale = np.where(length > 0.0, length, fill)
        u = np.broadcast_to(_AXES, (n, 3, 3)).copy()
        return PinBodyReference(d0, u), np.repeat(scale[:, None], N_DEF, axis=1)

    def state(self, x, ref, variant, prev):
        return pinbody_state(x, ref)

    def hessian(self, st, w):
        return pinbody_weighted_hessian(st, w)

    def stiffness(self, props, ref):
        return rbeam_stiffness(props[:, :3])
