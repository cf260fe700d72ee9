"""Linearized analyses: mass matrix, Table 3 lateral buckling, frequencies against closed
forms with observed convergence orders, rigid-body modes, stress stiffening, Euler loads."""
import numpy as np
import pytest

from spacarpy.elements.beam import reference_triads
from spacarpy.elements.beam_mass import beam_mass_matrix
from spacarpy.job import Job
from spacarpy.model import ElementSet, Fix, Load, Model, NodalMass
from spacarpy.settings import AnalysisSettings, IterStep
from spacarpy.solvers.linear.buckling import buckling_modes
from spacarpy.solvers.linear.eigen import ELASTIC, RIGID_BODY, UNSTABLE, eigenmodes
from spacarpy.solvers.linear.linearize import MassAssembler, linearize
from spacarpy.solvers.statics.static import solve_static

F_TH_CONSTANT = 4.012599344          # NOTES.md: the corrected lateral-buckling constant


def straight(n, *, L=1.0, stiffness=(1e6, 1.0, 1.0, 1.0, 0, 0), mass=(1.0, 0, 0, 0, 0),
             def_class=None, fixes="clamped", loads=(), variant="modified", nodal_masses=()):
    """n equal beams along x; nodes 2i+1 (position) and 2i+2 (orientation): the model and
    its settings (one load step)."""
    pos = np.arange(n + 1) * 2 + 1
    rot = pos + 1
    x0 = np.zeros((n + 1, 3))
    x0[:, 0] = np.linspace(0, L, n + 1)
    dc = np.ones((n, 6)) if def_class is None else np.tile(def_class, (n, 1))
    beams = ElementSet("BEAM", ids=np.arange(1, n + 1),
                    nodes=np.stack([pos[:-1], rot[:-1], pos[1:], rot[1:]], 1),
                    vector=np.tile([0, 1.0, 0], (n, 1)), def_class=dc,
                    stiffness=np.tile(stiffness, (n, 1)), has_stiffness=np.ones(n, bool),
                    mass=np.tile(mass, (n, 1)))
    fix = {"clamped": [Fix(1, (1, 2, 3)), Fix(2, (1, 2, 3, 4))],
           "pinned": [Fix(1, (1, 2, 3)), Fix(2, (2,)), Fix(int(pos[-1]), (2, 3))],
           "free": []}[fixes]
    loads = [Load(int(pos[-1]) if node == "tip" else int(node), "DELXF", tuple(v))
             for node, v in loads]
    model = Model(position_ids=pos, position_x0=x0, orientation_ids=rot,
                  elements={"BEAM": beams}, fixes=fix,
                  loads=loads, nodal_masses=list(nodal_masses))
    settings = AnalysisSettings(deformations=variant).override(
        iterstep=IterStep(max_iter=20, n_steps=1, tol=1e-12))
    return Job(model, settings)


def linearized_final_state(job, with_mass=True):
    model = job.model
    res = solve_static(model, job.settings)
    prob, st = res.problem, res.steps[-1]
    mass = (MassAssembler(model, prob.num, rotary=job.settings.rotary_inertia) if with_mass
            else None)
    return prob, linearize(prob, st.x, st.mu, prob.loads.at(1.0, 1.0), mass=mass)


def modes_of(job, n_modes):
    prob, lin = linearized_final_state(job)
    return eigenmodes(lin, prob.num, prob.free, n_modes=n_modes)


# ---------------------------------------------------------------------------- mass matrix
def test_straight_beam_mass_matrix_equals_the_textbook_consistent_mass():
    L, rho_a = 1.3, 2.5
    nx, ny, nz, l0 = reference_triads(np.zeros((1, 3)), np.array([[L, 0, 0]]),
                                      np.array([[0.0, 1.0, 0.0]]))
    x = np.array([[0, 0, 0, 1, 0, 0, 0, L, 0, 0, 1, 0, 0, 0]], dtype=float)
    m = beam_mass_matrix(x, nx, ny, nz, l0, np.array([[rho_a, 0, 0, 0, 0]]))[0]
    # virtual rotations at the identity: phi = 2 lambda_1..3
    cols = [0, 1, 2, 4, 5, 6, 7, 8, 9, 11, 12, 13]
    t = np.diag([1, 1, 1, .5, .5, .5] * 2)
    mu_ = t @ m[np.ix_(cols, cols)] @ t
    c = rho_a * L / 420
    v_tz = [1, 5, 7, 11]                              # v, theta_z at p and q
    ref = c * np.array([[156, 22 * L, 54, -13 * L], [22 * L, 4 * L**2, 13 * L, -3 * L**2],
                        [54, 13 * L, 156, -22 * L], [-13 * L, -3 * L**2, -22 * L, 4 * L**2]])
    np.testing.assert_allclose(mu_[np.ix_(v_tz, v_tz)], ref, rtol=1e-13, atol=1e-15)
    w_ty = [2, 4, 8, 10]                              # w, theta_y: theta_y = -dw/dx
    sign = np.diag([1, -1, 1, -1])
    np.testing.assert_allclose(mu_[np.ix_(w_ty, w_ty)], sign @ ref @ sign, rtol=1e-13,
                               atol=1e-15)
    # total translational mass in every direction
    for d in range(3):
        e = np.zeros(12)
        e[[d, 6 + d]] = 1.0
        assert e @ mu_ @ e == pytest.approx(rho_a * L, rel=1e-13)


