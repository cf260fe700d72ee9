"""The Lie-group update of the Euler parameters (spacarpy/solvers/dynamics/lie.py,
docs/transient.md "Rotations on their group"): its exponential map, tangent operator and
rate derivatives against differences; a rigid body spinning about a fixed axis integrated
exactly, a torque-free precessing body at second order."""
from __future__ import annotations

import dataclasses

import h5py
import numpy as np
import pytest
from scipy.integrate import solve_ivp

from spacarpy.cli import main
from spacarpy.rotation import rotation_matrix
from spacarpy.solvers.dynamics.lie import (
    LieNodes,
    LieStep,
    exp_q,
    log_q,
    qmul,
    tangent_operator,
)
from spacarpy.solvers.dynamics.transient_records import TransientOptions, alpha_parameters


def test_exponential_map_and_tangent_operator():
    """exp and log invert each other (small and large angles, the series branches), and
    ``exp(theta + d) = exp(theta) exp(T(theta) d)`` to second order in d."""
    rng = np.random.default_rng(3)
    for scale in (1e-9, 1e-5, 1e-2, 1.0, 3.0):
        th = rng.normal(size=(5, 3))
        th *= scale / np.linalg.norm(th, axis=1, keepdims=True)
        np.testing.assert_allclose(log_q(exp_q(th)), th, rtol=1e-12, atol=1e-22)
        q = exp_q(th)
        assert np.abs((q * q).sum(axis=1) - 1).max() < 1e-15
        d = rng.normal(size=(5, 3)) * 1e-6
        step = np.einsum("nij,nj->ni", tangent_operator(th), d)
        got = log_q(qmul(exp_q(th), exp_q(step)))
        assert np.abs(got - th - d).max() < 1e-11


class _Num:
    def __init__(self, n):
        self.euler_coords = np.arange(4 * n).reshape(n, 4)
        self.planar_mask = np.zeros(0, bool)
        self.n_coord = 4 * n


@pytest.mark.parametrize("rho", [1.0, 0.6])
@pytest.mark.parametrize("left", [True, False])
def test_rate_derivatives_against_differences(rho, left):
    """The iteration matrix's rate derivatives (``gamma' I + E_v``, ``beta' I + E_a``)
    equal central differences of the update's rates along tangent increments (the map
    x1 -> (v1, a1) of a Newton iteration), relative 1e-8."""
    rng = np.random.default_rng(7)
    n = 3
    nodes = LieNodes.of(_Num(n), np.ones(4 * n, bool))
    q = rng.normal(size=(n, 4))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    w, dw, at = (rng.normal(size=(n, 3)) * s for s in (5.0, 20.0, 20.0))
    pure = [np.c_[np.zeros(n), u] for u in (w, dw, at)]
    v, a, a_t = (0.5 * qmul(p, q).ravel() for p in pure)         # spatial axes
    step = LieStep(nodes, q.ravel(), v, a, a_t, alpha_parameters(rho), 0.02,
                   left=np.full(n, left))
    x1, v1, a1 = q.ravel().copy(), v.copy(), a.copy()
    step.predict(x1, v1, a1)
    d0 = rng.normal(size=(n, 4)) * 0.01
    qp = x1.reshape(n, 4)                                         # (the predicted q1)
    d0 -= (d0 * qp).sum(axis=1, keepdims=True) * qp               # (tangent at it)
    step.update(x1, v1, a1, d0.ravel())
    E_v, E_a = (m.toarray() for m in step.jacobians())
    saved = (step.at1.copy(), step.length.copy(), step.radial.copy())
    for _ in range(3):
        dx = rng.normal(size=(n, 4))
        q1 = x1.reshape(n, 4)
        dx = (dx - (dx * q1).sum(axis=1, keepdims=True) * q1).ravel()
        out = []
        for s in (1e-6, -1e-6):
            xs, vs, as_ = x1.copy(), v1.copy(), a1.copy()
            step.update(xs, vs, as_, s * dx)
            step.at1, step.length, step.radial = (u.copy() for u in saved)
            step._evaluate(x1, v1, a1)
            out.append((vs, as_))
        fv = (out[0][0] - out[1][0]) / 2e-6
        fa = (out[0][1] - out[1][1]) / 2e-6
        assert np.abs(fv - step.gamma_p * dx - E_v @ dx).max() < 1e-8 * np.abs(fv).max()
        assert np.abs(fa - step.beta_p * dx - E_a @ dx).max() < 1e-8 * np.abs(fa).max()


