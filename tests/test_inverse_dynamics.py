"""Inverse dynamics (SPACAR mode 2, analysis ``inverse_dynamics``): the input forces of a fully
prescribed motion against closed forms.

- a rigid pendulum driven at a constant rate (5-field INPUTE): tau = m g l sin(theta), and
  with an angular acceleration tau = I_p alpha + m g l sin(theta), the pivot force m (a_c - g),
  over two revolutions (the hinge's turn count), to 1e-10 of m g l;
- the same pendulum driven by a coordinate (INPUTX on the tip's x with TIMEFUNCTION sine):
  the force that coordinate needs from the torque balance about the pivot; and by a
  rotation (INPUTR): the moment it needs;
- the two-link arm of decks/two_link_arm_inverse.dat: the joint torques equal Lagrange's
  equations (written out below) to 1e-8, the base force the rate of the momentum minus
  the weight, the tip's acceleration and the kinetic energy the closed forms;
- the same arm in mode 1 with those torques as moment loads retraces the trajectory, with
  the error falling as h^2;
- the planar four-bar (PLBEAM, PLHINGE) driven at a constant crank rate: the input power
  equals the rate of the kinetic energy;
- a model its inputs do not determine (a released or flexible joint) is refused naming the
  degree of freedom; TIMESTEP is required; an interrupted run keeps its steps.
"""
from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import h5py
import numpy as np
import pytest

from spacarpy.cli import main
from spacarpy.deck import job_from_text, load
from spacarpy.errors import EXIT_INPUT, EXIT_MODEL, ModelError
from spacarpy.run import RunOptions, run_job
from spacarpy.settings import resolve_analysis, spacar_mode_refusal
from spacarpy.solvers.dynamics import transient as transient_module
from spacarpy.solvers.dynamics.inverse import solve_inverse
from spacarpy.solvers.dynamics.transient import TransientOptions, solve_transient

ARM = Path(__file__).resolve().parents[1] / "decks" / "two_link_arm_inverse.dat"
G = 9.81
M_ROD, L_ROD = 2.0, 1.0                 # the pendulum: a uniform rod of 2 kg, 1 m

PENDULUM = """MODE 2
X 1 0 0 0
X 3 0 -{L} 0               # hanging down from the pivot
RBEAM 1 1 4 3 1 0 0
HINGE 10 2 4 0 0 1
{joint}
FIX 1
FIX 2
END
HALT
EM 1 {rhoA}
{data}
GRAVITY 0 -{g} 0
TIMESTEP {t_end} {n}
END
END
"""


def pendulum(joint="INPUTE 10 1", data="", t_end=5.0, n=50):
    text = PENDULUM.format(L=L_ROD, rhoA=M_ROD / L_ROD, g=G, joint=joint, data=data,
                           t_end=t_end, n=n)
    return job_from_text(text, "pendulum.dat")


def run(job, tmp_path, name="x"):
    out = tmp_path / f"{name}.h5"
    run_job(job, out)
    return h5py.File(out, "r")


# -- the driven pendulum ---------------------------------------------------------------------

