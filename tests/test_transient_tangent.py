"""The exact iteration matrix of the transient solver (issue 21, point 1).

References: central finite differences. The inertia tangent of every kind with mass (BEAM with
lumped and consistent rotary inertia, RBEAM, TRUSS, PLBEAM, XM point masses and rotary
inertias) against small-step differences of the assembled inertia forces (Euler parameters
off the unit sphere, velocities with a radial part, so the projection onto the physical
velocities is covered); the assembled Newton matrix of the spin-up against differences of the
assembled residual along the generalized-alpha update (dx, gamma' dx, beta' dx); and the
residual history of a Newton step at steady spin, whose order of convergence is estimated
from its last iterations above the round-off floor.
"""
from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
import scipy.sparse as sp

import spacarpy.solvers.dynamics.transient as transient
from spacarpy.deck import job_from_text, load, model_from_text
from spacarpy.numbering import number_model
from spacarpy.rotation import from_axis_angle
from spacarpy.solvers.dynamics.inertia import Inertia
from spacarpy.solvers.dynamics.transient import TransientOptions, TransientProblem, solve_transient

from helpers import MIXED_MASS_DECK

DECKS = Path(__file__).resolve().parents[1] / "decks"


PLANAR = """X 1 0 0
X 3 1 0.2
X 5 1.6 0.5
PLBEAM 1 1 2 3 4
PLBEAM 2 3 4 5 6
DYNE 1 1 2 3
FIX 1
FIX 2
END
HALT
ESTIFF 1 100 2 0
EM 1 2.0 0.05
EM 2 1.0 0.02
XM 5 0.3
END
END
"""


def _random_state(num, rng):
    """Positions near x0, Euler parameters of random rotations scaled off |q| = 1, random
    velocities (with radial Euler parts) and accelerations."""
    x = num.x0.copy()
    x[num.pos_idx] += 0.1 * rng.normal(size=num.pos_idx.shape)
    x[num.rot_idx] = 1.01 * from_axis_angle(rng.normal(size=(len(num.rot_idx), 3)),
                                            rng.normal(size=len(num.rot_idx)))
    return x, 3.0 * rng.normal(size=num.n_coord), rng.normal(size=num.n_coord)


@pytest.mark.parametrize("text", [MIXED_MASS_DECK, PLANAR], ids=["spatial", "planar"])
@pytest.mark.parametrize("rotary", ["lumped", "consistent"])
def test_inertia_tangent_matches_finite_differences(text, rotary):
    model = model_from_text(text)
    num = number_model(model)
    inertia = Inertia(model, num, rotary=rotary)
    x, v, a = _random_state(num, np.random.default_rng(5))
    blocks, _ = inertia.forces(x, v, a)

    def assembled(gamma_p):
        tan = inertia.tangent(x, v, a, gamma_p)
        return inertia.assemble([np.zeros_like(m) if t is None else t
                                 for t, m in zip(tan, blocks)]).toarray()

    jx = assembled(0.0)
    jv = assembled(1.0) - jx
    n, eps = num.n_coord, 1e-6
    fx, fv = np.zeros((n, n)), np.zeros((n, n))
    for j in range(n):
        e = np.zeros(n)
        e[j] = eps
        fx[:, j] = (inertia.forces(x + e, v, a)[1] - inertia.forces(x - e, v, a)[1]) / (2 * eps)
        fv[:, j] = (inertia.forces(x, v + e, a)[1] - inertia.forces(x, v - e, a)[1]) / (2 * eps)
    assert np.abs(fx).max() > 1.0 and np.abs(fv).max() > 1.0      # not a vacuous check
    np.testing.assert_allclose(jx, fx, rtol=0, atol=1e-6 * np.abs(fx).max())
    np.testing.assert_allclose(jv, fv, rtol=0, atol=1e-6 * np.abs(fv).max())


def _newton_matrix(tp, t, x, v, a, mu, beta_p, gamma_p, exact):
    """The force rows (free coordinates) of the transient Newton matrix as _step assembles
    them."""
    res = tp.residual(t, x, v, a, mu)
    tan = tp.inertia.tangent(x, v, a, gamma_p) if exact else None
    extra, nodal = tp.inertia.iteration_parts(res.blocks, beta_p, tan)
    S = tp.prob.matrix(res.ev, mu, extra=extra, scale=1.0)
    n_x = tp.prob.pattern.n_x
    if nodal is not None:
        S = S + sp.block_diag([nodal, sp.csc_matrix((S.shape[0] - n_x,) * 2)], format="csc")
    return S[:n_x, :n_x].toarray()


def _spinup_state(seed: int, v_scale: float = 1.0):
    """The spin-up model at a random state at t = 16 s (positions 1 cm off the reference,
    velocities times ``v_scale``, the hub's prescribed motion): (tp, t, x, v, a, mu)."""
    job = load(DECKS / "spinup_beam.dat")
    tp = TransientProblem(job.model, TransientOptions.from_settings(job.settings))
    num = tp.num
    rng = np.random.default_rng(seed)
    x, v, a = _random_state(num, rng)
    x[num.pos_idx] = num.x0[num.pos_idx] + 0.01 * rng.normal(size=num.pos_idx.shape)
    v *= v_scale
    mu = rng.normal(size=num.n_constraint)
    t = 16.0
    idx, xp, vp, ap = tp.prescribed(t)
    x[idx], v[idx], a[idx] = xp, vp, ap
    return tp, t, x, v, a, mu


