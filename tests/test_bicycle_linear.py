"""The linearization about a steady motion (mode 3, ``TIMESTEP 0 0``) of the benchmark bicycle
of Meijaard et al. (2007) and of a rolling disc, against the published 14-digit matrices,
eigenvalues and speeds (docs/rolling.md, checks B1-B7, B11, C1, C2).

The matrices come from :class:`spacarpy.solvers.linear.steady_motion.SteadyMotion` on
decks/benchmark_bicycle.dat at chosen speeds; the weave, capsize and double-root speeds are
found by root-finding on the matrices of those runs (M0 exact, C0 = v C1, K0 = g K0 + v^2 K2:
the speed enters only through the rear wheel's rate)."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy.optimize import brentq

from spacarpy.deck import job_from_text, load
from spacarpy.solvers.linear.steady_motion import SteadyMotion, certified, richardson

from helpers import rolling_coin_deck

DECK = Path(__file__).resolve().parents[1] / "decks" / "benchmark_bicycle.dat"
G = 9.81

# [S1] eqs (6.1)-(6.4)
M_REF = np.array([[80.81722, 2.31941332208709], [2.31941332208709, 0.29784188199686]])
K0_REF = np.array([[-80.95, -2.59951685249872], [-2.59951685249872, -0.80329488458618]])
K2_REF = np.array([[0.0, 76.59734589573222], [0.0, 2.65431523794604]])
C1_REF = np.array([[0.0, 33.86641391492494], [-0.85035641456978, 1.68540397397560]])

# [S1] Table 2: v, Re and Im of the weave pair, capsize, castering (v = 0: two real pairs)
TABLE2 = {
    1: (3.52696170990070, 0.80774027519930, -3.13423125066578, -7.11008014637442),
    2: (2.68234517512745, 1.68066296590675, -3.07158645641514, -8.67387984831735),
    3: (1.70675605663975, 2.31582447384325, -2.63366137253667, -10.35101467245920),
    4: (0.41325331521125, 3.07910818603206, -1.42944427361326, -12.15861426576447),
    5: (-0.77534188219585, 4.46486771378823, -0.32286642900409, -14.07838969279822),
    6: (-1.52644486584142, 5.87673060598709, -0.00406690076970, -16.08537123098026),
    7: (-2.13875644258362, 7.19525913329805, 0.10268170574766, -18.15788466125262),
    8: (-2.69348683581097, 8.46037971396931, 0.14327879765713, -20.27940894394569),
    9: (-3.21675402252485, 9.69377351531791, 0.15790184030917, -22.43788559040858),
    10: (-3.72016840437287, 10.90681139476287, 0.16105338653172, -24.62459635017404),
}
V0_POLES = (3.13164324790656, 5.53094371765393)
V_WEAVE, V_CAPSIZE, V_DOUBLE = 4.29238253634111, 6.02426201538837, 0.68428307889246


def bicycle(v: float, text: str | None = None):
    """The matrices of the bicycle deck (or deck ``text``) at speed v."""
    if text is None:
        model = load(DECK, overrides={"V": v}).model
    else:
        model = job_from_text(text, overrides={"V": v}).model
    return SteadyMotion(model).matrices()


@pytest.fixture(scope="module")
def runs():
    return {v: bicycle(float(v)) for v in (0, 1, 2, 5, 10)}


def rel(a, b) -> float:
    return float(np.abs(a - b).max() / np.abs(b).max())


def expected_poles(v: float) -> np.ndarray:
    if v == 0:
        a, b = V0_POLES
        lam = [-b, -a, a, b]
    else:
        re, im, cap, cast = TABLE2[v]
        lam = [re - 1j * im, re + 1j * im, cap, cast]
    lam = np.array(lam, dtype=complex)
    return lam[np.lexsort((lam.imag, lam.real))]


def test_b1_mass_matrix(runs):
    for v in (1, 5):
        assert rel(runs[v].M0, M_REF) < 1e-12


def test_b2_damping_over_speed(runs):
    for v in (1, 5):
        assert rel(runs[v].C0 / v, C1_REF) < 1e-11


def test_b3_stiffness_and_its_parts(runs):
    for v in (0, 1, 5, 10):
        assert rel(runs[v].K0, G * K0_REF + v * v * K2_REF) < 1e-11
    k2 = (runs[2].K0 - runs[1].K0) / 3.0
    assert rel(k2, K2_REF) < 1e-11
    assert rel(runs[1].K0 - k2, G * K0_REF) < 1e-11


def test_b4_poles_against_table2(runs):
    for v in (0, 1, 2, 5, 10):
        lam = runs[v].dof_poles()
        assert np.abs(lam - expected_poles(v)).max() < 1e-10, v


@pytest.mark.slow
def test_b4_poles_every_speed():
    for v in range(11):
        lam = bicycle(float(v)).dof_poles()
        assert np.abs(lam - expected_poles(v)).max() < 1e-10, v


def _speed_matrices(runs):
    """M, C1, K2, g K0 from the runs at v = 1 and 2."""
    k2 = (runs[2].K0 - runs[1].K0) / 3.0
    return runs[1].M0, runs[1].C0, k2, runs[1].K0 - k2


def _poles(mats, v: float) -> np.ndarray:
    M, C1, K2, gK0 = mats
    a = np.zeros((4, 4))
    a[:2, 2:] = np.eye(2)
    a[2:, :2] = -np.linalg.solve(M, gK0 + v * v * K2)
    a[2:, 2:] = -np.linalg.solve(M, v * C1)
    return np.linalg.eigvals(a)


def test_b5_weave_and_capsize_speeds(runs):
    mats = _speed_matrices(runs)

    def weave(v):
        lam = _poles(mats, v)
        return lam.real[np.abs(lam.imag) > 0].max()

    def capsize(v):
        M, C1, K2, gK0 = mats
        return np.linalg.det(gK0 + v * v * K2)

    v_w = brentq(weave, 3.0, 5.0, xtol=1e-14, rtol=1e-15)
    v_c = brentq(capsize, 5.0, 7.0, xtol=1e-14, rtol=1e-15)
    assert abs(v_w - V_WEAVE) < 1e-9
    assert abs(v_c - V_CAPSIZE) < 1e-9


def test_b6_double_root_speed(runs):
    mats = _speed_matrices(runs)
    lo, hi = 0.5, 1.0                  # four real roots at lo, a complex pair at hi
    assert not np.any(_poles(mats, lo).imag) and np.any(_poles(mats, hi).imag)
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if not np.any(_poles(mats, mid).imag) else (lo, mid)
    assert abs(0.5 * (lo + hi) - V_DOUBLE) < 1e-7


def test_b7_kinematic_coupling_and_g_blocks(runs):
    for v in (1, 5, 10):
        m = runs[v]
        assert np.abs(m.K0p).max() <= 1e-12 * np.abs(m.K0).max()
        # the lateral position follows the yaw: d(y')/d(psi) = v (KINX 2 2 against KINE 1 1)
        assert abs(m.Gp[3, 0] - v) < 1e-12 * v
        # and the yaw rate the steer angle: d(psi')/d(delta) = v cos(lambda) / w
        assert abs(m.Gq[0, 1] - v * np.cos(np.pi / 10) / 1.02) < 1e-12 * v
    assert m.kinematic_names == ["KINE 1 1", "KINE 11 1", "KINX 2 1", "KINX 2 2"]
    assert m.dof_names == ["HINGE 2 1", "HINGE 8 1"]


# ---------------------------------------------------------------- B11: z up, yawed, moved
def _turned_deck(yaw: float = 0.7, shift=(12.3, -4.5)) -> str:
    """The §3.2 deck with z up (x, y, z) -> (x, -y, -z), yawed by ``yaw`` about z and moved
    by ``shift``, all numbers written out."""
    c, s = np.cos(yaw), np.sin(yaw)
    Q = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]]) @ np.diag([1.0, -1.0, -1.0])
    lam, w, cc, rr, rf = np.pi / 10, 1.02, 0.08, 0.3, 0.35
    nodes = {2: (0, 0, 0), 3: (0, 0, -rr), 4: (0.3, 0, -0.9),
             5: (w + cc - 0.9 * np.tan(lam), 0, -0.9), 6: (0.9, 0, -0.7), 7: (w, 0, -rf),
             8: (w, 0, 0)}

    def vec(v):
        return " ".join(repr(float(t)) for t in Q @ np.asarray(v, float))

    def pos(v):
        p = Q @ np.asarray(v, float) + np.array([shift[0], shift[1], 0.0])
        return " ".join(repr(float(t)) for t in p)

    def inertia(J):
        J = Q @ np.asarray(J, float) @ Q.T
        return " ".join(repr(float(J[i, j])) for i, j in
                        ((0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2)))

    lines = ["SET V 1"] + [f"X {n} {pos(x)}" for n, x in nodes.items()] + [
        f"HINGE 1 9 10 {vec((0, 0, 1))}", f"HINGE 2 10 11 {vec((1, 0, 0))}",
        f"HINGE 3 11 13 {vec((0, 1, 0))}", f"HINGE 4 13 12 {vec((0, 1, 0))}",
        f"WHEEL 5 3 12 2 {vec((0, 1, 0))}", "PINBODY 6 4 13 3", "PINBODY 7 4 13 5",
        f"HINGE 8 13 14 {vec((np.tan(lam), 0, 1))}", "PINBODY 9 5 14 6",
        "PINBODY 10 5 14 7", f"HINGE 11 14 15 {vec((0, 1, 0))}",
        f"WHEEL 12 7 15 8 {vec((0, 1, 0))}",
        "FIX 9", "RLSE 3 1", "DYNE 2 1", "DYNE 8 1", "INPUTE 4 1", "KINE 1 1", "KINE 11 1",
        "KINX 2 1", "KINX 2 2", "END", "HALT",
        "XM 3 2.0", f"XM 12 {inertia(np.diag([0.0603, 0.12, 0.0603]))}", "XM 4 85.0",
        f"XM 13 {inertia([[9.2, 0, 2.4], [0, 11, 0], [2.4, 0, 2.8]])}", "XM 6 4.0",
        f"XM 14 {inertia([[0.05892, 0, -0.00756], [0, 0.06, 0], [-0.00756, 0, 0.00708]])}",
        "XM 7 3.0", f"XM 15 {inertia(np.diag([0.1405, 0.28, 0.1405]))}",
        "GRAVITY 0 0 -9.81", f"INPUTE 4 1 0 {{-V/{rr}}} 0", "MODE 3", "TIMESTEP 0 0",
        "END", "END"]
    return "\n".join(lines) + "\n"


def test_b11_placement_invariance(runs):
    m = bicycle(5.0, _turned_deck())
    ref = runs[5]
    assert rel(m.M0, ref.M0) < 1e-12
    assert rel(m.C0, ref.C0) < 1e-12
    assert rel(m.K0, ref.K0) < 1e-12


# ---------------------------------------------------------------- C1, C2: the rolling disc
COIN = rolling_coin_deck()
M_D, R_D, A_D, C_D = 2.0, 0.3, 0.045, 0.09


def coin(v: float):
    return SteadyMotion(job_from_text(COIN, overrides={"V": v}).model).matrices()


@pytest.fixture(scope="module")
def coins():
    return {v: coin(v) for v in (0.5, 1.0, 1.5, 2.0, 3.0)}


def test_c1_rolling_disc_poles(coins):
    for v, ref in ((3.0, 14.6232691283447j), (1.5, 5.81721582889960j),
                   (0.5, 4.41512551727959)):
        w = v / R_D
        wn2 = ((C_D + M_D * R_D ** 2) * C_D * w * w / A_D - M_D * G * R_D) / (A_D + M_D * R_D ** 2)
        assert abs(np.sqrt(complex(-wn2)) - ref) < 1e-13 * abs(ref)    # the closed form
        lam = coins[v].poles()
        big = lam[np.abs(lam) > 1.0]
        assert big.size == 2
        assert np.abs(np.sort_complex(big) - np.sort_complex(np.array([-ref, ref]))).max() \
            < 1e-9 * abs(ref)
        # the cyclic heading, spin and contact point: zero poles, some in Jordan blocks,
        # whose computed values would carry half the digits of the matrices (3e-7 from
        # entries of 1e-13); the certified zeros of the differenced matrices make them exact
        assert np.abs(lam[np.abs(lam) <= 1.0]).max() < 1e-8
        m = coins[v]
        assert np.abs(m.K0[:, [0, 2]]).max() < 1e-12 * np.abs(m.K0).max()
        assert np.abs(m.K0p).max() < 1e-12 * np.abs(m.K0).max()


def test_certified_zeros_only_within_their_bound():
    """An entry is set to zero only where its magnitude is within its error bound."""
    value = np.array([1e-13, -2e-13, 5e-12, 3.0])
    bound = np.full(4, 2e-13)
    assert certified(value, bound).tolist() == [0.0, 0.0, 5e-12, 3.0]


def test_richardson_error_estimate():
    """The table's error estimate bounds the true error of a smooth function's derivative
    and is itself small (h0 = 0.05, 4 levels: truncation O(h^8))."""
    d, err = richardson(lambda h: np.array([np.sin(1.0 + h), np.exp(2 * h)]), error=True)
    assert np.all(np.abs(d - [np.cos(1.0), 2.0]) <= err + 1e-14)
    assert np.all(err < 1e-10)


def test_c2_rolling_disc_critical_speed(coins):
    a, b = coins[1.0], coins[2.0]
    k_v = (b.K0 - a.K0) / 3.0                     # K0 = K_g + V^2 K_v, C0 = V C_1

    def square(v):
        """lambda^2 of the lean pair at V: negative while it oscillates."""
        n = 3
        m = np.zeros((2 * n, 2 * n))
        m[:n, n:] = np.eye(n)
        m[n:, :n] = -np.linalg.solve(a.M0, a.K0 - k_v + v * v * k_v)
        m[n:, n:] = -np.linalg.solve(a.M0, v * a.C0)
        lam = np.linalg.eigvals(m)
        top = lam[np.argmax(np.abs(lam))]
        return float((top * top).real)

    v_c = brentq(square, 0.5, 1.5, xtol=1e-14, rtol=1e-15)
    assert abs(v_c - 0.990454441153151) < 1e-9
    assert abs(v_c - np.sqrt(G * R_D / 3.0)) < 1e-9


# ---------------------------------------------------------------- the deck, as a run
def test_deck_run_writes_the_state_space(tmp_path):
    import h5py

    from spacarpy.cli import main
    out = tmp_path / "b.h5"
    assert main(["run", str(DECK), "-o", str(out), "-q", "--set", "V=5"]) == 0
    with h5py.File(out, "r") as f:
        ss = f["state_space"]
        assert rel(ss["M0"][0], M_REF) < 1e-12
        assert rel(ss["C0"][0] / 5, C1_REF) < 1e-11
        assert rel(ss["K0"][0], G * K0_REF + 25 * K2_REF) < 1e-11
        names = [s.decode() for s in ss["state_name"][:]]
        assert names[-4:] == ["KINE 1 1", "KINE 11 1", "KINX 2 1", "KINX 2 2"]
        assert [s.decode() for s in ss["kinematic_name"][:]] == names[-4:]
        pole = ss["pole"][0]
        assert pole.shape == (8,)
        big = pole[np.abs(pole) > 1e-8]
        assert big.size == 4                        # the kinematic states' four zeros: exact
        assert np.abs(np.sort_complex(big) - np.sort_complex(expected_poles(5))).max() < 1e-10
        A = ss["A"][0]
        assert abs(A[7, 4] - 5.0) < 1e-12           # y' = v psi
        # the rolling state at t = 0: no slip, the rear contact moving forward at v
        v = f["transient/velocity"][0]
        assert np.abs(v[0] - [5.0, 0, 0]).max() < 1e-12
        # contact forces: the normal forces carry the weight (WHEEL mode 6: the multiplier,
        # times the kind's stress_sign where it has one, as in statics)
        from spacarpy.elements.registry import KINDS
        sign = (getattr(KINDS["WHEEL"], "stress_sign", ()) or (1.0,) * 6)[5]
        wheel = f["transient/elements/WHEEL/stress_resultant"][0]
        assert np.abs(wheel[:, 5] * sign + [612.8364705882354, 309.3035294117647]).max() \
            < 1e-9 * 94 * G
        assert np.abs(wheel[:, 3:5]).max() < 1e-9


def test_timestep_0_0_in_mode_1_and_a_massless_dof_are_refused(tmp_path, capsys):
    """(Mode 3 along a trajectory with slips runs: tests/test_rolling_mode3.py.)"""
    from spacarpy.cli import main
    text = DECK.read_text()
    assert main(["run", str(DECK), "--mode", "1", "-o", str(tmp_path / "m1.h5"), "-q"]) != 0
    assert "TIMESTEP 0 0" in capsys.readouterr().err
    massless = tmp_path / "massless.dat"
    massless.write_text("".join(line for line in text.splitlines(keepends=True)
                                if not line.startswith("XM")))
    assert main(["run", str(massless), "-o", str(tmp_path / "nm.h5"), "-q"]) == 2
    assert "needs inertia in every degree of freedom" in capsys.readouterr().err


def test_a_state_that_is_not_steady_is_linearized_with_a_warning(tmp_path, capsys):
    """The rigid pendulum (2 kg, 1 m, RLSE hinge: the DOF set falls back to the RLSE modes as
    in mode 9) released horizontally: M0 = m L^2/3, K0 = 0 there, and the state accelerates."""
    import h5py

    from spacarpy.cli import main
    deck = tmp_path / "pendulum.dat"
    deck.write_text((DECK.parent / "pendulum_rigid_90deg.dat").read_text()
                    .replace("TIMESTEP 2.2 440", "TIMESTEP 0 0"))
    out = tmp_path / "p.h5"
    assert main(["run", str(deck), "--mode", "3", "-o", str(out), "-q"]) == 0
    assert "not a steady motion" in capsys.readouterr().err
    with h5py.File(out, "r") as f:
        assert abs(f["state_space/M0"][0, 0, 0] - 2.0 / 3.0) < 1e-14
        assert abs(f["state_space/K0"][0, 0, 0]) < 1e-12