def test_kinetic_energy_of_a_rigidly_rotating_beam_is_exact():
    L, rho_a, rho_iz = 2.0, 3.0, 0.05
    nx, ny, nz, l0 = reference_triads(np.zeros((1, 3)), np.array([[L, 0, 0]]),
                                      np.array([[0.0, 1.0, 0.0]]))
    x = np.array([[0, 0, 0, 1, 0, 0, 0, L, 0, 0, 1, 0, 0, 0]], dtype=float)
    emass = np.array([[rho_a, rho_iz + 0.02, 0.02, rho_iz, 0.0]])
    m = beam_mass_matrix(x, nx, ny, nz, l0, emass)[0]
    assert np.array_equal(m, beam_mass_matrix(x, nx, ny, nz, l0, emass, "lumped")[0])
    m_c = beam_mass_matrix(x, nx, ny, nz, l0, emass, "consistent")[0]
    omega = 0.7                                       # about z through node p
    xdot = np.zeros(14)
    xdot[[8]] = omega * L                             # q moves along +y
    xdot[6] = xdot[13] = omega / 2                    # lambda3 rate of both nodes
    for mm in (m, m_c):                               # both exact for a rigid motion
        energy = 0.5 * xdot @ mm @ xdot
        assert energy == pytest.approx(0.5 * (rho_a * L**3 / 3 + rho_iz * L) * omega**2,
                                       rel=1e-13)


# ---------------------------------------------------------------------------- Table 3
TABLE3 = {("modified", 1): 1.495290, ("modified", 2): 1.069138, ("modified", 4): 1.015367,
          ("basic", 2): 1.220899, ("basic", 4): 1.046009}


def lateral_buckling_model(n, variant, EI=2.0, St=3.0, L=1.5, F=1.0):
    """Narrow cantilever, tip force in the stiff (x-y) plane; elongation and strong-axis
    bending (modes 5, 6) rigid, torsion and weak bending flexible."""
    return straight(n, L=L, stiffness=(0, St, EI, 0, 0, 0), def_class=(0, 1, 1, 1, 0, 0),
                    loads=[("tip", (0, F, 0))], variant=variant)


@pytest.mark.parametrize("variant,n", list(TABLE3))
def test_table3_lateral_buckling(variant, n):
    EI, St, L = 2.0, 3.0, 1.5
    prob, lin = linearized_final_state(lateral_buckling_model(n, variant), with_mass=False)
    ratio = buckling_modes(lin).critical / (F_TH_CONSTANT * np.sqrt(EI * St) / L**2)
    assert round(ratio, 6) == pytest.approx(TABLE3[(variant, n)], abs=1e-12)


def test_table3_one_basic_element_has_no_finite_multiplier():
    prob, lin = linearized_final_state(lateral_buckling_model(1, "basic"), with_mass=False)
    b = buckling_modes(lin)
    assert b.critical == np.inf and np.all(np.isnan(b.multiplier))


def test_table3_ratio_does_not_depend_on_the_rigidities():
    prob, lin = linearized_final_state(lateral_buckling_model(2, "modified", EI=7.0, St=0.3,
                                                              L=0.4, F=5.0), with_mass=False)
    f_cr = 5.0 * buckling_modes(lin).critical
    assert f_cr / (F_TH_CONSTANT * np.sqrt(7.0 * 0.3) / 0.4**2) == pytest.approx(1.069138,
                                                                                   abs=5e-7)


# ---------------------------------------------------------------------------- frequencies
BETA_L = np.array([1.8751040687, 4.6940911330, 7.8547574382, 10.9955407349])


