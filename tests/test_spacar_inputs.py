"""SPACAR's dynamic input fields and initial state (issue 18, point 4), against closed forms:

- the 5-field ``INPUTX n c value velocity acceleration`` / ``INPUTE e k value velocity
  acceleration``: a hinge-driven wheel turns exactly as ``phi0 + w t + alpha t^2/2`` and its
  driving stress resultant is ``-I alpha``; a driven slider mass receives the work
  ``m ((v0 + a t)^2 - v0^2) / 2``;
- ``STARTDE e k rate``: a mass on a spring released with an initial elongation rate moves as
  ``v0/w sin(w t)``, and the other flexible modes start at rate zero;
- ``ESIG e s1...``: a pre-stressed string's transverse frequencies (the discrete closed form
  of its consistent-mass chain, and ``k/(2L) sqrt(T/rhoA)`` in the limit), its static
  deflection under a point load ``F L / (4 T)``, and the stress resultant ``T + EA e``.
"""
from __future__ import annotations

import numpy as np
import pytest

from spacarpy.deck import job_from_text, model_from_text
from spacarpy.deck.writer import model_to_deck
from spacarpy.errors import DeckError
from spacarpy.solvers.dynamics.transient import TransientOptions, solve_transient
from spacarpy.solvers.statics.static import solve_static

from helpers import slider_deck


def run_transient(text: str):
    job = job_from_text(text)
    return solve_transient(job.model, TransientOptions.from_settings(job.settings))


# ------------------------------------------------------------------ 5-field INPUTE: a wheel

WHEEL = """# a wheel: inertia Izz = 0.5 kg m^2 on orientation node 4, turned by hinge 2 about z
X 1 0 0 0
X 3 1 0 0
RBEAM 1 1 4 3 0 1 0
HINGE 2 2 4 0 0 1
FIX 1
FIX 2
INPUTE 2 1
END
HALT
XM 4 0.3 0 0 0.3 0 0.5
INPUTE 2 1 0.0 {w} {alpha}
TIMESTEP 0.5 {n}
RHOINF 0
MODE transient
END
END
"""


@pytest.mark.parametrize("w, alpha", [(20.0, 0.0), (20.0, 10.0)])
def test_inpute_five_fields_turn_a_wheel_at_its_rate_and_acceleration(w, alpha):
    """``INPUTE 2 1 0 w alpha``: the hinge angle is ``w t + alpha t^2/2`` at every step (a
    position-level constraint: to round-off), and the initial state already turns at w
    (kinetic energy I w^2 / 2 at t = 0, the rate consistent with the constraints)."""
    text = WHEEL.format(w=w, alpha=alpha, n=20).replace("TIMESTEP 0.5", "TIMESTEP 0.1")
    res = run_transient(text)
    t = np.array([s.time for s in res.steps])
    angle = np.array([s.deformation["HINGE"][0, 0] for s in res.steps])
    np.testing.assert_allclose(angle, w * t + 0.5 * alpha * t * t, rtol=0, atol=1e-12)
    assert res.steps[0].kinetic_energy == pytest.approx(0.5 * 0.5 * w * w, rel=1e-12)
    assert res.steps[0].v[res.problem.num.rot_idx[1]] == pytest.approx([0, 0, 0, w / 2])


@pytest.mark.slow
@pytest.mark.parametrize("w, alpha", [(20.0, 0.0), (20.0, 10.0)])
def test_inpute_driven_wheel_torque_is_minus_i_alpha(w, alpha):
    """The stress resultant of the driven hinge, the torque that holds the prescribed motion,
    is ``-I alpha`` (zero for the balanced wheel at constant rate). With the Euler parameters
    updated on the rotation group (docs/transient.md) a rotation at w t + alpha t^2/2 about a
    fixed axis is integrated exactly, so the torque is exact to round-off at 100 and at 200
    steps (3e-10 to 1e-9 N m measured; with the linear update it converged as h^2, 1.5e-2 N m
    of 5 N m at 200 steps). RHOINF 0 damps the multipliers' start-up oscillation."""
    inertia = 0.5
    errors = []
    for n in (100, 200):
        res = run_transient(WHEEL.format(w=w, alpha=alpha, n=n))
        t = np.array([s.time for s in res.steps])
        torque = np.array([s.stress["HINGE"][0, 0] for s in res.steps])
        late = t > 0.1                         # after the start-up of the multipliers
        errors.append(np.abs(torque[late] + inertia * alpha).max())
    scale = inertia * max(alpha, 1.0)
    assert max(errors) < 1e-7 * scale


