"""Tests of spacarpy.results: round trip, schema checks, and crash safety of the writer."""
from __future__ import annotations

import datetime as dt
import hashlib
import os
import signal
from pathlib import Path

import h5py
import numpy as np
import pytest

from spacarpy.errors import EXIT_INPUT, SpacarError
from spacarpy.results import (
    SCHEMA_VERSION,
    ResultsFormatError,
    ResultsWriter,
    read_results,
    validate_file,
)
from spacarpy.results.header_crc import header_crc
from spacarpy.results.schema import DATASETS

from helpers import (
    DECK_TEXT,
    REACTION_COMPONENT,
    begin,
    chain_model,
    run_and_kill,
    step_data,
    writer,
)


def write_run(path, model, n_steps: int = 3) -> None:
    with writer(path, model) as w:
        begin(w, model)
        for k in range(n_steps):
            w.static_step(**step_data(model, k))
        w.finish()


def assert_steps(static, model, n_steps: int) -> None:
    """The file's committed steps are exactly ``step_data(model, 0 .. n_steps-1)``."""
    assert static.n_step == n_steps
    for name in ("load_factor", "position", "euler", "deformation", "stress_resultant",
                 "reaction", "iterations", "residual"):
        expected = np.array([_beam(step_data(model, k)[name]) for k in range(n_steps)])
        np.testing.assert_array_equal(getattr(static, name), expected, err_msg=name)


def _beam(value):
    """The BEAM array of a per-kind dict, other values as they are."""
    return value["BEAM"] if isinstance(value, dict) else value


def sha256(path) -> str:
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


# --- round trip and layout ----------------------------------------------------------------------

def test_round_trip(tmp_path):
    model = chain_model()
    out = tmp_path / "cantilever.h5"
    write_run(out, model)
    assert out.exists() and not (tmp_path / "cantilever.partial.h5").exists()

    res = read_results(out)
    assert res.completed and res.error is None
    assert res.schema_version == SCHEMA_VERSION
    assert res.attrs["filetype"] == "spacarpy-results"
    assert res.attrs["program"] == "spacarpy" and res.attrs["program_version"] == "0.1.0"
    assert res.analysis == "static" and res.deformations == "modified"
    assert dt.datetime.fromisoformat(res.attrs["created"]).tzinfo is not None
    assert res.attrs["deck_path"] == os.path.abspath("decks/tiny.dat")
    assert res.attrs["deck_sha256"] == hashlib.sha256(DECK_TEXT.encode()).hexdigest()
    assert res.deck == DECK_TEXT
    np.testing.assert_array_equal(res.position_nodes, [1, 3, 5])
    np.testing.assert_array_equal(res.orientation_nodes, [2, 4, 6])
    np.testing.assert_array_equal(res.position_x0, model.position_x0)
    np.testing.assert_array_equal(res.elements, [1, 2])
    np.testing.assert_array_equal(res.element_nodes, [[1, 2, 3, 4], [3, 4, 5, 6]])
    assert res.element_type == ["BEAM", "BEAM"]
    assert_steps(res.static, model, 3)
    np.testing.assert_array_equal(res.static.reaction_node, [1, 1, 1, 2, 2, 2])
    assert res.static.reaction_component == REACTION_COMPONENT
    assert res.static.iterations.dtype == np.int32
    assert res.position_nodes.dtype == np.int64

    assert validate_file(out) == []
    assert validate_file(out, require_complete=True) == []


