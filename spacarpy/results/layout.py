"""The layout of a new results file: its root attributes and ``/model`` datasets, and the
empty step groups (``/static``, ``/transient``, ``/eigen`` ...) made from the schema.

This module's one job is creating what :class:`~spacarpy.results.writer.ResultsWriter`
then appends to: :func:`write_header` at the start of a run, :func:`create_step_group` once
per step group before the file switches to SWMR mode. The writer decides which groups and
sizes a run has; appending and the commit protocol stay in the writer and
:mod:`spacarpy.results.steps`.
"""
from __future__ import annotations

import datetime as _dt
import hashlib
import os

import h5py
import numpy as np

from spacarpy.model import Model
from spacarpy.results import h5file
from spacarpy.results.dims import add_dimensions
from spacarpy.results.h5file import create, set_index_units
from spacarpy.results.header_crc import HEADER_CRC_ATTR, header_crc
from spacarpy.results.schema import (
    CRITICAL_POINT_NAMES,
    DATASETS,
    DEFORMATION_CLASS_NAMES,
    FILETYPE,
    MODE_KIND_NAMES,
    PROGRAM,
    SCHEMA_VERSION,
)
from spacarpy.results.steps import StepAppender, create_extendable

__all__ = ["create_step_group", "write_header", "string_dataset", "add_dimensions"]

_COLUMNS = {"stiffness": "EA GJ EIy EIz cy cz", "mass": "rhoA rho(Iy+Iz) rhoIy rhoIz rhoIyz"}


def create_step_group(f: h5py.File, group: str, specs, size, n_mode: int = 0) -> dict:
    """Create the step group ``group`` with its empty extendable datasets, their dimension
    labels and scales, and the checksum dataset; return the writer's entry for it (the
    datasets, their row shapes and dtypes, the :class:`StepAppender`).

    ``specs`` are the schema's ``(path, spec)`` pairs the file has for this group, ``size``
    gives the length of a named dimension: ``size(dim, kind)``.
    """
    g = f.create_group(group)
    scale_name = {"static": "load_factor", "transient": "time"}.get(group, "step")
    entry = {"datasets": {}, "shapes": {}, "dtypes": {}, "n": 0}
    lin = scale_name == "step"
    if lin:
        g.attrs["n_mode"] = np.int32(n_mode)
    for path, spec in specs:
        name = path[len(group) + 1:]
        if name.endswith("checksum"):
            continue
        trailing = tuple(size(d, spec.kind) for d in spec.shape[1:])
        parent = g.require_group(name.rsplit("/", 1)[0]) if "/" in name else g
        ds = create_extendable(parent, name.rsplit("/", 1)[-1], trailing,
                               np.dtype(spec.dtype))
        if name == scale_name:
            scale_label = spec.shape[0]
            if not lin:
                ds.make_scale(name)
            _label(ds, 0, scale_label)
            entry["scale"] = ds
            continue
        _label(ds, 0, spec.shape[0])
        if name == "kind":
            ds.attrs["kind_names"] = ", ".join(MODE_KIND_NAMES)
        if name == "point_type":
            ds.attrs["type_names"] = ", ".join(CRITICAL_POINT_NAMES)
        entry["datasets"][name] = ds
        entry["shapes"][name] = trailing
        entry["dtypes"][name] = np.dtype(spec.dtype)
    columns = [h5file.SCALE_COLUMN] + list(entry["datasets"])
    # schema 3.0: in a group of its own, beside the data (netCDF readers list it apart)
    checksum = create_extendable(g.create_group("integrity"), "checksum", (len(columns),),
                                 np.dtype("i8"))
    checksum.attrs["columns"] = " ".join(columns)
    _label(checksum, 0, scale_label)
    entry["checksum"] = (checksum, columns)
    entry["appender"] = StepAppender(f, entry["datasets"], entry["scale"],
                                     entry["checksum"])
    entry["rows"] = [(name, entry["dtypes"][name], entry["shapes"][name])
                     for name in entry["datasets"]]
    if not lin:                 # the scales are attached by dims.add_dimensions
        for name, ds in [*entry["datasets"].items(), ("integrity/checksum", checksum)]:
            spec = DATASETS[f"{group}/{name}"]
            for axis, label in enumerate(spec.shape[1:], start=1):
                if isinstance(label, str):
                    _label(ds, axis, label)
    entry["names"] = {"datasets": {n: ds.name for n, ds in entry["datasets"].items()},
                      "scale": entry["scale"].name, "checksum": checksum.name}
    return entry


def bind_step_group(entry: dict, f: h5py.File) -> None:
    """Point the writer's ``entry`` of a step group (:func:`create_step_group`), made in
    another file object of the same content, at the datasets of ``f``; the names were kept
    in ``entry["names"]`` when it was made."""
    names = entry["names"]
    entry["datasets"] = {name: f[path] for name, path in names["datasets"].items()}
    entry["scale"] = f[names["scale"]]
    entry["checksum"] = (f[names["checksum"]], entry["checksum"][1])
    entry["appender"] = StepAppender(f, entry["datasets"], entry["scale"], entry["checksum"])


