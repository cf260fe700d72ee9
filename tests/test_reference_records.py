"""The kinds' typed reference records (``elements/base.py: Reference`` and one per kind):
what ``reference`` returns, their parts and stacked copies, and the BEAM's section forms."""
from __future__ import annotations

import dataclasses
import gc
import weakref

import numpy as np
import pytest

from spacarpy.elements import beam
from spacarpy.elements.base import Reference
from spacarpy.elements.beam import Beam, BeamReference, reference_triads
from spacarpy.elements.beam_mass import section_axes
from spacarpy.elements.registry import KINDS


def _reference_of(kind, n: int, seed: int):
    """A kind's reference record of n random elements in the x-y plane (random y-axes or
    hinge axes; the planar kinds ignore them)."""
    rng = np.random.default_rng(seed)
    xp = np.c_[rng.normal(size=(n, 2)), np.zeros(n)]
    xq = xp + np.c_[rng.uniform(0.5, 1.5, size=(n, 2)), np.zeros(n)]
    pos = iter([xp, xq])
    x0 = [next(pos) if s == "pos" else None for s in kind.slots]
    return kind.reference(x0, rng.normal(size=(n, 3)))


def _arrays(ref: Reference) -> dict:
    return {f.name: getattr(ref, f.name) for f in dataclasses.fields(ref)}


@pytest.mark.parametrize("keyword", sorted(KINDS))
def test_every_kind_returns_its_declared_frozen_record(keyword):
    kind = KINDS[keyword]
    ref, scale = _reference_of(kind, 5, 1)
    assert kind.reference_type is not Reference and type(ref) is kind.reference_type
    assert scale.shape == (5, kind.n_def)
    values = _arrays(ref)
    assert values and all(v.shape[0] == 5 for v in values.values() if v is not None)
    with pytest.raises(dataclasses.FrozenInstanceError):
        setattr(ref, next(iter(values)), None)
    assert not hasattr(ref, "__dict__")                       # slots: no stray attributes


@pytest.mark.parametrize("keyword", sorted(KINDS))
def test_take_and_tile_give_the_rows_and_the_stacked_copies(keyword):
    ref, _ = _reference_of(KINDS[keyword], 4, 2)
    assert ref.tile(1) is ref
    tiled, part = ref.tile(3), ref.take(np.array([3, 0]))
    assert type(tiled) is type(ref) and type(part) is type(ref)
    for name, v in _arrays(ref).items():
        np.testing.assert_array_equal(getattr(tiled, name), np.concatenate([v] * 3))
        np.testing.assert_array_equal(getattr(part, name), v[[3, 0]])


def test_optional_fields_stay_none():
    rng = np.random.default_rng(3)
    nx, ny, nz, l0 = reference_triads(rng.normal(size=(4, 3)), rng.normal(size=(4, 3)) + 3.0,
                                      rng.normal(size=(4, 3)))
    ref = BeamReference(nx, ny, nz, l0)
    assert ref.axes is None and ref.u is None
    assert ref.tile(2).u is None and ref.take(slice(1, 3)).axes is None
    np.testing.assert_array_equal(ref.tile(2).l0, np.r_[l0, l0])
    np.testing.assert_array_equal(ref.take(slice(1, 3)).nx, nx[1:3])


def test_the_beam_kernels_read_the_record_with_or_without_its_stacked_vectors():
    """The stacked u and axes are a speed-up only: the same state and mass bit for bit."""
    kind = Beam()
    full, _ = _reference_of(kind, 6, 4)
    bare = BeamReference(full.nx, full.ny, full.nz, full.l0)
    rng = np.random.default_rng(5)
    x = np.concatenate([rng.normal(size=(6, 3)), np.tile([1.0, 0, 0, 0], (6, 1)),
                        rng.normal(size=(6, 3)), np.tile([0.0, 1, 0, 0], (6, 1))], axis=1)
    m = np.abs(rng.normal(size=(6, 5)))
    np.testing.assert_array_equal(kind.state(x, full, "modified", {}).D,
                                  kind.state(x, bare, "modified", {}).D)
    np.testing.assert_array_equal(kind.mass(x, full, m), kind.mass(x, bare, m))


def test_the_beam_section_forms_follow_the_record_into_its_parts_and_copies():
    """The forms are made on first use and kept beside the record: its tiled copies and parts
    get the rows of the kept forms (no remaking them per call), equal to fresh ones."""
    ref, _ = _reference_of(Beam(), 5, 6)
    m = np.c_[np.ones(5), np.full((5, 3), 0.2), np.zeros(5)]
    assert ref not in beam._SECTION_FORMS
    assert beam._section(ref, np.c_[np.ones(5), np.zeros((5, 4))]) is None   # no inertia
    assert ref not in beam._SECTION_FORMS
    forms = beam._section(ref, m)
    np.testing.assert_array_equal(forms, section_axes(ref.axes))
    assert beam._section(ref, m) is forms                                    # made once
    tiled, part = ref.tile(3), ref.take(np.array([4, 1]))
    np.testing.assert_array_equal(beam._SECTION_FORMS[tiled], np.concatenate([forms] * 3))
    np.testing.assert_array_equal(beam._SECTION_FORMS[part], forms[[4, 1]])
    np.testing.assert_array_equal(beam._section(tiled, np.tile(m, (3, 1))),
                                  section_axes(tiled.axes))
    # dropped with the records (their own keys: other tests' records may go at the same
    # collection, so the dictionary's length says nothing)
    gone = [weakref.ref(tiled), weakref.ref(part)]
    del tiled, part
    gc.collect()
    assert all(w() is None for w in gone)
