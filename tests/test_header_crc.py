"""The root attributes written with the header are covered by ``header_crc32`` (schema
2.18): a changed ``program_version`` or ``created`` (or deck path, analysis ...) is reported
as damaged by validate, read_results and open_results; a file without the attribute (2.14
and older) is still read and valid."""
from __future__ import annotations

import shutil

import h5py
import numpy as np
import pytest

from spacarpy.cli import main
from spacarpy.results import ResultsFormatError, open_results, read_results
from spacarpy.results.header_crc import HEADER_ATTRS, HEADER_CRC_ATTR, header_crc
from spacarpy.results.schema import SCHEMA_VERSION
from spacarpy.results.validate import validate_file


@pytest.fixture
def copy(result_files, tmp_path):
    path = tmp_path / "bend.h5"
    shutil.copyfile(result_files["bend"], path)
    return path


def test_a_new_file_carries_the_checksum_of_its_root_attributes(copy):
    with h5py.File(copy, "r") as f:
        stored = f.attrs[HEADER_CRC_ATTR]
        assert stored.dtype == np.int64 and int(stored) == int(header_crc(f.attrs))
        for name in ("program_version", "created", "deck_text", "schema_version"):
            assert name in f.attrs and name in HEADER_ATTRS
    assert validate_file(copy) == []
    assert open_results(copy).attrs["program_version"]


@pytest.mark.parametrize("name, value", [("program_version", "9.9.9"),
                                         ("created", "2020-01-01T00:00:00+00:00"),
                                         ("deck_path", "/elsewhere/deck.dat"),
                                         # another minor version than the one written
                                         ("schema_version", np.array(
                                             [SCHEMA_VERSION[0], SCHEMA_VERSION[1] + 1],
                                             np.int32))])
def test_a_changed_root_attribute_is_damage(copy, capsys, name, value):
    with h5py.File(copy, "r+") as f:
        f.attrs[name] = value
    problems = validate_file(copy)
    assert any("root attributes are damaged" in p for p in problems), problems
    with pytest.raises(ResultsFormatError, match="root attributes are damaged"):
        open_results(copy)
    with pytest.raises(ResultsFormatError, match="root attributes are damaged"):
        read_results(copy)
    assert open_results(copy, verify=False).attrs[name] is not None
    assert main(["validate", str(copy), "-q"]) == 2
    text = capsys.readouterr()
    assert "root attributes are damaged" in text.out + text.err
    assert "Traceback" not in text.out + text.err


def test_a_removed_or_garbled_checksum(copy):
    with h5py.File(copy, "r+") as f:
        f.attrs[HEADER_CRC_ATTR] = "not a number"
    assert any("root attributes are damaged" in p for p in validate_file(copy))


def test_an_older_file_without_the_checksum_is_read_as_before(copy):
    with h5py.File(copy, "r+") as f:
        del f.attrs[HEADER_CRC_ATTR]
        f.attrs["program_version"] = "0.1"          # unchecked in a 2.14 file
    assert validate_file(copy) == []
    res = open_results(copy)
    assert res.attrs["program_version"] == "0.1"
    assert read_results(copy).static is not None
