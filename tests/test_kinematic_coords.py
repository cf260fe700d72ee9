"""Kinematic coordinates (KINE, KINX), the third-module INPUTS with numbering gaps, and the
stray dynamics-module INPUTE (issue 32, docs/rolling.md "Kinematic coordinates", docs/deck.md).

Closed forms: a rigid rod of length L on a hinge with a torsion spring k and a tip mass m
has, for a unit torque sigma on the hinge (INPUTS), the static angle -1/k (ESIG's sign: a
positive stress resultant turns the hinge negative) and tip displacement -L/k; a unit tip
force (INPUTF) along y gives the angle L/k and the tip displacement L^2/k; its pole is
i sqrt(k / (m L^2)). The knife edge in the plane (x, y, heading th) with the lateral slip
held, -sin(th) x' + cos(th) y' = 0, has F_p and S F_p by hand: with x and th dynamic, y is a
valid kinematic coordinate (S F_p = cos th); with x and y dynamic the heading is not
(S F_p = 0: its rate is free).
"""
from __future__ import annotations

import logging

import numpy as np
import pytest
import scipy.sparse as sp

from spacarpy.cli import main
from spacarpy.deck import job_from_text
from spacarpy.elements.registry import KINDS
from spacarpy.errors import EXIT_MODEL, DeckError, ModelError
from spacarpy.model import KINEMATIC
from spacarpy.results import open_results
from spacarpy.run import run_model
from spacarpy.solvers.statics.nonholonomic import KinematicSetup, kinematic_map

_ROD = """X 1 0 0 0
X 3 {L} 0 0
RBEAM 1 1 4 3 0 1 0
HINGE 10 2 4 0 0 1
{classes}
FIX 1
FIX 2
END
HALT
ESTIFF 10 {k}
XM 3 {m}
{data}
END
HALT
{signals}
END
END
"""

L, K, M = 2.0, 3.0, 1.5


def _rod(classes="DYNE 10 1", data="MODE 9", signals=""):
    return _ROD.format(L=L, k=K, m=M, classes=classes, data=data, signals=signals)


# -- deck errors ------------------------------------------------------------------------------

@pytest.mark.parametrize("classes, message", [
    ("DYNE 10 1\nKINE 10 1",
     "d.dat:6:9: error: KINE: deformation 1 of element 10 is also listed in DYNE (line 5); a "
     "mode is either dynamic or kinematic"),
    ("RLSE 10 1\nKINE 10 1",
     "d.dat:6:9: error: KINE: deformation 1 of element 10 is also listed in RLSE (line 5)"),
    ("INPUTE 10 1\nKINE 10 1",
     "d.dat:6:9: error: KINE: deformation 1 of element 10 is also prescribed (INPUTE at line "
     "5); a mode is either prescribed or kinematic"),
    ("DYNE 10 1\nKINE 10 4", "d.dat:6:9: error: KINE: element 10 is a HINGE with deformation "
                            "modes 1 to 3, got 4"),
    ("DYNE 10 1\nKINE 11 2", "d.dat:6:6: error: KINE: element 11 is not defined"),
    ("DYNE 10 1\nKINE 10 2\nKINE 10 2",
     "d.dat:7:9: error: KINE: deformation 2 of element 10 is declared kinematic twice (lines "
     "6 and 7)"),
    ("DYNE 10 1\nKINX 1 2", "d.dat:6:8: error: KINX: coordinate 2 of node 1 is also fixed (FIX "
                            "at line 7); a kinematic coordinate moves"),
    ("DYNE 10 1\nINPUTX 3 2\nKINX 3 2",
     "d.dat:7:8: error: KINX: coordinate 2 of node 3 is also prescribed (INPUTX at line 6)"),
    ("DYNE 10 1\nKINX 3 4", "d.dat:6:8: error: KINX: node 3 is a position node with "
                           "coordinates 1 to 3, got 4"),
    ("DYNE 10 1\nKINX 4 5", "KINX: node 4 is an orientation node with coordinates 1 to 4, got 5"),
    ("DYNE 10 1\nKINX 7 1", "d.dat:6:6: error: KINX: node 7 is not defined"),
    ("DYNE 10 1\nKINX 3 1 1", "d.dat:6:10: error: KINX: coordinate 1 of node 3 is declared "
                             "kinematic twice (lines 6 and 6)"),
])
def test_kine_kinx_deck_errors(classes, message):
    with pytest.raises(DeckError) as err:
        job_from_text(_rod(classes=classes), "d.dat")
    assert message in str(err.value)


