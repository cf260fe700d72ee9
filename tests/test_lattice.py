"""The 3D beam lattice of ``spacarpy bench --cases lattice`` (spacarpy.bench.decks) and its
shipped deck decks/lattice.dat: the generator's counts and grid choice, a column of the
lattice against Timoshenko beam theory, and the equilibrium of the whole lattice."""
from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from spacarpy.bench.decks import (
    LATTICE,
    lattice_deck,
    lattice_elements,
    lattice_grid,
    lattice_node,
)
from spacarpy.bench.runner import lattice_top_ux
from spacarpy.deck import job_from_text
from spacarpy.solvers.statics.static import StaticOptions, StaticProblem, solve_static

DECKS = Path(__file__).resolve().parents[1] / "decks"


def _solve(kx, ky, m, tol=1e-10):
    model, settings = job_from_text(lattice_deck(kx, ky, m), f"<lattice {kx}x{ky}x{m}>")
    prob = StaticProblem(model, deformations=settings.deformations)
    res = solve_static(model, problem=prob,
                       options=StaticOptions(max_iter=20, tol=tol, n_steps=LATTICE["steps"]))
    return model, prob, res


def _mean_top_ux(kx, ky, m, tol=1e-10):
    """spacarpy's mean displacement along x of the lattice's top nodes, and the timings."""
    model, prob, res = _solve(kx, ky, m, tol)
    top = [lattice_node(kx, ky, i, j, m - 1) for j in range(ky) for i in range(kx)]
    return lattice_top_ux(model, prob, res.steps[-1].x, top), prob.timings


@pytest.mark.parametrize("grid", [(1, 1, 2), (2, 3, 2), (3, 2, 4), (5, 5, 8)])
def test_generator_counts(grid):
    kx, ky, m = grid
    text = lattice_deck(kx, ky, m)
    beams = re.findall(r"^BEAM (\d+) (\d+) (\d+) (\d+) (\d+)", text, re.M)
    assert len(beams) == lattice_elements(kx, ky, m)
    # every beam joins grid neighbours 0.1 m apart, each pair once
    xyz = {int(n): np.array(v, dtype=float) for n, *v in
           re.findall(r"^X (\d+) (\S+) (\S+) (\S+)$", text, re.M)}
    assert len(xyz) == kx * ky * m
    pairs = {(int(p), int(q)) for _, p, _, q, _ in beams}
    assert len(pairs) == len(beams)
    for _, p, r, q, s in beams:
        assert int(r) == int(p) + 1 and int(s) == int(q) + 1
        assert np.linalg.norm(xyz[int(q)] - xyz[int(p)]) == pytest.approx(LATTICE["l"])
    fixed = {int(n) for n in re.findall(r"^FIX (\d+)$", text, re.M)}
    bottom = {lattice_node(kx, ky, i, j, 0) for i in range(kx) for j in range(ky)}
    assert fixed == bottom | {n + 1 for n in bottom}
    loaded = [int(n) for n in re.findall(r"^DELXF (\d+) \{F\} 0 0$", text, re.M)]
    assert sorted(loaded) == sorted(lattice_node(kx, ky, i, j, m - 1)
                                    for i in range(kx) for j in range(ky))
    assert all(xyz[n][2] == pytest.approx((m - 1) * LATTICE["l"]) for n in loaded)


@pytest.mark.parametrize("target", [1000, 10000, 30000, 100000])
def test_grid_for_a_target_size(target):
    kx, ky, m = lattice_grid(target)
    assert kx == ky and abs(m - 2 * kx) <= 0.25 * m
    assert abs(lattice_elements(kx, ky, m) - target) <= 0.02 * target


def test_shipped_deck_is_the_generators():
    assert (DECKS / "lattice.dat").read_text() == lattice_deck(5, 5, 8)


@pytest.mark.parametrize("m, rel", [(2, 2e-5), (3, 2e-4)])
def test_column_against_timoshenko(m, rel):
    """A 1 x 1 x m lattice is a cantilever column of m - 1 members under 50 N along x: its
    top moves F L^3 / 3EI + F L / kGA (linear Timoshenko; the spacarpy beam is exact for it
    with one element per member). The shear term is 0.77 % of the deflection at m = 2 and
    0.2 % at m = 3, so the tolerances catch a shear flexibility that is 0.3 % or 10 % off;
    what is left is the geometric nonlinearity (end rotation 1.4e-3 and 5.8e-3 rad)."""
    c = LATTICE
    area, inertia = c["a"] ** 2, c["a"] ** 4 / 12
    g = c["E"] / (2 * (1 + c["nu"]))
    length = (m - 1) * c["l"]
    theory = (c["F"] * length**3 / (3 * c["E"] * inertia)
              + c["F"] * length / (c["kappa"] * g * area))
    model, prob, res = _solve(1, 1, m)
    ux = lattice_top_ux(model, prob, res.steps[-1].x, [lattice_node(1, 1, 0, 0, m - 1)])
    assert ux == pytest.approx(theory, rel=rel)


