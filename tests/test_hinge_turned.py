"""HINGE constraint moments at every joint angle (issue 34, item 9b): the stress resultants
of modes 2 and 3 are the physical moments about b and c of node p, through 180 degrees and
over full turns, and the joint's constraint keeps full rank at every angle."""
import numpy as np
import pytest

from spacarpy.deck import job_from_text
from spacarpy.elements.hinge import hinge_reference, hinge_state
from spacarpy.results import open_results
from spacarpy.rotation import from_axis_angle
from spacarpy.run import run_job
from spacarpy.solvers.statics.static import solve_static
from spacarpy.time_functions import TimeFunction

M, G, L = 1.0, 9.81, 1.0
MGL2 = M * G * L / 2                     # 4.905 N m: the weight's moment about the pivot

# A rod of mass M along x from a fixed pivot, on a HINGE about the vertical z, under gravity
# -z; the hinge angle is prescribed. The weight's moment about the pivot is horizontal and
# normal to the rod: (-sin t, cos t, 0) M g L/2 with t the angle; the joint carries it with
# its constraint modes 2 and 3 (b = x, c = y of the ground node p).
ROD = """\
{mode}
X 1 0 0 0
X 3 {L} 0 0
RBEAM 1 1 4 3 0 1 0
HINGE 10 2 4 0 0 1
INPUTE 10 1
FIX 1
FIX 2
END
HALT
EM 1 {rhoa}
GRAVITY 0 0 {g}
DELINPE 10 1 {angle}
{steps}
END
END
"""


def quat_mul(a, b):
    a0, av, b0, bv = a[..., :1], a[..., 1:], b[..., :1], b[..., 1:]
    return np.concatenate([a0 * b0 - np.sum(av * bv, -1, keepdims=True),
                           a0 * bv + b0 * av + np.cross(av, bv)], -1)


@pytest.mark.parametrize("deg", [90.0, 179.9, 180.0, 180.1, 270.0, 405.0])
def test_hinge_moments_of_a_turned_rod_under_gravity_are_the_closed_form(deg):
    """sigma_2 = -M g L/2 sin t, sigma_3 = M g L/2 cos t (N m) exactly; before, sigma_2,3
    were these divided by cos(t/2): 1e17 N m at 180 degrees."""
    t = np.radians(deg)
    text = ROD.format(mode="", L=L, rhoa=M / L, g=-G, angle=repr(float(t)),
                      steps="ITERSTEP 20 8 1e-12")
    model, settings = job_from_text(text, "rod.dat")
    st = solve_static(model, settings).steps[-1]
    e, s = st.deformation["HINGE"][0], st.stress["HINGE"][0]
    assert e[0] == pytest.approx(t, abs=1e-12)
    assert np.abs(e[1:]).max() < 1e-13
    np.testing.assert_allclose(s, [0.0, -MGL2 * np.sin(t), MGL2 * np.cos(t)],
                               rtol=0, atol=1e-11)


def test_crank_driven_through_two_turns_has_bounded_closed_form_hinge_moments(tmp_path):
    """The rod as a crank, its angle driven (INPUTE, TIMEFUNCTION spinup: the rate rises to
    4 pi rad/s in 0.5 s) through two full turns in a transient run. The weight's moment
    turns with it (sigma_2, sigma_3 as in the static test, at every step, 180 and 540
    degrees included); the hinge's own moment is minus the rod's inertia about the axis
    (M L^2 / 3) times the prescribed angular acceleration."""
    w, tspin = 4.0 * np.pi, 0.5
    text = ROD.format(mode="MODE transient\nTIMEFUNCTION spinup 0.5", L=L, rhoa=M / L,
                      g=-G, angle=repr(float(w)), steps="TIMESTEP 1.25 500")
    job = job_from_text(text, "crank.dat")
    out = tmp_path / "crank.h5"
    run_job(job, out)
    tr = open_results(out).transient
    e = tr.deformation(kind="HINGE")[:, 0]
    s = tr.stress_resultant(kind="HINGE")[:, 0]
    phi = TimeFunction("spinup", (tspin,))
    ph = np.array([phi(ti) for ti in tr.time])
    angle, acc = w * ph[:, 0], w * ph[:, 2]
    assert angle[-1] == pytest.approx(4 * np.pi) and e[-1, 0] == pytest.approx(4 * np.pi)
    np.testing.assert_allclose(e[:, 0], angle, rtol=0, atol=1e-12)
    # the run passes 180 and 540 degrees between stored steps
    assert np.any(np.abs(np.cos(angle / 2)) < 0.01)
    assert np.abs(s[:, 1:]).max() <= MGL2 * (1 + 1e-12)
    np.testing.assert_allclose(s[:, 1], -MGL2 * np.sin(angle), rtol=0, atol=1e-10)
    np.testing.assert_allclose(s[:, 2], MGL2 * np.cos(angle), rtol=0, atol=1e-10)
    # the joint moment to the integrator's acceleration error (0.2 % of its peak here)
    peak = M * L**2 / 3 * np.abs(acc).max()
    np.testing.assert_allclose(s[:, 0], -M * L**2 / 3 * acc, rtol=0, atol=3e-3 * peak)
    assert np.abs(s[:, 0]).max() <= peak * (1 + 3e-3)


