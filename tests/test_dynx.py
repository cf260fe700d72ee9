"""DYNX: nodal coordinates as degrees of freedom (SPACAR's dynamic class, issue 33 item 2).

The same model written twice, once with the degree of freedom a deformation (DYNE on the
joint) and once with it a nodal coordinate (the joint RLSE, the node's coordinate DYNX), gives
the same results: statics, transient, eigen, state space and mode 3. Where the coordinate and
the deformation are the same quantity (the angle of a planar hinge whose other node is fixed,
the x of a node on a spring along x) even the linearized matrices agree entry by entry. The
deck checks (a coordinate both fixed and DYNX, ...) and the count check (the DYNX coordinates
and DYNE modes are exactly the degrees of freedom) are tested with their messages.
"""
from __future__ import annotations

from pathlib import Path

import h5py
import numpy as np
import pytest

from spacarpy.cli import main
from spacarpy.deck import job_from_text
from spacarpy.errors import EXIT_INPUT, EXIT_MODEL, DeckError, ModelError
from spacarpy.results import validate_file
from spacarpy.run import run_model

ROOT = Path(__file__).resolve().parents[1]
CORPUS = ROOT.parent / "shared" / "spacar-decks"

# A planar pendulum: a rigid PLBEAM (1 m) on a PLHINGE with a torsion spring, a tip mass and
# a tip load; its one degree of freedom is the hinge angle (DYNE 2 1) or the angle of
# orientation node 2 (RLSE 2 1 and DYNX 2 1): the same quantity, as node 5 is fixed.
PENDULUM = """\
X 1 0 0
X 3 1 0
PLBEAM 1 1 2 3 4
PLHINGE 2 5 2
FIX 1
FIX 5
{dof}
END
HALT
ESTIFF 2 3.0
XM 3 2.0
XM 2 0.1
XF 3 0 -1
ITERSTEP 20 4 1e-12 1 3 0
TIMESTEP 1 100
END
END
"""
DYNE = "DYNE 2 1"
DYNX = "RLSE 2 1\nDYNX 2 1"


def _run(tmp_path, text, name, mode=None):
    if mode is not None:
        text = f"MODE {mode}\n" + text
    job = job_from_text(text, f"{name}.dat")
    out = tmp_path / f"{name}.h5"
    run_model(job.model, job.settings, out)
    return h5py.File(out, "r")


def test_statics_the_same_with_dynx_as_with_dyne(tmp_path):
    with _run(tmp_path, PENDULUM.format(dof=DYNE), "e") as a, \
            _run(tmp_path, PENDULUM.format(dof=DYNX), "x") as b:
        pa, pb = a["static/position"][()], b["static/position"][()]
        phi = a["static/elements/PLHINGE/deformation"][-1, 0, 0]
    np.testing.assert_allclose(pb, pa, rtol=0, atol=1e-13)
    # equilibrium of the spring and the tip load: k phi = -F L cos(phi)
    assert abs(3.0 * phi + 1.0 * np.cos(phi)) < 1e-10 and phi < -0.2


def test_transient_the_same_with_dynx_as_with_dyne(tmp_path):
    with _run(tmp_path, PENDULUM.format(dof=DYNE), "e", "transient") as a, \
            _run(tmp_path, PENDULUM.format(dof=DYNX), "x", "transient") as b:
        pa, pb = a["transient/position"][()], b["transient/position"][()]
        va, vb = a["transient/velocity"][()], b["transient/velocity"][()]
    assert pa.shape[0] == 101
    assert np.ptp(pa[:, 1, 1]) > 0.1                      # it swings
    np.testing.assert_allclose(pb, pa, rtol=0, atol=1e-12)
    np.testing.assert_allclose(vb, va, rtol=0, atol=1e-11)


def test_fis_catheter_decks_get_past_dynx():
    """The corpus decks with DYNX (120 and 36 of them) are SPACAR-consistent: without their
    user routines their DYNX coordinates are exactly their degrees of freedom."""
    if not CORPUS.is_dir():
        pytest.skip(f"the SPACAR deck corpus {CORPUS} is absent")
    from spacarpy.solvers.statics.dynamic_coords import dynamic_analysis
    from spacarpy.solvers.statics.equilibrium import StaticProblem
    for name, n in (("fis_flex_cat_s_3d.dat", 120), ("fis_rig_cat_s_3d.dat", 36)):
        text = "\n".join(line for line in (CORPUS / name).read_text().splitlines()
                         if not line.startswith(("USERSIG", "USERINP")))
        job = job_from_text(text, name)
        assert len(job.model.dynamic_coords) == n
        dc = dynamic_analysis(StaticProblem(job.model))
        assert dc.ok and dc.dof == n and dc.n_dynx == n and dc.n_dyne == 0


