"""Follower loads (XFL/DELXFL, spacarpy/solvers/statics/follower.py): the analytic load
stiffness against central differences of the generalized forces, and the Newton matrix of a
follower-loaded model against the differences of its residual."""
from __future__ import annotations

import numpy as np
import pytest

from spacarpy.deck import model_from_text
from spacarpy.solvers.statics.equilibrium import StaticProblem

#: A 3D frame of two beams, 1 -(2)- 3 -(4)- 5, clamped at node 1: follower loads on node 5
#: (force) in the axes of node 4, a moment on 6 in its own axes and one on 4 in the axes of 6.
FRAME = """X 1 0 0 0
X 3 1 0 0
X 5 1 1 0.3
BEAM 1 1 2 3 4 0 0 1
BEAM 2 3 4 5 6 0 0 1
DYNE 1 1 2 3 4 5 6
DYNE 2 1 2 3 4 5 6
FIX 1
FIX 2
END
HALT
ESTIFF 1 10 3 2 2.5
ESTIFF 2 12 3 2 2.5
XFL 5 4 0.3 -0.2 0.5
DELXFL 6 6 0.1 0.4 -0.3
DELXFL 4 6 -0.2 0.1 0.6
ITERSTEP 20 2 1e-10
END
END
"""


def _problem():
    return StaticProblem(model_from_text(FRAME, "frame.dat"))


def _perturbed(prob, rng, size=0.3):
    """A configuration away from the reference, Euler parameters not normalized."""
    x = prob.num.x0 + size * rng.standard_normal(prob.num.n_coord)
    return x


def test_part_stiffness_is_the_derivative_of_its_force():
    prob = _problem()
    rng = np.random.default_rng(3)
    assert [p.name for p in prob.loads.parts] == ["XFL force", "XFL moment"]
    n = prob.num.n_coord
    for part in prob.loads.parts:
        amp = rng.standard_normal(part.initial.shape)
        x = _perturbed(prob, rng)
        k = part.stiffness(x, amp)
        dense = np.zeros((n, n))
        for b in range(part.rows.shape[0]):
            np.add.at(dense, (part.rows[b][:, None], part.cols[b][None, :]), k[b])
        h = 1e-6
        fd = np.zeros((n, n))
        for j in range(n):
            e = np.zeros(n)
            e[j] = h
            fd[:, j] = (part.force(x + e, amp, n) - part.force(x - e, amp, n)) / (2 * h)
        scale = np.abs(fd).max()
        assert scale > 0.1
        np.testing.assert_allclose(dense, fd, rtol=0, atol=1e-8 * scale)
        # not symmetric: a follower load is not conservative
        assert np.abs(dense - dense.T).max() > 0.1 * scale


@pytest.mark.parametrize("s", [0.0, 0.7])
def test_newton_matrix_is_the_derivative_of_the_residual(s):
    prob = _problem()
    rng = np.random.default_rng(5)
    x = _perturbed(prob, rng, 0.05)
    x = prob.normalize(x)
    mu = rng.standard_normal(prob.n_multiplier)
    load = prob.loads.at(1.0, s)
    ev = prob.evaluate(x, mu, load)
    n_x = prob.pattern.n_x
    K = prob.matrix(ev, mu)[:n_x, :n_x].toarray()
    free = np.flatnonzero(prob.free)
    h = 1e-7
    fd = np.zeros((n_x, n_x))
    for j, c in enumerate(free):
        e = np.zeros(prob.num.n_coord)
        e[c] = h
        fd[:, j] = (prob.evaluate(x + e, mu, load).r - prob.evaluate(x - e, mu, load).r) / (2 * h)
    scale = np.abs(fd).max()
    np.testing.assert_allclose(K, fd, rtol=0, atol=2e-6 * scale)
    # the follower part matters: its blocks are far above the tolerance of the comparison
    blocks = prob.load_blocks(ev)
    assert max(np.abs(b).max() for b in blocks) > 1e3 * 2e-6 * scale


BAD = """X 1 0 0 0
X 3 1 0 0
BEAM 1 1 2 3 4 0 1 0
FIX 1
FIX 2
END
HALT
ESTIFF 1 1 1 1 1
XFL 3 3 1 0 0
DELXFL 9 4 1 0 0
DELXFL 3 7 1 0 0
XFL 4 4 1 0
END
END
"""


