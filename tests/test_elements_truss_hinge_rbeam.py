"""TRUSS, HINGE and RBEAM kernels: exact derivatives, objectivity, definitions and signs,
vectorization, stiffness and mass."""
import numpy as np
import pytest

from spacarpy.elements.beam_mass import beam_mass_matrix
from spacarpy.elements.hinge import (
    hinge_deformations,
    hinge_reference,
    hinge_state,
    hinge_stiffness,
    hinge_weighted_hessian,
)
from spacarpy.elements.rbeam import (
    rbeam_deformations,
    rbeam_mass_matrix,
    rbeam_reference,
    rbeam_state,
    rbeam_stiffness,
    rbeam_weighted_hessian,
)
from spacarpy.elements.truss import (
    truss_deformations,
    truss_mass_matrix,
    truss_reference,
    truss_state,
    truss_stiffness,
    truss_weighted_hessian,
)
from spacarpy.rotation import from_axis_angle, lambda_matrix, rotation_matrix

from helpers import fd_columns


# ------------------------------------------------------------------------------ helpers
def quat_mul(a, b):
    a0, av, b0, bv = a[..., :1], a[..., 1:], b[..., :1], b[..., 1:]
    return np.concatenate([a0 * b0 - np.sum(av * bv, -1, keepdims=True),
                           a0 * bv + b0 * av + np.cross(av, bv)], axis=-1)


def rot(q):
    """Plain Eq. (2) for one quaternion."""
    l0_, lam = q[0], q[1:]
    tilde = np.array([[0, -lam[2], lam[1]], [lam[2], 0, -lam[0]], [-lam[1], lam[0], 0]])
    return (l0_ ** 2 - lam @ lam) * np.eye(3) + 2 * l0_ * tilde + 2 * np.outer(lam, lam)


def random_quats(rng, n, spread, scale=False):
    q = from_axis_angle(rng.normal(size=(n, 3)), spread * rng.normal(size=n))
    if scale:                                   # the kernels are exact for any |q|
        q *= rng.uniform(0.8, 1.2, size=(n, 1))
    return q


def check_jacobian(state_fn, x):
    st = state_fn(x)
    fd = fd_columns(lambda y: state_fn(y).e, x)
    scale = np.abs(st.D).max(axis=(1, 2))[:, None, None]
    assert np.all(np.abs(fd - st.D) <= 1e-7 * scale)


def check_hessians(state_fn, hess_fn, x, n_def):
    st = state_fn(x)
    n = x.shape[0]
    for i in range(n_def):                       # each mode's Hessian separately
        w = np.zeros((n, n_def))
        w[:, i] = 1.0
        hess = hess_fn(st, w)
        assert hess.shape == (n, x.shape[1], x.shape[1])
        assert np.allclose(hess, hess.transpose(0, 2, 1), rtol=0, atol=1e-12)
        fd = fd_columns(lambda y: state_fn(y).D[:, i], x)
        scale = np.abs(hess).max(axis=(1, 2))[:, None, None] + 1e-12
        assert np.all(np.abs(fd - hess) <= 1e-6 * scale), f"mode {i + 1}"
    w = np.random.default_rng(0).normal(size=(n, n_def))
    parts = sum(hess_fn(st, w * np.eye(n_def)[i]) for i in range(n_def))
    assert np.allclose(hess_fn(st, w), parts, rtol=1e-12, atol=1e-12)
    assert np.allclose(hess_fn(st, 2.5 * w), 2.5 * hess_fn(st, w), rtol=1e-12, atol=1e-12)


def random_rigid_motion(rng):
    qrot = from_axis_angle(rng.normal(size=3), rng.uniform(-np.pi, np.pi))
    return qrot, rotation_matrix(qrot), 10 * rng.normal(size=3)


# -------------------------------------------------------------------------------- TRUSS
def random_trusses(rng, n):
    xp = rng.normal(size=(n, 3))
    xq = xp + rng.normal(size=(n, 3))
    l0 = truss_reference(xp, xq)
    x = np.concatenate([xp + 0.2 * rng.normal(size=(n, 3)),
                        xq + 0.2 * rng.normal(size=(n, 3))], axis=1)
    return x, l0


