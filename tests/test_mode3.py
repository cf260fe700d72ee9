"""SPACAR mode 3 (analysis ``transient_linearized``): the linearized equations at every
stored time step of a transient (spacarpy.solvers.dynamics.trajectory).

(a) A rigid rod (uniform, m = 2 kg, L = 1 m) on a free hinge, released from the horizontal
under gravity: with phi the hinge angle from the horizontal, I phi'' + m g (L/2) cos phi = 0,
I = m L^2 / 3, so along the swing the linearized equations are M0 = m L^2 / 3, C0 = 0 and
K0 = -m g (L/2) sin phi(t) (m g L/2 hanging straight down). This holds only with the terms
of the moving state: the rod's tension (the multipliers consistent with the stored
acceleration) in K_x and the second time derivative Phi'' of the degree-of-freedom map;
with the integrator's own multipliers K0 was 2 % off at t = 0.1 s. (c) At rest the matrices
are mode 9's of the same deck (with Rayleigh damping, so C0 is checked too).
"""
from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from spacarpy.cli import main
from spacarpy.deck import job_from_text
from spacarpy.errors import EXIT_INPUT
from spacarpy.results import open_results, validate_file
from spacarpy.run import run_model

DECKS = Path(__file__).resolve().parents[1] / "decks"
NAMES = ("M0", "C0", "K0", "B0", "A", "B", "C", "D")
M, L, G = 2.0, 1.0, 9.81


@pytest.fixture(scope="module")
def pendulum(tmp_path_factory):
    text = (DECKS / "pendulum_rigid_90deg.dat").read_text()
    text = text.replace("MODE transient", "MODE 3").replace("TIMESTEP 2.2 440",
                                                            "TIMESTEP 0.6 60")
    out = tmp_path_factory.mktemp("p3") / "p3.h5"
    job = job_from_text(text, "p3.dat")
    run_model(job.model, job.settings, out)
    return out


def test_pendulum_along_the_swing(pendulum):
    assert validate_file(pendulum, require_complete=True) == []
    with open_results(pendulum) as res:
        assert res.analysis == "transient_linearized"
        ss = res.state_space
        assert ss.state_name == ["HINGE 10 mode 1", "rate of HINGE 10 mode 1"]
    import h5py
    with h5py.File(pendulum) as f:
        t = f["transient/time"][()]
        phi = f["transient/elements/HINGE/deformation"][:, 0, 0]
        step = f["state_space/step"][()]
        time = f["state_space/time"][()]
        M0, C0, K0 = (f[f"state_space/{n}"][:, 0, 0] for n in ("M0", "C0", "K0"))
        A = f["state_space/A"][()]
    assert step.tolist() == list(range(61))
    np.testing.assert_array_equal(time, t)
    assert phi.min() < -1.5                      # swung past 85 degrees below the horizontal
    np.testing.assert_allclose(M0, M * L**2 / 3, rtol=1e-9)
    scale = M * G * L / 2
    np.testing.assert_allclose(K0, -scale * np.sin(phi), rtol=0, atol=1e-6 * scale)
    np.testing.assert_allclose(C0, 0.0, atol=1e-6 * np.sqrt(scale * M * L**2 / 3))
    np.testing.assert_allclose(A[:, 1, 0], -K0 / M0, rtol=1e-12)


GYRO = """MODE 3
RHOINF 1
HINGE 10 2 4 1 0 0
HINGE 20 4 6 0 1 0
HINGE 30 6 8 0 0 1
RLSE 10 1
RLSE 20 1
INPUTE 30 1
FIX 2
END
HALT
XM 8 {jt} 0 0 {jt} 0 {jp}
INPUTE 30 1 0.0 {omega} 0.0
TIMESTEP 0.1 4
END
END
"""


