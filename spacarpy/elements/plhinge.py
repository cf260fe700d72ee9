"""The planar hinge PLHINGE (``PLHINGE e r s``): the HINGE kernel about the z-axis, with only
its first mode (the joint angle); the other two vanish identically in a planar model."""
from __future__ import annotations

import numpy as np

from spacarpy.elements.base import ROT_P, ROT_Q, ElementKind, Fields, Selected, expand
from spacarpy.elements.hinge import Hinge, hinge_stiffness

_HINGE = Hinge()
_MODES = np.array([0])


class PlHinge(ElementKind):
    """``PLHINGE e r s``: a revolute joint about z between two orientation nodes."""

    keyword = "PLHINGE"
    slots = Hinge.slots
    node_roles = Hinge.node_roles
    modes = ("rotation about z",)
    mode_units = ("rad",)
    stress_units = ("N m",)
    deformation_meaning = "PLHINGE joint angle"
    stress_meaning = "PLHINGE joint moment"
    length_modes = (False,)
    estiff = Fields(("k",), ("N m/rad",), 0, 1, "k")
    mode_stiffness = (0,)
    planar = True
    summary = "planar hinge element (axis z)"
    node_fields = (ROT_P, ROT_Q)
    reference_type = Hinge.reference_type          # the spatial kernel's record

    def reference(self, x0, vector):
        n = len(vector)
        ref, scale = _HINGE.reference(x0, np.tile([0.0, 0.0, 1.0], (n, 1)))
        return ref, scale[:, :1]

    def state(self, x, ref, variant, prev):
        return Selected(_HINGE.state(x, ref, variant, prev), _MODES)

    def deformations(self, x, ref, variant, prev):
        return _HINGE.deformations(x, ref, variant, prev)[:, _MODES]

    def hessian(self, st, w):
        return _HINGE.hessian(st.full, expand(w, _MODES, 3))

    def stiffness(self, props, ref):
        return hinge_stiffness(props[:, :3])[:, :1, :1]

    def commit(self, st, prev):
        _HINGE.commit(st.full, prev)