@pytest.mark.parametrize("theta0, omega, alpha", [(0.0, 3.0, 0.0), (0.3, 1.0, 2.0)])
def test_pendulum_torque_and_pivot_force(tmp_path, theta0, omega, alpha):
    """tau = I_p alpha + m g l sin(theta) (alpha = 0: m g l sin(theta)) and the pivot force
    m (a_c - g) over two revolutions and more, to 1e-10 of m g l."""
    job = pendulum(data=f"INPUTE 10 1 {theta0} {omega} {alpha}")
    with run(job, tmp_path) as f:
        t = f["transient/time"][:]
        theta = f["transient/elements/HINGE/deformation"][:, 0, 0]
        tau = -f["transient/elements/HINGE/stress_resultant"][:, 0, 0]
        names = [c.decode() for c in f["static/reaction_component"][:]]
        nodes = f["static/reaction_node"][:]
        reaction = f["transient/reaction"][:]
        assert f.attrs["analysis"] == "inverse_dynamics" and f.attrs["completed"]
    th = theta0 + omega * t + 0.5 * alpha * t * t
    w = omega + alpha * t
    assert th[-1] > 4 * np.pi                       # two turns and more
    # the hinge angle counts the turns (the stored deformation is continuous)
    assert np.allclose(theta, th, rtol=0, atol=1e-12)
    m, l_c = M_ROD, L_ROD / 2
    exact = m * L_ROD**2 / 3 * alpha + m * G * l_c * np.sin(th)
    assert np.abs(tau - exact).max() <= 1e-10 * m * G * l_c
    # the pivot's force on the rod: m a_c - m g, a_c of the centre l (sin, -cos)
    a_c = l_c * np.c_[alpha * np.cos(th) - w * w * np.sin(th),
                      alpha * np.sin(th) + w * w * np.cos(th)]
    fx = reaction[:, names.index("Fx")]
    fy = reaction[:, names.index("Fy")]
    assert nodes[names.index("Fx")] == 1
    assert np.abs(fx - m * a_c[:, 0]).max() <= 1e-10 * m * G
    assert np.abs(fy - (m * a_c[:, 1] + m * G)).max() <= 1e-10 * m * G


def test_pendulum_driven_by_a_coordinate(tmp_path):
    """INPUTX on the tip's x, x(t) = 0.5 sin(pi t) (TIMEFUNCTION sine): the force the
    coordinate needs balances the torque about the pivot, F L cos(theta) = I_p theta'' +
    m g l sin(theta), with theta = asin(x / L) and its exact derivatives."""
    job = pendulum(joint="RLSE 10 1\nINPUTX 3 1",
                   data="INPUTX 3 1 0.0\nDELINPX 3 1 0.5\nTIMEFUNCTION sine 0.5", t_end=2.0,
                   n=16)
    with run(job, tmp_path) as f:
        t = f["transient/time"][:]
        names = [c.decode() for c in f["static/reaction_component"][:]]
        nodes = list(f["static/reaction_node"][:])
        col = next(i for i, (n, c) in enumerate(zip(nodes, names)) if n == 3 and c == "Fx")
        force = f["transient/reaction"][:, col]
        accel = f["transient/acceleration"][:, 1, :]            # the tip (node 3)
    L, m, l_c = L_ROD, M_ROD, L_ROD / 2
    x = 0.5 * np.sin(np.pi * t)
    xd = 0.5 * np.pi * np.cos(np.pi * t)
    xdd = -0.5 * np.pi**2 * np.sin(np.pi * t)
    th = np.arcsin(x / L)
    thd = xd / (L * np.cos(th))
    thdd = (xdd + L * np.sin(th) * thd**2) / (L * np.cos(th))
    exact = (m * L**2 / 3 * thdd + m * G * l_c * np.sin(th)) / (L * np.cos(th))
    assert np.abs(force - exact).max() <= 1e-10 * m * G
    # the tip's stored acceleration: (x'', d2/dt2 of -L cos(theta))
    ydd = L * (np.cos(th) * thd**2 + np.sin(th) * thdd)
    assert np.abs(accel[:, 0] - xdd).max() <= 1e-12
    assert np.abs(accel[:, 1] - ydd).max() <= 1e-10


# -- the two-link arm ------------------------------------------------------------------------

M1, L1, M2, L2 = 2.0, 1.0, 1.2, 0.8      # decks/two_link_arm_inverse.dat
T_SMOOTH = 1.25


