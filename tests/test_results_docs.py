"""docs/results.md documents exactly the schema table, and the files hold exactly its datasets.

The dataset tables of docs/results.md are the rows :func:`schema_rows` renders from
:data:`spacarpy.results.schema.DATASETS` (path, dtype, shape, units, meaning): every row must
be there as rendered, and no other dataset row. Every dataset path of every representative file
the test suite writes (static, static with cross-sections, linearized groups with compliance,
transient runs of every element kind, a failed run, a killed run) must be in the table, and
every dataset of the table must occur in one of those files. Run this module as a script to
print the rendered rows.
"""
from __future__ import annotations

import re
import signal
from pathlib import Path

import h5py

from spacarpy.results.schema import DATASETS, FIXED_DIMS, base_dim, n_def, n_slots

from helpers import run_and_kill

DOC = Path(__file__).resolve().parents[1] / "docs" / "results.md"

_DTYPES = {"f8": "float64", "c16": "complex128", "i8": "int64", "i4": "int32", "i1": "int8",
           "?": "bool",
           "ascii": "fixed-length ASCII string", "utf-8": "variable-length UTF-8 string"}
_SYMBOLS = {"step": "n_step", "time_step": "n_t", "linearized_step": "n_lin",
            "mode": "n_mode", "position_node": "n_pos", "orientation_node": "n_rot",
            "warping_node": "n_warp",
            "reaction": "n_reac", "coordinate": "3", "euler_parameter": "4",
            "global_coordinate": "n_coord", "load": "n_load", "input": "n_input",
            "line_load": "n_line_load", "follower_load": "n_follower_load",
            "kinematic": "n_kinematic", "kinematic_state": "n_kin",
            "checked_dataset": "n_checked", "dof": "n_dof", "state": "n_state",
            "system_input": "n_in", "system_output": "n_out"}


def _shape(spec) -> str:
    dims = []
    for d in map(base_dim, spec.shape):
        if isinstance(d, int):
            dims.append(str(d))
        elif d in FIXED_DIMS:
            dims.append(str(len(FIXED_DIMS[d])))
            dims.append(str(d))
        elif d == "element":
            dims.append("n_elem" if spec.kind == "BEAM" else f"n_{spec.kind.lower()}")
        elif d == "deformation_mode":
            dims.append(str(n_def(spec.kind)))
        elif d == "slot":
            dims.append(str(n_slots(spec.kind)))
        else:
            dims.append(_SYMBOLS[d])
    return "`()` (scalar)" if not dims else f"`({', '.join(dims)}{',' * (len(dims) == 1)})`"


def schema_rows() -> list[tuple[str, str]]:
    """(path, markdown row) of every dataset of the schema, in table order."""
    out = []
    for path, spec in DATASETS.items():
        units = spec.units.replace("|", "\\|")
        since = f" (since {spec.since[0]}.{spec.since[1]})" if spec.since > (1, 0) else ""
        out.append((f"/{path}", f"| `/{path}` | {_DTYPES[spec.dtype]} | {_shape(spec)} | "
                                f"`{units}` | {spec.long_name}{since} |"))
    return out


def documented_rows() -> dict:
    """Rows of the dataset tables, by path: ``| `/group/name` | ...`` lines of the section
    ``## Datasets``."""
    text = DOC.read_text(encoding="utf-8")
    section = text[text.index("\n## Datasets"):text.index("\n## How a file is written")]
    rows = {}
    for line in section.splitlines():
        m = re.match(r"\|\s*`(/[A-Za-z0-9_/]+)`\s*\|", line)
        if m:
            rows[m.group(1)] = line
    return rows


def documented_dimensions() -> set:
    """Names of the dimension scales in the table of section ``### Dimensions``."""
    text = DOC.read_text(encoding="utf-8")
    section = text[text.index("\n### Dimensions"):]
    section = section[:section.index("\n## ", 1)]
    return {m.group(1) for line in section.splitlines()
            for m in [re.match(r"\|\s*`([A-Za-z0-9_]+)`\s*\|", line)] if m}


def written_paths(path, scales: set | None = None) -> set:
    """Paths of the datasets of a file; the dimension scales that are no schema dataset
    (schema 3.0, results/dims.py) go to ``scales`` (their names) instead."""
    out = set()

    def visit(name, obj):
        if not isinstance(obj, h5py.Dataset):
            return
        if name not in DATASETS and h5py.h5ds.is_scale(obj.id) and scales is not None:
            scales.add(name.rsplit("/", 1)[-1])
        else:
            out.add("/" + name)
    with h5py.File(path, "r", swmr=True) as f:
        f.visititems(visit)
    return out


def test_documented_rows_are_the_schema_table():
    documented = documented_rows()
    rendered = dict(schema_rows())
    assert set(documented) == set(rendered)
    for path, row in rendered.items():
        assert documented[path] == row, path


def test_written_paths_are_the_schema_table(tmp_path, result_files):
    files = dict(result_files)
    if hasattr(signal, "SIGKILL"):
        run_and_kill(tmp_path, n_elem=2, pause=0.02)
        files["killed"] = tmp_path / "killed.partial.h5"
    scales = set()
    written = set().union(*(written_paths(p, scales) for p in files.values()))
    table = {"/" + p for p in DATASETS}
    assert written - table == set(), "written but not in the schema"
    assert table - written == set(), "in the schema but written by no test file"
    assert scales == documented_dimensions(), "dimension scales written vs documented"


if __name__ == "__main__":
    print("\n".join(row for _, row in schema_rows()))


def test_the_page_states_the_current_schema_version():
    """The title, the 'SCHEMA_VERSION = ...' sentence and the root-attribute table give the
    version files are written with (report N12: the page said (2, 3) beside a 2.6 title),
    and no other (major, minor) pair is named as the current one."""
    import re

    from spacarpy.results.schema import SCHEMA_VERSION
    major, minor = SCHEMA_VERSION
    text = DOC.read_text()
    assert text.splitlines()[0] == f"# Results file format (schema version {major}.{minor})"
    assert f"`SCHEMA_VERSION = ({major}, {minor})` and this page change together" in text
    row = next(line for line in text.splitlines() if line.startswith("| `schema_version`"))
    assert f"`({major}, {minor})`" in row
    assert re.findall(r"SCHEMA_VERSION = \((\d+), (\d+)\)", text) == [(str(major), str(minor))]