def test_truss_derivatives_equal_central_differences():
    rng = np.random.default_rng(20)
    x, l0 = random_trusses(rng, 20)
    st = truss_state(x, l0)
    assert st.e.shape == (20, 1) and st.D.shape == (20, 1, 6)
    check_jacobian(lambda y: truss_state(y, l0), x)
    check_hessians(lambda y: truss_state(y, l0), truss_weighted_hessian, x, 1)


def test_truss_invariance_zero_initial_and_one_element_reference():
    rng = np.random.default_rng(21)
    x, l0 = random_trusses(rng, 30)
    e = truss_deformations(x, l0)
    assert np.abs(e).max() > 1e-2
    for _ in range(3):
        _, r, t = random_rigid_motion(rng)
        y = np.concatenate([x[:, 0:3] @ r.T + t, x[:, 3:6] @ r.T + t], axis=1)
        np.testing.assert_allclose(truss_deformations(y, l0), e, rtol=0, atol=1e-12)
    xp, xq = rng.normal(size=(5, 3)), rng.normal(size=(5, 3))
    l00 = truss_reference(xp, xq)
    assert np.abs(truss_deformations(np.concatenate([xp, xq], 1), l00)).max() < 1e-14
    for i in range(30):
        ref = np.sqrt(np.sum((x[i, 3:6] - x[i, 0:3]) ** 2)) - l0[i]
        assert abs(e[i, 0] - ref) <= 1e-14


def test_truss_stiffness_and_mass():
    l0 = np.array([2.0, 0.5])
    s = truss_stiffness(np.array([[3e6], [4e5]]), l0)
    np.testing.assert_allclose(s[:, 0, 0], [1.5e6, 8e5])
    np.testing.assert_allclose(truss_stiffness(np.array([3e6, 4e5]), l0), s)
    # linear stiffness D^T S D along the axis: the textbook rod
    x = np.array([[0, 0, 0, 2.0, 0, 0]])
    st = truss_state(x, l0[:1])
    k = st.D[0].T @ s[0] @ st.D[0]
    assert np.isclose(k[0, 0], 1.5e6) and np.isclose(k[0, 3], -1.5e6)
    assert np.isclose(np.abs(k).sum(), 4 * 1.5e6)

    rng = np.random.default_rng(22)
    x, l0 = random_trusses(rng, 10)
    rho_a = rng.uniform(1, 3, size=10)
    m = truss_mass_matrix(rho_a, l0)
    assert m.shape == (10, 6, 6) and np.allclose(m, m.transpose(0, 2, 1))
    ones = np.tile([1.0, 0, 0], 2)
    np.testing.assert_allclose(ones @ m @ ones, rho_a * l0, rtol=1e-14)
    # kinetic energy of rigid motions (and of the linear velocity field along the truss)
    gauss = (1 - np.array([-1, 1]) / np.sqrt(3)) / 2
    for i in range(10):
        v0, om = rng.normal(size=3), rng.normal(size=3)
        vp, vq = v0 + np.cross(om, x[i, 0:3]), v0 + np.cross(om, x[i, 3:6])
        xdot = np.concatenate([vp, vq])
        exact = sum(0.5 * rho_a[i] * l0[i] * 0.5 * np.sum(((1 - s) * vp + s * vq) ** 2)
                    for s in gauss)
        assert np.isclose(0.5 * xdot @ m[i] @ xdot, exact, rtol=1e-13)


# -------------------------------------------------------------------------------- HINGE
def random_hinges(rng, n, angle_spread=2.0, tilt=0.2, scale=False):
    """Hinges with random axes: q^q = q^p (rotation about the axis) (small tilt)."""
    a, b, c = hinge_reference(rng.normal(size=(n, 3)))
    qp = random_quats(rng, n, 2.0)
    theta = angle_spread * rng.normal(size=n)
    qq = quat_mul(quat_mul(qp, from_axis_angle(a, theta)), random_quats(rng, n, tilt))
    if scale:
        qp *= rng.uniform(0.8, 1.2, size=(n, 1))
        qq *= rng.uniform(0.8, 1.2, size=(n, 1))
    return np.concatenate([qp, qq], axis=1), a, b, c