BASE = "X 1 0 0 0\nX 2 1 0 0\nTRUSS 1 1 2\nFIX 1\n"
DATA = "END\nHALT\nESTIFF 1 100\nXM 2 2\nXF 2 5 0 0\nEND\nEND\n"


@pytest.mark.parametrize("lines, where, text", [
    ("FIX 2 2 3\nDYNX 2 2\n", (6, 8),
     "DYNX: coordinate 2 of node 2 is also fixed (FIX at line 5)"),
    ("FIX 2 2 3\nINPUTX 2 1\nDYNX 2 1\n", (7, 8),
     "DYNX: coordinate 1 of node 2 is also prescribed (INPUTX at line 6)"),
    ("FIX 2 2 3\nKINX 2 1\nDYNX 2 1\n", (7, 8),
     "DYNX: coordinate 1 of node 2 is also kinematic (KINX)"),
    ("FIX 2 2 3\nDYNX 2 1\nDYNX 2 1\n", (7, 8),
     "DYNX: coordinate 1 of node 2 is declared dynamic twice (lines 6 and 7)"),
    ("FIX 2 2 3\nDYNX 2 4\n", (6, 8), "DYNX: node 2 is a position node with coordinates 1 "
                                      "to 3, got 4"),
    ("FIX 2 2 3\nDYNX 7 1\n", (6, 6), "DYNX: node 7 is not defined"),
    ("FIX 2 2 3\nRLSE 1 1\nEND\nHALT\nDYNX 2 1\nEND\nEND\n", (9, 1),
     "DYNX belongs in the kinematics module"),
])
def test_deck_errors_name_node_coordinate_and_place(lines, where, text):
    deck = BASE + lines + ("" if "END" in lines else "RLSE 1 1\n" + DATA)
    with pytest.raises(DeckError) as info:
        job_from_text(deck, "d.dat")
    items = [(loc.line, loc.column, msg) for loc, msg, _ in info.value.items]
    assert any((ln, col) == where and msg.startswith(text) for ln, col, msg in items), items


def test_a_fixed_planar_angle_cannot_be_dynx():
    text = PENDULUM.format(dof="RLSE 2 1\nDYNX 5 1")
    with pytest.raises(DeckError, match=r"d.dat:8:8: error: DYNX: coordinate 1 of node 5 is "
                                        r"also fixed \(FIX at line 6\)"):
        job_from_text(text, "d.dat")


def test_over_determined_names_the_dependent_entries(tmp_path):
    text = BASE + "FIX 2 2 3\nDYNE 1 1\nDYNX 2 1\n" + DATA
    job = job_from_text(text, "over.dat")
    with pytest.raises(ModelError) as info:
        run_model(job.model, job.settings, tmp_path / "o.h5")
    msg = str(info.value)
    assert msg.startswith("over.dat:7:1: the DYNX coordinates and DYNE modes must be")
    assert "the model has 1 degree of freedom, the deck gives 1 DYNX coordinate and 1 DYNE " \
           "mode" in msg
    assert "over-determined: TRUSS 1 mode 1 depends on the others" in msg
    assert "mechanism" not in msg


