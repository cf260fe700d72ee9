"""PINBODY (SPACAR type 9): exact kernel derivatives, definitions, coincident nodes, and the
same pendulum as the RBEAM chain in every analysis (rolling-contact spec A1, A3, A4)."""
import h5py
import numpy as np
import pytest

from spacarpy.deck import job_from_text
from spacarpy.elements.pinbody import PinBody, pinbody_state, pinbody_weighted_hessian
from spacarpy.elements.registry import KINDS
from spacarpy.rotation import from_axis_angle, rotation_matrix
from spacarpy.run import run_job

from helpers import deck_errors, fd_columns

KIND = PinBody()


def reference(xp0, xq0):
    return KIND.reference([xp0, None, xq0], np.full((len(xp0), 3), np.nan))


def random_configuration(rng, n):
    xp0, xq0 = rng.normal(size=(n, 3)), rng.normal(size=(n, 3))
    xq0[0] = xp0[0]                                         # one pin of zero length
    ref, scale = reference(xp0, xq0)
    q = from_axis_angle(rng.normal(size=(n, 3)), rng.uniform(-3, 3, n))
    q *= rng.uniform(0.7, 1.3, size=(n, 1))                # |lambda| != 1
    x = np.concatenate([xp0 + 0.3 * rng.normal(size=(n, 3)), q,
                        xq0 + 0.3 * rng.normal(size=(n, 3))], axis=1)
    return x, ref, scale


def test_registered_as_spacar_type_9_with_three_length_modes():
    assert KINDS["PINBODY"].n_def == 3 and KINDS["PINBODY"].slots == ("pos", "rot", "pos")
    assert KIND.mode_units == ("m",) * 3 and KIND.em is None and KIND.zero_length


def test_jacobian_and_weighted_hessian_equal_central_differences():
    rng = np.random.default_rng(9)
    x, ref, _ = random_configuration(rng, 5)
    st = pinbody_state(x, ref)
    fd = fd_columns(lambda y: pinbody_state(y, ref).e, x)
    assert np.abs(fd - st.D).max() <= 1e-7 * np.abs(st.D).max()
    w = rng.normal(size=(5, 3))
    fd = fd_columns(lambda y: np.einsum("nk,nkj->nj", w, pinbody_state(y, ref).D), x)
    hx = pinbody_weighted_hessian(st, w)
    assert np.abs(fd - hx).max() <= 1e-7 * np.abs(hx).max()
    assert np.abs(hx - hx.transpose(0, 2, 1)).max() == 0.0


def test_zero_in_the_reference_and_a_known_displacement_in_a_turned_body_frame():
    """e = R^T (x_q - x_p) - (x_q0 - x_p0): a rigid motion of p, q and the frame leaves it 0;
    a point displaced by u in the turned frame reads u, to 1e-12."""
    rng = np.random.default_rng(3)
    xp0, xq0 = rng.normal(size=(4, 3)), rng.normal(size=(4, 3))
    xq0[1] = xp0[1]
    ref, scale = reference(xp0, xq0)
    eye = np.tile([1.0, 0, 0, 0], (4, 1))
    assert np.all(pinbody_state(np.concatenate([xp0, eye, xq0], 1), ref).e == 0.0)
    q = from_axis_angle(rng.normal(size=(4, 3)), rng.uniform(-3, 3, 4))
    R = rotation_matrix(q)
    shift = rng.normal(size=(4, 3))
    u = np.array([[0.1, -0.2, 0.3]] * 4)
    xq = shift + np.einsum("nij,nj->ni", R, xq0 - xp0 + u)
    e = pinbody_state(np.concatenate([shift, q, xq], 1), ref).e
    assert np.abs(e - u).max() < 1e-12
    # the zero-length pin takes its group's largest length as its scale
    length = np.linalg.norm(xq0 - xp0, axis=1)
    assert scale[1, 0] == length.max() and scale[0, 0] == length[0]


# ---------------------------------------------------------------------------- in the analyses
PENDULUM = """# a double pendulum: body 11 (pivot 1, mass at 2), body 12 (mass at 5), hinge springs
X 1 0 0 0
X 2 0 -1.2 0
{x3}X 5 0 -2.0 0
HINGE 2 10 11 0 0 1
HINGE 3 11 12 0 0 1
{rods}
DYNE 2 1
DYNE 3 1
FIX 1
FIX 10
END
HALT
ESTIFF 2 5
ESTIFF 3 4
XM 2 3.0
XM 11 0.1 0 0 0.2 0 0.3
XM 5 2.0
XM 12 0.05 0 0 0.07 0 0.11
GRAVITY 0 -9.81 0
{data}
END
END
"""
# the PINBODY chain has a pin of zero length: node 3 of body 11 coincides with its node 2
PIN = dict(x3="X 3 0 -1.2 0\n", rods="PINBODY 1 1 11 2\nPINBODY 4 2 11 3\nPINBODY 5 3 12 5")
RBEAM = dict(x3="", rods="RBEAM 1 1 11 2\nRBEAM 5 2 12 5")


def run(tmp_path, text, name):
    out = tmp_path / f"{name}.h5"
    run_job(job_from_text(text, f"{name}.dat"), out)
    return h5py.File(out, "r")


def test_pinbody_chain_has_the_rbeam_chains_eigenfrequencies(tmp_path):
    with run(tmp_path, PENDULUM.format(**PIN, data="MODE 7"), "pin") as a, \
            run(tmp_path, PENDULUM.format(**RBEAM, data="MODE 7"), "rbeam") as b:
        fa, fb = a["eigen/frequency"][-1], b["eigen/frequency"][-1]
        assert a["static/elements/PINBODY/deformation"].shape[1:] == (3, 3)
    assert fa.size == 2 and np.all(fa > 0.1)
    np.testing.assert_allclose(fa, fb, rtol=1e-10)