# ------------------------------------------------------------------ 5-field INPUTX: a slider



def test_inputx_five_fields_move_a_slider_and_do_its_work():
    """x(t) = 1 + v0 t + a0 t^2/2 and v(t) = v0 + a0 t at every stored step (exact: they are
    prescribed), the kinetic energy m v(t)^2 / 2 and the work the prescribed motion does on
    the mass, m ((v0 + a0 t)^2 - v0^2) / 2 (the driving force m a0 times the distance)."""
    v0, a0, m = 0.5, -0.8, 2.0
    res = run_transient(slider_deck(v0, a0))
    num = res.problem.num
    ix = num.pos_idx[1, 0]
    t = np.array([s.time for s in res.steps])
    x = np.array([s.x[ix] for s in res.steps])
    v = np.array([s.v[ix] for s in res.steps])
    np.testing.assert_allclose(x, 1 + v0 * t + 0.5 * a0 * t * t, rtol=0, atol=1e-13)
    np.testing.assert_allclose(v, v0 + a0 * t, rtol=0, atol=1e-13)
    kinetic = np.array([s.kinetic_energy for s in res.steps])
    work = np.array([s.external_work for s in res.steps])
    np.testing.assert_allclose(kinetic, 0.5 * m * (v0 + a0 * t) ** 2, rtol=1e-12)
    np.testing.assert_allclose(work, 0.5 * m * ((v0 + a0 * t) ** 2 - v0 ** 2), rtol=0,
                               atol=1e-10)


def test_five_field_inputs_are_read_and_written_back():
    model = model_from_text(slider_deck(0.5, -0.8))
    (p,) = model.prescribed
    assert (p.initial, p.velocity, p.acceleration) == (1.0, 0.5, -0.8)
    again = model_from_text(model_to_deck(model))
    assert again.prescribed[0] == p.__class__(**{**p.__dict__, "loc": again.prescribed[0].loc})
    wheel = model_from_text(WHEEL.format(w=20, alpha=3, n=10))
    (d,) = wheel.prescribed_deformations
    assert (d.initial, d.velocity, d.acceleration) == (0.0, 20.0, 3.0)
    # the 3-field form is unchanged: no rate
    three = model_from_text(slider_deck(0, 0).replace("1.0 0 0\n", "1.0\n"))
    assert (three.prescribed[0].velocity, three.prescribed[0].acceleration) == (0.0, 0.0)


def test_inputx_with_four_fields_gives_the_velocity_only():
    model = model_from_text(slider_deck(0.5, 0).replace("0.5 0\n", "0.5\n"))
    assert (model.prescribed[0].velocity, model.prescribed[0].acceleration) == (0.5, 0.0)


# ------------------------------------------------------------------ STARTDE

SPRINGS = """# fixed node 1, spring 1 to the mass on node 3, spring 2 to the mass on node 5, along x
X 1 0 0 0
X 3 1 0 0
X 5 2 0 0
TRUSS 1 1 3
TRUSS 2 3 5
DYNE 1 1
DYNE 2 1
FIX 1
FIX 3 2 3
FIX 5 2 3
END
HALT
ESTIFF 1 {k1}
ESTIFF 2 {k2}
XM 3 {m1}
XM 5 {m2}
STARTDE 1 1 {rate}
TIMESTEP 1.0 200
RHOINF 1
MODE transient
END
END
"""


