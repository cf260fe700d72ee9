"""The initially curved beam BEAMC (docs/curved-beam.md): kernel, deck line, BEAMARC ... curved.

References: the straight BEAM's S (zero angle), Castigliano's closed form of a circular
cantilever under a tip force (one element), rigid motions (zero deformation), the closed-form
in-plane frequencies of a free ring, and the converged Table 2 bend.
"""
from __future__ import annotations

import h5py
import numpy as np
import pytest

from spacarpy.bench.cases import bend_deck
from spacarpy.cli.main import main
from spacarpy.deck import build_job, model_from_text, parse_deck
from spacarpy.elements.beam import beam_state, stiffness_matrix
from spacarpy.elements.beamc import (
    BeamC,
    arc_flexibility,
    arc_state,
    arc_stiffness,
    arc_tangent,
)
from spacarpy.elements.registry import KINDS
from spacarpy.rotation import from_axis_angle, rotation_matrix
from spacarpy.solvers.statics.static import solve_static
from tests.helpers import deck_errors

KIND = BeamC()
#: EA GJ EIy EIz cy cz of the kernel tests (shear included).
PROPS = np.array([[3e4, 70.0, 100.0, 50.0, 100.0 / 900.0, 50.0 / 700.0]])


def one_arc(radius=2.0, angle=1.3):
    """One BEAMC in the x-y plane about the origin, from angle 0 to ``angle``."""
    xp = np.array([[radius, 0.0, 0.0]])
    xq = np.array([[radius * np.cos(angle), radius * np.sin(angle), 0.0]])
    ref, scale = KIND.reference([xp, None, xq, None], np.zeros((1, 3)))
    return xp, xq, ref, scale


def test_beamc_is_a_registered_kind_with_the_beam_modes():
    assert KINDS["BEAMC"].n_def == 6 and KINDS["BEAMC"].n_ldof == 14
    assert KINDS["BEAMC"].vector_point and KINDS["BEAMC"].vector_required


@pytest.mark.parametrize("shear", [0.0, 1.0])
def test_zero_angle_is_the_straight_beam_to_round_off(shear):
    props = PROPS * [1, 1, 1, 1, shear, shear]
    l0 = np.array([0.7])
    straight = stiffness_matrix(props, l0)
    np.testing.assert_allclose(arc_stiffness(props, l0, np.zeros(1)), straight,
                               rtol=1e-13, atol=1e-13 * np.abs(straight).max())
    # and the curvature enters smoothly: first order in the angle
    small = arc_stiffness(props, l0, np.array([1e-6]))
    assert 1e-9 < np.abs(small - straight).max() / np.abs(straight).max() < 1e-5


def _tip_compliance(ref, props):
    """The linear 6x6 tip compliance (force, moment at q; p clamped) of one element from
    ``D^T S D`` at the reference state (virtual rotations: half the Euler-parameter rows)."""
    x = np.concatenate([ref.nx[0] * 0, [1, 0, 0, 0], ref.nx[0] * ref.l0[0], [1, 0, 0, 0]])
    st = beam_state(x[None], ref.ny, ref.nz, ref.l0, "modified", ref.u)
    d = st.D[0]
    du = np.concatenate([d[:, 0:3], d[:, 4:7] / 2, d[:, 7:10], d[:, 11:14] / 2], axis=1)
    k = du.T @ KIND.stiffness(props, ref)[0] @ du
    return np.linalg.inv(k[6:, 6:])