@pytest.mark.parametrize("mode", [4, 8, 9, 10, 3])
def test_pinbody_chain_equals_the_rbeam_chain_in_every_linearized_analysis(tmp_path, mode):
    """Loaded (buckling needs DELXF) and in SPACAR modes 4, 8, 9, 10 and 3 (along a short
    transient): the same frequencies, multipliers and linearized matrices to 1e-12; mode 3
    differences its derivatives (docs/linearized.md: 5e-9 relative), so there to 5e-9 of the
    largest entry of the equations."""
    data = (f"DELXF 5 0 -3 0\nDELXF 2 0.5 0 0\nMODE {mode}"
            + ("\nSTARTDE 2 1 0.8\nTIMESTEP 0.05 5" if mode == 3 else ""))
    keys = ("eigen/frequency", "buckling/load_multiplier", "state_space/M0", "state_space/C0",
            "state_space/K0", "state_space/A")
    with run(tmp_path, PENDULUM.format(**PIN, data=data), "pin") as a, \
            run(tmp_path, PENDULUM.format(**RBEAM, data=data), "rbeam") as b:
        compared = [k for k in keys if k in a]
        largest = max(np.nanmax(np.abs(b[k][...])) for k in compared)
        for key in compared:
            x, y = a[key][...], b[key][...]
            assert x.shape == y.shape and np.isfinite(y).any(), key
            tol = 5e-9 * largest if mode == 3 else 1e-12 * np.nanmax(np.abs(y))
            assert np.nanmax(np.abs(x - y)) <= tol, key
    assert len(compared) >= 1 + (mode in (9, 10, 3)) * 3


def test_single_pinbody_pendulum_has_the_closed_form_period(tmp_path):
    """omega^2 = (k + m g L) / (J + m L^2) for a rigid body on a hinge spring, hanging."""
    text = PENDULUM.format(**PIN, data="MODE 7")
    text = (text.replace("X 5 0 -2.0 0\n", "").replace("HINGE 3 11 12 0 0 1\n", "")
            .replace("PINBODY 5 3 12 5", "").replace("DYNE 3 1\n", "")
            .replace("ESTIFF 3 4\n", "").replace("XM 5 2.0\n", "")
            .replace("XM 12 0.05 0 0 0.07 0 0.11\n", ""))
    with run(tmp_path, text, "single") as f:
        freq = f["eigen/frequency"][-1]
    k, m, L, J, g = 5.0, 3.0, 1.2, 0.3, 9.81
    omega = np.sqrt((k + m * g * L) / (J + m * L * L))
    assert freq[0] == pytest.approx(omega / (2 * np.pi), rel=1e-10)


def test_pinbody_chain_moves_as_the_rbeam_chain_in_a_transient(tmp_path):
    data = "MODE 1\nSTARTDE 2 1 0.8\nTIMESTEP 0.5 50"
    with run(tmp_path, PENDULUM.format(**PIN, data=data), "pin_t") as a, \
            run(tmp_path, PENDULUM.format(**RBEAM, data=data), "rbeam_t") as b:
        pa, pb = a["transient/position"][-1], b["transient/position"][-1]
        ids_a, ids_b = list(a["model/position_nodes"][:]), list(b["model/position_nodes"][:])
    tip_a, tip_b = pa[ids_a.index(5)], pb[ids_b.index(5)]
    assert np.linalg.norm(tip_a - (0, -2.0, 0)) > 0.05           # it has swung
    np.testing.assert_allclose(tip_a, tip_b, atol=1e-10)


def test_a_released_pinbody_measures_the_displacement_in_the_turned_frame(tmp_path):
    """A body turned by a prescribed hinge angle about a skew axis; the released pin reads
    R^T d - d0 for the fixed point q (1e-12)."""
    text = """X 1 0.3 -0.2 0.1
X 3 1.3 0.3 0.3
HINGE 2 10 11 0.2 0.3 1
PINBODY 1 1 11 3
INPUTE 2 1
RLSE 1 1 2 3
FIX 1
FIX 3
FIX 10
END
HALT
INPUTE 2 1 0.0
DELINPE 2 1 0.7
ITERSTEP 20 1 1e-12
END
END
"""
    with run(tmp_path, text, "released") as f:
        e = f["static/elements/PINBODY/deformation"][-1, 0]
    R = rotation_matrix(from_axis_angle(np.array([0.2, 0.3, 1.0]), np.array(0.7)))
    d = np.array([1.0, 0.5, 0.2])
    assert np.abs(e - (R.T @ d - d)).max() < 1e-12
    assert np.abs(e).max() > 0.1


def test_pinbody_deck_errors():
    base = "X 1 0 0 0\nX 2 1 0 0\nPINBODY 1 1 11 2\nFIX 1\nFIX 11\nEND\nHALT\n"
    assert deck_errors(base + "EM 1 2.0\nEND\nEND\n") == [
        (8, "EM 1: a PINBODY has no mass of its own; put masses and inertias on its nodes "
            "with XM")]
    assert deck_errors(base.replace("PINBODY 1 1 11 2", "PINBODY 1 1 11 2 0 1 0")
                       + "END\nEND\n")[0][1].startswith("PINBODY takes exactly 4 fields")
    # a flexible mode needs its stiffness, as for an RBEAM
    assert "ESTIFF 1 [k1 k2 k3]" in deck_errors(base.replace("FIX 1\n", "FIX 1\nDYNE 1 2\n")
                                                 + "END\nEND\n")[0][1]