def test_layout_follows_schema(tmp_path):
    out = tmp_path / "r.h5"
    write_run(out, chain_model())
    with h5py.File(out, "r") as f:
        assert f.attrs["schema_version"].dtype == np.int32
        assert list(f.attrs["schema_version"]) == list(SCHEMA_VERSION) == [3, 1]
        assert f["deck"].shape == ()
        assert h5py.check_string_dtype(f["deck"].dtype).encoding == "utf-8"
        info = h5py.check_string_dtype(f["model/elements/BEAM/cross_section_type"].dtype)
        assert info.encoding == "utf-8" and info.length is None    # 3.0: variable length
        lf = f["static/load_factor"]
        assert h5py.h5ds.is_scale(lf.id)
        for name in ("position", "euler", "elements/BEAM/deformation",
                     "elements/BEAM/stress_resultant", "reaction", "iterations", "residual"):
            ds = f["static"][name]
            assert ds.maxshape[0] is None and ds.chunks is not None
            assert ds.dims[0].label == "step"
            assert ds.attrs["units"] == DATASETS["static/" + name].units
            assert h5py.h5ds.is_attached(ds.id, lf.id, 0)
        units = {}

        def collect(name, obj):   # must return None, or visititems stops
            if isinstance(obj, h5py.Dataset):
                assert obj.attrs["long_name"]
                units[name] = obj.attrs["units"]

        f.visititems(collect)
        assert units["static/position"] == "m"
        assert units["static/elements/BEAM/stress_resultant"] == "N"
        assert units["static/reaction"] == "1"      # 3.0: one unit per component beside it
        assert list(f["static/reaction"].attrs["units_per_index"].astype(str)) == [
            {"F": "N", "M": "N m"}[c[0]]
            for c in f["static/reaction_component"].asstr()[()]]
        assert units["model/position_nodes"] == "1"
        schema = [n for n in units if n in DATASETS]
        assert len(schema) == 16 + 14 + 1 + 1  # the 1.0 datasets but element_type, the 1.1
        # ones, /static/integrity/checksum (2.1; 3.0 its place), /static/converged_by (2.7)
        # and the dimension scales of schema 3.0, one per named axis of each group
        assert sorted(set(units) - set(schema)) == [
            "model/axis", "model/coordinate", "model/elements/BEAM/deformation_mode",
            "model/elements/BEAM/element", "model/elements/BEAM/slot", "model/end",
            "model/global_coordinate", "model/load", "model/mass_term",
            "model/orientation_node", "model/position_node", "model/section_dim",
            "model/stiffness_term", "static/coordinate",
            "static/elements/BEAM/deformation_mode", "static/elements/BEAM/element",
            "static/euler_parameter", "static/integrity/checked_dataset",
            "static/orientation_node", "static/position_node", "static/reaction_number"]
        for name in set(units) - set(schema):
            assert h5py.h5ds.is_scale(f[name].id), name


def test_overwrites_existing_output_only_when_finished(tmp_path):
    model = chain_model()
    out = tmp_path / "r.h5"
    write_run(out, model, n_steps=2)
    write_run(out, model, n_steps=4)
    assert read_results(out).static.n_step == 4


# --- schema version and file type ----------------------------------------------------------------

def _set_attr(path, name, value):
    with h5py.File(path, "r+") as f:
        f.attrs[name] = value


def test_newer_major_version_is_refused(tmp_path):
    out = tmp_path / "r.h5"
    write_run(out, chain_model())
    _set_attr(out, "schema_version", np.array([99, 0], dtype=np.int32))
    with pytest.raises(ResultsFormatError) as info:
        read_results(out)
    message = str(info.value)
    assert "99.0" in message and "3.1" in message
    assert isinstance(info.value, SpacarError) and info.value.exit_code == EXIT_INPUT
    problems = validate_file(out)
    assert len(problems) == 1 and "99" in problems[0]


def test_newer_minor_version_is_read(tmp_path):
    out = tmp_path / "r.h5"
    write_run(out, chain_model())
    newer = (SCHEMA_VERSION[0], SCHEMA_VERSION[1] + 1)
    _set_attr(out, "schema_version", np.array(newer, dtype=np.int32))
    with h5py.File(out, "r+") as f:     # as its writer would: the header's checksum too
        f.attrs["header_crc32"] = header_crc(f.attrs)
    assert read_results(out).schema_version == newer
    assert validate_file(out) == []


