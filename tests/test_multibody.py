"""TRUSS, HINGE and RBEAM elements in the static and linearized solvers (models built in
Python; deck support for these keywords comes with the multibody issue)."""
import numpy as np
import pytest
from scipy.optimize import brentq

from spacarpy.model import FLEXIBLE, RIGID, ElementSet, Fix, Load, Model, NodalMass
from spacarpy.settings import AnalysisSettings, IterStep
from spacarpy.solvers.linear.eigen import eigenmodes
from spacarpy.solvers.linear.linearize import MassAssembler, linearize
from spacarpy.solvers.statics.static import solve_static

NAN3 = (np.nan, np.nan, np.nan)


def steps(n_steps: int, tol: float = 1e-12) -> AnalysisSettings:
    """Static settings of n_steps load steps."""
    return AnalysisSettings().override(iterstep=IterStep(n_steps=n_steps, tol=tol))


def two_bar_truss(P, EA=1e4, h=0.3, half=1.0):
    """Symmetric two-bar truss in the x-y plane, apex node 3 loaded by P downwards."""
    trusses = ElementSet(kind="TRUSS", ids=[1, 2], nodes=[[1, 3], [5, 3]], vector=[NAN3, NAN3],
                         def_class=[[FLEXIBLE], [FLEXIBLE]], stiffness=[[EA], [EA]],
                         has_stiffness=[True, True])
    return Model(position_ids=[1, 3, 5], position_x0=[[-half, 0, 0], [0, h, 0], [half, 0, 0]],
                 orientation_ids=[], elements={"TRUSS": trusses},
                 fixes=[Fix(1, (1, 2, 3)), Fix(5, (1, 2, 3)), Fix(3, (3,))],
                 loads=[Load(3, "DELXF", (0, -P, 0))])


def test_two_bar_truss_matches_the_exact_nonlinear_equilibrium():
    EA, h, half, P = 1e4, 0.3, 1.0, 50.0                    # below the snap-through load
    res = solve_static(two_bar_truss(P, EA, h, half), steps(4))
    apex = res.steps[-1].x[res.problem.num.pos_idx[1]]
    l0 = np.hypot(half, h)

    def residual(v):                         # vertical equilibrium of the apex at drop v
        y = h - v
        length = np.hypot(half, y)
        return 2 * EA * (length - l0) / l0 * y / length + P

    v = brentq(residual, 0.0, 0.1)
    assert apex[1] == pytest.approx(h - v, rel=1e-9)
    assert abs(apex[0]) < 1e-12
    force = res.steps[-1].stress["TRUSS"][:, 0]
    assert force == pytest.approx(np.full(2, -P / 2 * np.hypot(half, h - v) / (h - v)),
                                  rel=1e-9)


def hinged_rod(F, k=3.0, L=2.0, rod="BEAM", tip_mass=0.0):
    """A rigid rod on a revolute joint (axis z) with a torsion spring k at the fixed end."""
    sets = {"HINGE": ElementSet(kind="HINGE", ids=[10], nodes=[[2, 4]], vector=[(0, 0, 1.0)],
                                def_class=[[FLEXIBLE, RIGID, RIGID]], stiffness=[[k]],
                                has_stiffness=[True])}
    if rod == "BEAM":
        sets["BEAM"] = ElementSet("BEAM", ids=[1], nodes=[[1, 4, 3, 6]], vector=[(0, 1.0, 0)],
                                  def_class=np.full((1, 6), RIGID), stiffness=np.zeros((1, 6)),
                                  has_stiffness=[False])
        rot = [2, 4, 6]
    else:
        sets["RBEAM"] = ElementSet(kind="RBEAM", ids=[1], nodes=[[1, 4, 3]],
                                   vector=[(0, 1.0, 0)], def_class=np.full((1, 3), RIGID),
                                   stiffness=np.zeros((1, 3)), has_stiffness=[False])
        rot = [2, 4]
    masses = [NodalMass(3, (tip_mass,))] if tip_mass else []
    return Model(position_ids=[1, 3], position_x0=[[0, 0, 0], [L, 0, 0]], orientation_ids=rot,
                 elements=sets, fixes=[Fix(1, (1, 2, 3)), Fix(2, (1, 2, 3, 4))],
                 loads=[Load(3, "DELXF", (0, F, 0))] if F else [], nodal_masses=masses)


