"""Transient post-processing and plots that show what happened (issue 17, points 2 and 8).

Exported XDMF and VTK time series of the pendulum and the slider-crank hold every stored time
step with the positions of the HDF5 file; the pendulum's tip stays on its circle in them; the
shape plot's displacement magnification follows the documented rule and is stated in the
legend; rigid bodies and hinges are drawn where they are; frequency, buckling and
load-displacement plots put the prescribed quantity (mrad, N) on the load axis; output paths
are checked before any work. Needs matplotlib (the ``plot`` extra, part of ``test``).
"""
from __future__ import annotations

import re
import xml.etree.ElementTree as ET
from pathlib import Path

import h5py
import numpy as np
import pytest

pytest.importorskip("matplotlib", reason="plots need the optional matplotlib (pip install "
                                         "\"spacarpy[plot]\")")

from spacarpy.cli import main  # noqa: E402
from spacarpy.results import open_results  # noqa: E402
from spacarpy.results.export import write_vtk, write_xdmf  # noqa: E402
from spacarpy.results.plot import make_figure  # noqa: E402
from spacarpy.results.plot_shapes import (  # noqa: E402
    auto_scale,
    hinge_positions,
    rigid_segments,
)

DECKS = Path(__file__).resolve().parents[1] / "decks"


@pytest.fixture(scope="module")
def files(result_files):
    return result_files


@pytest.fixture(scope="module")
def crank(tmp_path_factory) -> Path:
    """decks/slider_crank_flexible.dat over its first 20 stored steps (0.02 s)."""
    tmp = tmp_path_factory.mktemp("crank")
    deck = tmp / "slider_crank.dat"
    deck.write_text((DECKS / "slider_crank_flexible.dat").read_text()
                    .replace("TIMESTEP 0.2 200", "TIMESTEP 0.02 20"))
    out = tmp / "crank.h5"
    assert main(["run", str(deck), "-o", str(out), "-q"]) == 0
    return out


@pytest.fixture(scope="module")
def leafspring(tmp_path_factory) -> Path:
    """decks/leafspring_guidance_misalignment.dat in 8 load steps (phi0 = 0 .. 2 mrad)."""
    tmp = tmp_path_factory.mktemp("leafspring")
    for name in ("leafspring_guidance_model.inc", "leafspring_guidance_data.inc"):
        (tmp / name).write_text((DECKS / name).read_text())
    deck = tmp / "leafspring.dat"
    deck.write_text((DECKS / "leafspring_guidance_misalignment.dat").read_text()
                    .replace("ITERSTEP 20 40 1e-10", "ITERSTEP 20 8 1e-10"))
    out = tmp / "leafspring.h5"
    assert main(["run", str(deck), "-o", str(out), "-q"]) == 0
    return out


def _evaluate(item, base: Path) -> np.ndarray:
    """An XDMF DataItem (HDF, XML, HyperSlab, Function "$0 - $1") evaluated with h5py."""
    dims = tuple(int(v) for v in item.get("Dimensions").split())
    if item.get("ItemType") == "HyperSlab":
        sel, src = [c for c in item if c.tag == "DataItem"]
        start, stride, count = np.array(sel.text.split(), dtype=int).reshape(3, -1)
        data = _evaluate(src, base)
        return data[tuple(slice(a, a + s * c, s) for a, s, c in
                          zip(start, stride, count))].reshape(dims)
    if item.get("ItemType") == "Function":
        a, b = (_evaluate(c, base) for c in item if c.tag == "DataItem")
        return (a - b).reshape(dims)
    if item.get("Format") == "XML":
        return np.array(item.text.split(), dtype=float).reshape(dims)
    name, _, path = item.text.strip().partition(":")
    with h5py.File(base / name, "r") as f:
        return f[path][()]


def _grids(xdmf: Path):
    series = ET.parse(xdmf).getroot().find("Domain/Grid")
    assert series.get("CollectionType") == "Temporal"
    return series.get("Name"), series.findall("Grid")