_GIMBAL = """# a rigid body on a gimbal (heading z, lean x, spin y), no gravity
HINGE 1 9 10 0 0 1
HINGE 2 10 11 1 0 0
HINGE 3 11 12 0 1 0
FIX 9
DYNE 1 1
DYNE 2 1
DYNE 3 1
END
HALT
XM 12 0.3 0 0 0.5 0 0.4
STARTDE 1 1 {r[0]}
STARTDE 2 1 {r[1]}
STARTDE 3 1 {r[2]}
MODE 1
RHOINF 1
TIMESTEP 1 {n}
END
END
"""
_J = np.diag([0.3, 0.5, 0.4])


def _gimbal(tmp_path, monkeypatch, n, rates, lie=True):
    if not lie:
        orig = TransientOptions.from_settings.__func__
        monkeypatch.setattr(TransientOptions, "from_settings", classmethod(
            lambda cls, s: dataclasses.replace(orig(cls, s), lie_group=False)))
    deck = tmp_path / f"g{n}{lie}.dat"
    deck.write_text(_GIMBAL.format(r=rates, n=n))
    out = deck.with_suffix(".h5")
    assert main(["run", str(deck), "-o", str(out), "-q"]) == 0
    monkeypatch.undo()
    with h5py.File(out) as f:
        ids = list(f["model/orientation_nodes"][()])
        return (f["transient/time"][()], f["transient/elements/HINGE/deformation"][()][:, :, 0],
                f["transient/euler"][()][:, ids.index(12)])


def test_a_constant_spin_is_integrated_exactly(tmp_path, monkeypatch):
    """A body spinning at 10 rad/s about a principal axis, 40 steps a second (1/4 rad a
    step): its spin angle is 10 t to the Newton tolerance, where the linear update of the
    Euler parameters lags by 0.013 rad after one second (``(w h)^2/48`` of the angle)."""
    t, ang, _ = _gimbal(tmp_path, monkeypatch, 40, (0, 0, 10))
    assert np.abs(ang[:, 2] - 10 * t).max() < 1e-8
    assert np.abs(ang[:, :2]).max() < 1e-12
    t, ang, _ = _gimbal(tmp_path, monkeypatch, 40, (0, 0, 10), lie=False)
    assert 1e-2 < np.abs(ang[:, 2] - 10 * t).max() < 2e-2


def _angle(q, q_ref):
    c = (np.trace(rotation_matrix(q).T @ rotation_matrix(q_ref)) - 1) / 2
    return float(np.arccos(min(1.0, c)))


def test_a_precessing_body_converges_at_second_order(tmp_path, monkeypatch):
    """A torque-free asymmetric body (inertia 0.3, 0.5, 0.4 kg m^2) started turning at
    (0.5, 10, 1) rad/s: the orientation after 1 s against solve_ivp's (1e-13), at 50 and
    100 steps: second order (ratio 4 within 3 %; measured 4.00), and a tenth of the
    linear update's error at most (measured 2.55e-4 and 6.39e-5 rad, linear 8.73e-3 and
    2.19e-3: the angular velocity turns slowly in body axes, which the update follows)."""
    rates = (1.0, 0.5, 10.0)
    w0 = np.array([rates[1], rates[2], rates[0]])
    L, Ji = _J @ w0, np.linalg.inv(_J)

    def f(_, q):
        R = rotation_matrix(q)
        w = R @ Ji @ R.T @ L
        return 0.5 * np.r_[-w @ q[1:], q[0] * w + np.cross(w, q[1:])]
    exact = solve_ivp(f, (0, 1), [1, 0, 0, 0], rtol=1e-13, atol=1e-14, method="DOP853").y[:, -1]
    err = [_angle(_gimbal(tmp_path, monkeypatch, n, rates)[2][-1], exact) for n in (50, 100)]
    assert 0.97 * 4 < err[0] / err[1] < 1.03 * 4
    old = _angle(_gimbal(tmp_path, monkeypatch, 100, rates, lie=False)[2][-1], exact)
    assert err[1] < 0.1 * old


