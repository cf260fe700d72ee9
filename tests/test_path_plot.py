"""``spacarpy plot FILE path`` and ``spacarpy extract FILE path`` (docs/path.md): the numbers
of the table are the file's, the load axis is the reaction of a prescribed coordinate or the
DELXF force, critical points are named and marked where the file has them, and requests the
file cannot answer exit with 2."""
from __future__ import annotations

import csv
import io

import h5py
import numpy as np
import pytest

from spacarpy.cli import main
from spacarpy.deck import job_from_text
from spacarpy.errors import EXIT_INPUT
from spacarpy.results import open_results
from spacarpy.results.plot import make_figure
from spacarpy.results.schema import CRITICAL_POINT_NAMES
from spacarpy.run import run_job

from helpers import REPO

PNG = b"\x89PNG\r\n\x1a\n"


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    d = tmp_path_factory.mktemp("path")
    out = {}
    for name in ("lees_frame_load", "lees_frame"):
        out[name] = d / f"{name}.h5"
        text = (REPO / "decks" / f"{name}.dat").read_text().replace("SET m 2", "SET m 1")
        run_job(job_from_text(text, f"{name}.dat"), out[name])   # 20 elements: quicker
    # an arc-length run: its critical points are stored in /critical
    out["critical"] = d / "critical.h5"
    run_job(job_from_text((REPO / "decks" / "two_bar_truss_arclength.dat").read_text(),
                          "two_bar_truss_arclength.dat"), out["critical"])
    return out


def _csv(capsys, *argv):
    assert main(["extract", *map(str, argv), "--csv"]) == 0
    rows = list(csv.reader(io.StringIO(capsys.readouterr().out)))
    return rows[0], rows[1:]


def test_extract_path_of_a_displacement_controlled_run_gives_the_reaction(runs, capsys):
    head, rows = _csv(capsys, runs["lees_frame"], "path", "--node", "5", "--dof", "y")
    assert head == ["step", "load_factor", "uy [m]", "reaction_Fy [N]", "critical"]
    with open_results(runs["lees_frame"]) as res:
        s = res.static
        u, r = s.displacement(node=5)[:, 1], s.reaction(node=5)[:, 1]
        assert len(rows) == s.n_step == 30
        np.testing.assert_array_equal([float(x[2]) for x in rows], u)     # bit for bit
        np.testing.assert_array_equal([float(x[3]) for x in rows], r)
        np.testing.assert_array_equal([float(x[1]) for x in rows], s.load_factor)
    assert {x[4] for x in rows} == {""}                  # no critical points in this file
    assert float(rows[-1][2]) == pytest.approx(-58.0, abs=1e-9)   # the prescribed drop


def test_extract_path_of_a_load_controlled_run_gives_the_delxf_force(runs, capsys):
    head, rows = _csv(capsys, runs["lees_frame_load"], "path", "--node", "5", "--dof", "y",
                      "--step", "-1")
    assert head == ["step", "load_factor", "uy [m]", "load [N]", "critical"]
    assert len(rows) == 1 and float(rows[0][3]) == pytest.approx(1.8, rel=1e-12)


def test_path_names_and_marks_the_stored_critical_points(runs, capsys, tmp_path):
    with h5py.File(runs["critical"], "r") as f:
        steps = f["critical/step"][()].tolist()
        names = [CRITICAL_POINT_NAMES[c] for c in f["critical/point_type"][()]]
    # the two limit points of the von Mises truss, a maximum then a minimum of the load
    assert names == ["limit point (load maximum)", "limit point (load minimum)"]
    _, rows = _csv(capsys, runs["critical"], "path", "--node", "3", "--dof", "y")
    assert [(int(x[0]), x[4]) for x in rows if x[4]] == list(zip(steps, names))
    from spacarpy.results.plot import make_figure
    with open_results(runs["critical"]) as res:
        fig = make_figure(res, "path", node=3, dof="y")
        for step, name in zip(steps, names):
            marked = [ln for ln in fig.axes[0].lines if ln.get_label() == name]
            assert len(marked) == 1
            np.testing.assert_array_equal(marked[0].get_xdata(),
                                          res.static.displacement(node=3)[[step], 1])


def test_plot_path_writes_a_png(runs, tmp_path, capsys):
    pytest.importorskip("matplotlib", reason="plots need the optional matplotlib")
    out = tmp_path / "path.png"
    assert main(["plot", str(runs["lees_frame"]), "path", "--node", "5", "--dof", "y", "-o",
                 str(out)]) == 0
    assert capsys.readouterr().out.strip() == str(out)
    assert out.read_bytes()[:8] == PNG and out.stat().st_size > 10_000


def test_path_defaults_and_refusals(runs, capsys):
    # default node: the loaded node (DELXF 5 0 -1.8 0), its component along the load (y)
    head, rows = _csv(capsys, runs["lees_frame_load"], "path")
    with open_results(runs["lees_frame_load"]) as res:
        assert head[2] == "uy [m]"
        np.testing.assert_array_equal([float(x[2]) for x in rows],
                                      res.static.displacement(node=5)[:, 1])
        assert res.model.position_nodes[np.argmax(np.linalg.norm(
            res.static.displacement(step=-1), axis=-1))] != 5     # not the node moving most
        title = make_figure(res, "path").axes[0].get_title()
        assert title.endswith("equilibrium path, node 5 (the loaded node), uy"), title
    # displacement control (INPUTX 5 2): the prescribed coordinate, and its reaction
    head, rows = _csv(capsys, runs["lees_frame"], "path")
    assert head[2:4] == ["uy [m]", "reaction_Fy [N]"]
    with open_results(runs["lees_frame"]) as res:
        np.testing.assert_array_equal([float(x[2]) for x in rows],
                                      res.static.displacement(node=5)[:, 1])
    assert main(["extract", str(runs["lees_frame"]), "path", "--node", "6"]) == EXIT_INPUT
    assert "orientation node" in capsys.readouterr().err
    assert main(["extract", str(runs["lees_frame"]), "path", "--node", "99"]) == EXIT_INPUT
    assert main(["extract", str(runs["lees_frame"]), "path", "--dof", "w"]) == EXIT_INPUT
    assert "--dof" in capsys.readouterr().err
