"""Arc-length continuation (ARCLENGTH, spacarpy/solvers/path/arclength.py) and the load-stepping
snap-through warning, on the shallow two-bar (von Mises) truss whose equilibrium path is
known in closed form, and on a column (quadratic convergence, bifurcation, branch switch).

The truss (decks/two_bar_truss_arclength.dat): supports at (-1, 0) and (1, 0), apex at
(0, h = 0.3), TRUSS elements (elongation e = l - l0, force EA e / l0, EA = 1e4 N), DELXF
P = 200 N downward at the apex. With the apex at height y (x = 0 by symmetry) its vertical
equilibrium 2 (EA/l0)(l - l0) y / l = -lambda P gives the path

    lambda(y) = -(2 EA / P) y (1/l0 - 1/l),   l = sqrt(1 + y^2),  l0 = sqrt(1 + h^2),

with limit points where d lambda / dy = 0: 1/l0 - 1/l + y^2/l^3 = 0, i.e. l^3 = l0,
y = +-sqrt(l0^(2/3) - 1), lambda = +-(2 EA / P) y* (l0^(-1/3) - 1/l0) = +-0.476514599...
"""
from __future__ import annotations

from pathlib import Path

import h5py
import numpy as np
import pytest
from scipy.optimize import brentq

from spacarpy.bench.cases import arclength_column_deck
from spacarpy.bench.runner import convergence_order
from spacarpy.cli import main
from spacarpy.deck import job_from_text, load
from spacarpy.errors import ModelError
from spacarpy.results.validate import validate_file
from spacarpy.solvers.path.arclength import ArcLengthPath, point_at
from spacarpy.solvers.statics.static import StaticOptions, StaticProblem, solve_static

DECKS = Path(__file__).resolve().parents[1] / "decks"
ARC_DECK = DECKS / "two_bar_truss_arclength.dat"
EA, P, H = 1e4, 200.0, 0.3
L0 = np.sqrt(1 + H**2)


def truss_load_factor(y):
    """The closed-form path lambda(y) of the deck's truss (module docstring)."""
    return -(2 * EA / P) * y * (1 / L0 - 1 / np.sqrt(1 + y**2))


Y_STAR = np.sqrt(L0 ** (2 / 3) - 1)
LAMBDA_MAX = (2 * EA / P) * Y_STAR * (L0 ** (-1 / 3) - 1 / L0)


@pytest.fixture(scope="module")
def arc_file(result_files):
    """decks/two_bar_truss_arclength.dat run by ``spacarpy run`` (the shared result files)."""
    return result_files["arclength"]


def test_the_closed_form_limit_point_is_a_maximum_of_the_path():
    # the reference itself: a stationary point of lambda(y), larger than its neighbours
    d = 1e-6
    assert abs(truss_load_factor(Y_STAR + d) - truss_load_factor(Y_STAR - d)) < 1e-9
    assert truss_load_factor(Y_STAR) > truss_load_factor(Y_STAR + 1e-3)
    assert truss_load_factor(Y_STAR) > truss_load_factor(Y_STAR - 1e-3)
    assert LAMBDA_MAX == pytest.approx(0.4765146, abs=1e-7)


def test_every_point_of_the_traced_s_curve_is_on_the_closed_form_path(arc_file):
    with h5py.File(arc_file) as f:
        lam = f["static/load_factor"][()]
        apex = f["static/position"][:, 1, :]          # node 3
        arc = f["static/arc_length"][()]
    assert np.abs(lam - truss_load_factor(apex[:, 1])).max() < 1e-8
    assert np.abs(apex[:, 0]).max() < 1e-8              # symmetric: the apex moves straight down
    # through the load maximum, down to the load minimum and up onto the inverted branch
    k_min = int(np.argmin(lam))
    k_max = int(np.argmax(lam[:k_min]))
    assert 0 < k_max < k_min < lam.size - 1
    assert lam[k_max] > 0.47 and lam[k_min] < -0.47 and lam[-1] == 1.0
    assert np.all(np.diff(arc) > 0) and np.all(np.diff(apex[:, 1]) < 0)
    # the last point is the inverted equilibrium at lambda = 1 (the root of lambda(y) = 1
    # below -y*)
    y_end = brentq(lambda y: truss_load_factor(y) - 1.0, -1.0, -Y_STAR)
    assert apex[-1, 1] == pytest.approx(y_end, abs=1e-9)
    # every point converged
    with h5py.File(arc_file) as f:
        assert f["static/residual"][()].max() < 1e-12


def test_both_limit_loads_match_the_closed_form(arc_file):
    with h5py.File(arc_file) as f:
        crit = {k: f[f"critical/{k}"][()] for k in ("step", "point_type", "load_factor")}
        lam = f["static/load_factor"][()]
        apex_y = f["static/position"][:, 1, 1]
        shape = f["critical/shape_position"][()]
        names = f["critical/point_type"].attrs["type_names"]
    assert crit["point_type"].tolist() == [0, 1]            # load maximum, then minimum
    assert np.abs(crit["load_factor"] - [LAMBDA_MAX, -LAMBDA_MAX]).max() < 1e-6
    # the refined points are stored path points, at the limit points' apex heights
    assert np.array_equal(lam[crit["step"]], crit["load_factor"])
    assert np.abs(apex_y[crit["step"]] - [Y_STAR, -Y_STAR]).max() < 1e-4
    # the critical eigenvector: the apex moving vertically (largest component 1)
    np.testing.assert_allclose(shape[:, 0, 1], [[0, 1, 0], [0, 1, 0]], atol=1e-8)
    assert "limit point (load maximum)" in names