def test_lattice_in_equilibrium():
    """The clamps' reactions balance the 9 top forces: the force sum to 1e-10 of the load,
    and the moment about the origin (deformed positions) to 1e-10 of the load's moment."""
    kx, ky, m = 3, 3, 3
    model, prob, res = _solve(kx, ky, m)
    step = res.steps[-1]
    x = step.x
    where = {int(p): k for k, p in enumerate(model.position_ids)}
    pos = lambda n: x[prob.num.pos_idx[where[n]]]              # noqa: E731
    force, moment = np.zeros(3), np.zeros(3)
    for n, name, value in zip(prob.reaction_node, prob.reaction_component, step.reaction):
        axis = "xyz".index(name[1])
        if name[0] == "F":
            f = np.zeros(3)
            f[axis] = value
            force += f
            moment += np.cross(pos(int(n)), f)
        else:
            moment[axis] += value
    total = LATTICE["F"] * kx * ky
    load = np.array([LATTICE["F"], 0.0, 0.0])
    top = [lattice_node(kx, ky, i, j, m - 1) for i in range(kx) for j in range(ky)]
    load_moment = sum(np.cross(pos(n), load) for n in top)
    np.testing.assert_allclose(force, [-total, 0.0, 0.0], rtol=0, atol=1e-10 * total)
    np.testing.assert_allclose(moment, -load_moment, rtol=0,
                               atol=1e-10 * np.linalg.norm(load_moment))


def test_lattice_against_exudyn():
    """The bench's peer: Exudyn's geometrically exact beam, 4 and 8 elements per member,
    extrapolated in the mesh (spacarpy.bench.peers.exudyn_lattice), reaches spacarpy's mean
    top displacement to 1e-4 (measured 1.1e-5 at 4 x 4 x 13; with one Exudyn element per
    member it is 6 times too stiff)."""
    pytest.importorskip("exudyn")
    from spacarpy.bench.peers.exudyn_lattice import extrapolated
    kx, ky, m = 2, 2, 3
    ours, _ = _mean_top_ux(kx, ky, m)
    peer = extrapolated(kx, ky, m)
    assert peer["ok"], peer["reason"]
    assert peer["top_ux"] == pytest.approx(ours, rel=1e-4)
    assert abs(peer["coarse"]["top_ux"] / ours - 1) > 1e-3     # the mesh matters


def test_exudyn_newton_matrix_is_exudyns():
    """The Newton matrix that lattice_newton assembles from Exudyn's items equals Exudyn's
    own (GetSystemJacobian, dense) at a perturbed state."""
    pytest.importorskip("exudyn")
    import tempfile

    import exudyn as exu

    from spacarpy.bench.peers.exudyn_cantilever import _settings
    from spacarpy.bench.peers.exudyn_lattice import _ExudynJacobian, _model
    SC, mbs, top = _model(exu, 2, 2, 3, 2)
    sd = mbs.systemData
    n2, nae = sd.ODE2Size(), sd.AEsize()
    kinds = {}
    for i in range(sd.NumberOfObjects()):
        kinds.setdefault(mbs.GetObject(i)["objectType"], []).append(i)
    rng = np.random.default_rng(2)
    cur = exu.ConfigurationType.Current
    q, lam = rng.normal(scale=1e-3, size=n2), rng.normal(size=nae)
    sd.SetODE2Coordinates(q, configuration=cur)
    sd.SetAECoordinates(lam, configuration=cur)
    with tempfile.TemporaryDirectory() as tmp:
        settings = _settings(exu, tmp)
        solver = exu.MainSolverStatic()
        solver.InitializeSolver(mbs, settings)
        sd.SetODE2Coordinates(q, configuration=cur)
        sd.SetAECoordinates(lam, configuration=cur)
        solver.it.currentTime = 1.0
        solver.ComputeNewtonJacobian(mbs, settings)
        theirs = np.array(solver.GetSystemJacobian())
    ours = _ExudynJacobian(exu, mbs, kinds, n2)().toarray()
    assert np.abs(theirs).max() > 1e8
    np.testing.assert_allclose(ours, theirs, rtol=0, atol=1e-12 * np.abs(theirs).max())
    assert np.abs(ours - ours.T).max() > 0          # the constraint blocks' signs differ