def test_deck_errors_name_line_and_column():
    from spacarpy.errors import DeckError

    with pytest.raises(DeckError) as info:
        model_from_text(BAD, "bad.dat")
    got = [(loc.line, loc.column, msg) for loc, msg, _ in info.value.items]
    assert [(line, col) for line, col, _ in got] == [(9, 7), (10, 8), (11, 10), (12, 1)]
    assert "node 3 is a position node" in got[0][2] and "orientation node" in got[0][2]
    assert "node 9 is not defined" in got[1][2]
    assert "node 7 is not defined" in got[2][2]
    assert "expected three components (XFL 4 4 f1 f2 f3), got 2" in got[3][2]


def test_model_and_check_list_the_follower_loads(tmp_path, capsys):
    from spacarpy.cli.main import main

    model = model_from_text(FRAME, "frame.dat")
    assert [(ld.node, ld.axes, ld.kind) for ld in model.follower_loads] == [
        (5, 4, "XFL"), (6, 6, "DELXFL"), (4, 6, "DELXFL")]
    assert model.follower_loads[0].value == (0.3, -0.2, 0.5)
    deck = tmp_path / "frame.dat"
    deck.write_text(FRAME)
    assert main(["check", str(deck)]) == 0
    out = capsys.readouterr().out
    assert "1 XFL, 2 DELXFL (1 force, 2 moments)" in out


# --- Beck's column: clamped-free, a tangential follower force at the tip ------------------
#: Beck's flutter load P L^2 / EI of the inextensible Euler-Bernoulli column (Beck 1952;
#: Bolotin 1963, Timoshenko & Gere): the first two frequencies coalesce there.
BECK = 20.0509


def _column(n: int, P: float, dead: bool = False, ea: float = 1e8) -> str:
    """A planar clamped-free column along x, L = EI = rhoA = 1, n PLBEAM elements, under a
    compressive tip force P: a follower (in the tip's axes) or a dead one."""
    lines = [f"X {2 * i + 1} {i / n} 0 0" for i in range(n + 1)]
    lines += [f"PLBEAM {i + 1} {2 * i + 1} {2 * i + 2} {2 * i + 3} {2 * i + 4}"
              for i in range(n)]
    lines += [f"DYNE 1:{n} 1 2 3", "FIX 1", "FIX 2", "END", "HALT",
              f"ESTIFF 1:{n} {ea} 1", f"EM 1:{n} 1"]
    tip = 2 * n + 1
    lines += [f"DELXF {tip} {-P} 0" if dead else f"DELXFL {tip} {tip + 1} {-P} 0",
              "ITERSTEP 20 1 1e-10", "END", "END"]
    return "\n".join(lines) + "\n"


def _linearized(text: str):
    from spacarpy.deck import job_from_text
    from spacarpy.solvers.linear.linearize import MassAssembler, linearize
    from spacarpy.solvers.statics.static import solve_static

    job = job_from_text(text, "column.dat")
    res = solve_static(job.model, job.settings)
    prob, st = res.problem, res.steps[-1]
    lin = linearize(prob, st.x, st.mu, prob.loads.at(1.0, st.load_factor),
                    mass=MassAssembler(job.model, prob.num))
    return lin, prob


def _lowest(n: int, P: float, k: int = 2):
    from spacarpy.solvers.linear.eigen import eigenmodes

    lin, prob = _linearized(_column(n, P))
    return eigenmodes(lin, prob.num, prob.free, n_modes=k)


def test_beck_column_flutter_load():
    """The load where the two lowest w^2 meet and turn into a complex conjugate pair, by
    bisection on the eigenvalue analysis: 20.0509 EI/L^2 within 1e-3 (measured 2e-5 at 24
    elements; a dead load of the same size is far beyond the Euler load pi^2/4)."""
    from spacarpy.solvers.linear.eigen import COMPLEX, ELASTIC

    lo, hi = 19.9, 20.2
    below = _lowest(24, lo)
    above = _lowest(24, hi)
    assert list(below.kind) == [ELASTIC, ELASTIC] and below.eigenvalue[0].real > 0
    assert list(above.kind) == [COMPLEX, COMPLEX]
    lam = above.eigenvalue
    assert lam[0] == np.conj(lam[1]) and lam[0].imag > 0       # one exact conjugate pair
    while hi - lo > 1e-5 * lo:
        mid = 0.5 * (lo + hi)
        if (_lowest(24, mid).kind == COMPLEX).any():
            hi = mid
        else:
            lo = mid
    assert abs(0.5 * (lo + hi) / BECK - 1) < 1e-3
    # just below flutter the two frequencies are close, far apart unloaded
    near = _lowest(24, lo).eigenvalue.real
    free = _lowest(24, 0.0).eigenvalue.real
    assert near[1] / near[0] < 1.05 and free[1] / free[0] > 30


