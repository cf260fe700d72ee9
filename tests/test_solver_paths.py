"""The static solver's fast paths give the same answers as the plain ones.

- the tangent-space Newton step (spacarpy.solvers.statics.reduced) equals the bordered one;
- the LDL^T factorization (qdldl) and its SuperLU fallback solve the same SPD systems;
- the kinematic correction with a kept factorization converges like a fresh one;
- an untouched configuration is never accepted on the residual's round-off floor alone;
- the baseline comparison's round-off floor separates noise from real changes.
"""
import numpy as np
import pytest
import scipy.sparse as sp

import spacarpy.solvers.linalg.sparse as sparse_mod
from spacarpy.batch.compare import _compare
from spacarpy.bench.cases import cantilever_deck
from spacarpy.deck import job_from_text, model_from_text
from spacarpy.solvers.linalg.triangular import DENSE_MAX, BlockTriangular
from spacarpy.solvers.statics import kinematic_check
from spacarpy.solvers.statics.kinematic_correction import (
    NormalEquations,
    ReducedNormalEquations,
    SquareJacobian,
)
from spacarpy.solvers.statics.static import StaticOptions, StaticProblem, solve_static


def cantilever(n, **kw):
    text = cantilever_deck(n, n_steps=kw.pop("n_steps", 10), tol=1e-9, compact=True)
    return model_from_text(text, "<cantilever>")


def off_equilibrium_state(prob, seed=0):
    """A deformed, loaded, not normalized state with nonzero multipliers."""
    rng = np.random.default_rng(seed)
    num = prob.num
    x = num.x0.copy()
    free = ~num.fixed_mask
    x[free] += 0.02 * rng.standard_normal(free.sum())
    mu = 1e3 * rng.standard_normal(num.n_constraint)
    return x, mu, prob.loads.at(1.0, 0.7)


def test_tangent_space_newton_step_equals_the_bordered_step():
    prob = StaticProblem(cantilever(6))
    assert prob.reduced is not None
    x, mu, load = off_equilibrium_state(prob)
    ev = prob.evaluate(x, mu, load)
    k_el, euler_diag, _ = prob.element_blocks(ev, mu)
    dx_r, dmu_r = prob.reduced.step(ev, x, mu, k_el, euler_diag)
    A = prob.matrix(ev, mu)
    dz = np.linalg.solve(A.toarray(), -np.concatenate([ev.r, prob.scale * ev.c]))
    dx, dmu = dz[:prob.pattern.n_x], dz[prob.pattern.n_x:] * prob.scale
    assert np.allclose(dx_r, dx, rtol=1e-8, atol=1e-10 * np.abs(dx).max())
    assert np.allclose(dmu_r, dmu, rtol=1e-7, atol=1e-9 * np.abs(dmu).max())
    # and it is a real Newton step: the Euler constraints are met to first order
    q, dq = x[prob.num.rot_idx[prob.num.euler_nodes]], np.zeros_like(x)
    dq[~prob.num.fixed_mask] = dx_r
    lin = np.sum(q * q, 1) - 1 + 2 * np.sum(q * dq[prob.num.rot_idx[prob.num.euler_nodes]], 1)
    assert np.abs(lin).max() < 1e-12


def test_models_with_rigid_modes_or_moments_keep_the_bordered_step():
    from pathlib import Path

    from spacarpy.deck import load_deck
    decks = Path(__file__).resolve().parents[1] / "decks"
    assert StaticProblem(load_deck(decks / "planar_four_bar.dat")).reduced is None
    assert StaticProblem(load_deck(decks / "table1_cantilever_8el_modified.dat")).reduced \
        is not None


@pytest.mark.parametrize("use_qdldl", [True, False])
def test_spd_factorization_solves_like_a_dense_solver(monkeypatch, use_qdldl):
    if not use_qdldl:
        monkeypatch.setattr(sparse_mod, "_qdldl", None)
    rng = np.random.default_rng(1)
    n = 60
    a = sp.random(n, n, density=0.1, random_state=2)
    m = (a @ a.T + sp.eye(n)).tocsc()
    f = sparse_mod.SPDFactorization()
    for shift in (0.0, 3.0):               # a second factorization on the same pattern
        mm = (m + shift * sp.eye(n)).tocsc()
        b = rng.standard_normal(n)
        x = f.factorize(sp.triu(mm, format="csc"))(b)
        assert np.allclose(x, np.linalg.solve(mm.toarray(), b), rtol=1e-10, atol=1e-12)


