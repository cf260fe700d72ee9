"""Schema 2.0: the one table, the 1.x -> 2.0 map, and /transient read back everywhere.

The shipped baselines (``decks/baseline/*.h5``) are 1.x files written before schema 2.0: they
must validate and read through the map of old names, and a 2.0 run of the same deck must give
bit-identical arrays through both readers. The transient checks run the pendulum and the
flexible slider-crank decks once (module fixture).
"""
from __future__ import annotations

import csv
import io
import shutil
from pathlib import Path

import h5py
import numpy as np
import pytest

from spacarpy.batch.compare import compare_files
from spacarpy.cli import main
from spacarpy.results import open_results, read_results, validate_file
from spacarpy.results.schema import (
    DATASETS,
    KIND_NAMES,
    LEGACY_NAMES,
    SCHEMA_VERSION,
    legacy_name,
    n_def,
    new_name,
)
from spacarpy.results.tables import extract

from helpers import as_schema_2

DECKS = Path(__file__).resolve().parents[1] / "decks"
BASELINES = sorted((DECKS / "baseline").glob("*.h5"))


def _major(path) -> int:
    with h5py.File(path, "r") as f:
        return int(f.attrs["schema_version"][0])


#: The baselines written before schema 2.0; decks added later have 2.x baselines
#: (state_space_cantilever: schema 2.3).
BASELINES_1X = [p for p in BASELINES if _major(p) == 1]
#: Transient decks run once for the reader tests below; the slider-crank's baseline was
#: rewritten in schema 2.6 when the turning frame of issue 21 changed its results, the
#: pendulum's in 2.19 when the Lie-group update of issue 32 did.
TRANSIENT = ("pendulum_rigid_90deg", "slider_crank_flexible")
#: The pendulum's former baseline, a 1.x file (schema 1.1, before issue 32): the same deck
#: run with the linear update of the Euler parameters (``lie_group=False``) equals it.
PENDULUM_1X = Path(__file__).resolve().parent / "data" / "pendulum_rigid_90deg_schema1x.h5"


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("schema2")
    out = {}
    for deck in TRANSIENT:
        path = tmp / f"{deck}.h5"
        assert main(["run", str(DECKS / f"{deck}.dat"), "-o", str(path), "-q"]) == 0
        out[deck] = path
    # the pendulum with the linear update of the Euler parameters, against its 1.x file
    from dataclasses import replace

    from spacarpy.solvers.dynamics.transient_records import TransientOptions
    orig = TransientOptions.from_settings.__func__
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(TransientOptions, "from_settings", classmethod(
            lambda cls, s: replace(orig(cls, s), lie_group=False)))
        path = tmp / "pendulum_linear.h5"
        assert main(["run", str(DECKS / "pendulum_rigid_90deg.dat"), "-o", str(path),
                     "-q"]) == 0
    out["linear"] = path
    return out


# --- the table and the map ---------------------------------------------------------------------

def test_the_table_declares_every_kind_and_the_map_points_into_it():
    assert SCHEMA_VERSION == (3, 1)
    for kind in KIND_NAMES:
        for group in ("static", "transient"):
            spec = DATASETS[f"{group}/elements/{kind}/deformation"]
            assert spec.kind == kind and spec.shape[-1] == "deformation_mode" and n_def(kind)
        assert DATASETS[f"model/elements/{kind}/ids"].shape == ("element",)
    for new, old in LEGACY_NAMES.items():
        assert new in DATASETS, new
        assert legacy_name(new, 1) == old and legacy_name(new, 2) == new
        assert new_name("/" + old) == "/" + new
    assert len(set(LEGACY_NAMES.values())) == len(LEGACY_NAMES)
    for path in ("/static/position", "/static/euler", "/static/load_factor",
                 "/model/position_nodes", "/model/orientation_nodes", "/eigen/frequency",
                 "/buckling/load_multiplier", "/transient/time", "/transient/position"):
        assert path[1:] in DATASETS and new_name(path) == path       # kept their names
    for spec in DATASETS.values():
        assert spec.units and spec.long_name and spec.since <= SCHEMA_VERSION


def test_most_baselines_are_1x_files():
    assert len(BASELINES_1X) >= 35        # the legacy reader's test material
    for p in set(BASELINES) - set(BASELINES_1X):
        assert validate_file(p) == [], p  # the newer ones are valid files of today's schema


