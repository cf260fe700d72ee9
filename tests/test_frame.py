"""The rotating frame of a generalized-alpha step (spacarpy/solvers/dynamics/frame.py): exact for a
rigid motion, its operators consistent with each other."""
import numpy as np
import pytest

from spacarpy.rotation import rotate
from spacarpy.solvers.dynamics.frame import Motion, RotatingFrame


def _frame(n_pos=3, n_rot=2, planar=False):
    pos = np.arange(3 * n_pos).reshape(n_pos, 3)
    rot = 3 * n_pos + np.arange(4 * n_rot).reshape(n_rot, 4)
    return RotatingFrame(pos=pos, rot=rot, planar=planar, n_coord=3 * n_pos + 4 * n_rot)


def _quat(axis, angle):
    axis = np.asarray(axis, float) / np.linalg.norm(axis)
    return np.concatenate([[np.cos(angle / 2)], np.sin(angle / 2) * axis])


def _qmul(p, q):
    return np.concatenate([[p[0] * q[0] - p[1:] @ q[1:]],
                           p[0] * q[1:] + q[0] * p[1:] + np.cross(p[1:], q[1:])])


def _rigid(frame, X, Q, omega, c0, u, t):
    """Positions, Euler parameters and their first two derivatives of the rigid motion
    x = c0 + u t + R(omega t) (X - c0), q = q_R(omega t) Q (as a flat state)."""
    ang = np.linalg.norm(omega) * t
    qr = _quat(omega, ang)
    x, v, a = (np.zeros(frame.n_coord) for _ in range(3))
    rel = rotate(np.broadcast_to(qr, (len(X), 4)), X - c0)
    x[frame.pos] = c0 + u * t + rel
    v[frame.pos] = u + np.cross(omega, rel)
    a[frame.pos] = np.cross(omega, np.cross(omega, rel))
    if not len(Q):
        return x, v, a
    q = np.array([_qmul(qr, Qk) for Qk in Q])
    w4 = np.concatenate([[0.0], omega])
    x[frame.rot] = q
    v[frame.rot] = np.array([0.5 * _qmul(w4, qk) for qk in q])
    a[frame.rot] = np.array([0.5 * _qmul(w4, vk) for vk in v[frame.rot]])
    return x, v, a


def test_a_rigid_motion_is_a_constant_state_of_the_frame():
    """Along x = c + u t + R(omega t)(X - c), c the nodes' centroid, the frame's
    coordinates stand still
    (y' = y'' = 0) and the step's map from the frame gives the exact state at t = h, for
    any h: the linear update of y costs a rigid rotation nothing."""
    rng = np.random.default_rng(1)
    frame = _frame()
    X = rng.normal(size=(3, 3))
    Q = np.array([_quat(rng.normal(size=3), a) for a in (0.4, 2.0)])
    omega, u = np.array([0.3, -1.2, 2.5]), np.array([0.5, 0.1, -0.2])
    c0 = X.mean(axis=0)                                      # about the centroid
    x0, v0, a0 = _rigid(frame, X, Q, omega, c0, u, 0.0)
    motion = frame.rate(x0, v0)
    np.testing.assert_allclose(motion.omega, omega, rtol=1e-12)
    yd, ydd, at = frame.to_frame(motion, x0, v0, a0, a0)
    np.testing.assert_allclose(yd, 0, atol=1e-12)
    np.testing.assert_allclose(ydd, 0, atol=1e-12)
    np.testing.assert_allclose(at, 0, atol=1e-12)
    np.testing.assert_allclose(motion.centre, c0, atol=1e-14)
    np.testing.assert_allclose(motion.velocity, u, atol=1e-14)
    for h in (0.01, 0.3, 2.0):
        exact = _rigid(frame, X, Q, omega, c0, u, h)
        for got, want in zip(frame.from_frame(motion, h, x0, 0 * x0, 0 * x0), exact):
            np.testing.assert_allclose(got, want, atol=1e-12)


