"""Files for ParaView and other visualization tools: an XDMF sidecar and VTK (.vtu/.pvd).

This module's one job is exporting results to visualization formats.

XDMF (:func:`write_xdmf`) writes a small XML file (XDMF 3, written with the standard library)
that *points into* the results file, so no data is copied: ParaView opens the ``.xdmf`` and
reads the HDF5 datasets directly. The layout follows meshio's XDMF time series:

- one ``Grid CollectionType="Temporal"`` named ``static`` with one uniform grid per committed
  load step, its ``Time`` the load factor (the step number if the load factors do not
  increase strictly);
- beams as ``Polyline`` cells with 2 nodes (p, q) from ``/model/elements/BEAM/position_rows``;
- node coordinates = the positions of the step (``HyperSlab`` of ``/static/position``);
- node attributes ``displacement`` (vector: position minus ``/model/position_x0``, an XDMF
  ``Function``), and at linearized steps ``eigenmode_<j>`` / ``buckling_mode_<j>`` (vectors);
- cell attributes ``normal_force`` (sigma_1, N) and ``sigma2`` ... ``sigma6`` (the other
  generalized stress resultants, N; torque and end moments are these times the element
  length), plus ``max_normal_stress`` and ``max_von_mises_stress`` (Pa) when the file has them.

References are ``<file>.h5:/path``, relative to the ``.xdmf`` file. A partial file whose writer
was killed keeps HDF5's "open for SWMR write" mark, which other HDF5 readers refuse; for such
a file the committed steps are first copied to ``<name>.xdmf.h5`` next to the XDMF file, and
the XDMF file points there.

VTK (:func:`write_vtk`) writes one ``.vtu`` file per step and a ``.pvd`` collection with
meshio (the optional ``vtk`` extra).
"""
from __future__ import annotations

import logging
import os
import xml.etree.ElementTree as ET
from pathlib import Path

import h5py
import numpy as np

from spacarpy.errors import EXIT_INPUT, SpacarError
from spacarpy.results.reader import ResultsFile, open_results
from spacarpy.results.stress import section_forces

log = logging.getLogger(__name__)

__all__ = ["write_xdmf", "write_vtk", "ExportUnavailableError"]


class ExportUnavailableError(SpacarError):
    """An optional package needed for an export is not installed."""

    exit_code = EXIT_INPUT


def _needs_swmr_read(path) -> bool:
    """True when a plain read-only open is refused (the writer was killed or still runs)."""
    try:
        with h5py.File(path, "r"):
            return False
    except OSError:
        return True


def _copy_committed(res: ResultsFile, target: Path) -> None:
    """Copy what the XDMF file references, committed steps only, into ``target``."""
    with res._file() as src, h5py.File(target, "w", libver=("v110", "v110")) as dst:
        n_step = src["static/load_factor"].shape[0] if "static" in src else 0
        for name in ("model/position_x0", "model/elements/BEAM/position_rows",
                     "static/load_factor", "static/position",
                     "static/elements/BEAM/stress_resultant",
                     "static/elements/BEAM/max_normal_stress",
                     "static/elements/BEAM/max_von_mises_stress"):
            if res._has(name):
                real = res._name(name)
                data = src[real][()] if name.startswith("model") else src[real][:n_step]
                dst.create_dataset(real, data=data)
        if not res._has("model/elements/BEAM/position_rows"):
            dst.create_dataset(res._name("model/elements/BEAM/position_rows"),
                               data=res.model.element_position_rows)
        for group in ("eigen", "buckling"):
            if group in src:
                n_lin = src[f"{group}/step"].shape[0]
                for name in ("step", "shape_position"):
                    dst.create_dataset(f"{group}/{name}", data=src[f"{group}/{name}"][:n_lin])
        dst.attrs["note"] = (f"committed steps of {res.path}, copied for the XDMF file: the "
                             "original keeps the SWMR-write mark of a killed writer")


