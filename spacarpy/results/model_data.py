"""The ``/model`` datasets of a results file, prepared from a :class:`~spacarpy.model.Model`.

This module's one job is turning the analysed model into the arrays the writer stores under
``/model`` (2.0 names, see :mod:`spacarpy.results.schema`): nodes, the element sets per kind
(``/model/elements/<KIND>/...``), the BEAM element properties and cross-sections, the loads
and the map of global coordinates (from :class:`spacarpy.numbering.Numbering`). The writer
receives these arrays and computes nothing itself. The line and follower loads' arrays come
from :mod:`spacarpy.results.model_loads`.
"""
from __future__ import annotations

import numpy as np

from spacarpy.model import ElementSet, Model
from spacarpy.results.model_loads import load_datasets
from spacarpy.results.schema import KIND_NAMES

__all__ = ["element_sets", "model_datasets"]


def element_sets(model: Model) -> dict:
    """The model's element sets by kind keyword, each with ``ids`` (n,) and ``nodes``
    (n, n_slots): BEAM always (possibly empty), the other kinds when the model has them.

    The one place that knows where a model keeps its elements."""
    sets = {"BEAM": model.elements.get("BEAM") or ElementSet.empty("BEAM")}
    for kind, es in sorted(model.elements.items()):
        if es.n_elem and kind in KIND_NAMES and kind != "BEAM":
            sets[kind] = es
    return sets


def model_datasets(model: Model, num=None) -> dict:
    """Every ``/model`` dataset of ``model``, by path relative to the root (2.0 names).

    Parameters
    ----------
    model : spacarpy.model.Model
    num : spacarpy.numbering.Numbering, optional
        The model's numbering (computed when not given).

    Returns
    -------
    dict of str -> numpy.ndarray
        Values exactly as stored; ASCII strings as ``S`` arrays.
    """
    if num is None:
        from spacarpy.numbering import number_model
        num = number_model(model)
    sets = element_sets(model)
    beams = sets["BEAM"]
    n = beams.n_elem
    out = {
        "model/position_nodes": np.asarray(model.position_ids, dtype=np.int64),
        "model/position_x0": np.asarray(model.position_x0, dtype=np.float64).reshape(-1, 3),
        "model/orientation_nodes": np.asarray(model.orientation_ids, dtype=np.int64),
    }
    if model.warping_ids.size:
        out["model/warping_nodes"] = np.asarray(model.warping_ids, dtype=np.int64)
    b = "model/elements/BEAM"
    group = num.group("BEAM")
    idx = group.idx if group is not None else np.zeros((0, 14), np.int64)
    if group is not None:
        l0, axes = group.ref.l0, np.stack([group.ref.nx, group.ref.ny, group.ref.nz], axis=1)
    else:
        l0, axes = np.zeros(0), np.zeros((0, 3, 3))
    row_of = np.full(num.n_coord, -1, dtype=np.int64)
    row_of[num.pos_idx[:, 0]] = np.arange(num.pos_idx.shape[0])
    if model.cross_sections is not None:
        shape, dims = model.cross_sections.arrays(beams.ids)
    else:
        shape, dims = np.full(n, "", dtype="<U4"), np.full((n, 2), np.nan)
    out.update({
        f"{b}/ids": np.asarray(beams.ids, dtype=np.int64),
        f"{b}/nodes": np.asarray(beams.nodes, dtype=np.int64).reshape(-1, 4),
        f"{b}/position_rows": row_of[idx[:, [0, 7]]].reshape(n, 2),
        f"{b}/length": np.asarray(l0, dtype=np.float64),
        f"{b}/axes": axes.reshape(n, 3, 3),
        f"{b}/deformation_class": beams.def_class.astype(np.int8),
        f"{b}/stiffness": beams.stiffness.astype(np.float64),
        f"{b}/mass": beams.mass.astype(np.float64),
        f"{b}/cross_section_type": np.char.encode(shape, "ascii").astype("S4"),
        f"{b}/cross_section_dims": dims.astype(np.float64),
    })
    for kind, es in sets.items():
        if kind != "BEAM":
            out[f"model/elements/{kind}/ids"] = np.asarray(es.ids, dtype=np.int64)
            out[f"model/elements/{kind}/nodes"] = np.asarray(es.nodes, dtype=np.int64)
    if model.prescribed_deformations:
        out["model/input_deformation"] = np.array(
            [[pd.element, pd.mode] for pd in model.prescribed_deformations], dtype=np.int64)
    for keyword, name in (("KINE", "deformation"), ("KINX", "coordinate")):
        rows = [[k.target, k.number] for k in model.kinematic if k.keyword == keyword]
        if rows:
            out[f"model/kinematic_{name}"] = np.array(rows, dtype=np.int64)
    loads = list(model.loads)
    out["model/load_node"] = np.array([ld.node for ld in loads], dtype=np.int64)
    out["model/load_type"] = np.array([ld.kind.encode("ascii") for ld in loads], dtype="S5")
    out["model/load_value"] = np.array([ld.value for ld in loads],
                                       dtype=np.float64).reshape(len(loads), 3)
    out.update(load_datasets(model))
    index = np.zeros(num.n_coord, dtype=np.int8)
    index[num.pos_idx] = np.arange(1, 4, dtype=np.int8)
    index[num.rot_idx] = np.arange(1, 5, dtype=np.int8)
    index[num.warp_idx] = 1
    out["model/coordinate_node"] = num.node_of_coord(model)
    out["model/coordinate_index"] = index
    out["model/coordinate_fixed"] = num.fixed_mask.astype(np.int8)   # bool before 3.1
    return out
