"""Issue 21, fast rotation: the spin-up of decks/spinup_beam.dat (Simo & Vu-Quoc) is
stable at every numerical dissipation, and a free spinning beam keeps its energy and
angular momentum at RHOINF 1, because each step is taken in a frame turning with the
model (spacarpy/solvers/dynamics/frame.py). In the global frame the same runs fail
(docs/transient.md, "Fast rotation")."""
from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from spacarpy.deck import job_from_text
from spacarpy.errors import ConvergenceError
from spacarpy.solvers.dynamics.transient import TransientOptions, solve_transient

DECKS = Path(__file__).resolve().parents[1] / "decks"


def spin_up(rho_inf: float, h: float, n_el: int = 10, t_end: float = 30.0, rate: float = 4.0,
            **options):
    """The shipped spin-up at RHOINF rho_inf with integration steps h (and a final rate in
    rad/s), every step stored: (times, tip lag in the hub's frame, iterations per step,
    result)."""
    text = (DECKS / "spinup_beam.dat").read_text().replace("SET n 10", f"SET n {n_el}")
    text = text.replace("DELINPR 2 4 ", f"DELINPR 2 {rate} ")
    text = text.replace("MODE transient", f"MODE transient\nRHOINF {rho_inf}")
    job = job_from_text(text, "spinup_beam.dat")
    opts = replace(TransientOptions.from_settings(job.settings), t_end=t_end,
                   n_steps=int(round(t_end / h)), substeps=1, **options)
    result = solve_transient(job.model, opts)
    num = result.problem.num
    pos = list(job.model.position_ids)
    rot = list(job.model.orientation_ids)
    t = np.array([s.time for s in result.steps])
    tip = np.array([s.x[num.pos_idx[pos.index(3)]] for s in result.steps])
    hub = np.array([s.x[num.rot_idx[rot.index(2)]] for s in result.steps])
    theta = np.unwrap(2 * np.arctan2(hub[:, 3], hub[:, 0]))
    lag = -np.sin(theta) * tip[:, 0] + np.cos(theta) * tip[:, 1]
    its = np.array([s.iterations for s in result.steps])
    return t, lag, its, result


@pytest.mark.slow
@pytest.mark.parametrize("h", [0.05, 0.1])
@pytest.mark.parametrize("rho_inf", [0.5, 0.8, 0.9, 1.0])
def test_the_spin_up_runs_to_30_s_at_every_rho_inf(rho_inf, h):
    """To t = 30 s at RHOINF 0.5, 0.8, 0.9 and 1 with h = 0.05 s and 0.1 s (the issue's
    matrix): at most 4 Newton iterations per step on average at constant speed (t > 16 s;
    measured 2.00 in every case, 2.44-2.71 over the whole run), the tip's lag within 1 %
    of the reference run's peak (RHOINF 0.9,
    h = 0.025 s: -0.4002 m at t = 6.94 s; h = 0.0125 s: -0.4002 m) and a steady
    oscillation below 1 cm after t = 20 s, and the energy balance T + U - W (the hub's
    work by the trapezoidal rule) within 0.4 h^2/s^2 of the kinetic energy (3.2e3 J at
    4 rad/s) at every step: second order, measured 2.6 J at h = 0.05 s and 9.5-9.8 J at
    h = 0.1 s."""
    t, lag, its, result = spin_up(rho_inf, h)
    assert t[-1] == pytest.approx(30.0)
    assert its[t > 16].mean() <= 4.0
    k = int(np.argmin(lag))
    assert lag[k] == pytest.approx(-0.4002, rel=0.01)
    assert 6.5 < t[k] < 7.5
    assert np.abs(lag[t > 20]).max() < 0.01
    balance = np.array([s.energy_balance for s in result.steps])
    kinetic = result.steps[-1].kinetic_energy
    assert kinetic == pytest.approx(0.5 * 1.2 * 10**3 / 3 * 16, rel=0.01)
    assert np.abs(balance).max() < 0.4 * h**2 * kinetic


@pytest.mark.slow
@pytest.mark.parametrize("rho_inf", [0.9, 1.0])
def test_the_spin_up_to_6_rad_s_runs_to_30_s(rho_inf):
    """The final rate of 6 rad/s that later papers use, h = 0.1 s (0.6 rad per step): to
    t = 30 s; Newton iterations per step at constant speed 2.59 (RHOINF 0.9 and 1; asked:
    at most 4.5); the lag after the spin-up below 2 cm (measured 4.7 mm; the peak is
    -0.575 m at t = 6.8 s); T + U - W within 1 % of the kinetic energy
    (7.2e3 J; measured 49 J, the trapezoidal work at 0.6 rad per step)."""
    t, lag, its, result = spin_up(rho_inf, 0.1, rate=6.0)
    assert t[-1] == pytest.approx(30.0)
    assert its[t > 16].mean() <= 4.5
    assert np.abs(lag[t > 20]).max() < 0.02
    kinetic = result.steps[-1].kinetic_energy
    assert kinetic == pytest.approx(0.5 * 1.2 * 10**3 / 3 * 36, rel=0.01)
    balance = np.array([s.energy_balance for s in result.steps])
    assert np.abs(balance).max() < 0.01 * kinetic