def write_xdmf(path, out=None) -> Path:
    """Write an XDMF 3 sidecar for the results file ``path``.

    Parameters
    ----------
    path : str or os.PathLike
        Results file (complete or partial).
    out : str or os.PathLike, optional
        The XDMF file; default: ``path`` with the suffix ``.xdmf``.

    Returns
    -------
    pathlib.Path
        The XDMF file written.
    """
    path = Path(path)
    out = Path(out) if out is not None else path.with_suffix(".xdmf")
    res = open_results(path)
    if res.static is None:
        raise SpacarError(f"{path} has no static load steps: nothing to export")
    data_file = path
    if _needs_swmr_read(path):
        data_file = out.with_name(out.stem + ".xdmf.h5")
        _copy_committed(res, data_file)
        log.warning("%s is marked as open for SWMR writing (its writer was killed); the "
                    "committed steps were copied to %s for ParaView", path, data_file)
    relative = os.path.relpath(data_file.resolve(), out.resolve().parent)

    def href(name):     # a dataset by its 2.0 name, at its name in the file
        return f"{relative}:/{res._name(name)}"

    if data_file == path:
        with res._file() as f:
            shapes = {name: f[res._name(name)].shape for name in _referenced(f, res)}
    else:
        with h5py.File(data_file, "r") as f:
            shapes = {name: f[res._name(name)].shape for name in _referenced(f, res)}
    tree = _xdmf_tree(res, href, shapes)
    ET.indent(tree, space="  ")
    tmp = out.with_name(out.name + ".tmp")
    tree.write(tmp, encoding="utf-8", xml_declaration=True)
    os.replace(tmp, out)
    return out


def _referenced(f: h5py.File, res: ResultsFile) -> list[str]:
    names = ["model/position_x0", "static/position", "static/elements/BEAM/stress_resultant"]
    names += [n for n in ("model/elements/BEAM/position_rows",
                          "static/elements/BEAM/max_normal_stress",
                          "static/elements/BEAM/max_von_mises_stress", "eigen/shape_position",
                          "buckling/shape_position") if res._name(n) in f]
    return names


def _hdf(parent, href, name: str, shape, number_type="Float", precision=8):
    item = ET.SubElement(parent, "DataItem", Dimensions=_dims(shape), NumberType=number_type,
                         Precision=str(precision), Format="HDF")
    item.text = href(name)
    return item


def _dims(shape) -> str:
    return " ".join(str(int(n)) for n in shape)


def _slab(parent, href, name: str, full_shape, start, count, dims=None):
    """A HyperSlab of ``name``: ``count`` values from ``start``, reshaped to ``dims``.

    The slab opens with a comment naming the selection: VTK's XDMF 2 reader keys its geometry
    cache on the first text inside the geometry's DataItem, so each step gets its own key (and
    the reader no longer reports that it cannot cache).
    """
    item = ET.SubElement(parent, "DataItem", ItemType="HyperSlab",
                         Dimensions=_dims(dims if dims is not None else count),
                         Type="HyperSlab")
    item.append(ET.Comment(f" {name}[{', '.join(str(int(v)) for v in start)}] "))
    sel = ET.SubElement(item, "DataItem", Dimensions=f"3 {len(full_shape)}", Format="XML",
                        NumberType="Int")
    sel.text = " ".join(str(int(v)) for v in (*start, *([1] * len(full_shape)), *count))
    _hdf(item, href, name, full_shape)
    return item


