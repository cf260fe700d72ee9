"""The warping beam BEAMW (SPACAR type 18): the DDM beam plus Vlasov non-uniform torsion.

``BEAMW e Xp Rp Wp Xq Rq Wq [ox oy oz]``: a BEAM (:mod:`spacarpy.elements.beam`) with one
warping node at each end. A warping node has one coordinate, the rate of twist ``w = phi'``
that sets the amplitude of the cross-section's warping. Pure functions on arrays with the
element index first; the derivation is in docs/beamw.md.

Local coordinates (16)
----------------------
``[r^p (3), q^p (4), w^p (1), r^q (3), q^q (4), w^q (1)]``; the BEAM kernel sees the 14
coordinates without the two warping ones (:data:`BEAM_SLOTS`).

Deformations (1-based), all lengths (m)
---------------------------------------
1-6: the BEAM's (Eq. 7 or the modified Eq. 48b; e2 = l0 x the relative twist).
7, 8: ``e7 = l0^2 w^p - e2``, ``e8 = l0^2 w^q - e2``: l0^2 times the end rates of twist
relative to the element's mean rate ``e2 / l0^2`` (the torsional analogue of the bending
modes, which are l0 times the end slopes relative to the chord). Through the modified e2
(whose second-order part ``(-e3 e6 + e4 e5) / l0`` couples bending and twist) the warping
modes inherit the coupling that gives lateral-torsional buckling.

Stiffness
---------
The twist along the element is the cubic Hermite interpolation of the end twists (0 and
``theta = e2 / l0``) and the end rates of twist ``w^p, w^q``. Vlasov's energy
``1/2 int (GJ phi'^2 + E Cw phi''^2) dx`` is then exactly
``1/2 e^T S e`` with the BEAM's ``S_22 = GJ / l0^3`` and the block on (e7, e8)

    S_w = E Cw / l0^5 [[4, 2], [2, 4]] + GJ / (30 l0^3) [[4, -1], [-1, 4]]

(the second term the Saint-Venant energy of the cubic's bubble). ``ESTIFF e EA GJ EIy EIz cy
cz ECw``; a BEAMW's modes 7 and 8 are never rigid (SPACAR: "ep_7 and ep_8 are always
calculable"): they carry this stiffness whenever ESTIFF is given, whatever DYNE/RLSE list.

Inertia
-------
The BEAM's mass, plus the warping inertia ``1/2 int rho Iw (d phi'/dt)^2 dx`` lumped at the
two warping nodes (``rho Iw l0 / 2`` each, as SPACAR lumps the section rotary inertia):
``EM e rhoA rho(Iy+Iz) rhoIy rhoIz rhoIyz rhoIw``.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from spacarpy.elements.base import (
    POS_P,
    POS_Q,
    ROT_AT_P,
    ROT_AT_Q,
    Y_AXIS_FIELDS,
    ElementKind,
    Fields,
)
from spacarpy.elements.beam import (
    BeamReference,
    BeamState,
    _section,
    beam_gravity,
    beam_state,
    beam_weighted_hessian,
    check_saturation,
    reference_triads,
    stiffness_matrix,
)
from spacarpy.elements.beam_mass import beam_convective, beam_inertia_force, beam_mass_matrix

N_LDOF = 16
N_DEF = 8
#: The BEAM's 14 local coordinates among the BEAMW's 16, and the two warping coordinates.
BEAM_SLOTS = np.r_[0:7, 8:15]
WP, WQ = 7, 15

#: The warping node fields of the element line.
WARP_P, WARP_Q = ("warping node at p", "wp"), ("warping node at q", "wq")


class BeamWState(NamedTuple):
    """Deformations and Jacobian of a BEAMW group, with the BEAM's state they extend."""

    e: np.ndarray          # (n, 8)
    D: np.ndarray          # (n, 8, 16)
    beam: BeamState        # the BEAM kernel's state of the 14 BEAM coordinates
    l0: np.ndarray         # (n,)