def test_cantilever_bending_frequencies_converge_to_euler_bernoulli_with_order_4():
    exact = BETA_L**2 / (2 * np.pi)                 # L = EI = rhoA = 1
    errors = []
    for n in (4, 8, 16):
        md = modes_of(straight(n), 12)
        f = md.frequency[md.kind == ELASTIC]
        pairs = f.reshape(-1, 2)                     # y and z bending coincide
        np.testing.assert_allclose(pairs[:, 0], pairs[:, 1], rtol=1e-9)
        errors.append(np.abs(pairs[:4, 0] - exact) / exact)
    errors = np.array(errors)
    assert np.all(errors[-1] < [1e-6, 1e-4, 1e-3, 3e-3])
    order = np.log2(errors[1] / errors[2])
    assert np.all((order > 3.8) & (order < 4.2)), order


@pytest.mark.parametrize("rotary, sign", [("consistent", 1), ("lumped", -1)])
def test_first_torsion_frequency_converges_to_its_closed_form(rotary, sign):
    """Consistent rotary inertia converges from above, lumped (SPACAR's) from below."""
    GJ, rho_ip = 2.0, 0.5
    exact = np.sqrt(GJ / rho_ip) / 4.0               # (pi / 2L) sqrt(GJ / rho Ip) / 2 pi
    errors = []
    for n in (8, 16, 32):
        job = straight(n, stiffness=(1e6, GJ, 1e3, 1e3, 0, 0),
                       mass=(1.0, rho_ip, rho_ip / 2, rho_ip / 2, 0))
        md = modes_of(Job(job.model, job.settings.override(rotary_inertia=rotary)), 1)
        assert md.kind[0] == ELASTIC
        errors.append(md.frequency[0] / exact - 1)
    errors = np.array(errors)
    assert np.all(sign * errors > 0) and abs(errors[-1]) < 1e-3
    order = np.log2(errors[:-1] / errors[1:])
    assert np.all((order > 1.9) & (order < 2.1)), order


def test_free_free_beam_has_six_rigid_body_modes_reported_as_such():
    md = modes_of(straight(8, fixes="free", mass=(1.0, 0.01, 0.005, 0.005, 0)), 10)
    assert list(md.kind[:6]) == [RIGID_BODY] * 6
    assert np.all(md.frequency[:6] == 0.0)
    assert np.all(md.kind[6:] == ELASTIC) and md.frequency[6] > 1.0


def test_nodal_masses_add_up():
    """A massless cantilever with a tip point mass: f = sqrt(3 EI / (m L^3)) / 2 pi."""
    md = modes_of(straight(4, mass=(0, 0, 0, 0, 0),
                           nodal_masses=[NodalMass(9, (2.0,)), NodalMass(10, (1e-3, 0, 0, 1e-3,
                                                                                  0, 1e-3))]), 1)
    # the tip inertia lowers it slightly; with a tiny inertia the closed form holds closely
    assert md.frequency[0] == pytest.approx(np.sqrt(3 / 2.0) / (2 * np.pi), rel=2e-3)


# ---------------------------------------------------------------------------- stress stiffening
@pytest.mark.parametrize("ratio", [0.5, -0.5, -0.9])
def test_axial_load_changes_the_lowest_frequency_as_the_closed_form(ratio):
    """Pinned-pinned beam, axial force P (tension > 0): f(P)/f(0) = sqrt(1 + P / P_E)."""
    p_e = np.pi**2
    f0 = modes_of(straight(16, fixes="pinned"), 1).frequency[0]
    f = modes_of(straight(16, fixes="pinned", loads=[("tip", (ratio * p_e, 0, 0))]),
                 1).frequency[0]
    assert f / f0 == pytest.approx(np.sqrt(1 + ratio), rel=1e-4)


def test_frequency_goes_to_zero_at_the_euler_load_and_beyond_is_unstable():
    p_e = np.pi**2
    f0 = modes_of(straight(32, fixes="pinned"), 1).frequency[0]
    at = modes_of(straight(32, fixes="pinned", loads=[("tip", (-p_e, 0, 0))]), 1)
    assert abs(at.frequency[0]) < 5e-3 * f0
    beyond = modes_of(straight(32, fixes="pinned", loads=[("tip", (-1.2 * p_e, 0, 0))]), 1)
    assert beyond.kind[0] == UNSTABLE and beyond.frequency[0] < 0