def test_wrong_filetype_and_non_hdf5_are_refused(tmp_path):
    out = tmp_path / "r.h5"
    write_run(out, chain_model())
    _set_attr(out, "filetype", "something-else")
    with pytest.raises(ResultsFormatError, match="not a spacarpy results file"):
        read_results(out)
    junk = tmp_path / "junk.h5"
    junk.write_text("not hdf5")
    with pytest.raises(ResultsFormatError, match="not an HDF5 file"):
        read_results(junk)
    assert validate_file(tmp_path / "missing.h5") != []


def test_validator_reports_layout_problems(tmp_path):
    out = tmp_path / "r.h5"
    write_run(out, chain_model())
    with h5py.File(out, "r+") as f:
        del f.attrs["created"]
        del f["static/euler"].attrs["units"]
        f["static/residual"].resize(2, axis=0)
    problems = validate_file(out)
    assert any("created missing" in p for p in problems)
    assert any("/static/euler has no units" in p for p in problems)
    assert any("/static/residual has 2 steps" in p for p in problems)
    with pytest.raises(ResultsFormatError, match="not a valid"):
        read_results(out)


# --- failures inside the with block ---------------------------------------------------------------

@pytest.mark.parametrize("previous_output", [False, True])
@pytest.mark.parametrize("exc, message", [(RuntimeError("no convergence in step 3"),
                                           "no convergence in step 3"),
                                          (KeyboardInterrupt(), "interrupted by user")])
def test_exception_keeps_partial_and_output(tmp_path, previous_output, exc, message):
    model = chain_model()
    out = tmp_path / "r.h5"
    if previous_output:
        write_run(out, model, n_steps=5)
        good = sha256(out)
    with pytest.raises(type(exc)):
        with writer(out, model) as w:
            begin(w, model)
            for k in range(2):
                w.static_step(**step_data(model, k))
            raise exc
    assert w.partial_path == tmp_path / "r.partial.h5" and w.final_path == out
    if previous_output:
        assert sha256(out) == good
    else:
        assert not out.exists()
    assert w.partial_path.exists()
    with h5py.File(w.partial_path, "r"):   # a plain open works: the file was closed cleanly
        pass
    assert validate_file(w.partial_path) == []
    res = read_results(w.partial_path)
    assert res.completed is False and res.error == message
    assert_steps(res.static, model, 2)
    problems = validate_file(w.partial_path, require_complete=True)
    assert problems == [f"run incomplete: {message}"]


def test_exception_before_begin_static(tmp_path):
    model = chain_model()
    with pytest.raises(ValueError, match="bad deck"):
        with writer(tmp_path / "r.h5", model) as w:
            raise ValueError("bad deck")
    assert w._file is None
    res = read_results(w.partial_path)
    assert not res.completed and res.error == "bad deck" and res.static is None
    assert validate_file(w.partial_path) == []


def test_leaving_without_finish_is_incomplete(tmp_path):
    model = chain_model()
    with writer(tmp_path / "r.h5", model) as w:
        begin(w, model)
        w.static_step(**step_data(model, 0))
    assert w._file is None and not w.final_path.exists()
    res = read_results(w.partial_path)
    assert not res.completed and "without finish" in res.error
    assert res.static.n_step == 1


def test_bad_step_is_rejected_before_touching_the_file(tmp_path):
    model = chain_model()
    with pytest.raises(ValueError, match="position has shape"):
        with writer(tmp_path / "r.h5", model) as w:
            begin(w, model)
            w.static_step(**step_data(model, 0))
            w.static_step(**{**step_data(model, 1), "position": np.zeros((2, 3))})
    assert validate_file(w.partial_path) == []
    assert_steps(read_results(w.partial_path).static, model, 1)


def test_counts_must_match_model(tmp_path):
    model = chain_model()
    with pytest.raises(ValueError, match="n_orientation_node"):
        with writer(tmp_path / "r.h5", model) as w:
            w.begin_static(3, 5, [], [])
    assert w._file is None


