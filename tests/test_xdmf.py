"""XDMF and VTK export: the XDMF parses, every HDF5 path it references exists with the stated
shape, and evaluating its data items gives back the results; VTK files read back with meshio.
(tests/test_export_paraview.py reads every kind's exports back with meshio and VTK.)"""
from __future__ import annotations

import os
import signal
import xml.etree.ElementTree as ET
from pathlib import Path

import h5py
import numpy as np
import pytest

from spacarpy.cli import main
from spacarpy.results import open_results
from spacarpy.results.export import write_vtk, write_xdmf

from helpers import run_and_kill


@pytest.fixture(scope="module")
def files(result_files):
    return result_files


def hdf_items(root):
    return [d for d in root.iter("DataItem") if d.get("Format") == "HDF"]


def check_references(xdmf: Path) -> dict:
    """Every HDF reference exists, with the Dimensions stated; returns {path: dataset shape}."""
    root = ET.parse(xdmf).getroot()
    assert root.tag == "Xdmf" and root.get("Version") == "3.0"
    shapes = {}
    for item in hdf_items(root):
        file_name, _, h5path = item.text.strip().partition(":")
        target = xdmf.parent / file_name              # relative to the .xdmf file
        with h5py.File(target, "r", swmr=True) as f:
            assert h5path in f, f"{item.text} does not exist"
            shape = tuple(int(v) for v in item.get("Dimensions").split())
            if len(shape) == 3 and shape[1] == 1:      # a Matrix attribute: n x 1 x c
                shape = (shape[0], shape[2])
            assert f[h5path].shape == shape, item.text
        shapes[item.text.strip()] = shape
    return shapes


def evaluate(item: ET.Element, base: Path) -> np.ndarray:
    """Evaluate an XDMF DataItem (HDF, XML, HyperSlab, Function "$0 - $1") with h5py."""
    dims = tuple(int(v) for v in item.get("Dimensions").split())
    kind = item.get("ItemType", "Uniform")
    if kind == "HyperSlab":
        sel, src = [c for c in item if c.tag == "DataItem"]
        start, stride, count = np.array(sel.text.split(), dtype=int).reshape(3, -1)
        data = evaluate(src, base)
        index = tuple(slice(a, a + s * c, s) for a, s, c in zip(start, stride, count))
        return data[index].reshape(dims)
    if kind == "Function":
        assert item.get("Function") == "$0 - $1"
        a, b = (evaluate(c, base) for c in item if c.tag == "DataItem")
        return (a - b).reshape(dims)
    if item.get("Format") == "XML":
        return np.array(item.text.split(), dtype=float).reshape(dims)
    file_name, _, h5path = item.text.strip().partition(":")
    with h5py.File(base / file_name, "r", swmr=True) as f:
        return f[h5path][()]


def grids(xdmf: Path):
    root = ET.parse(xdmf).getroot()
    series = root.find("Domain/Grid")
    assert series.get("CollectionType") == "Temporal"
    return series.findall("Grid")


def test_xdmf_of_a_static_run(files, tmp_path):
    out = tmp_path / "sub" / "bend.xdmf"               # elsewhere: references go up a level
    out.parent.mkdir()
    assert write_xdmf(files["bend"], out) == out
    check_references(out)
    res = open_results(files["bend"])
    s, m = res.static, res.model
    steps = grids(out)
    assert len(steps) == s.n_step
    np.testing.assert_array_equal([float(g.find("Time").get("Value")) for g in steps],
                                  s.load_factor)
    for k in (0, 5, 10):
        g = steps[k]
        topo = g.find("Topology")
        assert topo.get("TopologyType") == "Polyline" and topo.get("NodesPerElement") == "2"
        conn = evaluate(topo.find("DataItem"), out.parent).astype(int)
        np.testing.assert_array_equal(m.position_nodes[conn], m.element_nodes[:, [0, 2]])
        np.testing.assert_array_equal(evaluate(g.find("Geometry/DataItem"), out.parent),
                                      s.position(step=k))
        attrs = {a.get("Name"): a for a in g.findall("Attribute")}
        assert attrs["displacement"].get("AttributeType") == "Vector"
        np.testing.assert_array_equal(evaluate(attrs["displacement"].find("DataItem"),
                                               out.parent), s.displacement(step=k))
        assert attrs["normal_force"].get("Center") == "Cell"
        np.testing.assert_array_equal(
            evaluate(attrs["BEAM_stress_resultant"].find("DataItem"), out.parent)[:, 4],
            s.stress_resultant(step=k)[:, 4])
        np.testing.assert_array_equal(evaluate(attrs["element_id"].find("DataItem"),
                                               out.parent), m.elements)
        assert "max_von_mises_stress" not in attrs


