"""Check a results file against the schema: :func:`validate_file`, :func:`check_readable`.

This module's one job is validation, generated from :data:`spacarpy.results.schema.DATASETS`:
every dataset the file should have (by group, element kind, schema version and the run's
content) is checked for presence, dtype and shape (named dimensions resolved from the file),
step datasets for their row counts against the group's commit scale, every dataset for its
CF attributes (``units`` as in the table), and the values of every dataset against their
checksums (schema 2.1: ``/<group>/checksum`` per committed step, ``crc32`` of a fixed
dataset), which names the damaged dataset and step. A few facts the table cannot say (unique node
numbers, references to known nodes, value ranges) are checked by hand. Files of schema 1.x
are checked through the same table, by their 1.x names
(:data:`~spacarpy.results.schema.LEGACY_NAMES`).
"""
from __future__ import annotations

import datetime as _dt
import hashlib
import logging
import os
import re

import h5py
import numpy as np

from spacarpy.results.h5file import (
    ResultsFormatError,
    SchemaFile,
    checksum_problems,
    damaged,
    open_for_reading,
    python_value,
    str_list,
)
from spacarpy.results.schema import (
    DATASETS,
    FILETYPE,
    FIXED_DIMS,
    KIND_NAMES,
    LEGACY_OPTIONAL,
    LINEARIZED_GROUPS,
    PROGRAM,
    REACTION_COMPONENTS,
    ROOT_ATTRS,
    SCHEMA_VERSION,
    STEP_GROUPS,
    base_dim,
    n_def,
    n_slots,
    new_name,
    slot_roles,
)
from spacarpy.settings import ANALYSES, DEFORMATION_VARIANTS, ROTARY_CHOICES

log = logging.getLogger(__name__)

__all__ = ["validate_file", "check_readable", "committed_steps"]

_OLDEST_MAJOR = 1
_STEP_AXES = ("step", "time_step", "linearized_step")


def validate_file(path, *, require_complete: bool = False) -> list[str]:
    """Check a results file (schema 1.x or 2.x) against the schema.

    An incomplete run (``completed`` False: the solver failed, the user interrupted, or the
    process was killed) is *not* a problem by itself: a partial file that passes is consistent
    and every committed step in it is readable. Pass ``require_complete=True`` to report it.

    Parameters
    ----------
    path : str or os.PathLike
    require_complete : bool
        Also report a run that did not complete.

    Returns
    -------
    list of str
        One message per problem; empty when the file is valid.
    """
    path = os.fspath(path)
    try:
        with open_for_reading(path) as f:
            problems = _identity_problems(f)
            if problems:
                return problems
            try:
                problems = _layout_problems(f)
                if not problems:
                    problems = checksum_problems(f, committed_steps(f))
            except (OSError, RuntimeError, ValueError, KeyError, TypeError, IndexError,
                    UnicodeDecodeError) as exc:
                return [str(damaged(path, exc))]
            if require_complete and not python_value(f.attrs.get("completed", False)):
                error = python_value(f.attrs.get("error"))
                problems.append("run incomplete: " + (
                    error if error else "the writer did not finish (killed, or still running)"))
            return problems
    except ResultsFormatError as exc:
        return [str(exc)]


def committed_steps(f: h5py.File) -> dict:
    """``{group: number of committed steps}`` of the step groups of an opened file."""
    return {group: f[group][scale].shape[0] for group, scale in STEP_GROUPS.items()
            if isinstance(f.get(f"{group}/{scale}"), h5py.Dataset)}


def check_readable(f: h5py.File, path) -> dict:
    """Refuse a file this version cannot read; return its root attributes as Python values.

    Raises
    ------
    ResultsFormatError
        Not a spacarpy results file, a newer major schema version, or schema violations.
    """
    identity = _identity_problems(f)
    if identity:
        raise ResultsFormatError(f"{path}: {identity[0]}")
    problems = _layout_problems(f)
    if problems:
        raise ResultsFormatError(f"{path}: not a valid spacarpy results file:\n  "
                                 + "\n  ".join(problems))
    attrs = {k: python_value(v) for k, v in f.attrs.items()}
    attrs["schema_version"] = tuple(int(x) for x in attrs["schema_version"])
    if attrs["schema_version"][0] == SCHEMA_VERSION[0] and \
            attrs["schema_version"][1] > SCHEMA_VERSION[1]:
        log.info("%s has schema version %d.%d (newer minor version than %d.%d); content "
                 "this version does not know is ignored", path, *attrs["schema_version"],
                 *SCHEMA_VERSION)
    return attrs