@pytest.mark.parametrize("rod", ["BEAM", "RBEAM"])
def test_hinge_spring_balances_a_dead_tip_force_at_large_rotation(rod):
    """k theta = F L cos(theta) for a rigid rod on a torsion-spring hinge."""
    F, k, L = 2.5, 3.0, 2.0
    res = solve_static(hinged_rod(F, k, L, rod), steps(5))
    theta = brentq(lambda t: k * t - F * L * np.cos(t), 0, np.pi / 2)
    assert theta > 0.8                                         # a large rotation
    tip = res.steps[-1].x[res.problem.num.pos_idx[1]]
    np.testing.assert_allclose(tip, [L * np.cos(theta), L * np.sin(theta), 0], atol=1e-10)
    e_hinge = res.steps[-1].deformation["HINGE"][0]
    assert e_hinge[0] == pytest.approx(theta, abs=1e-10)
    assert np.abs(e_hinge[1:]).max() < 1e-12                   # the joint stays a revolute one
    assert res.steps[-1].stress["HINGE"][0, 0] == pytest.approx(k * theta, rel=1e-10)


def test_hinge_angle_is_continuous_beyond_half_a_turn():
    """A spring so soft that the rod turns past 180 degrees: the hinge angle keeps counting."""
    k, L = 3.0, 2.0
    model = hinged_rod(0.0, k, L)
    model.loads = [Load(6, "DELXF", (0, 0, 4.0 * np.pi * k))]  # tip moment: theta = 4 pi
    res = solve_static(model, steps(16))
    angles = [s.deformation["HINGE"][0, 0] for s in res.steps]
    np.testing.assert_allclose(angles, np.linspace(0, 4 * np.pi, 17), atol=1e-9)


def test_hinged_rod_with_tip_mass_oscillates_at_sqrt_k_over_m_l2():
    k, L, m = 3.0, 2.0, 0.7
    model = hinged_rod(0.0, k, L, tip_mass=m)
    res = solve_static(model, steps(5))
    prob, st = res.problem, res.steps[-1]
    lin = linearize(prob, st.x, st.mu, prob.loads.at(1.0, 1.0),
                    mass=MassAssembler(model, prob.num))
    md = eigenmodes(lin, prob.num, prob.free, n_modes=1)
    assert md.frequency[0] == pytest.approx(np.sqrt(k / (m * L**2)) / (2 * np.pi), rel=1e-10)


# ------------------------------------------------------------------------ from decks
from pathlib import Path  # noqa: E402

from spacarpy.cli import main  # noqa: E402
from spacarpy.deck import job_from_text  # noqa: E402
from spacarpy.results import read_results  # noqa: E402

from helpers import deck_errors, planar_four_bar_equilibrium  # noqa: E402

DECKS = Path(__file__).resolve().parents[1] / "decks"


@pytest.mark.parametrize("deck,node,expected", [
    ("hinged_rod_spring", 3, (1.149902278161588, 1.63637549195739, 0.0)),
    ("two_bar_truss", 3, (0.0, 0.261907172128137, 0.0))])
def test_multibody_decks_run_from_the_command_line(tmp_path, deck, node, expected):
    out = tmp_path / f"{deck}.h5"
    assert main(["run", str(DECKS / f"{deck}.dat"), "-o", str(out), "-q"]) == 0
    res = read_results(out)
    row = list(res.position_nodes).index(node)
    np.testing.assert_allclose(res.static.position[-1, row], expected, atol=1e-9)


def test_deck_errors_of_the_new_element_kinds():
    text = ("X 1 0 0 0\nX 3 1 0 0\nTRUSS 1 1 3\nHINGE 2 2 4\nRBEAM 3 1 2 1\nDYNE 1 2\n"
            "EM 2 1.5\nESTIFF 1 1 2\nFIX 1\nEND\nEND\n")
    errors = deck_errors(text)
    assert (4, "element 2: a HINGE needs its axis: HINGE 2 2 4 ax ay az") in errors
    assert (5, "element 3 has zero length: nodes 1 and 1 are at the same position") in errors
    assert (6, "DYNE: element 1 is a TRUSS with deformation mode 1 only, got 2") in errors
    assert (7, "EM 2: a HINGE has no mass of its own; put masses and inertias on its nodes "
               "with XM") in errors
    assert (8, "ESTIFF 1: a TRUSS takes EA (1 value), got 2") in errors