def test_singular_spd_matrix_raises_a_factorization_error():
    m = sp.csc_matrix(np.diag([1.0, 0.0, 2.0]))
    with pytest.raises(sparse_mod.FactorizationError):
        sparse_mod.SPDFactorization().factorize(sp.triu(m, format="csc"))(np.ones(3))


def test_fine_cantilever_converges_quadratically_with_few_factorizations():
    """200 elements, Table 1 load in 10 steps: 4 Newton iterations per step (the last one
    only confirms), and the kept Gauss-Newton factorization saves a good part of the
    correction's factorizations: two fresh Gauss-Newton steps after every correcting Newton
    iteration (the scheme before) would need ``its + 2 (its - steps)``."""
    model = cantilever(200)
    prob = StaticProblem(model)
    res = solve_static(model, problem=prob, options=StaticOptions(max_iter=20, tol=1e-8,
                                                                   n_steps=10))
    its = [s.iterations for s in res.steps[1:]]
    assert max(its) <= 4
    t = prob.timings
    assert t.factorizations <= 0.8 * (t.iterations + 2 * (t.iterations - len(its)))
    tip = res.steps[-1].x[prob.num.pos_idx[-1]]
    # converged to the 200-element answer, between Table 1's 128-element value and the limit
    assert abs(2.0 - tip[0] - 0.508551) < 2e-5 and abs(tip[1] - 1.207256) < 2e-5


def test_an_untouched_configuration_is_not_accepted_on_the_round_off_floor(monkeypatch):
    model = cantilever(4, n_steps=1)
    prob = StaticProblem(model)
    # as with 10^5 elements: every equation "within its floor"
    monkeypatch.setattr(prob, "at_floor", lambda *args, **kw: True)
    res = solve_static(model, problem=prob, options=StaticOptions(max_iter=20, tol=1e-9))
    assert res.steps[-1].iterations >= 1
    assert res.steps[-1].x[prob.num.pos_idx[-1]][1] > 1.0     # it did move (u_y ~ 1.22 m)


def test_baseline_comparison_floor_ignores_round_off_of_vanishing_values_only():
    base = np.array([1.3e6, -2.0e5, 3.1e-8, 0.0])
    noise = base + np.array([0.0, 0.0, -4e-7, 2e-7])        # 1e-13 of the scale
    assert _compare("/r", noise, base, 1e-6, 1e-9, floor=1e-9) is None
    assert _compare("/r", noise, base, 1e-6, 1e-9, floor=0.0) is not None
    real = base * np.array([1.0, 1.0 + 1e-5, 1.0, 1.0])       # a real change of 1e-5
    assert _compare("/r", real, base, 1e-6, 1e-9, floor=1e-9) is not None