@pytest.mark.parametrize("baseline", BASELINES_1X, ids=lambda p: p.stem)
def test_every_1x_baseline_validates_and_reads(baseline):
    with h5py.File(baseline, "r") as f:
        assert tuple(f.attrs["schema_version"])[0] == 1
    assert validate_file(baseline) == []
    full, res = read_results(baseline), open_results(baseline)
    assert res.schema_version[0] == 1
    np.testing.assert_array_equal(res.model.elements, full.elements)
    if full.static is not None and full.static.n_step:
        np.testing.assert_array_equal(res.static.deformation(), full.static.deformation)
        for kind, arrays in full.static.elements.items():
            np.testing.assert_array_equal(res.static.stress_resultant(kind=kind),
                                          arrays["stress_resultant"])


def _close(a, b):
    """Equal up to the round-off by which the shipped baselines (older code) differ; the
    bit-identity of the change is checked with ``spacarpy batch --rtol 0 --atol 0``. The
    absolute part scales with the array (a slider crank's bending moments of 1e-3 N m beside
    its 800 N axial force converge with Newton's tolerance on the whole, issue 21)."""
    np.testing.assert_allclose(a, b, rtol=1e-6,
                               atol=1e-9 * max(1.0, float(np.abs(b).max(initial=0.0))))


def test_a_2_0_run_equals_its_1x_baseline_through_both_readers(runs):
    checked = 0
    pairs = [(runs[d], DECKS / "baseline" / f"{d}.h5") for d in TRANSIENT]
    for path, base in pairs + [(runs["linear"], PENDULUM_1X)]:
        assert validate_file(path) == [] and validate_file(base) == []
        assert compare_files(path, base) == []
        new, old = open_results(path), open_results(base)
        assert new.schema_version == SCHEMA_VERSION
        if old.schema_version[0] != 1:
            continue                          # a 2.x baseline: compare_files above
        checked += 1
        assert new.model.element_kinds == old.model.element_kinds
        for kind in new.model.element_kinds:
            np.testing.assert_array_equal(new.model.element_ids(kind),
                                          old.model.element_ids(kind))
            for what in ("deformation", "stress_resultant"):
                a = getattr(new.transient, what)(kind=kind)
                _close(a, getattr(old.transient, what)(kind=kind))
        _close(new.transient.time, old.transient.time)
        _close(new.transient.velocity(), old.transient.velocity())
        a, b = read_results(path), read_results(base)
        for kind, arrays in a.transient.elements.items():
            for what, values in arrays.items():
                if what in ("deformation_rate", "lift_off", "friction_ratio"):
                    continue                  # (since 2.14, 2.15: no 1.x baseline has them)
                _close(values, b.transient.elements[kind][what])
        _close(a.transient.euler_rate, b.transient.euler_rate)
    assert checked >= 1


def test_old_names_read_a_2_0_file_and_new_names_a_1x_file(runs):
    new = open_results(runs["linear"])
    old = open_results(PENDULUM_1X)
    assert old.schema_version[0] == 1
    _close(new._read("transient/hinge_deformation"),
           old._read("transient/elements/HINGE/deformation"))


def test_a_2_0_file_with_a_missing_per_kind_dataset_is_invalid(runs, tmp_path):
    path = tmp_path / "broken.h5"
    shutil.copy(runs["pendulum_rigid_90deg"], path)
    with h5py.File(path, "r+") as f:
        del f["transient/elements/HINGE/stress_resultant"]
    assert "/transient/elements/HINGE/stress_resultant missing" in validate_file(path)


# --- /transient ----------------------------------------------------------------------------------

def test_pendulum_tip_stays_on_its_circle(runs):
    res = open_results(runs["pendulum_rigid_90deg"])
    tr = res.transient
    assert tr.n_step == 441 and tr.time[0] == 0.0 and tr.time[-1] == pytest.approx(2.2)
    tip, pivot = tr.position(node=3), tr.position(node=1)
    np.testing.assert_allclose(np.linalg.norm(tip - pivot, axis=1), 1.0, rtol=0, atol=1e-9)
    assert tip[:, 1].min() < -0.99                    # it swings through the bottom
    # the tip velocity is tangent to the circle, to the integrator's velocity error
    v = tr.velocity(node=3)
    assert np.all(np.abs(np.sum(v * (tip - pivot), axis=1))
                  <= 1e-3 * np.linalg.norm(v, axis=1) + 1e-12)
    hinge = tr.deformation(kind="HINGE")               # (n_step, 1, 3): the joint angle first
    assert hinge.shape == (441, 1, 3)
    angle = np.arctan2(tip[:, 1], tip[:, 0])
    np.testing.assert_allclose(hinge[:, 0, 0], angle, atol=1e-9)
    assert tr.step_at(0.5) == 100 and np.allclose(tr.position(node=3, step=100),
                                                  tip[100])


