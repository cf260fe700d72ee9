"""ParaView exports of every element kind, read back with meshio and with VTK (issue 35).

The leaf-spring guidance (BEAM, RBEAM, HINGE; static with eigenmodes), the slider-crank
(PLBEAM transient) and the pendulum (RBEAM and HINGE transient) are exported to XDMF and VTK;
meshio (``TimeSeriesReader``, ``meshio.read``) and VTK (``vtkXdmfReader``,
``vtkXMLUnstructuredGridReader`` on the files the ``.pvd`` lists) read them back, and every
array is compared with what the reader API gives for the HDF5: forces per element, the
section frames (the rotation matrix of the orientation node, computed here from its Euler
parameters), node and element ids, mode shapes, positions, velocities and times.
"""
from __future__ import annotations

import logging
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest

from spacarpy.cli import main
from spacarpy.results import open_results
from spacarpy.results.export import write_vtk, write_xdmf

meshio = pytest.importorskip("meshio", reason="the VTK export needs the optional meshio")
vtk = pytest.importorskip("vtk", reason="reading the exports back needs vtk")
from vtk.util.numpy_support import vtk_to_numpy  # noqa: E402

DECKS = Path(__file__).resolve().parents[1] / "decks"
KIND_ORDER = ("BEAM", "TRUSS", "HINGE", "RBEAM", "PLBEAM", "PLTRUSS", "PLHINGE")


@pytest.fixture(scope="module")
def leafspring(tmp_path_factory) -> Path:
    """decks/leafspring_guidance_misalignment.dat in 8 load steps, 3 modes at each."""
    tmp = tmp_path_factory.mktemp("ls")
    for name in ("leafspring_guidance_model.inc", "leafspring_guidance_data.inc"):
        (tmp / name).write_text((DECKS / name).read_text())
    deck = tmp / "ls.dat"
    deck.write_text((DECKS / "leafspring_guidance_misalignment.dat").read_text()
                    .replace("ITERSTEP 20 40 1e-10", "ITERSTEP 20 8 1e-10"))
    assert main(["run", str(deck), "-o", str(tmp / "ls.h5"), "-q"]) == 0
    return tmp / "ls.h5"


@pytest.fixture(scope="module")
def crank(tmp_path_factory) -> Path:
    """decks/slider_crank_flexible.dat over its first 20 stored steps."""
    tmp = tmp_path_factory.mktemp("crank")
    deck = tmp / "crank.dat"
    deck.write_text((DECKS / "slider_crank_flexible.dat").read_text()
                    .replace("TIMESTEP 0.2 200", "TIMESTEP 0.02 20"))
    assert main(["run", str(deck), "-o", str(tmp / "crank.h5"), "-q"]) == 0
    return tmp / "crank.h5"


@pytest.fixture(scope="module")
def pendulum(tmp_path_factory) -> Path:
    """decks/pendulum_rigid_90deg.dat in 10 time steps: an RBEAM on a HINGE."""
    tmp = tmp_path_factory.mktemp("pend")
    deck = tmp / "pend.dat"
    deck.write_text((DECKS / "pendulum_rigid_90deg.dat").read_text()
                    .replace("TIMESTEP 2.2 440", "TIMESTEP 0.5 10"))
    assert main(["run", str(deck), "-o", str(tmp / "pend.h5"), "-q"]) == 0
    return tmp / "pend.h5"


# --------------------------------------------------------------------------------------------
# readers
# --------------------------------------------------------------------------------------------

def _vtk_arrays(data) -> dict:
    return {data.GetArrayName(i): vtk_to_numpy(data.GetArray(i))
            for i in range(data.GetNumberOfArrays())}


def _vtk_grid(grid) -> dict:
    return {"points": vtk_to_numpy(grid.GetPoints().GetData()),
            "cells": np.array([[grid.GetCell(c).GetPointId(j) for j in range(2)]
                               for c in range(grid.GetNumberOfCells())]).reshape(-1, 2),
            "point": _vtk_arrays(grid.GetPointData()), "cell": _vtk_arrays(grid.GetCellData())}


def vtk_xdmf(path: Path) -> list:
    """[(time, grid dict)] of every time of an XDMF file, read by vtkXdmfReader."""
    reader = vtk.vtkXdmfReader()
    reader.SetFileName(str(path))
    reader.UpdateInformation()
    times = reader.GetOutputInformation(0).Get(
        vtk.vtkStreamingDemandDrivenPipeline.TIME_STEPS())
    out = []
    for t in times:
        reader.UpdateTimeStep(t)
        out.append((t, _vtk_grid(reader.GetOutputDataObject(0))))
    return out