def test_one_element_cantilever_equals_castigliano_closed_form():
    """A circular cantilever (radius R, angle a, clamped at angle 0) under a tip force P
    along y: with theta from the clamp, M = P R (cos a - cos theta), N = P cos theta,
    Q = P sin theta, and Castigliano's theorem gives the tip displacements and rotation
    in closed form (bending, extension and shear)."""
    radius, a = 2.0, 1.3
    _, _, ref, _ = one_arc(radius, a)
    ea, _, ei, _, cy, _ = PROPS[0]
    ga = ei / cy
    i1 = a * np.cos(a)**2 - 2 * np.sin(a) * np.cos(a) + a / 2 + np.sin(2 * a) / 4
    i2, i3 = a / 2 + np.sin(2 * a) / 4, a / 2 - np.sin(2 * a) / 4
    i4 = a * np.sin(a) * np.cos(a) - np.cos(a) + np.cos(a)**2 - np.sin(a)**2 / 2
    i5, i6 = np.sin(a)**2 / 2, a * np.cos(a) - np.sin(a)
    dy = radius * (radius**2 * i1 / ei + i2 / ea + i3 / ga)
    dx = radius * (-radius**2 * i4 / ei - i5 / ea + i5 / ga)
    phi = radius**2 * i6 / ei
    u = _tip_compliance(ref, PROPS)[:, 1]             # response to a unit force along y
    np.testing.assert_allclose(u, [dx, dy, 0, 0, 0, phi], rtol=1e-12, atol=1e-12 * dy)


def test_out_of_plane_tip_rotation_equals_closed_form():
    """The same cantilever under a tip force P out of its plane: with theta from the clamp,
    bending M = P R sin(a - theta), torsion T = P R (1 - cos(a - theta)), shear P, so
    w = P R^3 (int sin^2 / EIz + int (1 - cos)^2 / GJ) + P R a / kGA (Castigliano)."""
    radius, a = 2.0, 1.3
    _, _, ref, _ = one_arc(radius, a)
    _, gj, _, eiz, _, cz = PROPS[0]
    ga = eiz / cz
    s2 = a / 2 - np.sin(2 * a) / 4
    c2 = a - 2 * np.sin(a) + a / 2 + np.sin(2 * a) / 4
    w = radius**3 * (s2 / eiz + c2 / gj) + radius * a / ga
    np.testing.assert_allclose(_tip_compliance(ref, PROPS)[2, 2], w, rtol=1e-12)


def test_deformations_vanish_in_the_curved_state_and_under_rigid_motions():
    xp, xq, ref, _ = one_arc()
    rng = np.random.default_rng(3)
    axes = rng.normal(size=(20, 3))
    q = from_axis_angle(axes, rng.uniform(-3, 3, size=20))       # large rotations
    shift = rng.normal(size=(20, 3)) * 50.0
    rot = rotation_matrix(q)
    rp = (rot @ xp[0]) + shift
    rq = (rot @ xq[0]) + shift
    x = np.concatenate([rp, q, rq, q], axis=1)
    x0 = np.concatenate([xp[0], [1, 0, 0, 0], xq[0], [1, 0, 0, 0]])[None]
    refs = ref.tile(20)
    for variant in ("basic", "modified"):
        e = KIND.state(x, refs, variant, None).e
        assert np.abs(e).max() < 1e-13 * (1 + np.abs(shift).max())
        assert np.abs(KIND.state(x0, ref, variant, None).e).max() < 1e-15


def _random_states(n=6, seed=11, spread=0.6):
    """One arc's reference and n configurations with large nodal rotations and moved ends."""
    xp, xq, ref, _ = one_arc()
    rng = np.random.default_rng(seed)
    qs = [from_axis_angle(rng.normal(size=(n, 3)), rng.uniform(-spread, spread, n))
          for _ in range(2)]
    x = np.concatenate([xp + 0.1 * rng.normal(size=(n, 3)), qs[0],
                        xq + 0.1 * rng.normal(size=(n, 3)), qs[1]], axis=1)
    return x, ref.tile(n)


