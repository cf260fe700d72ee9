"""DDM beam kernel: exact derivatives, objectivity, vectorization, linear stiffness."""
import numpy as np
import pytest

from spacarpy.elements.beam import (
    beam_deformations,
    beam_state,
    beam_tangent,
    beam_weighted_hessian,
    reference_triads,
    stiffness_matrix,
)
from spacarpy.rotation import from_axis_angle, lambda_matrix, rotation_matrix

VARIANTS = ("basic", "modified")


def random_elements(rng, n, deform=0.3):
    """n random elements (random reference geometry) in random deformed configurations."""
    xp = rng.normal(size=(n, 3))
    xq = xp + rng.normal(size=(n, 3))
    nx, ny, nz, l0 = reference_triads(xp, xq, rng.normal(size=(n, 3)))
    qp = from_axis_angle(rng.normal(size=(n, 3)), deform * rng.normal(size=n))
    qq = from_axis_angle(rng.normal(size=(n, 3)), deform * rng.normal(size=n))
    x = np.concatenate([xp + 0.1 * rng.normal(size=(n, 3)), qp,
                        xq + 0.1 * rng.normal(size=(n, 3)), qq], axis=1)
    return x, ny, nz, l0


def quat_mul(a, b):
    a0, av, b0, bv = a[..., :1], a[..., 1:], b[..., :1], b[..., 1:]
    return np.concatenate([a0 * b0 - np.sum(av * bv, -1, keepdims=True),
                           a0 * bv + b0 * av + np.cross(av, bv)], axis=-1)


@pytest.mark.parametrize("variant", VARIANTS)
def test_first_derivatives_equal_central_differences(variant):
    rng = np.random.default_rng(10)
    x, ny, nz, l0 = random_elements(rng, 20)
    st = beam_state(x, ny, nz, l0, variant)
    h = 1e-6
    fd = np.zeros_like(st.D)
    for k in range(14):
        dx = np.zeros(14)
        dx[k] = h
        fd[:, :, k] = (beam_deformations(x + dx, ny, nz, l0, variant)
                       - beam_deformations(x - dx, ny, nz, l0, variant)) / (2 * h)
    scale = np.abs(st.D).max(axis=(1, 2))[:, None, None]
    assert np.all(np.abs(fd - st.D) <= 1e-7 * scale)


@pytest.mark.parametrize("variant", VARIANTS)
def test_second_derivatives_equal_central_differences(variant):
    rng = np.random.default_rng(11)
    x, ny, nz, l0 = random_elements(rng, 20)
    st = beam_state(x, ny, nz, l0, variant)
    h = 1e-6
    for i in range(6):                       # each mode's Hessian separately
        w = np.zeros((x.shape[0], 6))
        w[:, i] = 1.0
        hess = beam_weighted_hessian(st, w)
        assert np.allclose(hess, hess.transpose(0, 2, 1), atol=1e-12)
        fd = np.zeros_like(hess)
        for k in range(14):
            dx = np.zeros(14)
            dx[k] = h
            fd[:, :, k] = (beam_state(x + dx, ny, nz, l0, variant).D[:, i]
                           - beam_state(x - dx, ny, nz, l0, variant).D[:, i]) / (2 * h)
        scale = np.abs(hess).max(axis=(1, 2))[:, None, None] + 1e-12
        assert np.all(np.abs(fd - hess) <= 1e-6 * scale), f"mode {i + 1}"


