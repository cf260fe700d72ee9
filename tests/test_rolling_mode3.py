"""Mode 3 with slips beyond the initial steady motion (docs/rolling.md): along a trajectory
(check B8: the bicycle rolling upright at constant speed linearizes to the same matrices at
every stored step; a disc rolling down a slope, whose motion accelerates), and the inputs
and outputs of the state space (INPUTS, OUTE, OUTEP, OUTX on a KINX coordinate) against the
benchmark's 14-digit matrices."""
from __future__ import annotations

from pathlib import Path

import h5py
import numpy as np
import pytest

from spacarpy.cli import main
from spacarpy.deck import job_from_text
from spacarpy.solvers.linear.steady_motion import SteadyMotion

from helpers import rolling_coin_deck

DECK = Path(__file__).resolve().parents[1] / "decks" / "benchmark_bicycle.dat"
G = 9.81

# [S1] eqs (6.1)-(6.4)
M_REF = np.array([[80.81722, 2.31941332208709], [2.31941332208709, 0.29784188199686]])
K0_REF = np.array([[-80.95, -2.59951685249872], [-2.59951685249872, -0.80329488458618]])
K2_REF = np.array([[0.0, 76.59734589573222], [0.0, 2.65431523794604]])
C1_REF = np.array([[0.0, 33.86641391492494], [-0.85035641456978, 1.68540397397560]])
# [S1] Table 2 at v = 5: the weave pair, capsize, castering
POLES_5 = np.array([-0.77534188219585 - 4.46486771378823j, -0.77534188219585 + 4.46486771378823j,
                    -0.32286642900409, -14.07838969279822])

#: the third module: a steer torque in, the lean, the steer rate, the rear contact's y
#: (a KINX coordinate) and the rear wheel's longitudinal slip velocity out
SIGNALS = ["HALT", "INPUTS 1 8 1", "OUTE 1 2 1", "OUTEP 2 8 1", "OUTX 3 2 2", "OUTEP 4 5 4"]
STATE_SPACE = ("M0", "C0", "K0", "B0", "A", "B", "C", "K0p", "G", "Gq", "Gp")


def _deck(tmp_path, name: str, timestep: str, signals: bool = True) -> Path:
    lines = DECK.read_text().rstrip("\n").split("\n")
    assert lines[-2:] == ["END", "END"]
    lines = [("TIMESTEP " + timestep) if ln.startswith("TIMESTEP") else ln for ln in lines]
    if signals:
        lines = lines[:-1] + SIGNALS + ["END", "END"]
    path = tmp_path / name
    path.write_text("\n".join(lines) + "\n")
    return path


def _run(deck: Path, out: Path, v: float) -> dict:
    assert main(["run", str(deck), "-o", str(out), "-q", "--set", f"V={v}"]) == 0
    with h5py.File(out, "r") as f:
        ss = f["state_space"]
        data = {k: ss[k][:] for k in STATE_SPACE + ("pole", "time")}
        data["names"] = [s.decode() for s in ss["state_name"][:]]
        data["t"] = f["transient/time"][:]
    return data


def rel(a, b) -> float:
    return float(np.abs(a - b).max() / max(np.abs(b).max(), 1e-300))


# ---------------------------------------------------------------- B8: along a trajectory
def _b8(tmp_path, timestep: str, n_rows: int):
    v = 4.6
    steady = _run(_deck(tmp_path, "s.dat", "0 0"), tmp_path / "s.h5", v)
    along = _run(_deck(tmp_path, "a.dat", timestep), tmp_path / "a.h5", v)
    assert along["A"].shape[0] == n_rows == along["t"].size
    assert np.array_equal(along["time"], along["t"])
    assert along["names"] == steady["names"]
    worst = 0.0
    for key in STATE_SPACE:
        ref = steady[key][0]
        for k in range(n_rows):
            if np.abs(ref).max() == 0.0:
                assert np.abs(along[key][k]).max() < 1e-12, key
            else:
                worst = max(worst, rel(along[key][k], ref))
    assert worst < 1e-9                       # B8 (measured 2e-13)
    assert np.abs(along["pole"] - steady["pole"][0]).max() < 1e-9
    return steady


