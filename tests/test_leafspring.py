"""Prescribed deformations (INPUTE/DELINPE), branch switching (BIFURCATION switch) and the
parallel leaf-spring guidance of section 5.4 of Jonker & Meijaard (2013)."""
import logging
from pathlib import Path

import numpy as np
import pytest
from scipy.optimize import brentq
from scipy.special import ellipk

from spacarpy.cli import main
from spacarpy.deck import job_from_text
from spacarpy.results.reader import open_results
from spacarpy.results.tables import extract
from spacarpy.solvers.statics.static import solve_static

from helpers import deck_errors

DECKS = Path(__file__).resolve().parents[1] / "decks"

# material and geometry of the leaf-spring decks (their SET lines)
E, G, T, B, L_LEAF = 195e9, 75e9, 0.2e-3, 0.03, 0.1
EI_WEAK, EI_STIFF = E * B * T**3 / 12, E * T * B**3 / 12
GJ = G * B * T**3 / 3 * (1 - 0.63 * T / B)
PAPER_TORQUE = 0.30361


def hinged_cantilever(kin, data, n=4):
    """A unit cantilever whose root orientation node 2 sits on a hinge (axis z) to the fixed
    ground node 6, or is turned directly (INPUTR)."""
    lines = ["X 1 0 0 0", "X 3 1 0 0", f"BEAMS 1 1 2 3 4 {n} 0 1 0", f"DYNE 1:{n} 1 2 3 4 5 6",
             "FIX 1", kin, "END", "HALT", f"ESTIFF 1:{n} 1e5 1 1 1", "DELXF 3 0 0.3 0", data,
             "ITERSTEP 20 6 1e-12", "END", "END", ""]
    return "\n".join(lines)


# ------------------------------------------------------------------ INPUTE / DELINPE
def test_a_hinge_driven_by_inpute_equals_turning_the_node_by_inputr():
    """Driving the root hinge angle to 0.4 rad (INPUTE/DELINPE) and turning the root node by
    0.4 rad about the hinge axis (INPUTR/DELINPR) are the same problem: the same equilibrium,
    and the hinge's stress resultant (the driving torque) is the reaction moment."""
    hinge, hinge_settings = job_from_text(hinged_cantilever("HINGE 9 6 2 0 0 1\nINPUTE 9 1\nFIX 6",
                                              "DELINPE 9 1 0.4"))
    turned, turned_settings = job_from_text(hinged_cantilever("INPUTR 2 0 0 1", "DELINPR 2 0.4"))
    res_h, res_t = solve_static(hinge, hinge_settings), solve_static(turned, turned_settings)
    num_h, num_t = res_h.problem.num, res_t.problem.num
    # the generated intermediate nodes are numbered differently (the hinge model has more
    # nodes): compare the positions in order along the beam, the root and the tip triads
    rows = [list(hinge.orientation_ids).index(n) for n in (2, 4)]
    rows_t = [list(turned.orientation_ids).index(n) for n in (2, 4)]
    assert len(res_h.steps) == len(res_t.steps) == 7
    for s_h, s_t in zip(res_h.steps, res_t.steps):
        np.testing.assert_allclose(s_h.x[num_h.pos_idx], s_t.x[num_t.pos_idx], atol=1e-11)
        np.testing.assert_allclose(s_h.x[num_h.rot_idx[rows]], s_t.x[num_t.rot_idx[rows_t]],
                                   atol=1e-11)
    assert res_h.steps[-1].deformation["HINGE"][0, 0] == pytest.approx(0.4, abs=1e-12)
    prob = res_t.problem
    reac = dict(zip(zip(prob.reaction_node.tolist(), prob.reaction_component),
                    res_t.steps[-1].reaction))
    torque = res_h.steps[-1].stress["HINGE"][0, 0]
    # the reaction is the moment the support exerts on the node; the hinge's stress
    # resultant is the moment the node exerts on the hinge (dual to the hinge angle)
    assert torque == pytest.approx(-reac[(2, "Mz")], rel=1e-9)
    assert abs(torque) > 0.1                         # a real torque, not a trivial zero


def test_inpute_initial_value_is_reached_at_step_0():
    text = hinged_cantilever("HINGE 9 6 2 0 0 1\nINPUTE 9 1\nFIX 6", "INPUTE 9 1 0.1\n"
                             "DELINPE 9 1 0.2")
    res = solve_static(*job_from_text(text))
    angles = [s.deformation["HINGE"][0, 0] for s in res.steps]
    np.testing.assert_allclose(angles, 0.1 + 0.2 * np.arange(7) / 6, atol=1e-12)


