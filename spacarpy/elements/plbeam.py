"""The planar beam PLBEAM (``PLBEAM e p r q s``): the BEAM kernel restricted to the x-y plane.

A planar model holds z and the Euler parameters lambda1, lambda2 of every node at 0
(:mod:`spacarpy.numbering`), so a BEAM in the plane has no torsion and no bending about its
local y-axis; the PLBEAM keeps the in-plane modes 1 (elongation), 5 and 6 (bending in the x-y
plane at p and q; rigidity EIz, shear flexibility cz) of :mod:`spacarpy.elements.beam`.
Its section rotary inertia rhoIz (about the plane's normal) is the BEAM's, lumped or
consistent as the BEAM's is (:mod:`spacarpy.elements.beam_mass`).
"""
from __future__ import annotations

import numpy as np

from spacarpy.elements.base import (
    POS_P,
    POS_Q,
    ROT_AT_P,
    ROT_AT_Q,
    ElementKind,
    Fields,
    Selected,
    expand,
)
from spacarpy.elements.beam import Beam, beam_gravity, check_saturation

#: BEAM modes a PLBEAM keeps: 1 elongation, 2 and 3 bending in the x-y plane at p and q.
PLBEAM_MODES = np.array([0, 4, 5])

_BEAM = Beam()


def plbeam_props(props: np.ndarray) -> np.ndarray:
    """(EA, EI, c) -> BEAM's (EA, GJ, EIy, EIz, cy, cz) with only the in-plane values."""
    out = np.zeros((props.shape[0], 6))
    out[:, 0], out[:, 3], out[:, 5] = props[:, 0], props[:, 1], props[:, 2]
    return out


def plbeam_mass(m: np.ndarray) -> np.ndarray:
    """(rhoA, rhoIz) -> BEAM's (rhoA, rhoIp, rhoIy, rhoIz, rhoIyz)."""
    out = np.zeros((m.shape[0], 5))
    out[:, 0], out[:, 3] = m[:, 0], m[:, 1]
    return out


class PlBeam(ElementKind):
    """``PLBEAM e p r q s``: the planar beam (its local y-axis is z x the element axis)."""

    keyword = "PLBEAM"
    slots = Beam.slots
    node_roles = Beam.node_roles
    modes = ("elongation", "bending at p", "bending at q")
    mode_units = ("m",) * 3
    stress_units = ("N",) * 3
    deformation_meaning = ("PLBEAM deformations: 1 elongation, 2-3 bending in the x-y plane at p "
                           "and q (l0 times a sine)")
    stress_meaning = "PLBEAM stress resultants: normal force, bending moments divided by l0"
    length_modes = (True,) * 3
    estiff = Fields(("EA", "EI", "c"), ("N", "N m^2", "m^2"), 2, 3, "EA EI [c]")
    mode_stiffness = (0, 1, 1)
    em = Fields(("rhoA", "rhoIz"), ("kg/m", "kg m"), 1, 2, "rhoA [rhoIz]")
    planar = True
    summary = "planar beam element (x-y plane)"
    node_fields = (POS_P, ROT_AT_P, POS_Q, ROT_AT_Q)
    reference_type = Beam.reference_type          # the spatial kernel's record

    def reference(self, x0, vector):
        # the local y-axis lies in the plane: z x (element axis)
        axis = x0[2] - x0[0]
        ref, scale = _BEAM.reference(x0, np.stack([-axis[:, 1], axis[:, 0],
                                                   np.zeros(len(axis))], axis=1))
        return ref, scale[:, PLBEAM_MODES]

    def state(self, x, ref, variant, prev):
        return Selected(_BEAM.state(x, ref, variant, prev), PLBEAM_MODES)

    def deformations(self, x, ref, variant, prev):
        return _BEAM.deformations(x, ref, variant, prev)[:, PLBEAM_MODES]

    def hessian(self, st, w):
        return _BEAM.hessian(st.full, expand(w, PLBEAM_MODES, 6))

    def stiffness(self, props, ref):
        return _BEAM.stiffness(plbeam_props(props), ref)[:, PLBEAM_MODES[:, None], PLBEAM_MODES]

    def mass(self, x, ref, m, rotary="lumped"):
        return _BEAM.mass(x, ref, plbeam_mass(m), rotary)

    def convective(self, x, v, ref, m, rotary="lumped"):
        return _BEAM.convective(x, v, ref, plbeam_mass(m), rotary)

    def check(self, st, ref):
        return check_saturation(st.full, ref)

    def gravity(self, x, ref, mass, g):
        return beam_gravity(x, ref, plbeam_mass(mass), g)