@pytest.mark.parametrize("variant", ["basic", "modified"])
def test_deformations_derivatives_are_exact_against_finite_differences(variant):
    """D = de/dx, the weighted second derivatives and the tangent D^T S D + H of the
    angle-measured deformations against central differences (step 1e-6: truncation
    1e-12, round-off 1e-10 of the entries)."""
    x, ref = _random_states()
    n = x.shape[0]
    st = KIND.state(x, ref, variant, None)
    rng = np.random.default_rng(4)
    w = rng.normal(size=(n, 6))
    h = 1e-6
    fd_d = np.empty((n, 6, 14))
    fd_h = np.empty((n, 14, 14))
    for j in range(14):
        dx = np.zeros(14)
        dx[j] = h
        sp, sm = KIND.state(x + dx, ref, variant, None), KIND.state(x - dx, ref, variant, None)
        fd_d[:, :, j] = (sp.e - sm.e) / (2 * h)
        fd_h[:, :, j] = np.einsum("ni,nik->nk", w, sp.D - sm.D) / (2 * h)
    np.testing.assert_allclose(st.D, fd_d, rtol=0, atol=1e-8 * np.abs(st.D).max())
    hess = KIND.hessian(st, w)
    np.testing.assert_allclose(hess, fd_h, rtol=0, atol=1e-7 * np.abs(hess).max())
    assert np.abs(hess).max() > 1e-2
    stiff = np.repeat(KIND.stiffness(PROPS, ref.take([0])), n, axis=0)
    np.testing.assert_allclose(KIND.tangent(st, stiff, w),
                               st.D.transpose(0, 2, 1) @ stiff @ st.D + hess,
                               rtol=0, atol=1e-12 * np.abs(hess).max())
    np.testing.assert_allclose(KIND.deformations(x, ref, variant, None), st.e, rtol=0,
                               atol=1e-15)
    # the dense and the blocked second derivatives of the BEAM's kernels agree here too
    blocked = arc_state(x, ref.ny, ref.nz, ref.l0, ref.u, variant, False)
    np.testing.assert_allclose(arc_tangent(blocked, stiff, w, False),
                               arc_tangent(st, stiff, w, True), rtol=0,
                               atol=1e-13 * np.abs(hess).max())


def test_torsion_and_bending_are_measured_as_angles():
    """Node q turned by phi about the chord: the BEAM's torsion is l0 sin(phi), the BEAMC's
    l0 phi; about the arc's normal (in-plane bending at q): l0 beta, where the BEAM has
    l0 sin(beta). At the reference the Jacobian is the BEAM's (the linear theory is
    unchanged)."""
    xp, xq, ref, _ = one_arc()
    phi = 0.7
    for axis, mode in ((ref.nx[0], 1), (ref.ny[0], 3)):
        q = from_axis_angle(axis[None], np.array([phi]))[0]
        x = np.concatenate([xp[0], [1, 0, 0, 0], xq[0], q])[None]
        e = KIND.state(x, ref, "basic", None).e[0]
        straight = beam_state(x, ref.ny, ref.nz, ref.l0, "basic", ref.u).e[0]
        np.testing.assert_allclose(e[mode], ref.l0[0] * phi, rtol=1e-14)
        np.testing.assert_allclose(straight[mode], ref.l0[0] * np.sin(phi), rtol=1e-14)
    x0 = np.concatenate([xp[0], [1, 0, 0, 0], xq[0], [1, 0, 0, 0]])[None]
    np.testing.assert_allclose(KIND.state(x0, ref, "modified", None).D,
                               beam_state(x0, ref.ny, ref.nz, ref.l0, "modified", ref.u).D,
                               rtol=0, atol=1e-15)


def test_flexibility_is_symmetric_positive_and_the_arc_couples_the_modes():
    _, _, ref, _ = one_arc()
    f = arc_flexibility(PROPS, ref.l0, ref.alpha)[0]
    np.testing.assert_allclose(f, f.T, rtol=0, atol=1e-15 * np.abs(f).max())
    assert np.linalg.eigvalsh(f).min() > 0
    # elongation couples with in-plane bending (modes 3, 4), torsion with out-of-plane (5, 6)
    assert abs(f[0, 2]) > 1e-3 * np.sqrt(f[0, 0] * f[2, 2])
    assert abs(f[1, 4]) > 1e-3 * np.sqrt(f[1, 1] * f[4, 4])
    assert f[0, 4] == 0 and f[1, 2] == 0


def _rigid_energies(radius, a):
    """2 T of a unit translation along x and of a unit rotation about the arc's centre."""
    _, _, ref, _ = one_arc(radius, a)
    m = np.array([[3.0, 0, 0, 0, 0]])
    x0 = np.concatenate([[radius, 0, 0], [1, 0, 0, 0],
                         [radius * np.cos(a), radius * np.sin(a), 0], [1, 0, 0, 0]])[None]
    mm = KIND.mass(x0, ref, m)[0]
    v = np.zeros(14)
    v[0] = v[7] = 1.0
    w = np.zeros(14)
    w[0:3] = np.cross([0, 0, 1.0], x0[0, 0:3])
    w[7:10] = np.cross([0, 0, 1.0], x0[0, 7:10])
    w[[6, 13]] = 0.5                                             # dq/dt = (0, 0, 0, w/2)
    return v @ mm @ v, w @ mm @ w