def vtk_pvd(path: Path) -> list:
    """[(time, grid dict)] of the .vtu files a .pvd lists, read by VTK's XML reader."""
    out = []
    for ds in ET.parse(path).getroot().findall("Collection/DataSet"):
        reader = vtk.vtkXMLUnstructuredGridReader()
        reader.SetFileName(str(path.parent / ds.get("file")))
        reader.Update()
        out.append((float(ds.get("timestep")), _vtk_grid(reader.GetOutput())))
    return out


def meshio_series(path: Path) -> list:
    """[(time, grid dict)] by meshio's XDMF TimeSeriesReader."""
    out = []
    with meshio.xdmf.TimeSeriesReader(path) as reader:
        points, cells = reader.read_points_cells()
        assert [c.type for c in cells] == ["line"]
        for k in range(reader.num_steps):
            t, point, cell = reader.read_data(k)
            out.append((t, {"points": None, "cells": cells[0].data, "point": point,
                            "cell": {n: v[0] for n, v in cell.items()}}))
    out[0][1]["points"] = points
    return out


# --------------------------------------------------------------------------------------------
# what the HDF5 says, through the reader API
# --------------------------------------------------------------------------------------------

def rotation(q: np.ndarray) -> np.ndarray:
    """R of Euler parameters q = (l0, l1, l2, l3): (l0^2 - l.l) I + 2 l l^T + 2 l0 [l~]."""
    l0, lam = q[0], q[1:]
    tilde = np.array([[0, -lam[2], lam[1]], [lam[2], 0, -lam[0]], [-lam[1], lam[0], 0]])
    return (l0 ** 2 - lam @ lam) * np.eye(3) + 2 * np.outer(lam, lam) + 2 * l0 * tilde


def check_grid(res, view, k: int, grid: dict, *, exact: bool = True):
    """Every array of ``grid`` (one exported step ``k``) equals the results file's data."""
    m = res.model
    close = (lambda a, b: np.testing.assert_array_equal(a, b)) if exact else (
        lambda a, b: np.testing.assert_allclose(a, b, rtol=1e-15, atol=0))
    point, cell = grid["point"], grid["cell"]
    if grid["points"] is not None:
        close(grid["points"], view.position(step=k))
    np.testing.assert_array_equal(point["node_id"], m.position_nodes)
    close(point["displacement"], view.displacement(step=k))
    if view is res.transient:
        close(point["velocity"], view.velocity(step=k))
    # the section frames: the rotation of the orientation node riding on each point
    ori = point["orientation_node_id"]
    riding = set()
    for kind in m.element_kinds:
        nodes = m.element_kind_nodes(kind)
        if kind in ("BEAM", "RBEAM", "PLBEAM"):
            riding |= {(p, r) for p, r in nodes[:, :2].tolist()}
            if kind != "RBEAM":
                riding |= {(q, s) for q, s in nodes[:, 2:4].tolist()}
            else:                           # q of a rigid beam rides on its body r
                riding |= {(q, r) for r, q in nodes[:, 1:3].tolist()}
    assert (ori >= 0).sum() >= 2
    for row, (node, r) in enumerate(zip(m.position_nodes.tolist(), ori.tolist())):
        if r < 0:
            assert np.isnan(point["frame_x"][row]).all()
            continue
        assert (node, r) in riding
        R = rotation(view.euler(node=r, step=k))
        for j, axis in enumerate("xyz"):
            np.testing.assert_allclose(point[f"frame_{axis}"][row], R[:, j], rtol=0,
                                       atol=1e-15)
    # one cell per element, every kind, BEAM first; ids, kinds and forces per element
    ids = cell["element_id"]
    kinds = [k for k in KIND_ORDER if k in m.element_kinds and len(m.element_ids(k))]
    np.testing.assert_array_equal(ids, np.concatenate([m.element_ids(k) for k in kinds]))
    start = 0
    for kind in kinds:
        n = len(m.element_ids(kind))
        rows = slice(start, start + n)
        start += n
        sigma = view.stress_resultant(step=k, kind=kind)
        e = view.deformation(step=k, kind=kind)
        got_s, got_e = cell[f"{kind}_stress_resultant"], cell[f"{kind}_deformation"]
        close(got_s[rows].reshape(sigma.shape), sigma)
        close(got_e[rows].reshape(e.shape), e)
        others = np.ones(len(ids), bool)
        others[rows] = False
        assert np.isnan(got_s[others]).all()
        if kind == "BEAM":
            forces = view.section_forces(step=k) if view is res.static else None
            if forces is not None:
                for j, name in enumerate(("normal_force", "torque", "moment_y_p", "moment_y_q",
                                          "moment_z_p", "moment_z_q")):
                    np.testing.assert_allclose(cell[name][rows], forces[:, j], rtol=1e-15,
                                               atol=0)
        if kind == "HINGE":
            close(cell["joint_moment"][rows], sigma[:, 0])
            close(cell["joint_angle"][rows], e[:, 0])
        if kind == "PLBEAM":
            x0 = m.position_x0
            pq = m.position_row(m.element_kind_nodes("PLBEAM")[:, [0, 2]])
            l0 = np.linalg.norm(x0[pq[:, 1]] - x0[pq[:, 0]], axis=1)
            close(cell["normal_force"][rows], sigma[:, 0])
            np.testing.assert_allclose(cell["moment_z_q"][rows], sigma[:, 2] * l0, rtol=1e-15)
    # the cells join each element's nodes
    cells = grid["cells"]
    if "BEAM" in kinds:
        nb = len(m.element_ids("BEAM"))
        np.testing.assert_array_equal(m.position_nodes[cells[:nb]],
                                      m.element_kind_nodes("BEAM")[:, [0, 2]])