def test_kine_marks_the_mode_kinematic_and_kinx_is_listed():
    model = job_from_text(_rod(classes="DYNE 10 1\nKINE 10 2\nKINX 3 1", data=""),
                          "d.dat").model
    assert model.elements["HINGE"].def_class.tolist() == [[1, KINEMATIC, 0]]
    assert [(k.name, k.loc.line) for k in model.kinematic] == [("KINE 10 2", 6),
                                                                ("KINX 3 1", 7)]


def test_kinematic_coordinates_without_slips_are_a_model_error(tmp_path, capsys):
    """Until a kind with slips (WHEEL) is in the model, any KINE/KINX is the count error,
    naming the lines."""
    deck = tmp_path / "k.dat"
    deck.write_text(_rod(classes="RLSE 10 1\nKINE 10 2\nKINX 3 3", data="MODE 0"))
    assert main(["run", str(deck), "--mode", "0"]) == EXIT_MODEL
    err = capsys.readouterr().err
    assert ("0 slips held, 2 kinematic coordinates declared (KINE 10 2 (line 6); KINX 3 3 "
            "(line 7)): the slips need 0 kinematic coordinates (KINE/KINX)") in err
    assert "Traceback" not in err


# -- the stray dynamics-module INPUTE ----------------------------------------------------------

def test_stray_inpute_on_a_dyne_mode_is_a_warning_and_ignored(caplog):
    text = _rod(data="INPUTE 10 1 0.3 1.0 0.0\nMODE 9")
    with caplog.at_level(logging.WARNING):
        job = job_from_text(text, "d.dat")
    assert ("d.dat:12:1: INPUTE 10 1: deformation 1 of element 10 is not prescribed (it is "
            "not INPUTE in the kinematics module); the line is ignored, as SPACAR does"
            ) in caplog.text
    assert job.model.prescribed_deformations == []


def test_inpute_value_on_a_rigid_mode_is_still_an_error():
    with pytest.raises(DeckError, match="deformation 2 of element 10 is not prescribed: declare"):
        job_from_text(_rod(data="INPUTE 10 2 0.3"), "d.dat")


# -- INPUTS and numbering gaps ------------------------------------------------------------------