def _identity_problems(f: h5py.File) -> list[str]:
    """File type and schema-version check; a non-empty result stops any further check."""
    filetype = python_value(f.attrs.get("filetype"))
    if filetype != FILETYPE:
        return [f"root attribute filetype is {filetype!r}, expected {FILETYPE!r}: "
                "not a spacarpy results file"]
    version = f.attrs.get("schema_version")
    try:
        major, minor = (int(x) for x in np.asarray(version).reshape(-1))
    except (TypeError, ValueError):
        return [f"root attribute schema_version is {version!r}, expected two integers"]
    if major > SCHEMA_VERSION[0]:
        return [f"schema version {major}.{minor} is newer than schema version "
                f"{SCHEMA_VERSION[0]}.{SCHEMA_VERSION[1]} read by this spacarpy (major {major} > "
                f"{SCHEMA_VERSION[0]}); use a newer spacarpy"]
    if major < _OLDEST_MAJOR:
        return [f"schema version {major}.{minor} is not supported (this spacarpy reads "
                f"{_OLDEST_MAJOR}.x to {SCHEMA_VERSION[0]}.x)"]
    return []


def _layout_problems(f: h5py.File) -> list[str]:
    """All schema violations of an opened file whose identity has been checked."""
    problems: list[str] = []
    sf = SchemaFile(f)
    version = tuple(int(x) for x in np.asarray(f.attrs["schema_version"]).reshape(-1))
    completed = _check_root_attrs(f, problems)
    deck = f.get("deck")
    kinds = sf.element_kinds()
    unknown = [k for k in kinds if k not in KIND_NAMES]
    if unknown:
        problems.append(f"/model/elements has groups of unknown element kinds {unknown}")
    sizes = _sizes(sf, kinds)
    found = {}
    for path, spec in DATASETS.items():
        if spec.kind is not None and spec.kind not in kinds:
            continue
        if spec.group in STEP_GROUPS and spec.group not in f:
            continue
        present = path in sf
        if not present:
            required = not spec.optional and version >= spec.since
            if version[0] < 2 and path in LEGACY_OPTIONAL:
                required = False
            if path.endswith(("max_normal_stress", "max_von_mises_stress")):
                required = sizes["sections"]
            if required:
                problems.append(f"/{sf.name(path)} missing")
            continue
        found[path] = _check_dataset(sf, spec, sizes, problems)
    if deck is not None and found.get("deck") is not None:
        sha = python_value(f.attrs.get("deck_sha256"))
        actual = hashlib.sha256(deck.asstr()[()].encode("utf-8")).hexdigest()
        if isinstance(sha, str) and sha != actual:
            problems.append("root attribute deck_sha256 does not match /deck")
    _check_values(sf, kinds, found, problems)
    _check_steps(sf, found, completed, problems)
    analysis = python_value(f.attrs.get("analysis"))
    for group in STEP_GROUPS:
        if completed and analysis == group and group not in f:
            problems.append(f"completed {group} analysis without a /{group} group")
    _check_cf_attrs(sf, problems)
    return problems


def _sizes(sf: SchemaFile, kinds: list) -> dict:
    """Sizes of the named dimensions, from the file (None where unknown)."""
    def rows(path):
        ds = sf.get(path)
        return ds.shape[0] if isinstance(ds, h5py.Dataset) and ds.shape else None

    n_pos, n_rot = rows("model/position_nodes"), rows("model/orientation_nodes")
    n_warp = rows("model/warping_nodes") or 0
    types = sf.get("model/elements/BEAM/cross_section_type")
    sections = isinstance(types, h5py.Dataset) and types.ndim == 1 and any(str_list(types))
    return {
        "position_node": n_pos, "orientation_node": n_rot, "coordinate": 3,
        "warping_node": n_warp,
        "euler_parameter": 4, "reaction": rows("static/reaction_node"),
        "global_coordinate": (3 * n_pos + 4 * n_rot + n_warp
                              if n_pos is not None and n_rot is not None else None),
        "load": rows("model/load_node"), "input": None, "kinematic": None,
        "line_load": rows("model/line_load_element"),
        "follower_load": rows("model/follower_load_node"),
        "sections": sections,
        "dof": rows("state_space/dof_element"),
        "kinematic_state": (rows("state_space/kinematic_name") or 0
                            if rows("state_space/dof_element") is not None else None),
        "state": (2 * rows("state_space/dof_element")
                  + (rows("state_space/kinematic_name") or 0)
                  if rows("state_space/dof_element") is not None else None),
        "system_input": rows("state_space/input_name"),
        "system_output": rows("state_space/output_name"),
        "element": {k: rows(f"model/elements/{k}/ids") for k in kinds},
    }