def test_back_inverts_the_map_from_the_frame_and_w_matches_its_matrix():
    rng = np.random.default_rng(2)
    frame = _frame()
    motion = Motion(rng.normal(size=3), rng.normal(size=3), rng.normal(size=3))
    y, yd, ydd = (rng.normal(size=frame.n_coord) for _ in range(3))
    out = frame.back(motion, 0.7, *frame.from_frame(motion, 0.7, y, yd, ydd))
    for got, want in zip(out, (y, yd, ydd)):
        np.testing.assert_allclose(got, want, atol=1e-12)
    free = np.ones(frame.n_coord, bool)
    W = frame.matrix(motion.omega, free).toarray()
    z = rng.normal(size=frame.n_coord)
    np.testing.assert_allclose(W @ z, frame.apply_w(motion.omega, z), atol=1e-14)
    np.testing.assert_allclose(W, -W.T, atol=1e-15)           # skew: T(s) orthogonal
    # d/ds T(s) z = W T(s) z
    e = 1e-6
    dT = (frame.apply_t(motion.omega, 0.4 + e, z) - frame.apply_t(motion.omega, 0.4 - e, z))
    np.testing.assert_allclose(dT / (2 * e), W @ frame.apply_t(motion.omega, 0.4, z),
                               atol=1e-8)


@pytest.mark.parametrize("planar", [False, True])
def test_the_fitted_rate_of_a_straight_line_of_nodes(planar):
    """A straight line of nodes turning about an axis across it: the fit gives that rate;
    the rate about the line's own axis is not seen by positions and is zero (least norm)."""
    frame = _frame(n_rot=0, planar=planar)
    X = np.array([[1.0, 0, 0], [2.0, 0, 0], [3.0, 0, 0]])
    omega = np.array([0.0, 0.0, 4.0]) if planar else np.array([0.0, 1.5, 4.0])
    x, v, _ = _rigid(frame, X, np.zeros((0, 4)), omega, np.zeros(3), np.zeros(3), 0.0)
    np.testing.assert_allclose(frame.rate(x, v).omega, omega, atol=1e-12)


@pytest.mark.parametrize("shape", ["cloud", "line", "flat", "point"])
def test_the_rate_bound_never_hides_a_rate_above_it(shape):
    """fit_above (a step's test whether its frame turns) answers None only where the fitted
    rate is at most the limit, and otherwise gives the fit itself; for a vibrating beam
    (nodes on a line, velocities across it) it decides without the eigendecomposition
    when the limit is a few times the rate."""
    rng = np.random.default_rng(7)
    n = 12
    frame = RotatingFrame(pos=np.arange(3 * n).reshape(n, 3), rot=np.zeros((0, 4), int),
                          planar=False, n_coord=3 * n, floating=False)
    decided = 0
    for _ in range(200):
        X = rng.normal(size=(n, 3)) + 5.0
        if shape == "line":
            X = np.outer(np.linspace(0, 1, n), rng.normal(size=3)) + 1e-9 * X
        elif shape == "flat":
            X[:, 2] = 2.0
        elif shape == "point":
            X = np.broadcast_to(X[0], (n, 3)).copy()
        # a rigid rate plus a deformation (a mode shape across the line)
        V = np.cross(rng.normal(size=3), X) + rng.normal(size=(n, 3)) * rng.uniform(0, 2)
        x, v = X.ravel(), V.ravel()
        omega, c, u = frame.fit(x, v)
        rate = float(np.linalg.norm(omega))
        for limit in (0.5 * rate, 0.99 * rate, 1.01 * rate, 3.0 * rate, 30.0 * rate):
            got = frame.fit_above(x, v, limit)
            if got is None:
                assert rate <= limit
                decided += limit <= 3.0 * rate
            else:
                np.testing.assert_array_equal(got[0], omega)
                np.testing.assert_array_equal(got[1], c)
    if shape == "line":
        assert decided > 0          # the bound decides where the rate is a third of it


def test_a_pinned_model_turns_about_its_screw_axis():
    """With held nodes (floating=False) the frame turns about the fitted motion's screw
    axis: a rigid rotation about an axis through a held point (a beam on a hub) is again a
    constant state of the frame, and the frame's origin lies on that axis."""
    rng = np.random.default_rng(3)
    frame = _frame()
    frame.floating = False
    X = rng.normal(size=(3, 3))
    Q = np.array([_quat(rng.normal(size=3), a) for a in (0.4, 2.0)])
    omega, pin = np.array([0.0, 1.0, 4.0]), np.array([0.3, -0.2, 0.5])
    slide = 0.7 * omega                                          # along the axis
    x0, v0, a0 = _rigid(frame, X, Q, omega, pin, slide, 0.0)
    motion = frame.rate(x0, v0)
    np.testing.assert_allclose(np.cross(motion.centre - pin, omega), 0, atol=1e-12)
    np.testing.assert_allclose(motion.velocity, slide, atol=1e-12)
    yd, ydd, _ = frame.to_frame(motion, x0, v0, a0, a0)
    np.testing.assert_allclose(yd, 0, atol=1e-12)
    np.testing.assert_allclose(ydd, 0, atol=1e-12)
    for got, want in zip(frame.from_frame(motion, 0.3, x0, 0 * x0, 0 * x0),
                         _rigid(frame, X, Q, omega, pin, slide, 0.3)):
        np.testing.assert_allclose(got, want, atol=1e-12)