def test_inputs_static_gain_and_gaps(tmp_path, caplog):
    """D-free static gain -C A^-1 B of the hinged rod against the closed forms; input 2 and
    output 2 have no line: a zero column and a zero row, each with a warning."""
    signals = "INPUTS 1 10 1\nINPUTS 3 10 1\nINPUTF 4 3 2\nOUTE 1 10 1\nOUTX 3 3 2"
    with caplog.at_level(logging.WARNING):
        job = job_from_text(_rod(signals=signals), "d.dat")
    assert ("d.dat:17:1: inputs are numbered up to 4, but input number 2 has no line: zero "
            "columns of the state space") in caplog.text
    assert "outputs are numbered up to 3, but output number 2 has no line" in caplog.text
    out = tmp_path / "r.h5"
    run_model(job.model, job.settings, out)
    with open_results(out) as res:
        v = res.state_space
        assert v.input_name == ["INPUTS 1 10 1", "(no input 2)", "INPUTS 3 10 1",
                                "INPUTF 4 3 2"]
        assert v.output_name == ["OUTE 1 10 1", "(no output 2)", "OUTX 3 3 2"]
        m = v.matrices(step=v.step[-1])
    gain = -m["C"] @ np.linalg.solve(m["A"], m["B"]) + m["D"]
    expected = np.array([[-1 / K, 0, -1 / K, L / K],
                         [0, 0, 0, 0],
                         [-L / K, 0, -L / K, L * L / K]])
    np.testing.assert_allclose(gain, expected, rtol=1e-12, atol=1e-14)
    assert np.all(m["B"][:, 1] == 0) and np.all(m["C"][1] == 0)
    # B = [0; M0^-1 B0] with B0 = -Phi^T D^T = -1 for the torque (the DOF is the hinge
    # angle itself) and M0 = m L^2
    np.testing.assert_allclose(m["B"][:, 0], [0.0, -1.0 / (M * L * L)], rtol=1e-14)
    poles = np.sort(np.linalg.eigvals(m["A"]).imag)
    np.testing.assert_allclose(poles, [-np.sqrt(K / (M * L * L)), np.sqrt(K / (M * L * L))],
                               rtol=1e-12)


def test_inputs_deck_errors():
    with pytest.raises(DeckError) as err:
        job_from_text(_rod(signals="INPUTS 1 10 4\nINPUTS 1 10 1"), "d.dat")
    text = str(err.value)
    assert "d.dat:15:13: error: INPUTS: element 10 (HINGE) has deformation modes 1..3, got 4" \
        in text
    assert "d.dat:16:8: error: INPUTS: input 1 is already defined (line 15)" in text


# -- F_p and S F_p on a knife edge in the plane ---------------------------------------------

def _knife(th: float, dynamic: list[int], kinematic: list[int]) -> KinematicSetup:
    """Coordinates (x, y, th); no holonomic constraint; the lateral slip held."""
    def unit(cols):
        return sp.csr_matrix(np.eye(3)[cols]) if cols else sp.csr_matrix((0, 3))
    return KinematicSetup(
        hol=sp.csr_matrix((0, 3)), rheo=sp.csr_matrix((0, 3)),
        slips=sp.csr_matrix([[-np.sin(th), np.cos(th), 0.0]]), slip_names=["KNIFE 1 mode 2"],
        kin=unit(kinematic), kin_names=[["KINX 1 1", "KINX 1 2", "KINE 1 1"][c]
                                        for c in kinematic],
        dyn_sets=[("DYNE", unit(dynamic), [])])


@pytest.mark.parametrize("th", [0.0, 0.4, -1.1])
def test_knife_edge_kinematic_map(th):
    F, label = kinematic_map(_knife(th, [0, 2], [1]), np.ones(3, bool))
    np.testing.assert_array_equal(F, [[0.0], [1.0], [0.0]])
    assert label == "DYNE"
    # G = -(S F_p)^-1 S F_q: y' = tan(th) x'
    S = np.array([-np.sin(th), np.cos(th), 0.0])
    assert S @ F[:, 0] == pytest.approx(np.cos(th), abs=1e-15)


def test_knife_edge_heading_cannot_be_kinematic():
    with pytest.raises(ModelError) as err:
        kinematic_map(_knife(0.3, [0, 1], [2]), np.ones(3, bool))
    assert str(err.value).startswith(
        "the slips cannot fix the rates of the kinematic coordinates: S F_p has rank 0 of 1; "
        "dependent slip rows: KNIFE 1 mode 2; kinematic coordinates whose rates the slips "
        "leave free: KINE 1 1.")


def test_a_choice_that_does_not_parameterize_is_named():
    with pytest.raises(ModelError, match="do not parameterize the configuration: it has 3 "
                                         "degrees of freedom, the model gives 1 dynamic"):
        kinematic_map(_knife(0.3, [0], [1]), np.ones(3, bool))


# -- with rolling contact (the WHEEL kind) ------------------------------------------------------