def _dim(dim, spec, sizes, sf):
    dim = base_dim(dim)
    if isinstance(dim, int):
        return dim
    if dim in FIXED_DIMS:
        return len(FIXED_DIMS[dim])
    if dim in _STEP_AXES:
        return None
    if dim == "element":
        return sizes["element"].get(spec.kind)
    if dim == "deformation_mode":
        return n_def(spec.kind) if spec.kind in KIND_NAMES else None
    if dim == "slot":
        return n_slots(spec.kind) if spec.kind in KIND_NAMES else None
    if dim == "checked_dataset":
        return None
    if dim == "mode":
        n_mode = python_value(sf.f[spec.group].attrs.get("n_mode"))
        return n_mode if isinstance(n_mode, int) else None
    return sizes[dim]


def _check_dataset(sf, spec, sizes, problems) -> h5py.Dataset | None:
    """Presence, dtype and shape of one dataset; returns it (None: not a dataset)."""
    name = sf.name(spec.path)
    obj = sf.f.get(name)
    if not isinstance(obj, h5py.Dataset):
        problems.append(f"/{name} is not a dataset")
        return None
    dt = obj.dtype
    ok = {"int": np.issubdtype(dt, np.integer), "float": np.issubdtype(dt, np.floating),
          "complex": np.issubdtype(dt, np.complexfloating),
          "ascii": dt.kind == "S", "bool": dt.kind == "b",
          "str": h5py.check_string_dtype(dt) is not None
          or (sf.major < 3 and spec.path != "deck" and dt.kind == "S")}[spec.kind_class] \
        or (spec.path == "model/coordinate_fixed" and dt.kind == "b" and _before_3_1(sf))
    if not ok:
        problems.append(f"/{name} has dtype {dt}, expected {spec.kind_class}")
    shape = tuple(_dim(d, spec, sizes, sf) for d in spec.shape)
    if len(obj.shape) != len(shape) or any(
            want is not None and have != want for have, want in zip(obj.shape, shape)):
        want = tuple("*" if s is None else s for s in shape)
        problems.append(f"/{name} has shape {obj.shape}, expected {want}")
    return obj


def _before_3_1(sf) -> bool:
    """Whether the file's schema is older than 3.1 (``coordinate_fixed`` was an HDF5 bool)."""
    version = tuple(int(x) for x in np.asarray(sf.attrs["schema_version"]).reshape(-1)[:2])
    return version < (3, 1)


