"""Rolling wheels in statics and the linearizations at rest (rolling-contact spec, checks
B9, B10, B11 at rest, B1/B3 at v = 0, C6, C7; docs/rolling.md, "Statics and the
linearizations at rest").

Equilibrium for virtual displacements that satisfy the slips (Chetaev); the slips act on
first-order perturbations at rest like holonomic constraints. The references are the
published values of Meijaard et al. (2007), eqs (6.1)-(6.2) and Table 2(a), and the closed
forms of the spec's coin checks.
"""
import logging
from pathlib import Path

import h5py
import numpy as np
import pytest

from spacarpy.deck import job_from_text
from spacarpy.run import run_job

DECKS = Path(__file__).resolve().parent.parent / "decks"
BICYCLE = DECKS / "benchmark_bicycle_at_rest.dat"
BRAKED = DECKS / "rolling_disc_braked.dat"

# [S1] eqs (6.1), (6.2): M and K0 (the gravity part, times g) of the benchmark bicycle
M_REF = np.array([[80.81722, 2.31941332208709], [2.31941332208709, 0.29784188199686]])
K0_REF = np.array([[-80.95, -2.59951685249872], [-2.59951685249872, -0.80329488458618]])
G = 9.81


def run_text(text: str, path: Path) -> h5py.File:
    run_job(job_from_text(text), path)
    return h5py.File(path, "r")


def bicycle(mode: str) -> str:
    return BICYCLE.read_text().replace("MODE 7", f"MODE {mode}")


def rel(a, ref):
    return np.abs(np.asarray(a) - ref).max() / np.abs(ref).max()


# ---------------------------------------------------------------------------- the bicycle
def test_b9_the_bicycle_at_rest_has_two_unstable_modes(tmp_path):
    """Mode 7 at V = 0: lambda = 3.13164324790656 and 5.53094371765393 1/s (Table 2(a)),
    stored as negative "frequencies" -lambda/2pi of kind 2 (unstable)."""
    with run_text(bicycle(7), tmp_path / "b9.h5") as f:
        freq = f["eigen/frequency"][-1]
        kind = f["eigen/kind"][-1]
    assert kind.tolist() == [2, 2]
    ref = np.array([-0.498416502904687, -0.880277032627687])
    assert np.abs(freq / ref - 1).max() < 1e-10


def test_mode9_at_rest_gives_the_benchmark_m_and_k0_entry_by_entry(tmp_path):
    """M0 = M of eq. (6.1), K0 = g K0 of eq. (6.2), in the DOFs (lean, steer) with [S1]'s
    signs (B1/B3 at v = 0), 1e-12 relative to the largest entry; the kinematic coordinates
    follow the DOFs (the slips in the constraint Jacobian)."""
    with run_text(bicycle(9), tmp_path / "b9.h5") as f:
        ss = f["state_space"]
        M0, K0, C0 = ss["M0"][-1], ss["K0"][-1], ss["C0"][-1]
        assert ss["dof_element"][:].tolist() == [2, 8]
        assert ss["dof_mode"][:].tolist() == [1, 1]
    assert rel(M0, M_REF) < 1e-12
    assert rel(K0, G * K0_REF) < 1e-12
    assert np.abs(C0).max() == 0.0                  # at rest: no gyroscopic coupling


def test_b10_normal_forces_at_rest(tmp_path):
    """Static contact forces (WHEEL mode 6, compression positive) from the moment balance
    about P; no friction is needed at rest."""
    with run_text(bicycle("static"), tmp_path / "b10.h5") as f:
        ids = f["model/elements/WHEEL/ids"][:].tolist()
        sig = f["static/elements/WHEEL/stress_resultant"][-1]
    assert ids == [5, 12]
    n_ref = np.array([612.8364705882354, 309.3035294117647])
    assert np.abs(sig[:, 5] / n_ref - 1).max() < 1e-9
    assert np.abs(sig[:, 3:5]).max() < 1e-9
    # the holonomic modes carry the normal force through the contact node (spoke, mode 3)
    assert np.abs(sig[:, 2] / -n_ref - 1).max() < 1e-9