def arm_trajectory(t):
    """theta, theta', theta'' (2, n) of the deck's prescribed joint angles."""
    s = t / T_SMOOTH
    phi, dphi, ddphi = 3 * s**2 - 2 * s**3, (6 * s - 6 * s**2) / T_SMOOTH, \
        (6 - 12 * s) / T_SMOOTH**2
    th = np.array([1.2 * phi + 0.25 * t * t, -0.9 * phi - 0.15 * t * t])
    w = np.array([1.2 * dphi + 0.5 * t, -0.9 * dphi - 0.3 * t])
    al = np.array([1.2 * ddphi + 0.5 + 0 * t, -0.9 * ddphi - 0.3 + 0 * t])
    return th, w, al


def lagrange_torques(th, w, al):
    """The joint torques of Lagrange's equations for two uniform rods (mass m_i, length
    L_i, centre at L_i/2, I_i = m_i L_i^2/12) on revolute joints about z, gravity -y;
    theta_1 absolute from x, theta_2 relative to link 1."""
    l1, l2 = L1 / 2, L2 / 2
    I1, I2 = M1 * L1**2 / 12, M2 * L2**2 / 12
    c2, s2 = np.cos(th[1]), np.sin(th[1])
    m11 = I1 + I2 + M1 * l1**2 + M2 * (L1**2 + l2**2 + 2 * L1 * l2 * c2)
    m12 = I2 + M2 * (l2**2 + L1 * l2 * c2)
    m22 = I2 + M2 * l2**2
    h = M2 * L1 * l2 * s2
    g1 = (M1 * l1 + M2 * L1) * G * np.cos(th[0]) + M2 * l2 * G * np.cos(th[0] + th[1])
    g2 = M2 * l2 * G * np.cos(th[0] + th[1])
    tau1 = m11 * al[0] + m12 * al[1] - h * (2 * w[0] * w[1] + w[1]**2) + g1
    tau2 = m12 * al[0] + m22 * al[1] + h * w[0]**2 + g2
    kinetic = 0.5 * (m11 * w[0]**2 + 2 * m12 * w[0] * w[1] + m22 * w[1]**2)
    return np.array([tau1, tau2]), kinetic


def centre_accelerations(th, w, al):
    """(2 links, n, 2) accelerations of the rods' centres, and the tip's (n, 2)."""
    def point(lengths):          # sum of lengths along the absolute angles
        acc = 0.0
        for ln, (a, b, c) in zip(lengths, ((th[0], w[0], al[0]),
                                           (th[0] + th[1], w[0] + w[1], al[0] + al[1]))):
            acc = acc + ln * np.c_[-c * np.sin(a) - b * b * np.cos(a),
                                   c * np.cos(a) - b * b * np.sin(a)]
        return acc
    return np.array([point([L1 / 2, 0.0]), point([L1, L2 / 2])]), point([L1, L2])


@pytest.fixture(scope="module")
def arm_file(tmp_path_factory):
    out = tmp_path_factory.mktemp("arm") / "arm.h5"
    run_job(load(ARM), out)
    with h5py.File(out, "r") as f:
        yield {name: f[f"transient/{name}"][:] for name in (
            "time", "elements/HINGE/deformation", "elements/HINGE/stress_resultant",
            "reaction", "acceleration", "kinetic_energy", "external_work", "residual")} | {
            "components": [c.decode() for c in f["static/reaction_component"][:]],
            "nodes": list(f["static/reaction_node"][:])}


def test_arm_torques_are_lagranges(arm_file):
    t = arm_file["time"]
    th, w, al = arm_trajectory(t)
    assert np.abs(arm_file["elements/HINGE/deformation"][:, :, 0].T - th).max() < 1e-12
    tau, kinetic = lagrange_torques(th, w, al)
    got = -arm_file["elements/HINGE/stress_resultant"][:, :, 0].T
    for i in range(2):
        assert np.abs(got[i] - tau[i]).max() <= 1e-8 * np.abs(tau[i]).max(), i
    assert np.abs(arm_file["kinetic_energy"] - kinetic).max() <= 1e-10 * kinetic.max()
    assert arm_file["residual"].max() < 1e-12