def write_header(f: h5py.File, model: Model, model_data: dict, *, program_version: str,
                 analysis: str, deformations: str, rotary_inertia: str | None) -> None:
    """The root attributes (``completed = False`` first), ``/deck`` and the ``/model``
    datasets of ``model_data`` (each checked against the schema)."""
    text = model.source_text or ""
    a = f.attrs
    a["completed"] = np.bool_(False)    # first, so that any partial file says "incomplete"
    a["filetype"] = FILETYPE
    a["schema_version"] = np.array(SCHEMA_VERSION, dtype=np.int32)
    a["program"] = PROGRAM
    a["program_version"] = program_version
    a["created"] = _dt.datetime.now().astimezone().isoformat(timespec="seconds")
    a["deck_path"] = _absolute_deck_path(model.source_path)
    a["deck_sha256"] = hashlib.sha256(text.encode("utf-8")).hexdigest()
    a["deck_text"] = text    # also here, so the run is identified from the root alone
    a["analysis"] = analysis
    a["deformations"] = deformations
    if rotary_inertia is not None:
        a["rotary_inertia"] = rotary_inertia
    a[HEADER_CRC_ATTR] = header_crc(a)  # of the values as read back (schema 2.18)
    create(f, "deck", text, dtype=h5py.string_dtype("utf-8"))
    for path, value in model_data.items():
        if path not in DATASETS:
            raise ValueError(f"model data {path!r} is not a dataset of the schema")
        value, dtype = np.asarray(value), None
        if value.dtype.kind in "SU":        # UTF-8 strings of variable length (3.0)
            value = np.array([v.decode("utf-8") if isinstance(v, bytes) else str(v)
                              for v in value.reshape(-1).tolist()], dtype=object)
            dtype = h5py.string_dtype("utf-8")
        parent, name = path.rsplit("/", 1)
        ds = create(f.require_group(parent), name, value, dtype=dtype)
        what = name
        if what == "deformation_class":
            ds.attrs["class_names"] = ", ".join(DEFORMATION_CLASS_NAMES)
        elif what in _COLUMNS and path.startswith("model/elements/BEAM/"):
            ds.attrs["columns"] = _COLUMNS[what]
    if "model/load_value" in f:             # N on a position node, N m on an orientation one
        rot = set(np.asarray(model_data.get("model/orientation_nodes", [])).tolist())
        set_index_units(f["model/load_value"],
                        ["N m" if n in rot else "N" for n in
                         np.asarray(model_data["model/load_node"]).tolist()], ("load",))
    if "model/follower_load_value" in f:    # the same, by the loaded node (not the axes node)
        rot = set(np.asarray(model_data.get("model/orientation_nodes", [])).tolist())
        set_index_units(f["model/follower_load_value"],
                        ["N m" if n in rot else "N" for n in
                         np.asarray(model_data["model/follower_load_node"])[:, 0].tolist()],
                        ("follower_load",))
    add_dimensions(f, "model", model_data)


def string_dataset(group: h5py.Group, name: str, strings) -> h5py.Dataset:
    """A fixed dataset of UTF-8 strings of variable length (schema 3.0)."""
    return create(group, name, np.array([str(s) for s in strings], dtype=object),
                  dtype=h5py.string_dtype("utf-8"))


def _absolute_deck_path(source_path: str) -> str:
    """Absolute deck path; pseudo names such as ``<model>`` or ``<string>`` are kept."""
    source_path = str(source_path)
    if source_path.startswith("<"):
        return source_path
    return os.path.abspath(source_path)


def _label(ds: h5py.Dataset, axis: int, label: str) -> None:
    """``ds.dims[axis].label = label`` without h5py's dimension proxies (which ask HDF5 for
    the rank and the scales first: 50 us a label, about 40 labels in a static run)."""
    h5py.h5ds.set_label(ds.id, axis, label.encode())


def state_space_values(ss, k: int) -> dict:
    """The datasets of one /state_space step from ``ss`` (attributes M0, C0, K0, B0, A, B, C,
    D, and K0p, G, Gq, Gp where the model has ``k`` kinematic coordinates; zero-sized
    otherwise) and the poles, the eigenvalues of A sorted by real, then imaginary part
    (schema 2.13), with their error bounds (schema 2.20; NaN where ``ss`` has none)."""
    values = {name: getattr(ss, name) for name in ("M0", "C0", "K0", "B0", "A", "B", "C", "D")}
    n = np.shape(ss.M0)[0]
    for name, shape in (("K0p", (n, k)), ("G", (k, n)), ("Gq", (k, n)), ("Gp", (k, k))):
        values[name] = getattr(ss, name, np.zeros(shape))
    lam = getattr(ss, "pole", None)         # refined (solvers/linear/refine.py)
    bound = getattr(ss, "pole_bound", None)
    if lam is None:
        lam = np.linalg.eigvals(ss.A) if np.size(ss.A) else np.zeros(0, complex)
    lam = np.asarray(lam, complex)
    bound = np.full(lam.shape, np.nan) if bound is None else np.asarray(bound, float)
    order = np.lexsort((lam.imag, lam.real))
    values["pole"], values["pole_bound"] = lam[order], bound[order]
    return values