@pytest.mark.parametrize("rotary", ["lumped", "consistent"])
def test_analytic_convective_terms_equal_the_differenced_ones(rotary):
    """The BEAM's dM/dt v and d(v^T M v)/dx (beam_convective) against unit central
    differences of its mass matrix, which are exact (M is quadratic in the Euler
    parameters), and the transient inertia forces with and without them (and with the
    kernel that skips the mass matrix, beam_inertia_force, and the kinetic energy from
    it), for either rotary inertia (lumped: the gyroscopic term of each end node's rigid
    body)."""
    import copy

    from spacarpy.elements import beam, beam_mass
    from spacarpy.solvers.dynamics.inertia import Inertia
    rng = np.random.default_rng(3)
    n = 7
    x, v = rng.standard_normal((n, 14)), rng.standard_normal((n, 14))
    nx, ny, nz, l0 = beam.reference_triads(rng.standard_normal((n, 3)),
                                           rng.standard_normal((n, 3)), np.full((n, 3), np.nan))
    mass = np.abs(rng.standard_normal((n, 5)))
    mdot_v, grad = beam_mass.beam_convective(x, v, nx, ny, nz, l0, mass, rotary)

    def f(xx):
        return np.einsum("ni,nij,nj->n", v, beam_mass.beam_mass_matrix(xx, nx, ny, nz, l0,
                                                                       mass, rotary), v)
    fd = np.stack([(f(x + e) - f(x - e)) / 2 for e in np.eye(14)], axis=1)
    assert np.allclose(grad, fd, rtol=1e-12, atol=1e-12 * np.abs(fd).max())
    dm = (beam_mass.beam_mass_matrix(x + v, nx, ny, nz, l0, mass, rotary)
          - beam_mass.beam_mass_matrix(x - v, nx, ny, nz, l0, mass, rotary)) / 2
    md = np.einsum("nij,nj->ni", dm, v)
    assert np.allclose(mdot_v, md, rtol=1e-12, atol=1e-12 * np.abs(md).max())

    from spacarpy.bench.decks import transient_cantilever_deck
    text = transient_cantilever_deck(5, 10)
    model = model_from_text(text, "<t>")
    prob = StaticProblem(model)
    xg = prob.num.x0 + 0.05 * rng.standard_normal(prob.num.n_coord)
    vg, ag = rng.standard_normal((2, prob.num.n_coord))
    fast = Inertia(model, prob.num, rotary)
    blocks, f_fast = fast.forces(xg, vg, ag)
    # the force without the mass matrix (beam_inertia_force) and the one from it agree
    lazy, f_lazy = fast.forces(xg, vg, ag, blocks=False)
    assert any(b is None for b in lazy)
    assert np.allclose(f_lazy, f_fast, rtol=1e-12, atol=1e-12 * np.abs(f_fast).max())
    assert all(np.array_equal(b, c) for b, c in zip(fast.complete(xg, lazy), blocks))
    vp = fast.physical(xg, vg)
    t_matrix = 0.5 * vp @ (fast.matrix(xg) @ vp)
    assert fast.kinetic_energy(xg, vg) == pytest.approx(t_matrix, rel=1e-12)
    for g in prob.num.groups:                       # the same model without the gradient
        g.kind = copy.copy(g.kind)
        g.kind.convective = g.kind.inertia_force = None
    _, f_diff = Inertia(model, prob.num, rotary).forces(xg, vg, ag)
    assert np.allclose(f_fast, f_diff, rtol=1e-11, atol=1e-11 * np.abs(f_diff).max())


def test_transient_steps_in_the_tangent_space_equal_the_bordered_ones(monkeypatch):
    from spacarpy.bench.decks import transient_cantilever_deck
    from spacarpy.solvers.dynamics.transient import TimeFunction, TransientOptions, solve_transient
    from spacarpy.solvers.statics import equilibrium as equilibrium_mod
    text = transient_cantilever_deck(6, 30)

    def run():
        model, settings = job_from_text(text, "<t>")
        opts = TransientOptions(t_end=settings.transient.timestep[0], n_steps=30, rho_inf=0.5,
                                tol=1e-10, phi=TimeFunction(*settings.transient.time_function))
        res = solve_transient(model, opts)
        tip_y = res.steps[-1].x[res.problem.num.pos_idx[-1][1]]
        return res.problem.reduced is not None, res.steps[-1].x, res.n_newton, tip_y

    reduced, x_r, its_r, tip = run()
    monkeypatch.setattr(equilibrium_mod, "reduced_applies", lambda prob: False)
    bordered, x_b, its_b, _ = run()
    assert reduced and not bordered
    assert its_r == its_b
    assert np.allclose(x_r, x_b, rtol=0, atol=1e-11)
    assert tip > 1e-3                 # the tip has moved (u_y of cm after 30 ms)


def test_few_modes_of_a_mid_size_model_come_from_the_sparse_solver_unchanged():
    from spacarpy.bench.decks import eigen_cantilever_deck
    from spacarpy.solvers.linear import eigen
    from spacarpy.solvers.linear.linearize import MassAssembler, linearize
    text = eigen_cantilever_deck(60)                     # 420 free coordinates
    model = model_from_text(text, "<e>")
    prob = StaticProblem(model)
    x, mu = prob.num.x0.copy(), np.zeros(prob.num.n_constraint)
    lin = linearize(prob, x, mu, prob.loads.at(0.0, 0.0), mass=MassAssembler(model, prob.num))
    assert lin.K.shape[0] > eigen.FEW_MODES_DENSE_LIMIT
    sparse = eigen.eigenmodes(lin, prob.num, prob.free, n_modes=10)
    dense = eigen.eigenmodes(lin, prob.num, prob.free, n_modes=10, dense_limit=10**6)
    # the dense solve's round-off on this pencil is 0.4e-9 to 1.7e-9 (measured; it depends
    # on the BLAS threads); the sparse one's Rayleigh quotients are sharper: the y/z bending
    # pairs agree to round-off
    assert np.allclose(sparse.frequency, dense.frequency, rtol=1e-8)
    f = sparse.frequency
    assert np.allclose(f[[0, 2]], f[[1, 3]], rtol=1e-12)
    assert np.array_equal(sparse.kind, dense.kind)
    assert abs(dense.frequency[0] - 20.727) < 0.01       # first bending mode (Hz)