def test_hinge_reference_triad_rule():
    a, b, c = hinge_reference(np.array([[2.0, 0, 0], [0, 1, 0], [0, 0, -3], [1, 1, 1]]))
    np.testing.assert_allclose(a[0], [1, 0, 0])
    np.testing.assert_allclose(np.stack([b[0], c[0]]), [[0, 1, 0], [0, 0, 1]])
    np.testing.assert_allclose(np.stack([b[1], c[1]]), [[1, 0, 0], [0, 0, -1]])
    np.testing.assert_allclose(np.stack([b[2], c[2]]), [[1, 0, 0], [0, -1, 0]], atol=1e-15)
    np.testing.assert_allclose(b[3], np.array([2, -1, -1]) / np.sqrt(6))  # from global x
    for i in range(4):
        e = np.stack([a[i], b[i], c[i]], axis=1)
        np.testing.assert_allclose(e.T @ e, np.eye(3), atol=1e-15)
        assert np.isclose(np.linalg.det(e), 1.0)
    with pytest.raises(ValueError):
        hinge_reference(np.array([[0.0, 0, 0]]))


def test_hinge_derivatives_equal_central_differences():
    rng = np.random.default_rng(30)
    x, a, b, c = random_hinges(rng, 20, angle_spread=3.0, tilt=0.4, scale=True)
    # random branches (multi-turn); every finite-difference evaluation stays on its branch
    e1 = hinge_state(x, a, b, c).e[:, 0] + 2 * np.pi * rng.integers(-2, 3, size=20)
    fn = lambda y: hinge_state(y, a, b, c, e1_previous=e1)          # noqa: E731
    st = fn(x)
    assert st.e.shape == (20, 3) and st.D.shape == (20, 3, 8)
    check_jacobian(fn, x)
    check_hessians(fn, hinge_weighted_hessian, x, 3)


def test_hinge_deformations_are_invariant_under_rigid_motion():
    rng = np.random.default_rng(31)
    x, a, b, c = random_hinges(rng, 30, tilt=0.5)
    e = hinge_deformations(x, a, b, c)
    assert np.abs(e[:, 1:]).max() > 1e-2
    for _ in range(5):
        qrot, _, _ = random_rigid_motion(rng)
        y = np.concatenate([quat_mul(qrot, x[:, 0:4]), quat_mul(qrot, x[:, 4:8])], axis=1)
        np.testing.assert_allclose(hinge_deformations(y, a, b, c, e[:, 0]), e,
                                   rtol=0, atol=1e-12)


def test_hinge_zero_initially_and_sign_conventions():
    rng = np.random.default_rng(32)
    n = 12
    a, b, c = hinge_reference(rng.normal(size=(n, 3)))
    ident = np.tile([1.0, 0, 0, 0], (n, 1))
    assert np.abs(hinge_deformations(np.concatenate([ident, ident], 1), a, b, c)).max() < 1e-15
    for qp in (ident, random_quats(rng, n, 2.0)):
        ang = rng.uniform(-3.0, 3.0, size=n)
        # rotation about the axis: e1 = theta
        qq = quat_mul(qp, from_axis_angle(a, ang))
        e = hinge_deformations(np.concatenate([qp, qq], 1), a, b, c)
        np.testing.assert_allclose(e[:, 0], ang, rtol=0, atol=1e-13)
        assert np.abs(e[:, 1:]).max() < 1e-14
        # rotation about b: e2 = sin(phi) ~ phi
        qq = quat_mul(qp, from_axis_angle(b, ang / 4))
        e = hinge_deformations(np.concatenate([qp, qq], 1), a, b, c)
        np.testing.assert_allclose(e[:, 1], np.sin(ang / 4), rtol=0, atol=1e-14)
        assert np.abs(e[:, [0, 2]]).max() < 1e-14
        # rotation about c: e3 = sin(psi) ~ psi
        qq = quat_mul(qp, from_axis_angle(c, ang / 4))
        e = hinge_deformations(np.concatenate([qp, qq], 1), a, b, c)
        np.testing.assert_allclose(e[:, 2], np.sin(ang / 4), rtol=0, atol=1e-14)
        assert np.abs(e[:, :2]).max() < 1e-14
    # node p turning by theta about the axis gives e1 = -theta
    qp = from_axis_angle(a, np.full(n, 0.7))
    e = hinge_deformations(np.concatenate([qp, ident], 1), a, b, c)
    np.testing.assert_allclose(e[:, 0], -0.7, atol=1e-14)


