"""Static solver: the paper's Tables 1 and 2 from the shipped decks, objectivity of a whole
model, equilibrium of reactions, mechanism / over-constraint diagnosis, failure reports."""
from pathlib import Path

import numpy as np
import pytest

from spacarpy.deck import load, load_deck
from spacarpy.errors import ConvergenceError, ModelError, SolverError
from spacarpy.model import RIGID, ElementSet, Fix, Load, Model
from spacarpy.rotation import from_axis_angle, rotation_matrix
from spacarpy.settings import AnalysisSettings, IterStep
from spacarpy.solvers.statics.static import StaticOptions, solve_static

DECKS = Path(__file__).resolve().parents[1] / "decks"

# Table 1 of Jonker & Meijaard (2013): tip displacements (m), 6 printed digits.
TABLE1_MODIFIED = {1: (0.901067, 1.521304), 2: (0.574104, 1.276622), 4: (0.523295, 1.223753),
                   8: (0.512121, 1.211296), 16: (0.509427, 1.208249),
                   32: (0.508759, 1.207492), 64: (0.508593, 1.207303),
                   128: (0.508551, 1.207256)}
TABLE1_BASIC = {2: (0.575338, 1.316823), 4: (0.521435, 1.230945), 8: (0.511573, 1.212951),
                16: (0.509285, 1.208655), 32: (0.508724, 1.207593), 64: (0.508584, 1.207328),
                128: (0.508549, 1.207262)}
# Table 2: tip position (m), 2 printed decimals.
TABLE2 = {("modified", 8): (46.94, 53.64, 15.64), ("basic", 8): (46.95, 53.75, 15.61),
          ("modified", 48): (47.14, 53.48, 15.68)}


def tip_position(res):
    return res.steps[-1].x[res.problem.num.pos_idx[-1]]


@pytest.mark.parametrize("variant,n,expected",
                         [("modified", n, v) for n, v in TABLE1_MODIFIED.items()]
                         + [("basic", n, v) for n, v in TABLE1_BASIC.items()])
def test_table1_cantilever(variant, n, expected):
    model, settings = load(DECKS / f"table1_cantilever_{n}el_{variant}.dat")
    assert settings.deformations == variant and model.elements["BEAM"].n_elem == n
    tip = tip_position(solve_static(model, settings))
    ux, uy = 2.0 - tip[0], tip[1]          # Table 1 prints the shortening and the deflection
    assert round(ux, 6) == pytest.approx(expected[0], abs=1e-12)
    assert round(uy, 6) == pytest.approx(expected[1], abs=1e-12)


def test_table1_one_basic_element_is_reported_not_printed():
    model, settings = load(DECKS / "table1_cantilever_1el_basic.dat")
    steps = []
    with pytest.raises(SolverError, match="spurious equilibrium"):
        solve_static(model, settings, on_step=steps.append)
    assert 1 <= len(steps) < 11                     # the valid steps before it were kept


@pytest.mark.parametrize("variant,n", list(TABLE2))
def test_table2_bend(variant, n):
    tip = tip_position(solve_static(*load(DECKS / f"table2_bend_{n}el_{variant}.dat")))
    assert tuple(np.round(tip, 2)) == pytest.approx(TABLE2[(variant, n)], abs=1e-9)


def test_deck_cli_override_of_the_deformation_variant():
    job = load(DECKS / "table1_cantilever_4el_modified.dat", deformations="basic")
    tip = tip_position(solve_static(*job))
    assert round(2.0 - tip[0], 6) == TABLE1_BASIC[4][0]


def test_randomly_oriented_cantilever_gives_the_rotated_tip_displacement():
    base, settings = load(DECKS / "table1_cantilever_8el_modified.dat")
    tip0 = tip_position(solve_static(base, settings))
    rng = np.random.default_rng(3)
    for _ in range(2):
        rot = rotation_matrix(from_axis_angle(rng.normal(size=3), rng.uniform(0.5, 3.0)))
        shift = rng.normal(size=3)
        b = base.elements["BEAM"]
        beams = ElementSet("BEAM", ids=b.ids, nodes=b.nodes,
                           vector=np.tile(rot @ [0, 1.0, 0], (8, 1)),
                           def_class=b.def_class, stiffness=b.stiffness,
                           has_stiffness=b.has_stiffness)
        loads = [Load(ld.node, ld.kind, tuple(rot @ np.array(ld.value))) for ld in base.loads]
        model = Model(position_ids=base.position_ids,
                      position_x0=base.position_x0 @ rot.T + shift,
                      orientation_ids=base.orientation_ids, elements={"BEAM": beams},
                      fixes=base.fixes,
                      loads=loads)
        tip = tip_position(solve_static(model, settings))
        np.testing.assert_allclose(tip - shift, rot @ tip0, atol=1e-9)