def beamw_state(x: np.ndarray, ref: BeamReference, variant: str = "modified") -> BeamWState:
    """Deformations e (n, 8) and their exact Jacobian D (n, 8, 16) at x (n, 16)."""
    n = x.shape[0]
    l0 = ref.l0
    st = beam_state(x[:, BEAM_SLOTS], ref.ny, ref.nz, l0, variant, ref.u, dense=True)
    l2 = l0 * l0
    e = np.empty((n, N_DEF))
    e[:, :6] = st.e
    e[:, 6] = l2 * x[:, WP] - st.e[:, 1]
    e[:, 7] = l2 * x[:, WQ] - st.e[:, 1]
    D = np.zeros((n, N_DEF, N_LDOF))
    D[:, :6, BEAM_SLOTS] = st.D
    D[:, 6:, BEAM_SLOTS] = -st.D[:, 1:2]
    D[:, 6, WP] = l2
    D[:, 7, WQ] = l2
    return BeamWState(e=e, D=D, beam=st, l0=l0)


def beamw_weighted_hessian(st: BeamWState, w: np.ndarray) -> np.ndarray:
    """``sum_i w_i d^2 e_i / dx^2`` (n, 16, 16): e7, e8 are linear in the warping
    coordinates, so their second derivatives are minus e2's."""
    w6 = np.array(w[:, :6], dtype=float, copy=True)
    w6[:, 1] -= w[:, 6] + w[:, 7]
    h = np.zeros((w.shape[0], N_LDOF, N_LDOF))
    h[:, BEAM_SLOTS[:, None], BEAM_SLOTS] = beam_weighted_hessian(st.beam, w6, dense=True)
    return h


def beamw_stiffness(props: np.ndarray, l0: np.ndarray) -> np.ndarray:
    """S (n, 8, 8) from ``[EA, GJ, EIy, EIz, cy, cz, ECw]`` (n, 7) (module docstring)."""
    n = l0.size
    s = np.zeros((n, N_DEF, N_DEF))
    s[:, :6, :6] = stiffness_matrix(props[:, :6], l0)
    gj, ecw = props[:, 1], props[:, 6]
    a = ecw / l0**5
    b = gj / (30.0 * l0**3)
    s[:, 6, 6] = s[:, 7, 7] = 4.0 * a + 4.0 * b
    s[:, 6, 7] = s[:, 7, 6] = 2.0 * a - b
    return s


def _embed(part: np.ndarray) -> np.ndarray:
    """A BEAM vector (n, 14) or matrix (n, 14, 14) placed in the BEAMW's 16 coordinates."""
    n = part.shape[0]
    if part.ndim == 2:
        out = np.zeros((n, N_LDOF))
        out[:, BEAM_SLOTS] = part
        return out
    out = np.zeros((n, N_LDOF, N_LDOF))
    out[:, BEAM_SLOTS[:, None], BEAM_SLOTS] = part
    return out


def warping_mass(ref: BeamReference, m: np.ndarray) -> np.ndarray:
    """The lumped warping inertia ``rho Iw l0 / 2`` of each end (n,)."""
    return 0.5 * m[:, 5] * ref.l0


def beamw_mass(x, ref, m, rotary="lumped"):
    """Mass matrices (n, 16, 16): the BEAM's and the lumped warping inertia."""
    mb = m[:, :5]
    out = _embed(beam_mass_matrix(x[:, BEAM_SLOTS], ref.nx, ref.ny, ref.nz, ref.l0, mb,
                                  rotary, _section(ref, mb)))
    mw = warping_mass(ref, m)
    out[:, WP, WP] = mw
    out[:, WQ, WQ] = mw
    return out


def beamw_convective(x, v, ref, m, rotary="lumped"):
    """The BEAM's convective parts (the warping inertia is constant: none of its own)."""
    mb = m[:, :5]
    mdot, grad = beam_convective(x[:, BEAM_SLOTS], v[:, BEAM_SLOTS], ref.nx, ref.ny, ref.nz,
                                 ref.l0, mb, rotary, _section(ref, mb))
    return _embed(mdot), _embed(grad)