# --------------------------------------------------------------------------------------------
# export as a time series
# --------------------------------------------------------------------------------------------

def test_xdmf_of_the_pendulum_is_its_time_series(files, tmp_path):
    xdmf = write_xdmf(files["transient"], tmp_path / "pendulum.xdmf")
    tr, m = (res := open_results(files["transient"])).transient, res.model
    name, grids = _grids(xdmf)
    assert name == "transient" and len(grids) == tr.n_step == 11
    np.testing.assert_array_equal([float(g.find("Time").get("Value")) for g in grids], tr.time)
    pivot, tip = m.position_row(1), m.position_row(3)
    for k, g in enumerate(grids):
        xyz = _evaluate(g.find("Geometry/DataItem"), tmp_path)
        np.testing.assert_array_equal(xyz, tr.position(step=k))
        # the hinge on the ground (at the pivot) and the rigid rod (RBEAM 1, pivot to tip)
        # are the cells, and the rod's length stays 1 m
        cells = _evaluate(g.find("Topology/DataItem"), tmp_path).astype(int)
        np.testing.assert_array_equal(cells, [[pivot, pivot], [pivot, tip]])
        assert abs(np.linalg.norm(xyz[tip] - xyz[pivot]) - 1.0) < 1e-9
        attrs = {a.get("Name"): a for a in g.findall("Attribute")}
        np.testing.assert_array_equal(_evaluate(attrs["velocity"].find("DataItem"), tmp_path),
                                      tr.velocity(step=k))
        np.testing.assert_array_equal(_evaluate(attrs["displacement"].find("DataItem"),
                                                tmp_path), tr.displacement(step=k))
    assert np.linalg.norm(tr.displacement(node=3, step=-1)) > 0.04      # it did swing


def test_xdmf_and_vtk_of_the_slider_crank(crank, tmp_path):
    meshio = pytest.importorskip("meshio", reason="VTK export needs the optional meshio")
    res = open_results(crank)
    tr, m = res.transient, res.model
    name, grids = _grids(write_xdmf(crank, tmp_path / "crank.xdmf"))
    assert name == "transient" and len(grids) == tr.n_step == 21
    for k in (0, 10, 20):
        np.testing.assert_array_equal(_evaluate(grids[k].find("Geometry/DataItem"), tmp_path),
                                      tr.position(step=k))
    pvd = write_vtk(crank, tmp_path / "crank.pvd")
    sets = ET.parse(pvd).getroot().findall("Collection/DataSet")
    assert len(sets) == tr.n_step
    np.testing.assert_array_equal([float(d.get("timestep")) for d in sets], tr.time)
    mesh = meshio.read(tmp_path / sets[-1].get("file"))
    np.testing.assert_array_equal(mesh.points, tr.position(step=-1))
    np.testing.assert_array_equal(mesh.point_data["velocity"], tr.velocity(step=-1))
    assert len(mesh.cells[0].data) == 7                 # the crank and the 6 rod elements
    # the crank pin A stays at r = 0.15 m from the pivot O
    rows = m.position_row([1, 3])
    for k in range(tr.n_step):
        p = tr.position(step=k)[rows]
        assert abs(np.linalg.norm(p[1] - p[0]) - 0.15) < 1e-9


def test_output_paths_are_checked_before_any_work(tmp_path, capsys):
    missing = str(tmp_path / "missing.h5")       # not even opened: the path fails first
    for argv, message in (
            (["plot", missing, "-o", "/nonexist/b.png"], "/nonexist does not exist"),
            (["plot", missing, "-o", str(tmp_path / "b.xyz")], "unknown format '.xyz'"),
            (["plot", missing, "-o", str(tmp_path)], "unknown format"),
            (["plot", missing, "animate", "-o", str(tmp_path / "a.png")], ".gif, .mp4"),
            (["export", missing, "--xdmf", "-o", "/nonexist/a.xdmf"], "does not exist"),
            (["export", missing, "--vtk", "-o", "/nonexist/a.pvd"], "does not exist"),
            (["export", missing, "--vtk", "-o", str(tmp_path / "a.xdmf")], "end in .pvd")):
        assert main(argv) == 2, argv
        err = capsys.readouterr().err
        assert message in err and "Traceback" not in err, (argv, err)
    assert list(tmp_path.iterdir()) == []


