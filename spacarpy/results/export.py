"""Files for ParaView and other visualization tools: an XDMF sidecar and VTK (.vtu/.pvd).

This module's one job is exporting results to visualization formats.

XDMF (:func:`write_xdmf`) writes a small XML file (XDMF 3, written with the standard library)
that *points into* the results file, so no data is copied: ParaView opens the ``.xdmf`` and
reads the HDF5 datasets directly. The layout follows meshio's XDMF time series:

- one ``Grid CollectionType="Temporal"`` named ``static`` with one uniform grid per committed
  load step, its ``Time`` the load factor (the step number if the load factors do not
  increase strictly); for a transient run (a file with time steps) the collection is named
  ``transient``, one grid per stored time step, its ``Time`` the time (s), with the node
  attribute ``velocity`` besides ``displacement``;
- beams as ``Polyline`` cells with 2 nodes (p, q) from ``/model/elements/BEAM/position_rows``;
  a model with other line elements (TRUSS, RBEAM, PLBEAM, PLTRUSS) has one cell per element
  between its first two position nodes, BEAMs first, written inline;
- node coordinates = the positions of the step (``HyperSlab`` of ``/static/position`` or
  ``/transient/position``);
- node attributes ``displacement`` (vector: position minus ``/model/position_x0``, an XDMF
  ``Function``), and at linearized steps ``eigenmode_<j>`` / ``buckling_mode_<j>`` (vectors);
- cell attributes ``normal_force`` (sigma_1, N) and ``sigma2`` ... ``sigma6`` (the other
  generalized stress resultants, N; torque and end moments are these times the element
  length), plus ``max_normal_stress`` and ``max_von_mises_stress`` (Pa) when the file has them
  (static runs whose only line elements are BEAMs).

References are ``<file>.h5:/path``, relative to the ``.xdmf`` file. A partial file whose writer
was killed keeps HDF5's "open for SWMR write" mark, which other HDF5 readers refuse; for such
a file the committed steps are first copied to ``<name>.xdmf.h5`` next to the XDMF file, and
the XDMF file points there.

VTK (:func:`write_vtk`) writes one ``.vtu`` file per step (time step of a transient run) and
a ``.pvd`` collection with meshio (the optional ``vtk`` extra), with the same cells.

The linearized state space of SPACAR mode 9 (:func:`write_state_space_mat`) goes to a
MATLAB file for ``ss(A, B, C, D)``.

Output paths are checked before any work (:func:`check_export_output`).
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

__all__ = ["write_xdmf", "write_vtk", "ExportUnavailableError", "ExportError",
           "check_export_output", "line_cells", "write_state_space_mat"]

_LINE_KINDS = ("BEAM", "TRUSS", "RBEAM", "PLBEAM", "PLTRUSS", "BEAMC")


class ExportUnavailableError(SpacarError):
    """An optional package needed for an export is not installed."""

    exit_code = EXIT_INPUT


class ExportError(SpacarError):
    """The output cannot be written, or the file has nothing to export (exit 2)."""

    exit_code = EXIT_INPUT


def check_export_output(out, suffix: str) -> Path:
    """``out`` as a Path when it can be written (an existing, writable directory, not a
    directory itself, the suffix ``suffix``); else a :class:`SpacarError` (exit 2)."""
    out = Path(out)
    if str(out) in ("", "."):
        raise ExportError("export: -o needs a file name")
    if out.suffix.lower() != suffix:
        raise ExportError(f"export: cannot write {out}: the file name must end in {suffix}")
    if out.is_dir():
        raise ExportError(f"export: cannot write {out}: it is a directory")
    parent = out.parent if str(out.parent) else Path(".")
    if not parent.is_dir():
        raise ExportError(f"export: cannot write {out}: the directory {parent} does not exist")
    if not os.access(parent, os.W_OK):
        raise ExportError(f"export: cannot write {out}: the directory {parent} is not "
                          "writable")
    return out


def line_cells(res: ResultsFile) -> tuple[np.ndarray, bool]:
    """((n_cell, 2) position rows of every line element, BEAMs first; whether the cells are
    exactly the BEAMs (so that BEAM cell data fits them))."""
    from spacarpy.results.schema import slot_roles

    m = res.model
    cells = [m.element_position_rows.reshape(-1, 2)]
    for kind in m.element_kinds:
        if kind != "BEAM" and kind in _LINE_KINDS:
            cols = [j for j, r in enumerate(slot_roles(kind)) if r == "pos"][:2]
            cells.append(m.position_row(m.element_kind_nodes(kind)[:, cols]).reshape(-1, 2))
    all_cells = np.concatenate(cells).astype(np.int64)
    return all_cells, len(all_cells) == m.n_elem


def _group(res: ResultsFile) -> str:
    """``transient`` for a file with time steps, else ``static``."""
    if res.transient is not None and res.transient.n_step:
        return "transient"
    if res.static is None:
        raise ExportError(f"{res.path} has no load steps and no time steps: nothing to export")
    return "static"


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
        group = _group(res)
        n_step = getattr(res, group).n_step
        for name in ("model/position_x0", "model/elements/BEAM/position_rows",
                     "static/load_factor", "static/position", "transient/time",
                     "transient/position", "transient/velocity",
                     "static/elements/BEAM/stress_resultant",
                     "static/elements/BEAM/max_normal_stress",
                     "static/elements/BEAM/max_von_mises_stress"):
            if res._has(name) and (name.startswith("model") or name.startswith(group)):
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
    out = check_export_output(out if out is not None else path.with_suffix(".xdmf"), ".xdmf")
    res = open_results(path)
    _group(res)
    data_file = path
    if _needs_swmr_read(path):
        data_file = out.with_name(out.stem + ".xdmf.h5")
        try:
            _copy_committed(res, data_file)
        except BaseException:
            data_file.unlink(missing_ok=True)     # a full disk: no half copy left
            raise
        from spacarpy.outputs import running_writer
        pid = running_writer(path)
        state = (f"it is being written by spacarpy process {pid}" if pid is not None
                 else "its writer was killed")
        log.warning("%s is marked as open for SWMR writing (%s); the committed steps so far "
                    "were copied to %s for ParaView", path, state, data_file)
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
    try:
        tree.write(tmp, encoding="utf-8", xml_declaration=True)
        os.replace(tmp, out)
    except BaseException:
        tmp.unlink(missing_ok=True)               # a full disk: no 0-byte file left
        raise
    return out


def _referenced(f: h5py.File, res: ResultsFile) -> list[str]:
    group = _group(res)
    names = ["model/position_x0", f"{group}/position"]
    names += [n for n in ("model/elements/BEAM/position_rows", "transient/velocity",
                          f"{group}/elements/BEAM/stress_resultant",
                          "static/elements/BEAM/max_normal_stress",
                          "static/elements/BEAM/max_von_mises_stress", "eigen/shape_position",
                          "buckling/shape_position")
              if n.startswith(("model", group, "eigen", "buckling")) and res._name(n) in f]
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
    group = _group(res)
    s, m = getattr(res, group), res.model
    n_pos, n_step = m.n_pos, s.n_step
    if group == "transient":
        times = s.time
    else:
        lf = s.load_factor
        times = lf if n_step < 2 or np.all(np.diff(lf) > 0) else np.arange(n_step, dtype=float)
    cells, beams_only = line_cells(res)
    n_cell = len(cells)
    root = ET.Element("Xdmf", {"Version": "3.0", "xmlns:xi": "http://www.w3.org/2001/XInclude"})
    domain = ET.SubElement(root, "Domain")
    series = ET.SubElement(domain, "Grid", Name=group, GridType="Collection",
                           CollectionType="Temporal")
    modes = {}
    for lin in ("eigen", "buckling"):
        view = getattr(res, lin)
        if group == "static" and view is not None and f"{lin}/shape_position" in shapes:
            modes[lin] = {int(k): r for r, k in enumerate(view.step)}
    pos_shape = shapes[f"{group}/position"]
    sig_name = f"{group}/elements/BEAM/stress_resultant"
    cell_data = beams_only and n_cell > 0 and sig_name in shapes
    for k in range(n_step):
        grid = ET.SubElement(series, "Grid", Name=f"step {k}", GridType="Uniform")
        ET.SubElement(grid, "Time", Value=repr(float(times[k])))
        topo = ET.SubElement(grid, "Topology", TopologyType="Polyline", NodesPerElement="2",
                             NumberOfElements=str(n_cell))
        if beams_only and "model/elements/BEAM/position_rows" in shapes:
            _hdf(topo, href, "model/elements/BEAM/position_rows", (n_cell, 2), "Int", 8)
        else:       # other line elements, or a schema 1.0 file: the connectivity inline
            item = ET.SubElement(topo, "DataItem", Dimensions=f"{n_cell} 2", NumberType="Int",
                                 Format="XML")
            item.text = " ".join(map(str, cells.ravel().tolist()))
        geo = ET.SubElement(grid, "Geometry", GeometryType="XYZ")
        _slab(geo, href, f"{group}/position", pos_shape, (k, 0, 0), (1, n_pos, 3),
              (n_pos, 3))
        att = ET.SubElement(grid, "Attribute", Name="displacement", AttributeType="Vector",
                            Center="Node")
        fn = ET.SubElement(att, "DataItem", ItemType="Function", Function="$0 - $1",
                           Dimensions=f"{n_pos} 3")
        _slab(fn, href, f"{group}/position", pos_shape, (k, 0, 0), (1, n_pos, 3), (n_pos, 3))
        _hdf(fn, href, "model/position_x0", (n_pos, 3))
        if "transient/velocity" in shapes and group == "transient":
            att = ET.SubElement(grid, "Attribute", Name="velocity", AttributeType="Vector",
                                Center="Node")
            _slab(att, href, "transient/velocity", shapes["transient/velocity"], (k, 0, 0),
                  (1, n_pos, 3), (n_pos, 3))
        if cell_data:
            for j, name in enumerate(("normal_force", "sigma2", "sigma3", "sigma4", "sigma5",
                                      "sigma6")):
                att = ET.SubElement(grid, "Attribute", Name=name, AttributeType="Scalar",
                                    Center="Cell")
                _slab(att, href, sig_name, shapes[sig_name], (k, 0, j), (1, n_cell, 1), (n_cell,))
            for name in ("max_normal_stress", "max_von_mises_stress"):
                if f"{group}/elements/BEAM/{name}" in shapes:
                    att = ET.SubElement(grid, "Attribute", Name=name, AttributeType="Scalar",
                                        Center="Cell")
                    path = f"{group}/elements/BEAM/{name}"
                    _slab(att, href, path, shapes[path], (k, 0),
                          (1, n_cell), (n_cell,))
        for lin, rows in modes.items():
            if k not in rows:
                continue
            full = shapes[f"{lin}/shape_position"]
            label = "eigenmode" if lin == "eigen" else "buckling_mode"
            for j in range(full[1]):
                att = ET.SubElement(grid, "Attribute", Name=f"{label}_{j + 1}",
                                    AttributeType="Vector", Center="Node")
                _slab(att, href, f"{lin}/shape_position", full, (rows[k], j, 0, 0),
                      (1, 1, n_pos, 3), (n_pos, 3))
    return ET.ElementTree(root)


# --------------------------------------------------------------------------------------------
# VTK
# --------------------------------------------------------------------------------------------

def write_vtk(path, out=None) -> Path:
    """Write one ``.vtu`` per committed step (time step of a transient run) and a ``.pvd``
    collection (needs meshio).

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
    out = check_export_output(out if out is not None else path.with_suffix(".pvd"), ".pvd")
    res = open_results(path)
    group = _group(res)
    s, m = getattr(res, group), res.model
    line, beams_only = line_cells(res)
    with res:
        position = s.position()
        velocity = s.velocity() if group == "transient" else None
        cell = beams_only and len(line) > 0 and res._has(
            f"{group}/elements/BEAM/stress_resultant")
        sigma = s.stress_resultant() if cell else None
        forces = section_forces(sigma, m.element_length) if cell else None
        stress = ((s.max_normal_stress(), s.max_von_mises_stress())
                  if cell and group == "static" and s.has_stress else None)
        times = s.time if group == "transient" else s.load_factor
    cells = [("line", line)]
    root = ET.Element("VTKFile", type="Collection", version="0.1")
    coll = ET.SubElement(root, "Collection")
    for k in range(s.n_step):
        name = f"{out.stem}_{k}.vtu"
        cell_data = {}
        if cell:
            cell_data = {"normal_force": [forces[k, :, 0]], "torque": [forces[k, :, 1]],
                         "stress_resultant": [sigma[k]]}
        if stress is not None:
            cell_data["max_normal_stress"] = [stress[0][k]]
            cell_data["max_von_mises_stress"] = [stress[1][k]]
        point_data = {"displacement": position[k] - m.position_x0}
        if velocity is not None:
            point_data["velocity"] = velocity[k]
        meshio.write_points_cells(out.with_name(name), position[k], cells,
                                  point_data=point_data, cell_data=cell_data or None)
        ET.SubElement(coll, "DataSet", timestep=repr(float(times[k])), part="0", file=name)
    tree = ET.ElementTree(root)
    ET.indent(tree, space="  ")
    tree.write(out, encoding="utf-8", xml_declaration=True)
    return out