def test_hinge_linearized_deformations_are_relative_rotations():
    """At the identity, delta q = delta phi / 2 (vector part): e = [a, b, c] (phi^q - phi^p)."""
    rng = np.random.default_rng(33)
    n = 6
    a, b, c = hinge_reference(rng.normal(size=(n, 3)))
    ident = np.tile([1.0, 0, 0, 0], (n, 1))
    st = hinge_state(np.concatenate([ident, ident], 1), a, b, c)
    triad = np.stack([a, b, c], axis=1)
    np.testing.assert_allclose(0.5 * st.D[:, :, 5:8], triad, atol=1e-15)
    np.testing.assert_allclose(0.5 * st.D[:, :, 1:4], -triad, atol=1e-15)
    assert np.abs(st.D[:, :, [0, 4]]).max() < 1e-15


def test_hinge_large_and_multi_turn_rotations_are_continuous():
    a, b, c = hinge_reference(np.array([[0.0, 0, 1]] * 6))
    theta = np.array([3.3, -3.3, 20.2, -20.2, 3.0, 2 * np.pi + 0.1])
    prev = np.array([3.0, -3.0, 20.0, -20.0, 3.0, 6.0])
    qp = from_axis_angle(np.array([[1.0, 2, 3]] * 6), np.full(6, 0.8))
    qq = quat_mul(qp, from_axis_angle(a, theta))
    x = np.concatenate([qp, qq], 1)
    st = hinge_state(x, a, b, c, e1_previous=prev)
    np.testing.assert_allclose(st.e[:, 0], theta, atol=1e-12)
    np.testing.assert_array_equal(st.turns, [1, -1, 3, -3, 0, 1])
    # without a previous value: the principal branch (-pi, pi]
    e1 = hinge_state(x, a, b, c).e[:, 0]
    np.testing.assert_allclose(e1, np.angle(np.exp(1j * theta)), atol=1e-12)
    # a scalar previous value broadcasts; Jacobians do not depend on the branch
    st2 = hinge_state(x, a, b, c, e1_previous=20.0)
    np.testing.assert_allclose(st2.D, st.D, rtol=0, atol=1e-15)
    assert np.all(np.abs(st2.e[:, 0] - 20.0) <= np.pi)


def hinge_one_element(qp, qq, a, b, c):
    """Plain transcription of the hinge deformations for one element."""
    ap, bp, cp = rot(qp) @ a, rot(qp) @ b, rot(qp) @ c
    aq, bq, cq = rot(qq) @ a, rot(qq) @ b, rot(qq) @ c
    th = np.arctan2(cp @ bq - bp @ cq, bp @ bq + cp @ cq)
    # q's triad turned back by the joint angle about its axis
    bq_, cq_ = np.cos(th) * bq - np.sin(th) * cq, np.cos(th) * cq + np.sin(th) * bq
    return np.array([th, (ap @ cq_ - cp @ aq) / 2, (bp @ aq - ap @ bq_) / 2])


def test_hinge_vectorized_kernel_equals_one_element_reference():
    rng = np.random.default_rng(34)
    x, a, b, c = random_hinges(rng, 50, tilt=0.6, scale=True)
    e = hinge_deformations(x, a, b, c)
    for i in range(50):
        ref = hinge_one_element(x[i, 0:4], x[i, 4:8], a[i], b[i], c[i])
        np.testing.assert_allclose(e[i], ref, rtol=1e-13, atol=1e-14)


