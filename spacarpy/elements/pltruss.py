"""The planar truss PLTRUSS (``PLTRUSS e p q``): the TRUSS of :mod:`spacarpy.elements.truss`
in a planar model (its nodes stay in the x-y plane, the kernel is the same)."""
from __future__ import annotations

from spacarpy.elements.base import Fields
from spacarpy.elements.truss import Truss


class PlTruss(Truss):
    """``PLTRUSS e p q``: a TRUSS whose model is planar."""

    keyword = "PLTRUSS"
    deformation_meaning = "elongation of each PLTRUSS element"
    stress_meaning = "axial force of each PLTRUSS element"
    em = Fields(("rhoA",), ("kg/m",), 1, 1, "rhoA")
    planar = True
    summary = "planar truss element (x-y plane)"
