"""Line loads on beams (QE/DELQE, issue 37): the consistent lumping against quadrature of the
beam's shape functions, closed-form beam solutions (simply supported beam under uniform load,
cantilever under a linear load, Greenhill's heavy column), a large deflection against the
elastica, the arc-length path, and the deck errors."""
from __future__ import annotations

import h5py
import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import brentq
from scipy.special import jv

from spacarpy.cli import main
from spacarpy.deck import model_from_text
from spacarpy.elements.line_load import lump_line_load
from spacarpy.errors import DeckError


def run(tmp_path, text: str, name: str = "d", *extra) -> h5py.File:
    deck = tmp_path / f"{name}.dat"
    deck.write_text(text)
    out = tmp_path / f"{name}.h5"
    assert main(["run", str(deck), "-o", str(out), "-q", *extra]) == 0
    return h5py.File(out, "r")


# ---------------------------------------------------------------- the lumping itself
def test_uniform_load_on_one_element_exact_values():
    """q = 3 N/m along -y on an element of length 2 along x: forces q L / 2 = 3 N down at
    each end, moments -+q L^2 / 12 = -+1 N m about z (t x q = -3 z)."""
    f_p, f_q, m_p, m_q = lump_line_load([[0, 0, 0]], [[2, 0, 0]], [[0, -3, 0]], [[0, -3, 0]])
    assert f_p.tolist() == [[0.0, -3.0, 0.0]] and f_q.tolist() == [[0.0, -3.0, 0.0]]
    np.testing.assert_allclose(m_p, [[0, 0, -1.0]], rtol=0, atol=1e-15)
    np.testing.assert_allclose(m_q, [[0, 0, 1.0]], rtol=0, atol=1e-15)


def test_linear_load_on_one_element_exact_values():
    """A triangular load 0 -> q1 = 60 N/m (along z) on an element of length 1 along x:
    F_p = 3 q1 L / 20 = 9, F_q = 7 q1 L / 20 = 21, M_p = -2 q1 L^2 / 60 = -2 about y
    (t x z = -y), M_q = +3 q1 L^2 / 60 = 3 about y; the axial triangular load 0 -> 60 lumps
    linearly: 10 and 20."""
    f_p, f_q, m_p, m_q = lump_line_load([[0, 0, 0]], [[1, 0, 0]], [[0, 0, 0]], [[60, 0, 60]])
    np.testing.assert_allclose(f_p, [[10, 0, 9]], rtol=1e-15)
    np.testing.assert_allclose(f_q, [[20, 0, 21]], rtol=1e-15)
    np.testing.assert_allclose(m_p, [[0, -2, 0]], rtol=1e-15)
    np.testing.assert_allclose(m_q, [[0, 3, 0]], rtol=1e-15)


def _quadrature(x_p, x_q, q_p, q_q):
    """The consistent nodal loads by Gauss quadrature of the virtual work with the linear
    axial and cubic Hermite bending functions in the element's own frame."""
    chord = x_q - x_p
    L = np.linalg.norm(chord)
    t = chord / L
    n1 = np.cross(t, [0.3, -0.7, 0.2])
    n1 /= np.linalg.norm(n1)
    n2 = np.cross(t, n1)
    xi, w = np.polynomial.legendre.leggauss(6)
    xi, w = (xi + 1) / 2, w / 2
    q = (1 - xi)[:, None] * q_p + xi[:, None] * q_q
    f_p, f_q, m_p, m_q = (np.zeros(3) for _ in range(4))
    lin = (1 - xi, xi)
    herm = (1 - 3 * xi**2 + 2 * xi**3, L * (xi - 2 * xi**2 + xi**3), 3 * xi**2 - 2 * xi**3,
            L * (-xi**2 + xi**3))
    qt = q @ t
    f_p += L * np.sum(w * qt * lin[0]) * t
    f_q += L * np.sum(w * qt * lin[1]) * t
    for n in (n1, n2):
        qn = q @ n
        b = np.cross(t, n)             # a rotation about b moves the axis along n: w' = theta
        f_p += L * np.sum(w * qn * herm[0]) * n
        m_p += L * np.sum(w * qn * herm[1]) * b
        f_q += L * np.sum(w * qn * herm[2]) * n
        m_q += L * np.sum(w * qn * herm[3]) * b
    return f_p, f_q, m_p, m_q


def test_lumping_matches_quadrature_of_the_shape_functions_for_many_elements():
    """Inclined 3D elements with arbitrary linear loads, all at once, against quadrature of
    the shape functions element by element (1e-13)."""
    rng = np.random.default_rng(7)
    x_p, x_q = rng.normal(size=(5, 3)), rng.normal(size=(5, 3))
    q_p, q_q = rng.normal(size=(5, 3)), rng.normal(size=(5, 3))
    got = lump_line_load(x_p, x_q, q_p, q_q)
    for i in range(5):
        want = _quadrature(x_p[i], x_q[i], q_p[i], q_q[i])
        for g, r in zip(got, want):
            np.testing.assert_allclose(g[i], r, rtol=0, atol=1e-13 * (1 + np.abs(r).max()))