def test_spinning_disc_gyroscopic_damping(tmp_path):
    """(b) A symmetric disc (J_t = 0.3, J_p = 0.5 kg m^2) in a Cardan suspension: tilt hinges
    about x (alpha) and then y (beta), free; the spin hinge about the disc's axis driven at
    Omega = 7 rad/s. T = J_t (alpha'^2 cos^2 beta + beta'^2)/2 + J_p (gamma' + alpha' sin
    beta)^2/2 gives, about alpha = beta = 0, M0 = J_t I, K0 = 0 and the gyroscopic
    C0 = J_p Omega [[0, 1], [-1, 0]]. The linearization uses the velocities projected on the
    constraints' velocity form, whose spin rate is the prescribed Omega; the stored spin rate
    is Omega too now that the Euler parameters are updated on the rotation group (with the
    linear update it was 2e-3 off)."""
    jt, jp, omega = 0.3, 0.5, 7.0
    job = job_from_text(GYRO.format(jt=jt, jp=jp, omega=omega), "gyro.dat")
    out = tmp_path / "gyro.h5"
    run_model(job.model, job.settings, out)
    assert validate_file(out, require_complete=True) == []
    import h5py
    with h5py.File(out) as f:
        q, qd = f["transient/euler"][:, -1], f["transient/euler_rate"][:, -1]
        M0, C0, K0 = (f[f"state_space/{n}"][()] for n in ("M0", "C0", "K0"))
        names = [s.decode() for s in f["state_space/state_name"][()]]
    assert names[:2] == ["HINGE 10 mode 1", "HINGE 20 mode 1"]
    w = 2 * (q[:, 0] * qd[:, 3] - q[:, 3] * qd[:, 0])        # spin rate about z
    np.testing.assert_allclose(w, omega, rtol=1e-12)
    skew = np.array([[0.0, 1.0], [-1.0, 0.0]])
    np.testing.assert_allclose(M0, np.broadcast_to(jt * np.eye(2), M0.shape), rtol=0,
                               atol=1e-9 * jt)
    np.testing.assert_allclose(C0, np.broadcast_to(jp * omega * skew, C0.shape), rtol=0,
                               atol=1e-7 * jp * omega)
    np.testing.assert_allclose(K0, 0.0, atol=1e-7 * jp * omega**2)


def _rest_deck():
    text = (DECKS / "state_space_cantilever.dat").read_text()
    text = re.sub(r"^DELXF .*$", "", text, flags=re.M)
    text = text.replace("SET ALPHA 0 ", "SET ALPHA 0.5 ").replace("SET BETA 0\n",
                                                                  "SET BETA 1e-5\n")
    return text.replace("ITERSTEP 20 2 1e-10", "ITERSTEP 20 2 1e-10\nTIMESTEP 0.001 2")


def test_at_rest_mode_3_is_mode_9(tmp_path):
    text = _rest_deck()
    job = job_from_text(text, "rest.dat")
    assert job.model.damping == (0.5, 1e-5)
    out3, out9 = tmp_path / "m3.h5", tmp_path / "m9.h5"
    run_model(job.model, job.settings.override(analysis="3"), out3)
    run_model(job.model, job.settings.override(analysis="9"), out9)
    assert validate_file(out3, require_complete=True) == []
    with open_results(out3) as r3, open_results(out9) as r9:
        assert r3.state_space.step.tolist() == [0, 1, 2]
        assert r3.state_space.output_name == r9.state_space.output_name
        for k in (0, 2):
            for name in NAMES:
                a, b = r3.state_space.matrix(name, k), r9.state_space.matrix(name, 0)
                scale = max(np.abs(b).max(initial=0.0), 1e-300)
                np.testing.assert_allclose(a, b, rtol=0, atol=1e-7 * scale,
                                           err_msg=f"{name} at time step {k}")
        assert np.abs(r9.state_space.matrix("C0", 0)).max() > 0