def test_hinge_constraint_keeps_full_rank_at_every_angle():
    """The Jacobian of the constraint modes 2-3 with both Euler normalizations (4 x 8) has
    the same singular values at every joint angle: at the angle t the gradients of e2 and
    e3 are the relative rotations about b and c of node p, of unit length. Before, they had
    the length |cos(t/2)| and vanished at 180 degrees."""
    rng = np.random.default_rng(5)
    angles = np.concatenate([np.linspace(-4 * np.pi, 4 * np.pi, 161),
                             np.pi + np.array([-1e-3, -1e-9, 0, 1e-9, 1e-3]), [3 * np.pi]])
    n = angles.size
    a, b, c = hinge_reference(np.tile(rng.normal(size=3), (n, 1)))
    qp = np.tile(from_axis_angle(rng.normal(size=(1, 3)), np.array([1.1])), (n, 1))
    qq = quat_mul(qp, from_axis_angle(a, angles))
    st = hinge_state(np.concatenate([qp, qq], 1), a, b, c, e1_previous=angles)
    np.testing.assert_allclose(st.e[:, 0], angles, atol=1e-12)
    assert np.abs(st.e[:, 1:]).max() < 1e-14
    C = np.zeros((n, 4, 8))
    C[:, :2] = st.D[:, 1:]
    C[:, 2, :4], C[:, 3, 4:] = 2 * qp, 2 * qq
    sv = np.linalg.svd(C, compute_uv=False)
    # unit quaternions: the two normalization rows have norm 2, the modes' rows 2 sqrt 2
    # (the relative rotation of q against p, dq = q (0, dphi/2)): sqrt 8 and 2, twice each
    np.testing.assert_allclose(sv, np.tile([np.sqrt(8), np.sqrt(8), 2, 2], (n, 1)),
                               rtol=1e-12)
    # the gradients are the relative rotations about b^p and c^p at every angle:
    # dq^q = q^q (0, u/2) with u = R(q^q)^T v turns node q about v (global)
    from spacarpy.rotation import rotation_matrix
    for i in range(0, n, 7):
        R = rotation_matrix(qp[i:i + 1])[0]
        Rq = rotation_matrix(qq[i:i + 1])[0]
        for k, v in ((1, R @ b[i]), (2, R @ c[i])):
            u = Rq.T @ v
            dq = quat_mul(qq[i], np.concatenate([[0.0], u / 2]))
            rates = st.D[i, :, 4:] @ dq
            np.testing.assert_allclose(rates, np.eye(3)[k], atol=1e-12)


@pytest.mark.parametrize("deg", [90.0, 180.0, 270.0, 405.0])
def test_plhinge_moment_of_a_turned_rod_is_the_closed_form(deg):
    """The planar rod (PLBEAM, rigid) on a PLHINGE turned by t under gravity -y: the joint
    moment is the weight's moment about the pivot, -M g L/2 cos t, through full turns."""
    t = float(np.radians(deg))
    text = (f"X 1 0 0\nX 3 {L} 0\nPLBEAM 1 1 4 3 5\nPLHINGE 10 2 4\nINPUTE 10 1\nFIX 1\n"
            f"FIX 2\nEND\nHALT\nEM 1 {M / L}\nGRAVITY 0 {-G} 0\nDELINPE 10 1 {t!r}\n"
            f"ITERSTEP 20 8 1e-12\nEND\nEND\n")
    model, settings = job_from_text(text, "plrod.dat")
    st = solve_static(model, settings).steps[-1]
    assert st.deformation["PLHINGE"][0, 0] == pytest.approx(t, abs=1e-12)
    assert st.stress["PLHINGE"][0, 0] == pytest.approx(-MGL2 * np.cos(t), abs=1e-11)