def test_reactions_balance_the_tip_load():
    model, settings = load(DECKS / "table1_cantilever_8el_modified.dat")
    res = solve_static(model, settings)
    prob = res.problem
    reac = dict(zip(zip(prob.reaction_node.tolist(), prob.reaction_component),
                    res.steps[-1].reaction))
    force = model.loads[0].value[1]
    tip = tip_position(res)
    assert reac[(1, "Fy")] == pytest.approx(-force, rel=1e-9)
    assert abs(reac[(1, "Fx")]) < 1e-6 * force
    # moment about the clamped node (at the origin) balances the tip force's moment
    assert reac[(2, "Mz")] == pytest.approx(-force * tip[0], rel=1e-8)


def two_beam_model(fixes, def_class=None, loads=()):
    dc = np.ones((2, 6)) if def_class is None else def_class
    return Model(position_ids=[1, 3, 5], position_x0=[[0, 0, 0], [1, 0, 0], [2, 0, 0]],
                 orientation_ids=[2, 4, 6],
                 elements={"BEAM": ElementSet(
                     "BEAM", ids=[11, 12], nodes=[[1, 2, 3, 4], [3, 4, 5, 6]],
                     vector=np.tile([0, 1.0, 0], (2, 1)), def_class=dc,
                     stiffness=np.tile([1e6, 1e3, 1e3, 1e3, 0, 0], (2, 1)),
                     has_stiffness=[True, True])},
                 fixes=fixes, loads=list(loads))


def test_free_floating_model_is_reported_as_a_mechanism_naming_nodes():
    model = two_beam_model([], loads=[Load(5, "DELXF", (0, 1.0, 0))])
    with pytest.raises(ModelError, match=r"mechanism: \d+ free motion.*nodes that move: 1, 2, 3"):
        solve_static(model)


def test_redundant_rigid_modes_are_named_with_the_rlse_that_removes_them():
    dc = np.full((2, 6), RIGID)
    model = two_beam_model([Fix(1, (1, 2, 3)), Fix(2, (1, 2, 3, 4)), Fix(5, (1, 2, 3)),
                            Fix(6, (1, 2, 3, 4))], def_class=dc)
    with pytest.raises(ModelError, match=r"over-constrained.*RLSE 1[12] \d"):
        solve_static(model)


def test_non_convergence_names_the_step_and_keeps_converged_steps():
    model = load_deck(DECKS / "table1_cantilever_4el_modified.dat")
    steps = []
    opts = StaticOptions(max_iter=2, tol=1e-12, n_steps=4, max_cuts=2)
    with pytest.raises(ConvergenceError, match=r"static step 1 .*residual history"):
        solve_static(model, options=opts, on_step=steps.append)
    assert len(steps) == 1 and steps[0].load_factor == 0.0


def test_rigid_modes_are_enforced_exactly_and_carry_the_stress_resultant():
    # cantilever of two beams, all modes flexible except the elongation made rigid
    dc = np.ones((2, 6))
    dc[:, 0] = RIGID
    model = two_beam_model([Fix(1, (1, 2, 3)), Fix(2, (1, 2, 3, 4))], def_class=dc,
                           loads=[Load(5, "DELXF", (50.0, 20.0, 0.0))])
    res = solve_static(model)
    st = res.steps[-1]
    assert np.abs(st.deformation["BEAM"][:, 0]).max() < 1e-12
    # the axial multiplier equals the axial force: tip force projected on the last chord
    tip, mid = st.x[res.problem.num.pos_idx[2]], st.x[res.problem.num.pos_idx[1]]
    chord = (tip - mid) / np.linalg.norm(tip - mid)
    assert st.stress["BEAM"][1, 0] == pytest.approx(np.dot([50.0, 20.0, 0.0], chord), rel=1e-8)