def test_beck_column_has_no_divergence_and_euler_column_keeps_its_load(caplog):
    """Buckling (det(K0 + mu G) = 0) of Beck's column has no real positive multiplier (the
    follower column does not diverge) and says why; the same column under a dead force
    keeps its Euler load pi^2 EI / 4 L^2."""
    from spacarpy.solvers.linear.buckling import buckling_modes

    lin, _ = _linearized(_column(24, 5.0))
    with caplog.at_level("WARNING"):
        follower = buckling_modes(lin)
    assert follower.critical == np.inf
    assert "flutter shows as complex w^2 in MODE eigen" in caplog.text
    lin, _ = _linearized(_column(24, 1.0, dead=True))
    dead = buckling_modes(lin)
    assert abs(dead.critical / (np.pi ** 2 / 4) - 1) < 2e-4


# --- a cantilever rolled into a circle by a tip follower moment ---------------------------

def _rolled(n: int, k: float, steps: int = 4, arc: str | None = None):
    """Node positions (n + 1, 2) of a planar cantilever, L = EI = 1 (EA = 1e7), under the
    tip follower moment M = k pi EI / L (DELXFL on the tip's own orientation node), by
    ``steps`` load steps or by the arc length ``arc``; and the number of stored steps."""
    from spacarpy.deck import job_from_text
    from spacarpy.solvers.statics.static import solve_static

    lines = [f"X {2 * i + 1} {i / n} 0 0" for i in range(n + 1)]
    lines += [f"PLBEAM {i + 1} {2 * i + 1} {2 * i + 2} {2 * i + 3} {2 * i + 4}"
              for i in range(n)]
    lines += [f"DYNE 1:{n} 1 2 3", "FIX 1", "FIX 2", "END", "HALT", f"ESTIFF 1:{n} 1e7 1",
              f"DELXFL {2 * n + 2} {2 * n + 2} {k * np.pi!r}", f"ITERSTEP 30 {steps} 1e-10"]
    lines += ([arc] if arc else []) + ["END", "END"]
    job = job_from_text("\n".join(lines) + "\n", "roll.dat")
    res = solve_static(job.model, job.settings)
    x = res.steps[-1].x
    assert res.steps[-1].load_factor == 1.0
    return x[res.problem.num.pos_idx][:, :2], len(res.steps)


def _circle(pos: np.ndarray) -> tuple[float, float]:
    """The circle through the nodes (least squares, x^2 + y^2 + D x + E y + F = 0): its
    radius and the largest distance of a node from it."""
    a = np.column_stack([pos, np.ones(len(pos))])
    (d, e, f), *_ = np.linalg.lstsq(a, -(pos ** 2).sum(axis=1), rcond=None)
    centre = -0.5 * np.array([d, e])
    radius = float(np.sqrt(centre @ centre - f))
    return radius, float(np.abs(np.hypot(*(pos - centre).T) - radius).max())


@pytest.mark.parametrize("k", [0.5, 1.0, 2.0])
def test_follower_moment_rolls_a_circle_second_order(k):
    """Every node lies on one circle (each element deforms alike), whose radius converges
    to EI/M as h^2 (the beam element's error, measured ratio 4.00 per halving): the
    Richardson value of 128 and 256 elements is EI/M to 1e-7; and the arc length gives
    the load steps' configuration."""
    radii = []
    for n in (128, 256):
        pos, _ = _rolled(n, k)
        radius, off = _circle(pos)
        assert off < 1e-9 * radius                     # one circle
        radii.append(radius)
    R = 1.0 / (k * np.pi)
    e128, e256 = radii[0] - R, radii[1] - R
    assert abs(e128 / e256 - 4.0) < 0.01
    assert 1e-7 < abs(e256) / R < 2e-3                # a real, small discretization error
    assert abs((4 * radii[1] - radii[0]) / 3 - R) < 1e-7 * R
    pos_arc, points = _rolled(128, k, steps=1, arc="ARCLENGTH 200 0.2")
    assert points > 2                                  # a path, not one step
    np.testing.assert_allclose(pos_arc, _rolled(128, k)[0], rtol=0, atol=1e-8)