def _placed_bicycle(yaw: float, shift) -> str:
    """The benchmark deck with z up, yawed by ``yaw`` about z and moved by ``shift``: every
    point p -> R Q p + t, vector v -> R Q v, inertia J -> (R Q) J (R Q)^T, Q = diag(1, -1,
    -1)."""
    c, s = np.cos(yaw), np.sin(yaw)
    T = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]]) @ np.diag([1.0, -1.0, -1.0])
    t = np.array([shift[0], shift[1], 0.0])
    lam, rr, rf, w, tr = np.pi / 10, 0.3, 0.35, 1.02, 0.08
    points = {2: (0, 0, 0), 3: (0, 0, -rr), 4: (0.3, 0, -0.9),
              5: (w + tr - 0.9 * np.tan(lam), 0, -0.9), 6: (0.9, 0, -0.7), 7: (w, 0, -rf),
              8: (w, 0, 0)}

    def vec(v):
        return " ".join(f"{u:.17g}" for u in T @ np.asarray(v, float))

    def inertia(J):
        J = T @ np.asarray(J, float) @ T.T
        return " ".join(f"{u:.17g}" for u in (J[0, 0], J[0, 1], J[0, 2], J[1, 1], J[1, 2],
                                              J[2, 2]))
    lines = [f"X {n} " + " ".join(f"{u:.17g}" for u in T @ np.asarray(p, float) + t)
             for n, p in points.items()]
    lines += [f"HINGE 1 9 10 {vec((0, 0, 1))}", f"HINGE 2 10 11 {vec((1, 0, 0))}",
              f"HINGE 3 11 13 {vec((0, 1, 0))}", f"HINGE 4 13 12 {vec((0, 1, 0))}",
              f"WHEEL 5 3 12 2 {vec((0, 1, 0))}", "PINBODY 6 4 13 3", "PINBODY 7 4 13 5",
              f"HINGE 8 13 14 {vec((np.tan(lam), 0, 1))}", "PINBODY 9 5 14 6",
              "PINBODY 10 5 14 7", f"HINGE 11 14 15 {vec((0, 1, 0))}",
              f"WHEEL 12 7 15 8 {vec((0, 1, 0))}",
              "FIX 9", "RLSE 3 1", "DYNE 2 1", "DYNE 8 1", "INPUTE 4 1", "KINE 1 1",
              "KINE 11 1", "KINX 2 1", "KINX 2 2", "END", "HALT",
              "XM 3 2.0", f"XM 12 {inertia(np.diag([0.0603, 0.12, 0.0603]))}", "XM 4 85.0",
              f"XM 13 {inertia([[9.2, 0, 2.4], [0, 11, 0], [2.4, 0, 2.8]])}", "XM 6 4.0",
              f"XM 14 {inertia([[0.05892, 0, -0.00756], [0, 0.06, 0], [-0.00756, 0, 0.00708]])}",
              "XM 7 3.0", f"XM 15 {inertia(np.diag([0.1405, 0.28, 0.1405]))}",
              f"GRAVITY {vec((0, 0, G))}", "INPUTE 4 1 0 0 0", "MODE 9", "END", "END"]
    return "\n".join(lines) + "\n"


def test_b11_placement_z_up_yawed_and_moved_gives_the_same_matrices(tmp_path):
    """z up, yawed by 0.7 rad, moved by (12.3, -4.5) m: the same M0 and K0 (the hinge
    angles keep their physical sense), 1e-12 relative."""
    with run_text(_placed_bicycle(0.7, (12.3, -4.5)), tmp_path / "b11.h5") as f:
        M0, K0 = f["state_space/M0"][-1], f["state_space/K0"][-1]
    assert rel(M0, M_REF) < 1e-12
    assert rel(K0, G * K0_REF) < 1e-12