def test_under_determined_names_the_nodes_that_move(tmp_path, capsys):
    # the pendulum of two rigid links: two degrees of freedom, one DYNX
    text = ("X 1 0 0\nX 3 1 0\nX 6 2 0\nPLBEAM 1 1 2 3 4\nPLHINGE 2 5 2\n"
            "PLBEAM 3 3 7 6 8\nPLHINGE 4 4 7\nFIX 1\nFIX 5\nRLSE 2 1\nRLSE 4 1\nDYNX 2 1\n"
            "END\nHALT\nESTIFF 2 1\nESTIFF 4 1\nXF 6 0 -1\nEND\nEND\n")
    deck = tmp_path / "under.dat"
    deck.write_text(text)
    assert main(["run", str(deck), "-o", str(tmp_path / "u.h5")]) == EXIT_MODEL
    err = capsys.readouterr().err
    assert f"{deck}:12:1: the DYNX coordinates and DYNE modes must be the model's degrees " \
           "of freedom" in err
    assert "the model has 2 degrees of freedom, the deck gives 1 DYNX coordinate and 0 DYNE " \
           "modes; under-determined: 1 motion changes no DYNX coordinate and no DYNE mode " \
           "(nodes that move: 6, 7, 8)" in err
    assert "Traceback" not in err
    # mode 0 reports it instead of refusing
    assert main(["run", str(deck), "--mode", "0"]) == 0
    out = capsys.readouterr().out
    assert "dynamic (DYNX)      1: DYNX 2 1" in out
    assert "SPACAR's DOF        1 DYNX + 0 DYNE = 1, the model has 2" in out


def test_check_lists_the_dynx_coordinates(tmp_path, capsys):
    deck = tmp_path / "p.dat"
    deck.write_text(PENDULUM.format(dof=DYNX))
    assert main(["check", str(deck)]) == 0
    out = capsys.readouterr().out
    assert "dynamic (DYNX)      1 coordinate: node 2 (1); with 0 DYNE modes, 1 degrees of " \
           "freedom (SPACAR's)" in out
    assert main(["run", str(deck), "--mode", "0"]) == 0
    out = capsys.readouterr().out
    assert "SPACAR's DOF        1 DYNX + 0 DYNE = 1 of 1: they are the degrees of freedom" in out


def test_input_exit_code_for_deck_errors(tmp_path, capsys):
    deck = tmp_path / "bad.dat"
    deck.write_text(BASE + "FIX 2\nDYNX 2 1\nRLSE 1 1\n" + DATA)
    assert main(["run", str(deck), "-o", str(tmp_path / "b.h5")]) == EXIT_INPUT
    err = capsys.readouterr().err
    assert f"{deck}:6:8: error: DYNX: coordinate 1 of node 2 is also fixed" in err


def _matrices(f):
    return {n: f[f"state_space/{n}"][()] for n in ("M0", "C0", "K0", "A", "B", "C")}


def test_state_space_in_the_dynx_coordinate(tmp_path):
    """Mode 9 (with an input and outputs): the hinge angle and the node's angle are the
    same degree of freedom, so every matrix agrees; the names and the schema 2.16 dof_node
    say which degree of freedom it is."""
    io = "END\nHALT\nINPUTF 1 3 2\nOUTX 1 3 2\nOUTXP 2 2 1\nEND\nEND\n"
    ta, tb = (PENDULUM.format(dof=d).replace("END\nEND\n", io) for d in (DYNE, DYNX))
    with _run(tmp_path, ta, "e", 9) as a, _run(tmp_path, tb, "x", 9) as b:
        ma, mb = _matrices(a), _matrices(b)
        assert b["state_space/state_name"].asstr()[()].tolist() == [
            "node 2 coordinate 1", "rate of node 2 coordinate 1"]
        assert b["state_space/dof_node"][()].tolist() == [2]
        assert b["state_space/dof_element"][()].tolist() == [0]
        assert b["state_space/dof_mode"][()].tolist() == [1]
        assert "dof_node" not in a["state_space"]
        assert b.attrs["schema_version"].tolist() >= [2, 16]
        phi = a["static/elements/PLHINGE/deformation"][:, 0, 0]
    for n in ma:
        np.testing.assert_allclose(mb[n], ma[n], rtol=1e-12, atol=1e-13)
    assert validate_file(tmp_path / "x.h5", require_complete=True) == []
    # V = k phi^2 / 2 + P L sin(phi) with P = -k phi / cos(phi) at equilibrium: M0 = m L^2 + J,
    # K0 = V'' = k (1 + phi tan(phi)) (the load's geometric stiffness in it)
    assert phi.min() < -0.2
    np.testing.assert_allclose(mb["M0"][:, 0, 0], 2.0 + 0.1, rtol=1e-12)
    np.testing.assert_allclose(mb["K0"][:, 0, 0], 3.0 * (1 + phi * np.tan(phi)), rtol=1e-9)