@pytest.mark.slow
def test_follower_moment_rolls_a_full_circle_at_a_fine_mesh():
    """k = 2 (a full turn) at 4096 elements: every node on the circle of radius EI/M, to
    1e-6 of it (measured 7.8e-7), the tip back at the root to 1e-6 L."""
    pos, _ = _rolled(4096, 2.0)
    R = 1.0 / (2.0 * np.pi)
    r = np.hypot(pos[:, 0], pos[:, 1] - R)
    assert np.abs(r - R).max() < 1e-6 * R
    assert np.abs(pos[-1]).max() < 1e-6
    th = 2 * np.pi * np.arange(pos.shape[0]) / (pos.shape[0] - 1)
    exact = np.stack([R * np.sin(th), R * (1 - np.cos(th))], axis=1)
    assert np.abs(pos - exact).max() < 1e-6


# --- a cantilever under a tip follower force perpendicular to its tip ---------------------

def _follower_elastica(P: float) -> np.ndarray:
    """The tip (x, y) of the inextensible cantilever (L = EI = 1) under a tip force P that
    stays perpendicular to the tip: with the angle theta(s) of the axis, EI theta' is the
    moment of the tip force, so ``theta'' = -P cos(theta - theta_L)``, theta(0) = 0,
    theta'(L) = 0 and theta_L = theta(L); shooting on (theta'(0), theta_L)."""
    from scipy.integrate import solve_ivp
    from scipy.optimize import fsolve

    def shoot(u):
        c, th_l = u

        def rhs(s, y):
            return [y[1], -P * np.cos(y[0] - th_l), np.cos(y[0]), np.sin(y[0])]
        end = solve_ivp(rhs, (0.0, 1.0), [0.0, c, 0.0, 0.0], rtol=1e-12, atol=1e-13).y[:, -1]
        return np.array([end[1], end[0] - th_l]), end

    u, _, ok, msg = fsolve(lambda u: shoot(u)[0], [P / 2, P / 2], xtol=1e-13, full_output=True)
    assert ok == 1, msg
    residual, end = shoot(u)
    assert np.abs(residual).max() < 1e-10
    return end[2:]


def _tip_force(n: int, P: float, follower: bool = True) -> np.ndarray:
    from spacarpy.deck import job_from_text
    from spacarpy.solvers.statics.static import solve_static

    tip = 2 * n + 1
    lines = [f"X {2 * i + 1} {i / n} 0 0" for i in range(n + 1)]
    lines += [f"PLBEAM {i + 1} {2 * i + 1} {2 * i + 2} {2 * i + 3} {2 * i + 4}"
              for i in range(n)]
    lines += [f"DYNE 1:{n} 1 2 3", "FIX 1", "FIX 2", "END", "HALT", f"ESTIFF 1:{n} 1e7 1",
              f"DELXFL {tip} {tip + 1} 0 {P!r}" if follower else f"DELXF {tip} 0 {P!r}",
              "ITERSTEP 30 8 1e-10", "END", "END"]
    job = job_from_text("\n".join(lines) + "\n", "tipforce.dat")
    res = solve_static(job.model, job.settings)
    return res.steps[-1].x[res.problem.num.pos_idx[-1]][:2]


@pytest.mark.parametrize("P", [2.0, 5.0, 10.0])
def test_tip_follower_force_against_the_shooting_elastica(P):
    """The tip under a follower force perpendicular to it (up to 10 EI/L^2, the tip turned
    by 171 degrees) against the shooting solution: second-order convergence (ratio 4 per
    halving, errors 1e-5 to 3e-4 at 64 elements) and the Richardson value within 2e-6; a
    dead force of the same size ends elsewhere."""
    ref = _follower_elastica(P)
    e64 = _tip_force(64, P) - ref
    e128 = _tip_force(128, P) - ref
    ratio = np.abs(e64).max() / np.abs(e128).max()
    assert 3.8 < ratio < 4.2
    assert np.abs((4 * e128 - e64) / 3).max() < 2e-6
    assert np.abs(_tip_force(64, P, follower=False) - ref).max() > 1e-2