def _check_steps(sf, found, completed, problems) -> None:
    """Row counts of the step datasets against their group's commit scale; scales attached."""
    for group, scale_name in STEP_GROUPS.items():
        scale = found.get(f"{group}/{scale_name}")
        if group not in sf.f:
            continue
        if scale is None:
            if f"{group}/{scale_name}" in sf:
                continue
            if group in LINEARIZED_GROUPS:
                n_mode = python_value(sf.f[group].attrs.get("n_mode"))
                if not isinstance(n_mode, int) or n_mode < 1:
                    problems.append(f"/{group} attribute n_mode missing or not a positive "
                                    "integer")
            continue
        n = scale.shape[0]
        attach = group in ("static", "transient")
        if attach and not h5py.h5ds.is_scale(scale.id):
            problems.append(f"/{scale.name.lstrip('/')} is not a dimension scale")
        if not attach:
            n_mode = python_value(sf.f[group].attrs.get("n_mode"))
            if not isinstance(n_mode, int) or n_mode < 1:
                problems.append(f"/{group} attribute n_mode missing or not a positive integer")
            n_static = sf["static/load_factor"].shape[0] if "static/load_factor" in sf else 0
            what = "static steps"
            if group == "state_space" and python_value(
                    sf.f.attrs.get("analysis")) == "transient_linearized":
                n_static = sf["transient/time"].shape[0] if "transient/time" in sf else 0
                what = "time steps"
            values = scale[()]
            if values.size and (values.min() < 0 or values.max() >= n_static):
                problems.append(f"/{group}/step refers to {what} outside "
                                f"0..{n_static - 1}")
        for path, ds in found.items():
            spec = DATASETS[path]
            if ds is None or spec.group != group or path == f"{group}/{scale_name}" \
                    or not spec.shape or spec.shape[0] not in _STEP_AXES:
                continue
            m = ds.shape[0] if ds.shape else 0
            if m != n and (completed or m < n):
                # A partial file may hold one uncommitted step (rows beyond the scale).
                if attach:
                    problems.append(f"{ds.name} has {m} steps but {scale.name} has {n}")
                else:
                    problems.append(f"{ds.name} has {m} rows but {scale.name} has {n}")
            if attach and not h5py.h5ds.is_attached(ds.id, scale.id, 0):
                problems.append(f"{scale.name} is not attached to axis 0 of {ds.name}")


def _check_values(sf, kinds, found, problems) -> None:
    """What the table cannot say: unique numbers, references, value ranges."""
    def values(path):
        ds = found.get(path)
        return ds[()] if ds is not None and ds.size else None

    def ids(path):
        ds = found.get(path)
        return ds[()] if ds is not None else None

    for path in ["model/position_nodes", "model/orientation_nodes", "model/warping_nodes"] + [
            f"model/elements/{k}/ids" for k in kinds]:
        v = ids(path)
        if v is not None and np.unique(v).size != v.size:
            problems.append(f"/{sf.name(path)} has duplicate numbers")
    pos, rot = ids("model/position_nodes"), ids("model/orientation_nodes")
    warp = ids("model/warping_nodes")
    warp = np.zeros(0, np.int64) if warp is None else warp
    for kind in kinds:
        nodes = ids(f"model/elements/{kind}/nodes")
        if nodes is None or pos is None or rot is None or kind not in KIND_NAMES \
                or nodes.ndim != 2 or nodes.shape[1] != n_slots(kind):
            continue
        roles = slot_roles(kind)
        for role, known, what in (("pos", pos, "position"), ("rot", rot, "orientation"),
                                  ("warp", warp, "warping")):
            cols = [j for j, r in enumerate(roles) if r == role]
            unknown = np.setdiff1d(nodes[:, cols], known)
            if cols and unknown.size:
                problems.append(f"/{sf.name(f'model/elements/{kind}/nodes')} refers to unknown "
                                f"{what} nodes {unknown.tolist()}")
    b = "model/elements/BEAM"
    rows, nodes = values(f"{b}/position_rows"), ids(f"{b}/nodes")
    if rows is not None and pos is not None and nodes is not None and nodes.ndim == 2:
        if rows.min() < 0 or rows.max() >= pos.size or rows.shape[0] != nodes.shape[0] \
                or not np.array_equal(pos[rows], nodes[:, [0, 2]]):
            problems.append(f"/{sf.name(b + '/position_rows')} does not match "
                            f"/{sf.name(b + '/nodes')}")
    for path, allowed in ((f"{b}/cross_section_type", {"", "RECT", "CIRC"}),
                          ("model/load_type", {"XF", "DELXF"}),
                          ("model/line_load_type", {"QE", "DELQE", "QEL", "DELQEL"}),
                          ("model/follower_load_type", {"XFL", "DELXFL"}),
                          ("static/reaction_component", set(REACTION_COMPONENTS))):
        if found.get(path) is not None:
            bad = sorted(set(str_list(found[path])) - allowed)
            if bad:
                what = "components" if path.endswith("component") else "values"
                problems.append(f"/{sf.name(path)} has unknown {what} {bad}")
    comp, node = found.get("static/reaction_component"), found.get("static/reaction_node")
    if comp is not None and node is not None and comp.shape[:1] != node.shape[:1]:
        problems.append(f"/static/reaction_component has {comp.shape[0]} entries, "
                        f"/static/reaction_node {node.shape[0]}")
    cls = values(f"{b}/deformation_class")
    if cls is not None and (cls.min() < 0 or cls.max() > 2):
        problems.append(f"/{sf.name(b + '/deformation_class')} has values outside 0..2")
    index = values("model/coordinate_index")
    if index is not None and (index.min() < 1 or index.max() > 4):
        problems.append("/model/coordinate_index has values outside 1..4")
    if pos is not None and rot is not None:
        every = np.concatenate([pos, rot, warp])
        for path in ("model/coordinate_node", "model/load_node"):
            v = values(path)
            if v is not None and np.setdiff1d(v, every).size:
                problems.append(f"/{path} refers to unknown nodes "
                                f"{np.setdiff1d(v, every).tolist()}")