def test_b8_bicycle_at_constant_speed_linearizes_alike_at_every_step(tmp_path):
    steady = _b8(tmp_path, "0.1 5", 6)
    # and the steady matrices are the benchmark's at 4.6 m/s
    assert rel(steady["M0"][0], M_REF) < 1e-12
    assert rel(steady["K0"][0], G * K0_REF + 4.6 ** 2 * K2_REF) < 1e-11


@pytest.mark.slow
def test_b8_two_seconds_in_100_steps(tmp_path):
    """The spec's B8 as the ESM runs it: ``TIMESTEP 2 100``."""
    _b8(tmp_path, "2 100", 101)


COIN_SLOPE = rolling_coin_deck(
    gravity="{9.81*sin(AL)} 0 {-9.81*cos(AL)}", timestep="0.2 4", sets="SET AL 0.1\n",
    title="a uniform thin disc rolling upright down a slope (gravity tilted by AL)")
M_D, R_D, A_D, C_D, AL = 2.0, 0.3, 0.045, 0.09, 0.1


def test_a_disc_rolling_down_a_slope_linearizes_about_its_accelerating_motion(tmp_path):
    """Not a steady motion: the spin accelerates at g sin(alpha) / (1 + C/(m r^2)) / r. At
    each step q'' comes from the equations of motion there, M0 is the upright disc's, and
    C0 (the gyroscopic coupling, linear in the spin rate) follows the spin rate stored."""
    acc = G * np.sin(AL) / (1.0 + C_D / (M_D * R_D ** 2))      # 0.6529105448702562 m/s^2
    sm = SteadyMotion(job_from_text(COIN_SLOPE).model)
    m_start = sm.matrices()
    x, v, *_ = sm.motion(sm.q0, sm.dq0, sm.p0)
    sm.at_state(0.0, x, v)
    assert abs(sm.ddq0[2] - acc / R_D) < 1e-12 * acc / R_D
    assert np.abs(sm.ddq0[:2]).max() < 1e-12
    deck = tmp_path / "slope.dat"
    deck.write_text(COIN_SLOPE)
    out = tmp_path / "slope.h5"
    assert main(["run", str(deck), "-o", str(out), "-q"]) == 0
    with h5py.File(out, "r") as f:
        ss = f["state_space"]
        rate = f["transient/elements/HINGE/deformation_rate"][:, 2, 0]     # the spin rate
        M0, C0 = ss["M0"][:], ss["C0"][:]
    assert rate[-1] > rate[0] + 0.9 * acc * 0.2 / R_D                  # it accelerates
    diag = [A_D, A_D + M_D * R_D ** 2, C_D + M_D * R_D ** 2]
    for k in range(rate.size):
        assert np.abs(M0[k] - np.diag(diag)).max() < 1e-12
        assert rel(C0[k], m_start.C0 * rate[k] / (3.0 / R_D)) < 1e-9


# ---------------------------------------------------------------- inputs and outputs
def test_steer_torque_to_lean_transfer_function_is_the_benchmark_s(tmp_path, capsys):
    v = 5.0
    d = _run(_deck(tmp_path, "io.dat", "0 0"), tmp_path / "io.h5", v)
    B0, A, B, C = d["B0"][0], d["A"][0], d["B"][0], d["C"][0]
    # INPUTS on the steer hinge: -D_k^T in (lean, steer), ESIG's sign
    assert np.abs(B0 - [[0.0], [-1.0]]).max() < 1e-14
    # OUTE lean, OUTEP steer rate: unit rows on q and q'; OUTX y of P: the KINX state
    e = np.eye(8)
    assert np.abs(C[0] - e[0]).max() < 1e-12
    assert np.abs(C[1] - e[3]).max() < 1e-12
    assert np.abs(C[2] - e[7]).max() < 1e-12
    assert np.abs(C[3]).max() < 1e-12          # a held slip's velocity: 0 to first order
    K = G * K0_REF + v * v * K2_REF
    for s in (0.0, 2.0j, 1.5 + 3.0j):
        ref = np.linalg.solve(M_REF * s * s + v * C1_REF * s + K, [0.0, -1.0])[0]
        if s == 0.0:   # A is singular (the kinematic zeros): the DOF block at s = 0
            got = np.linalg.solve(-A[:4, :4], B[:4])[0, 0]
        else:
            got = (C[0] @ np.linalg.solve(s * np.eye(8) - A, B))[0]
        assert abs(got - ref) < 1e-10 * abs(ref)
    pole = d["pole"][0]
    assert np.count_nonzero(np.abs(pole) < 1e-8) == 4
    big = pole[np.abs(pole) >= 1e-8]
    assert np.abs(np.sort_complex(big) - np.sort_complex(POLES_5)).max() < 1e-10
    # spacarpy show names the smallest nonzero pole (capsize at 5 m/s) and counts the zeros
    capsys.readouterr()
    assert main(["show", str(tmp_path / "io.h5")]) == 0
    out = capsys.readouterr().out
    assert "the pole of smallest magnitude is -0.3229 +- 0i 1/s" in out
    assert "(besides 4 zero poles)" in out