def test_bifurcation_check_is_refused_with_follower_loads(caplog):
    """BIFURCATION warn counts negative eigenvalues of the tangent's symmetric part: with
    follower loads that is no stability criterion, and the run says so instead of
    reporting it (Beck's column beyond its flutter load)."""
    from spacarpy.deck import job_from_text
    from spacarpy.solvers.statics.static import solve_static

    job = job_from_text(_column(8, 30.0).replace("ITERSTEP", "BIFURCATION warn\nITERSTEP"),
                        "beck.dat")
    with caplog.at_level("WARNING"):
        res = solve_static(job.model, job.settings)
    assert res.steps[-1].load_factor == 1.0
    assert "BIFURCATION warn is off: the follower loads" in caplog.text


@pytest.mark.parametrize("P, grows", [(15.0, False), (25.0, True)])
def test_transient_beck_column_flutters_above_its_load(tmp_path, P, grows):
    """Transient: Beck's column (8 elements) released from a small static tip deflection
    (DELXF removed at t = 0) under its follower force (XFL): below the flutter load 20.05
    the vibration stays at its size (numerical damping only), above it it grows (measured
    200 times in 2 s at P = 25: the complex pair's growth rate)."""
    import spacarpy
    from spacarpy.deck import job_from_text
    from spacarpy.run import run_job

    n, tip = 8, 17
    text = _column(n, P).replace(f"DELXFL {tip} {tip + 1} {-P} 0",
                                 f"XFL {tip} {tip + 1} {-P} 0\nDELXF {tip} 0 0.01")
    text = text.replace("ITERSTEP 20 1 1e-10", "ITERSTEP 20 1 1e-10\nTIMESTEP 2 80\n"
                        "START static\nTIMEFUNCTION zero\nMODE transient")
    out = tmp_path / "beck.h5"
    run_job(job_from_text(text, "beck.dat"), out)
    y = spacarpy.open_results(out).transient.position(node=tip)[:, 1]
    first, last = np.abs(y[:20]).max(), np.abs(y[-20:]).max()
    if grows:
        assert last > 50 * first
    else:
        assert 0.8 * first < last < 1.05 * first


@pytest.mark.parametrize("P", [15.0, 25.0])
def test_state_space_poles_of_beck_column(tmp_path, P):
    """Mode 9 (state space) about Beck's column (16 elements, undamped): below the flutter
    load every pole is on the imaginary axis; above it the coalesced pair gives poles with a
    positive real part, equal to the one the eigenvalue analysis gives (s^2 = -w^2)."""
    import h5py

    from spacarpy.deck import job_from_text
    from spacarpy.run import run_job

    n, tip = 16, 33
    text = _column(n, P).replace("END\nEND\n", f"END\nHALT\nINPUTF 1 {tip} 2\nOUTX 1 {tip} 2\n"
                                 "END\nEND\n").replace("ITERSTEP", "MODE 9\nITERSTEP")
    out = tmp_path / "beck_ss.h5"
    run_job(job_from_text(text, "beck_ss.dat"), out)
    with h5py.File(out, "r") as f:
        poles = np.asarray(f["state_space/pole"][()])[-1]
    scale = np.abs(poles).max()
    w2 = _lowest(n, P).eigenvalue
    if P < 20:
        assert np.abs(poles.real).max() < 1e-6 * scale
    else:
        expected = abs(np.sqrt(-complex(w2[0])).real)          # s = +-sqrt(-w^2)
        assert expected > 0.5
        assert abs(poles.real.max() - expected) < 1e-6 * scale


def test_flutter_pair_stored_in_the_results_file(tmp_path):
    """MODE eigen on Beck's column above its flutter load: the results file holds the
    coalesced pair as two exact conjugates, kind 3 (complex), frequency NaN."""
    import h5py

    from spacarpy.deck import job_from_text
    from spacarpy.run import run_job

    out = tmp_path / "beck_eigen.h5"
    run_job(job_from_text(_column(16, 21.0).replace("ITERSTEP", "MODE eigen\nITERSTEP"),
                          "beck_eigen.dat"), out)
    with h5py.File(out, "r") as f:
        re = np.asarray(f["eigen/eigenvalue_real"][()])[-1]
        im = np.asarray(f["eigen/eigenvalue_imag"][()])[-1]
        kind = np.asarray(f["eigen/kind"][()])[-1]
        freq = np.asarray(f["eigen/frequency"][()])[-1]
    assert list(kind[:3]) == [3, 3, 0]
    assert re[0] == re[1] and im[0] == -im[1] and im[0] > 1.0
    assert np.isnan(freq[:2]).all() and freq[2] > 0


