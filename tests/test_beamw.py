"""The warping beam BEAMW (spacarpy/elements/beamw.py, docs/beamw.md) against closed forms.

- Non-uniform (Vlasov) torsion of a cantilever, warping restrained at the root and free at
  the tip: tip twist ``T/GJ (L - tanh(kL)/k)``, ``k = sqrt(GJ/ECw)``; its convergence order;
  warping free at both ends gives Saint-Venant's ``T L / GJ``.
- Lateral-torsional buckling of a simply supported beam under uniform moment (fork
  supports, warping free): ``M_cr = pi/L sqrt(EI GJ (1 + pi^2 ECw/(GJ L^2)))`` from the
  buckling analysis and from the static path (Southwell), for two warping parameters.
- Torsional frequencies of a warping-restrained beam with warping inertia (eigen).
- A BEAMW with ECw = 0 and rhoIw = 0 gives the BEAM's results (statics, eigen, transient).
- The corpus decks with BEAMWs (../shared/spacar-decks, skipped when absent): the mode-9
  state space of mod8_flexure_mode9.dat, its poles and static gain (its poles with 1 and 2
  BLAS threads, their bounds and the warping modes: tests/test_stiff_modes.py).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from spacarpy.deck import job_from_text, load
from spacarpy.elements.beamw import beamw_state, beamw_stiffness, beamw_weighted_hessian
from spacarpy.elements.registry import KINDS
from spacarpy.results import open_results
from spacarpy.run import run_model
from spacarpy.solvers.statics.equilibrium import StaticProblem
from spacarpy.solvers.statics.static import solve_static

CORPUS = Path(__file__).resolve().parents[2] / "shared" / "spacar-decks"
if not CORPUS.is_dir():
    CORPUS = Path("/work/shared/spacar-decks")


def _statics(text: str):
    """(problem, steps) of a static solve of a deck text."""
    job = job_from_text(text, "beamw.dat")
    problem = StaticProblem(job.model, deformations=job.settings.deformations)
    steps = []
    solve_static(job.model, job.settings, problem=problem, on_step=steps.append)
    return job, problem, steps


def _twist(q) -> float:
    """The rotation angle about x of Euler parameters (lambda0, lambda1, 0, 0)."""
    return 2.0 * np.arctan2(q[1], q[0])


# ------------------------------------------------------------------ the kernel itself
def test_the_kernel_derivatives_are_exact():
    """D and the weighted second derivatives of all 8 modes against central differences,
    at a random configuration (positions, unnormalized Euler parameters, warping)."""
    rng = np.random.default_rng(3)
    kind = KINDS["BEAMW"]
    x0 = [np.array([[0.0, 0.0, 0.0]]), None, None, np.array([[0.7, 0.2, -0.1]]), None, None]
    ref, _ = kind.reference(x0, np.array([[0.0, 1.0, 0.3]]))
    x = np.zeros((1, 16))
    x[0, 8:11] = x0[3][0]
    x[0, 3], x[0, 11] = 1.0, 1.0
    x += 0.1 * rng.standard_normal(x.shape)
    st = beamw_state(x, ref)
    w = rng.standard_normal((1, 8))
    h = beamw_weighted_hessian(st, w)
    eps = 1e-6
    for j in range(16):
        dx = np.zeros_like(x)
        dx[0, j] = eps
        sp, sm = beamw_state(x + dx, ref), beamw_state(x - dx, ref)
        np.testing.assert_allclose((sp.e - sm.e)[0] / (2 * eps), st.D[0, :, j], atol=1e-8)
        np.testing.assert_allclose(((w @ sp.D[0]) - (w @ sm.D[0]))[0] / (2 * eps), h[0, :, j],
                                   atol=1e-7)
    assert np.allclose(h[0], h[0].T, atol=1e-12)


def test_the_stiffness_is_vlasov_s_energy_of_the_cubic():
    """1/2 e^T S e of pure twist equals int (GJ phi'^2 + ECw phi''^2)/2 of the cubic Hermite
    twist with end values 0, theta and end rates wp, wq (Simpson's rule is exact for the
    integrands, polynomials of degree 4 at most, on 2 panels... taken on 200 here)."""
    l0, gj, ecw = 0.8, 3.0, 0.7
    theta, wp, wq = 0.01, 0.02, -0.005
    s = beamw_stiffness(np.array([[0, gj, 0, 0, 0, 0, ecw]], float), np.array([l0]))[0]
    e = np.zeros(8)
    e[1] = l0 * theta
    e[6], e[7] = l0**2 * wp - e[1], l0**2 * wq - e[1]
    xi = np.linspace(0.0, 1.0, 2001)
    # Hermite cubic: phi = h3 theta + l0 (h2 wp + h4 wq)
    d1 = np.stack([6 * xi**2 - 6 * xi, 1 - 4 * xi + 3 * xi**2, -6 * xi**2 + 6 * xi,
                   -2 * xi + 3 * xi**2]) / l0
    d2 = np.stack([12 * xi - 6, -4 + 6 * xi, -12 * xi + 6, -2 + 6 * xi]) / l0**2
    c = np.array([0.0, l0 * wp, theta, l0 * wq])
    phi1, phi2 = c @ d1, c @ d2
    energy = 0.5 * np.trapezoid(gj * phi1**2 + ecw * phi2**2, xi) * l0
    assert 0.5 * e @ s @ e == pytest.approx(energy, rel=1e-6)


# ------------------------------------------------------------------ non-uniform torsion
def _chain(n: int, length: float, dyne: str) -> list[str]:
    """The X, BEAMW and DYNE lines of n BEAMWs along x from the origin: position node 3i+1,
    orientation 3i+2, warping 3i+3 of node i; each element's DYNE modes ``dyne``."""
    lines = [f"X {3 * i + 1} {length * i / n!r} 0 0" for i in range(n + 1)]
    for e in range(1, n + 1):
        a, b = 3 * (e - 1), 3 * e
        lines.append(f"BEAMW {e} {a + 1} {a + 2} {a + 3} {b + 1} {b + 2} {b + 3} 0 1 0")
        lines.append(f"DYNE {e} {dyne}")
    return lines


def _torsion_deck(n: int, length: float, gj: float, ecw: float, torque: float,
                  root_warping: bool = True, tip_warping: bool = False) -> str:
    """A cantilever of n BEAMWs along x: position node 3i+1, orientation 3i+2, warping 3i+3
    of node i; the root clamped, its warping fixed (or not), a torque about x at the tip."""
    lines = ["DEFORMATIONS modified"]
    lines += _chain(n, length, "1 2 3 4 5 6")
    lines += ["FIX 1", "FIX 2"]
    if root_warping:
        lines.append("FIX 3")
    if tip_warping:
        lines.append(f"FIX {3 * n + 3}")
    lines += ["END", "HALT"]
    for e in range(1, n + 1):
        lines.append(f"ESTIFF {e} 1e9 {gj!r} 1e6 1e6 0 0 {ecw!r}")
    lines += [f"DELXF {3 * n + 2} {torque!r} 0 0", "ITERSTEP 20 1 1e-13", "END", "END"]
    return "\n".join(lines) + "\n"


L_T, GJ_T, ECW_T, T_T = 2.0, 1.0e3, 1.0e3, 1e-2      # k = 1 / m, kL = 2


def _tip_twist(n: int, **kw) -> float:
    job, problem, steps = _statics(_torsion_deck(n, L_T, GJ_T, ECW_T, T_T, **kw))
    num = problem.num
    tip = list(job.model.orientation_ids).index(3 * n + 2)
    return _twist(steps[-1].x[num.rot_idx[tip]])


def test_warping_restrained_cantilever_converges_to_vlasov():
    """Tip twist of the root-restrained cantilever against T/GJ (L - tanh(kL)/k), kL = 2,
    for 1, 2, 4, 8, 16 elements: the error falls by 2^4 per halving (cubic Hermite twist;
    the measured order from 4 elements on lies between 3.9 and 4.1), 16 elements within 2e-7."""
    k = np.sqrt(GJ_T / ECW_T)
    exact = T_T / GJ_T * (L_T - np.tanh(k * L_T) / k)
    err = np.array([_tip_twist(n) / exact - 1.0 for n in (1, 2, 4, 8, 16)])
    order = np.log2(np.abs(err[:-1] / err[1:]))
    assert np.all(err < 0)                              # the cubic twist is too stiff
    assert np.all((order[2:] > 3.9) & (order[2:] < 4.1)), order
    assert abs(err[-1]) < 2e-7
    # the warping restraint matters: the Saint-Venant twist is 1.93 times larger here
    assert T_T * L_T / GJ_T / exact == pytest.approx(1.0 / (1.0 - np.tanh(2.0) / 2.0))


def test_warping_free_gives_saint_venant():
    """Warping free at both ends: uniform torsion, the tip twist is T L / GJ (exactly: the
    warping coordinates settle at the rate of twist, e7 = e8 = 0)."""
    assert _tip_twist(4, root_warping=False) == pytest.approx(T_T * L_T / GJ_T, rel=1e-9)


def test_warping_restrained_at_both_ends_is_stiffer():
    """Both ends restrained: T/GJ (L - 2 (cosh kL - 1)/(k sinh kL)) (4 elements, 1e-4)."""
    k = np.sqrt(GJ_T / ECW_T)
    exact = T_T / GJ_T * (L_T - 2.0 * (np.cosh(k * L_T) - 1.0) / (k * np.sinh(k * L_T)))
    assert _tip_twist(8, tip_warping=True) == pytest.approx(exact, rel=1e-5)


# ------------------------------------------------------------------ lateral-torsional buckling
L_B, EI_B, GJ_B = 2.0, 2.0, 3.0        # weak-axis EI (modes 3, 4), torsion


def _ltb_deck(n: int, ecw: float, mode: str = "buckling", moment: float = 1.0,
              imperfection: float = 0.0, steps: int = 1) -> str:
    """A simply supported beam of n BEAMWs along x under equal and opposite end moments about
    z (the stiff plane x-y: elongation and modes 5, 6 rigid, as in the paper's Table 3, so
    that no pre-buckling deformation enters); fork supports: both ends held in y and z and
    in their twist (lambda1), free to turn about y and z; warping free everywhere; a lateral
    force ``imperfection`` along z at midspan (n even) for the static path."""
    lines = ["DEFORMATIONS modified", f"MODE {mode}"]
    lines += _chain(n, L_B, "2 3 4")
    lines += ["FIX 1", "FIX 2 2", f"FIX {3 * n + 1} 2 3", f"FIX {3 * n + 2} 2", "END", "HALT"]
    for e in range(1, n + 1):
        lines.append(f"ESTIFF {e} 0 {GJ_B!r} {EI_B!r} 0 0 0 {ecw!r}")
    lines += [f"DELXF 2 0 0 {-float(moment)!r}", f"DELXF {3 * n + 2} 0 0 {float(moment)!r}"]
    if imperfection:
        lines.append(f"XF {3 * (n // 2) + 1} 0 0 {imperfection!r}")
    lines += [f"ITERSTEP 30 {steps} 1e-12", "END", "END"]
    return "\n".join(lines) + "\n"


def _m_cr(ecw: float) -> float:
    return np.pi / L_B * np.sqrt(EI_B * GJ_B * (1.0 + np.pi**2 * ecw / (GJ_B * L_B**2)))


#: Two warping parameters pi^2 ECw / (GJ L^2): 1 and 4.
ECW_VALUES = (GJ_B * L_B**2 / np.pi**2, 4.0 * GJ_B * L_B**2 / np.pi**2)


@pytest.mark.parametrize("ecw", ECW_VALUES)
def test_lateral_torsional_buckling_analysis(ecw, tmp_path):
    """The critical multiplier of a unit end moment converges to M_cr at second order (as
    the BEAM's own lateral buckling with ECw = 0: 3.2e-3 at 16 elements, 8.0e-4 at 32, for
    either warping parameter; docs/beamw.md); the Richardson extrapolation of 16 and 32
    elements is within 1e-5, and the warping raises M_cr by sqrt(2) and sqrt(5)."""
    got = []
    for n in (16, 32):
        out = tmp_path / f"ltb{n}.h5"
        job = job_from_text(_ltb_deck(n, ecw), "ltb.dat")
        run_model(job.model, job.settings, out)
        with open_results(out) as res:
            got.append(abs(res.buckling.critical_load_multiplier[-1]))
    rel = np.array(got) / _m_cr(ecw) - 1.0
    assert 0 < rel[0] < 4e-3 and 0 < rel[1] < 1e-3, rel
    assert 1.9 < np.log2(rel[0] / rel[1]) < 2.1
    assert (4.0 * got[1] - got[0]) / 3.0 == pytest.approx(_m_cr(ecw), rel=1e-5)
    ratio = _m_cr(ecw) / _m_cr(0.0)
    assert ratio == pytest.approx(np.sqrt(1.0 + np.pi**2 * ecw / (GJ_B * L_B**2)))


@pytest.mark.parametrize("ecw", ECW_VALUES)
def test_lateral_torsional_buckling_from_the_static_path(ecw, tmp_path):
    """The static path to 0.95 M_cr with a small lateral force at midspan: the lateral
    deflection grows as d0 / (1 - (M / M_cr)^2) (the moment couples bending and twist), so
    two points of the path give M_cr (Southwell). With 16 elements it lies within 2e-4 of
    the buckling analysis of the same mesh (the rest: higher modes in the imperfection) and
    within the mesh error (4e-3) of the closed form."""
    n, m_max = 16, 0.95 * _m_cr(ecw)
    job, problem, steps = _statics(_ltb_deck(n, ecw, mode="static", moment=m_max,
                                             imperfection=1e-6, steps=19))
    mid = list(job.model.position_ids).index(3 * (n // 2) + 1)
    d = np.array([s.x[problem.num.pos_idx[mid, 2]] for s in steps[-2:]])
    m = np.array([s.load_factor for s in steps[-2:]]) * m_max
    southwell = np.sqrt((d[1] * m[1]**2 - d[0] * m[0]**2) / (d[1] - d[0]))
    assert d[1] / d[0] > 1.8 and d[1] > 9.0 * 1e-6 * L_B**3 / (48.0 * EI_B)
    out = tmp_path / "ltb.h5"
    job = job_from_text(_ltb_deck(n, ecw), "ltb.dat")
    run_model(job.model, job.settings, out)
    with open_results(out) as res:
        analysis = abs(res.buckling.critical_load_multiplier[-1])
    assert southwell == pytest.approx(analysis, rel=2e-4)
    assert 0 < southwell / _m_cr(ecw) - 1.0 < 4e-3


# ------------------------------------------------------------------ the corpus decks
needs_corpus = pytest.mark.skipif(not (CORPUS / "mod8_flexure_mode9.dat").is_file(),
                                  reason="../shared/spacar-decks is not available")


@pytest.fixture(scope="module")
def mod8(tmp_path_factory):
    """mod8_flexure_mode9.dat in mode 9 and in eigen (all 8 modes)."""
    if not (CORPUS / "mod8_flexure_mode9.dat").is_file():
        pytest.skip("../shared/spacar-decks is not available")
    job = load(CORPUS / "mod8_flexure_mode9.dat")
    tmp = tmp_path_factory.mktemp("mod8")
    run_model(job.model, job.settings.override(analysis="state_space"), tmp / "ss.h5")
    run_model(job.model, job.settings.override(analysis="eigen", n_modes=8), tmp / "eig.h5")
    return job, tmp / "ss.h5", tmp / "eig.h5"


@needs_corpus
def test_mod8_state_space_is_written(mod8):
    """Its 8 degrees of freedom: the 6 DYNE modes and, for the two free warping nodes (6 and
    12), the warping mode at q of BEAMW 1 and 2; the warping coordinates are stored."""
    from spacarpy.results import validate_file
    job, ss, _ = mod8
    assert validate_file(ss, require_complete=True) == []
    with open_results(ss) as res:
        v = res.state_space
        assert v.dof.tolist() == [[1, 1], [1, 3], [1, 4], [1, 8], [2, 1], [2, 3], [2, 8],
                                  [3, 6]]
        assert v.input_name == ["INPUTF 1 22 3"]
        assert v.output_name == ["OUTXP 1 22 3", "OUTX 2 31 1"]
    import h5py
    with h5py.File(ss) as f:
        assert f["model/warping_nodes"][:].tolist() == [3, 6, 9, 12, 15, 18, 21]
        w = f["static/warping"][-1]
        assert w.shape == (7,) and np.all(w[[0, 2, 4, 5, 6]] == 0.0) and np.all(w[[1, 3]] != 0)


@needs_corpus
def test_mod8_poles_are_its_eigenfrequencies(mod8):
    """The stored poles are +-i omega of the eigen analysis' 8 modes (6 DYNE modes and the
    two free warping nodes' at 46 kHz) to 1e-8, and the eigenvalues of the stored A to its
    eigensolver's accuracy, eps ||A|| / |p| (1e-6 here); tests/test_stiff_modes.py checks
    the poles with 1 and 2 BLAS threads, the error bounds and the warping modes' closed
    form."""
    import h5py
    _, ss, eig = mod8
    with open_results(ss) as res:
        A = res.state_space.matrix("A", 1)
    with h5py.File(ss) as f:
        pole = f["state_space/pole"][-1]
    with open_results(eig) as res:
        f = res.eigen.frequency[res.eigen.row(1)]
    f = np.sort(f[np.isfinite(f)])
    assert f.size == 8 and f[0] == pytest.approx(2.5025, rel=1e-4)
    omega = np.sort(pole.imag[pole.imag > 0])
    np.testing.assert_allclose(omega, 2 * np.pi * f, rtol=1e-8, atol=0)
    poles = np.linalg.eigvals(A)
    np.testing.assert_allclose(np.sort(poles.imag[poles.imag > 0]), omega, rtol=1e-6)
    np.testing.assert_allclose(np.sort(-poles.imag[poles.imag < 0]), omega, rtol=1e-6)


@needs_corpus
def test_mod8_static_gain_is_the_static_compliance(mod8):
    """-C A^-1 B: the x displacement of node 31 per unit force along z on node 22 equals the
    central difference of two static solves with +-1e-3 N added (1e-7), and the velocity
    output has no static gain."""
    _, ss, _ = mod8
    with open_results(ss) as res:
        m = res.state_space.matrices(1)
    gain = m["D"] - m["C"] @ np.linalg.solve(m["A"], m["B"])
    text = (CORPUS / "mod8_flexure_mode9.dat").read_text()
    old = "ITERSTEP\t10\t1\t0.0000005\t1\t1\t0"
    assert old in text

    def x31(force):
        job, problem, steps = _statics(text.replace(
            old, f"ITERSTEP 20 1 1e-13 1 1 0\nDELXF 22 0 0 {force!r}"))
        k = list(job.model.position_ids).index(31)
        return steps[-1].x[problem.num.pos_idx[k, 0]]

    fd = (x31(1e-3) - x31(-1e-3)) / 2e-3
    assert gain[1, 0] == pytest.approx(fd, rel=1e-7)
    assert abs(gain[0, 0]) <= 1e-12 * abs(fd)


@needs_corpus
def test_mod8mk3_runs_in_mode_9(tmp_path):
    """The three-times refined sibling (consecutive BEAMWs share their warping nodes): 24
    DYNE modes and 5 free warping nodes make its 29 degrees of freedom."""
    job = load(CORPUS / "mod8mk3_flexure_mode9.dat")
    run_model(job.model, job.settings.override(analysis="state_space"), tmp_path / "ss.h5")
    with open_results(tmp_path / "ss.h5") as res:
        assert res.state_space.matrix("A", 1).shape == (58, 58)
        assert sum(m in (7, 8) for m in res.state_space.dof[:, 1].tolist()) == 5


# ------------------------------------------------------------------ torsional vibration
L_V, GJ_V, ECW_V, RIP_V, RIW_V = 2.0, 1.0e3, 1.0e3, 1.0, 0.5


def _vibration_deck(n: int, riw: float = RIW_V) -> str:
    """n BEAMWs along x, both ends clamped with their warping restrained; only the twist
    deforms (the other modes rigid, released in the last element, which closes the loop)."""
    lines = ["MODE eigen", "MODES 3"]
    lines += _chain(n, L_V, "2")
    lines.append(f"RLSE {n} 1 3 4 5 6")
    lines += ["FIX 1", "FIX 2", "FIX 3", f"FIX {3 * n + 1}", f"FIX {3 * n + 2}",
              f"FIX {3 * n + 3}", "END", "HALT"]
    for e in range(1, n + 1):
        lines.append(f"ESTIFF {e} 0 {GJ_V!r} 0 0 0 0 {ECW_V!r}")
        lines.append(f"EM {e} 1 {RIP_V!r} {RIP_V / 2!r} {RIP_V / 2!r} 0 {riw!r}")
    lines += ["END", "END"]
    return "\n".join(lines) + "\n"


def _clamped_torsion_frequencies(riw: float, count: int = 3) -> np.ndarray:
    """omega (rad/s) of ECw phi'''' - GJ phi'' = omega^2 (rhoIp phi - rhoIw phi''), phi =
    phi' = 0 at both ends: phi = A cosh(ax) + B sinh(ax) + C cos(bx) + D sin(bx) with
    ECw s^4 - (GJ - omega^2 rhoIw) s^2 - omega^2 rhoIp = 0, s^2 = a^2 or -b^2."""
    from scipy.optimize import brentq

    def det(w):
        c = GJ_V - w * w * riw
        disc = np.sqrt(c * c + 4.0 * ECW_V * w * w * RIP_V)
        a, b = np.sqrt((c + disc) / (2 * ECW_V)), np.sqrt((disc - c) / (2 * ECW_V))
        ch, sh, co, si = (np.cosh(a * L_V), np.sinh(a * L_V), np.cos(b * L_V),
                          np.sin(b * L_V))
        return a * (ch - co) ** 2 - (sh - a / b * si) * (a * sh + b * si)

    grid = np.linspace(0.1, 400.0, 8001)
    vals = np.array([det(w) for w in grid])
    cut = np.flatnonzero(np.sign(vals[:-1]) != np.sign(vals[1:]))
    return np.array([brentq(det, grid[i], grid[i + 1], xtol=1e-14) for i in cut[:count]])


def test_torsional_frequencies_with_warping_inertia(tmp_path):
    """The three lowest torsional frequencies of a beam clamped with its warping restrained
    at both ends, with warping inertia (rhoIw (n pi/L)^2 is of the order of rhoIp): second
    order convergence (the lumped section and warping inertia), within 2.2e-2 (16 elements)
    and 6e-3 (32), the Richardson extrapolation within 1e-4; without the warping inertia in
    the closed form the lowest frequency would be 60 % higher."""
    exact = _clamped_torsion_frequencies(RIW_V)
    assert _clamped_torsion_frequencies(0.0, 1)[0] / exact[0] > 1.5
    got = []
    for n in (16, 32):
        job = job_from_text(_vibration_deck(n), "vib.dat")
        run_model(job.model, job.settings, tmp_path / f"v{n}.h5")
        with open_results(tmp_path / f"v{n}.h5") as res:
            got.append(2 * np.pi * res.eigen.frequency[-1][:3])
    err = [g / exact - 1.0 for g in got]
    assert np.all(err[0] < 0) and np.all(np.abs(err[0]) < 2.2e-2)
    assert np.all(np.abs(err[1]) < 6e-3) and abs(err[1][0]) < 1e-3
    order = np.log2(err[0] / err[1])
    assert np.all((order > 1.9) & (order < 2.1)), order
    np.testing.assert_allclose((4 * got[1] - got[0]) / 3, exact, rtol=1e-4)


# ------------------------------------------------------------------ ECw = 0: the BEAM
def _pair_deck(kind: str, mode: str) -> str:
    """A spatial cantilever of 4 BEAMs or BEAMWs (ECw = 0, rhoIw = 0, warping free, each
    element end with its own warping node) bent and twisted by a tip force and moment;
    ``mode`` static, eigen or transient (from rest, undeformed, the load ramped up over
    0.2 s: the initial accelerations are zero, which the transient start also takes where
    the mass matrix is singular, as the BEAMW's with rhoIw = 0 is on its warping
    coordinates)."""
    lines = [f"MODE {mode}"]
    if mode == "transient":
        lines += ["TIMEFUNCTION ramp 0.2"]
    for i in range(5):
        lines.append(f"X {3 * i + 1} {0.25 * i!r} {0.02 * i * i!r} 0")
    for e in range(1, 5):
        a, b = 3 * (e - 1), 3 * e
        warp = (f" {100 + 2 * e}", f" {101 + 2 * e}") if kind == "BEAMW" else ("", "")
        lines.append(f"{kind} {e} {a + 1} {a + 2}{warp[0]} {b + 1} {b + 2}{warp[1]} 0 1 0.2")
        lines.append(f"DYNE {e} 1 2 3 4 5 6")
    lines += ["FIX 1", "FIX 2", "END", "HALT"]
    extra = " 0" if kind == "BEAMW" else ""
    for e in range(1, 5):
        lines.append(f"ESTIFF {e} 1e4 0.8 1 1.5 0 0{extra}")
        lines.append(f"EM {e} 1 2e-4 1e-4 1e-4 0{extra}")
    lines += ["DELXF 13 0.5 0.3 -0.4", "DELXF 14 0.1 0.05 0", "ITERSTEP 30 4 1e-12"]
    if mode == "transient":
        lines.append("TIMESTEP 0.5 50")
    lines += ["END", "END"]
    return "\n".join(lines) + "\n"


@pytest.mark.parametrize("mode", ["static", "eigen", "transient"])
def test_beamw_without_warping_is_the_beam(mode, tmp_path):
    """With ECw = 0 and rhoIw = 0 and its warping free, a BEAMW is a BEAM: the warping
    coordinates take the element's mean rate of twist (e7 = e8 = 0, no stress; a warping
    node shared by two elements would make the rate of twist continuous instead, a
    different discretization of the same torsion, docs/beamw.md), so positions, Euler
    parameters, the BEAM modes' deformations and stress resultants, frequencies and the
    motion agree to round-off (1e-9 of their size) in large deflections."""
    import h5py
    out = {}
    for kind in ("BEAM", "BEAMW"):
        job = job_from_text(_pair_deck(kind, mode), f"{kind}.dat")
        run_model(job.model, job.settings, tmp_path / f"{kind}.h5")
        out[kind] = h5py.File(tmp_path / f"{kind}.h5")
    a, b = out["BEAM"], out["BEAMW"]
    group = "transient" if mode == "transient" else "static"
    for name in ("position", "euler"):
        x, y = a[f"{group}/{name}"][:], b[f"{group}/{name}"][:]
        assert x.shape == y.shape and np.abs(x).max() > 0.1
        np.testing.assert_allclose(y, x, rtol=0, atol=1e-9 * np.abs(x).max())
    if mode == "static":
        rot = a["static/euler"][-1, -1]
        assert abs(2 * np.arccos(min(1.0, rot[0]))) > 0.2       # 13 degrees at the tip
    for name in ("deformation", "stress_resultant"):
        x = a[f"{group}/elements/BEAM/{name}"][:]
        y = b[f"{group}/elements/BEAMW/{name}"][:]
        np.testing.assert_allclose(y[..., :6], x, rtol=0, atol=1e-9 * np.abs(x).max())
        np.testing.assert_allclose(y[..., 6:], 0.0, atol=1e-9 * np.abs(x).max())
    if mode == "eigen":
        fa, fb = a["eigen/frequency"][:], b["eigen/frequency"][:]
        assert np.all(np.isfinite(fa)) and fa.shape == fb.shape
        np.testing.assert_allclose(fb, fa, rtol=1e-9)
    if mode == "transient":
        assert a["transient/time"].size == b["transient/time"].size == 51
        assert b["transient/warping"].shape == (51, 8)
    for f in out.values():
        f.close()


# ------------------------------------------------------------------ the deck layer
_ONE = "X 1 0 0 0\nX 4 1 0 0\nBEAMW 1 1 2 3 4 5 6 0 1 0\nDYNE 1 1 2 3 4 5 6\n"
_DATA = "END\nHALT\nESTIFF 1 1e8 1e3 1e4 1e4 0 0 1e3\n"


@pytest.mark.parametrize("lines, data, message", [
    ("FIX 1\nFIX 2\nFIX 3 2\n", "", "7:7: error: FIX: node 3 is a warping node with coordinate "
                                     "1 (its rate of twist), got 2"),
    ("BEAM 2 4 3 1 6\nFIX 1\nFIX 2\n", "ESTIFF 2 1 1 1 1\n",
     "3:13: error: element 1: node 3 is an orientation node (line 5) and cannot be the "
     "warping node at p"),
    ("FIX 1\nFIX 2\n", "XF 6 1 0 0\n", "10:4: error: XF: node 6 is a warping node (BEAMW); a "
                                       "load on it (a bimoment) is not supported"),
    ("FIX 1\nFIX 2\n", "XM 3 1\n", "10:4: error: XM: node 3 is a warping node (BEAMW): give "
                                   "its warping inertia as the sixth EM value instead"),
    ("FIX 1\nFIX 2\n", "END\nHALT\nINPUTF 1 6 2\n",
     "12:12: error: INPUTF: node 6 is a warping node: coordinate 1..1 (the rate of twist), "
     "got 2"),
])
def test_warping_node_errors(lines, data, message):
    from spacarpy.errors import DeckError
    with pytest.raises(DeckError) as info:
        job_from_text(_ONE + lines + _DATA + data + "END\nEND\n", "w.dat")
    assert f"w.dat:{message}" in str(info.value)


def test_check_reports_the_warping_nodes(tmp_path, capsys):
    from spacarpy.cli import main
    deck = tmp_path / "w.dat"
    deck.write_text(_ONE + "FIX 1\nFIX 2\nFIX 3\n" + _DATA + "END\nEND\n")
    assert main(["check", str(deck)]) == 0
    out = capsys.readouterr().out
    assert "nodes               2 position, 2 orientation, 2 warping" in out
    assert "coordinates         16 (6 position + 8 Euler parameters + 2 warping), 8 fixed" in out
    assert "degrees of freedom  7 (8 free coordinates - 1 constraints)" in out


def test_a_warping_coordinate_as_state_space_input_and_output(tmp_path):
    """INPUTF/OUTX on the free warping node of a cantilever BEAMW (root clamped, warping
    restrained): a unit generalized force on the rate of twist (a bimoment) in, the rate of
    twist out. Its static gain is the (w, w) entry of the inverse of the torsion-warping
    stiffness in (theta, w): ``GJ/l`` on theta plus ``T^T S_w T`` with e7 = -l theta,
    e8 = l^2 w - l theta (round-off: the linearization about the undeformed state)."""
    length, gj, ecw = 1.0, 1e3, 1e3
    text = (_ONE + "FIX 1\nFIX 2\nFIX 3\n" + _DATA + "EM 1 1 0.1 0.05 0.05 0 1e-3\n"
            "END\nHALT\nINPUTF 1 6 1\nOUTX 1 6 1\nEND\nEND\n")
    job = job_from_text(text, "w.dat")
    run_model(job.model, job.settings.override(analysis="state_space"), tmp_path / "w.h5")
    with open_results(tmp_path / "w.h5") as res:
        m = res.state_space.matrices(0)
        assert res.state_space.dof.tolist()[-1] == [1, 8]
    gain = (m["D"] - m["C"] @ np.linalg.solve(m["A"], m["B"]))[0, 0]
    s = beamw_stiffness(np.array([[0, gj, 0, 0, 0, 0, ecw]], float), np.array([length]))[0, 6:, 6:]
    t = np.array([[-length, 0.0], [-length, length**2]])
    k = t.T @ s @ t
    k[0, 0] += gj / length
    assert gain == pytest.approx(np.linalg.inv(k)[1, 1], rel=1e-9)
