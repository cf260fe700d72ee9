"""A Twente-dialect bicycle-robot deck runs in every mode (check D1 of the rolling-contact
spec, issue 32): decks/bicycle_robot_twente.dat, z up, PINBODY, WHEEL, HINGE, KINE, KINX,
INPUTS, OUTE, OUTEP, EDAMP, a rider on a sprung lean hinge and a rigid BEAM.

What is measured, not only that it runs:
- ``spacarpy check`` and ``--mode 0``: the SPACAR classes (M, K, C, O) and the total mass;
- with the rider's hinge made rigid, the deck is the benchmark bicycle (frame and rider carry
  the rear frame's mass, centre of mass and inertia, turned to z up): mode 7 gives Table 2(a)'s
  two unstable roots at rest to 1e-10;
- without its dampers, the poles of its mode-9 state space are the roots of its own mode 7
  (the same linearization stored twice);
- mode 1 (its TIMESTEP line): the energy T + U + D - W is kept to 2e-6 of the kinetic energy,
  and the lean and steer follow the mode-9 state space's exp(A t) response while the motion is
  small (the nonlinear transient against the linearization).
"""
from __future__ import annotations

from pathlib import Path

import h5py
import numpy as np
import scipy.linalg as sla

from spacarpy.cli import main
from spacarpy.results import open_results

DECK = Path(__file__).resolve().parents[1] / "decks" / "bicycle_robot_twente.dat"
#: Table 2(a) of Meijaard et al. (2007) at v = 0: the capsize-like and the weave-like roots
V0_ROOTS = np.array([3.13164324790656, 5.53094371765393])


def _variant(tmp_path, name: str, drop: tuple[str, ...] = ()) -> Path:
    lines = [ln for ln in DECK.read_text().splitlines() if not ln.startswith(drop)]
    path = tmp_path / name
    path.write_text("\n".join(lines) + "\n")
    return path


def _run(deck: Path, out: Path, *args: str) -> Path:
    assert main(["run", str(deck), "-o", str(out), "-q", *args]) == 0
    return out


def test_check_and_mode_0_report_the_classes_and_the_mass(tmp_path, capsys):
    assert main(["check", str(DECK)]) == 0
    out = capsys.readouterr().out
    assert "7 degrees of freedom" in out
    assert "slips held          4" in out and "kinematic           4 coordinates" in out
    assert main(["run", str(DECK), "--mode", "0"]) == 0
    report = capsys.readouterr()
    text = report.out + report.err
    assert "M dynamic           3: HINGE 2 mode 1; HINGE 8 mode 1; HINGE 14 mode 1" in text
    assert "K kinematic         4: KINE 1 1" in text
    assert "C calculable        1 deformation mode (RLSE): HINGE 3 mode 1" in text
    assert "O fixed" in text
    assert "total mass          94 kg" in text        # 2 + 15 + 70 + 4 + 3
    assert "not supported yet" not in text and "Traceback" not in text


def test_with_a_rigid_rider_it_is_the_benchmark_at_rest(tmp_path):
    deck = _variant(tmp_path, "rigid.dat",
                    ("DYNE 14", "ESTIFF 14", "EDAMP", "INPUTS 2"))
    with h5py.File(_run(deck, tmp_path / "r.h5", "--mode", "7")) as f:
        freq, kind = f["eigen/frequency"][-1], f["eigen/kind"][-1]
    assert kind.tolist() == [2, 2]                # both unstable (kind 2)
    np.testing.assert_allclose(np.sort(-2 * np.pi * freq), V0_ROOTS, rtol=1e-10)


def test_its_state_space_poles_are_its_mode_7_roots(tmp_path):
    deck = _variant(tmp_path, "undamped.dat", ("EDAMP",))
    with h5py.File(_run(deck, tmp_path / "e.h5", "--mode", "7")) as f:
        freq, kind = f["eigen/frequency"][-1], f["eigen/kind"][-1]
    with open_results(_run(deck, tmp_path / "s.h5")) as r:
        v = r.state_space
        a = v.matrices(step=v.step[-1])["A"]
    # kind 2 (unstable): a real pair +-lambda, lambda = -2 pi f; else +-i 2 pi f
    roots = np.where(kind == 2, -2 * np.pi * freq, 2j * np.pi * freq)
    expected = np.concatenate([roots, -roots])
    poles = np.linalg.eigvals(a)
    assert poles.size == expected.size == 6
    for p in expected:
        assert np.min(np.abs(poles - p)) < 1e-9 * np.abs(expected).max(), (p, poles)