def test_inpute_deck_errors():
    base = "X 1 0 0 0\nX 3 1 0 0\nBEAM 1 1 2 3 4\nHINGE 5 6 2 0 0 1\nDYNE 1 1 2 3 4 5 6\n"
    errors = deck_errors(base + "RLSE 5 1\nINPUTE 5 1\nINPUTE 5 4\nINPUTE 7 1\nINPUTE 5 2\n"
                         "INPUTE 5 2\nFIX 1\nFIX 6\nEND\nHALT\nESTIFF 1 1 1 1 1\n"
                         "DELINPE 5 3 0.1\nEND\nEND\n")
    messages = [m for _, m in errors]
    assert ("INPUTE: deformation 1 of element 5 is also listed in RLSE (line 6); a prescribed "
            "deformation is neither flexible nor released") in messages
    assert "INPUTE: element 5 is a HINGE with deformation modes 1 to 3, got 4" in messages
    assert "INPUTE: element 7 is not defined (no element line)" in messages
    assert "INPUTE: deformation 2 of element 5 is prescribed twice" in messages
    assert ("DELINPE: deformation 3 of element 5 is not prescribed: declare it with "
            "'INPUTE 5 3' in the kinematics module") in messages


# ------------------------------------------------------------------ branch switching
def column_text(P, bifurcation, n=16):
    """A clamped-free inextensible, shear-rigid column (L = EI = 1) under a dead axial load
    P along -x, bending in the x-y plane only (modes 5, 6 flexible, 3, 4 rigid): nothing
    but the instability makes it leave the straight line."""
    return "\n".join([
        "DEFORMATIONS modified", f"BIFURCATION {bifurcation}",
        "X 1 0 0 0", "X 3 1 0 0", f"BEAMS 1 1 2 3 4 {n} 0 1 0", f"DYNE 1:{n} 2 5 6",
        "FIX 1", "FIX 2", "END", "HALT", f"ESTIFF 1:{n} 0 1 1 1",
        f"DELXF 3 {-P} 0 0", "ITERSTEP 30 6 1e-11", "END", "END", ""])


def elastica_tip_angle(ratio):
    """Tip rotation alpha of the buckled cantilever (elastica): P/P_cr = (2 K(k)/pi)^2 with
    k = sin(alpha/2), K the complete elliptic integral of the first kind (parameter k^2)."""
    return brentq(lambda a: (2 * ellipk(np.sin(a / 2) ** 2) / np.pi) ** 2 - ratio, 1e-6, 3.0)


def tip_angle(n, ratio, bifurcation="switch"):
    model, settings = job_from_text(column_text(ratio * np.pi**2 / 4, bifurcation, n=n))
    res = solve_static(model, settings)
    q = res.steps[-1].x[res.problem.num.rot_idx[list(model.orientation_ids).index(4)]]
    return abs(2 * np.arctan2(q[3], q[0])), res


def test_bifurcation_switch_follows_the_elastica(caplog):
    """Beyond the Euler load (P_cr = pi^2/4 for L = EI = 1) the straight column is unstable.
    'BIFURCATION switch' leaves it for the buckled branch, whose tip rotation converges to
    the exact elastica's with order 2 (8, 16 elements: errors 1.8 % and 0.44 %; 32 and 64
    give 0.11 % and 0.027 %); 'warn' keeps the straight (unstable) solution and says so."""
    ratio = 1.3
    exact = elastica_tip_angle(ratio)
    (a8, _), (a16, res) = tip_angle(8, ratio), tip_angle(16, ratio)
    e8, e16 = a8 / exact - 1, a16 / exact - 1
    assert 0 < e16 < 5e-3
    assert np.log2(e8 / e16) == pytest.approx(2.0, abs=0.1)
    # the steps below P_cr stay straight
    num = res.problem.num
    for s in res.steps[:int(np.floor(6 / ratio)) + 1]:
        assert np.abs(s.x[num.pos_idx][:, 1]).max() < 1e-9
    with caplog.at_level(logging.WARNING):
        a_warn, straight = tip_angle(16, ratio, "warn")
    assert a_warn < 1e-9
    assert any("unstable: 1 negative stiffness eigenvalue" in r.message for r in caplog.records)


# ------------------------------------------------------------------ leaf-spring guidance
@pytest.mark.parametrize("variant", ["modified", "basic"])
def test_leafspring_guidance_critical_torque(tmp_path, variant):
    """Critical torque of the hinge: the same with both variants (as in the article), within
    2 % of the article's 0.30361 N m (its material data are not published) and of the
    closed form for a clamped leaf under a uniform in-plane moment, 2 pi/l sqrt(EIw GJ)
    (the shuttle carries no shear between the leaves, see docs/multibody.md)."""
    out = tmp_path / "b.h5"
    assert main(["run", str(DECKS / "leafspring_guidance_buckling.dat"), "-o", str(out), "-q",
                 "--deformations", variant]) == 0
    with open_results(out) as res:
        torque = 0.01 * float(res.buckling.critical_load_multiplier[-1])
    assert torque == pytest.approx(0.308317, rel=1e-5)
    assert torque == pytest.approx(PAPER_TORQUE, rel=0.02)
    assert torque == pytest.approx(2 * np.pi / L_LEAF * np.sqrt(EI_WEAK * GJ), rel=0.02)