def write_state_space_mat(path, out, step: int | None = None) -> Path:
    """The state space of static step ``step`` (None or -1: the last linearized one) of the
    result file ``path`` as a MATLAB file ``out`` (:func:`scipy.io.savemat`, MATLAB 5
    format): ``A``, ``B``, ``C``, ``D`` (for ``ss(A, B, C, D)``), the second-order matrices
    ``M0``, ``C0``, ``K0``, ``B0``, the names ``state_name``, ``input_name``,
    ``output_name`` (cell arrays of strings), ``dof`` ([element mode] per degree of freedom),
    ``step`` (the static step; along a trajectory, SPACAR mode 3: the time step),
    ``load_factor`` and ``time`` (NaN where they do not apply)."""
    from scipy.io import savemat

    out = check_export_output(out, ".mat")
    with open_results(path) as res:
        view = res.state_space
        if view is None:
            raise ExportError(f"export: {path} has no state space (/state_space): run the "
                              "deck with --mode 9 (state_space) and INPUTF/OUTX lines")
        row = view.row(None if step in (None, -1) else step)
        k = int(view.step[row])
        data = {name: view.matrix(name, k) for name in ("A", "B", "C", "D", "M0", "C0",
                                                          "K0", "B0")}
        data.update(
            state_name=np.array(view.state_name, dtype=object).reshape(-1, 1),
            input_name=np.array(view.input_name, dtype=object).reshape(-1, 1),
            output_name=np.array(view.output_name, dtype=object).reshape(-1, 1),
            dof=view.dof.astype(float), step=float(k),
            load_factor=float(view.load_factor[row]), time=float(view.time[row]))
    savemat(out, data, do_compression=True)
    return out
