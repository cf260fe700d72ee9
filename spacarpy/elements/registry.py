"""The registry of element kinds: the only place the rest of the program learns which kinds exist.

:data:`KINDS` maps each deck keyword to its kind (an :class:`~spacarpy.elements.base.ElementKind`
instance), in the order the model keeps and the solver assembles them. Adding a kind is its
own module ``spacarpy/elements/<kind>.py`` plus one entry here (and its tests).
"""
from __future__ import annotations

from spacarpy.elements.base import ElementKind
from spacarpy.elements.beam import Beam
from spacarpy.elements.beamc import BeamC
from spacarpy.elements.beamw import BeamW
from spacarpy.elements.hinge import Hinge
from spacarpy.elements.pinbody import PinBody
from spacarpy.elements.plbeam import PlBeam
from spacarpy.elements.plhinge import PlHinge
from spacarpy.elements.pltruss import PlTruss
from spacarpy.elements.rbeam import RBeam
from spacarpy.elements.truss import Truss
from spacarpy.elements.wheel import Wheel

#: Keyword -> kind, in the order the model keeps and the solver assembles them.
KINDS: dict[str, ElementKind] = {k.keyword: k for k in (
    Beam(), Truss(), Hinge(), RBeam(), PlBeam(), PlTruss(), PlHinge(), PinBody(), Wheel(),
    BeamW(), BeamC())}

#: The planar kinds (a model with them is planar and may not have the others).
PLANAR_KINDS = tuple(k for k, kind in KINDS.items() if kind.planar)


def kind_of(keyword: str) -> ElementKind:
    """The kind of a deck keyword.

    Raises
    ------
    KeyError
        For a keyword that is not an element kind, naming the known ones.
    """
    try:
        return KINDS[keyword]
    except KeyError:
        raise KeyError(f"{keyword!r} is not an element kind; known: {', '.join(KINDS)}") \
            from None