def _xdmf_tree(res: ResultsFile, href, shapes: dict) -> ET.ElementTree:
    s, m = res.static, res.model
    n_pos, n_elem, n_step = m.n_pos, m.n_elem, s.n_step
    lf = s.load_factor
    times = lf if n_step < 2 or np.all(np.diff(lf) > 0) else np.arange(n_step, dtype=float)
    root = ET.Element("Xdmf", {"Version": "3.0", "xmlns:xi": "http://www.w3.org/2001/XInclude"})
    domain = ET.SubElement(root, "Domain")
    series = ET.SubElement(domain, "Grid", Name="static", GridType="Collection",
                           CollectionType="Temporal")
    modes = {}
    for group in ("eigen", "buckling"):
        view = getattr(res, group)
        if view is not None and f"{group}/shape_position" in shapes:
            modes[group] = {int(k): r for r, k in enumerate(view.step)}
    pos_shape = shapes["static/position"]
    sig_shape = shapes["static/elements/BEAM/stress_resultant"]
    for k in range(n_step):
        grid = ET.SubElement(series, "Grid", Name=f"step {k}", GridType="Uniform")
        ET.SubElement(grid, "Time", Value=repr(float(times[k])))
        topo = ET.SubElement(grid, "Topology", TopologyType="Polyline", NodesPerElement="2",
                             NumberOfElements=str(n_elem))
        if "model/elements/BEAM/position_rows" in shapes:
            _hdf(topo, href, "model/elements/BEAM/position_rows", (n_elem, 2), "Int", 8)
        else:       # schema 1.0 file: the connectivity inline
            item = ET.SubElement(topo, "DataItem", Dimensions=f"{n_elem} 2", NumberType="Int",
                                 Format="XML")
            item.text = " ".join(map(str, m.element_position_rows.ravel().tolist()))
        geo = ET.SubElement(grid, "Geometry", GeometryType="XYZ")
        _slab(geo, href, "static/position", pos_shape, (k, 0, 0), (1, n_pos, 3), (n_pos, 3))
        att = ET.SubElement(grid, "Attribute", Name="displacement", AttributeType="Vector",
                            Center="Node")
        fn = ET.SubElement(att, "DataItem", ItemType="Function", Function="$0 - $1",
                           Dimensions=f"{n_pos} 3")
        _slab(fn, href, "static/position", pos_shape, (k, 0, 0), (1, n_pos, 3), (n_pos, 3))
        _hdf(fn, href, "model/position_x0", (n_pos, 3))
        for j, name in enumerate(("normal_force", "sigma2", "sigma3", "sigma4", "sigma5",
                                  "sigma6")):
            att = ET.SubElement(grid, "Attribute", Name=name, AttributeType="Scalar",
                                Center="Cell")
            _slab(att, href, "static/elements/BEAM/stress_resultant", sig_shape, (k, 0, j),
                  (1, n_elem, 1), (n_elem,))
        for name in ("max_normal_stress", "max_von_mises_stress"):
            if f"static/elements/BEAM/{name}" in shapes:
                att = ET.SubElement(grid, "Attribute", Name=name, AttributeType="Scalar",
                                    Center="Cell")
                path = f"static/elements/BEAM/{name}"
                _slab(att, href, path, shapes[path], (k, 0),
                      (1, n_elem), (n_elem,))
        for group, rows in modes.items():
            if k not in rows:
                continue
            full = shapes[f"{group}/shape_position"]
            label = "eigenmode" if group == "eigen" else "buckling_mode"
            for j in range(full[1]):
                att = ET.SubElement(grid, "Attribute", Name=f"{label}_{j + 1}",
                                    AttributeType="Vector", Center="Node")
                _slab(att, href, f"{group}/shape_position", full, (rows[k], j, 0, 0),
                      (1, 1, n_pos, 3), (n_pos, 3))
    return ET.ElementTree(root)


# --------------------------------------------------------------------------------------------
# VTK
# --------------------------------------------------------------------------------------------

def write_vtk(path, out=None) -> Path:
    """Write one ``.vtu`` per committed step and a ``.pvd`` collection (needs meshio).

    Parameters
    ----------
    path : str or os.PathLike
        Results file.
    out : str or os.PathLike, optional
        The ``.pvd`` file; default ``path`` with the suffix ``.pvd``. The step files are
        ``<stem>_<step>.vtu`` beside it.

    Returns
    -------
    pathlib.Path
        The ``.pvd`` file.
    """
    try:
        import meshio
    except ImportError as exc:
        raise ExportUnavailableError("VTK export needs meshio, which is not installed: pip "
                                     "install \"spacarpy[vtk]\" (or pip install meshio)") from exc
    path = Path(path)
    out = Path(out) if out is not None else path.with_suffix(".pvd")
    res = open_results(path)
    s, m = res.static, res.model
    if s is None:
        raise SpacarError(f"{path} has no static load steps: nothing to export")
    with res:
        position = s.position()
        sigma = s.stress_resultant()
        forces = section_forces(sigma, m.element_length)
        stress = ((s.max_normal_stress(), s.max_von_mises_stress()) if s.has_stress
                  else None)
        lf = s.load_factor
    cells = [("line", m.element_position_rows.astype(np.int64))]
    root = ET.Element("VTKFile", type="Collection", version="0.1")
    coll = ET.SubElement(root, "Collection")
    for k in range(s.n_step):
        name = f"{out.stem}_{k}.vtu"
        cell_data = {"normal_force": [forces[k, :, 0]], "torque": [forces[k, :, 1]],
                     "stress_resultant": [sigma[k]]}
        if stress is not None:
            cell_data["max_normal_stress"] = [stress[0][k]]
            cell_data["max_von_mises_stress"] = [stress[1][k]]
        meshio.write_points_cells(out.with_name(name), position[k], cells,
                                  point_data={"displacement": position[k] - m.position_x0},
                                  cell_data=cell_data)
        ET.SubElement(coll, "DataSet", timestep=repr(float(lf[k])), part="0", file=name)
    tree = ET.ElementTree(root)
    ET.indent(tree, space="  ")
    tree.write(out, encoding="utf-8", xml_declaration=True)
    return out