def test_extract_and_history_of_a_transient_use_the_time(files):
    from spacarpy.results.tables import extract

    res = open_results(files["transient"])
    table = extract(res, "position", node=3)
    assert table.names[:2] == ["time", "step"]
    np.testing.assert_array_equal(np.asarray(table.columns[0], dtype=float),
                                  res.transient.time)
    fig = make_figure(res, "history", quantity="position", node=3)
    x, y = fig.axes[0].lines[1].get_data()              # y of node 3 against the time
    np.testing.assert_array_equal(x, res.transient.time)
    np.testing.assert_array_equal(y, res.transient.position(node=3)[:, 1])


# --------------------------------------------------------------------------------------------
# shapes: magnification, rigid bodies, hinges, animation
# --------------------------------------------------------------------------------------------

@pytest.mark.parametrize("u, size, factor", [
    (0.0007143, 0.12, 10.0),     # the leaf-spring guidance: 0.1 L / u = 16.8 -> 10
    (1e-3, 1.0, 100.0),          # 100 exactly
    (0.03, 1.0, 2.0),            # 3.33 -> 2
    (2.1e-6, 1.0, 20000.0),      # 47619 -> 2e4
    (0.05, 1.0, 1.0),            # visible at true scale
    (0.0, 1.0, 1.0)])
def test_auto_scale_rule(u, size, factor):
    assert auto_scale(u, size) == factor


@pytest.mark.slow
def test_leafspring_shape_states_its_magnification(leafspring):
    res = open_results(leafspring)
    s, m = res.static, res.model
    u_max = float(np.max(np.linalg.norm(s.displacement(step=-1), axis=-1)))
    factor = auto_scale(u_max, float(np.max(np.ptp(m.position_x0, axis=0))))
    assert factor == 10.0
    fig = make_figure(res, "shape")
    labels = [t.get_text() for t in fig.axes[0].get_legend().get_texts()]
    assert fig.spacarpy_scale == factor
    assert any(lab.endswith(", displacements x10") for lab in labels), labels
    assert "hinge" in labels
    fig = make_figure(res, "shape", scale=1)
    assert not any("displacements x" in t.get_text()
                   for t in fig.axes[0].get_legend().get_texts())


def test_pendulum_rod_and_hinge_are_drawn_where_they_are(files):
    res = open_results(files["transient"])
    tr = res.transient
    hinge = hinge_positions(res, tr.position(step=-1))
    np.testing.assert_array_equal(hinge, [[0.0, 0.0, 0.0]])          # the pivot, node 1
    bars, bodies = rigid_segments(res, tr.position(step=-1))
    np.testing.assert_array_equal(bars, [tr.position(step=-1)[res.model.position_row([1, 3])]])
    assert bodies == []                                 # one rod: a bar, nothing to fill
    ax = make_figure(res, "shape", time=0.1).axes[0]
    widths = sorted(c.get_linewidth()[0] for c in ax.collections)
    assert widths[-1] == 6.0                            # the rod: 3 x the 2.0 of a line


@pytest.mark.slow
def test_animation_of_the_pendulum(files, tmp_path, capsys):
    from PIL import Image

    out = tmp_path / "pendulum.gif"
    assert main(["plot", str(files["transient"]), "animate", "--frames", "6", "-o",
                 str(out)]) == 0
    with Image.open(out) as gif:
        assert gif.n_frames == 6
    assert capsys.readouterr().out.strip() == str(out)


# --------------------------------------------------------------------------------------------
# the prescribed quantity on the load axis; D13
# --------------------------------------------------------------------------------------------