def beamw_inertia_force(x, v, a, ref, m, rotary="lumped"):
    """``M a + h`` (n, 16): the BEAM's and the warping inertia times the warping rates."""
    mb = m[:, :5]
    f = _embed(beam_inertia_force(x[:, BEAM_SLOTS], v[:, BEAM_SLOTS], a[:, BEAM_SLOTS],
                                  ref.nx, ref.ny, ref.nz, ref.l0, mb, rotary,
                                  _section(ref, mb)))
    mw = warping_mass(ref, m)
    f[:, WP] = mw * a[:, WP]
    f[:, WQ] = mw * a[:, WQ]
    return f


class BeamW(ElementKind):
    """``BEAMW e p r wp q s wq [oy_x oy_y oy_z]``: the DDM beam with warping (kernels above)."""

    keyword = "BEAMW"
    slots = ("pos", "rot", "warp", "pos", "rot", "warp")
    node_roles = ("p", "r", "wp", "q", "s", "wq")
    modes = ("elongation", "torsion", "bending y at p", "bending y at q", "bending z at p",
             "bending z at q", "warping at p", "warping at q")
    mode_units = ("m",) * 8
    stress_units = ("N",) * 8
    deformation_meaning = ("generalized deformations of each BEAMW element (modes 7, 8: l0^2 "
                           "times the end rates of twist relative to the mean)")
    stress_meaning = ("generalized stress resultants of each BEAMW element (modes 7, 8: the "
                      "end bimoments divided by l0^2)")
    length_modes = (True,) * 8
    estiff = Fields(("EA", "GJ", "EIy", "EIz", "cy", "cz", "ECw"),
                    ("N", "N m^2", "N m^2", "N m^2", "m^2", "m^2", "N m^4"), 4, 7,
                    "EA GJ EIy EIz [cy cz ECw]")
    mode_stiffness = (0, 1, 2, 2, 3, 3, 6, 6)
    em = Fields(("rhoA", "rho(Iy+Iz)", "rhoIy", "rhoIz", "rhoIyz", "rhoIw"),
                ("kg/m", "kg m", "kg m", "kg m", "kg m", "kg m^3"), 1, None,
                "rhoA [rho(Iy+Iz) rhoIy rhoIz rhoIyz rhoIw]")
    vector = "local y-axis"
    summary = "spatial beam element with warping nodes (Vlasov torsion)"
    node_fields = (POS_P, ROT_AT_P, WARP_P, POS_Q, ROT_AT_Q, WARP_Q)
    vector_fields = Y_AXIS_FIELDS
    reference_type = BeamReference
    #: modes (0-based) that are never rigid: released by default, flexible with ESTIFF
    always_free = (6, 7)

    def reference(self, x0, vector):
        nx, ny, nz, l0 = reference_triads(x0[0], x0[3], vector)
        axes = np.stack([nx, ny, nz], axis=1)
        return (BeamReference(nx, ny, nz, l0, axes, axes[:, 1:]),
                np.repeat(l0[:, None], N_DEF, axis=1))

    def state(self, x, ref, variant, prev):
        return beamw_state(x, ref, variant)

    def hessian(self, st, w):
        return beamw_weighted_hessian(st, w)

    def stiffness(self, props, ref):
        return beamw_stiffness(props, ref.l0)

    def mass(self, x, ref, m, rotary="lumped"):
        return beamw_mass(x, ref, m, rotary)

    def convective(self, x, v, ref, m, rotary="lumped"):
        return beamw_convective(x, v, ref, m, rotary)

    def inertia_force(self, x, v, a, ref, m, rotary="lumped"):
        return beamw_inertia_force(x, v, a, ref, m, rotary)

    def check(self, st, ref):
        return check_saturation(st.beam, ref)

    def gravity(self, x, ref, mass, g):
        f, k = beam_gravity(x[:, BEAM_SLOTS], ref, mass, g)
        return _embed(f), _embed(k)