# ------------------------------------------------------------------ conditioning (issue 9)
def test_element_wise_product_equals_the_assembled_matrix_and_ignores_translations():
    """ReducedNewton's element-by-element K z (positions taken relative to each element's
    first node) is the assembled reduced matrix times z; a uniform translation of all nodes
    gives exactly zero (the assembled product only round-off), which is what keeps the
    soft bending directions of a 10^5-element beam resolvable."""
    prob = StaticProblem(cantilever(6))
    red = prob.reduced
    x, mu, load = off_equilibrium_state(prob)
    ev = prob.evaluate(x, mu, load)
    k_el, euler_diag, _ = prob.element_blocks(ev, mu)
    k_rot = red.rotate(k_el, red.basis(x[red.eu]))
    diag = np.broadcast_to(euler_diag[:, None, None] * np.eye(4), (red.nodes.size, 4, 4))
    upper = red.pattern.assemble([k.copy() for k in k_rot] + [diag]).toarray()
    a = upper + np.triu(upper, 1).T
    y = np.random.default_rng(1).standard_normal(red.n)
    ay = red._reduced_times(k_rot, euler_diag, y)
    assert np.allclose(ay, a @ y, rtol=0, atol=1e-12 * np.abs(a).max() * np.abs(y).max())
    shift = np.zeros(prob.num.n_coord)
    shift[prob.num.pos_idx] = [1e3, -2e3, 5e2]     # every free position node moves alike
    t = shift[red.keep]
    # beyond the first free node (whose element also holds the clamped node, which stays)
    # every element just translates: exactly zero, where the assembled product has round-off
    rest = slice(6, None)
    assert np.array_equal(red._reduced_times(k_rot, euler_diag, t)[rest], np.zeros(red.n - 6))
    assert np.abs((a @ t)[rest]).max() > 0


def test_refinement_recovers_the_solution_from_a_poor_or_indefinite_preconditioner():
    """The step is solved by conjugate gradients (GMRES when the preconditioner is not
    positive definite) with the LDL^T as preconditioner: even a preconditioner 40 % off, or
    with a negative eigenvalue, gives the solution to round-off."""
    prob = StaticProblem(cantilever(4))
    rng = np.random.default_rng(3)
    n = 30
    q, _ = np.linalg.qr(rng.standard_normal((n, n)))
    lam = np.logspace(-6, 0, n)
    a = (q * lam) @ q.T
    b = rng.standard_normal(n)
    exact = np.linalg.solve(a, b)
    for wrong in (1.4, -1.0):            # the softest direction 40 % too stiff; negative
        lam_p = lam.copy()
        lam_p[0] *= wrong
        p_inv = (q / lam_p) @ q.T
        y = prob.reduced._refine(lambda v: p_inv @ v, lambda v: a @ v, b)
        assert y is not None
        assert np.abs(y - exact).max() < 1e-8 * np.abs(exact).max()
        assert np.abs(p_inv @ b - exact).max() > 1e-2 * np.abs(exact).max()


def test_square_kinematic_correction_agrees_with_the_normal_equations():
    """For a tree (as many deformations and normalizations as free coordinates) the
    kinematic correction solves W step = g by LU; it lands where the normal equations
    W^T W step = W^T g land. A closed loop keeps the normal equations."""
    from pathlib import Path

    from spacarpy.deck import load_deck
    decks = Path(__file__).resolve().parents[1] / "decks"
    assert isinstance(StaticProblem(load_deck(decks / "leafspring_guidance_buckling.dat"))
                      .corrector.system, NormalEquations)
    results = []
    for solver in ("triangular", "superlu", "normal"):
        prob = StaticProblem(cantilever(8))
        kin = prob.corrector
        assert isinstance(kin.system, SquareJacobian)
        assert isinstance(kin.system.solver, BlockTriangular)   # a tree: forward substitution
        if solver == "superlu":
            kin.system = SquareJacobian(prob.num, triangular=False)
        elif solver == "normal":
            kin.system = NormalEquations(prob.num)
        x, mu, load = off_equilibrium_state(prob, seed=4)
        x = prob.normalize(x)
        ev = prob.evaluate(x, mu, load)
        dx = 0.05 * np.random.default_rng(5).standard_normal(prob.num.n_unknown)
        x_lin = x.copy()
        x_lin[prob.free] += dx
        results.append(prob.correct_kinematics(x_lin, dx, ev.states))
    assert np.abs(results[0] - results[1]).max() < 1e-12      # the same linear system
    assert np.abs(results[0] - results[2]).max() < 1e-8       # both stop at their floor
    assert np.abs(results[0] - x_lin).max() > 1e-4          # it did correct something


