"""The channel and the contact model of the FIS catheter decks (fis_rig_cat_s_3d.dat and
fis_flex_cat_s_3d.dat of ../shared/spacar-decks), written for spacarpy's USERSIG/USERINP
convention from the physics their source describes (Straathof et al., "Multibody dynamic
modelling of the behaviour of flexible instruments used in cervical cancer brachytherapy";
repository roepnaamstraat/FlexibleInstrumentSimulation). docs/user-routines.md explains it.

The model
---------
A catheter of outer radius ``ro`` is pushed at its proximal node (49) along +x into a rigid
S-shaped channel of radius ``rb``. The channel's centreline is a polyline of 5N + 1 points
along five pieces of a curve of constant curvature and torsion: a straight start, an arc of
angle t1 and radius r, a straight piece of length d2 turning the frame by pi about the
tangent (so that the next arc bends back), a second arc, and a straight end; d2 and t1 make
the S span the width ``w`` over the height ``ht``.

Each position node of the catheter (not the driven one) meets the wall through a penalty
force on its distance d from the centreline, with a transition zone between ``a = ra - ro``
and ``b = rb - ro`` (xi = (d - a)/(b - a)):

    zone I    d < a       no contact
    zone II   a <= d < b  fn = k (b - a) xi^2 / 2 + c (3 - 2 xi) xi^2 vn
    zone III  d >= b      fn = k (b - a) (xi - 1/2) + c vn

(continuous with its slope; vn the node's velocity along the outward normal n). Friction
acts against the slip velocity of the contact point (the node's tangential velocity plus
omega x ro n; vt its size, t its direction), with a Stribeck peak mu_s at the breakaway
velocity v_brk above the Coulomb level mu_k:

    ff = sqrt(2 e) (mu_s - mu_k) fn exp(-u^2) u + mu_k fn tanh(10 vt / v_brk),
    u = vt / (v_brk sqrt 2)

The node gets F = -fn n - ff t and its orientation node the moment (ro n) x F (as Euler
parameter forces 2 Lambda(q)^T M). The run is sped up: the insertion runs ``vel_ratio``
times faster than the real one (0.1 m/s simulated for 5 mm/s), so the velocities entering
damping and friction are divided by it. At the tip, where the surface point facing the wall
lies on the rounded end, the radius in the wall's direction is ro times the sine of the
angle between the tip's axis and n.

Where this differs from the MATLAB routines: they read the parameters from .bin files the
driver script writes (here they are constants below, the driver's values), find the nearest
point with a third-party curve-distance function (here: the exact nearest point of the
polyline), zero a node's whole load when its slip direction is undefined (here only the
friction, whose limit at zero slip is zero), and keep the tip's reduced radius for every
later node of the loop (here the tip alone, as their comment says). The slip direction is
the contact point's (the node's velocity alone gave a friction that jumped where the node
stopped and the section still turned: the flexible deck's Newton iterations stalled there,
after the insertion stops at t = 0.6 s).
"""
from __future__ import annotations

import math

import numpy as np

# the driver script's parameters (m, N/m, N s/m, m/s)
STIFFNESS = 1.0e6          # wall stiffness
DAMPING = 10.0             # wall damping coefficient
MU_STATIC = 0.094          # static friction coefficient
MU_KINETIC = 0.074         # kinetic friction coefficient
V_BREAKAWAY = 0.001        # breakaway velocity
R_OUTER = 0.00099          # outer radius of the catheter
V_REAL = 0.005             # real insertion velocity
V_SIM = 0.1                # simulated insertion velocity
N_POINTS = 20              # centreline points per piece
X_START = -0.19            # x of the channel's start
D1, D3 = 0.01, 0.03        # lengths of the first and last straight pieces
R_A, R_B = 0.0012, 0.0013  # inner and outer radius of the transition zone
TORSION = 0.0              # geometric torsion of the middle piece
R_CURVE = 0.05             # radius of the arcs
WIDTH, HEIGHT = 0.03, 0.12  # width and height of the S
DEPTH = 0.12               # insertion depth
X_INPUT = -0.12            # the driven node's initial x