def test_no_reactions_and_no_steps(tmp_path):
    model = chain_model()
    out = tmp_path / "r.h5"
    with writer(out, model) as w:
        w.begin_static(3, 3, [], [])
        w.finish()
    assert validate_file(out) == []
    res = read_results(out)
    assert res.static.n_step == 0 and res.static.reaction.shape == (0, 0)


def test_linearized_groups_round_trip(tmp_path):
    # /eigen, /buckling and /compliance are written next to /static by the linearized analyses.
    model = chain_model()
    out = tmp_path / "r.h5"
    rng = np.random.default_rng(1)
    shapes = [(rng.standard_normal((2, 3, 3)), rng.standard_normal((2, 3, 4))) for _ in range(2)]
    with ResultsWriter(out, model, program_version="0.1.0", deformations="basic",
                       analysis="eigen") as w:
        w.begin_static(3, 3, [1], ["Fx"], n_eigen_modes=2, n_buckling_modes=2,
                       compliance_node=(5, 6))
        for k in range(2):
            w.static_step(**{**step_data(model, k), "reaction": [1.0]})
            w.eigen_step(k, [4.0 + 0j, 9.0 + 0j], [1.0, 2.0], [0, 0], *shapes[k])
            w.buckling_step(k, [3.0, -5.0], 3.0, *shapes[k])
            w.compliance_step(k, np.eye(6) * (k + 1), np.eye(6))
        w.finish()
    assert validate_file(out, require_complete=True) == []
    res = read_results(out)
    np.testing.assert_array_equal(res.eigen.step, [0, 1])
    np.testing.assert_array_equal(res.eigen.frequency, [[1.0, 2.0], [1.0, 2.0]])
    np.testing.assert_array_equal(res.eigen.shape_position[1], shapes[1][0])
    np.testing.assert_array_equal(res.buckling.critical_load_multiplier, [3.0, 3.0])
    np.testing.assert_array_equal(getattr(res.compliance, "global")[1], 2 * np.eye(6))


# --- a real process killed with SIGKILL ---------------------------------------------------------

@pytest.mark.slow
@pytest.mark.skipif(not hasattr(signal, "SIGKILL"), reason="needs POSIX SIGKILL")
def test_sigkill_between_steps_leaves_readable_partial(tmp_path):
    model = chain_model()

    def read_while_running(partial, reported):   # SWMR: the live file can be read
        assert validate_file(partial) == []
        assert read_results(partial).static.n_step >= reported

    out, reported = run_and_kill(tmp_path, n_elem=2, pause=0.05, on_running=read_while_running)
    partial = tmp_path / "killed.partial.h5"
    assert not out.exists() and partial.exists()
    # Structurally valid; the only thing "wrong" is that the run is incomplete.
    assert validate_file(partial) == []
    assert validate_file(partial, require_complete=True) == [
        "run incomplete: the writer did not finish (killed, or still running)"]
    res = read_results(partial)
    assert res.completed is False and res.error is None
    assert res.static.n_step >= reported >= 3
    assert_steps(res.static, model, res.static.n_step)
    # A new run replaces the stale partial file and finishes normally.
    write_run(out, model)
    assert not partial.exists() and validate_file(out, require_complete=True) == []


@pytest.mark.slow
@pytest.mark.skipif(not hasattr(signal, "SIGKILL"), reason="needs POSIX SIGKILL")
def test_sigkill_while_writing_keeps_committed_steps(tmp_path):
    # No pause and a bigger model: the kill almost always lands inside static_step.
    model = chain_model(n_elem=3000)
    out, reported = run_and_kill(tmp_path, n_elem=3000, pause=0.0, kill_after=5)
    partial = tmp_path / "killed.partial.h5"
    assert validate_file(partial) == []
    res = read_results(partial)
    assert res.static.n_step >= reported >= 5
    assert_steps(res.static, model, res.static.n_step)