# ---------------------------------------------------------------- closed forms
def _simply_supported(n: int, load: str, kind: str = "BEAM") -> str:
    if kind == "PLBEAM":
        nodes = "X 1 0 0\nX 3 2 0\nFIX 1 1 2\nFIX 3 2\n"
        elems = "".join(f"PLBEAM {i + 1} {2 * i + 1 if i else 1} {2 * i + 2} "
                        f"{2 * i + 3} {2 * i + 4}\n" for i in range(n))
        xs = "".join(f"X {2 * i + 3} {2 * (i + 1) / n} 0\n" for i in range(n - 1))
        return (f"{nodes}{xs}{elems}DYNE 1:{n} 1 2 3\nEND\nHALT\nESTIFF 1:{n} 1e6 1\n"
                f"{load}\nEND\nEND\n").replace("X 3 2 0\n", f"X {2 * n + 1} 2 0\n").replace(
                    "FIX 3 2\n", f"FIX {2 * n + 1} 2\n")
    return (f"X 1 0 0 0\nX 3 2 0 0\nBEAMS 1 1 2 3 4 {n} 0 1 0\nDYNE 1:{n} 1 2 3 4 5 6\n"
            f"FIX 1 1 2 3\nFIX 2 2\nFIX 3 2 3\nEND\nHALT\nESTIFF 1:{n} 1e6 1 1 1\n{load}\n"
            "END\nEND\n")


@pytest.mark.parametrize("kind", ["BEAM", "PLBEAM"])
def test_simply_supported_beam_under_uniform_load(tmp_path, kind):
    """L = 2, EI = 1, q = 1e-4 down: midspan deflection 5 q L^4 / (384 EI) = 2.0833e-5 (the
    consistent load makes the nodal deflections of Hermite beams exact), to 1e-6 relative
    at this small load; the supports carry q L / 2 each."""
    q, L, n = 1e-4, 2.0, 8
    line = f"DELQE 1:{n} 0 {-q}" + ("" if kind == "PLBEAM" else " 0")
    f = run(tmp_path, _simply_supported(n, line, kind))
    pos = f["static/position"][-1]
    mid = np.flatnonzero(np.isclose(pos[:, 0], L / 2))
    assert mid.size == 1
    exact = 5 * q * L**4 / 384
    assert abs(-pos[mid[0], 1] - exact) < 1e-6 * exact
    react = f["static/reaction"][-1][f["static/reaction_component"][:] == b"Fy"]
    np.testing.assert_allclose(react, [q * L / 2] * 2, rtol=1e-9)


def test_initial_line_load_gives_the_same_equilibrium(tmp_path):
    """QE (present from the start) and DELQE (over the load steps) end in the same state."""
    a = run(tmp_path, _simply_supported(4, "QE 1:4 0 -1e-3 0"), "a")
    b = run(tmp_path, _simply_supported(4, "DELQE 1:4 0 -1e-3 0"), "b")
    np.testing.assert_allclose(a["static/position"][-1], b["static/position"][-1],
                               rtol=0, atol=1e-13)


def test_cantilever_under_a_linear_load(tmp_path):
    """A cantilever (L = 1, EI = 1) under a load rising linearly from 0 at the root to q0 at
    the tip, each element given its own linear piece: tip deflection 11 q0 L^4 / (120 EI)
    and tip rotation q0 L^3 / (8 EI), to 1e-6 at q0 = 1e-4."""
    n, q0 = 6, 1e-4
    lines = "\n".join(f"DELQE {i + 1} 0 {q0 * i / n} 0 0 {q0 * (i + 1) / n} 0"
                      for i in range(n))
    text = (f"X 1 0 0 0\nX 3 1 0 0\nBEAMS 1 1 2 3 4 {n} 0 1 0\nDYNE 1:{n} 1 2 3 4 5 6\n"
            f"FIX 1\nFIX 2\nEND\nHALT\nESTIFF 1:{n} 1e6 1 1 1\n{lines}\nEND\nEND\n")
    f = run(tmp_path, text)
    pos, euler = f["static/position"][-1], f["static/euler"][-1]
    tip = int(np.argmax(pos[:, 0]))
    w_exact = 11 * q0 / 120
    assert abs(pos[tip, 1] - w_exact) < 1e-6 * w_exact
    # the tip's orientation node: the one turned most
    angle = 2 * np.arcsin(np.abs(euler[:, 3])).max()
    assert abs(angle - q0 / 8) < 1e-6 * q0 / 8