def test_arm_base_force_and_tip_acceleration(arm_file):
    """The base's force is the rate of the momentum minus the weight, its moment the
    shoulder torque; the stored tip acceleration is the closed form's."""
    t = arm_file["time"]
    th, w, al = arm_trajectory(t)
    a_c, a_tip = centre_accelerations(th, w, al)
    comp, nodes, reac = arm_file["components"], arm_file["nodes"], arm_file["reaction"]
    fx, fy = reac[:, comp.index("Fx")], reac[:, comp.index("Fy")]
    assert np.abs(fx - (M1 * a_c[0, :, 0] + M2 * a_c[1, :, 0])).max() < 1e-10
    assert np.abs(fy - (M1 * a_c[0, :, 1] + M2 * a_c[1, :, 1] + (M1 + M2) * G)).max() < 1e-10
    mz = reac[:, comp.index("Mz")]
    assert nodes[comp.index("Mz")] == 2
    tau, _ = lagrange_torques(th, w, al)
    assert np.abs(mz - tau[0]).max() < 1e-10
    assert np.abs(arm_file["acceleration"][:, 2, :2] - a_tip).max() < 1e-10


def test_arm_energy_balance(arm_file):
    """The work of gravity and the prescribed motions, summed as mode 1 sums it
    (trapezoidal rule over the stored steps), is the kinetic energy gained: T - W stays
    zero to the rule's O(h^2) (a sign error in either work would leave twice the
    potential energy, 20 J)."""
    balance = arm_file["kinetic_energy"] - arm_file["external_work"]
    err = np.abs(balance).max()
    assert 0 < err < 2e-3 * arm_file["kinetic_energy"].max()


LOADS = transient_module.TransientProblem.loads


def forward_arm(monkeypatch, n_steps: int):
    """The arm in mode 1 with its joints free and Lagrange's torques as moment loads
    (tau_1 - tau_2 on link 1, tau_2 on link 2, through the Python API): the hinge angles
    at the stored times."""
    text = (ARM.read_text().replace("MODE 2", "MODE transient")
            .replace("INPUTE 10 1 0.0 0.0 0.5", "DELXF 4 0 0 1")
            .replace("INPUTE 11 1 0.0 0.0 -0.3", "DELXF 6 0 0 1")
            .replace("INPUTE 10 1 ", "RLSE 10 1 ").replace("INPUTE 11 1 ", "RLSE 11 1 ")
            .replace("DELINPE 10 1 1.2", "").replace("DELINPE 11 1 -0.9", "")
            .replace("\nTIMEFUNCTION smoothstep 1.25", "\nTIMEFUNCTION zero\nRHOINF 1")
            .replace("TIMESTEP 1.0 20", f"TIMESTEP 1.0 {n_steps}"))
    job = job_from_text(text, "arm_forward.dat")
    loads = LOADS                                           # (not the patched one)

    def with_torques(self, t):
        load = loads(self, t)
        tau, _ = lagrange_torques(*arm_trajectory(np.array([t])))
        moment = np.zeros_like(load.moment)
        moment[:, 2] = [tau[0, 0] - tau[1, 0], tau[1, 0]]    # nodes 4 and 6
        return replace(load, moment=load.moment + moment)

    monkeypatch.setattr(transient_module.TransientProblem, "loads", with_torques)
    res = solve_transient(job.model, TransientOptions.from_settings(job.settings))
    t = np.array([s.time for s in res.steps])
    theta = np.array([s.deformation["HINGE"][:, 0] for s in res.steps]).T
    return np.abs(theta - arm_trajectory(t)[0]).max()


def test_mode_1_with_the_torques_retraces_the_trajectory(monkeypatch):
    """Mode 1 driven by the torques of mode 2 follows the prescribed angles to the
    integrator's error, which falls as h^2 (generalized-alpha, RHOINF 1)."""
    coarse, fine = forward_arm(monkeypatch, 50), forward_arm(monkeypatch, 100)
    assert fine < 5e-4                                     # measured 2.2e-4 rad
    order = np.log2(coarse / fine)
    assert 1.8 < order < 2.6, (coarse, fine, order)      # measured 2.2


