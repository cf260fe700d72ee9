"""The lazy reader spacarpy.open_results, on real result files of the shipped decks.

The ``result_files`` fixture (conftest.py) writes one representative file of each kind
(static, static with cross-sections, linearized groups, failed run) once per test session; the
CLI, export, plot and documentation tests use the same files.
"""
from __future__ import annotations

import shutil
from pathlib import Path

import h5py
import numpy as np
import pytest

import spacarpy
from spacarpy.errors import EXIT_INPUT
from spacarpy.results import (
    ResultsFormatError,
    ResultsQueryError,
    open_results,
    read_results,
    validate_file,
)

DECKS = Path(__file__).resolve().parents[1] / "decks"


@pytest.fixture(scope="module")
def files(result_files):
    return result_files


def test_every_written_file_is_valid(files):
    for key, path in files.items():
        assert validate_file(path) == [], key
        assert (validate_file(path, require_complete=True) == []) == \
            (key not in ("failed", "kinematic"))


def test_open_results_is_exported_at_the_top(files):
    assert spacarpy.open_results is open_results
    res = spacarpy.open_results(files["bend"])
    assert res.completed and res.analysis == "static" and res.schema_version == (3, 1)
    assert "static analysis, completed" in repr(res)


def test_static_accessors_agree_with_the_eager_reader(files):
    res, full = open_results(files["bend"]), read_results(files["bend"])
    s, m = res.static, res.model
    assert s.n_step == 11
    tip, n17 = (int(np.flatnonzero(full.position_nodes == n)[0]) for n in (3, 17))
    assert m.position_row(3) == tip and m.position_row([17, 3]).tolist() == [n17, tip]
    np.testing.assert_allclose(full.position_x0[tip], [100 * np.sin(np.pi / 4), 0,
                                                       100 * (1 - np.cos(np.pi / 4))])
    np.testing.assert_array_equal(s.load_factor, full.static.load_factor)
    np.testing.assert_array_equal(s.position(node=3), full.static.position[:, tip])
    np.testing.assert_array_equal(s.position(step=-1), full.static.position[-1])
    np.testing.assert_array_equal(s.position(node=3, step=4), full.static.position[4, tip])
    np.testing.assert_array_equal(s.position(node=[17, 3], step=[10, 0, 10]),
                                  full.static.position[[10, 0, 10]][:, [n17, tip]])
    np.testing.assert_array_equal(s.position(step=slice(2, 5)), full.static.position[2:5])
    np.testing.assert_array_equal(s.displacement(node=3),
                                  full.static.position[:, tip] - full.position_x0[tip])
    r4 = m.orientation_row(4)
    np.testing.assert_array_equal(s.euler(node=4), full.static.euler[:, r4])
    e8, e2 = m.element_row(8), m.element_row(2)
    np.testing.assert_array_equal(s.deformation(element=8), full.static.deformation[:, e8])
    np.testing.assert_array_equal(s.stress_resultant(element=2, step=-1),
                                  full.static.stress_resultant[-1, e2])
    np.testing.assert_array_equal(s.iterations, full.static.iterations)
    assert m.element_length == pytest.approx(np.full(8, 2 * 100 * np.sin(np.pi / 64)))
    assert m.coordinate_node.size == 3 * 9 + 4 * 9 and m.coordinate_fixed.sum() == 7
    assert m.stiffness[0, 0] == 1e7 and m.load_type.tolist() == ["DELXF"]
    # reactions by node: the clamp carries the tip force; node 3 (the tip) is not supported
    np.testing.assert_allclose(s.reaction(node=1, step=-1), [0, -600, 0], atol=1e-6)
    assert s.reaction(node=2).shape == (11, 3)
    assert np.isnan(s.reaction(node=3)).all()


def test_section_forces_balance_the_tip_force_at_the_root(files):
    s = open_results(files["bend"]).static
    # root moment about the clamp, r x F with F = 600 N along y at the tip
    tip = s.position(node=3, step=-1)
    moment = np.cross(tip, [0.0, 600.0, 0.0])
    f = s.section_forces(element=1, step=-1)
    # the element's moments at p, in its (undeformed, clamped) axes; Eq. (17) identifies them
    # to first order in the element's rotation relative to its chord (a few percent here)
    model = open_results(files["bend"]).model
    local = model.element_axes[model.element_row(1)] @ moment
    np.testing.assert_allclose([f[1], f[2], f[4]], local, atol=0.03 * np.linalg.norm(moment))