def _elastica_tip(k: float) -> np.ndarray:
    """The tip (x, y) of a cantilever (L = EI = 1, clamped along x) under a uniform dead
    load k along -y per unit length: EI theta'' = k (L - s) cos(theta), theta(0) = 0,
    theta'(L) = 0, shot from the tip."""
    def rhs(s, y):
        return [y[1], k * (1 - s) * np.cos(y[0]), np.cos(y[0]), np.sin(y[0])]

    def root(t1):
        return solve_ivp(rhs, [1, 0], [t1, 0, 0, 0], rtol=1e-12, atol=1e-13).y[0, -1]

    t1 = brentq(root, -1.5, 0.0, xtol=1e-14)
    y = solve_ivp(rhs, [1, 0], [t1, 0, 0, 0], rtol=1e-12, atol=1e-13).y[:, -1]
    return -y[2:]


def test_cantilever_under_a_large_dead_line_load_converges_to_the_elastica(tmp_path):
    """qL^3/EI = 10 (the tip turns by 60 degrees), lumped in the reference configuration:
    the tip converges as h^2 to the elastica; Richardson of 16 and 32 elements within 5e-6
    of it (EA = 1e7 stretches the beam by 1e-6)."""
    ref = _elastica_tip(10.0)
    assert np.allclose(ref, [0.656354, -0.700200], atol=1e-6)
    tips = []
    for n in (16, 32):
        text = (f"X 1 0 0 0\nX 3 1 0 0\nBEAMS 1 1 2 3 4 {n} 0 1 0\nDYNE 1:{n} 1 2 3 4 5 6\n"
                f"FIX 1\nFIX 2\nEND\nHALT\nESTIFF 1:{n} 1e7 1 1 1\nDELQE 1:{n} 0 -10 0\n"
                "ITERSTEP 30 10\nEND\nEND\n")
        tips.append(run(tmp_path, text, f"c{n}")["static/position"][-1, 1, :2])
    err = [np.linalg.norm(t - ref) for t in tips]
    assert 3.5 < err[0] / err[1] < 4.5 and err[1] < 4e-4
    assert np.linalg.norm(tips[1] + (tips[1] - tips[0]) / 3 - ref) < 5e-6


def _greenhill() -> float:
    """(q L^3 / EI) at which a clamped-free column buckles under its own weight:
    9/4 j^2 with j the first zero of J_{-1/3}."""
    j = brentq(lambda z: jv(-1.0 / 3.0, z), 1.0, 2.5)
    return 9.0 / 4.0 * j * j


def test_heavy_column_buckles_at_greenhills_load(tmp_path):
    """A clamped-free column under a uniform axial line load (its own weight): the buckling
    multiplier of q L^3 / EI = 1 converges as h^2 to 7.8373; the Richardson value of 16 and
    32 elements within 1e-4 (the 32-element value alone is 4e-4 low)."""
    values = []
    for n in (16, 32):
        text = (f"MODE buckling\nX 1 0 0 0\nX 3 1 0 0\nBEAMS 1 1 2 3 4 {n} 0 1 0\n"
                f"DYNE 1:{n} 1 2 3 4 5 6\nFIX 1\nFIX 2\nEND\nHALT\nESTIFF 1:{n} 1e6 1 1 2\n"
                f"DELQE 1:{n} -1 0 0\nEND\nEND\n")
        values.append(float(run(tmp_path, text, f"g{n}")["buckling/load_multiplier"][0, 0]))
    exact = _greenhill()
    assert abs(exact - 7.83734) < 1e-5
    richardson = values[1] + (values[1] - values[0]) / 3
    assert abs(richardson - exact) < 1e-4 * exact
    assert 3.5 < (exact - values[0]) / (exact - values[1]) < 4.5


def test_arc_length_path_under_a_line_load(tmp_path):
    """ARCLENGTH follows a DELQE load: in the linear range the midspan deflection over the
    load factor is 5 q L^4 / (384 EI) at every path point."""
    f = run(tmp_path, _simply_supported(8, "DELQE 1:8 0 -1e-4 0\nARCLENGTH 5 0.3"))
    lf = f["static/load_factor"][1:]
    pos = f["static/position"][1:]
    mid = np.flatnonzero(np.isclose(pos[0, :, 0], 1.0))[0]
    assert lf.size >= 3 and lf[-1] >= 1.0 - 1e-12
    np.testing.assert_allclose(-pos[:, mid, 1] / lf, 5e-4 * 16 / 384, rtol=1e-6)