def check_modes(res, k: int, point: dict):
    if k in res.eigen.step.tolist():
        for j in range(1, res.eigen.n_mode + 1):
            np.testing.assert_array_equal(point[f"eigenmode_{j}"],
                                          res.eigen.shape(mode=j, step=k).position)
        return 1
    assert "eigenmode_1" not in point
    return 0


# --------------------------------------------------------------------------------------------
# tests
# --------------------------------------------------------------------------------------------

def test_leafspring_guidance_in_xdmf_read_by_vtk_and_meshio(leafspring, tmp_path):
    res = open_results(leafspring)
    s, m = res.static, res.model
    assert {k for k in m.element_kinds if len(m.element_ids(k))} == {"BEAM", "RBEAM", "HINGE"}
    xdmf = write_xdmf(leafspring, tmp_path / "ls.xdmf")
    assert (tmp_path / "ls.xdmf.h5").is_file()
    text = xdmf.read_text()
    assert "HyperSlab" not in text and "Function" not in text
    for series in (vtk_xdmf(xdmf), meshio_series(xdmf)):
        assert len(series) == s.n_step == 9
        np.testing.assert_array_equal([t for t, _ in series], s.load_factor)
        n_modes = 0
        for k, (_, grid) in enumerate(series):
            check_grid(res, s, k, grid)
            n_modes += check_modes(res, k, grid["point"])
        assert n_modes == s.n_step
    # the misalignment hinge carries its moment; the leaves their bending
    last = vtk_xdmf(xdmf)[-1][1]["cell"]
    hinge = last["element_kind"] == 2
    assert hinge.sum() == 1 and abs(last["joint_moment"][hinge][0]) > 1e-3
    assert np.nanmax(np.abs(last["moment_z_p"])) > 0


def test_leafspring_guidance_in_vtk_read_by_vtk_and_meshio(leafspring, tmp_path):
    res = open_results(leafspring)
    s = res.static
    pvd = write_vtk(leafspring, tmp_path / "ls.pvd")
    series = vtk_pvd(pvd)
    assert len(series) == s.n_step
    for k, (t, grid) in enumerate(series):
        assert t == s.load_factor[k]
        check_grid(res, s, k, grid)
        check_modes(res, k, grid["point"])
    files = sorted(tmp_path.glob("ls_*.vtu"))
    mesh = meshio.read(files[-1])
    check_grid(res, s, s.n_step - 1, {"points": mesh.points, "cells": mesh.cells[0].data,
                                      "point": mesh.point_data,
                                      "cell": {n: v[0] for n, v in mesh.cell_data.items()}})
    # one naming: the XDMF has the very same arrays
    xgrid = vtk_xdmf(write_xdmf(leafspring, tmp_path / "ls.xdmf"))[-1][1]
    assert set(xgrid["point"]) == set(series[-1][1]["point"])
    assert set(xgrid["cell"]) == set(series[-1][1]["cell"])


def test_one_step_xdmf_is_read_by_meshio_read(leafspring, tmp_path):
    res = open_results(leafspring)
    out = write_xdmf(leafspring, tmp_path / "one.xdmf", step=4)
    mesh = meshio.read(out)
    check_grid(res, res.static, 4, {"points": mesh.points, "cells": mesh.cells[0].data,
                                    "point": mesh.point_data,
                                    "cell": {n: v[0] for n, v in mesh.cell_data.items()}})
    check_modes(res, 4, mesh.point_data)