def test_linearized_views(files):
    res, full = open_results(files["column"]), read_results(files["column"])
    e, b, c = res.eigen, res.buckling, res.compliance
    assert e.n_lin == 5 and e.n_mode == 3
    np.testing.assert_array_equal(e.step, np.arange(5))
    np.testing.assert_array_equal(e.frequency, full.eigen.frequency)
    np.testing.assert_array_equal(e.load_factor, res.static.load_factor)
    assert e.eigenvalue.dtype == complex and e.kind.shape == (5, 3)
    shape = e.shape(mode=1, step=3)
    np.testing.assert_array_equal(shape.position, full.eigen.shape_position[3, 0])
    np.testing.assert_array_equal(shape.euler, full.eigen.shape_euler[3, 0])
    np.testing.assert_array_equal(e.shape(mode=2).position, full.eigen.shape_position[-1, 1])
    np.testing.assert_array_equal(b.critical_load_multiplier,
                                  full.buckling.critical_load_multiplier)
    assert np.isinf(b.critical_load_multiplier[0])          # unloaded: no buckling
    assert c.node == (3, 4) and c.global_.shape == (5, 6, 6)
    with pytest.raises(ResultsQueryError, match="modes are numbered 1..3"):
        e.shape(mode=4)


def test_queries_that_cannot_be_answered_name_what_exists(files):
    s = open_results(files["bend"]).static
    with pytest.raises(ResultsQueryError, match=r"position node 4 is not in this model "
                                                r"\(position nodes: 1, 3, 5, ..., 17\)"):
        s.position(node=4)
    with pytest.raises(ResultsQueryError, match=r"step 11 does not exist: .* \(0..10\)"):
        s.position(step=11)
    with pytest.raises(ResultsQueryError, match="element 9"):
        s.deformation(element=9)
    err = pytest.raises(ResultsQueryError, s.max_von_mises_stress).value
    assert err.exit_code == EXIT_INPUT and isinstance(err, LookupError)
    assert open_results(files["bend"]).eigen is None


def test_partial_file_and_live_reading(files):
    res = open_results(files["failed"])
    assert not res.completed and "spurious" in res.error
    assert 1 <= res.static.n_step < 11
    assert res.static.position().shape[0] == res.static.n_step


def test_with_block_keeps_one_handle(files):
    res = open_results(files["bend"])
    with res:
        handle = res._handle
        assert handle is not None and res.static.position(node=3).shape == (11, 3)
        assert res._handle is handle
    assert res._handle is None
    assert res.static.n_step == 11            # opens the file again


def test_newer_major_version_is_refused_with_both_versions(files, tmp_path):
    path = tmp_path / "future.h5"
    shutil.copy(files["bend"], path)
    with h5py.File(path, "r+") as f:
        f.attrs["schema_version"] = np.array([4, 0], dtype=np.int32)
    with pytest.raises(ResultsFormatError, match=r"schema version 4\.0 is newer than schema "
                                                 r"version 3\.1"):
        open_results(path)


def test_schema_1_0_file_is_still_read(files, tmp_path):
    """A 1.0 file lacks the 1.1 model datasets: lengths and connectivity are derived."""
    path = tmp_path / "old.h5"
    shutil.copy(DECKS / "baseline" / "table2_bend_8el_modified.h5", path)     # schema 1.x
    with h5py.File(path, "r+") as f:
        f.attrs["schema_version"] = np.array([1, 0], dtype=np.int32)
        for name in list(f["model"]):
            if name not in ("position_nodes", "position_x0", "orientation_nodes", "elements",
                            "element_nodes", "element_type"):
                del f["model"][name]
    assert validate_file(path) == []
    new, old = open_results(files["bend"]).model, open_results(path).model
    np.testing.assert_allclose(old.element_length, new.element_length, rtol=1e-15)
    np.testing.assert_array_equal(old.element_position_rows, new.element_position_rows)
    assert old.coordinate_node is None and old.stiffness is None
    with h5py.File(path, "r+") as f:          # but a 1.1 file must have them
        f.attrs["schema_version"] = np.array([1, 1], dtype=np.int32)
    assert any("/model/element_length missing" in p for p in validate_file(path))