def test_mode_1_keeps_its_energy_and_follows_the_state_space(tmp_path):
    out = _run(DECK, tmp_path / "t.h5", "--mode", "1")
    with h5py.File(out) as f:
        g = f["transient"]
        t = g["time"][()]
        energy = sum(g[k][()] for k in ("kinetic_energy", "elastic_energy",
                                        "dissipated_energy")) - g["external_work"][()]
        kinetic = g["kinetic_energy"][()]
        hinge = g["elements/HINGE/deformation"][()]
        order = f["model/elements/HINGE/ids"][()].tolist()
    assert t[-1] == 0.5 and t.size == 101
    assert np.abs(energy - energy[0]).max() < 2e-6 * kinetic.max()
    with open_results(_run(DECK, tmp_path / "s.h5")) as r:
        v = r.state_space
        m = v.matrices(step=v.step[-1])
        names = list(v.state_name)
    x0 = np.zeros(len(names))
    x0[names.index("rate of HINGE 2 mode 1")] = 0.05            # STARTDE 2 1 0.05
    lean, steer = hinge[:, order.index(2), 0], hinge[:, order.index(8), 0]
    for k in (10, 20, 40):                                       # t = 0.05, 0.1, 0.2 s
        y = m["C"] @ sla.expm(m["A"] * t[k]) @ x0                # frame lean, steer, ...
        assert abs(lean[k] - y[0]) < 2e-4 * abs(y[0]), (t[k], lean[k], y[0])
        assert abs(steer[k] - y[1]) < 2e-2 * abs(y[1]), (t[k], steer[k], y[1])


def test_mode_1_driven_rear_wheel_does_the_work_it_should(tmp_path):
    """The rear wheel driven at 5 m/s (INPUTE 4 1 0 5/RR 0): the work of the prescribed
    rotation equals the change of T + U + D to 2e-6 of T. (Before the multipliers of a
    driven step were made consistent with the projected velocities, that work grew with the
    time step: 71 J of 1220 J at h = 5 ms.)"""
    text = DECK.read_text().replace("INPUTE 4 1 0 0 0 ", "INPUTE 4 1 0 {5/RR} 0 ")
    assert "{5/RR}" in text
    deck = tmp_path / "driven.dat"
    deck.write_text(text)
    with h5py.File(_run(deck, tmp_path / "d.h5", "--mode", "1")) as f:
        g = f["transient"]
        work = g["external_work"][()]
        energy = sum(g[k][()] for k in ("kinetic_energy", "elastic_energy",
                                        "dissipated_energy")) - work
        kinetic = g["kinetic_energy"][()]
    assert kinetic[0] > 1000.0                      # 94 kg at 5 m/s and the wheels' spin
    assert np.abs(energy - energy[0]).max() < 2e-6 * kinetic.max()


def test_mode_10_stores_the_mechanism_multipliers_as_exact_zeros(tmp_path):
    """At rest only the rider's hinge has a material stiffness (ESTIFF 14): K0 has rank 1 on
    the three degrees of freedom, so two of the load multipliers of K0 + mu G are zero (frame
    lean and steer resist nothing but through the load). Computed they came out as -3e-15
    and -7e-15 (+ with another BLAS would make one of them the 'critical' multiplier); they
    are certified zero (|v^T K0 v| within its round-off) and stored as 0. The third one is
    -k cof_33(G)/det(G) of the reduced pencil: finite, positive, the critical one."""
    with h5py.File(_run(DECK, tmp_path / "b.h5", "--mode", "10")) as f:
        mu, kind = f["buckling/load_multiplier"][-1], f["buckling/kind"][-1]
        critical = f["buckling/critical_load_multiplier"][-1]
    assert kind.tolist()[:3] == [0, 0, 0] and set(kind.tolist()[3:]) == {4}
    assert mu[0] == 0.0 and mu[1] == 0.0
    assert mu[2] > 1.0 and critical == mu[2]