def test_deck_writer_writes_the_follower_lines():
    from spacarpy.deck.writer import model_to_deck

    model = model_from_text(FRAME, "frame.dat")
    again = model_from_text(model_to_deck(model), "again.dat")
    assert again.follower_loads == [
        type(ld)(node=ld.node, axes=ld.axes, kind=ld.kind, value=ld.value,
                 loc=again.follower_loads[i].loc) for i, ld in enumerate(model.follower_loads)]


# --- QEL/DELQEL: follower line loads on planar beams --------------------------------------

def _ring(n: int, p: float, keyword: str = "DELQEL", extra: str = "") -> str:
    """A closed planar ring, R = EI = 1 (EA = 1e6), n PLBEAM elements counter-clockwise,
    held statically determinately (node 1 in x and y, the opposite node in y), under the
    pressure p as a follower line load along each element's local y-axis (inwards)."""
    th = 2 * np.pi * np.arange(n) / n
    lines = [f"X {2 * i + 1} {float(np.cos(t))!r} {float(np.sin(t))!r} 0"
             for i, t in enumerate(th)]
    lines += [f"PLBEAM {i + 1} {2 * i + 1} {2 * i + 2} {2 * ((i + 1) % n) + 1} "
              f"{2 * ((i + 1) % n) + 2}" for i in range(n)]
    lines += [f"DYNE 1:{n} 1 2 3", "FIX 1 1 2", f"FIX {n + 1} 2", "END", "HALT",
              f"ESTIFF 1:{n} 1e6 1", f"{keyword} 1:{n} 0 {p!r}", extra,
              "ITERSTEP 20 1 1e-10", "END", "END"]
    return "\n".join(lines) + "\n"


def test_line_load_stiffness_is_the_derivative_of_its_force():
    prob = StaticProblem(model_from_text(_ring(6, 0.4, "QEL", "DELQEL 2:4 0.3 -0.2"),
                                         "ring.dat"))
    (part,) = [p for p in prob.loads.parts if p.name == "QEL line load"]
    assert part.rows.shape == (9, 14)
    rng = np.random.default_rng(11)
    n = prob.num.n_coord
    x = prob.num.x0 + 0.3 * rng.standard_normal(n)
    amp = rng.standard_normal(part.initial.shape)
    k = part.stiffness(x, amp)
    dense = np.zeros((n, n))
    for b in range(part.rows.shape[0]):
        np.add.at(dense, (part.rows[b][:, None], part.cols[b][None, :]), k[b])
    fd = np.zeros((n, n))
    for j in range(n):
        e = np.zeros(n)
        e[j] = 1e-6
        fd[:, j] = (part.force(x + e, amp, n) - part.force(x - e, amp, n)) / 2e-6
    scale = np.abs(fd).max()
    np.testing.assert_allclose(dense, fd, rtol=0, atol=1e-8 * scale)
    assert np.abs(dense - dense.T).max() > 0.1 * scale         # not symmetric per element


def test_line_load_lumps_a_uniform_load_as_the_cubic_beam_does():
    """One straight PLBEAM of length 2 along x, qy = 3 per length: each end carries
    qy L / 2 = 3 along y, the end moments are +-qy L^2 / 12 = +-1 about z."""
    prob = StaticProblem(model_from_text(
        "X 1 0 0 0\nX 3 2 0 0\nPLBEAM 1 1 2 3 4\nDYNE 1 1 2 3\nFIX 1\nFIX 2\nEND\nHALT\n"
        "ESTIFF 1 1 1\nQEL 1 0 3\nEND\nEND\n", "one.dat"))
    f = prob.loads.part_forces(prob.num.x0, prob.loads.at(1.0, 0.0))
    num = prob.num
    np.testing.assert_allclose(f[num.pos_idx], [[0, 3, 0], [0, 3, 0]], atol=1e-15)
    # a moment T about z acts on identity Euler parameters as 2 Lambda^T T = (0, 0, 0, 2T)
    np.testing.assert_allclose(f[num.rot_idx], [[0, 0, 0, 2.0], [0, 0, 0, -2.0]],
                               atol=1e-15)