def test_mass_of_rigid_motions_is_the_arcs():
    """Translation: rho A L exactly. Rotation about the centre: rho A R^3 a to the
    interpolation error of the Hermite cubic of the arc, fourth order in the angle."""
    radius = 2.0
    errors = []
    for a in (0.4, 0.2):
        trans, rot = _rigid_energies(radius, a)
        np.testing.assert_allclose(trans, 3.0 * radius * a, rtol=1e-14)
        errors.append(abs(rot / (3.0 * radius**3 * a) - 1))
    assert errors[1] < 1e-5 and 12 < errors[0] / errors[1] < 20, errors


# ------------------------------------------------------------------------ deck and generator
RING = """# a free ring of BEAMC elements, R = 1, EI = rhoA = 1
MODE eigen
SET n {n}
X 1 1 0 0
X 3 0 1 0
X 5 -1 0 0
X 7 0 -1 0
BEAMARC 1 1 2 3 4 {{n}} 0 0 0 0 0 -1 curved
BEAMARC {{n+1}} 3 4 5 6 {{n}} 0 0 0 0 0 -1 curved
BEAMARC {{2*n+1}} 5 6 7 8 {{n}} 0 0 0 0 0 -1 curved
BEAMARC {{3*n+1}} 7 8 1 2 {{n}} 0 0 0 0 0 -1 curved
DYNE 1:{{4*n}} 1 2 3 4 5 6
END
HALT
ESTIFF 1:{{4*n}} 1e6 1e4 1 1e4
EM 1:{{4*n}} 1 1e-6 5e-7 5e-7
ITERSTEP 20 1 1e-10
END
END
"""


def test_ring_in_plane_frequencies_equal_the_closed_form(tmp_path):
    """Free thin ring, in-plane flexural modes: w_n = sqrt(EI/(rho A R^4)) n (n^2 - 1) /
    sqrt(n^2 + 1) (inextensible, no rotary inertia; here EA R^2/EI = 1e6 and rhoI/rhoA R^2
    = 5e-7, well below the tolerance). 32 curved elements: 2.5e-4 at n = 4; straight chords
    need about 10 times more elements for 5e-3 (docs/curved-beam.md)."""
    deck = tmp_path / "ring.dat"
    deck.write_text(RING.format(n=8))
    out = tmp_path / "ring.h5"
    assert main(["run", str(deck), "-o", str(out), "-q", "--modes", "12"]) == 0
    with h5py.File(out) as f:
        w = np.ravel(f["eigen/frequency"][...]) * 2 * np.pi
        assert f["model/elements/BEAMC/ids"].shape == (32,)
    # six rigid motions (their w^2 are round-off sized, whatever their stored kind)
    np.testing.assert_allclose(w[:6], 0, atol=1e-2)
    n = np.arange(2, 5)
    exact = n * (n**2 - 1) / np.sqrt(n**2 + 1)
    np.testing.assert_allclose(w[6:12:2], exact, rtol=3e-4)       # each a double pair
    np.testing.assert_allclose(w[7:12:2], exact, rtol=3e-4)
    assert np.abs(w[6:12:2] / exact - 1).max() > 1e-6                 # (not exact: the mass)


def _bend_tip(n: int, shape: str, force: float = 600.0) -> np.ndarray:
    text = bend_deck(n).replace("0 0 {R}  0 1 0", "0 0 {R}  0 1 0" +
                                (" curved" if shape == "curved" else ""))
    text = "\n".join(line for line in text.splitlines() if not line.startswith("EXPECT"))
    text = text.replace("DELXF 3 0 600 0", f"DELXF 3 0 {force:g} 0")
    job = build_job(parse_deck(text, "t.dat"), text=text, path="t.dat")
    assert job.model.elements["BEAMC" if shape == "curved" else "BEAM"].n_elem == n
    res = solve_static(job.model, job.settings)
    row = list(job.model.position_ids).index(3)
    return res.steps[-1].x[res.problem.num.pos_idx[row]]