def moment_cantilever(n, variant, moment, EI=1.0, EA=1e7, L=1.0):
    """A cantilever of n beams under a tip moment: (model, settings)."""
    pos = np.arange(n + 1) * 2 + 1
    rot = pos + 1
    x0 = np.zeros((n + 1, 3))
    x0[:, 0] = np.linspace(0, L, n + 1)
    beams = ElementSet("BEAM", ids=np.arange(1, n + 1),
                       nodes=np.stack([pos[:-1], rot[:-1], pos[1:], rot[1:]], 1),
                       vector=np.tile([0, 1.0, 0], (n, 1)), def_class=np.ones((n, 6)),
                       stiffness=np.tile([EA, EI, EI, EI, 0, 0], (n, 1)),
                       has_stiffness=np.ones(n, bool))
    return Model(position_ids=pos, position_x0=x0, orientation_ids=rot,
                 elements={"BEAM": beams},
                 fixes=[Fix(1, (1, 2, 3)), Fix(2, (1, 2, 3, 4))],
                 loads=[Load(int(rot[-1]), "DELXF", (0, 0, moment))]), \
        AnalysisSettings(deformations=variant).override(
            iterstep=IterStep(max_iter=20, n_steps=8, tol=1e-10))


@pytest.mark.parametrize("variant", ["modified", "basic"])
def test_tip_moment_bends_the_cantilever_into_the_exact_circular_arc(variant):
    """A dead tip moment M = EI theta / L bends a cantilever into an arc of angle theta:
    tip at (sin theta, 1 - cos theta) L / theta, tip rotation theta. The DDM solution
    converges to it with order 2."""
    theta = np.pi / 2
    exact = np.array([np.sin(theta), 1 - np.cos(theta), 0.0]) / theta
    errors, rot_errors = [], []
    for n in (8, 16, 32):
        res = solve_static(*moment_cantilever(n, variant, theta))
        x = res.steps[-1].x
        errors.append(np.linalg.norm(x[res.problem.num.pos_idx[-1]] - exact))
        q = x[res.problem.num.rot_idx[-1]]
        assert abs(q[1]) < 1e-12 and abs(q[2]) < 1e-12           # stays in the x-y plane
        rot_errors.append(abs(2 * np.arctan2(q[3], q[0]) - theta))
    for err, bound in ((errors, 3.5e-4), (rot_errors, 7e-4)):
        order = np.log2(np.array(err[:-1]) / err[1:])
        assert np.all((order > 1.95) & (order < 2.1)), order
        assert err[-1] < bound


def test_newton_matrix_equals_finite_differences_of_the_residual():
    """The tangent K_T (material + geometric + Euler multipliers + moment-load part N0) and
    the constraint gradients, at a deformed state with random multipliers and a moment."""
    model, _ = moment_cantilever(3, "modified", 0.7, EA=50.0)
    model.loads.append(Load(5, "DELXF", (0.3, -0.2, 0.4)))
    from spacarpy.solvers.statics.static import StaticProblem
    prob = StaticProblem(model)
    num = prob.num
    rng = np.random.default_rng(5)
    x = num.x0.copy()
    x[prob.free] += 0.05 * rng.normal(size=num.n_unknown)
    mu = rng.normal(size=num.n_constraint)
    load = prob.loads.at(1.0, 1.0)
    a = prob.matrix(prob.evaluate(x, mu, load), mu).toarray()
    n_x = prob.pattern.n_x
    h = 1e-6
    fd = np.zeros((a.shape[0], n_x))
    for k in range(n_x):
        xp, xm = x.copy(), x.copy()
        xp[np.flatnonzero(prob.free)[k]] += h
        xm[np.flatnonzero(prob.free)[k]] -= h
        ep, em = prob.evaluate(xp, mu, load), prob.evaluate(xm, mu, load)
        fd[:, k] = np.concatenate([ep.r - em.r, prob.scale * (ep.c - em.c)]) / (2 * h)
    np.testing.assert_allclose(a[:, :n_x], fd, atol=1e-6 * np.abs(a).max())


def chain(n, def_class=None, fixes=(), loads=()):
    pos = np.arange(n + 1) * 2 + 1
    rot = pos + 1
    x0 = np.zeros((n + 1, 3))
    x0[:, 0] = np.linspace(0, 1, n + 1)
    dc = np.ones((n, 6)) if def_class is None else np.full((n, 6), def_class)
    beams = ElementSet("BEAM", ids=np.arange(1, n + 1),
                       nodes=np.stack([pos[:-1], rot[:-1], pos[1:], rot[1:]], 1),
                       vector=np.tile([0, 1.0, 0], (n, 1)), def_class=dc,
                       stiffness=np.tile([1e6, 1.0, 1.0, 1.0, 0, 0], (n, 1)),
                       has_stiffness=np.ones(n, bool))
    return Model(position_ids=pos, position_x0=x0, orientation_ids=rot,
                 elements={"BEAM": beams},
                 fixes=list(fixes), loads=list(loads))


