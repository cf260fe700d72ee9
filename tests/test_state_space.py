"""The linearized state space of SPACAR mode 9 (spacarpy.solvers.linear.state_space) and SPACAR's
mode numbers on the command line.

The three verifications of the state space, on decks/state_space_cantilever.dat (a preloaded
cantilever, so the geometric stiffness is in the linearization): (a) the poles of A are
+-i 2 pi f of the eigen analysis at the same step; (b) the static gain -C A^-1 B is the
compliance of ``--compliance``; (c) the frequency response C (iwI - A)^-1 B + D is a direct
harmonic solve of the linearized equations in all free coordinates, with the constraints
kept by multipliers and the damping built from its definition (alpha M + beta K0).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import scipy.io
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from spacarpy.cli import main
from spacarpy.deck import job_from_text, load
from spacarpy.errors import EXIT_INPUT, EXIT_MODEL, DeckError
from spacarpy.results import open_results, read_results
from spacarpy.run import RunOptions, run_model
from spacarpy.settings import resolve_analysis, spacar_mode_refusal
from spacarpy.solvers.linear.linearize import MassAssembler, linearize
from spacarpy.solvers.linear.state_space import dof_layout, state_space
from spacarpy.solvers.statics.equilibrium import StaticProblem
from spacarpy.solvers.statics.static import solve_static

DECK = Path(__file__).resolve().parents[1] / "decks" / "state_space_cantilever.dat"


@pytest.fixture(scope="module")
def ss_file(tmp_path_factory):
    out = tmp_path_factory.mktemp("ss") / "ss.h5"
    job = load(DECK)
    run_model(job.model, job.settings, out)
    return out


@pytest.fixture(scope="module")
def eigen_file(tmp_path_factory):
    """The eigen analysis (all 24 modes) and the tip compliance at every step."""
    out = tmp_path_factory.mktemp("eig") / "eig.h5"
    job = load(DECK)
    settings = job.settings.override(analysis="eigen", n_modes=24, modes_each_step=True)
    run_model(job.model, settings, out, RunOptions(compliance_node=(9, 10)))
    return out


def test_mode_9_writes_a_valid_state_space(ss_file):
    from spacarpy.results import validate_file
    assert validate_file(ss_file, require_complete=True) == []
    with open_results(ss_file) as res:
        assert res.analysis == "state_space"
        v = res.state_space
        assert v.step.tolist() == [0, 1, 2]
        assert v.input_name == ["INPUTF 1 9 2", "INPUTF 2 9 3"]
        assert v.output_name == ["OUTX 1 9 2", "OUTXP 2 9 2", "OUTX 3 9 3", "OUTE 4 1 3",
                                 "OUTX 5 10 4"]
        # the degrees of freedom: the 24 DYNE modes, element by element
        assert v.dof.tolist() == [[e, k] for e in range(1, 5) for k in range(1, 7)]
        assert v.state_name[0] == "BEAM 1 mode 1"
        assert v.state_name[24] == "rate of BEAM 1 mode 1"
        m = v.matrices(step=2)
        assert m["A"].shape == (48, 48) and m["B"].shape == (48, 2)
        assert m["C"].shape == (5, 48) and np.all(m["D"] == 0)
        # OUTE 4 1 3 is the degree of freedom BEAM 1 mode 3 itself
        np.testing.assert_allclose(m["C"][3, :24], np.eye(24)[2], atol=1e-12)
        sys = v.system(step=2)
        np.testing.assert_array_equal(sys.A, m["A"])
    full = read_results(ss_file).state_space            # the eager reader: every step
    assert full.A.shape == (3, 48, 48) and full.step.tolist() == [0, 1, 2]
    np.testing.assert_array_equal(full.A[2], m["A"])
    assert full.output_name[1] == "OUTXP 2 9 2" and full.dof_mode.tolist()[:6] == [1, 2, 3,
                                                                                4, 5, 6]


@pytest.mark.parametrize("step", [0, 2])
def test_poles_are_the_eigenfrequencies(ss_file, eigen_file, step):
    """(a) Undamped: the eigenvalues of A are +-i 2 pi f of the eigen analysis of the same
    step (step 2 carries the preload: 100 N compression and 10 N lateral)."""
    with open_results(ss_file) as res:
        A = res.state_space.matrix("A", step)
    with open_results(eigen_file) as res:
        f = res.eigen.frequency[res.eigen.row(step)]
    assert np.all(np.isfinite(f)) and f.size == 24
    poles = np.linalg.eigvals(A)
    np.testing.assert_allclose(np.abs(poles.real), 0.0, atol=1e-6 * np.abs(poles).max())
    up = np.sort(poles.imag[poles.imag > 0])
    down = np.sort(-poles.imag[poles.imag < 0])
    np.testing.assert_allclose(up, 2 * np.pi * np.sort(f), rtol=1e-8)
    np.testing.assert_allclose(down, 2 * np.pi * np.sort(f), rtol=1e-8)


def test_the_preload_changes_the_frequencies(eigen_file):
    """The geometric stiffness is in it: the compressed cantilever's first bending frequency
    is lower than the unloaded one, f^2 by about 1 - P / P_E = 1 - 100 / 411 = 0.757 (Galef's
    approximation; measured 0.771, the 10 N lateral load included)."""
    with open_results(eigen_file) as res:
        f0, f2 = res.eigen.frequency[0, 0], res.eigen.frequency[2, 0]
    assert 0.74 < (f2 / f0) ** 2 < 0.80


@pytest.mark.parametrize("step", [0, 2])
def test_static_gain_is_the_compliance(ss_file, eigen_file, step):
    """(b) -C A^-1 B: tip y and z displacements per unit tip force along y and z are the
    entries of the 6x6 compliance of node 9/10; velocity outputs have zero gain."""
    with open_results(ss_file) as res:
        m = res.state_space.matrices(step)
    with open_results(eigen_file) as res:
        c = res.compliance.global_[res.compliance.row(step)]
    gain = m["D"] - m["C"] @ np.linalg.solve(m["A"], m["B"])
    want = np.array([[c[1, 1], c[1, 2]], [c[2, 1], c[2, 2]]])
    got = gain[[0, 2]]
    np.testing.assert_allclose(got, want, rtol=1e-8, atol=1e-8 * np.abs(want).max())
    # a cantilever of EI = 166.67 N m^2, L = 1 m: 1 / (3 EI / L^3) = 2.0e-3 m/N unloaded
    if step == 0:
        assert got[0, 0] == pytest.approx(1 / (3 * 166.6666667), rel=1e-6)
    assert np.abs(gain[1]).max() <= 1e-10 * np.abs(want).max()


def _equilibria(job):
    problem = StaticProblem(job.model, deformations=job.settings.deformations)
    steps = []
    solve_static(job.model, job.settings, problem=problem, on_step=steps.append)
    return problem, steps


def test_frequency_response_is_a_harmonic_solve():
    """(c) With damping (alpha = 2 1/s, beta = 1e-4 s), at the preloaded step: the transfer
    function of A, B, C, D equals the solution of (K - w^2 M + i w C_d) u = F of all the free
    coordinates with the constraints C u = 0, C_d = alpha M + beta K0 taken from the
    material stiffness; the matrices stored in the file are the ones computed here."""
    job = load(DECK, overrides={"ALPHA": "2", "BETA": "1e-4"})
    problem, steps = _equilibria(job)
    num, free = problem.num, problem.free
    mass = MassAssembler(job.model, num)
    step = steps[-1]
    lin = linearize(problem, step.x, step.mu, problem.loads.at(1.0, step.load_factor), mass)
    lin0 = linearize(problem, num.x0.copy(), np.zeros(num.n_constraint),
                     problem.loads.at(1.0, 0.0))
    lay = dof_layout(lin0, num, free)
    lio = job.settings.linearized
    ss = state_space(lin, num, free, job.model, lay, lio.inputs, lio.outputs)
    assert np.abs(ss.C0).max() > 0

    n_x = lin.K.shape[0]
    n_c = lin.C.shape[0]
    u = np.full(num.n_coord, -1)
    u[free] = np.arange(n_x)
    tip = num.pos_idx[list(job.model.position_ids).index(9)]
    tip_rot = num.rot_idx[list(job.model.orientation_ids).index(10)]
    F = np.zeros((n_x, 2))
    F[u[tip[1]], 0] = F[u[tip[2]], 1] = 1.0
    g = num.groups[0]
    Cd = 2.0 * lin.M + 1e-4 * lin.K_mat
    for f_hz in (3.0, 20.0, 150.0):
        w = 2 * np.pi * f_hz
        a = sp.bmat([[lin.K - w**2 * lin.M + 1j * w * Cd, lin.C.T], [lin.C, None]],
                    format="csc")
        rhs = np.zeros((n_x + n_c, 2), dtype=complex)
        rhs[:n_x] = F
        sol = spla.splu(a).solve(rhs)[:n_x]
        full = np.zeros((num.n_coord, 2), dtype=complex)
        full[free] = sol
        e13 = lin.states[0].D[0, 2] @ full[g.idx[0]]          # element 1, mode 3
        direct = np.array([full[tip[1]], 1j * w * full[tip[1]], full[tip[2]], e13,
                           full[tip_rot[3]]])
        tf = ss.C @ np.linalg.solve(1j * w * np.eye(ss.A.shape[0]) - ss.A, ss.B) + ss.D
        for j in range(2):
            scale = np.abs(direct[:, j]).max()
            np.testing.assert_allclose(tf[:, j], direct[:, j], rtol=0, atol=1e-8 * scale)


def test_the_file_holds_the_computed_matrices(tmp_path):
    job = load(DECK, overrides={"ALPHA": "2", "BETA": "1e-4"})
    out = tmp_path / "damped.h5"
    run_model(job.model, job.settings, out)
    problem, steps = _equilibria(job)
    num, free = problem.num, problem.free
    lin = linearize(problem, steps[1].x, steps[1].mu,
                    problem.loads.at(1.0, steps[1].load_factor),
                    MassAssembler(job.model, num))
    lin0 = linearize(problem, num.x0.copy(), np.zeros(num.n_constraint),
                     problem.loads.at(1.0, 0.0))
    lio = job.settings.linearized
    ss = state_space(lin, num, free, job.model, dof_layout(lin0, num, free), lio.inputs,
                     lio.outputs)
    with open_results(out) as res:
        for name in ("M0", "C0", "K0", "B0", "A", "B", "C", "D"):
            stored = res.state_space.matrix(name, 1)
            np.testing.assert_allclose(stored, getattr(ss, name), rtol=1e-9,
                                       atol=1e-9 * np.abs(stored).max(initial=1.0))


def test_export_state_space_mat_round_trips(ss_file, tmp_path, capsys):
    out = tmp_path / "sys.mat"
    assert main(["export", str(ss_file), "--state-space", str(out), "--step", "1", "-q"]) == 0
    data = scipy.io.loadmat(out)
    with open_results(ss_file) as res:
        v = res.state_space
        for name in ("A", "B", "C", "D", "M0", "K0"):
            np.testing.assert_array_equal(data[name], v.matrix(name, 1))
        assert [str(s[0][0]) for s in data["output_name"]] == v.output_name
        assert [str(s[0][0]) for s in data["input_name"]] == v.input_name
        assert [str(s[0][0]) for s in data["state_name"]] == v.state_name
    assert float(data["step"][0, 0]) == 1.0
    assert float(data["load_factor"][0, 0]) == pytest.approx(0.5)
    # default: the last step
    assert main(["export", str(ss_file), "--state-space", str(out), "-q"]) == 0
    assert float(scipy.io.loadmat(out)["step"][0, 0]) == 2.0


def test_export_state_space_errors(ss_file, eigen_file, tmp_path, capsys):
    assert main(["export", str(eigen_file), "--state-space", str(tmp_path / "a.mat")]) \
        == EXIT_INPUT
    assert "no state space" in capsys.readouterr().err
    assert main(["export", str(ss_file), "--state-space", str(tmp_path / "a.txt")]) \
        == EXIT_INPUT
    assert main(["export", str(ss_file), "--state-space", str(tmp_path / "a.mat"),
                 "--step", "7"]) == EXIT_INPUT


# -- SPACAR mode numbers ---------------------------------------------------------------------

@pytest.mark.parametrize("number, name", [(0, "check"), (1, "transient"), (4, "eigen"),
                                          (7, "eigen"), (8, "buckling"), (9, "state_space"),
                                          (10, "static_linearized"), (-9, "state_space"),
                                          ("-10", "static_linearized"), ("static", "static")])
def test_spacar_mode_numbers(number, name):
    assert resolve_analysis(number) == name


@pytest.mark.parametrize("number", [2, -2])
def test_mode_2_runs_inverse_dynamics(number, tmp_path, capsys):
    """SPACAR mode 2 is no longer refused: on this deck (a flexible cantilever, nothing
    prescribed) inverse dynamics asks for its time span, and with one names the degrees of
    freedom it would need prescribed (tests/test_inverse_dynamics.py has the runs)."""
    assert resolve_analysis(number) == "inverse_dynamics"
    assert spacar_mode_refusal(number) is None
    code = main(["run", str(DECK), "-o", str(tmp_path / "x.h5"), "--mode", str(number)])
    assert code == EXIT_INPUT
    err = capsys.readouterr().err
    assert "MODE inverse_dynamics (SPACAR 2) needs the time span: TIMESTEP" in err
    deck = tmp_path / "timed.dat"
    deck.write_text(DECK.read_text().replace("MODE 9", "MODE 9\nTIMESTEP 1 2"))
    code = main(["run", str(deck), "-o", str(tmp_path / "x.h5"), "--mode", str(number)])
    assert code == EXIT_MODEL
    err = capsys.readouterr().err
    assert "MODE inverse_dynamics (SPACAR 2) needs every degree of freedom prescribed" in err
    assert "flexible (DYNE) modes are degrees of freedom: BEAM" in err
    assert "not supported yet" not in err and "Traceback" not in err


def test_mode_2_in_the_deck_is_read():
    job = job_from_text(DECK.read_text().replace("MODE 9", "MODE 2"), "deck.dat")
    assert job.settings.analysis == "inverse_dynamics"


def test_negative_mode_is_silent(tmp_path, capfd):
    out = tmp_path / "s.h5"
    assert main(["run", str(DECK), "-o", str(out), "--mode", "-9"]) == 0
    captured = capfd.readouterr()
    assert captured.err == ""                # no progress lines (the EXPECT table is stdout)
    assert open_results(out).state_space.n_lin == 3
    assert main(["run", str(DECK), "-o", str(out), "--mode", "9"]) == 0
    assert "state space: 48 states, 2 inputs, 5 outputs" in capfd.readouterr().err


# -- decks and models the state space refuses ------------------------------------------------

_BASE = """X 1 0 0 0
X 3 1 0 0
X 5 2 0 0
BEAM 1 1 2 3 4 0 1 0
BEAM 2 3 4 5 6 0 1 0
DYNE 1 1 2 3 4 5 6
DYNE 2 1 2 3 4 5 6
FIX 1
FIX 2
{fix}
END
HALT
ESTIFF 1 1e6 1e3 1e3 1e3
ESTIFF 2 1e6 1e3 1e3 1e3
EM 1 1 {rot}
EM 2 1 {rot}
END
HALT
{signals}
END
END
"""


def _deck(signals="INPUTF 1 5 2\nOUTX 1 5 2", fix="", rot="2e-3 1e-3 1e-3 0"):
    return _BASE.format(signals=signals, fix=fix, rot=rot)


@pytest.mark.parametrize("signals, message", [
    ("INPUTF 1 7 2", "d.dat:19:10: error: INPUTF: node 7 is not defined"),
    ("OUTX 1 5 4", "OUTX: node 5 is a position node: coordinate 1..3 (x y z), got 4"),
    ("OUTX 1 6 5", "OUTX: node 6 is an orientation node: coordinate 1..4"),
    ("OUTE 1 3 1", "OUTE: element 3 is not defined"),
    ("OUTEP 1 2 7", "OUTEP: element 2 (BEAM) has deformation modes 1..6, got 7"),
    ("OUTX 1 5 1\nOUTE 1 2 1", "d.dat:20:6: error: OUTE: output 1 is already defined (line 19)"),
])
def test_signal_deck_errors(signals, message):
    with pytest.raises(DeckError) as err:
        job_from_text(_deck(signals), "d.dat")
    assert message in str(err.value)


def test_the_degrees_of_freedom_must_be_spacar_s(tmp_path, capsys):
    """A beam clamped at both ends with every mode DYNE has 12 flexible modes but 6 degrees
    of freedom: exit 3, with the counts."""
    deck = tmp_path / "cc.dat"
    # the input on the free middle node 3 (one on the clamped node 5 is a deck error)
    deck.write_text(_deck(signals="INPUTF 1 3 2\nOUTX 1 3 2", fix="FIX 5\nFIX 6"))
    assert main(["run", str(deck), "--mode", "9"]) == EXIT_MODEL
    err = capsys.readouterr().err
    assert "(6); the model has 12 flexible and 0 released (RLSE) modes" in err


def test_a_degree_of_freedom_without_inertia_is_named(tmp_path, capsys):
    deck = tmp_path / "m.dat"
    deck.write_text(_deck(rot="0 0 0 0"))
    assert main(["run", str(deck), "--mode", "9"]) == EXIT_INPUT
    err = capsys.readouterr().err
    assert "the mass matrix is singular there" in err and "Traceback" not in err


_PLANAR = """MODE 9
X 1 0 0
X 3 0.5 0
X 5 1 0
PLBEAM 1 1 2 3 4
PLBEAM 2 3 4 5 6
DYNE 1:2 1 2 3
FIX 1
FIX 2
END
HALT
ESTIFF 1:2 1e6 2.0
EM 1:2 0.5 1e-4
END
HALT
INPUTF 1 5 2
INPUTF 2 6 1
OUTX 1 5 2
OUTX 2 6 1
OUTXP 3 6 1
END
END
"""


def test_planar_orientation_coordinate_is_the_rotation(tmp_path):
    """In a planar model coordinate 1 of an orientation node is the rotation about z: the
    static gain of a cantilever (L = 1 m, EI = 2 N m^2) from the tip force and moment to the
    tip deflection and rotation is [[L^3/3EI, L^2/2EI], [L^2/2EI, L/EI]]."""
    job = job_from_text(_PLANAR, "planar.dat")
    out = tmp_path / "p.h5"
    run_model(job.model, job.settings, out)
    with open_results(out) as res:
        m = res.state_space.matrices()
    gain = m["D"] - m["C"] @ np.linalg.solve(m["A"], m["B"])
    ei = 2.0
    np.testing.assert_allclose(gain[:2], [[1 / (3 * ei), 1 / (2 * ei)],
                                          [1 / (2 * ei), 1 / ei]], rtol=1e-8)
    np.testing.assert_allclose(gain[2], 0.0, atol=1e-12)
    with pytest.raises(DeckError, match="OUTX: node 6 is an orientation node: coordinate 1..1 "
                                        r"\(the rotation about z\), got 2"):
        job_from_text(_PLANAR.replace("OUTX 2 6 1", "OUTX 2 6 2"), "planar.dat")


def test_show_summarizes_the_state_space(ss_file, capsys):
    """The summary names the signals and the lowest pole: at the preloaded step the first
    bending frequency, 7.183 Hz (the eigen analysis of the same step)."""
    assert main(["show", str(ss_file)]) == 0
    out = capsys.readouterr().out
    assert "State space (SPACAR mode 9) at 3 steps: 48 states (24 degrees of freedom), " \
           "2 inputs, 5 outputs" in out
    assert "outputs  OUTX 1 9 2, OUTXP 2 9 2, OUTX 3 9 3, OUTE 4 1 3, OUTX 5 10 4" in out
    assert "at step 2: the pole of smallest magnitude is 0 +- 45.13i 1/s (7.183 Hz)" in out


def test_signals_without_mode_9_draw_a_warning(tmp_path, caplog):
    job = load(DECK)
    with caplog.at_level("WARNING"):
        run_model(job.model, job.settings.override(analysis="static"), tmp_path / "s.h5")
    assert "the INPUTF/OUT* lines (INPUTF 1 9 2) define the state space of MODE " \
           "state_space (SPACAR 9); this static analysis does not use them" in caplog.text


def test_a_deck_without_signals_stores_the_matrices(tmp_path):
    """No INPUTF/OUT* lines: M0, C0, K0 and A are stored, B and C are empty."""
    text = _deck(signals="")
    out = tmp_path / "n.h5"
    job = job_from_text(text, "n.dat")
    run_model(job.model, job.settings.override(analysis="9"), out)
    with open_results(out) as res:
        m = res.state_space.matrices()
        assert m["A"].shape == (24, 24) and m["B"].shape == (24, 0) and m["C"].shape == (0, 24)
        assert res.state_space.input_name == [] and res.state_space.output_name == []