def test_hinge_stiffness():
    s = hinge_stiffness(np.array([2.0, 3.0]))
    np.testing.assert_allclose(s, [np.diag([2.0, 0, 0]), np.diag([3.0, 0, 0])])
    s = hinge_stiffness(np.array([[2.0, 5.0, 7.0]]))
    np.testing.assert_allclose(s[0], np.diag([2.0, 5.0, 7.0]))
    with pytest.raises(ValueError):
        hinge_stiffness(np.ones((1, 4)))


# -------------------------------------------------------------------------------- RBEAM
def random_rbeams(rng, n, deform=0.1, scale=False):
    """Random reference geometry (some default y-axes) in random configurations."""
    xp = rng.normal(size=(n, 3))
    xq = xp + rng.normal(size=(n, 3))
    orient = rng.normal(size=(n, 3))
    orient[::3] = np.nan
    nx, ny, nz, l0 = rbeam_reference(xp, xq, orient)
    qp = random_quats(rng, n, 2.0, scale)
    # q carried rigidly by the body of p (moved by r^p - x^p and R(q^p)), plus a perturbation
    rp = xp + rng.normal(size=(n, 3))
    rq = rp + np.einsum("nij,nj->ni", rotation_matrix(qp),
                        xq - xp + deform * rng.normal(size=(n, 3)))
    return np.concatenate([rp, qp, rq], 1), nx, ny, nz, l0


def test_rbeam_derivatives_equal_central_differences():
    rng = np.random.default_rng(40)
    x, nx, ny, nz, l0 = random_rbeams(rng, 20, deform=0.3, scale=True)
    fn = lambda y: rbeam_state(y, nx, ny, nz, l0)                  # noqa: E731
    st = fn(x)
    assert st.e.shape == (20, 3) and st.D.shape == (20, 3, 10)
    check_jacobian(fn, x)
    check_hessians(fn, rbeam_weighted_hessian, x, 3)


def test_rbeam_invariance_zero_initial_and_definitions():
    rng = np.random.default_rng(41)
    x, nx, ny, nz, l0 = random_rbeams(rng, 30, deform=0.3)
    e = rbeam_deformations(x, nx, ny, nz, l0)
    assert np.abs(e).max() > 1e-2
    for _ in range(5):
        qrot, r, t = random_rigid_motion(rng)
        y = np.concatenate([x[:, 0:3] @ r.T + t, quat_mul(qrot, x[:, 3:7]),
                            x[:, 7:10] @ r.T + t], axis=1)
        np.testing.assert_allclose(rbeam_deformations(y, nx, ny, nz, l0), e,
                                   rtol=0, atol=1e-11)
    # initial configuration and rigid motions of the body of p: zero
    xp = rng.normal(size=(9, 3))
    xq = xp + rng.normal(size=(9, 3))
    nx, ny, nz, l0 = rbeam_reference(xp, xq, np.full((9, 3), np.nan))
    ident = np.tile([1.0, 0, 0, 0], (9, 1))
    assert np.abs(rbeam_deformations(np.concatenate([xp, ident, xq], 1),
                                     nx, ny, nz, l0)).max() < 1e-14
    qp = random_quats(rng, 9, 2.0)
    rq = xp + np.einsum("nij,nj->ni", rotation_matrix(qp), xq - xp)
    assert np.abs(rbeam_deformations(np.concatenate([xp, qp, rq], 1),
                                     nx, ny, nz, l0)).max() < 1e-14
    # displacing q along the body axes of p
    u = rng.normal(size=(9, 3))
    rot_ = rotation_matrix(qp)
    disp = np.einsum("nij,nj->ni", rot_, u[:, 0:1] * nx + u[:, 1:2] * ny + u[:, 2:3] * nz)
    e = rbeam_deformations(np.concatenate([xp, qp, rq + disp], 1), nx, ny, nz, l0)
    np.testing.assert_allclose(e, u, atol=1e-13)
    with pytest.raises(ValueError):
        rbeam_reference(np.zeros((1, 3)), np.zeros((1, 3)), np.full((1, 3), np.nan))