#: Table 2's tip at 600 N, converged (256 elements; chords and arcs agree to 6e-5).
BEND_LIMIT = np.array([47.15024, 53.47504, 15.68473])


def _rod_tip(force: float, steps: int) -> np.ndarray:
    """The tip of Table 2's bend from the rod equations themselves (Reissner's rod: strains
    ``Lambda^T r' - E1``, curvature change ``Lambda^T Lambda' - K0``, linear section laws
    with EA, kGA, GJ, EI; dead tip force along y), by shooting on the moment at the clamp
    with the load raised in ``steps`` steps. Independent of any element."""
    from scipy.integrate import solve_ivp
    from scipy.optimize import fsolve

    radius, ei = 100.0, 1e7 / 12
    cf = np.array([1e-7, 2e-7, 2e-7])                         # 1/EA, 1/kGA, 1/kGA
    cm = np.full(3, 1.0 / ei)                                 # 1/GJ, 1/EIy, 1/EIz
    k0 = np.array([0.0, -1.0 / radius, 0.0])                  # section axes [t, y, t x y]
    frame0 = np.array([[1.0, 0, 0], [0, 1, 0], [0, 0, 1]])    # columns t, y, t x y at s = 0

    def hat(v):
        return np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])

    def shoot(m0, f):
        def rhs(_s, y):
            lam, m = y[3:12].reshape(3, 3), y[12:]
            dr = lam @ (np.array([1.0, 0, 0]) + cf * (lam.T @ f))
            dlam = lam @ hat(k0 + cm * (lam.T @ m))
            return np.concatenate([dr, dlam.ravel(), -np.cross(dr, f)])
        y0 = np.concatenate([np.zeros(3), frame0.ravel(), m0])
        return solve_ivp(rhs, (0.0, radius * np.pi / 4), y0, method="DOP853",
                         rtol=1e-10, atol=1e-10).y[:, -1]

    m0 = np.zeros(3)
    for f in np.linspace(force / steps, force, steps):
        load = np.array([0.0, f, 0.0])
        m0 = fsolve(lambda m, load=load: shoot(m, load)[12:], m0, xtol=1e-13)
    end = shoot(m0, load)
    assert np.abs(end[12:]).max() < 1e-8 * force * radius           # free end: no moment
    return end[:3]


@pytest.fixture(scope="module")
def rod_tips():
    return {600.0: _rod_tip(600.0, 3), 60.0: _rod_tip(60.0, 1)}


def test_rod_equations_give_the_converged_bend(rod_tips):
    """The rod's tip and the 256-element DDM limit agree to 3e-4 m (the DDM's error at 256
    elements, second order); the paper's 48-element DDM row (47.14, 53.48, 15.68) to 1.1e-2."""
    np.testing.assert_allclose(rod_tips[600.0], BEND_LIMIT, atol=4e-4)
    np.testing.assert_allclose(rod_tips[600.0], [47.14, 53.48, 15.68], atol=1.1e-2)
    np.testing.assert_allclose(rod_tips[60.0], [69.8965, 11.0392, 28.8010], atol=1e-4)


def test_curved_elements_need_fewer_elements_than_chords(rod_tips):
    """The convergence table (docs/curved-beam.md): tip errors against the rod at the
    paper's load (600 N, the tip moves as far as the bend is long) and at 60 N. Curved
    elements measure torsion and bending as angles, so their large-rotation error is about
    a sixth of the chords' (whose DDM modes are sines): 4 and 8 curved elements beat 8 and
    16 chords at 600 N, and 4 curved elements beat 16 chords at 60 N."""
    err = {}
    for force in (600.0, 60.0):
        for shape, counts in (("curved", (4, 8)), ("chords", (8, 16))):
            for n in counts:
                tip = _bend_tip(n, shape, force)
                err[force, shape, n] = float(np.linalg.norm(tip - rod_tips[force]))
    table = "; ".join(f"{f:g} N {s} {n}: {e:.3e}" for (f, s, n), e in err.items())
    assert err[600.0, "curved", 8] < 5e-2 < err[600.0, "chords", 16], table
    assert err[600.0, "curved", 4] < err[600.0, "chords", 8], table
    assert err[60.0, "curved", 4] < err[60.0, "chords", 16], table
    # second order for both: halving the elements quarters the error (within 15 %)
    for shape, n in (("curved", 4), ("chords", 8)):
        assert 3.4 < err[600.0, shape, n] / err[600.0, shape, 2 * n] < 4.6, table