def test_extract_gives_the_datasets_with_the_time_first(runs):
    path = runs["slider_crank_flexible"]
    res = open_results(path)
    with h5py.File(path, "r") as f:
        t = f["transient/time"][()]
        rows = list(f["model/position_nodes"][()])
        y = f["transient/position"][:, rows.index(15)]
        e = f["transient/elements/PLBEAM/deformation"][()]
        ids = list(f["model/elements/PLBEAM/ids"][()])
        energy = f["transient/kinetic_energy"][()]
    table = extract(res, "time_position", node=15)
    assert table.names[:3] == ["time", "step", "node"]
    parsed = list(csv.reader(io.StringIO(table.to_csv())))
    assert parsed[0][0] == "time [s]"
    values = np.array(parsed[1:], dtype=float)
    np.testing.assert_array_equal(values[:, 0], t)
    np.testing.assert_array_equal(values[:, 3:6], y)                # repr round-trips
    table = extract(res, "time_deformation", element=12)
    np.testing.assert_array_equal(np.column_stack(table.columns[3:]), e[:, ids.index(12)])
    table = extract(res, "energy")
    np.testing.assert_array_equal(table.columns[table.names.index("kinetic_energy")], energy)
    np.testing.assert_array_equal(table.columns[0], t)


def test_show_extract_and_plot_on_the_command_line(runs, tmp_path, capsys):
    path = runs["slider_crank_flexible"]
    assert main(["show", str(path)]) == 0
    text = capsys.readouterr().out
    assert "Time steps:" in text and "energy balance" in text
    out = tmp_path / "history.csv"
    assert main(["extract", str(path), "time_velocity", "--node", "5", "--csv", "-o",
                 str(out)]) == 0
    assert out.read_text().startswith("time [s],step,node,vx [m/s]")
    pytest.importorskip("matplotlib")
    for argv in (["history", "--quantity", "displacement", "--node", "5"],
                 ["history", "--quantity", "energy"], ["shape", "--time", "0.05"]):
        png = tmp_path / f"{argv[0]}_{len(argv)}.png"
        assert main(["plot", str(path), *argv, "-o", str(png)]) == 0
        assert png.stat().st_size > 1000


def test_buckling_kind_is_stored_and_derived_for_older_files(tmp_path):
    """Schema 2.2 stores each buckling multiplier's kind. Table 3's lateral buckling (4
    elements) has 8 finite multipliers (+-4.435 the critical pair, paper Table 3) and, past
    them, multipliers the load does not reach: stored as NaN of kind 4 ("infinite"). A file
    without the dataset (older than 2.2) gets the same kinds from its NaN multipliers."""
    out = tmp_path / "t3.h5"
    deck = DECKS / "table3_lateral_buckling_4el_modified.dat"
    assert main(["run", str(deck), "-o", str(out), "-q"]) == 0
    with open_results(out) as res:
        mu, kind = res.buckling.load_multiplier[-1], res.buckling.kind[-1]
    assert kind.dtype == np.int8
    np.testing.assert_array_equal(kind, np.where(np.isnan(mu), 4, 0))
    assert (kind == 0).sum() == 8 and (kind == 4).sum() >= 1
    np.testing.assert_allclose(np.abs(mu[:2]), 4.4355, rtol=1e-4)
    with h5py.File(out, "r+") as f:                 # as a 2.1 file was written
        del f["buckling/kind"]
        as_schema_2(f, 1)
    with open_results(out, verify=False) as res:
        np.testing.assert_array_equal(res.buckling.kind[-1], kind)


def test_attributes_written_low_level_equal_h5pys_own(tmp_path):
    """h5file.new_attrs writes exactly what ``ds.attrs[name] = value`` writes: the same HDF5
    type and scalar space, read back as the same Python value and type."""
    from spacarpy.results.h5file import new_attrs

    values = {"units": "N m", "long_name": "Größe, µm", "empty": "", "crc32": np.int64(-7)}
    with h5py.File(tmp_path / "a.h5", "w") as f:
        theirs = f.create_dataset("theirs", data=np.zeros(3))
        mine = f.create_dataset("mine", data=np.zeros(3))
        for name, value in values.items():
            theirs.attrs[name] = value
        new_attrs(mine, values)
        for name in values:
            a = h5py.h5a.open(theirs.id, name.encode())
            b = h5py.h5a.open(mine.id, name.encode())
            assert a.get_type() == b.get_type(), name
            assert a.get_space().get_simple_extent_type() == \
                b.get_space().get_simple_extent_type() == h5py.h5s.SCALAR, name
            assert mine.attrs[name] == theirs.attrs[name] == values[name], name
            assert type(mine.attrs[name]) is type(theirs.attrs[name]), name
        with pytest.raises(TypeError, match="str or np.int64"):
            new_attrs(mine, {"scale": 1.5})