@pytest.mark.slow
def test_leafspring_frequency_axis_is_the_misalignment_in_mrad(leafspring):
    res = open_results(leafspring)
    fig = make_figure(res, "frequency")
    ax = fig.axes[0]
    assert ax.get_xlabel() == "prescribed angle of HINGE 23 [mrad]"
    angles = 2e-3 * np.arange(9) / 8 * 1e3            # phi = 2 mrad in 8 steps
    for line in ax.lines[:3]:
        np.testing.assert_allclose(line.get_xdata(), angles, rtol=1e-9, atol=1e-9)
    lf_fig = make_figure(res, "frequency", x="load-factor")
    np.testing.assert_allclose(lf_fig.axes[0].lines[0].get_xdata(), np.arange(9) / 8,
                               rtol=1e-12)
    # the legend stands right of the axes, clear of every curve
    fig.canvas.draw()
    legend = ax.get_legend().get_window_extent()
    assert legend.x0 >= ax.get_window_extent().x1


def test_buckling_and_load_displacement_in_newtons(files):
    res = open_results(files["column"])               # DELXF 3 -2 0 0 in 4 steps
    ax = make_figure(res, "buckling").axes[0]
    assert ax.get_xlabel() == "DELXF force on node 3 [N]"
    np.testing.assert_allclose(ax.lines[0].get_xdata(), 2.0 * res.buckling.load_factor,
                               rtol=1e-15)
    ax = make_figure(res, "load-displacement", node=3).axes[0]
    assert ax.get_ylabel() == "DELXF force on node 3 [N]"
    np.testing.assert_allclose(ax.lines[0].get_ydata(), 2.0 * res.static.load_factor,
                               rtol=1e-15)


def test_driven_hinge_angle_in_mrad(files):
    res = open_results(files["driven"])                # DELINPE 10 1 0.5 (rad)
    ax = make_figure(res, "load-displacement", node=3).axes[0]
    assert ax.get_ylabel() == "prescribed angle of HINGE 10 [mrad]"
    np.testing.assert_allclose(ax.lines[0].get_ydata(), 500.0 * res.static.load_factor,
                               rtol=1e-9, atol=1e-9)


def test_history_load_factor_labels_stand_over_their_steps(files):
    res = open_results(files["bend"])
    fig = make_figure(res, "history", quantity="displacement", node=3)
    fig.canvas.draw()
    ax = fig.axes[0]
    top = [c for c in ax.child_axes if c.get_xlabel() == "load factor"][0]
    ticks = top.get_xticks()
    np.testing.assert_array_equal(ticks, ax.get_xticks())
    assert set(ticks) <= set(range(res.static.n_step))
    labels = [t.get_text() for t in top.get_xticklabels()]
    assert labels == [f"{res.static.load_factor[int(t)]:.3g}" for t in ticks]
    assert len(ticks) >= 3


def test_progress_bar_clears_its_line_for_a_log_line():
    import io

    from spacarpy.cli.run import _ProgressBar

    stream = io.StringIO()
    bar = _ProgressBar(stream)
    bar(0.5, 1.0)
    assert bar.clear_line() is True
    stream.write("WARNING: something\n")
    bar(1.0, 1.0)
    bar.close()
    lines = re.split(r"[\r\n]", stream.getvalue())
    assert "WARNING: something" in lines               # on its own line, not after the bar


@pytest.mark.slow
def test_history_of_a_start_static_run_is_the_time_history(tmp_path):
    """D2: a transient after a static preload (START static) plots its time steps, not only
    the preload steps."""
    out = tmp_path / "vibration.h5"
    assert main(["run", str(DECKS / "cantilever_free_vibration.dat"), "--set", "periods=0.1",
                 "-o", str(out), "-q"]) == 0
    res = open_results(out)
    assert res.static.n_step >= 2 and res.transient.n_step == 11
    ax = make_figure(res, "history", quantity="displacement", node=3).axes[0]
    assert ax.get_xlabel() == "time [s]"
    np.testing.assert_array_equal(ax.lines[1].get_xdata(), res.transient.time)
    np.testing.assert_array_equal(ax.lines[1].get_ydata(),
                                  res.transient.displacement(node=3)[:, 1])
    assert "static preload steps" in ax.get_title()