def test_rbeam_vectorized_kernel_equals_one_element_reference():
    rng = np.random.default_rng(42)
    x, nx, ny, nz, l0 = random_rbeams(rng, 50, deform=0.3, scale=True)
    e = rbeam_deformations(x, nx, ny, nz, l0)
    for i in range(50):
        r = rot(x[i, 3:7])
        d = x[i, 7:10] - x[i, 0:3]
        ref = np.array([(r @ nx[i]) @ d - l0[i], (r @ ny[i]) @ d, (r @ nz[i]) @ d])
        np.testing.assert_allclose(e[i], ref, rtol=1e-13, atol=1e-14)


def test_rbeam_stiffness():
    np.testing.assert_allclose(rbeam_stiffness(np.zeros((2, 0))), np.zeros((2, 3, 3)))
    np.testing.assert_allclose(rbeam_stiffness(np.array([[1.0, 2.0]]))[0],
                               np.diag([1.0, 2.0, 0.0]))


def rigid_rbeam_motion(rng, n):
    """Rigid configurations with unit q^p and velocities from random v^p and omega (global)."""
    x, nx, ny, nz, l0 = random_rbeams(rng, n, deform=0.0)
    vp, om = rng.normal(size=(n, 3)), rng.normal(size=(n, 3))
    qdot = 0.5 * np.einsum("nki,nk->ni", lambda_matrix(x[:, 3:7]), om)   # 2 Lambda qdot = om
    vq = vp + np.cross(om, x[:, 7:10] - x[:, 0:3])
    return x, nx, ny, nz, l0, np.concatenate([vp, qdot, vq], 1), vp, om


def test_rbeam_mass_total_mass_and_rigid_kinetic_energy():
    rng = np.random.default_rng(43)
    n = 12
    x, nx, ny, nz, l0, xdot, vp, om = rigid_rbeam_motion(rng, n)
    mass = np.column_stack([rng.uniform(1, 3, n), np.zeros(n), rng.uniform(0, .1, n),
                            rng.uniform(0, .1, n), rng.uniform(0, .02, n)])
    mass[:, 1] = mass[:, 2] + mass[:, 3]
    m = rbeam_mass_matrix(x, nx, ny, nz, l0, mass)
    assert m.shape == (n, 10, 10) and np.allclose(m, m.transpose(0, 2, 1))
    assert np.abs(m[:, 7:10]).max() == 0 and np.abs(m[:, :, 7:10]).max() == 0
    unit = np.zeros(10)
    unit[1] = 1.0
    np.testing.assert_allclose(unit @ m @ unit, mass[:, 0] * l0, rtol=1e-14)
    gauss = (1 - np.array([-1, 1]) / np.sqrt(3)) / 2
    for i in range(n):
        r = rotation_matrix(x[i, 3:7])
        # rod: int rhoA |v|^2 (quadratic in s, 2-point Gauss exact) + section rotary inertia
        t_exact = sum(0.25 * mass[i, 0] * l0[i]
                      * np.sum((vp[i] + np.cross(om[i], r @ (s * l0[i] * nx[i]))) ** 2)
                      for s in gauss)
        e = np.stack([nx[i], ny[i], nz[i]], axis=1)
        jsec = np.array([[mass[i, 1], 0, 0], [0, mass[i, 2], -mass[i, 4]],
                         [0, -mass[i, 4], mass[i, 3]]])
        j_spatial = r @ e @ jsec @ e.T @ r.T
        t_exact += 0.5 * l0[i] * om[i] @ j_spatial @ om[i]
        assert np.isclose(0.5 * xdot[i] @ m[i] @ xdot[i], t_exact, rtol=1e-12)