def s_shape(r=R_CURVE, w=WIDTH, ht=HEIGHT, d1=D1, d3=D3):
    """(d2, t1): the middle piece's length and the arcs' angle of the S, the solution of
    d2 sin t1 + 2 r (1 - cos t1) = w, d1 + d3 + d2 cos t1 + 2 r sin t1 = ht with the larger
    d2. Eliminating d2: (w - 2r) cos t1 - H sin t1 + 2r = 0, H = ht - d1 - d3."""
    h = ht - d1 - d3
    amp, phase = math.hypot(w - 2 * r, h), math.atan2(-h, w - 2 * r)
    best = None
    for sign in (1.0, -1.0):
        t1 = phase + sign * math.acos(-2 * r / amp)
        t1 = math.atan2(math.sin(t1), math.cos(t1))
        s, c = math.sin(t1), math.cos(t1)
        d2 = (w - 2 * r * (1 - c)) / s if abs(s) > abs(c) else (h - 2 * r * s) / c
        if best is None or d2 > best[0]:
            best = (d2, t1)
    return best


def _step(pose, length, curvature, twist):
    """The pose (4x4) after an arc of ``length`` with ``curvature`` about the local z axis and
    ``twist`` (rad per m) about the local x axis (the tangent): the exponential of the
    constant twist, exact also for a straight piece."""
    w = np.array([length * twist, 0.0, length * curvature])      # rotation vector
    v = np.array([length, 0.0, 0.0])
    th = float(np.linalg.norm(w))
    k = np.array([[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]])
    if th < 1e-12:
        rot, trans = np.eye(3) + k, v
    else:
        rot = np.eye(3) + math.sin(th) / th * k + (1 - math.cos(th)) / th**2 * k @ k
        # translation of the screw motion: V v with V the left Jacobian of SO(3)
        jac = np.eye(3) + (1 - math.cos(th)) / th**2 * k + (th - math.sin(th)) / th**3 * k @ k
        trans = jac @ v
    step = np.eye(4)
    step[:3, :3], step[:3, 3] = rot, trans
    return pose @ step


def centreline(n=N_POINTS):
    """The channel's centreline: (5n + 1, 3) points from (X_START, 0, 0)."""
    d2, t1 = s_shape()
    pieces = [((-X_START + D1) / n, 0.0, 0.0), (t1 * R_CURVE / n, 1 / R_CURVE, 0.0),
              (d2 / n, 0.0, (math.pi - TORSION) / d2), (t1 * R_CURVE / n, 1 / R_CURVE, 0.0),
              (D3 / n, 0.0, 0.0)]
    pose = np.eye(4)
    pose[0, 3] = X_START
    points = [pose[:3, 3].copy()]
    for length, curvature, twist in pieces:
        for _ in range(n):
            pose = _step(pose, length, curvature, twist)
            points.append(pose[:3, 3].copy())
    return np.array(points)


CENTRELINE = centreline()


def nearest(points, line=CENTRELINE, near=None):
    """(nearest points (k, 3), distances (k,), segment indices (k,)) of ``points`` on the
    polyline ``line``; with ``near`` (k,) segment indices, among those segments and their
    neighbours only (points that moved little since ``near`` was found)."""
    a, b = line[:-1], line[1:]
    if near is None:
        cand = np.broadcast_to(np.arange(a.shape[0]), (points.shape[0], a.shape[0]))
    else:
        cand = np.clip(np.asarray(near)[:, None] + np.arange(-1, 2), 0, a.shape[0] - 1)
    a, ab = a[cand], (b - a)[cand]                            # (k, m, 3)
    rel = points[:, None, :] - a
    s = np.clip(np.einsum("kmi,kmi->km", rel, ab) / np.einsum("kmi,kmi->km", ab, ab),
                0.0, 1.0)
    diff = rel - s[..., None] * ab
    dist2 = np.einsum("kmi,kmi->km", diff, diff)
    k = dist2.argmin(axis=1)
    rows = np.arange(points.shape[0])
    return (points - diff[rows, k], np.sqrt(dist2[rows, k]), cand[rows, k])


def _cross(a, b):
    """Row-wise cross products of (k, 3) arrays (np.cross's axis handling costs more)."""
    return np.stack([a[..., 1] * b[..., 2] - a[..., 2] * b[..., 1],
                     a[..., 2] * b[..., 0] - a[..., 0] * b[..., 2],
                     a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]], axis=-1)


def _unit(v):
    n = np.linalg.norm(v, axis=-1, keepdims=True)
    return np.divide(v, n, out=np.zeros_like(v), where=n > 0)


def angular_velocity(q, qd):
    """omega = 2 Lambda(q) q' (global axes) for Euler parameters q and rates qd, (k, 4)."""
    return 2.0 * (-qd[:, :1] * q[:, 1:] + q[:, :1] * qd[:, 1:] + _cross(q[:, 1:], qd[:, 1:]))


