"""docs/results.md documents exactly the datasets the writer produces.

Every dataset path of every representative file the test suite writes (static, static with
cross-sections, linearized groups with compliance, a failed run, a killed run) must be in a
table row of docs/results.md, and every documented path must occur in one of those files and in
the writer's table of units.
"""
from __future__ import annotations

import re
import signal
from pathlib import Path

import h5py

from spacarpy.results.hdf5 import DATASET_ATTRS

from helpers import run_and_kill

DOC = Path(__file__).resolve().parents[1] / "docs" / "results.md"


def documented_paths() -> set:
    """Dataset paths in the first column of the schema tables: ``| `/group/name` | ...``."""
    paths = set()
    for line in DOC.read_text(encoding="utf-8").splitlines():
        m = re.match(r"\|\s*`(/[a-z0-9_/]+)`\s*\|", line)
        if m:
            paths.add(m.group(1))
    return paths


def written_paths(path) -> set:
    out = set()
    with h5py.File(path, "r", swmr=True) as f:
        f.visititems(lambda name, obj: out.add("/" + name)
                     if isinstance(obj, h5py.Dataset) else None)
    return out


def test_documented_paths_equal_written_paths(tmp_path, result_files):
    files = dict(result_files)
    if hasattr(signal, "SIGKILL"):
        run_and_kill(tmp_path, n_elem=2, pause=0.02)
        files["killed"] = tmp_path / "killed.partial.h5"
    written = set().union(*(written_paths(p) for p in files.values()))
    documented = documented_paths()
    assert written - documented == set(), "written but not documented"
    assert documented - written == set(), "documented but written by no test file"
    assert documented == {"/" + k for k in DATASET_ATTRS}


def test_documented_units_match_the_writer():
    text = DOC.read_text(encoding="utf-8")
    for name, (units, _) in DATASET_ATTRS.items():
        row = next(line for line in text.splitlines() if line.startswith(f"| `/{name}`"))
        cells = [c.strip().replace("\\|", "|") for c in re.split(r"(?<!\\)\|", row)[1:-1]]
        assert f"`{units}`" in cells or (units.startswith("m/N") and "same" in cells), name