def test_mode_check_counts_degrees_of_freedom(capsys):
    assert main(["run", str(DECKS / "table1_cantilever_4el_modified.dat"), "--mode", "0",
                 "-q"]) == 0
    out = capsys.readouterr().out
    assert "kinematic check passed" in out
    assert "coordinates         35 (5 position nodes x 3 + 5 orientation nodes x 4), 7 fixed" \
        in out
    assert "degrees of freedom  24, no free motion" in out
    assert main(["run", str(DECKS / "hinged_rod_spring.dat"), "--mode", "check", "-q"]) == 0
    out = capsys.readouterr().out
    assert "elements            1 HINGE, 1 RBEAM" in out
    assert "constraints         6 (5 rigid deformation modes + 1 Euler normalizations)" in out
    assert "degrees of freedom  1, no free motion" in out                 # the joint angle


def test_mode_check_names_a_mechanism(tmp_path, capsys):
    deck = tmp_path / "mech.dat"
    deck.write_text("X 1 0 0 0\nX 3 1 0 0\nTRUSS 1 1 3\nDYNE 1 1\nFIX 1\nFIX 3 1\nEND\nHALT\n"
                    "ESTIFF 1 100\nEND\nEND\n")
    # a mechanism is the kinematic check's result (SPACAR mode 0), not an error
    assert main(["run", str(deck), "--mode", "check", "-q"]) == 0
    out = capsys.readouterr().out
    assert "kinematic check: a mechanism with 2 free motions" in out
    assert "degrees of freedom  2, 2 of them free motions that no stiffness resists" in out
    assert "free motion 1       node 3 y (the others held); nodes that move: 3\n" in out
    assert "free motion 2       node 3 z (the others held); nodes that move: 3\n" in out
    assert not (tmp_path / "mech.h5").exists()
    # a loaded static run refuses it (exit 3) with the same diagnosis
    deck.write_text(deck.read_text().replace("ESTIFF 1 100", "ESTIFF 1 100\nDELXF 3 0 1 0"))
    assert main(["run", str(deck), "--mode", "static", "-q"]) == 3
    assert ("mechanism: 2 free motion(s) that no flexible element resists; nodes that move: "
            "3; motion 1 driven by node 3 y; motion 2 driven by node 3 z") \
        in capsys.readouterr().err


# ------------------------------------------------------------------------ prescribed motion
def cantilever_text(extra_kin="", extra_data="", n=8):
    """A unit cantilever from node 1/2 to the tip node 3/4, generated with BEAMS."""
    lines = ["X 1 0 0 0", "X 3 1 0 0", f"BEAMS 1 1 2 3 4 {n} 0 1 0", f"DYNE 1:{n} 1 2 3 4 5 6",
             "FIX 1", "FIX 2", extra_kin, "END", "HALT", f"ESTIFF 1:{n} 1e5 1 1 1",
             extra_data, "ITERSTEP 20 8 1e-12", "END", "END", ""]
    return "\n".join(lines)


def solve_text(text):
    model, settings = job_from_text(text, "p.dat")
    res = solve_static(model, settings)
    return model, res, res.steps[-1]


def test_prescribed_rotation_and_load_control_reach_the_same_equilibrium():
    """Bend a cantilever with a dead tip moment; then prescribe the tip rotation it reached
    (INPUTX/DELINPX on lambda3): same shape, and the reaction moment equals the load."""
    _, res_m, st_m = solve_text(cantilever_text(extra_data="DELXF 4 0 0 1.2"))
    q_tip = st_m.x[res_m.problem.num.rot_idx[1]]           # orientation node 4
    _, res_p, st_p = solve_text(cantilever_text(extra_kin="INPUTX 4 4",
                                                extra_data=f"DELINPX 4 4 {float(q_tip[3])!r}"))
    np.testing.assert_allclose(st_p.x, st_m.x, atol=1e-10)
    prob = res_p.problem
    reac = dict(zip(zip(prob.reaction_node.tolist(), prob.reaction_component), st_p.reaction))
    assert reac[(4, "Mz")] == pytest.approx(1.2, rel=1e-9)    # the input supplies the moment
    assert reac[(2, "Mz")] == pytest.approx(-1.2, rel=1e-9)   # and the clamp balances it


def test_prescribed_displacement_gives_the_force_that_causes_it():
    _, res_f, st_f = solve_text(cantilever_text(extra_data="DELXF 3 0 0.9 0"))
    tip = st_f.x[res_f.problem.num.pos_idx[1]]
    _, res_p, st_p = solve_text(cantilever_text(extra_kin="INPUTX 3 2",
                                                extra_data=f"DELINPX 3 2 {float(tip[1])!r}"))
    np.testing.assert_allclose(st_p.x, st_f.x, atol=1e-10)
    prob = res_p.problem
    reac = dict(zip(zip(prob.reaction_node.tolist(), prob.reaction_component), st_p.reaction))
    assert reac[(3, "Fy")] == pytest.approx(0.9, rel=1e-9)     # the force that the load was