@pytest.mark.slow
def test_the_global_frame_fails_where_the_turning_frame_holds():
    """The former scheme (every step in the global frame) on the same run, RHOINF 0.9 and
    h = 0.1 s: the discrete solution turns unstable soon after the spin-up (it failed at
    t = 15.4 s in the measurements of docs/transient.md), which the turning frame removes
    (the test above)."""
    with pytest.raises(ConvergenceError):
        spin_up(0.9, 0.1, rotating_frame=False)


def free_spinning_beam(n_el: int, h: float, revolutions: float, rate: float = 4.0):
    """A free beam (the spin-up's section, L = 10 m, no supports) spinning about z at
    ``rate`` through its centre, with a small in-plane and flapwise velocity on top (a
    tilt about y: the motion is a spin with a slow precession), ``RHOINF 1``. Returns the
    times, T + U and the angular momentum (3,) about the origin at every stored step."""
    from spacarpy.solvers.dynamics.frame import RotatingFrame
    from spacarpy.solvers.dynamics.inertia import Inertia

    length = 10.0
    xs = np.linspace(-length / 2, length / 2, n_el + 1)
    lines = ["MODE transient", "RHOINF 1"]
    lines += [f"X {2 * i + 1} {float(x)!r} 0 0" for i, x in enumerate(xs)]
    lines += [f"BEAM {e + 1} {2 * e + 1} {2 * e + 2} {2 * e + 3} {2 * e + 4} 0 1 0"
              for e in range(n_el)]
    lines += [f"DYNE 1:{n_el} 1 2 3 4 5 6", "END", "HALT",
              f"ESTIFF 1:{n_el} 2.8e7 1.4e4 1.4e4 1.4e4", f"EM 1:{n_el} 1.2 1.2e-3 6e-4 6e-4 0"]
    for i, x in enumerate(xs):
        vy = rate * x + 0.2 * np.cos(np.pi * x / length)
        vz = 0.3 * np.sin(np.pi * x / length)
        lines += [f"VELOCITY {2 * i + 1} 0 {float(vy)!r} {float(vz)!r}",
                  f"VELOCITY {2 * i + 2} 0 0 {rate}"]
    t_end = revolutions * 2 * np.pi / rate
    lines += [f"TIMESTEP {float(t_end)!r} {int(round(t_end / h))}", "END", "END", ""]
    job = job_from_text("\n".join(lines), "free_spin.dat")
    result = solve_transient(job.model, TransientOptions.from_settings(job.settings))
    num = result.problem.num
    inertia = Inertia(job.model, num)
    # Noether's momentum of the rotations: H . e = p . (d/ds of the state turned by s e)
    turn = RotatingFrame(pos=num.pos_idx, rot=num.rot_idx, planar=False, n_coord=num.n_coord)
    t, energy, momentum = [], [], []
    for s in result.steps:
        p = inertia.matrix(s.x) @ inertia.physical(s.x, s.v)
        t.append(s.time)
        energy.append(s.kinetic_energy + s.elastic_energy)
        momentum.append([p @ turn.apply_w(e, s.x) for e in np.eye(3)])
    return np.array(t), np.array(energy), np.array(momentum)


@pytest.mark.slow
def test_a_free_spinning_beam_keeps_its_energy_and_angular_momentum():
    """RHOINF 1, no damping, 4 elements, h = 0.02 s (0.08 rad per step), 5 revolutions of
    a free beam spinning at 4 rad/s with a slow precession: T + U drifts by less than 2e-5
    of itself per revolution and stays within 2e-4 of its start (measured: 2.6e-6 per
    revolution and 1.4e-5 at most over 5 revolutions; the frame is on from the first step,
    the model turning at t = 0); the angular momentum stays within 3e-4 of its start
    (measured 8.6e-5). In the global frame the same run
    fails after 1.6 revolutions (the instability of docs/transient.md, "Fast rotation")."""
    t, energy, momentum = free_spinning_beam(4, 0.02, 5.0)
    assert t[-1] == pytest.approx(5 * 2 * np.pi / 4)
    assert energy[0] == pytest.approx(800.3, rel=1e-3)          # 1/2 I w^2 + the wobble
    assert abs(energy[-1] - energy[0]) / energy[0] / 5 < 2e-5
    assert np.abs(energy - energy[0]).max() < 2e-4 * energy[0]
    h0 = momentum[0]
    assert h0[2] == pytest.approx(1.2 * 10**3 / 12 * 4 + 6e-4 * 10 * 4, rel=1e-3)
    assert np.abs(momentum - h0).max() < 3e-4 * np.linalg.norm(h0)