@pytest.fixture(scope="module")
def misalignment(tmp_path_factory):
    out = {}
    for variant in ("modified", "basic"):
        path = tmp_path_factory.mktemp(variant) / "m.h5"
        assert main(["run", str(DECKS / "leafspring_guidance_misalignment.dat"), "-o",
                     str(path), "-q", "--deformations", variant]) == 0
        out[variant] = path
    return out


@pytest.mark.slow
def test_leafspring_guidance_before_buckling(misalignment):
    """At zero misalignment the first mode is the guided motion of the shuttle: stiffness of
    two clamped-guided leaves 24 EIw/l^3, mass of the shuttle plus 13/35 of the leaves
    (the consistent mass of the static deflection shape). Up to buckling the hinge torque
    grows as EIs/(2 l) per radian: each leaf carries a uniform in-plane moment and the
    shuttle turns by half the misalignment."""
    with open_results(misalignment["modified"]) as res:
        table = extract(res, "frequency_table")
        cols = dict(zip(table.names, table.columns))
        torque = res._read("static/hinge_stress_resultant")[:, 0, 0]
    ms = 2700 * 0.12 * 0.03 * 0.02
    m_eff = ms + 2 * 13 / 35 * 7900 * B * T * L_LEAF
    f1 = np.sqrt(24 * EI_WEAK / L_LEAF**3 / m_eff) / (2 * np.pi)
    assert cols["f1"][0] == pytest.approx(f1, rel=1e-4)
    phi = cols["e23.1"]
    np.testing.assert_allclose(phi, 0.002 * cols["load_factor"], atol=1e-15)
    assert abs(torque[4]) / phi[4] == pytest.approx(EI_STIFF / (2 * L_LEAF), rel=2e-3)


@pytest.mark.slow
def test_leafspring_guidance_frequencies_drop_at_the_critical_misalignment(misalignment):
    """The three frequencies fall sharply towards the misalignment at which the hinge torque
    reaches the critical torque (0.70 mrad in this model; 'about 0.8 mrad' in the article);
    beyond it the solver switches to the stable buckled branch (no unstable modes) and the
    frequencies rise again. Both variants agree closely before buckling."""
    tables = {}
    for variant, path in misalignment.items():
        with open_results(path) as res:
            t = extract(res, "frequency_table")
            tables[variant] = dict(zip(t.names, t.columns))
            kinds = res.eigen.kind
            assert np.all(kinds == 0), "every mode on the followed path is elastic (stable)"
            torque = np.abs(res._read("static/hinge_stress_resultant")[:, 0, 0])
        phi = tables[variant]["e23.1"]
        slope = np.polyfit(phi[1:14], torque[1:14], 1)[0]     # linear before buckling
        phi_cr = 0.308317 / slope
        assert phi_cr == pytest.approx(2 * L_LEAF * 0.308317 / EI_STIFF, rel=2e-3)
        assert 0.68e-3 < phi_cr < 0.72e-3
        freqs = np.column_stack([tables[variant][f"f{k}"] for k in (1, 2, 3)])
        low = int(np.argmin(freqs[:, 1]))
        assert abs(phi[low] - phi_cr) < 0.05e-3
        below = int(np.flatnonzero(phi < phi_cr)[-1])
        assert np.all(freqs[below] < 0.15 * freqs[0])     # a sharp drop of all three
        assert np.all(freqs[-1] > freqs[low])             # and a partial recovery
        assert np.all(np.diff(freqs[:below + 1], axis=0) < 0)   # monotone fall before it
    mod, bas = tables["modified"], tables["basic"]
    for k in (1, 2, 3):
        np.testing.assert_allclose(bas[f"f{k}"][:12], mod[f"f{k}"][:12], rtol=1e-3)


def test_branch_choice_does_not_depend_on_the_eigenvector_sign_or_round_off():
    """Mirror-image post-buckling branches have equal energy to round-off; the switch takes
    the first one tried along the eigenvector with a canonical sign, so neither the eigen
    solver's arbitrary sign nor the last digits of the energies decide the branch."""
    from spacarpy.solvers.path.stability import ENERGY_TIE, canonical_sign
    rng = np.random.default_rng(7)
    v = rng.standard_normal((30, 3))
    assert np.array_equal(canonical_sign(v), canonical_sign(-v))
    assert np.array_equal(canonical_sign(v * [1, -1, 1]), canonical_sign(v))
    mirror = np.array([[0.0], [-1.0], [1.0 + 1e-15], [0.2]])     # equal magnitudes
    assert canonical_sign(mirror)[1, 0] == 1.0 == canonical_sign(-mirror)[1, 0]
    assert 1e-14 < ENERGY_TIE < 1e-8        # round-off ties, but not distinct branches