# ---------------------------------------------------------------- the root-locus plot
def test_root_locus_plot_draws_the_sweep_s_stored_poles(tmp_path, capsys):
    pytest.importorskip("matplotlib")
    from spacarpy.results.plot_sweep import root_locus_figure
    sweep = tmp_path / "sweep.h5"
    assert main(["sweep", str(DECK), "--set", "V=1,5", "--collect", "/state_space/pole",
                 "-o", str(sweep), "-j", "1", "-q"]) == 0
    with h5py.File(sweep, "r") as f:
        V, P = f["parameters/V"][:], f["state_space/pole"][:]
    assert V.tolist() == [1.0, 5.0] and P.shape == (2, 8)
    fig = root_locus_figure(sweep)
    real, imag = fig.axes[0].lines[:2]
    keep = P != 0                                  # the four kinematic zeros of each run
    assert np.count_nonzero(~keep) == 8
    x = np.broadcast_to(V[:, None], P.shape)
    assert np.array_equal(real.get_xdata(), x[keep])
    assert np.array_equal(real.get_ydata(), P.real[keep])
    up = keep & (P.imag > 0)
    assert np.array_equal(imag.get_xdata(), x[up])
    assert np.array_equal(imag.get_ydata(), P.imag[up])
    # the weave pair at 5 m/s (Table 2), drawn as stored
    assert np.abs(np.sort(imag.get_ydata()[imag.get_xdata() == 5.0]) - 4.46486771378823).max() \
        < 1e-10
    png = tmp_path / "rl.png"
    assert main(["plot", str(sweep), "root-locus", "-o", str(png), "-q"]) == 0
    assert png.read_bytes()[:4] == b"\x89PNG"
    # a run's result file is not a sweep: one line, exit code 2
    capsys.readouterr()
    run = tmp_path / "one.h5"
    assert main(["run", str(DECK), "-o", str(run), "-q"]) == 0
    assert main(["plot", str(run), "root-locus", "-o", str(tmp_path / "x.png"), "-q"]) == 2
    err = capsys.readouterr().err
    assert "root-locus draws a sweep over one SET parameter" in err and "Traceback" not in err


def test_root_locus_marks_the_changes_of_stability():
    from spacarpy.results.plot_sweep import RootLocus
    poles = np.array([[3.0 + 1j, 3.0 - 1j, 0.0], [-1.0 + 2j, -1.0 - 2j, 0.0],
                      [-0.5, 1.0, 0.0], [-0.5, -0.25, 0.0]])
    rl = RootLocus("V", np.array([1.0, 2.0, 3.0, 4.0]), poles, 0, "d.dat")
    # +3 -> -1 between 1 and 2: at 1.75; -1 -> +1 between 2 and 3: at 2.5; +1 -> -0.25: 3.8
    assert np.allclose(rl.stability_changes(), [1.75, 2.5, 3.8], rtol=0, atol=1e-15)
    x_re, re, x_im, im = rl.points()
    assert re.size == 8 and np.all(re != 0.0) and im.tolist() == [1.0, 2.0]
