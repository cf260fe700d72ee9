"""Files for ParaView and other visualization tools: XDMF (with one HDF5 file) and VTK (.vtu/.pvd).

This module's one job is writing the visualization formats; what they hold (one line cell per
element of every kind, ids, forces per element, section frames, mode shapes) is computed by
:mod:`spacarpy.results.export_data`, through the reader API, so that both formats carry the
same arrays under the same names (docs/results.md, "ParaView").

XDMF (:func:`write_xdmf`) writes ``<name>.xdmf`` (XDMF 3, written with the standard library)
and one HDF5 file beside it, ``<name>.xdmf.h5``, that holds the data of every exported step.
Every data item is a plain ``Format="HDF"`` reference (no HyperSlab, no Function), so
meshio's ``TimeSeriesReader`` reads the series and VTK's ``vtkXdmfReader`` (ParaView's "XDMF
Reader") reads it with its times. The file is one ``Grid CollectionType="Temporal"`` named
``static`` (time: the load factor, or the step number if the load factors do not increase
strictly) or ``transient`` (time in s), one uniform grid per exported step. With ``step``
given, the file is one uniform grid of that step instead, which ``meshio.read`` reads (meshio
reads no temporal collection with ``read``). A long run is thinned to at most
:data:`MAX_FRAMES` intervals unless ``every`` is given.

VTK (:func:`write_vtk`) writes a ``.pvd`` collection and one ``.vtu`` per exported step with
meshio (the optional ``vtk`` extra), with the same cells and arrays, thinned like the XDMF.

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
from spacarpy.results.export_data import (
    DERIVED_UNITS,
    export_mesh,
    export_steps,
    group_of,
    step_arrays,
)
from spacarpy.results.reader import open_results

log = logging.getLogger(__name__)

__all__ = ["write_xdmf", "write_vtk", "ExportUnavailableError", "ExportError",
           "check_export_output", "write_state_space_mat", "MAX_FRAMES"]


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


#: A run with more steps than this is exported every k-th step (k the smallest that keeps
#: at most this many intervals) unless ``every`` is given.
MAX_FRAMES = 500


def _prepare(path, every, step):
    """(results file, group, mesh, steps to export) for the results file ``path``."""
    res = open_results(path)
    group = group_of(res)
    if group is None:
        raise ExportError(f"{res.path} has no load steps and no time steps: nothing to export")
    view = getattr(res, group)
    if step is not None:
        steps = np.atleast_1d(view.step_index(step))
    else:
        if every is None and view.n_step > MAX_FRAMES + 1:
            every = -(-(view.n_step - 1) // MAX_FRAMES)
            log.warning("%s has %d %s steps: exporting every %d-th (and the last); give "
                        "--every 1 for all of them", path, view.n_step,
                        "time" if group == "transient" else "load", every)
        steps = export_steps(view, every)
    if not res.completed:
        from spacarpy.outputs import running_writer
        pid = running_writer(path)
        state = (f"it is being written by spacarpy process {pid}" if pid is not None
                 else "its writer was killed" if _needs_swmr_read(path) else "the run failed")
        log.warning("%s is a partial file (%s): the export holds its %d committed steps so "
                    "far", path, state, view.n_step)
    return res, group, export_mesh(res), steps


def _needs_swmr_read(path) -> bool:
    """True when a plain read-only open is refused (the writer was killed or still runs)."""
    try:
        with h5py.File(path, "r"):
            return False
    except OSError:
        return True


def _units(name: str) -> str:
    """The unit of an exported array (its columns' units, comma-separated, where they
    differ), see :mod:`spacarpy.results.export_data`."""
    from spacarpy.elements.registry import KINDS
    kind, _, what = name.partition("_")
    if kind in KINDS and what in ("deformation", "stress_resultant"):
        facts = KINDS[kind]
        units = facts.mode_units if what == "deformation" else facts.stress_units
        return units[0] if len(set(units)) == 1 else ", ".join(units)
    if name in DERIVED_UNITS:
        return DERIVED_UNITS[name]
    if name.startswith(("eigenmode_", "buckling_mode_")):
        return "as /eigen/shape_position" if name[0] == "e" else "as /buckling/shape_position"
    return {"displacement": "m", "position": "m", "velocity": "m/s", "max_normal_stress": "Pa",
            "max_von_mises_stress": "Pa"}.get(name, "1")


_CONSTANT = ("node_id", "orientation_node_id", "element_id", "element_kind")


def write_xdmf(path, out=None, *, every: int | None = None, step: int | None = None) -> Path:
    """Write ``out`` (XDMF 3) and its data file ``<out>.h5`` for the results file ``path``.

    Parameters
    ----------
    path : str or os.PathLike
        Results file (complete or partial).
    out : str or os.PathLike, optional
        The XDMF file; default: ``path`` with the suffix ``.xdmf``.
    every : int, optional
        Export every ``every``-th step (and the last); default: all, thinned to
        :data:`MAX_FRAMES` intervals for a long run.
    step : int, optional
        Export this one step as a single uniform grid (what ``meshio.read`` reads).

    Returns
    -------
    pathlib.Path
        The XDMF file written.
    """
    path = Path(path)
    out = check_export_output(out if out is not None else path.with_suffix(".xdmf"), ".xdmf")
    res, group, mesh, steps = _prepare(path, every, step)
    data_file = out.with_name(out.name + ".h5")
    if data_file.resolve() == path.resolve():
        raise ExportError(f"export: cannot write {out}: its data file {data_file} would "
                          "replace the results file")
    tmp_data = data_file.with_name(data_file.name + ".tmp")
    tmp = out.with_name(out.name + ".tmp")
    href_base = os.path.relpath(data_file.resolve(), out.resolve().parent)
    try:
        with res, h5py.File(tmp_data, "w") as h5:
            h5.attrs["note"] = (f"steps of {path.name} for {out.name}; written by spacarpy "
                                "export (docs/results.md, ParaView)")
            h5.create_dataset("mesh/cells", data=mesh.cells)
            h5.create_group("units").attrs["note"] = "the units of each array, by its name"
            units, written = {"position": "m"}, set()
            root = ET.Element("Xdmf", {"Version": "3.0"})
            domain = ET.SubElement(root, "Domain")
            parent = domain if step is not None else ET.SubElement(
                domain, "Grid", Name=group, GridType="Collection", CollectionType="Temporal")
            for k, time, position, point, cell in step_arrays(res, mesh, group, steps):
                grid = ET.SubElement(parent, "Grid", Name=f"step {k}", GridType="Uniform")
                if step is None:
                    ET.SubElement(grid, "Time", Value=repr(time))
                topo = ET.SubElement(grid, "Topology", TopologyType="Polyline",
                                     NodesPerElement="2", NumberOfElements=str(mesh.n_cell))
                _item(topo, href_base, "/mesh/cells", mesh.cells)
                s = f"/step_{k}"
                h5.create_dataset(f"{s}/position", data=position)
                geo = ET.SubElement(grid, "Geometry", GeometryType="XYZ")
                _item(geo, href_base, f"{s}/position", position)
                for center, arrays in (("Node", point), ("Cell", cell)):
                    for name, data in arrays.items():
                        where = f"/mesh/{name}" if name in _CONSTANT else f"{s}/{name}"
                        if name not in units:
                            units[name] = _units(name)
                        if name not in _CONSTANT or where not in written:
                            h5.create_dataset(where, data=data)
                            written.add(where)
                        att = ET.SubElement(grid, "Attribute", Name=name, Center=center,
                                            AttributeType=_attribute_type(data))
                        _item(att, href_base, where, data)
            for name, unit in units.items():
                h5["units"].attrs[name] = unit
        tree = ET.ElementTree(root)
        ET.indent(tree, space=" ")
        tree.write(tmp, encoding="utf-8", xml_declaration=True)
        os.replace(tmp_data, data_file)
        os.replace(tmp, out)
    except BaseException:
        tmp.unlink(missing_ok=True)               # a full disk: no half file left
        tmp_data.unlink(missing_ok=True)
        raise
    return out


def _attribute_type(data: np.ndarray) -> str:
    """Scalar, Vector (3 components) or Matrix (the other component counts: VTK's reader
    takes a Vector of 6 too, but warns that it is not a vector)."""
    if data.ndim == 1:
        return "Scalar"
    return "Vector" if data.shape[1] == 3 else "Matrix"


def _item(parent, href_base: str, where: str, data: np.ndarray) -> None:
    """A ``Format="HDF"`` DataItem of dataset ``where`` (shape and type of ``data``; a
    Matrix attribute's cells as n x 1 x components, how VTK's reader counts its tuples)."""
    int_type = np.issubdtype(data.dtype, np.integer)
    shape = data.shape
    if _attribute_type(data) == "Matrix" and parent.tag == "Attribute":
        shape = (shape[0], 1, shape[1])
    item = ET.SubElement(parent, "DataItem", Dimensions=" ".join(map(str, shape)),
                         NumberType="Int" if int_type else "Float", Precision="8",
                         Format="HDF")
    item.text = f"{href_base}:{where}"


# --------------------------------------------------------------------------------------------
# VTK
# --------------------------------------------------------------------------------------------

def write_vtk(path, out=None, *, every: int | None = None, step: int | None = None) -> Path:
    """Write a ``.pvd`` collection and one ``.vtu`` per exported step (needs meshio), with
    the arrays of :func:`write_xdmf`.

    Parameters
    ----------
    path : str or os.PathLike
        Results file.
    out : str or os.PathLike, optional
        The ``.pvd`` file; default ``path`` with the suffix ``.pvd``. The step files are
        ``<stem>_<step>.vtu`` beside it (the step number zero-padded).
    every, step : int, optional
        As for :func:`write_xdmf`.

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
    res, group, mesh, steps = _prepare(path, every, step)
    width = len(str(max(int(steps.max()), 0))) if steps.size else 1
    root = ET.Element("VTKFile", type="Collection", version="0.1")
    coll = ET.SubElement(root, "Collection")
    with res:
        for k, time, position, point, cell in step_arrays(res, mesh, group, steps):
            name = f"{out.stem}_{k:0{width}d}.vtu"
            meshio.write_points_cells(out.with_name(name), position, [("line", mesh.cells)],
                                      point_data=point,
                                      cell_data={n: [v] for n, v in cell.items()})
            ET.SubElement(coll, "DataSet", timestep=repr(time), part="0", file=name)
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