def test_startde_releases_a_mass_on_a_spring_at_its_rate():
    """One spring (k = EA/l = 39.48 N/m) and one 1 kg mass, ``STARTDE 1 1 v0``: x(t) - 1 =
    v0/w sin(w t) with w = sqrt(k/m) = 2 pi (the trapezoidal rule's phase error at 200 steps
    per period is (w h)^2/12 = 8e-5 of a radian per radian: 5e-4 after one period)."""
    w, v0 = 2 * np.pi, 1e-3
    text = SPRINGS.format(k1=w * w, k2=1.0, m1=1.0, m2=1.0, rate=v0)
    # the second spring and mass removed: a single oscillator
    lines = [ln for ln in text.splitlines()
             if not any(ln.startswith(s) for s in ("X 5", "TRUSS 2", "DYNE 2", "FIX 5",
                                                    "ESTIFF 2", "XM 5"))]
    res = run_transient("\n".join(lines))
    ix = res.problem.num.pos_idx[1, 0]
    t = np.array([s.time for s in res.steps])
    u = np.array([s.x[ix] for s in res.steps]) - 1.0
    amplitude = v0 / w
    np.testing.assert_allclose(u, amplitude * np.sin(w * t), rtol=0, atol=1e-3 * amplitude)
    assert res.steps[0].v[ix] == pytest.approx(v0, rel=1e-12)


def test_startde_gives_the_other_flexible_modes_rate_zero():
    """SPACAR's reading: STARTDE sets the rate of one flexible (DYNE) mode, every other
    flexible mode starts at rate zero. ``STARTDE 1 1 v0`` on the first of two springs in
    series moves both masses at v0 (the second spring keeps its length); the motion is then
    the two-mass chain's modal solution (eigenvectors of K, M: a closed form)."""
    k1, k2, m1, m2, v0 = 30.0, 20.0, 1.0, 0.5, 1e-3
    res = run_transient(SPRINGS.format(k1=k1, k2=k2, m1=m1, m2=m2, rate=v0))
    num = res.problem.num
    i3, i5 = num.pos_idx[1, 0], num.pos_idx[2, 0]
    assert res.steps[0].v[i3] == pytest.approx(v0, rel=1e-12)
    assert res.steps[0].v[i5] == pytest.approx(v0, rel=1e-12)
    K = np.array([[k1 + k2, -k2], [-k2, k2]])
    M = np.diag([m1, m2])
    lam, phi = np.linalg.eigh(np.linalg.solve(np.sqrt(M), np.linalg.solve(np.sqrt(M), K).T))
    w = np.sqrt(lam)
    q0dot = phi.T @ (np.sqrt(M) @ np.array([v0, v0]))
    t = np.array([s.time for s in res.steps])
    exact = np.linalg.solve(np.sqrt(M), phi @ (q0dot[:, None] / w[:, None]
                                              * np.sin(w[:, None] * t)))
    u = np.array([[s.x[i3] - 1.0, s.x[i5] - 2.0] for s in res.steps]).T
    np.testing.assert_allclose(u, exact, rtol=0, atol=1e-3 * np.abs(exact).max())


@pytest.mark.parametrize("line, message", [
    ("STARTDE 1 2 0.1", "TRUSS with deformation mode 1 only, got 2"),
    ("STARTDE 9 1 0.1", "element 9 is not defined"),
    ("STARTDE 1 1 0.1\nSTARTDE 1 1 0.2", "given twice"),
])
def test_startde_errors(line, message):
    text = SPRINGS.format(k1=1, k2=1, m1=1, m2=1, rate=0).replace("STARTDE 1 1 0\n",
                                                                  line + "\n")
    with pytest.raises(DeckError, match=message):
        model_from_text(text)


def test_startde_on_a_rigid_mode_is_refused():
    text = SPRINGS.format(k1=1, k2=1, m1=1, m2=1, rate=0.1).replace("DYNE 1 1\n", "")
    text = text.replace("ESTIFF 1 1\n", "")
    with pytest.raises(DeckError, match="STARTDE: mode 1 of element 1 is rigid"):
        model_from_text(text)


# ------------------------------------------------------------------ ESIG

def string_deck(n, L=2.0, T=50.0, rhoA=0.1, EA=1e5, extra=""):
    """A string of n TRUSS elements along x between two fixed ends, tension T by ESIG."""
    lines = [f"X {2 * i + 1} {L * i / n} 0 0" for i in range(n + 1)]
    lines += [f"TRUSS {i + 1} {2 * i + 1} {2 * i + 3}" for i in range(n)]
    lines += [f"DYNE 1:{n} 1", "FIX 1", f"FIX {2 * n + 1}"]
    lines += [f"FIX {2 * i + 1} 3" for i in range(1, n)]
    lines += ["END", "HALT", f"ESTIFF 1:{n} {EA}", f"EM 1:{n} {rhoA}", f"ESIG 1:{n} {T}",
              extra, "END", "END"]
    return "\n".join(lines)