def test_arc_length_file_is_valid(arc_file):
    assert validate_file(arc_file, require_complete=True) == []


def test_load_stepping_warns_at_the_snap_through_step(tmp_path, capsys):
    """The issue's case: the truss with 200 N in 20 load steps snaps between 0.45 and 0.5;
    spacarpy run names step 10, advises ARCLENGTH, and stores the warning in the file."""
    deck = tmp_path / "truss200.dat"
    deck.write_text(ARC_DECK.read_text().replace("ARCLENGTH 400 0.02", ""))
    out = tmp_path / "truss200.h5"
    assert main(["run", str(deck), "-o", str(out), "-q"]) == 0
    warned = [ln for ln in capsys.readouterr().err.splitlines() if "jumped" in ln]
    assert len(warned) == 1 and warned[0].startswith("step 10 (load factor 0.5)")
    assert "ARCLENGTH" in warned[0]
    with h5py.File(out) as f:
        assert f.attrs["warnings"].startswith("step 10 (load factor 0.5) jumped")
        y = f["static/position"][:, 1, 1]
    assert y[9] > Y_STAR and y[10] < -Y_STAR                 # it did jump over the snap
    assert validate_file(out, require_complete=True) == []


def test_a_smooth_load_path_gives_no_jump_warning(tmp_path, capsys):
    out = tmp_path / "truss50.h5"
    assert main(["run", str(DECKS / "two_bar_truss.dat"), "-o", str(out), "-q"]) == 0
    assert "jumped" not in capsys.readouterr().err
    with h5py.File(out) as f:
        assert "warnings" not in f.attrs and "critical" not in f
        assert "arc_length" not in f["static"]


@pytest.mark.slow
def test_a_failure_leaves_a_valid_file_with_the_points_reached(tmp_path, monkeypatch):
    """A failure in the middle of the path (simulated: the corrector gives up from the 30th
    call on): the partial file is valid and holds every point stored before it."""
    from spacarpy.solvers.path import arclength
    from spacarpy.solvers.statics.errors import StepFailed
    calls = {"n": 0}
    real = arclength.ArcLengthPath.correct

    def failing(self, *args, **kw):
        calls["n"] += 1
        if calls["n"] >= 30:
            raise StepFailed("simulated failure", [1.0])
        return real(self, *args, **kw)

    monkeypatch.setattr(arclength.ArcLengthPath, "correct", failing)
    out = tmp_path / "cut.h5"
    assert main(["run", str(ARC_DECK), "-o", str(out), "-q"]) == 1
    partial = tmp_path / "cut.partial.h5"
    assert validate_file(partial) == []
    with h5py.File(partial) as f:
        assert not f.attrs["completed"] and "arc-length point" in f.attrs["error"]
        lam = f["static/load_factor"][()]
        apex_y = f["static/position"][:, 1, 1]
        assert lam.size >= 20 and f["static/arc_length"].shape == lam.shape
    assert np.abs(lam - truss_load_factor(apex_y)).max() < 1e-8


def test_an_interrupt_leaves_a_valid_file(tmp_path, monkeypatch):
    from spacarpy.solvers.path import arclength
    calls = {"n": 0}
    real = arclength.ArcLengthPath.correct

    def interrupted(self, *args, **kw):
        calls["n"] += 1
        if calls["n"] == 12:
            raise KeyboardInterrupt
        return real(self, *args, **kw)

    monkeypatch.setattr(arclength.ArcLengthPath, "correct", interrupted)
    out = tmp_path / "int.h5"
    assert main(["run", str(ARC_DECK), "-o", str(out), "-q"]) != 0
    partial = tmp_path / "int.partial.h5"
    assert validate_file(partial) == []
    with h5py.File(partial) as f:
        assert f["static/load_factor"].shape[0] >= 10


def test_arclength_deck_errors_name_the_place(tmp_path, capsys):
    deck = tmp_path / "bad.dat"
    deck.write_text(ARC_DECK.read_text().replace("ARCLENGTH 400 0.02", "ARCLENGTH 400 0.02 0.5"))
    assert main(["check", str(deck)]) == 2
    err = "".join(capsys.readouterr())
    assert f"{deck}:" in err and "ds_min <= ds0 <= ds_max" in err
    lines = ARC_DECK.read_text().splitlines()
    row = next(i for i, ln in enumerate(lines) if ln.startswith("ARCLENGTH")) + 1
    assert f"bad.dat:{row}:" in err
    deck.write_text(ARC_DECK.read_text().replace("ARCLENGTH 400 0.02", "ARCLENGTH 400 -1"))
    assert main(["check", str(deck)]) == 2
    assert f"bad.dat:{row}:15: error: ARCLENGTH: ds0 must be positive, got -1" in "".join(
        capsys.readouterr())