# ---------------------------------------------------------------- deck errors
_BASE = ("X 1 0 0 0\nX 3 1 0 0\nX 5 2 0 0\nBEAM 1 1 2 3 4 0 1 0\nTRUSS 2 3 5\n"
         "DYNE 1 1 2 3 4 5 6\nDYNE 2 1\nFIX 1\nFIX 2\nEND\nHALT\nESTIFF 1 1 1 1 1\n"
         "ESTIFF 2 1\n{lines}\nEND\nEND\n")


def deck_error(lines: str, base: str = _BASE) -> list[str]:
    """The deck's error lines ``line:column: message``."""
    with pytest.raises(DeckError) as exc:
        model_from_text(base.format(lines=lines), "t.dat")
    return [line.split("t.dat:", 1)[1].replace(" error: ", " ")
            for line in str(exc.value).splitlines() if line.startswith("t.dat:")]


@pytest.mark.parametrize("lines, want", [
    ("QE 2 0 1 0", "14:4: QE: element 2 is a TRUSS; a line load acts on a beam (BEAM, "
                   "PLBEAM, BEAMW)"),
    ("DELQE 7 0 1 0", "14:7: DELQE: element 7 is not defined (no element line)"),
    ("DELQE 1 0 1", "14:1: DELQE: expected 3 or 6 components (DELQE 1 q1 q2 q3 [q1 q2 q3 "
                    "at q]), got 2"),
    ("DELQE 1 0 1 0 1", "14:1: DELQE: expected 3 or 6 components"),
])
def test_line_load_errors(lines, want):
    errors = deck_error(lines)
    assert len(errors) == 1 and errors[0].startswith(want), errors


def test_line_load_on_a_planar_beam_takes_two_components():
    text = ("X 1 0 0\nX 3 1 0\nPLBEAM 1 1 2 3 4\nDYNE 1 1 2 3\nFIX 1\nFIX 2\nEND\nHALT\n"
            "ESTIFF 1 1 1\nDELQE 1 0 1 0\nEND\nEND\n")
    with pytest.raises(DeckError) as exc:
        model_from_text(text, "t.dat")
    msg = str(exc.value)
    assert "t.dat:10:1: error: DELQE: expected 2 or 4 components (a planar deck: DELQE 1 qx " \
           "qy [qx qy at q]), got 3" in msg
    model = model_from_text(text.replace("DELQE 1 0 1 0", "DELQE 1 0 1 0 3"), "t.dat")
    assert model.line_loads[0].q_p == (0.0, 1.0, 0.0)
    assert model.line_loads[0].q_q == (0.0, 3.0, 0.0)


def test_line_load_range_and_model():
    model = model_from_text(_BASE.format(lines="QE 1 1 2 3\nDELQE 1:1 4 5 6 7 8 9"), "t.dat")
    qe, delqe = model.line_loads
    assert (qe.kind, qe.q_p, qe.q_q) == ("QE", (1.0, 2.0, 3.0), (1.0, 2.0, 3.0))
    assert (delqe.kind, delqe.q_p, delqe.q_q) == ("DELQE", (4.0, 5.0, 6.0), (7.0, 8.0, 9.0))
    assert qe.tf is None and delqe.tf is None


def test_check_counts_the_line_loads(tmp_path, capsys):
    deck = tmp_path / "d.dat"
    deck.write_text(_BASE.format(lines="QE 1 0 1 0\nDELQE 1:1 0 2 0"))
    assert main(["check", str(deck)]) == 0
    assert "1 QE, 1 DELQE" in capsys.readouterr().out


def test_warping_beam_takes_a_line_load(tmp_path):
    """BEAMW (its nodes p r wp q s wq): a cantilever (L = EI = 1) under q = 1e-4 + 1e-4 x/L
    along z, each element its own linear piece: tip deflection q L^4/8 + 11 q L^4/120."""
    n = 4
    xs = "\n".join(f"X {3 * i + 1} {i / n} 0 0" for i in range(n + 1))
    els = "\n".join(f"BEAMW {i + 1} {3 * i + 1} {3 * i + 2} {3 * i + 3} {3 * i + 4} "
                    f"{3 * i + 5} {3 * i + 6} 0 1 0" for i in range(n))
    loads = "\n".join(f"DELQE {i + 1} 0 0 {1e-4 * (1 + i / n)} 0 0 {1e-4 * (1 + (i + 1) / n)}"
                      for i in range(n))
    text = (f"{xs}\n{els}\nDYNE 1:{n} 1 2 3 4 5 6 7 8\nFIX 1\nFIX 2\nFIX 3\nEND\nHALT\n"
            f"ESTIFF 1:{n} 1e6 1 1 1 0 0 0.01\n{loads}\nEND\nEND\n")
    pos = run(tmp_path, text)["static/position"][-1]
    tip = int(np.argmax(pos[:, 0]))
    exact = 1e-4 / 8 + 11e-4 / 120
    assert abs(pos[tip, 2] - exact) < 1e-6 * exact