def test_rbeam_mass_equals_rigid_beam_kinetic_energy():
    rng = np.random.default_rng(44)
    n = 8
    x, nx, ny, nz, l0, xdot, _, _ = rigid_rbeam_motion(rng, n)
    mass = rng.uniform(0.01, 1, size=(n, 5))
    m = rbeam_mass_matrix(x, nx, ny, nz, l0, mass)
    xb = np.concatenate([x, x[:, 3:7]], 1)              # [r^p q^p r^q q^q], q^q = q^p
    xbdot = np.concatenate([xdot, xdot[:, 3:7]], 1)
    mb = beam_mass_matrix(xb, nx, ny, nz, l0, mass)
    t_beam = 0.5 * np.einsum("ni,nij,nj->n", xbdot, mb, xbdot)
    t_rbeam = 0.5 * np.einsum("ni,nij,nj->n", xdot, m, xdot)
    np.testing.assert_allclose(t_rbeam, t_beam, rtol=1e-12)
    # only rhoA given: the rod alone
    m1 = rbeam_mass_matrix(x, nx, ny, nz, l0, mass[:, 0])
    mb1 = beam_mass_matrix(xb, nx, ny, nz, l0, np.column_stack([mass[:, 0], np.zeros((n, 4))]))
    np.testing.assert_allclose(0.5 * np.einsum("ni,nij,nj->n", xdot, m1, xdot),
                               0.5 * np.einsum("ni,nij,nj->n", xbdot, mb1, xbdot), rtol=1e-12)


def test_property_columns_pads_missing_and_nan_values_and_keeps_full_rows():
    """EM/ESTIFF values as the kernels take them: short rows padded with zeros, NaN read as
    0, a full float table without NaN handed back as it is (no copy per kernel call)."""
    from spacarpy.linalg import property_columns
    np.testing.assert_array_equal(property_columns(np.array([2.0, 3.0]), 3, "t"),
                                  [[2, 0, 0], [3, 0, 0]])
    np.testing.assert_array_equal(property_columns(np.array([[1.0, np.nan]]), 3, "t"),
                                  [[1, 0, 0]])
    full = np.array([[1.0, 2.0, 3.0]])
    assert property_columns(full, 3, "t") is full
    with_nan = np.array([[1.0, np.nan, 3.0]])
    got = property_columns(with_nan, 3, "t")
    np.testing.assert_array_equal(got, [[1, 0, 3]])
    assert np.isnan(with_nan[0, 1])                  # the input is not changed
    np.testing.assert_array_equal(property_columns([[4, 5, 6]], 3, "t"), [[4, 5, 6]])
    with pytest.raises(ValueError, match="t: expected"):
        property_columns(np.ones((2, 4)), 3, "t")


def test_rbeam_inertia_force_is_lagranges_equations_of_its_mass_matrix():
    """``M a + dM/dt v - 1/2 d(v^T M v)/dx`` of rbeam_mass_matrix, by central differences
    (exact: M is quadratic in the Euler parameters and does not depend on positions),
    against rbeam_inertia_force at random states (Euler parameters not normalized, full
    section inertia with a product term)."""
    from spacarpy.elements.rbeam import rbeam_inertia_force, rbeam_mass_matrix, rbeam_reference
    rng = np.random.default_rng(11)
    n = 5
    xp = rng.standard_normal((n, 3))
    xq = xp + rng.standard_normal((n, 3))
    nx, ny, nz, l0 = rbeam_reference(xp, xq, np.full((n, 3), np.nan))
    x = np.concatenate([xp, rng.standard_normal((n, 4)), xq], axis=1)
    v, a = rng.standard_normal((n, 10)), rng.standard_normal((n, 10))
    em = np.abs(rng.standard_normal((n, 5)))

    def mass(xx):
        return rbeam_mass_matrix(xx, nx, ny, nz, l0, em)

    want = np.einsum("nij,nj->ni", mass(x), a)
    want += np.einsum("nij,nj->ni", 0.5 * (mass(x + v) - mass(x - v)), v)
    for j in range(10):
        e = np.zeros(10)
        e[j] = 1.0
        vmv = [np.einsum("ni,nij,nj->n", v, mass(x + s * e), v) for s in (1.0, -1.0)]
        want[:, j] -= 0.25 * (vmv[0] - vmv[1])
    got = rbeam_inertia_force(x, v, a, nx, ny, nz, l0, em)
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-12 * np.abs(want).max())
    assert np.all(got[:, 7:] == 0.0)                    # node q carries no mass