def test_prescribed_coordinate_errors():
    errors = deck_errors(cantilever_text(extra_kin="INPUTX 1 2\nINPUTX 3 5",
                                         extra_data="DELINPX 3 1 0.1"))
    messages = [m for _, m in errors]
    assert any("coordinate 2 of node 1 is also fixed" in m for m in messages)
    assert any("node 3 is a position node with coordinates 1 to 3, got 5" in m
               for m in messages)
    assert any("DELINPX: coordinate 1 of node 3 is not prescribed: declare it with "
               "'INPUTX 3 1'" in m for m in messages)


# ------------------------------------------------------------------------ gravity
def test_cantilever_under_self_weight_and_a_tip_mass_matches_beam_theory():
    """Uniform weight w = rhoA g: tip deflection w L^4 / 8 EI (exact at the nodes for the
    consistent Hermite load); a tip point mass m adds m g L^3 / 3 EI (small loads)."""
    text = cantilever_text(extra_data="EM 1:8 2.0\nXM 3 0.5\nGRAVITY 0 -1e-3 0")
    _, res, st = solve_text(text)
    tip = st.x[res.problem.num.pos_idx[1]]
    w, m, g = 2.0 * 1e-3, 0.5, 1e-3
    expected = w / 8 + m * g / 3                      # L = EI = 1
    assert -tip[1] == pytest.approx(expected, rel=2e-5)
    prob = res.problem
    reac = dict(zip(zip(prob.reaction_node.tolist(), prob.reaction_component), st.reaction))
    assert reac[(1, "Fy")] == pytest.approx(w + m * g, rel=1e-9)       # total weight


def test_gravity_on_a_rigid_rod_balances_the_hinge_spring():
    """RBEAM rod of mass m (EM rhoA), hinge spring k, gravity g along +y:
    k theta = m g (L/2) cos(theta)."""
    model = hinged_rod(0.0, k=3.0, L=2.0, rod="RBEAM")
    model.elements["RBEAM"].mass[:, 0] = 1.5            # rhoA: m = 3 kg
    model.gravity = (0.0, 2.0, 0.0)
    res = solve_static(model, steps(5))
    theta = brentq(lambda t: 3.0 * t - 3.0 * 2.0 * 1.0 * np.cos(t), 0, np.pi / 2)
    tip = res.steps[-1].x[res.problem.num.pos_idx[1]]
    np.testing.assert_allclose(tip, [2 * np.cos(theta), 2 * np.sin(theta), 0], atol=1e-10)


CORPUS = Path(__file__).resolve().parents[1].parent / "shared" / "spacar-decks"


@pytest.mark.skipif(not (CORPUS / "oopspa_crosshinge.dat").exists(),
                    reason="the SPACAR corpus (../shared/spacar-decks) is not beside the repo")
def test_corpus_cross_hinge_runs_and_has_the_cross_spring_pivot_stiffness(tmp_path):
    """oopspa_crosshinge.dat (SPACAR Light): two crossed leaf springs, the top body rotated
    by a prescribed Euler parameter (INPUTX/DELINPX), gravity. Small-angle rotational
    stiffness of a symmetric cross-spring pivot: 2 EI / L (each leaf, clamped at the base and
    turning about its midpoint, gives M = EI theta / L); it decreases with the rotation."""
    out = tmp_path / "cross.h5"
    assert main(["run", str(CORPUS / "oopspa_crosshinge.dat"), "-o", str(out), "-q"]) == 0
    res = read_results(out)
    s = res.static
    k = list(zip(s.reaction_node.tolist(), s.reaction_component)).index((8, "Mz"))
    q = s.euler[:, list(res.orientation_nodes).index(8)]
    theta = 2 * np.arctan2(q[:, 3], q[:, 0])
    stiffness = s.reaction[1:, k] / theta[1:]
    ei, length = 0.007, 0.1 * np.sqrt(2)
    assert theta[-1] == pytest.approx(2 * np.arcsin(0.247404), rel=1e-9)
    assert stiffness[0] == pytest.approx(2 * ei / length, rel=2e-4)
    assert np.all(np.diff(stiffness[1:]) < 0) and stiffness[-1] < 0.996 * stiffness[0]