_COIN = """X 2 0 0 0
X 3 0 0 0.3
HINGE 1 9 10 0 0 1
HINGE 2 10 11 1 0 0
HINGE 3 11 12 0 1 0
WHEEL 5 3 12 2 0 1 0
FIX 9
{classes}
END
HALT
XM 3 2
XM 12 0.045 0 0 0.09 0 0.045
END
END
"""

needs_wheel = pytest.mark.skipif("WHEEL" not in KINDS,
                                 reason="needs the WHEEL kind (branch e-wheel)")


@needs_wheel
def test_rolling_disc_mode_0_counts(tmp_path, capsys):
    deck = tmp_path / "coin.dat"
    deck.write_text(_COIN.format(classes="DYNE 1 1\nDYNE 2 1\nDYNE 3 1\nKINX 2 1 2"))
    assert main(["run", str(deck), "--mode", "0"]) == 0
    out = capsys.readouterr()
    text = out.out + out.err
    assert "non-holonomic       2 (WHEEL 5 mode 4, WHEEL 5 mode 5)" in text
    assert "configuration DOF   5" in text
    assert "velocity DOF        3" in text
    assert "K kinematic         2: KINX 2 1 (line 11); KINX 2 2 (line 11)" in text
    assert "total mass          2 kg" in text


@needs_wheel
def test_rolling_disc_with_one_kinematic_coordinate_for_two_slips(tmp_path, capsys):
    deck = tmp_path / "coin.dat"
    deck.write_text(_COIN.format(classes="DYNE 1 1\nDYNE 2 1\nDYNE 3 1\nKINX 2 1"))
    assert main(["run", str(deck), "--mode", "0"]) == EXIT_MODEL
    err = capsys.readouterr().err
    assert ("2 slips held (WHEEL 5 mode 4, WHEEL 5 mode 5), 1 kinematic coordinate declared "
            "(KINX 2 1 (line 11)): the slips need 2 kinematic coordinates (KINE/KINX)") in err
    assert "Traceback" not in err


def test_mode_0_reports_the_total_mass(tmp_path, capsys):
    """SPACAR's "Total mass of the system": the XM point mass and a TRUSS's EM rhoA L."""
    deck = tmp_path / "m.dat"
    deck.write_text(_rod(data="MODE 0").replace(
        "HINGE 10 2 4 0 0 1", "HINGE 10 2 4 0 0 1\nX 5 0 3 0\nTRUSS 20 3 5\nFIX 5").replace(
        "XM 3 1.5", "XM 3 1.5\nEM 20 0.25\nESTIFF 20 1e6"))
    assert main(["run", str(deck), "--mode", "0", "-q"]) == 0
    # truss from (2, 0, 0) to (0, 3, 0): L = sqrt(13)
    assert f"total mass          {1.5 + 0.25 * np.sqrt(13):.10g} kg" in capsys.readouterr().out


def test_spacarpy_check_counts_the_kinematic_coordinates(tmp_path, capsys):
    deck = tmp_path / "k.dat"
    deck.write_text(_rod(classes="RLSE 10 1\nKINE 10 2\nKINX 3 3", data="MODE 0"))
    main(["check", str(deck)])
    out = capsys.readouterr().out
    assert "kinematic           2 coordinates (KINE/KINX)" in out
    assert "slips held          0 (non-holonomic constraints)" in out


# -- the benchmark bicycle of docs/rolling.md (issue 32 §3.2), SPACAR's mode-0 counts ---------