def test_reduced_normal_equations_solve_the_constrained_least_squares():
    """Where Newton's steps are reduced and W is not square (a closed loop of 3D beams), the
    kinematic correction's Gauss-Newton step fits the element rows in least squares while
    it meets every Euler row exactly: the same step as the KKT system
    ``[W^T W, C^T; C, 0] [dx; l] = [W^T g_e; g_q]`` solved densely (C: the rows 2 q^T)."""
    from spacarpy.bench.decks import lattice_deck
    model, _ = job_from_text(lattice_deck(2, 2, 3), "<lattice>")
    prob = StaticProblem(model)
    kin = prob.corrector
    assert prob.reduced is not None
    assert isinstance(kin.system, ReducedNormalEquations)
    num = prob.num
    x, mu, load = off_equilibrium_state(prob, seed=2)
    states = prob.evaluate(x, mu, load).states
    w_e, wq = kin.jacobian_blocks(states, x)
    rng = np.random.default_rng(7)
    g_e = [rng.standard_normal(w.shape[:2]) for w in w_e]
    g_q = 0.1 * rng.standard_normal(wq.shape[0])
    step = kin.system.factorize(w_e, wq, prob.timings)(g_e, g_q, w_e, wq)

    free_of = np.full(num.n_coord, -1)
    free_of[prob.free] = np.arange(prob.free.sum())
    n = int(prob.free.sum())
    rows = []
    for g, w in zip(num.groups, w_e):
        for e in range(w.shape[0]):
            block = np.zeros((w.shape[1], n))
            cols = free_of[g.idx[e]]
            block[:, cols[cols >= 0]] = w[e][:, cols >= 0]
            rows.append(block)
    W = np.vstack(rows)
    C = np.zeros((wq.shape[0], n))
    C[np.arange(wq.shape[0])[:, None], free_of[num.euler_coords]] = wq
    kkt = np.block([[W.T @ W, C.T], [C, np.zeros((C.shape[0], C.shape[0]))]])
    exact = np.linalg.solve(kkt, np.concatenate([W.T @ np.concatenate(
        [v.ravel() for v in g_e]), g_q]))[:n]
    assert np.abs(step - exact).max() < 1e-9 * np.abs(exact).max()
    assert np.abs(C @ step - g_q).max() < 1e-12        # the Euler rows exactly
    # and not the unconstrained least squares of all rows together
    plain = np.linalg.lstsq(np.vstack([W, C]), np.concatenate(
        [np.concatenate([v.ravel() for v in g_e]), g_q]), rcond=None)[0]
    assert np.abs(plain - exact).max() > 1e-4 * np.abs(exact).max()


def test_a_model_far_from_the_origin_converges_like_one_at_the_origin():
    """The residual's round-off floor follows the coordinates' magnitude: the cantilever
    moved 100 km along its axis reaches the same tip deflection in as many iterations
    (it used to stall on a residual of 3e-6 that no iteration could reduce)."""
    tips, its = [], []
    for offset in (0.0, 1e5):
        text = cantilever_deck(40, n_steps=4, tol=1e-9, compact=True, shear=10.0)
        lines = []
        for ln in text.splitlines():
            if ln.startswith("X "):
                f = ln.split()
                f[2] = repr(float(f[2]) + offset)
                ln = " ".join(f)
            lines.append(ln)
        model, settings = job_from_text("\n".join(lines), "<moved cantilever>")
        prob = StaticProblem(model)
        res = solve_static(model, settings, problem=prob,
                           options=StaticOptions(max_iter=20, tol=1e-9, n_steps=4, max_cuts=0))
        tips.append(res.steps[-1].x[prob.num.pos_idx[-1]] - [offset, 0, 0])
        its.append([s.iterations for s in res.steps])
    assert its[0] == its[1]
    assert np.abs(tips[0] - tips[1]).max() < 1e-9