def test_eigen_the_same_with_dynx_as_with_dyne(tmp_path):
    with _run(tmp_path, PENDULUM.format(dof=DYNE), "e", "eigen") as a, \
            _run(tmp_path, PENDULUM.format(dof=DYNX), "x", "eigen") as b:
        fa, fb = a["eigen/frequency"][()], b["eigen/frequency"][()]
        phi = a["static/elements/PLHINGE/deformation"][-1, 0, 0]
    np.testing.assert_allclose(fb, fa, rtol=1e-12)
    exact = np.sqrt(3.0 * (1 + phi * np.tan(phi)) / 2.1) / (2 * np.pi)
    np.testing.assert_allclose(fb.ravel()[0], exact, rtol=1e-9)


def test_mode_3_along_the_swing_the_same_with_dynx(tmp_path):
    """Mode 3 (the transient, linearized at every stored step): the same matrices."""
    ta, tb = (PENDULUM.format(dof=d).replace("TIMESTEP 1 100", "TIMESTEP 0.5 20")
              .replace("XF 3 0 -1", "XF 3 0 -20") for d in (DYNE, DYNX))
    with _run(tmp_path, ta, "e", 3) as a, _run(tmp_path, tb, "x", 3) as b:
        ma, mb = _matrices(a), _matrices(b)
        assert b["state_space/dof_node"][()].tolist() == [2]
        assert a["state_space/step"].size == b["state_space/step"].size == 21
        phi = a["transient/elements/PLHINGE/deformation"][:, 0, 0]
    assert np.ptp(phi) > 0.1                                    # it swings
    # V = k phi^2 / 2 + 20 L sin(phi) (the tip load -20 along y): M0 = m L^2 + J = 2.1,
    # C0 = 0, K0 = k - 20 sin(phi(t)); both to the finite differences' error of the
    # trajectory linearization (Phi' and Phi'' by central differences: about 1e-7 here)
    for m in (ma, mb):
        np.testing.assert_allclose(m["M0"][:, 0, 0], 2.1, rtol=1e-12)

        print("C0", m["C0"][:, 0, 0], "K0err", m["K0"][:, 0, 0] - (3.0 - 20 * np.sin(phi)))
    for n in ma:
        print(n, np.abs(mb[n] - ma[n]).max(initial=0), np.abs(ma[n]).max(initial=0))
        np.testing.assert_allclose(mb[n], ma[n], rtol=0, atol=1e-5)


# A spatial pendulum: a rigid rod (RBEAM) on a HINGE about z with a torsion spring; the
# degree of freedom is the hinge angle (DYNE) or the Euler parameter lambda3 of the rod's
# orientation node (DYNX 4 4). At the identity lambda3 = sin(phi/2), so dphi = 2 dlambda3:
# M0 and K0 in lambda3 are 4 times those in phi, the frequencies the same.
SPATIAL = """X 1 0 0 0
X 3 1 0 0
RBEAM 1 1 4 3 0 1 0
HINGE 10 2 4 0 0 1
FIX 1
FIX 2
{dof}
END
HALT
EM 1 2
ESTIFF 10 5
END
END
"""


def test_spatial_euler_parameter_as_degree_of_freedom(tmp_path):
    with _run(tmp_path, SPATIAL.format(dof="DYNE 10 1"), "e", 9) as a, \
            _run(tmp_path, SPATIAL.format(dof="RLSE 10 1\nDYNX 4 4"), "x", 9) as b:
        ma, mb = _matrices(a), _matrices(b)
    np.testing.assert_allclose(ma["M0"][0], [[2.0 / 3.0]], rtol=1e-12)     # m L^2 / 3
    np.testing.assert_allclose(ma["K0"][0], [[5.0]], rtol=1e-12)
    np.testing.assert_allclose(mb["M0"], 4 * ma["M0"], rtol=1e-12)
    np.testing.assert_allclose(mb["K0"], 4 * ma["K0"], rtol=1e-12)
    with _run(tmp_path, SPATIAL.format(dof="DYNE 10 1"), "e2", "eigen") as a, \
            _run(tmp_path, SPATIAL.format(dof="RLSE 10 1\nDYNX 4 4"), "x2", "eigen") as b:
        fa, fb = a["eigen/frequency"][()], b["eigen/frequency"][()]
    np.testing.assert_allclose(fb, fa, rtol=1e-12)
    np.testing.assert_allclose(fa.ravel()[0], np.sqrt(5.0 / (2.0 / 3.0)) / (2 * np.pi),
                               rtol=1e-9)