def test_ring_under_follower_pressure_buckles_at_3_EI_over_R3():
    """A ring under a pressure that stays normal to its deformed axis (per deformed length):
    the buckling pressure of the inextensible ring is 3 EI/R^3 (the n = 2 mode; n = 3 at
    8 EI/R^3), within 1e-3 at 128 elements (measured 5.0e-4, h^2)."""
    from spacarpy.deck import job_from_text
    from spacarpy.solvers.linear.buckling import buckling_modes
    from spacarpy.solvers.linear.linearize import linearize
    from spacarpy.solvers.statics.static import solve_static

    p = 0.3
    out = {}
    for n in (64, 128):
        job = job_from_text(_ring(n, p), "ring.dat")
        res = solve_static(job.model, job.settings)
        prob, st = res.problem, res.steps[-1]
        pos = st.x[prob.num.pos_idx][:, :2]
        radius = np.hypot(*(pos - pos.mean(axis=0)).T)              # (node 1 holds x: the
        np.testing.assert_allclose(radius, 1 - p / 1e6, rtol=1e-9)   # ring shifts) uniformly
        lin = linearize(prob, st.x, st.mu, prob.loads.at(1.0, st.load_factor))
        out[n] = p * buckling_modes(lin).multiplier
    assert abs(out[128][0] / 3.0 - 1) < 1e-3 and abs(out[128][2] / 8.0 - 1) < 2e-3
    ratio = (out[64][0] - 3.0) / (out[128][0] - 3.0)
    assert 3.8 < ratio < 4.2


def test_qel_errors_and_the_deck_writer():
    """A truss takes no line load, a spatial beam's QEL has three (or six) components, an
    element that does not exist is named; the deck writer writes uniform and linear lines
    back (planar: two or four components) with their time functions."""
    from spacarpy.deck.writer import model_to_deck
    from spacarpy.errors import DeckError

    text = ("X 1 0 0 0\nX 3 1 0 0\nX 5 2 0 0\nBEAM 1 1 2 3 4 0 1 0\nBEAM 2 3 4 5 6 0 1 0\n"
            "TRUSS 3 1 5\nFIX 1\nFIX 2\nEND\nHALT\nESTIFF 1:2 1 1 1 1\nQEL 2 0 1\n"
            "DELQEL 7 0 1 0\nQEL 3 0 1 0\nDELQEL 1 0 1 0 0 2\nEND\nEND\n")
    with pytest.raises(DeckError) as info:
        model_from_text(text, "bad.dat")
    got = [(loc.line, loc.column, msg) for loc, msg, _ in info.value.items]
    assert [(line, col) for line, col, _ in got] == [(12, 1), (13, 8), (14, 5), (15, 1)]
    assert "QEL: expected 3 or 6 components (QEL 2 q1 q2 q3 [q1 q2 q3 at q]), got 2" in got[0][2]
    assert "element 7 is not defined" in got[1][2]
    assert "element 3 is a TRUSS; a follower line load acts on a beam" in got[2][2]
    assert "expected 3 or 6 components" in got[3][2]
    from spacarpy.deck import job_from_text
    job = job_from_text(_ring(4, 0.5, "QEL", "DELQEL 2 0.1 0.2 0.3 0.4\n"
                                             "TIMEFUNCTION pulse ramp 1\n"
                                             "LOADTF pulse DELQEL 2"), "ring.dat")
    again = model_from_text(model_to_deck(job.model, job.settings), "again.dat")
    assert [(ld.element, ld.kind, ld.q_p, ld.q_q, ld.tf)
            for ld in again.follower_line_loads] == [
        (1, "QEL", (0.0, 0.5, 0.0), (0.0, 0.5, 0.0), None),
        (2, "QEL", (0.0, 0.5, 0.0), (0.0, 0.5, 0.0), None),
        (3, "QEL", (0.0, 0.5, 0.0), (0.0, 0.5, 0.0), None),
        (4, "QEL", (0.0, 0.5, 0.0), (0.0, 0.5, 0.0), None),
        (2, "DELQEL", (0.1, 0.2, 0.0), (0.3, 0.4, 0.0), "pulse")]