# ---------------------------------------------------------------------------- the coin
R, MASS, ALPHA = 0.3, 2.0, 0.1


def test_c6_braked_disc_on_a_slope(tmp_path):
    """Normal force m g cos(alpha), friction m g sin(alpha) uphill: stored as the ground's
    force on the wheel along the heading e_l = +x (downhill), so -m g sin(alpha); no lateral
    force (1e-9 relative)."""
    with run_text(BRAKED.read_text(), tmp_path / "c6.h5") as f:
        sig = f["static/elements/WHEEL/stress_resultant"][-1, 0]
    n_ref, t_ref = 19.521981722754866, 1.9587316346107686
    assert abs(MASS * G * np.cos(ALPHA) - n_ref) < 1e-12       # the spec's closed forms
    assert abs(MASS * G * np.sin(ALPHA) - t_ref) < 1e-12
    assert abs(sig[5] / n_ref - 1) < 1e-9
    assert abs(sig[3] / -t_ref - 1) < 1e-9
    assert abs(sig[4]) < 1e-9 * n_ref


def _rolling_turn(n_steps: int) -> str:
    """The coin upright, no gravity, spin prescribed over one turn (-2 pi about the axle +y,
    rolling towards -x) in ``n_steps`` load steps."""
    text = BRAKED.read_text()
    text = text.replace("KINX 2 1 ", "INPUTE 3 1\nKINX 2 1 ")
    text = text.replace("ITERSTEP 20 1 1e-12", f"ITERSTEP 20 {n_steps} 1e-12\n"
                        "DELINPE 3 1 {-2*pi}")
    return "\n".join(ln for ln in text.splitlines() if not ln.startswith("GRAVITY")) + "\n"


def test_c7_prescribed_spin_rolls_the_disc_along_its_heading(tmp_path):
    """Every Newton increment satisfies S dx = 0, so the disc rolls: the hub keeps its
    height and the contact point stays under it, both on the heading line, to 1e-10 m.
    The distance rolled over one turn is 2 pi r in the limit of small load steps: a
    static path of a non-holonomic system depends on its steps, and the error of N equal
    steps is r (2 pi)^3 / (12 N^2) to leading order (measured: N^2 times the error is
    6.1995 at N = 64, 6.2013 in the limit), docs/rolling.md."""
    err = {}
    for n in (32, 64):
        with run_text(_rolling_turn(n), tmp_path / f"c7_{n}.h5") as f:
            pos = f["static/position"][:]
            ids = f["model/position_nodes"][:].tolist()
        contact, hub = pos[:, ids.index(2)], pos[:, ids.index(3)]
        assert np.abs(hub[:, 2] - R).max() < 1e-10                   # hub height
        assert np.abs(contact[:, 2]).max() < 1e-10                   # on the ground
        assert np.abs(contact[:, :2] - hub[:, :2]).max() < 1e-10     # under the hub
        assert np.abs(pos[:, :, 1]).max() < 1e-10                    # no lateral motion
        x = -contact[:, 0]
        assert np.all(np.diff(x) > 0)                                # rolls forward (-x)
        err[n] = x[-1] - 2 * np.pi * R
    lead = R * (2 * np.pi) ** 3 / 12
    assert abs(err[64] * 64 ** 2 / lead - 1) < 2e-3
    assert abs(err[32] / err[64] - 4) < 0.02


def test_lift_off_is_warned_naming_the_wheel_and_the_step(tmp_path, caplog):
    """Gravity pulling the braked disc away from the ground: a negative normal force, a
    warning that names WHEEL 4 and the load step, stored with the results."""
    text = BRAKED.read_text().replace("GRAVITY {G*sin(AL)} 0 {-G*cos(AL)}",
                                      "GRAVITY 0 0 {G}")
    with caplog.at_level(logging.WARNING):
        with run_text(text, tmp_path / "lift.h5") as f:
            sig = f["static/elements/WHEEL/stress_resultant"][-1, 0]
            warnings = str(f.attrs.get("warnings", ""))
    assert sig[5] == pytest.approx(-MASS * G, rel=1e-12)
    assert "static step 0 (load factor 0): negative normal force (WHEEL mode 6) at WHEEL 4 " \
           "(-19.62 N): the wheel would lift off the ground" in caplog.text
    assert "WHEEL 4 (-19.62 N)" in warnings