@pytest.mark.parametrize("name", ["crank", "pendulum"])
def test_transients_in_both_formats(name, request, tmp_path):
    path = request.getfixturevalue(name)
    res = open_results(path)
    tr = res.transient
    xdmf = write_xdmf(path, tmp_path / "t.xdmf")
    pvd = write_vtk(path, tmp_path / "t.pvd")
    for series in (vtk_xdmf(xdmf), meshio_series(xdmf), vtk_pvd(pvd)):
        assert len(series) == tr.n_step
        np.testing.assert_array_equal([t for t, _ in series], tr.time)
        for k, (_, grid) in enumerate(series):
            check_grid(res, tr, k, grid)
    if name == "pendulum":           # the hinge on the ground sits at the pivot
        cell = vtk_xdmf(xdmf)[-1][1]
        hinge = cell["cell"]["element_kind"] == 2
        pivot = res.model.position_row(1)
        np.testing.assert_array_equal(cell["cells"][hinge], [[pivot, pivot]])
        assert abs(cell["cell"]["joint_angle"][hinge][0]) > 0.1       # it swung
    else:                            # the rod bends: moments in the flexible PLBEAMs
        cell = vtk_pvd(pvd)[-1][1]["cell"]
        assert np.nanmax(np.abs(cell["moment_z_p"])) > 0


def test_long_runs_are_thinned_and_every_picks_steps(pendulum, tmp_path, monkeypatch, caplog):
    from spacarpy.results import export
    tr = open_results(pendulum).transient
    monkeypatch.setattr(export, "MAX_FRAMES", 4)
    with caplog.at_level(logging.WARNING):
        xdmf = write_xdmf(pendulum, tmp_path / "a.xdmf")
    assert "exporting every 3-th" in caplog.text
    times = [t for t, _ in vtk_xdmf(xdmf)]
    np.testing.assert_array_equal(times, tr.time[[0, 3, 6, 9, 10]])
    from spacarpy.results import export_data
    monkeypatch.setattr(export_data, "_BATCH_VALUES", 20)     # read 2 steps at a time
    pvd = write_vtk(pendulum, tmp_path / "a.pvd", every=4)
    series = vtk_pvd(pvd)
    np.testing.assert_array_equal([t for t, _ in series], tr.time[[0, 4, 8, 10]])
    res = open_results(pendulum)
    for k, (_, grid) in zip((0, 4, 8, 10), series):
        check_grid(res, tr, k, grid)
    assert sorted(p.name for p in tmp_path.glob("a_*.vtu")) == [
        "a_00.vtu", "a_04.vtu", "a_08.vtu", "a_10.vtu"]


def test_export_command_every_and_step(pendulum, tmp_path, capsys):
    out = tmp_path / "p.xdmf"
    assert main(["export", str(pendulum), "-o", str(out), "--every", "5"]) == 0
    assert len(vtk_xdmf(out)) == 3
    assert main(["export", str(pendulum), "-o", str(out), "--step", "-1"]) == 0
    assert meshio.read(out).points.shape == (2, 3)
    assert main(["export", str(pendulum), "-o", str(out), "--every", "0"]) == 2
    assert "expected a positive whole number, got '0'" in capsys.readouterr().err


def test_cli_cap_matches_the_writer():
    from spacarpy.cli import export as cli_export
    from spacarpy.results import export
    assert cli_export.MAX_FRAMES == export.MAX_FRAMES


def test_documented_kind_codes_and_units():
    """docs/results.md's table of element_kind codes is the writer's."""
    from spacarpy.elements.registry import KINDS
    from spacarpy.results.export_data import KIND_CODES
    text = (Path(__file__).resolve().parents[1] / "docs" / "results.md").read_text()
    row = next(line for line in text.splitlines() if line.startswith("| `element_kind` |"))
    documented = dict((int(c), k) for c, k in
                      (pair.split() for pair in row.split("|")[5].split(",")))
    assert documented == KIND_CODES
    assert list(KIND_CODES.values()) == list(KINDS)


def test_units_of_the_arrays(leafspring, tmp_path):
    import h5py
    xdmf = write_xdmf(leafspring, tmp_path / "u.xdmf")
    with h5py.File(tmp_path / "u.xdmf.h5", "r") as f:
        units = dict(f["units"].attrs)
    assert units["HINGE_deformation"] == "rad, 1, 1"
    assert units["HINGE_stress_resultant"] == "N m"
    assert units["BEAM_stress_resultant"] == "N" and units["torque"] == "N m"
    assert units["displacement"] == "m" and units["joint_angle"] == "rad"
    assert xdmf.is_file()