def test_arclength_refuses_a_growing_prescribed_motion():
    text = ARC_DECK.read_text().replace("FIX 3 3 ", "INPUTX 3 1\nFIX 3 3 ").replace(
        "ARCLENGTH 400", "DELINPX 3 1 0.01\nARCLENGTH 400")
    model, settings = job_from_text(text, "<truss>")
    with pytest.raises(ModelError, match="displacement control"):
        solve_static(model, settings)


def test_arclength_round_trips_through_the_deck_writer():
    from spacarpy.deck.writer import model_to_deck
    job = load(ARC_DECK)
    text = model_to_deck(job.model, job.settings)
    assert "ARCLENGTH 400 0.02" in text
    again = job_from_text(text, "<again>")
    assert again.settings.static.arclength == job.settings.static.arclength


@pytest.mark.slow
def test_the_corrector_converges_quadratically_past_buckling():
    """One post-buckling point of the bench column, taken again with an arc length of 0.1:
    the residual history of the bordered Newton iteration has order 2 (a wrong tangent, e.g.
    without the load column or the geometric stiffness, gives order 1)."""
    model, settings = job_from_text(
        arclength_column_deck(20, ds0=0.02, tol=1e-8).replace(
            "ARCLENGTH 200 0.02", "ARCLENGTH 400 0.02 0.0001 0.02"), "<column>")
    prob = StaticProblem(model)
    res = solve_static(model, settings, problem=prob)
    assert res.steps[-1].load_factor == 1.0
    k = min(range(len(res.steps)), key=lambda i: abs(res.steps[i].load_factor - 0.7))
    path = ArcLengthPath(prob, StaticOptions.from_settings(settings),
                         settings.static.arclength)
    _, history = path.correct(point_at(path, res.steps[k]), 0.1)
    ev = prob.evaluate(res.steps[k].x, res.steps[k].mu, path.load(res.steps[k].load_factor))
    floor = prob.residual_norm(ev.r, ev.c, ev.f_int, ev.f_ext)[1]
    assert len([h for h in history if h > 10 * floor]) >= 3
    assert 1.7 < convergence_order(history, floor) < 2.6
    assert 1.7 < convergence_order(path.increments) < 2.6


def _elastica_tip_deflection(load_ratio: float) -> float:
    """Lateral tip deflection of the clamped-free elastica (L = EI = 1) under the axial force
    load_ratio * P_E, P_E = pi^2/4: sqrt(P) = K(k), deflection 2 k / sqrt(P) (k = sin of
    half the tip rotation; K the complete elliptic integral of the first kind)."""
    from scipy.special import ellipk
    root_p = np.sqrt(load_ratio) * np.pi / 2
    m = brentq(lambda m: ellipk(m) - root_p, 1e-12, 1 - 1e-12)
    return 2 * np.sqrt(m) / root_p


@pytest.mark.slow
@pytest.mark.parametrize("setting", ["warn", "switch"])
def test_a_perfect_column_bifurcates_and_switch_follows_the_buckled_branch(setting):
    """The straight clamped column under 1.5 times its Euler load (20 elements, EIy = 2 EIz:
    one buckling mode): the path finds the bifurcation at the load factor 1/1.5 (Euler's
    load, to the discretization error), refines it, and with BIFURCATION switch leaves it
    along the critical eigenvector onto the buckled branch, which ends at the elastica's
    deflection; without switching the column stays straight (on the unstable branch)."""
    text = arclength_column_deck(20, imperfection=0.0, ds0=0.02).replace(
        "ARCLENGTH 200 0.02", "ARCLENGTH 200 0.02 0.0001 0.02").replace(
        "MODE static", f"MODE static\nBIFURCATION {setting}").replace(
        "1000000 1 1 1", "1000000 1 2 1")
    model, settings = job_from_text(text, "<column>")
    prob = StaticProblem(model)
    res = solve_static(model, settings, problem=prob)
    crit = [(k, st.critical) for k, st in enumerate(res.steps) if st.critical is not None]
    assert len(crit) == 1
    k, cp = crit[0]
    assert cp.kind == 2 and cp.load_factor == res.steps[k].load_factor
    assert cp.load_factor == pytest.approx(1 / 1.5, rel=1e-5)
    # the critical eigenvector bends the column in the weak x-y plane
    tip_row = prob.num.pos_idx[-1]
    shape = np.zeros(prob.num.n_coord)
    shape[prob.free] = cp.shape
    assert abs(shape[tip_row[1]]) > 0.1 and abs(shape[tip_row[2]]) < 1e-8
    tip = res.steps[-1].x[tip_row]
    assert res.steps[-1].load_factor == 1.0
    if setting == "switch":
        assert abs(tip[1]) == pytest.approx(_elastica_tip_deflection(1.5), rel=5e-3)
    else:
        assert abs(tip[1]) < 1e-8