@pytest.mark.parametrize("deck, dyne, dynx, factor", [
    (PENDULUM.replace("XF 3 0 -1\n", ""), DYNE, DYNX, 1.0),
    (SPATIAL, "DYNE 10 1", "RLSE 10 1\nDYNX 4 4", 4.0),
])
def test_mode_3_about_the_steady_state_with_dynx(tmp_path, deck, dyne, dynx, factor):
    """Mode 3 with TIMESTEP 0 0 (the linearization about the initial steady state, here at
    rest): the DYNX coordinate gives the DYNE model's matrices (times 4 for lambda3 against
    the angle), and its name."""
    steady = deck.replace("TIMESTEP 1 100", "").replace("END\nEND\n", "TIMESTEP 0 0\nEND\nEND\n")
    with _run(tmp_path, steady.format(dof=dyne), "e", 3) as a, \
            _run(tmp_path, steady.format(dof=dynx), "x", 3) as b:
        ma, mb = _matrices(a), _matrices(b)
        names = b["state_space/state_name"].asstr()[()].tolist()
        node = b["state_space/dof_node"][()].tolist()
    assert names[0].startswith("node ") and " coordinate " in names[0]
    assert node == [int(names[0].split()[1])]
    np.testing.assert_allclose(mb["M0"], factor * ma["M0"], rtol=1e-10)
    np.testing.assert_allclose(mb["K0"], factor * ma["K0"], rtol=1e-8)
    np.testing.assert_allclose(mb["C0"], 0.0, atol=1e-12)
    mass, spring = (2.1, 3.0) if factor == 1.0 else (2.0 / 3.0, 5.0)
    np.testing.assert_allclose(ma["M0"][0], [[mass]], rtol=1e-10)
    np.testing.assert_allclose(ma["K0"][0], [[spring]], rtol=1e-8)


def test_arc_length_and_buckling_the_same_with_dynx(tmp_path):
    """The two-bar truss (a snap-through) followed by arc length and its buckling
    multipliers: with its apex's x and y as DYNX instead of the bars' elongations as DYNE,
    the same path, critical points and multipliers."""
    text = (ROOT / "decks" / "two_bar_truss_arclength.dat").read_text()
    assert "DYNE 1:2 1\n" in text
    x_text = text.replace("DYNE 1:2 1\n", "RLSE 1:2 1\nDYNX 3 1 2\n")
    with _run(tmp_path, text, "e") as a, _run(tmp_path, x_text, "x") as b:
        pa, pb = a["static/position"][()], b["static/position"][()]
        la, lb = a["static/load_factor"][()], b["static/load_factor"][()]
        ca, cb = a["critical/load_factor"][()], b["critical/load_factor"][()]
    assert pa.shape[0] > 10 and ca.size >= 1
    np.testing.assert_allclose(pb, pa, rtol=0, atol=1e-12)
    np.testing.assert_allclose(lb, la, rtol=0, atol=1e-12)
    np.testing.assert_allclose(cb, ca, rtol=1e-10)
    sa = text.replace("ARCLENGTH 400 0.02\n", "").replace("ITERSTEP 20 20", "ITERSTEP 20 2")
    sb = sa.replace("DYNE 1:2 1\n", "RLSE 1:2 1\nDYNX 3 1 2\n")
    with _run(tmp_path, sa, "be", "buckling") as a, _run(tmp_path, sb, "bx", "buckling") as b:
        ma, mb = a["buckling/load_multiplier"][()], b["buckling/load_multiplier"][()]
    assert np.isfinite(ma).any()
    np.testing.assert_allclose(mb, ma, rtol=1e-10)


def test_the_deck_writer_keeps_the_dynx_lines():
    from spacarpy.deck.writer import model_to_deck
    # deck order kept (the reading only: these two would be over-determined)
    job = job_from_text(SPATIAL.format(dof="RLSE 10 1\nDYNX 4 4\nDYNX 3 2"), "w.dat")
    text = model_to_deck(*job)
    assert "DYNX 4 4\n" in text and "DYNX 3 2\n" in text
    again = job_from_text(text, "again.dat")
    assert [(d.node, d.coord) for d in again.model.dynamic_coords] == [(4, 4), (3, 2)]