# -- refusals and the run's life cycle -------------------------------------------------------

def test_mode_number_2_is_inverse_dynamics():
    assert resolve_analysis(2) == resolve_analysis("-2") == "inverse_dynamics"
    assert spacar_mode_refusal(2) is None


def test_a_released_joint_is_refused_by_name():
    job = job_from_text(ARM.read_text().replace("INPUTE 11 1 0.0 0.0 -0.3", "")
                        .replace("INPUTE 11 1 ", "RLSE 11 1 ")
                        .replace("DELINPE 11 1 -0.9", ""), "arm.dat")
    with pytest.raises(ModelError) as info:
        solve_inverse(job.model, TransientOptions.from_settings(job.settings))
    text = str(info.value)
    assert "1 degree(s) of freedom remain" in text
    assert "motion 1 driven by HINGE 11 mode 1 (nodes that move: 5, 6)" in text
    assert "Prescribe them (INPUTX, INPUTE)" in text and "\n" not in text


def test_a_flexible_joint_is_a_degree_of_freedom(tmp_path, capsys):
    """A DYNE mode is a degree of freedom in SPACAR: mode 2 refuses it by name (exit 3)."""
    deck = tmp_path / "flex.dat"
    deck.write_text(PENDULUM.format(L=1, rhoA=2, g=G, joint="DYNE 10 1", data="ESTIFF 10 5",
                                    t_end=1, n=4))
    code = main(["run", str(deck), "-o", str(tmp_path / "flex.h5")])
    err = capsys.readouterr().err
    assert code == EXIT_MODEL
    assert "flexible (DYNE) modes are degrees of freedom: HINGE 10 mode 1" in err
    assert "Traceback" not in err
    assert not list(tmp_path.glob("flex*.h5"))          # refused before the result file


def test_redundant_inputs_are_refused():
    """An input on a coordinate that the other inputs fix already: its force is not unique."""
    job = pendulum(joint="INPUTE 10 1\nINPUTX 3 1", data="INPUTE 10 1 0 1 0")
    with pytest.raises(ModelError, match=r"redundant constraint\(s\), whose forces would "
                                         r"not be unique: HINGE 10 mode 1"):
        solve_inverse(job.model, TransientOptions.from_settings(job.settings))


def test_timestep_is_required(tmp_path, capsys):
    deck = tmp_path / "no_time.dat"
    deck.write_text(ARM.read_text().replace("TIMESTEP 1.0 20", ""))
    assert main(["run", str(deck), "-o", str(tmp_path / "x.h5")]) == EXIT_INPUT
    err = capsys.readouterr().err
    assert "MODE inverse_dynamics (SPACAR 2) needs the time span: TIMESTEP" in err


def test_an_interrupted_run_keeps_its_steps(tmp_path):
    """Ctrl-C after the 6th step: the partial file holds the 6 steps, marked incomplete."""
    seen = []

    def progress(t, t_end):
        seen.append(t)
        if len(seen) == 6:
            raise KeyboardInterrupt
    out = tmp_path / "arm.h5"
    with pytest.raises(KeyboardInterrupt):
        run_job(load(ARM), out, RunOptions(progress=progress))
    assert not out.exists()
    with h5py.File(tmp_path / "arm.partial.h5", "r") as f:
        assert not f.attrs["completed"]
        assert f["transient/time"].shape == (6,)
        assert f["transient/acceleration"].shape == (6, 3, 3)