def test_mode_3_needs_mass_and_a_time_span(tmp_path, capsys):
    text = re.sub(r"^EM .*$", "", _rest_deck(), flags=re.M)
    deck = tmp_path / "nomass.dat"
    deck.write_text(text)
    assert main(["run", str(deck), "-o", str(tmp_path / "x.h5"), "--mode", "3"]) == EXIT_INPUT
    err = capsys.readouterr().err
    assert "needs mass" in err and "Traceback" not in err


PLANAR_PENDULUM = """MODE 3
X 1 0 0
X 3 1 0
PLBEAM 1 1 4 3 6
PLHINGE 10 2 4
RLSE 10 1
FIX 1
FIX 2
END
HALT
EM 1 2
GRAVITY 0 -9.81 0
TIMESTEP 0.6 60
END
END
"""


def test_planar_pendulum_along_the_swing(tmp_path):
    """(a) as a planar model: a flexible PLBEAM (rigid, its modes not released) with the
    consistent Hermite mass, whose end tangents depend on the angle coordinates. Its
    velocities from the integrator violate the rod's length constraint by O(h^2) (1e-3 of
    the tip speed at h = 0.01 s); Phi' taken along them read that as stretching and gave
    C0 = 1.7e-3 (7e-4 of sqrt(K0 M0)) where the exact value is 0. With the velocities
    projected on the constraints, C0 is 0 to the difference quotients' error."""
    job = job_from_text(PLANAR_PENDULUM, "plp.dat")
    out = tmp_path / "plp.h5"
    run_model(job.model, job.settings, out)
    import h5py
    with h5py.File(out) as f:
        phi = f["transient/elements/PLHINGE/deformation"][:, 0, 0]
        M0, C0, K0 = (f[f"state_space/{n}"][:, 0, 0] for n in ("M0", "C0", "K0"))
    assert phi.min() < -2.0
    scale = M * G * L / 2
    np.testing.assert_allclose(M0, M * L**2 / 3, rtol=1e-9)
    np.testing.assert_allclose(K0, -scale * np.sin(phi), rtol=0, atol=1e-6 * scale)
    np.testing.assert_allclose(C0, 0.0, atol=1e-7 * np.sqrt(scale * M * L**2 / 3))


def test_show_export_and_reader_along_the_trajectory(pendulum, tmp_path, capsys):
    import scipy.io

    from spacarpy.results import read_results
    assert main(["show", str(pendulum)]) == 0
    assert "State space (SPACAR mode 3, along the transient) at 61 time steps" in \
        capsys.readouterr().out
    mat = tmp_path / "p.mat"
    assert main(["export", str(pendulum), "--state-space", str(mat), "--step", "30"]) == 0
    m = scipy.io.loadmat(mat)
    with open_results(pendulum) as res:
        ss = res.state_space
        assert ss.time[30] == pytest.approx(0.3, abs=1e-12)
        np.testing.assert_array_equal(m["K0"], ss.matrix("K0", 30))
        assert np.isnan(ss.load_factor).all()
    assert float(m["time"][0, 0]) == pytest.approx(0.3, abs=1e-12) and m["step"][0, 0] == 30
    full = read_results(pendulum).state_space
    assert full.K0.shape == (61, 1, 1)
    np.testing.assert_array_equal(full.K0[30], m["K0"])


def test_the_run_says_how_many_time_steps_it_linearized(tmp_path, capsys):
    """`spacarpy run` of a mode-3 deck ends with the stored time steps it linearized (it said
    "0 steps": the static counter)."""
    deck = tmp_path / "plp.dat"
    deck.write_text(PLANAR_PENDULUM.replace("TIMESTEP 0.6 60", "TIMESTEP 0.1 10"))
    assert main(["run", str(deck), "-o", str(tmp_path / "plp.h5")]) == 0
    err = capsys.readouterr().err
    assert re.search(r"finished transient_linearized analysis \(linearized at every stored "
                     r"time step\): 11 stored time steps, 10 integration steps", err), err