@pytest.mark.parametrize("variant", VARIANTS)
def test_weighted_hessian_is_linear_in_the_weights(variant):
    rng = np.random.default_rng(12)
    x, ny, nz, l0 = random_elements(rng, 7)
    st = beam_state(x, ny, nz, l0, variant)
    w = rng.normal(size=(7, 6))
    parts = sum(beam_weighted_hessian(st, w * np.eye(6)[i]) for i in range(6))
    assert np.allclose(beam_weighted_hessian(st, w), parts, rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("variant", VARIANTS)
def test_tangent_is_material_plus_geometric_stiffness(variant):
    """beam_tangent folds D^T S D into the modified deformations' quadratic term
    (D = J D_hat): the same matrix as the two parts computed apart."""
    rng = np.random.default_rng(13)
    x, ny, nz, l0 = random_elements(rng, 9)
    st = beam_state(x, ny, nz, l0, variant)
    w = rng.normal(size=(9, 6))
    props = np.abs(rng.normal(size=(9, 6))) * [1e3, 1.0, 2.0, 3.0, 0.01, 0.02]
    S = stiffness_matrix(props, l0)
    apart = st.D.transpose(0, 2, 1) @ S @ st.D + beam_weighted_hessian(st, w)
    k = beam_tangent(st, S, w)
    assert np.abs(k - apart).max() <= 1e-13 * np.abs(apart).max()
    assert np.abs(k - k.transpose(0, 2, 1)).max() <= 1e-13 * np.abs(k).max()


@pytest.mark.parametrize("variant", VARIANTS)
def test_deformations_are_invariant_under_rigid_motion(variant):
    rng = np.random.default_rng(13)
    x, ny, nz, l0 = random_elements(rng, 30, deform=0.5)
    e = beam_deformations(x, ny, nz, l0, variant)
    assert np.abs(e).max() > 1e-2                        # the test is not trivial
    for _ in range(5):
        qrot = from_axis_angle(rng.normal(size=3), rng.uniform(-np.pi, np.pi))
        rot = rotation_matrix(qrot)
        shift = rng.normal(size=3) * 10
        y = x.copy()
        y[:, 0:3] = x[:, 0:3] @ rot.T + shift
        y[:, 7:10] = x[:, 7:10] @ rot.T + shift
        y[:, 3:7] = quat_mul(qrot, x[:, 3:7])
        y[:, 10:14] = quat_mul(qrot, x[:, 10:14])
        np.testing.assert_allclose(beam_deformations(y, ny, nz, l0, variant), e,
                                   rtol=0, atol=1e-12 * l0.max())


def test_zero_deformation_in_the_initial_configuration_of_a_curved_chain():
    th = np.linspace(0, np.pi / 4, 9)
    pts = np.stack([100 * np.sin(th), 0 * th, 100 * (1 - np.cos(th))], 1)
    nx, ny, nz, l0 = reference_triads(pts[:-1], pts[1:], np.tile([0, 1.0, 0], (8, 1)))
    ident = np.tile([1.0, 0, 0, 0], (8, 1))
    x = np.concatenate([pts[:-1], ident, pts[1:], ident], axis=1)
    for variant in VARIANTS:
        assert np.abs(beam_deformations(x, ny, nz, l0, variant)).max() < 1e-12


def reference_one_element(rp, qp, rq, qq, ny, nz, l0, variant):
    """Plain transcription of Eq. (1), (2), (7) and (48b) for one element."""
    def rot(q):
        l0_, lam = q[0], q[1:]
        tilde = np.array([[0, -lam[2], lam[1]], [lam[2], 0, -lam[0]], [-lam[1], lam[0], 0]])
        return (l0_ ** 2 - lam @ lam) * np.eye(3) + 2 * l0_ * tilde + 2 * np.outer(lam, lam)
    nyp, nzp = rot(qp) @ ny, rot(qp) @ nz
    nyq, nzq = rot(qq) @ ny, rot(qq) @ nz
    lvec = rq - rp
    length = np.sqrt(lvec @ lvec)
    n1 = lvec / length
    e1 = length - l0
    e2 = l0 * (nzp @ nyq - nyp @ nzq) / 2
    e3 = -l0 * (n1 @ nzp)
    e4 = l0 * (n1 @ nzq)
    e5 = l0 * (n1 @ nyp)
    e6 = -l0 * (n1 @ nyq)
    if variant == "basic":
        return np.array([e1, e2, e3, e4, e5, e6])
    return np.array([
        e1 + (2 * e3**2 + e3 * e4 + 2 * e4**2 + 2 * e5**2 + e5 * e6 + 2 * e6**2) / (30 * l0),
        e2 + (-e3 * e6 + e4 * e5) / l0,
        e3 + e2 * (e5 + e6) / (6 * l0),
        e4 - e2 * (e5 + e6) / (6 * l0),
        e5 - e2 * (e3 + e4) / (6 * l0),
        e6 + e2 * (e3 + e4) / (6 * l0)])


@pytest.mark.parametrize("variant", VARIANTS)
def test_vectorized_kernel_equals_one_element_reference(variant):
    rng = np.random.default_rng(14)
    x, ny, nz, l0 = random_elements(rng, 50, deform=0.4)
    e = beam_deformations(x, ny, nz, l0, variant)
    for i in range(50):
        ref = reference_one_element(x[i, 0:3], x[i, 3:7], x[i, 7:10], x[i, 10:14],
                                    ny[i], nz[i], l0[i], variant)
        np.testing.assert_allclose(e[i], ref, rtol=1e-13, atol=1e-14 * l0[i])


def test_jacobian_matches_corrected_eq14_in_virtual_rotations():
    """D_hat = D_u A with D_u from Eq. (14) (errata of NOTES.md applied), A from Eq. (51)."""
    rng = np.random.default_rng(15)
    x, ny, nz, l0 = random_elements(rng, 10, deform=0.4)
    qn = x.copy()
    for sl in (slice(3, 7), slice(10, 14)):
        qn[:, sl] /= np.linalg.norm(qn[:, sl], axis=1)[:, None]
    st = beam_state(qn, ny, nz, l0, "basic")
    for i in range(10):
        rp, rq = qn[i, 0:3], qn[i, 7:10]
        rotp, rotq = rotation_matrix(qn[i, 3:7]), rotation_matrix(qn[i, 10:14])
        nyp, nzp, nyq, nzq = rotp @ ny[i], rotp @ nz[i], rotq @ ny[i], rotq @ nz[i]
        lv = rq - rp
        length = np.linalg.norm(lv)
        n1 = lv / length
        L = l0[i]
        perp = lambda a: (a - (n1 @ a) * n1) * L / length           # noqa: E731
        du = np.zeros((6, 12))
        du[0, 0:3], du[0, 6:9] = -n1, n1
        du[1, 3:6] = L / 2 * (np.cross(nzp, nyq) - np.cross(nyp, nzq))
        du[1, 9:12] = L / 2 * (np.cross(nyq, nzp) - np.cross(nzq, nyp))
        du[2, 0:3], du[2, 3:6], du[2, 6:9] = perp(nzp), -L * np.cross(nzp, n1), -perp(nzp)
        du[3, 0:3], du[3, 6:9], du[3, 9:12] = -perp(nzq), perp(nzq), L * np.cross(nzq, n1)
        du[4, 0:3], du[4, 3:6], du[4, 6:9] = -perp(nyp), L * np.cross(nyp, n1), perp(nyp)
        du[5, 0:3], du[5, 6:9], du[5, 9:12] = perp(nyq), -perp(nyq), -L * np.cross(nyq, n1)
        a = np.zeros((12, 14))
        a[0:3, 0:3] = a[6:9, 7:10] = np.eye(3)
        a[3:6, 3:7] = 2 * lambda_matrix(qn[i, 3:7])
        a[9:12, 10:14] = 2 * lambda_matrix(qn[i, 10:14])
        # D_hat and D_u A agree on variations tangent to the Euler-parameter constraint
        tangent = np.eye(14)
        for sl in (slice(3, 7), slice(10, 14)):
            q = qn[i, sl]
            tangent[sl, sl] -= np.outer(q, q)
        np.testing.assert_allclose(st.D_hat[i] @ tangent, du @ a @ tangent, atol=1e-12 * L)


def textbook_beam_stiffness(L, EA, GJ, EIy, EIz, phi_y, phi_z):
    """12x12 Timoshenko beam along x, dofs [u v w tx ty tz]_p [u v w tx ty tz]_q."""
    k = np.zeros((12, 12))
    for a, b, v in ((0, 0, 1), (0, 6, -1), (6, 6, 1)):
        k[a, b] = k[b, a] = v * EA / L
    for a, b, v in ((3, 3, 1), (3, 9, -1), (9, 9, 1)):
        k[a, b] = k[b, a] = v * GJ / L
    # bending in x-y (v, theta_z), rigidity EIz, shear factor phi_y
    c = EIz / ((1 + phi_y) * L**3)
    idx = [1, 5, 7, 11]
    kb = c * np.array([[12, 6 * L, -12, 6 * L],
                       [6 * L, (4 + phi_y) * L**2, -6 * L, (2 - phi_y) * L**2],
                       [-12, -6 * L, 12, -6 * L],
                       [6 * L, (2 - phi_y) * L**2, -6 * L, (4 + phi_y) * L**2]])
    k[np.ix_(idx, idx)] = kb
    # bending in x-z (w, theta_y), rigidity EIy, shear factor phi_z (signs of theta_y flip)
    c = EIy / ((1 + phi_z) * L**3)
    idx = [2, 4, 8, 10]
    kb = c * np.array([[12, -6 * L, -12, -6 * L],
                       [-6 * L, (4 + phi_z) * L**2, 6 * L, (2 - phi_z) * L**2],
                       [-12, 6 * L, 12, 6 * L],
                       [-6 * L, (2 - phi_z) * L**2, 6 * L, (4 + phi_z) * L**2]])
    k[np.ix_(idx, idx)] = kb
    return k


@pytest.mark.parametrize("variant", VARIANTS)
def test_linear_stiffness_equals_textbook_timoshenko_beam(variant):
    L, EA, GJ, EIy, EIz, cy, cz = 1.7, 3e7, 2e3, 5e3, 8e3, 1e-3, 4e-3
    nx, ny, nz, l0 = reference_triads(np.zeros((1, 3)), np.array([[L, 0, 0]]),
                                      np.array([[0.0, 1.0, 0.0]]))
    x = np.array([[0, 0, 0, 1, 0, 0, 0, L, 0, 0, 1, 0, 0, 0]], dtype=float)
    st = beam_state(x, ny, nz, l0, variant)
    S = stiffness_matrix(np.array([[EA, GJ, EIy, EIz, cy, cz]]), l0)[0]
    # virtual rotations at the identity: d(phi) = 2 d(lambda_1..3)
    cols = [0, 1, 2, 4, 5, 6, 7, 8, 9, 11, 12, 13]
    du = st.D[0][:, cols] * np.array([1, 1, 1, .5, .5, .5] * 2)
    k = du.T @ S @ du
    ref = textbook_beam_stiffness(L, EA, GJ, EIy, EIz, 12 * cz / L**2, 12 * cy / L**2)
    np.testing.assert_allclose(k, ref, rtol=1e-12, atol=1e-9 * np.abs(ref).max())


def test_deformations_alone_equal_those_of_the_full_state():
    """beam_deformations (used by the kinematic correction's chord iterations) computes
    exactly the e of beam_state, for both variants."""
    from spacarpy.elements.beam import beam_deformations, beam_state
    rng = np.random.default_rng(7)
    n = 9
    x = np.zeros((n, 14))
    x[:, 7] = 1.0
    x[:, :3] += 0.05 * rng.standard_normal((n, 3))
    for s in (3, 10):
        q = np.c_[np.ones(n), 0.2 * rng.standard_normal((n, 3))]
        x[:, s:s + 4] = q / np.linalg.norm(q, axis=1)[:, None]
    ny, nz, l0 = np.tile([0, 1.0, 0], (n, 1)), np.tile([0, 0, 1.0], (n, 1)), np.ones(n)
    for variant in ("modified", "basic"):
        assert np.array_equal(beam_deformations(x, ny, nz, l0, variant),
                              beam_state(x, ny, nz, l0, variant).e)
    assert np.abs(beam_state(x, ny, nz, l0).e).max() > 1e-2