def test_the_newton_matrix_is_the_derivative_of_the_residual_with_slip_forces():
    """The bordered matrix of a model with slips: its K block is d r/dx of the residual
    with the slip forces S^T nu (the non-symmetric d(S^T nu)/dx included), checked by
    central differences at a perturbed state with nonzero multipliers; its last rows are
    the slip Jacobian S over the free coordinates, scaled like the holonomic rows."""
    from spacarpy.solvers.statics.equilibrium import StaticProblem
    job = job_from_text(BRAKED.read_text())
    prob = StaticProblem(job.model)
    num, n_x = prob.num, prob.pattern.n_x
    free = np.flatnonzero(prob.free)
    rng = np.random.default_rng(7)
    x = num.x0.copy()
    x[free] += 0.05 * rng.standard_normal(free.size)
    mu = rng.standard_normal(prob.n_multiplier)
    assert prob.slips.n == 2 and prob.n_multiplier == num.n_constraint + 2
    load = prob.loads.at(1.0, 0.0)
    A = prob.matrix(prob.evaluate(x, mu, load), mu).toarray()
    assert A.shape == (n_x + prob.n_multiplier,) * 2
    K = A[:n_x, :n_x]
    h = 1e-6
    fd = np.zeros_like(K)
    for j, c in enumerate(free):
        xp, xm = x.copy(), x.copy()
        xp[c] += h
        xm[c] -= h
        fd[:, j] = (prob.evaluate(xp, mu, load).r - prob.evaluate(xm, mu, load).r) / (2 * h)
    assert np.abs(K - fd).max() < 1e-7 * np.abs(fd).max()
    assert not np.allclose(K, K.T)                  # d(S^T nu)/dx is not symmetric
    S = prob.slips.jacobian(x, cols=free).toarray()
    assert np.abs(A[n_x + num.n_constraint:, :n_x] / prob.scale - S).max() < 1e-15
    assert np.abs(A[:n_x, n_x + num.n_constraint:] / prob.scale - S.T).max() < 1e-15


@pytest.mark.parametrize("mode", [4, 10])
def test_modes_4_and_10_run_the_bicycle_at_rest(tmp_path, mode):
    """SPACAR modes 4 (eigen) and 10 (the static path with its linearized equations) impose
    the slips too: the same unstable modes (Table 2(a)), and mode 10's /state_space."""
    with run_text(bicycle(mode), tmp_path / f"m{mode}.h5") as f:
        freq = f["eigen/frequency"][-1]
        if mode == 10:
            assert rel(f["state_space/K0"][-1], G * K0_REF) < 1e-12
    ref = np.array([-0.498416502904687, -0.880277032627687])
    assert np.abs(freq / ref - 1).max() < 1e-10


def test_balanced_multipliers_large_path_agrees_with_the_dense_one(monkeypatch):
    """The sparse least-squares start (large models) gives the dense one's multipliers."""
    from spacarpy.solvers.statics import newton as nt
    from spacarpy.solvers.statics.equilibrium import StaticProblem
    prob = StaticProblem(job_from_text(BICYCLE.read_text()).model)
    x, mu = prob.num.x0.copy(), np.zeros(prob.n_multiplier)
    load = prob.loads.at(1.0, 0.0)
    dense = nt.balanced_multipliers(prob, x, mu, load)
    monkeypatch.setattr(nt, "_DENSE_LSQ", 0)
    sparse = nt.balanced_multipliers(prob, x, mu, load)
    assert np.abs(sparse - dense).max() < 1e-9 * np.abs(dense).max()
    assert np.abs(prob.evaluate(x, dense, load).r).max() < 1e-10 * np.abs(dense).max()