def euler_forces(q, m):
    """2 Lambda(q)^T M for moments m (k, 3): the generalized forces on the Euler parameters."""
    return 2.0 * np.concatenate([-(q[:, 1:] * m).sum(-1, keepdims=True),
                                 q[:, :1] * m - _cross(q[:, 1:], m)], axis=1)


def normal_force(d, vn, a, b):
    """The wall's normal force (N) at distance d (m) from the centreline, normal velocity vn
    (m/s, real time) and transition zone [a, b] (arrays)."""
    xi = (d - a) / (b - a)
    zone2 = STIFFNESS / 2 * (b - a) * xi**2 + DAMPING * (3 - 2 * xi) * xi**2 * vn
    zone3 = STIFFNESS * (b - a) * (xi - 0.5) + DAMPING * vn
    return np.where(d < a, 0.0, np.where(d < b, zone2, zone3))


def friction_force(fn, vt):
    """The friction force (N) against a slip velocity vt (m/s, real time) under normal force
    fn: a Stribeck peak (mu_s - mu_k) fn at vt = V_BREAKAWAY over regularized Coulomb."""
    u = vt / (V_BREAKAWAY * math.sqrt(2))
    return (math.sqrt(2 * math.e) * (MU_STATIC - MU_KINETIC) * fn * np.exp(-u * u) * u
            + MU_KINETIC * fn * np.tanh(vt / (V_BREAKAWAY / 10)))


def contact_loads(pos, nxt, vel, q, qd, vel_ratio, tip, near=None, distance=False):
    """The wall's force (k, 3) on position nodes at ``pos`` (velocities ``vel``, m/s of the
    run) and the Euler-parameter forces (k, 4) on their orientation nodes (``q``, ``qd``);
    ``nxt`` the next position node's coordinates, which set the axis of the rows ``tip``
    (bool, k) whose radius towards the wall is reduced; ``near``: the centreline segments
    near which the nodes lie (:func:`nearest`), if known; with ``distance`` also the nodes'
    distances from the centreline."""
    vel = vel / vel_ratio
    omega = angular_velocity(q, qd) / vel_ratio
    foot, d, _ = nearest(pos, near=near)
    n = _unit(pos - foot)                                    # outward normal
    vn = (vel * n).sum(-1)
    ro = np.full(pos.shape[0], R_OUTER)
    if tip.any():
        axis = _unit(nxt[tip] - pos[tip])                    # the tip's axis
        perp = _unit(_cross(_cross(axis, n[tip]), axis))     # n's part across the axis
        ro[tip] = (perp * n[tip]).sum(-1) * R_OUTER
    a, b = R_A - ro, R_B - ro
    # the contact point's slip: its velocity across n (omega x ro n is across n already);
    # friction acts against it, ff(|slip|) slip/|slip|, smooth through zero slip (ff is odd)
    slip = vel - vn[:, None] * n + _cross(omega, ro[:, None] * n)
    vt = np.linalg.norm(slip, axis=-1)
    t = _unit(slip)                                          # slip direction
    fn = normal_force(d, vn, a, b)
    ff = friction_force(fn, vt)
    force = -fn[:, None] * n - ff[:, None] * t
    moment = _cross(ro[:, None] * n, force)
    if distance:
        return force, euler_forces(q, moment), d
    return force, euler_forces(q, moment)


#: The difference quotients' steps of :func:`contact_derivatives`: positions (m), Euler
#: parameters, velocities (m/s of the run), Euler-parameter rates (1/s).
FD_STEPS = (1e-9, 1e-8, 1e-8, 1e-7)