@pytest.mark.parametrize("mesh", [1, 2])
def test_exudyn_equations_solved_with_pardiso(mesh):
    """lattice_newton solves Exudyn's own lattice equations (its residual and its items'
    Jacobians) with PARDISO: the root is Exudyn's SolveStatic answer to 1e-10 (measured
    1e-13; at 6 x 6 x 11 4e-13, at 12 x 12 x 25 with one beam per member 2e-12), in no more
    Newton iterations than Exudyn's own."""
    pytest.importorskip("exudyn")
    from spacarpy.bench.peers.exudyn_lattice import lattice, lattice_newton
    from spacarpy.solvers.linalg.pardiso import available
    if not available():
        pytest.skip("MKL PARDISO is not installed")
    own = lattice(2, 2, 3, mesh=mesh)
    ours = lattice_newton(2, 2, 3, mesh=mesh)
    assert own["ok"] and ours["ok"], ours["reason"]
    assert ours["top_ux"] == pytest.approx(own["top_ux"], rel=1e-10)
    assert LATTICE["steps"] <= ours["iterations"] <= own["iterations"]
    assert ours["unknowns"] > 0 and ours["factor_entries"] > 0


def test_exudyn_own_solve_process():
    """own_solve runs Exudyn's SolveStatic in a fresh process: its answer is lattice()'s,
    its whole-process time exceeds the solve's; a limit stops it (a lower bound, shown as
    ">T" with a ratio "<x"), it does not hang the bench."""
    pytest.importorskip("exudyn")
    from spacarpy.bench.peers.exudyn_lattice import lattice, own_solve
    from spacarpy.bench.tables import _text_table
    run = own_solve(2, 2, 3, mesh=1, limit=300)
    assert run["ok"] and run["stopped"] is None, run["reason"]
    assert run["top_ux"] == pytest.approx(lattice(2, 2, 3, mesh=1)["top_ux"], rel=1e-12)
    assert run["whole"] > run["total"] > 0
    cut = own_solve(2, 2, 3, mesh=1, limit=0.05)
    assert not cut["ok"] and cut["stopped"] == "time" and "time limit" in cut["reason"]
    assert cut["limit"] == 0.05
    full = own_solve(2, 2, 3, mesh=1, limit=300, memory=1)       # any process is too big
    if full["stopped"] is not None:                               # Linux: /proc is read
        assert full["stopped"] == "memory" and "resident" in full["reason"]
        assert full["limit"] < 300                                # the seconds it ran
    row = dict(n=20, grid="2x2x3", total=2.0, whole=3.0, result=1.0e-4,
               peer=dict(ok=True, result=1.0e-4 * (1 + 3e-5), iterations=None,
                         total=None, whole=None, stopped="time", limit=900.0,
                         reason=cut["reason"]))
    head, _, line = _text_table("lattice", [row], "exudyn")
    assert "rel. diff" in head and "Exudyn whole s" in head
    assert ">900" in line and "<0.002" in line and "<0.003" in line     # time, ratios
    assert " 3.0e-05 " in line                                             # the difference


def test_lattice_against_opensees():
    """The bench's other peer: OpenSees' force-based beam (elastic section with shear, three
    Lobatto points, Corotational transformation), one element per member
    (spacarpy.bench.peers.opensees_lattice), reaches spacarpy's mean top displacement at
    4 x 4 x 5 to 1e-6 (measured 3e-8: both are exact for the member's linear basic system and
    take its large rotations corotationally; on a 1 x 1 x 3 column, rotations 6e-3 rad, they
    differ by 2e-6). Without shear flexibility OpenSees' answer moves by 2.9 %, with
    two Lobatto points (the trapezoid rule) by 180 %: both would fail."""
    from spacarpy.bench.peers.opensees_lattice import available, lattice
    ok, why = available()
    if not ok:
        pytest.skip(why)
    kx, ky, m = 4, 4, 5
    ours, _ = _mean_top_ux(kx, ky, m)
    peer = lattice(kx, ky, m)
    assert peer["ok"], peer["reason"]
    assert peer["top_ux"] == pytest.approx(ours, rel=1e-6)
    assert peer["iterations"] >= LATTICE["steps"] and peer["total"] > 0