@pytest.mark.parametrize("support,exact", [("pinned", np.pi**2), ("clamped", np.pi**2 / 4)])
def test_euler_loads_from_buckling_analysis(support, exact):
    prob, lin = linearized_final_state(straight(16, fixes=support,
                                                loads=[("tip", (-1.0, 0, 0))]), with_mass=False)
    assert buckling_modes(lin).critical == pytest.approx(exact, rel=5e-6)


def test_nodal_compliance_of_a_cantilever_tip_equals_the_closed_form():
    from spacarpy.solvers.linear.compliance import nodal_compliance
    EA, GJ, EIy, EIz, L = 100.0, 3.0, 2.0, 5.0, 1.7
    prob, lin = linearized_final_state(straight(4, L=L, stiffness=(EA, GJ, EIy, EIz, 0, 0)),
                                       with_mass=False)
    c_glob, c_loc = nodal_compliance(lin, prob.num, prob.free, 4, 4)
    ref = np.zeros((6, 6))
    ref[0, 0] = L / EA
    ref[1, 1], ref[5, 5], ref[1, 5] = L**3 / (3 * EIz), L / EIz, L**2 / (2 * EIz)
    ref[2, 2], ref[4, 4], ref[2, 4] = L**3 / (3 * EIy), L / EIy, -L**2 / (2 * EIy)
    ref[3, 3] = L / GJ
    ref = np.triu(ref) + np.triu(ref, 1).T
    np.testing.assert_allclose(c_glob, ref, rtol=1e-10, atol=1e-14)
    np.testing.assert_allclose(c_loc, ref, rtol=1e-10, atol=1e-14)   # undeformed: same axes


def test_compliance_under_load_is_expressed_in_the_rotated_body_axes():
    """Under a tip moment the tip rotates by theta about z: the local compliance equals the
    global one rotated by R(theta)^T, and the axial compliance stays L/EA in local axes."""
    from spacarpy.solvers.linear.compliance import nodal_compliance
    model = straight(16, stiffness=(1e4, 1.0, 1.0, 1.0, 0, 0), loads=[(34, (0, 0, 0.8))])
    prob, lin = linearized_final_state(model, with_mass=False)
    c_glob, c_loc = nodal_compliance(lin, prob.num, prob.free, 16, 16)
    q = lin.x[prob.num.rot_idx[16]]
    theta = 2 * np.arctan2(q[3], q[0])                 # close to M L / EI = 0.8
    assert theta == pytest.approx(0.8, rel=1e-3)
    c, s = np.cos(theta), np.sin(theta)
    r = np.kron(np.eye(2), np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]]))
    np.testing.assert_allclose(c_loc, r.T @ c_glob @ r, atol=1e-10)
    # rotation about z: L / EI for the inextensible elastica (discretization: 1e-3)
    assert c_loc[5, 5] == pytest.approx(1.0, rel=2e-3)


@pytest.mark.slow
def test_sparse_eigenvalues_of_a_fine_mesh_are_exact_rayleigh_quotients():
    """ARPACK's shift-invert eigenvalue inherits the sparse LU's error in the soft
    directions (8e-6 too high for the lowest frequency of a 5000-element cantilever); the
    Rayleigh quotient with the element-by-element material energy is converged like the
    coarse mesh's, to the 1e-9 the two meshes differ by."""
    from spacarpy.bench.decks import eigen_cantilever_deck
    from spacarpy.deck import model_from_text
    from spacarpy.solvers.linear import eigen as E
    from spacarpy.solvers.linear.linearize import MassAssembler, linearize
    from spacarpy.solvers.statics.static import StaticProblem
    f1 = {}
    for n in (300, 5000):
        model = model_from_text(eigen_cantilever_deck(n), f"<cantilever {n}>")
        prob = StaticProblem(model)
        lin = linearize(prob, prob.num.x0.copy(), np.zeros(prob.num.n_constraint),
                        prob.loads.at(0.0, 0.0), mass=MassAssembler(model, prob.num))
        assert lin.K.shape[0] > E.FEW_MODES_DENSE_LIMIT          # the sparse path
        md = E.eigenmodes(lin, prob.num, prob.free, n_modes=4)
        f1[n] = md.frequency[0]
        if n == 5000:
            lam, _ = E._sparse(lin, lin.K.shape[0], 4)
            arpack = np.sqrt(np.sort(lam.real)[0]) / (2 * np.pi)
            assert abs(arpack / f1[300] - 1) > 1e-6               # what the quotient mends
    assert abs(f1[5000] / f1[300] - 1) < 2e-8