def test_initial_check_of_a_determinate_tree_needs_no_lu(monkeypatch):
    """A tree whose every mode carries stiffness, with a regular W, has neither mechanism
    nor redundant constraint: the initial check passes without the bordered LU. A closed
    loop, or a singular W, gets the full check."""
    from pathlib import Path

    from spacarpy.deck import load_deck
    calls = []
    original = kinematic_check.bordered_solve

    def spy(*args, **kwargs):
        calls.append(1)
        return original(*args, **kwargs)
    monkeypatch.setattr(kinematic_check, "bordered_solve", spy)
    kinematic_check.check_initial(StaticProblem(cantilever(16)))
    assert calls == []
    decks = Path(__file__).resolve().parents[1] / "decks"
    kinematic_check.check_initial(
        StaticProblem(load_deck(decks / "leafspring_guidance_buckling.dat")))
    assert calls == [1]                                  # a closed loop: the full check
    # a singular diagonal block (the Euler row of a zero quaternion) is not regular
    prob = StaticProblem(cantilever(4))
    mu, load = np.zeros(prob.num.n_constraint), prob.loads.unloaded()
    x = prob.num.x0.copy()
    assert kinematic_check.determinate(prob, prob.evaluate(x, mu, load).states, x)
    x[prob.num.rot_idx[prob.num.euler_nodes[0]]] = 0.0
    assert not kinematic_check.determinate(prob, prob.evaluate(x, mu, load).states, x)


@pytest.mark.slow
@pytest.mark.parametrize("n_elem", [DENSE_MAX // 7, DENSE_MAX // 7 + 1])
def test_dense_and_sparse_kinematic_substitution_give_the_same_path(n_elem, monkeypatch):
    """The kinematic correction's block forward substitution solves with a dense L up to
    DENSE_MAX unknowns (7 per cantilever element) and a sparse one above: just below and
    just above the threshold, each path forced, the static solve takes the same Newton
    iterations in every load step and reaches the same states to round-off."""
    import spacarpy.solvers.linalg.triangular as tri
    model = cantilever(n_elem, n_steps=3)
    runs = []
    for limit in (10**9, 0):                              # dense, then sparse
        monkeypatch.setattr(tri, "DENSE_MAX", limit)
        prob = StaticProblem(model)
        res = solve_static(model, problem=prob, options=StaticOptions(n_steps=3, tol=1e-9))
        assert prob.corrector.system.solver.dense == (limit > 0)
        runs.append(res)
    dense, sparse = runs
    assert [s.iterations for s in dense.steps] == [s.iterations for s in sparse.steps]
    for a, b in zip(dense.steps, sparse.steps):
        assert np.abs(a.x - b.x).max() <= 1e-12 * np.abs(b.x).max()


def test_the_sparse_eigen_solver_says_when_it_gives_fewer_modes_than_asked(monkeypatch):
    """Where the sparse solver's modes come back infinite (not resolved, or without
    inertia) fewer modes are stored: a warning names how many of how many, never a silent
    shorter list; with all ten resolved there is no warning."""
    from spacarpy.bench.decks import eigen_cantilever_deck
    from spacarpy.solvers.linear import eigen
    from spacarpy.solvers.linear.linearize import MassAssembler, linearize
    model = model_from_text(eigen_cantilever_deck(60), "<e>")
    prob = StaticProblem(model)
    x, mu = prob.num.x0.copy(), np.zeros(prob.num.n_constraint)
    lin = linearize(prob, x, mu, prob.loads.at(0.0, 0.0), mass=MassAssembler(model, prob.num))
    warnings = []
    monkeypatch.setattr(eigen.log, "warning", lambda *a: warnings.append(a))
    full = eigen.eigenmodes(lin, prob.num, prob.free, n_modes=10)
    assert full.frequency.size == 10 and warnings == []
    found = eigen.lowest_modes

    def seven_left(*args, **kw):
        lam, vec = found(*args, **kw)
        lam = lam.astype(complex)
        lam[7:] = complex(np.inf, 0.0)              # all but the lowest seven
        return lam, vec
    monkeypatch.setattr(eigen, "lowest_modes", seven_left)
    short = eigen.eigenmodes(lin, prob.num, prob.free, n_modes=10)
    assert short.frequency.size == 7
    assert len(warnings) == 1 and warnings[0][1:] == (short.frequency.size, 10)