def test_curved_bend_in_the_linear_range_is_exact_with_one_element():
    """At 6 mN the bend is linear: one curved element gives the arc's exact tip deflection
    (Castigliano; the chords' 64-element value to 1e-5), where 8 chords are 1.2e-3 off."""
    one = _bend_tip(1, "curved", 0.006)
    fine = _bend_tip(64, "chords", 0.006)
    eight = _bend_tip(8, "chords", 0.006)
    assert abs(one[1] / fine[1] - 1) < 3e-5
    assert abs(eight[1] / fine[1] - 1) > 1e-3


def test_beamarc_curved_writes_beamc_lines_and_default_stays_chords():
    chords = build_job(parse_deck(bend_deck(4), "t.dat"), text="", path="t.dat").model
    assert chords.elements["BEAM"].n_elem == 4 and "BEAMC" not in chords.elements or \
        chords.elements["BEAMC"].n_elem == 0
    text = bend_deck(4).replace("0 0 {R}  0 1 0", "0 0 {R}  0 1 0 curved")
    curved = build_job(parse_deck(text, "t.dat"), text=text, path="t.dat").model
    es = curved.elements["BEAMC"]
    assert es.n_elem == 4
    np.testing.assert_allclose(es.vector, np.tile([0, 0, 100.0], (4, 1)))
    np.testing.assert_array_equal(curved.position_x0, chords.position_x0)


@pytest.mark.parametrize("text, message", [
    ("X 1 1 0 0\nX 3 0 1.1 0\nBEAMC 1 1 2 3 4 0 0 0\n", "not on one circle"),
    ("X 1 1 0 0\nX 3 -1 0 0\nBEAMC 1 1 2 3 4 0 0 0\n", "lies on the line"),
    ("X 1 1 0 0\nX 3 0 1 0\nBEAMC 1 1 2 3 4\n", "BEAMC"),
    ("X 1 1 0 0\nX 3 0 1 0\nBEAMARC 1 1 2 3 4 2 0 0 0 0 0 1 curved\n", "normal to the arc"),
])
def test_bad_arcs_are_deck_errors(text, message):
    errors = deck_errors(text + "FIX 1\nFIX 2\nDYNE 1 1 2 3 4 5 6\nEND\nHALT\n"
                         "ESTIFF 1 1 1 1 1\nEND\nEND\n")
    assert any(message in m for _, m in errors), errors


def test_centre_at_the_origin_is_accepted():
    model = model_from_text("X 1 1 0 0\nX 3 0 1 0\nBEAMC 1 1 2 3 4 0 0 0\nFIX 1\nFIX 2\n"
                            "DYNE 1 1 2 3 4 5 6\nEND\nHALT\nESTIFF 1 1 1 1 1\nEND\nEND\n")
    assert model.elements["BEAMC"].n_elem == 1