def test_opensees_peer_is_named_in_the_table():
    """``--peer opensees`` heads the lattice's peer columns with OpenSees (Exudyn stays the
    name of ``--peer exudyn`` and of the old boolean), and an unknown peer is refused."""
    from spacarpy.bench.runner import run_bench
    from spacarpy.bench.tables import _text_table
    row = dict(n=10, grid="2x2x3", result=1e-4,
               peer=dict(ok=True, total=0.5, iterations=6, result=1.0e-4))
    assert "OpenSees s" in _text_table("lattice", [row], "opensees")[0]
    for peer in ("exudyn", True):
        head = _text_table("lattice", [row], peer)[0]
        assert "Exudyn s" in head and "OpenSees" not in head
    with pytest.raises(ValueError, match="opensees"):
        run_bench(cases=("lattice",), peer="abaqus")


def test_bench_with_the_opensees_peer(capsys):
    """``spacarpy bench --cases lattice --peer opensees``: the row carries OpenSees' answer,
    spacarpy's to 1e-6, and its columns are headed OpenSees."""
    from spacarpy.bench.peers.opensees_lattice import available
    from spacarpy.bench.runner import run_bench
    ok, why = available()
    if not ok:
        pytest.skip(why)
    rows = run_bench(cases=("lattice",), sizes={"lattice": (30,)}, peer="opensees",
                     repeat=1)["lattice"]
    row = rows[0]
    assert row["peer"]["ok"], row["peer"]["reason"]
    assert row["peer"]["result"] == pytest.approx(row["result"], rel=1e-6)
    text = capsys.readouterr().out
    assert "OpenSees s" in text and "Exudyn" not in text


def test_bench_row_and_table():
    """The bench's lattice row: the grid it picks for a target, the deck's numbers and its
    top displacement, shown in the text table (no timing is checked)."""
    from spacarpy.bench.runner import _static_row
    from spacarpy.bench.tables import _text_table
    row = _static_row("lattice", 100, 1, 10)
    kx, ky, m = lattice_grid(100)
    assert row["grid"] == f"{kx}x{ky}x{m}" and row["n"] == lattice_elements(kx, ky, m)
    assert row["result"] == pytest.approx(_mean_top_ux(kx, ky, m, tol=1e-8)[0], rel=1e-6)
    line = _text_table("lattice", [row], False)[2]
    assert row["grid"] in line and f"{row['result']:.6e}" in line


def _top_ux(kx, ky, m, monkeypatch, backend):
    monkeypatch.setenv("SPACARPY_FACTORIZATION", backend)
    return _mean_top_ux(kx, ky, m)


def test_the_supernodal_path_gives_qdldls_answer_with_fewer_factorizations(monkeypatch):
    """The 6 x 6 x 11 lattice (2 160 reduced unknowns) goes to PARDISO by the rule; its
    answer is QDLDL's, and the Newton iterations reuse the factorization."""
    from spacarpy.solvers.linalg import pardiso
    if not pardiso.available():
        pytest.skip("MKL PARDISO not installed (pip install 'spacarpy[pardiso]'; x86-64)")
    ux_q, t_q = _top_ux(6, 6, 11, monkeypatch, "qdldl")
    ux_p, t_p = _top_ux(6, 6, 11, monkeypatch, "auto")
    assert abs(ux_p - ux_q) <= 1e-9 * abs(ux_q)      # Newton to 1e-10 on both paths
    assert t_q.reuses == 0 and t_p.reuses >= 1
    assert t_p.factorizations < t_q.factorizations


@pytest.mark.parametrize("backend", ["qdldl", "auto"])
def test_a_floating_lattice_is_a_mechanism_on_either_path(monkeypatch, backend):
    """Without its clamps the lattice floats: six free motions. The supernodal LDL^T
    perturbs pivots on that singular matrix and hands it to SuperLU, whose diagnosis
    names the mechanism, as on the QDLDL path."""
    from spacarpy.errors import ModelError
    monkeypatch.setenv("SPACARPY_FACTORIZATION", backend)
    text = "\n".join(line for line in lattice_deck(6, 6, 11).splitlines()
                     if not line.startswith("FIX"))
    model, settings = job_from_text(text, "<floating lattice>")
    prob = StaticProblem(model, deformations=settings.deformations)
    with pytest.raises(ModelError, match="mechanism"):
        solve_static(model, problem=prob, options=StaticOptions(max_iter=20, tol=1e-10,
                                                                n_steps=1))