def _gimbal_result(n, rates, extra=""):
    """The gimbal deck through the Python API (the step counts are not in the file):
    (result, spin-hinge angles (n + 1,), Euler parameters of the body at the end)."""
    from spacarpy.deck import job_from_text
    from spacarpy.solvers.dynamics.transient import solve_transient
    text = _GIMBAL.format(r=rates, n=n).replace("RHOINF 1", "RHOINF 1\n" + extra)
    job = job_from_text(text, "gimbal.dat")
    res = solve_transient(job.model, TransientOptions.from_settings(job.settings))
    num = res.problem.num
    q = res.steps[-1].x[num.rot_idx[list(job.model.orientation_ids).index(12)]]
    return res, q


def _precession_exact(rates, t_end=1.0):
    """The torque-free body's Euler parameters at t_end (solve_ivp, 1e-13)."""
    w0 = np.array([rates[1], rates[2], rates[0]])
    L, Ji = _J @ w0, np.linalg.inv(_J)

    def f(_, q):
        R = rotation_matrix(q)
        w = R @ Ji @ R.T @ L
        return 0.5 * np.r_[-w @ q[1:], q[0] * w + np.cross(w, q[1:])]
    return solve_ivp(f, (0, t_end), [1, 0, 0, 0], rtol=1e-13, atol=1e-14,
                     method="DOP853").y[:, -1]


def test_error_control_measures_a_rotation_by_its_angle():
    """ERROR on the rotation group: the local error of a rotation is ``h^2 |beta - 1/6|``
    times the change of the update's angular pseudo-acceleration (rad), not of the four
    Euler parameters'. A body spinning at 10 rad/s about a principal axis with ``ERROR
    1e-6 0`` takes exactly the 40 steps of the run without ERROR, none rejected, and
    ends where it does (before, ``-|w|^2/4 q`` turning with q read as an error of up to
    8.8e3 times the tolerance: 217 steps, 64 rejected). A precessing body (a real error)
    with the same tolerance still cuts its steps (measured 120 steps, 40 rejected; 222 and
    50 before), and its orientation error at 1 s falls below the 40 fixed steps' by a
    factor 5 at least (measured 5.4e-5 against 4.0e-4 rad)."""
    spin = (0, 0, 10)
    fixed, q_fixed = _gimbal_result(40, spin)
    adapted, q_adapted = _gimbal_result(40, spin, "ERROR 1e-6 0")
    assert fixed.n_steps_taken == adapted.n_steps_taken == 40
    assert adapted.n_rejected == 0
    np.testing.assert_allclose(q_adapted, q_fixed, rtol=0, atol=1e-12)
    rates = (1.0, 0.5, 10.0)
    exact = _precession_exact(rates)
    fixed, q_fixed = _gimbal_result(40, rates)
    adapted, q_adapted = _gimbal_result(40, rates, "ERROR 1e-6 0")
    assert adapted.n_steps_taken > 2 * 40 and fixed.n_steps_taken == 40
    assert _angle(q_adapted, exact) < 0.2 * _angle(q_fixed, exact)


def test_a_step_turning_more_than_half_a_turn_is_cut(caplog):
    """A step may turn a node by pi at most (lie.MAX_TURN): the body spinning at 10 rad/s
    at two steps a second (5 rad a step) has its steps halved, with the reason in the log,
    and its spin angle is 10 t at every stored step (before, its orientations ended nearer
    the other way round and the hinge lost a turn: 10 - 2 pi rad at 1 s)."""
    import logging
    with caplog.at_level(logging.INFO, logger="spacarpy"):
        res, _ = _gimbal_result(2, (0, 0, 10))
    assert "the step turns an orientation node by 5 rad, more than pi" in caplog.text
    assert res.n_steps_taken >= 4
    t = np.array([s.time for s in res.steps])
    ang = np.array([s.deformation["HINGE"][2, 0] for s in res.steps])
    assert np.abs(ang - 10 * t).max() < 1e-8