def test_esig_pre_stressed_string_has_the_string_frequencies():
    """The transverse frequencies of a string of tension T (ESIG) between fixed ends: n
    equal TRUSS elements (consistent mass, geometric stiffness T/h) have exactly
    ``w_k^2 = 6 T / (rhoA h^2) (1 - cos th) / (2 + cos th)``, th = k pi / n; with n = 40 the
    lowest approach the string's ``f_k = k / (2 L) sqrt(T / rhoA)`` (to (k pi/n)^2/24). The
    transverse modes deform no element to first order: they are elastic, not rigid-body."""
    import tempfile
    from pathlib import Path

    from spacarpy.results import open_results
    from spacarpy.run import run_job
    n, L, T, rhoA = 40, 2.0, 50.0, 0.1
    job = job_from_text(string_deck(n, L, T, rhoA, extra="MODE eigen\nMODES 6"))
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "string.h5"
        run_job(job, out)
        with open_results(out) as res:
            f = np.asarray(res.eigen.frequency)[-1]
            kinds = np.asarray(res.eigen.kind)[-1]
    h = L / n
    k = np.arange(1, 7)
    th = k * np.pi / n
    discrete = np.sqrt(6 * T / (rhoA * h * h) * (1 - np.cos(th)) / (2 + np.cos(th))) / (2 * np.pi)
    np.testing.assert_allclose(f, discrete, rtol=1e-9)
    continuous = k / (2 * L) * np.sqrt(T / rhoA)
    np.testing.assert_allclose(f, continuous, rtol=1.2 * (th ** 2 / 24).max())
    assert not np.allclose(f, continuous, rtol=1e-4)      # the mesh error is resolved
    assert (kinds == 0).all()                              # elastic


def test_esig_string_deflects_under_a_point_load_by_fl_over_4t():
    """A point load F at the middle of a string of tension T: the deflection is F L / (4 T)
    (small: the stretch adds EA 2 (d/L)^2 = 2e-6 of T), and each element's stress resultant
    is T + (EA / l0) e."""
    n, L, T, EA = 4, 2.0, 50.0, 1e4
    delta = 1e-4 * L
    F = 4 * T * delta / L
    extra = f"DELXF 5 0 {F} 0\nITERSTEP 20 2 1e-12"
    job = job_from_text(string_deck(n, L, T, EA=EA, extra=extra))
    res = solve_static(job.model, job.settings)
    y = res.steps[-1].x[res.problem.num.pos_idx[2, 1]]
    assert y == pytest.approx(delta, rel=1e-5)
    last = res.steps[-1]
    np.testing.assert_allclose(last.stress["TRUSS"][:, 0],
                               T + EA / (L / n) * last.deformation["TRUSS"][:, 0], rtol=1e-12)
    assert last.stress["TRUSS"][0, 0] > T                  # stretched by the deflection


def test_esig_without_load_leaves_the_string_in_equilibrium_and_stores_t():
    job = job_from_text(string_deck(3))
    res = solve_static(job.model, job.settings)
    np.testing.assert_allclose(res.steps[-1].x, res.problem.num.x0, atol=0)
    np.testing.assert_allclose(res.steps[-1].stress["TRUSS"][:, 0], 50.0, rtol=0)


def test_esig_is_read_checked_and_written_back():
    model = model_from_text(string_deck(3))
    assert model.element_prestress == {1: (50.0,), 2: (50.0,), 3: (50.0,)}
    assert model_from_text(model_to_deck(model)).element_prestress == model.element_prestress
    with pytest.raises(DeckError, match="so 1 to 1 initial stress resultants, got 2"):
        model_from_text(string_deck(3).replace("ESIG 1:3 50.0", "ESIG 1 50 2"))
    with pytest.raises(DeckError, match="mode 1 is rigid"):
        model_from_text(string_deck(3).replace("DYNE 1:3 1", "DYNE 2:3 1"))
    with pytest.raises(DeckError, match="ESIG for element 2 is given twice"):
        model_from_text(string_deck(3).replace("ESIG 1:3 50.0", "ESIG 1:3 50.0\nESIG 2 1"))