def test_large_free_floating_model_is_reported_as_a_mechanism():
    """700 beams (> 4000 unknowns: no dense SVD); SuperLU factorizes the singular matrix
    without complaint, the deformation-free-motion check still finds the 6 rigid motions."""
    model = chain(700, loads=[Load(1401, "DELXF", (0, 1.0, 0))])
    with pytest.raises(ModelError, match=r"mechanism: 6 free motion.*1402 in all"):
        solve_static(model)


def test_large_over_constrained_model_names_rlse_lines():
    model = chain(700, def_class=RIGID, fixes=[Fix(1, (1, 2, 3)), Fix(2, (1, 2, 3, 4)),
                                               Fix(1401, (1, 2, 3)), Fix(1402, (1, 2, 3, 4))])
    with pytest.raises(ModelError, match=r"over-constrained: 6 redundant.*'RLSE 1 1'.*in all"):
        solve_static(model)


def test_stiff_fine_mesh_is_not_mistaken_for_a_mechanism():
    """A 2000-element cantilever has a huge condition number but no free motion."""
    model = chain(2000, fixes=[Fix(1, (1, 2, 3)), Fix(2, (1, 2, 3, 4))],
                  loads=[Load(4001, "DELXF", (0, 1e-3, 0))])
    res = solve_static(model)
    tip = res.steps[-1].x[res.problem.num.pos_idx[-1]]
    assert tip[1] == pytest.approx(1e-3 / 3, rel=1e-4)                 # F L^3 / 3 EI


def test_a_tolerance_below_round_off_fails_with_a_hint_and_a_value_that_works(tmp_path,
                                                                                capsys):
    from spacarpy.cli import main
    from spacarpy.solvers.statics.static import ROUNDOFF_TOL, roundoff_hint

    assert ROUNDOFF_TOL == pytest.approx(2.220446e-14)
    assert roundoff_hint(1e-9, [1.0, 1e-10]) == ""             # a reachable tolerance
    assert roundoff_hint(3e-14, [1.0]) == ""
    assert "use a tolerance of 1e-08 or larger" in roundoff_hint(1e-30, [1.0, 1.7e-9, 1.7e-9])
    assert "use a tolerance of 1e-13 or larger" in roundoff_hint(1e-15, [1.0, 1e-16])
    assert "use a tolerance of 5e-07 or larger" in roundoff_hint(1e-15, [1.0, np.nan])
    text = (DECKS / "table1_cantilever_1el_modified.dat").read_text()
    assert "ITERSTEP 20 10 1e-09" in text
    deck = tmp_path / "t.dat"
    deck.write_text(text.replace("ITERSTEP 20 10 1e-09", "ITERSTEP 20 10 1e-30"))
    assert main(["run", str(deck), "-q"]) == 1
    err = capsys.readouterr().err
    assert "The ITERSTEP tolerance 1e-30 is below the round-off floor" in err
    suggested = err.split("use a tolerance of ")[1].split()[0]
    assert 1e-14 <= float(suggested) <= 1e-7              # stalled near 1.7e-9 here
    deck.write_text(text.replace("ITERSTEP 20 10 1e-09", f"ITERSTEP 20 10 {suggested}"))
    assert main(["run", str(deck), "-q"]) == 0             # the suggested value works


def test_a_step_accepted_at_its_round_off_floor_says_so():
    """D12: a step accepted within its measured round-off floor (above the tolerance, on
    converged increments, solvers/statics/newton.py) says so in the progress line; a step whose
    residual met the tolerance does not, and neither does one merely above it (never
    accepted that way any more: the line follows the stored reason, not the number)."""
    from types import SimpleNamespace

    from spacarpy.run import step_line

    step = SimpleNamespace(load_factor=0.5, iterations=4, residual=5e-4, converged_by="floor")
    line = step_line(3, 10, step, 1e-9)
    assert "residual 5.00e-04" in line and "round-off floor" in line and "1e-09" in line
    assert "(above the tolerance" in line
    # recorded on its floor with the residual below the tolerance (the tolerance does not
    # clear the floor: StaticProblem.accepted_by): not "above"
    step.residual = 5e-10
    assert "(at the tolerance 1e-09, within its round-off floor" in step_line(3, 10, step, 1e-9)
    for res, by in ((1e-10, "tolerance"), (5e-4, "tolerance")):
        assert "round-off" not in step_line(3, 10, SimpleNamespace(
            load_factor=0.5, iterations=4, residual=res, converged_by=by), 1e-9)