def _residual_differences(tp, t, x, v, a, mu, beta_p, gamma_p, W=None, eps=1e-6):
    """Central differences of the force residual over the free coordinates along a Newton
    correction d: (d, (gamma' + W) d, (beta' + 2 gamma' W + W^2) d), W the rotating frame's
    rate operator (None: the global frame)."""
    num, free = tp.num, tp.free
    n = int(free.sum())
    Wd = np.zeros((n, n)) if W is None else W.toarray()
    mv = gamma_p * np.eye(n) + Wd
    ma = beta_p * np.eye(n) + 2 * gamma_p * Wd + Wd @ Wd
    fd = np.zeros((n, n))
    for j in range(n):
        d = np.zeros(n)
        d[j] = eps
        e = [np.zeros(num.n_coord) for _ in range(3)]
        for k, vec in enumerate((d, mv @ d, ma @ d)):
            e[k][free] = vec
        rp = tp.residual(t, x + e[0], v + e[1], a + e[2], mu).r
        rm = tp.residual(t, x - e[0], v - e[1], a - e[2], mu).r
        fd[:, j] = (rp - rm) / (2 * eps)
    return fd


def test_transient_newton_matrix_matches_finite_differences():
    """The spin-up model at a random state: d r / d x along (dx, gamma' dx, beta' dx) with the
    inertia tangent is the assembled matrix; without it (the former iteration matrix) it is
    not."""
    tp, t, x, v, a, mu = _spinup_state(1, v_scale=4.0 / 3.0)
    beta_p, gamma_p = 1600.0, 40.0
    fd = _residual_differences(tp, t, x, v, a, mu, beta_p, gamma_p)
    scale = np.abs(fd).max()
    exact = _newton_matrix(tp, t, x, v, a, mu, beta_p, gamma_p, True)
    former = _newton_matrix(tp, t, x, v, a, mu, beta_p, gamma_p, False)
    assert np.abs(exact - fd).max() < 1e-8 * scale
    assert np.abs(former - fd).max() > 1e-7 * scale


def _histories(text, t_end, n_steps, exact=True, frame=True):
    """Residual histories of every integration step of a spin-up deck text."""
    job = job_from_text(text, "spinup_beam.dat")
    opts = replace(TransientOptions.from_settings(job.settings), t_end=t_end,
                   n_steps=n_steps, exact_tangent=exact, rotating_frame=frame)
    hist, cur = [], []
    residual, step = TransientProblem.residual, transient._step

    def recording_residual(self, *args, **kw):
        r = residual(self, *args, **kw)
        cur.append(r.res)
        return r

    def recording_step(*args, **kw):
        cur.clear()
        out = step(*args, **kw)
        hist.append((args[1] + args[2], list(cur)))
        return out

    mp = pytest.MonkeyPatch()
    mp.setattr(TransientProblem, "residual", recording_residual)
    mp.setattr(transient, "_step", recording_step)
    try:
        solve_transient(job.model, opts)
    finally:
        mp.undo()
    return hist


@pytest.mark.slow
def test_newton_converges_quadratically_at_steady_spin():
    """decks/spinup_beam.dat with 4 elements and a final rate of 10 rad/s (the convective
    terms then weigh in the Newton matrix): after the spin-up (t > 15 s) every step converges
    quadratically: the order estimate log(r_3/r_2)/log(r_2/r_1) of the first three Newton
    residuals is at least 1.8 (the predictor's residual r_0 is not a Newton iterate and is
    left out; r_3 at the round-off floor on another machine could only raise the estimate).
    Exact matrix: 2.5; the former one (without the inertia tangent): 1.6, and it needs a
    fifth iteration. In the global frame: the steps in the rotating frame (the default,
    solvers/dynamics/frame.py) start so close to the solution that the third residual is at the
    round-off floor and gives no order (its Newton matrix is checked against differences
    in tests/test_frame.py)."""
    text = (DECKS / "spinup_beam.dat").read_text()
    text = text.replace("SET n 10", "SET n 4").replace("DELINPR 2 4 ", "DELINPR 2 10 ")
    text = text.replace("MODE transient", "MODE transient\nRHOINF 0.5")  # global frame
    hist = _histories(text, 16.0, 80, frame=False)
    steady = [h for t, h in hist if t > 15.2]
    assert len(steady) >= 10
    for h in steady:
        r = h[1:4]
        assert len(r) == 3 and r[-1] > 0, h
        order = np.log(r[2] / r[1]) / np.log(r[1] / r[0])
        assert order >= 1.8, h


# ------------------------------------------------------------------ messages (issue 21, point 2)
def test_a_failed_transient_names_the_time_steps_kept_and_the_time_reached(
        tmp_path, capsys, monkeypatch):
    """A transient whose step 31 fails: the error and the log say how many time steps the
    partial file holds and the time they reach (not "0 static steps"), and the file agrees."""
    import h5py

    from spacarpy.cli import main
    from spacarpy.solvers.statics.errors import StepFailed

    step, calls = transient._step, []

    def failing_step(*args, **kw):
        calls.append(args[1])
        if len(calls) > 30:
            raise StepFailed("no convergence (forced by the test)", [1.0])
        return step(*args, **kw)

    monkeypatch.setattr(transient, "_step", failing_step)
    deck = tmp_path / "c.dat"
    deck.write_text((DECKS / "cantilever_free_vibration.dat").read_text()
                    .replace("START static\n", ""))
    assert main(["run", str(deck), "-o", str(tmp_path / "c.h5")]) == 1
    err = capsys.readouterr().err
    with h5py.File(tmp_path / "c.partial.h5") as f:
        t = f["transient/time"][()]
    assert len(t) == 31 and t[-1] == pytest.approx(calls[-1])
    assert f"run not completed; 31 time steps (to t = {t[-1]:.6g} s) kept in" in err
    assert "static steps" not in err
    assert f"the 31 time steps stored before it (to t = {t[-1]:.6g} s) are kept" in err