@pytest.mark.slow
@pytest.mark.skipif(not CORPUS.exists(), reason="the SPACAR corpus is not beside the repo")
def test_every_corpus_deck_with_only_supported_features_runs_from_the_cli(tmp_path):
    """Every corpus deck that uses only supported features finishes. (spatools_cantilever.dat
    pushes its 1 m cantilever with a dead axial load of -1e10 N, 40000 times its buckling
    load: the equilibrium found has the beam turned over and stretched to 21 m, which the
    run reports with a strain warning.) The transient (mode 1) decks, slider cranks driven by
    an ESIG torque that have no static equilibrium, run in tests/test_spacar_compat.py."""
    from spacarpy.deck.check import check_deck
    ran = []
    for deck in sorted(CORPUS.glob("*.dat")):
        if not check_deck(deck).ok or "TIMESTEP" in deck.read_text(encoding="latin-1"):
            continue
        code = main(["run", str(deck), "-o", str(tmp_path / (deck.stem + ".h5")), "-q"])
        ran.append(deck.name)
        assert code == 0, deck.name
    assert {"oopspa_crosshinge.dat", "oopspa_testfile.dat", "dynastatflex_simple_beam.dat",
            "oopspa_crosshinge_mode3.dat"} <= set(ran)


def test_prescribed_rotation_by_axis_and_angle():
    """INPUTR/DELINPR turn the tip node about z by the angle that a dead tip moment causes:
    the same equilibrium, and the reaction moment equals that load."""
    _, res_m, st_m = solve_text(cantilever_text(extra_data="DELXF 4 0 0 1.2"))
    q = st_m.x[res_m.problem.num.rot_idx[1]]
    theta = float(2 * np.arctan2(q[3], q[0]))
    _, res_r, st_r = solve_text(cantilever_text(extra_kin="INPUTR 4 0 0 1",
                                                extra_data=f"DELINPR 4 {theta!r}"))
    np.testing.assert_allclose(st_r.x, st_m.x, atol=1e-10)
    prob = res_r.problem
    reac = dict(zip(zip(prob.reaction_node.tolist(), prob.reaction_component), st_r.reaction))
    assert reac[(4, "Mz")] == pytest.approx(1.2, rel=1e-9)
    assert abs(reac[(4, "Mx")]) < 1e-9 and abs(reac[(4, "My")]) < 1e-9
    messages = [m for _, m in deck_errors(cantilever_text(extra_kin="INPUTR 3 0 0 1\n"
                                                                    "INPUTR 2 0 0 1"))]
    assert any("INPUTR: node 3 is a position node" in m for m in messages)
    assert any("INPUTR: node 2 is already fixed or prescribed" in m for m in messages)


def test_four_bar_linkage_matches_the_planar_solution(tmp_path):
    out = tmp_path / "fb.h5"
    assert main(["run", str(DECKS / "four_bar_linkage.dat"), "-o", str(out), "-q"]) == 0
    res = read_results(out)
    phi, c = planar_four_bar_equilibrium()
    pos = res.static.position[-1, list(res.position_nodes).index(5)]
    np.testing.assert_allclose(pos, [c[0], c[1], 0.0], atol=1e-9)
    q = res.static.euler[-1, list(res.orientation_nodes).index(4)]
    assert 2 * np.arctan2(q[3], q[0]) == pytest.approx(phi, abs=1e-9)


def test_four_bar_without_releases_is_reported_three_times_over_constrained(tmp_path, capsys):
    text = (DECKS / "four_bar_linkage.dat").read_text()
    text = text.replace("RLSE 13 2 3", "").replace("RLSE 12 2", "")
    deck = tmp_path / "fb_over.dat"
    deck.write_text(text)
    assert main(["run", str(deck), "--mode", "check", "-q"]) == 0
    out = capsys.readouterr().out
    assert "kinematic check: 3 redundant constraints\n" in out
    assert ("  redundant           HINGE 13 mode 2: 'RLSE 13 2' releases it\n"
            "                      HINGE 14 mode 2: 'RLSE 14 2' releases it\n"
            "                      HINGE 14 mode 3: 'RLSE 14 3' releases it\n") in out
    assert main(["run", str(deck), "-q", "-o", str(tmp_path / "fb.h5")]) == 3
    assert ("over-constrained: 3 redundant constraint(s): HINGE 13 mode 2 ('RLSE 13 2' "
            "releases it); HINGE 14 mode 2") in capsys.readouterr().err
    assert main(["run", str(DECKS / "four_bar_linkage.dat"), "--mode", "check", "-q"]) == 0
    assert "degrees of freedom  1, no free motion" in capsys.readouterr().out