def test_the_reader_gives_the_accelerations(tmp_path):
    from spacarpy.results import open_results
    from spacarpy.results.views import ResultsQueryError
    out = tmp_path / "arm.h5"
    run_job(load(ARM), out)
    tr = open_results(out).transient
    a_tip = centre_accelerations(*arm_trajectory(tr.time))[1]
    assert np.abs(tr.acceleration(5)[:, :2] - a_tip).max() < 1e-10
    assert tr.acceleration(step=3).shape == (3, 3)
    pend = tmp_path / "pendulum.h5"
    text = PENDULUM.format(L=1, rhoA=2, g=G, joint="RLSE 10 1", data="", t_end=0.02, n=2)
    job = job_from_text(text.replace("MODE 2", "MODE transient"), "p.dat")
    run_job(job, pend)
    with pytest.raises(ResultsQueryError, match="only inverse dynamics"):
        open_results(pend).transient.acceleration()


@pytest.mark.parametrize("theta0", [0.0, 1.0, 2.5])
def test_planar_four_bar_power_balance(tmp_path, theta0):
    """decks/planar_four_bar_driven.dat (PLBEAM, PLHINGE; the crank at 6 rad/s, a dead force
    of 1.5 N along x at C) in mode 2 from the crank angle theta0: the drive's power and the
    force's equal the rate of the kinetic energy, dT/dt = tau omega + P v_Cx, with dT/dt by
    a central difference over +-20 us (its error h^2 T'''/6, about 1.5e-8 of the power;
    over +-0.1 ms it was 3.5e-7, falling as h^2)."""
    deck = ARM.parent / "planar_four_bar_driven.dat"
    text = (deck.read_text().replace("MODE transient", "MODE 2")
            .replace("INPUTE 11 1 0.0 6.0 0", f"INPUTE 11 1 {theta0} 6.0 0")
            .replace("TIMESTEP 1.0 50", "TIMESTEP 4e-5 2").replace("SUBSTEPS 4", ""))
    with run(job_from_text(text, "fourbar.dat"), tmp_path) as f:
        kinetic = f["transient/kinetic_energy"][:]
        tau = -f["transient/elements/PLHINGE/stress_resultant"][1, 0, 0]
        v_c = f["transient/velocity"][1, 2, 0]                  # node 5 (C), x
        angle = f["transient/elements/PLHINGE/deformation"][:, 0, 0]
    assert np.allclose(angle, theta0 + 6.0 * np.array([0, 2e-5, 4e-5]), rtol=0, atol=1e-13)
    power = tau * 6.0 + 1.5 * v_c
    rate = (kinetic[2] - kinetic[0]) / 4e-5
    assert abs(rate - power) <= 1e-7 * (abs(tau * 6.0) + 1.5 * abs(v_c)), (rate, power)


def test_pendulum_driven_by_a_rotation(tmp_path):
    """INPUTR on the rod's orientation node (no hinge), theta(t) = sin(pi t) (DELINPR with
    TIMEFUNCTION sine 0.5): the moment the input needs, the node's reaction Mz, is
    I_p theta'' + m g l sin(theta) (the exact quaternion derivatives of INPUTR)."""
    text = (PENDULUM.format(L=L_ROD, rhoA=M_ROD / L_ROD, g=G, joint="INPUTR 4 0 0 1",
                            data="DELINPR 4 1.0\nTIMEFUNCTION sine 0.5", t_end=2.0, n=16)
            .replace("HINGE 10 2 4 0 0 1\n", "").replace("FIX 2\n", ""))
    with run(job_from_text(text, "rot.dat"), tmp_path) as f:
        t = f["transient/time"][:]
        names = [c.decode() for c in f["static/reaction_component"][:]]
        nodes = list(f["static/reaction_node"][:])
        col = next(i for i, (n, c) in enumerate(zip(nodes, names)) if n == 4 and c == "Mz")
        moment = f["transient/reaction"][:, col]
    th, thdd = np.sin(np.pi * t), -np.pi**2 * np.sin(np.pi * t)
    exact = M_ROD * L_ROD**2 / 3 * thdd + M_ROD * G * L_ROD / 2 * np.sin(th)
    assert np.abs(moment - exact).max() <= 1e-10 * M_ROD * G * L_ROD / 2