@pytest.mark.parametrize("rotary", ["lumped", "consistent"])
def test_inertia_kernels_are_lagranges_equations_of_the_arc_mass(rotary):
    """``M a + dM/dt v - 1/2 d(v^T M v)/dx`` of the BEAMC mass matrix by central differences
    (exact: M is quadratic in the Euler parameters and does not depend on positions)
    against its inertia force and its convective terms, at random states with section
    inertia (the per-node tangents of the arc in the BEAM's mass kernels)."""
    rng = np.random.default_rng(5)
    n = 4
    centre = rng.standard_normal((n, 3))
    u, w = rng.standard_normal((n, 3)), rng.standard_normal((n, 3))
    u /= np.linalg.norm(u, axis=1)[:, None]
    w -= np.sum(w * u, axis=1)[:, None] * u
    w /= np.linalg.norm(w, axis=1)[:, None]
    ang = rng.uniform(0.2, 1.5, size=(n, 1))
    xp, xq = centre + 2.0 * u, centre + 2.0 * (np.cos(ang) * u + np.sin(ang) * w)
    ref, _ = KIND.reference([xp, None, xq, None], centre)
    x = np.concatenate([xp, rng.standard_normal((n, 4)), xq, rng.standard_normal((n, 4))],
                       axis=1)
    v, a = rng.standard_normal((n, 14)), rng.standard_normal((n, 14))
    em = np.abs(rng.standard_normal((n, 5)))

    def mass(xx):
        return KIND.mass(xx, ref, em, rotary)

    mdot = np.einsum("nij,nj->ni", 0.5 * (mass(x + v) - mass(x - v)), v)
    grad = np.zeros((n, 14))
    for j in range(14):
        e = np.zeros(14)
        e[j] = 1.0
        vmv = [np.einsum("ni,nij,nj->n", v, mass(x + s * e), v) for s in (1.0, -1.0)]
        grad[:, j] = 0.5 * (vmv[0] - vmv[1])
    want = np.einsum("nij,nj->ni", mass(x), a) + mdot - 0.5 * grad
    got = KIND.inertia_force(x, v, a, ref, em, rotary)
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-12 * np.abs(want).max())
    got_mdot, got_grad = KIND.convective(x, v, ref, em, rotary)
    np.testing.assert_allclose(got_mdot, mdot, rtol=0, atol=1e-12 * np.abs(mdot).max())
    np.testing.assert_allclose(got_grad, grad, rtol=0, atol=1e-12 * np.abs(grad).max())


def test_gravity_is_the_arc_centre_lines_and_its_derivative():
    """Generalized gravity: the work of g on the Hermite centre line of the arc; at the
    reference the position rows carry rho A L g / 2 each, and df/dx is its exact derivative."""
    xp, xq, ref, _ = one_arc()
    g = np.array([0.3, -9.81, 1.2])
    rng = np.random.default_rng(2)
    x = np.concatenate([xp[0], rng.standard_normal(4), xq[0], rng.standard_normal(4)])[None]
    em = np.array([[2.5, 0, 0, 0, 0]])
    f, k = KIND.gravity(x, ref, em, g)
    np.testing.assert_allclose(f[0, 0:3], 0.5 * 2.5 * ref.arc[0] * g, rtol=1e-15)
    h = 1e-6
    for j in range(14):
        e = np.zeros(14)
        e[j] = h
        fd = (KIND.gravity(x + e, ref, em, g)[0] - KIND.gravity(x - e, ref, em, g)[0]) / (2 * h)
        np.testing.assert_allclose(k[0, :, j], fd[0], rtol=0, atol=1e-8 * np.abs(k).max())


def test_results_and_check_name_the_beamc_elements(tmp_path, capsys):
    """A run stores the BEAMC group's deformations and stress resultants (sigma = S e for
    the flexible modes) and `check` reports the kind."""
    deck = tmp_path / "bend.dat"
    deck.write_text(bend_deck(4).replace("0 0 {R}  0 1 0", "0 0 {R}  0 1 0 curved"))
    out = tmp_path / "bend.h5"
    assert main(["run", str(deck), "-o", str(out), "-q"]) in (0, 4)
    with h5py.File(out) as f:
        e = f["static/elements/BEAMC/deformation"][-1]
        s = f["static/elements/BEAMC/stress_resultant"][-1]
        assert f["model/elements/BEAMC/ids"][:].tolist() == [1, 2, 3, 4]
    job = build_job(parse_deck(deck.read_text(), str(deck)), text="", path=str(deck))
    es = job.model.elements["BEAMC"]
    ids = list(job.model.position_ids)
    x0 = job.model.position_x0
    ref, _ = KIND.reference([x0[[ids.index(n) for n in es.nodes[:, 0]]], None,
                             x0[[ids.index(n) for n in es.nodes[:, 2]]], None], es.vector)
    sk = KIND.stiffness(es.stiffness, ref)
    np.testing.assert_allclose(s, np.einsum("nij,nj->ni", sk, e), rtol=1e-9,
                               atol=1e-9 * np.abs(s).max())
    capsys.readouterr()
    assert main(["check", str(deck)]) == 0
    assert "BEAMC" in capsys.readouterr().out