_BICYCLE = """SET V 4.6
SET RR 0.3
SET RF 0.35
SET W 1.02
SET C 0.08
SET LAM {pi/10}
X 2  0 0 0
X 3  0 0 {-RR}
X 4  0.3 0 -0.9
X 5  {W+C-0.9*tan(LAM)} 0 -0.9
X 6  0.9 0 -0.7
X 7  {W} 0 {-RF}
X 8  {W} 0 0
HINGE    1  9 10  0 0 1
HINGE    2 10 11  1 0 0
HINGE    3 11 13  0 1 0
HINGE    4 13 12  0 1 0
WHEEL    5  3 12 2  0 1 0
PINBODY  6  4 13 3
PINBODY  7  4 13 5
HINGE    8 13 14  {tan(LAM)} 0 1
PINBODY  9  5 14 6
PINBODY 10  5 14 7
HINGE   11 14 15  0 1 0
WHEEL   12  7 15 8  0 1 0
FIX 9
RLSE 3 1
{classes}
INPUTE 4 1
KINE 11 1
KINX 2 1
KINX 2 2
END
HALT
XM 3  2.0
XM 12 0.0603 0 0 0.12 0 0.0603
XM 4  85.0
XM 13 9.2 0 2.4 11.0 0 2.8
XM 6  4.0
XM 14 0.05892 0 -0.00756 0.06 0 0.00708
XM 7  3.0
XM 15 0.1405 0 0 0.28 0 0.1405
GRAVITY 0 0 9.81
INPUTE 4 1 0 {-V/RR} 0
END
END
"""

needs_bicycle = pytest.mark.skipif(
    "WHEEL" not in KINDS or "PINBODY" not in KINDS,
    reason="needs the WHEEL kind (branch e-wheel)")


@needs_bicycle
def test_benchmark_bicycle_mode_0_counts(tmp_path, capsys):
    """§3.2's count: 49 coordinates, 4 fixed; 38 holonomic constraints (32 rigid modes, 6
    Euler normalizations); 7 configuration DOF; 4 slips; 3 velocity DOF (lean, steer and
    the prescribed rear wheel); 4 kinematic coordinates; total mass 94 kg."""
    deck = tmp_path / "bike.dat"
    deck.write_text(_BICYCLE.replace("{classes}", "DYNE 2 1\nDYNE 8 1\nKINE 1 1"))
    assert main(["run", str(deck), "--mode", "0", "-q"]) == 0
    out = capsys.readouterr().out
    for line in (
            "coordinates         49 (7 position nodes x 3 + 7 orientation nodes x 4), 4 fixed",
            "holonomic           38 (32 rigid modes + 6 Euler normalizations), 1 prescribed "
            "mode (rheonomic)",
            "non-holonomic       4 (WHEEL 5 mode 4, WHEEL 5 mode 5, WHEEL 12 mode 4, WHEEL 12 "
            "mode 5)",
            "configuration DOF   7",
            "velocity DOF        3",
            "M dynamic           2: HINGE 2 mode 1; HINGE 8 mode 1",
            "K kinematic         4: KINE 1 1 (line 30); KINE 11 1 (line 32); KINX 2 1 (line "
            "33); KINX 2 2 (line 34)",
            "rheonomic           1: HINGE 4 mode 1",
            "C calculable        1 deformation mode (RLSE): HINGE 3 mode 1, 43 coordinates",
            "total mass          94 kg"):
        assert line in out, line
    # the slips are velocity-level constraints: not redundant holonomic ones
    assert "redundant" not in out


@needs_bicycle
def test_benchmark_bicycle_with_the_lean_kinematic_is_refused(tmp_path, capsys):
    """Lean declared kinematic (and the yaw dynamic, so that the count fits): the slips do
    not fix the lean rate, S F_p is singular, exit 3 naming KINE 2 1."""
    deck = tmp_path / "bike.dat"
    deck.write_text(_BICYCLE.replace("{classes}", "KINE 2 1\nDYNE 8 1\nDYNE 1 1"))
    assert main(["run", str(deck), "--mode", "0", "-q"]) == EXIT_MODEL
    err = capsys.readouterr().err
    assert "the slips cannot fix the rates of the kinematic coordinates: S F_p has rank 3 of 4" \
        in err
    assert "KINE 2 1 (line 28)" in err.split("leave free:")[1]