def test_the_framed_newton_matrix_matches_finite_differences():
    """The spin-up model at a random state turning at 4 rad/s: the transient Newton matrix
    with the rotating frame's terms (TransientProblem.frame_terms) is the derivative of
    the residual along the frame's correction (d, (gamma' + W) d, (beta' + 2 gamma' W +
    W^2) d), to 1e-8 of its largest entry; without those terms it misses by more than
    1e-6 (measured 2.5e-6: the axial stiffness EA/l dominates the scale)."""
    import scipy.sparse as sp
    from test_transient_tangent import _newton_matrix, _residual_differences, _spinup_state

    tp, t, x, v, a, mu = _spinup_state(4)
    W = tp.frame.matrix(np.array([0.0, 0.0, 4.0]), tp.free)
    beta_p, gamma_p = 400.0, 20.0
    fd = _residual_differences(tp, t, x, v, a, mu, beta_p, gamma_p, W)
    scale = np.abs(fd).max()
    base = _newton_matrix(tp, t, x, v, a, mu, beta_p, gamma_p, True)
    c_h = []
    tp.inertia.tangent(x, v, a, gamma_p, velocity_part=c_h)
    blocks = tp.residual(t, x, v, a, mu).blocks
    framed = base + sp.csr_matrix(tp.frame_terms(blocks, c_h, W, gamma_p)).toarray()
    assert np.abs(framed - fd).max() < 1e-8 * scale
    assert np.abs(base - fd).max() > 1e-6 * scale


@pytest.mark.parametrize("shapes", [((5, 3), (5, 3)), ((3,), (7, 3)), ((4, 2, 3), (2, 3)),
                                    ((0, 3), (0, 3)), ((3,), (3,))])
def test_cross3_is_numpys_cross_bit_for_bit(shapes):
    """The frame's cross product (spacarpy.linalg.cross3) gives np.cross's bits."""
    from spacarpy.linalg import cross3
    rng = np.random.default_rng(len(shapes[0]) + 10 * shapes[1][0])
    a, b = rng.standard_normal(shapes[0]), rng.standard_normal(shapes[1])
    assert np.array_equal(cross3(a, b), np.cross(a, b))
    assert np.array_equal(cross3(b, a), np.cross(b, a))


def test_the_closed_form_rate_agrees_with_the_eigendecomposition(monkeypatch):
    """fit's rate by the adjugate where all three axes are kept (what every step of a model
    whose frame is usable computes, to add up the angle turned) equals the eigh path's to
    1e-11 relative, on random and nearly straight sets of nodes; and it is taken in most of
    the random cases (else the test would show nothing)."""
    import spacarpy.solvers.dynamics.frame as frame_mod

    rng = np.random.default_rng(1)
    fast = 0
    for k in range(600):
        n = int(rng.integers(2, 8))
        pos = np.arange(3 * n).reshape(n, 3)
        fr = frame_mod.RotatingFrame(pos=pos, rot=np.zeros((0, 4), int), planar=False,
                                     n_coord=3 * n)
        x = rng.normal(size=3 * n) * 10 ** rng.uniform(-3, 3)
        if k % 3 == 0:                                   # nearly straight
            x[pos[:, 1:]] *= 1e-3
        v = rng.normal(size=3 * n)
        got = fr.fit(x, v)[0]
        with monkeypatch.context() as m:
            m.setattr(frame_mod, "_rate_all_kept", lambda *a: None)
            ref = fr.fit(x, v)[0]
        fast += not np.array_equal(got, ref)
        assert np.linalg.norm(got - ref) <= 1e-11 * np.linalg.norm(ref) + 1e-300
    assert fast > 200
