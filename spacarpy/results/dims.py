"""The netCDF-4 dimensions of a results file: a dimension scale on every axis (schema 3.0).

This module's one job is naming the axes so that netCDF readers (netCDF-C's ``ncdump``,
netCDF4-python, xarray with either engine) open every group: :func:`add_dimensions` gives
every axis of every dataset of a group a dimension scale, as netCDF-4 writes them.

- Axis 0 of a step dataset is its group's commit scale: ``load_factor`` (``/static``),
  ``time`` (``/transient``) or ``step`` (the linearized groups and ``/critical``).
- The other axes get a *coordinate variable* of the dimension's name in the dataset's
  top-level group (``/model``, ``/static`` ...), or in its element kind's group for the
  per-kind dimensions ``element``, ``deformation_mode`` and ``slot``: the deck numbers of
  the nodes (``position_node``, ``orientation_node``, ``warping_node``) and elements
  (``element``), the labels of a fixed dimension (:data:`~.schema.FIXED_DIMS`, e.g.
  ``coordinate`` = x, y, z), the slot roles, the checksum's columns (``checked_dataset``
  in ``/<group>/integrity``) and else the 1-based numbers (``mode``, ``deformation_mode``,
  ``reaction_number`` ...).

A dimension is made once per group and every dataset of the group that has it uses it, so
names and lengths agree within a group. Each scale carries ``units``, ``long_name`` and
the ``crc32`` of its values, as every fixed dataset.
"""
from __future__ import annotations

import h5py
import numpy as np

from spacarpy.elements.registry import KINDS
from spacarpy.results.h5file import CRC_ATTR, crc32, new_attrs
from spacarpy.results.schema import DATASETS, FIXED_DIMS, STEP_GROUPS

__all__ = ["add_dimensions", "NC_NAMES", "dimension_name"]

#: netCDF dimension names of the schema's dimensions where they differ (``reaction`` is a
#: dataset of /static, so its dimension is ``reaction_number``).
NC_NAMES = {"reaction": "reaction_number"}
_STEP_AXES = ("step", "time_step", "linearized_step")
_KIND_DIMS = ("element", "deformation_mode", "slot")
_NODE_IDS = {"position_node": "model/position_nodes",
             "orientation_node": "model/orientation_nodes",
             "warping_node": "model/warping_nodes"}
_LONG_NAMES = {
    "position_node": "deck number of each position node",
    "orientation_node": "deck number of each orientation node",
    "warping_node": "deck number of each warping node",
    "element": "deck number of each element of the group's kind",
    "deformation_mode": "deformation mode number (1-based)",
    "slot": "node slot of the element kind (its role: p, r, q, s ...)",
    "mode": "mode number (1-based, lowest first)",
    "checked_dataset": "dataset covered by each column of the checksum ((scale): the "
                       "group's commit scale)",
}


def dimension_name(dim: str) -> str:
    """The netCDF dimension name of the schema dimension ``dim`` (not a step axis)."""
    return NC_NAMES.get(dim, dim)


def add_dimensions(f: h5py.File, top: str, model_data: dict) -> None:
    """Attach a dimension scale to every axis of every schema dataset under ``/top``
    (creating the scales; the group's commit scale becomes one), before the file goes to
    SWMR mode. ``model_data`` gives the deck numbers of nodes and elements. Raises
    ``ValueError`` where two datasets of a group disagree on a dimension's length."""
    group = f[top]
    commit = group.get(STEP_GROUPS.get(top, ""))
    if isinstance(commit, h5py.Dataset) and not h5py.h5ds.is_scale(commit.id):
        commit.make_scale(commit.name.rsplit("/", 1)[-1])
    datasets = []
    group.visititems(lambda name, obj: datasets.append(obj)
                     if isinstance(obj, h5py.Dataset) else None)
    for ds in datasets:
        spec = DATASETS.get(ds.name.lstrip("/"))
        if spec is None or ds is commit or h5py.h5ds.is_scale(ds.id):
            continue
        for axis, dim in enumerate(spec.shape):
            if dim in _STEP_AXES:
                scale = commit
            else:
                scale = _scale(f, top, spec, dim, ds, axis, model_data)
            h5py.h5ds.attach_scale(ds.id, scale.id, axis)


def _scale(f, top, spec, dim, ds, axis, model_data) -> h5py.Dataset:
    """The scale of dimension ``dim`` (axis ``axis`` of ``ds``), made at first use."""
    if dim == "checked_dataset":
        host = f[ds.parent.name]
    elif dim in _KIND_DIMS:
        host = f[f"{top}/elements/{spec.kind}"]
    else:
        host = f[top]
    name = dimension_name(dim)
    n = ds.shape[axis]
    scale = host.get(name)
    if scale is None:
        values = _values(dim, n, spec, ds, model_data)
        dtype = h5py.string_dtype("utf-8") if values.dtype.kind in "OU" else None
        if dtype is not None:
            values = np.array([str(v) for v in values], dtype=object)
        scale = host.create_dataset(name, data=values, dtype=dtype)
        new_attrs(scale, {"units": "1",
                          "long_name": _LONG_NAMES.get(dim, _long_name(dim)),
                          CRC_ATTR: np.int64(crc32(scale[()]))})
        scale.make_scale(name)
    if scale.shape != (n,):
        raise ValueError(f"dimension {name} of {host.name} has length {scale.shape[0]}, "
                         f"but axis {axis} of {ds.name} has {n}")
    return scale


def _long_name(dim: str) -> str:
    if dim in FIXED_DIMS:
        return f"label of each {dim.replace('_', ' ')}: {', '.join(FIXED_DIMS[dim])}"
    return f"number of each {dim.replace('_', ' ')} (1-based)"


def _values(dim, n, spec, ds, model_data) -> np.ndarray:
    """The values of a new scale of length ``n``."""
    if dim in _NODE_IDS:
        values = np.asarray(model_data.get(_NODE_IDS[dim], np.zeros(0, np.int64)))
    elif dim == "element":
        values = np.asarray(model_data[f"model/elements/{spec.kind}/ids"])
    elif dim in FIXED_DIMS:
        values = np.array(FIXED_DIMS[dim], dtype=object)
    elif dim == "slot":
        values = np.array(KINDS[spec.kind].node_roles, dtype=object)
    elif dim == "checked_dataset":
        values = np.array(str(ds.attrs["columns"]).split(), dtype=object)
    else:
        values = np.arange(1, n + 1, dtype=np.int32)
    if values.shape != (n,):
        raise ValueError(f"dimension {dimension_name(dim)}: {values.shape[0]} values, but "
                         f"axis of {ds.name} has {n}")
    return values
