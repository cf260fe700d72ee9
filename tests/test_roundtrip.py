"""Model -> deck -> model round trips: every shipped deck, every element kind, and the static
results of re-written decks with non-BEAM kinds, bit for bit."""
from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from spacarpy.deck import job_from_text, load, model_from_text, model_to_deck
from spacarpy.elements.registry import KINDS
from spacarpy.model import ElementSet, Model
from spacarpy.settings import AnalysisSettings

DECKS = Path(__file__).resolve().parent.parent / "decks"
SHIPPED = sorted(DECKS.glob("*.dat"))

#: Model fields that say where the model came from, not what it is.
_ORIGIN = {"source_path", "source_text"}


def _without_loc(value):
    if dataclasses.is_dataclass(value) and not isinstance(value, type) \
            and any(f.name == "loc" for f in dataclasses.fields(value)):
        return dataclasses.replace(value, loc=None)
    return value


def _assert_same(a, b, what: str) -> None:
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        assert np.asarray(a).dtype == np.asarray(b).dtype, what
        np.testing.assert_array_equal(a, b, err_msg=what)
    elif isinstance(a, ElementSet):
        for f in dataclasses.fields(ElementSet):
            if f.name != "locs":
                _assert_same(getattr(a, f.name), getattr(b, f.name), f"{what}.{f.name}")
    elif isinstance(a, dict):
        assert list(a) == list(b), what
        for k in a:
            _assert_same(a[k], b[k], f"{what}[{k!r}]")
    elif isinstance(a, list):
        assert [_without_loc(v) for v in a] == [_without_loc(v) for v in b], what
    elif hasattr(a, "by_element"):          # CrossSections
        assert {e: (cs.shape, cs.dims) for e, cs in a.by_element.items()} == \
            {e: (cs.shape, cs.dims) for e, cs in b.by_element.items()}, what
    else:
        assert _without_loc(a) == _without_loc(b), what


def assert_models_equal(a: Model, b: Model) -> None:
    """Every field of two models equal (floats bit for bit), source locations aside."""
    for f in dataclasses.fields(Model):
        if f.name not in _ORIGIN:
            _assert_same(getattr(a, f.name), getattr(b, f.name), f.name)


def assert_settings_equal(a: AnalysisSettings, b: AnalysisSettings) -> None:
    """Every setting equal, source locations aside."""
    assert dataclasses.replace(a.static.iterstep, loc=None) == \
        dataclasses.replace(b.static.iterstep, loc=None)
    for f in dataclasses.fields(AnalysisSettings):
        if f.name != "static":
            assert getattr(a, f.name) == getattr(b, f.name), f.name


def assert_jobs_equal(a, b) -> None:
    assert_models_equal(a.model, b.model)
    assert_settings_equal(a.settings, b.settings)


@pytest.mark.parametrize("path", SHIPPED, ids=lambda p: p.stem)
def test_every_shipped_deck_round_trips(path):
    job = load(path)
    assert_jobs_equal(job, job_from_text(model_to_deck(*job), "<written>"))
    assert_jobs_equal(job, job_from_text(model_to_deck(*job, compact=True), "<compact>"))


#: Every kind and every setting a model holds, in a spatial and a planar deck.
SPATIAL = """
MODE transient
BIFURCATION warn
MODES 3 each
DEFORMATIONS basic
X 1 0 0 0
X 3 1 0 0
X 5 2 0 0.5
X 7 1 1 0
X 9 2 1 0
BEAM 1 1 2 3 4 0 0 1
BEAM 2 3 4 5 6
TRUSS 3 3 7
TRUSS 4 7 9
RBEAM 5 5 6 9 0 1 0
HINGE 6 2 8 0 0 1
BEAMW 7 5 6 11 9 10 12 0 1 0
X 13 0 2 0
BEAMC 8 1 2 13 14 1 1 0
DYNE 8 1 2 3 4 5 6
DYNE 7 1 2 3 4 5 6
DYNE 1 1 2 3 4 5 6
RLSE 2 1 2
DYNE 2 3 4 5 6
DYNE 3 1
DYNE 4 1
DYNE 6 1
FIX 1
FIX 2
FIX 7 3
FIX 11
INPUTX 9 3
INPUTE 6 2
INPUTR 8 0 1 1
KINE 6 3
KINX 9 1 2
KINE 5 2
END
HALT
ESTIFF 1 2.1e7 1.1e4 1.7e4 1.7e4 0.001 0.002
ESTIFF 2 2.1e7 1.1e4 1.7e4 1.7e4
ESTIFF 3 1e5
ESTIFF 4 1e5
ESTIFF 5 1e3 2e3
ESTIFF 6 5.5
EM 1 1.2 1e-3 6e-4 6e-4 1e-5
ESTIFF 7 2.1e7 1.1e4 1.7e4 1.7e4 0 0 3.5
EM 7 1.2 1e-3 6e-4 6e-4 0 2e-7
ESTIFF 8 2.1e7 1.1e4 1.7e4 1.7e4 0.001
EM 8 0.8 1e-3 6e-4 6e-4
EM 2 1.2
EM 3 0.3
EM 5 0.7 1e-4
EDAMP 1 0.1 0 0.3
EDAMP 6 0.25
XM 3 2.5
XM 4 1 0 0 2 0 3
XF 3 0 0 -1.5
DELXF 5 0 1 0
DELXF 4 0.1 0 0
INPUTX 9 3 0.01
DELINPX 9 3 -0.02
INPUTE 6 2 1e-3
DELINPE 6 2 2e-3
DELINPR 8 0.3
GRAVITY 0 0 -9.81
ITERSTEP 15 3 1e-9 0 0 2
TIMESTEP 0.5 10
ERROR 1e-6 1e-4
SUBSTEPS 2
RHOINF 0.7
DAMPING 0.01 0.002
START static
TIMEFUNCTION table 0 0 0.1 1 0.5 1
VELOCITY 5 0 0.1 0
END
HALT
INPUTS 1 6 1
INPUTF 3 3 2
OUTE 1 6 1
OUTEP 2 2 3
END
END
VISUALIZATION
BEAMPROPS 1 2
CROSSTYPE RECT
CROSSDIM 0.02 0.01
"""

