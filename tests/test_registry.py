"""The element registry: one declaration per kind, consistent with the deck keywords."""
import numpy as np
import pytest

from spacarpy.deck.keywords import KEYWORDS
from spacarpy.elements.base import ElementKind
from spacarpy.elements.registry import KINDS, PLANAR_KINDS, kind_of
from spacarpy.model import ElementSet


def test_registry_order_and_planar_set():
    assert list(KINDS) == ["BEAM", "TRUSS", "HINGE", "RBEAM", "PLBEAM", "PLTRUSS", "PLHINGE",
                           "PINBODY", "WHEEL", "BEAMW", "BEAMC"]
    assert PLANAR_KINDS == ("PLBEAM", "PLTRUSS", "PLHINGE")
    assert kind_of("TRUSS") is KINDS["TRUSS"]
    with pytest.raises(KeyError, match="not an element kind"):
        kind_of("TUBE")


@pytest.mark.parametrize("keyword", list(KINDS))
def test_declarations_are_consistent(keyword):
    kind = KINDS[keyword]
    assert isinstance(kind, ElementKind) and kind.keyword == keyword
    n = kind.n_def
    assert len(kind.mode_units) == len(kind.length_modes) == n
    assert len(kind.rate_units) in (0, n)
    assert all(0 <= k < n for k in kind.velocity_modes)
    if kind.estiff is None:                 # no mode can be flexible (the WHEEL)
        assert kind.mode_stiffness == () and kind.no_stiffness_why
    else:
        assert len(kind.mode_stiffness) == n
        assert all(0 <= k < kind.n_estiff for k in kind.mode_stiffness)
        assert len(kind.estiff.units) == kind.n_estiff and kind.estiff.required <= kind.n_estiff
    if kind.em is not None:
        assert len(kind.em.units) == kind.n_em
    # the deck keyword is made from the kind: node roles p position, r orientation, w warping
    roles = KEYWORDS[keyword].node_roles
    assert tuple({"p": "pos", "r": "rot", "w": "warp"}[r] for r in roles) == kind.slots
    assert len(kind.node_roles) == len(kind.slots) == len(kind.node_fields)
    assert kind.summary and len(kind.vector_fields) == (3 if kind.vector else 0)
    assert kind.n_ldof == sum({"pos": 3, "rot": 4, "warp": 1}[s] for s in kind.slots)
    # the trailing vector: the keyword accepts three more fields exactly when one is declared,
    # optional unless the kind requires it
    spec = KEYWORDS[keyword]
    assert len(spec.fields) == 1 + len(kind.slots) + (3 if kind.vector else 0)
    assert (len(spec.optional) == 1) == (kind.vector is not None and not kind.vector_required)


@pytest.mark.parametrize("keyword", list(KINDS))
def test_element_set_arrays_have_the_declared_widths(keyword):
    kind = KINDS[keyword]
    es = ElementSet(keyword, ids=[4, 7], nodes=np.arange(2 * len(kind.slots)))
    assert es.nodes.shape == (2, len(kind.slots))
    assert es.def_class.shape == (2, kind.n_def)
    assert es.stiffness.shape == (2, kind.n_estiff)
    assert es.mass.shape == (2, kind.n_em)
    assert np.isnan(es.vector).all()