def _check_root_attrs(f: h5py.File, problems: list[str]) -> bool:
    """Check the required root attributes; return ``completed`` (False if missing/bad)."""
    a = {k: python_value(v) for k, v in f.attrs.items()}
    for name in ROOT_ATTRS:
        if name not in a:
            problems.append(f"root attribute {name} missing")
    for name in ("program", "program_version", "created", "deck_path", "deck_sha256",
                 "analysis", "deformations"):
        if name in a and not isinstance(a[name], str):
            problems.append(f"root attribute {name} must be a string, not {a[name]!r}")
    if a.get("program", PROGRAM) != PROGRAM:
        problems.append(f"root attribute program is {a['program']!r}, expected {PROGRAM!r}")
    if isinstance(a.get("created"), str):
        try:
            if _dt.datetime.fromisoformat(a["created"]).tzinfo is None:
                problems.append("root attribute created has no time zone")
        except ValueError:
            problems.append(f"root attribute created is not ISO 8601: {a['created']!r}")
    if isinstance(a.get("deck_sha256"), str) and not re.fullmatch(r"[0-9a-f]{64}",
                                                                   a["deck_sha256"]):
        problems.append("root attribute deck_sha256 is not 64 lowercase hex digits")
    if isinstance(a.get("analysis"), str) and a["analysis"] not in ANALYSES:
        problems.append(f"root attribute analysis is {a['analysis']!r}, expected one of "
                        f"{ANALYSES}")
    if isinstance(a.get("deformations"), str) and a["deformations"] not in DEFORMATION_VARIANTS:
        problems.append(f"root attribute deformations is {a['deformations']!r}, expected one "
                        f"of {DEFORMATION_VARIANTS}")
    if "rotary_inertia" in a and a["rotary_inertia"] not in ROTARY_CHOICES:
        problems.append(f"root attribute rotary_inertia is {a['rotary_inertia']!r}, expected "
                        f"one of {ROTARY_CHOICES}")
    completed = a.get("completed")
    if "completed" in a and not isinstance(completed, bool):
        problems.append(f"root attribute completed must be a boolean, not {completed!r}")
        completed = False
    if "error" in a:
        if not isinstance(a["error"], str):
            problems.append("root attribute error must be a string")
        if completed:
            problems.append("root attribute error is set on a completed run")
    return bool(completed)


def _check_cf_attrs(sf: SchemaFile, problems: list[str]) -> None:
    """Every dataset needs ``units`` and ``long_name``; schema datasets the table's units."""
    def visit(name, obj):
        if not isinstance(obj, h5py.Dataset):
            return
        for attr in ("units", "long_name"):
            value = python_value(obj.attrs.get(attr))
            if not isinstance(value, str) or not value:
                problems.append(f"/{name} has no {attr} attribute")
        # 1.x units are checked for the datasets that kept their name (some 1.4 files carry
        # older units on the moved per-kind datasets)
        spec = DATASETS.get(name) if sf.major >= 2 or new_name(name) == name else None
        units = python_value(obj.attrs.get("units"))
        if spec is not None and isinstance(units, str) and units != spec.units_in(sf.major):
            problems.append(f"/{name} has units {units!r}, expected "
                            f"{spec.units_in(sf.major)!r}")
        if sf.major >= 3 and not h5py.h5ds.is_scale(obj.id):   # netCDF-4: every axis named
            bare = [k for k in range(obj.ndim) if h5py.h5ds.get_num_scales(obj.id, k) < 1]
            if bare:
                problems.append(f"/{name} has no dimension scale on axis "
                                f"{', '.join(map(str, bare))}")
    sf.f.visititems(visit)