PLANAR = """
MODE eigen
X 1 0 0
X 3 1 0
X 5 2 0.5
X 7 1 1
PLBEAM 1 1 2 3 4
PLTRUSS 2 3 7
PLTRUSS 3 5 7
PLBEAM 4 3 6 5 8
PLHINGE 5 4 6
DYNE 1 1 2 3
DYNE 2 1
RLSE 3 1
DYNE 4 1 2 3
DYNE 5 1
FIX 1
INPUTX 2 1
INPUTX 7 2
END
HALT
ESTIFF 1 2.1e7 1.7e4 0.001
ESTIFF 2 1e5
ESTIFF 3 1e5
ESTIFF 4 2.1e7 1.7e4
ESTIFF 5 3.5
EM 1 1.2 6e-4
EM 2 0.3
EM 4 1.2
XM 3 2.5
XM 4 0.5
XF 5 1 -2
DELXF 8 0.25
INPUTX 2 1 0.05
DELINPX 2 1 0.1
DELINPX 7 2 -0.01
VELOCITY 3 0.1 0 0
ITERSTEP 10 2 1e-10
END
END
"""

# the rolling-contact kinds: a zero-length and a released, flexible pin; wheels z up and down
ROLLING = """
MODE eigen
X 1 0 0 0.3
X 2 0 0 0
X 3 1 0 0.3
X 4 1 0 0.3
X 5 2 0 -0.35
X 6 2 0 0
WHEEL 1 1 11 2 0 1 0
PINBODY 2 1 11 3
PINBODY 3 3 11 4
WHEEL 4 5 12 6 0 -1 0
HINGE 5 11 12 0 0 1
RLSE 1 4 5
RLSE 2 3
DYNE 2 1
DYNE 5 1
END
HALT
ESTIFF 2 1e4
XM 1 2.0
XM 11 0.05 0 0 0.09 0 0.05
END
END
"""


@pytest.mark.parametrize("text", [SPATIAL, PLANAR, ROLLING], ids=["spatial", "planar",
                                                                  "rolling"])
def test_every_kind_and_setting_round_trips(text):
    job = job_from_text(text)
    assert job.settings != AnalysisSettings()        # the decks set every setting
    for compact in (False, True):
        assert_jobs_equal(job, job_from_text(model_to_deck(*job, compact=compact)))


def test_the_round_trip_decks_cover_every_kind():
    kinds = set().union(*(model_from_text(t).elements for t in (SPATIAL, PLANAR, ROLLING)))
    assert kinds == set(KINDS)


@pytest.mark.parametrize("name", ["four_bar_linkage", "two_bar_truss", "planar_four_bar",
                                  "slider_crank_flexible", "leafspring_guidance_buckling"])
def test_rewritten_deck_gives_the_same_static_results(name):
    from spacarpy.solvers.statics.static import solve_static

    job = load(DECKS / f"{name}.dat")
    again = job_from_text(model_to_deck(*job), "<written>")
    runs = []
    for model, settings in (job, again):      # a couple of load steps
        it = settings.iterstep
        settings = settings.override(iterstep=dataclasses.replace(it, n_steps=min(it.n_steps, 2)))
        runs.append(solve_static(model, settings).steps)
    assert len(runs[0]) == len(runs[1]) == min(job.settings.iterstep.n_steps, 2) + 1
    for s0, s1 in zip(*runs):
        np.testing.assert_array_equal(s0.x, s1.x)
        assert s0.stress.keys() == s1.stress.keys()
        for kind in s0.stress:
            np.testing.assert_array_equal(s0.stress[kind], s1.stress[kind])
            np.testing.assert_array_equal(s0.deformation[kind], s1.deformation[kind])