def test_xdmf_with_stresses_and_modes(files, tmp_path):
    out = write_xdmf(files["frame"], tmp_path / "frame.xdmf")
    check_references(out)
    g = grids(out)[-1]
    attrs = {a.get("Name"): a for a in g.findall("Attribute")}
    np.testing.assert_array_equal(evaluate(attrs["max_von_mises_stress"].find("DataItem"),
                                           tmp_path),
                                  open_results(files["frame"]).static.max_von_mises_stress(
                                      step=-1))
    out = write_xdmf(files["column"], tmp_path / "column.xdmf")
    check_references(out)
    res = open_results(files["column"])
    for k, g in enumerate(grids(out)):
        attrs = {a.get("Name"): a for a in g.findall("Attribute")}
        assert {"eigenmode_1", "eigenmode_3", "buckling_mode_2"} <= set(attrs)
        np.testing.assert_array_equal(evaluate(attrs["eigenmode_2"].find("DataItem"), tmp_path),
                                      res.eigen.shape(mode=2, step=k).position)


@pytest.mark.slow
def test_xdmf_of_a_killed_run_holds_the_committed_steps(tmp_path):
    if not hasattr(signal, "SIGKILL"):
        pytest.skip("needs POSIX SIGKILL")
    out, _ = run_and_kill(tmp_path, n_elem=2, pause=0.02)
    partial = tmp_path / "killed.partial.h5"
    with pytest.raises(OSError):                       # the SWMR-write mark
        h5py.File(partial, "r")
    xdmf = write_xdmf(partial)
    sidecar = tmp_path / "killed.partial.xdmf.h5"
    n = open_results(partial).static.n_step
    with h5py.File(sidecar, "r") as f:                 # a plain HDF5 file ParaView can open
        assert f"step_{n - 1}/position" in f and f"step_{n}" not in f
    refs = check_references(xdmf)
    assert all(r.startswith("killed.partial.xdmf.h5:") for r in refs)
    assert len(grids(xdmf)) == open_results(partial).static.n_step == n


def test_export_command(files, tmp_path, capsys):
    out = tmp_path / "bend.xdmf"
    assert main(["export", str(files["bend"]), "--xdmf", "-o", str(out)]) == 0
    assert capsys.readouterr().out.strip() == str(out)
    check_references(out)
    assert main(["export", str(files["bend"]), "--xdmf", "--vtk", "-o", str(out)]) == 2


def test_vtk_export_reads_back(files, tmp_path):
    meshio = pytest.importorskip("meshio", reason="VTK export needs the optional meshio")
    pvd = write_vtk(files["frame"], tmp_path / "frame.pvd")
    res = open_results(files["frame"])
    s = res.static
    sets = ET.parse(pvd).getroot().findall("Collection/DataSet")
    assert len(sets) == s.n_step
    np.testing.assert_array_equal([float(d.get("timestep")) for d in sets], s.load_factor)
    mesh = meshio.read(tmp_path / sets[-1].get("file"))
    np.testing.assert_allclose(mesh.points, s.position(step=-1), rtol=0, atol=0)
    assert mesh.cells[0].type == "line"
    np.testing.assert_array_equal(mesh.cells[0].data, res.model.element_position_rows)
    np.testing.assert_allclose(mesh.point_data["displacement"], s.displacement(step=-1))
    np.testing.assert_allclose(mesh.cell_data["max_von_mises_stress"][0],
                               s.max_von_mises_stress(step=-1))


@pytest.mark.slow
def test_xdmf_of_a_run_being_written_says_so(tmp_path, caplog):
    """A partial file whose run still holds its output lock is 'being written', not
    'killed' (report N11); the lock is held here by this process for the killed run."""
    if not hasattr(signal, "SIGKILL"):
        pytest.skip("needs POSIX SIGKILL")
    from spacarpy.outputs import OutputLock, running_writer
    run_and_kill(tmp_path, n_elem=2, pause=0.02)
    partial = tmp_path / "killed.partial.h5"
    assert running_writer(partial) is None
    with caplog.at_level("WARNING"):
        write_xdmf(partial, tmp_path / "a.xdmf")
    assert "its writer was killed" in caplog.text
    caplog.clear()
    with OutputLock(tmp_path / "killed.h5"):
        assert running_writer(partial) == os.getpid()
        with caplog.at_level("WARNING"):
            write_xdmf(partial, tmp_path / "b.xdmf")
    assert f"it is being written by spacarpy process {os.getpid()}" in caplog.text
    assert "writer was killed" not in caplog.text