def contact_derivatives(pos, nxt, vel, q, qd, vel_ratio, tip):
    """The derivatives of :func:`contact_loads`' 7 outputs (force x, y, z, then the Euler-
    parameter forces) of each row with respect to its own inputs, by central differences
    of all rows at once (each row's loads depend on its own inputs only): ``(d/dx (k, 7,
    10), d/dxd (k, 7, 7))``, the inputs ``[pos, q, nxt]`` and ``[vel, qd]``."""
    k = pos.shape[0]
    base = np.concatenate([pos, q, nxt, vel, qd], axis=1)          # (k, 17)
    steps = np.repeat([FD_STEPS[0], FD_STEPS[1], FD_STEPS[0], FD_STEPS[2], FD_STEPS[3]],
                      [3, 4, 3, 3, 4])
    m = base.shape[1]
    z = np.repeat(base[None], 2 * m, axis=0)                       # (2m, k, 17)
    cols = np.arange(m)
    z[cols, :, cols] += steps[:, None]
    z[m + cols, :, cols] -= steps[:, None]
    z = z.reshape(2 * m * k, m)
    near = np.tile(nearest(pos)[2], 2 * m)      # (the perturbations move nodes by 1e-9 m)
    force, gen = contact_loads(z[:, :3], z[:, 7:10], z[:, 10:13], z[:, 3:7], z[:, 13:],
                               vel_ratio, np.tile(tip, 2 * m), near)
    out = np.concatenate([force, gen], axis=1).reshape(2, m, k, 7)
    jac = ((out[0] - out[1]) / (2 * steps[:, None, None])).transpose(1, 2, 0)   # (k, 7, m)
    return jac[:, :, :10], jac[:, :, 10:]


def contact_rows(state, nodes, stride, vel_ratio):
    """USERSIG rows ``[node, direction, value]`` of the wall's contact on the position nodes
    ``nodes`` (the tip first); the next position node is ``node + stride``, the orientation
    node ``node + 1``. Where the solver asks for them (``state.derivatives``), also the
    derivative rows ``[node, direction, wrt_node, wrt_direction, d/dx, d/dxd]``."""
    nodes = np.asarray(nodes)
    pos = np.asarray(state.x[nodes], dtype=float)
    nxt = np.asarray(state.x[nodes + stride], dtype=float)
    vel = np.asarray(state.xd[nodes], dtype=float)
    q = np.asarray(state.x[nodes + 1], dtype=float)
    qd = np.asarray(state.xd[nodes + 1], dtype=float)
    tip = np.zeros(nodes.size, dtype=bool)
    tip[0] = True
    force, gen, d = contact_loads(pos, nxt, vel, q, qd, vel_ratio, tip, distance=True)
    out_node = np.repeat([[0, 0, 0, 1, 1, 1, 1]], nodes.size, axis=0) + nodes[:, None]
    out_dir = np.tile([1, 2, 3, 1, 2, 3, 4], (nodes.size, 1))
    rows = np.column_stack([out_node.ravel(), out_dir.ravel(),
                            np.concatenate([force, gen], axis=1).ravel()])
    if not getattr(state, "derivatives", False):
        return rows
    # only the nodes near the wall have loads that change (zone I, d < a, has none; the
    # difference steps move a node by 1e-9 m)
    touch = d >= R_A - R_OUTER - 1e-6
    dx = np.zeros((nodes.size, 7, 10))
    dv = np.zeros((nodes.size, 7, 7))
    if touch.any():
        dx[touch], dv[touch] = contact_derivatives(pos[touch], nxt[touch], vel[touch],
                                                   q[touch], qd[touch], vel_ratio, tip[touch])
    # the inputs' coordinates: [pos 1-3, q 1-4, nxt 1-3]; the rates those of pos and q
    wrt_node = np.concatenate([np.repeat(nodes[:, None], 3, 1),
                               np.repeat(nodes[:, None] + 1, 4, 1),
                               np.repeat(nodes[:, None] + stride, 3, 1)], axis=1)  # (k, 10)
    wrt_dir = np.tile([1, 2, 3, 1, 2, 3, 4, 1, 2, 3], (nodes.size, 1))
    d_dxd = np.concatenate([dv, np.zeros((nodes.size, 7, 3))], axis=2)     # (k, 7, 10)
    shape = (nodes.size, 7, 10)
    drows = np.column_stack([np.broadcast_to(out_node[:, :, None], shape).ravel(),
                             np.broadcast_to(out_dir[:, :, None], shape).ravel(),
                             np.broadcast_to(wrt_node[:, None, :], shape).ravel(),
                             np.broadcast_to(wrt_dir[:, None, :], shape).ravel(),
                             dx.ravel(), d_dxd.ravel()])
    drows = drows[(drows[:, 4] != 0) | (drows[:, 5] != 0)]
    return rows, drows


def insertion(t, node, t_end, speed, x0=X_INPUT):
    """USERINP rows ``[node, 1, x, x', x'']``: node pushed along x at ``speed`` until
    ``t_end``, then held where it arrived."""
    if t <= t_end:
        return [[node, 1, x0 + speed * t, speed, 0.0]]
    return [[node, 1, x0 + speed * t_end, 0.0, 0.0]]
