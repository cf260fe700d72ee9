"""Inertia of the DDM beam: consistent mass matrix in nodal coordinates, vectorized.

Translational inertia (Eq. 57-59): the centre line is the cubic Hermite interpolation of the
nodal positions and the nodal tangents ``n_x^p = R(q^p) n_x``, ``n_x^q = R(q^q) n_x``:

    r(xi) = h1 r^p + l0 h2 n_x^p + h3 r^q + l0 h4 n_x^q,
    r_dot = N x_dot,   N = [h1 I, l0 h2 B^p, h3 I, l0 h4 B^q],   B = d n_x / d q,

so ``M_c = rho A l0 int_0^1 N^T N dxi``, which is Eq. (59) with the familiar 156/22/54/13
coefficients.

Rotary inertia of the cross-section (not in the paper; SPACAR's EM line): per unit length the
section has the inertia tensor, in the element axes (n_x, n_y, n_z),

    J = [[rho Ip, 0, 0], [0, rho Iy, -rho Iyz], [0, -rho Iyz, rho Iz]],

from ``EM e rhoA rho(Iy+Iz) rhoIy rhoIz rhoIyz`` (Ip = Iy + Iz, the product term enters the
tensor with a minus sign). With the body-frame angular velocity of an orientation node
``omega = 2 G(q) q_dot`` (G = [-lambda, lambda0 I - lambda~]) the rotary kinetic energy is
``1/2 sum_ab l0 c_ab omega_a^T E J E^T omega_b`` (E = [n_x n_y n_z], the element's initial
axes, carried along by each node's rotation), i.e. the 4x4 blocks ``4 l0 c_ab G_a^T E J E^T
G_b``, with the weights c of the choice ``rotary`` (:data:`ROTARY_WEIGHTS`):

- ``"lumped"`` (SPACAR's, the default): c = [[1/2, 0], [0, 1/2]]. Each end orientation node
  carries the rigid-body rotary inertia ``l0/2 E J E^T``; its convective term is the
  gyroscopic ``omega x (J omega)`` of that body.
- ``"consistent"``: c = [[1/3, 1/6], [1/6, 1/3]], the angular velocity interpolated linearly
  along the element.

Both give the same total rotary inertia ``l0 J`` of a rigid motion; they differ in how the
inertia of a deforming element is distributed (docs/linearized.md compares their
convergence).

Local coordinates as in :mod:`spacarpy.elements.beam`: ``[r^p, q^p, r^q, q^q]`` (14).
"""
from __future__ import annotations

import numpy as np

from spacarpy.elements.beam_layout import QP, QQ, RP, RQ
from spacarpy.elements.nodal import TQ_VEC, nodal_jacobians
from spacarpy.rotation import quadratic_form

#: int_0^1 h_i h_j dxi for the Hermite functions h1..h4 (Eq. 59, times 420).
HERMITE_MASS = np.array([[156.0, 22.0, 54.0, -13.0],
                         [22.0, 4.0, 13.0, -3.0],
                         [54.0, 13.0, 156.0, -22.0],
                         [-13.0, -3.0, -22.0, 4.0]]) / 420.0
#: int_0^1 N_a N_b dxi for linear interpolation.
LINEAR_MASS = np.array([[1.0 / 3.0, 1.0 / 6.0], [1.0 / 6.0, 1.0 / 3.0]])
#: The choices of the section rotary inertia (module docstring), the default first.
ROTARY_CHOICES = ("lumped", "consistent")
#: Weights c_ab (a, b = node p, q) of the section rotary inertia per choice.
ROTARY_WEIGHTS = {"lumped": np.diag([0.5, 0.5]), "consistent": LINEAR_MASS}


def rotary_weights(rotary: str) -> np.ndarray:
    """The weights c_ab of :data:`ROTARY_WEIGHTS` for the choice ``rotary``."""
    try:
        return ROTARY_WEIGHTS[rotary]
    except KeyError:
        raise ValueError(f"unknown rotary inertia {rotary!r}; expected one of "
                         f"{ROTARY_CHOICES}") from None


def g_matrix(q: np.ndarray) -> np.ndarray:
    """G(q) = [-lambda, lambda0 I - [lambda~]], shape (..., 3, 4): omega_body = 2 G q_dot;
    one product with a constant (G is linear in q, its entries are +-q_i, exactly)."""
    return (q @ _G_TENSOR).reshape(q.shape[:-1] + (3, 4))


def _g_entries(q: np.ndarray) -> np.ndarray:
    """G(q) entry by entry (for the constant of :func:`g_matrix`)."""
    l0 = q[..., 0]
    lam = q[..., 1:]
    out = np.zeros(q.shape[:-1] + (3, 4))
    out[..., :, 0] = -lam
    out[..., :, 1:] = l0[..., None, None] * np.eye(3)
    out[..., 0, 2] += lam[..., 2]
    out[..., 0, 3] -= lam[..., 1]
    out[..., 1, 1] -= lam[..., 2]
    out[..., 1, 3] += lam[..., 0]
    out[..., 2, 1] += lam[..., 1]
    out[..., 2, 2] -= lam[..., 0]
    return out


#: ``G(q) = (q @ _G_TENSOR).reshape(3, 4)`` (G is linear in q).
_G_TENSOR = np.stack([_g_entries(e).ravel() for e in np.eye(4)])


def section_inertia(mass: np.ndarray) -> np.ndarray:
    """Per-unit-length rotary inertia tensors J (n_elem, 3, 3) in element axes from EM data
    ``[rhoA, rho(Iy+Iz), rhoIy, rhoIz, rhoIyz]`` (n_elem, 5)."""
    j = np.zeros((mass.shape[0], 3, 3))
    j[:, 0, 0] = mass[:, 1]
    j[:, 1, 1] = mass[:, 2]
    j[:, 2, 2] = mass[:, 3]
    j[:, 1, 2] = j[:, 2, 1] = -mass[:, 4]
    return j


#: The Euler-parameter slots [q^p, q^q] of the 14 local coordinates.
_Q8 = np.r_[QP, QQ]
#: The constant translational blocks (positions with positions) of the mass matrix per
#: unit rho A l0: ``C_ij I`` for the Hermite functions 1 and 3.
_M_POS = np.zeros((14, 14))
for _i, _si in ((0, RP), (2, RQ)):
    for _j, _sj in ((0, RP), (2, RQ)):
        _M_POS[_si, _sj] = HERMITE_MASS[_i, _j] * np.eye(3)
#: Weights of the position-tangent blocks per unit rho A l0: rows (p, q) of the positions,
#: columns the eight Euler-parameter slots (``C_12``, ``C_14`` for p; ``C_32``, ``C_34`` for q).
_W_CROSS = np.repeat(HERMITE_MASS[np.ix_([0, 2], [1, 3])], 4, axis=1)          # (2, 8)
#: Weights of the tangent-tangent blocks per unit rho A l0^3 (``C_22, C_24, C_44``).
_W_TANGENT = np.kron(HERMITE_MASS[np.ix_([1, 3], [1, 3])], np.ones((4, 4)))    # (8, 8)


def _g_pair(q8: np.ndarray) -> np.ndarray:
    """``[G(q^p) | G(q^q)]`` (n, 3, 8) of :func:`g_matrix`, for q8 (n, 8)."""
    n = q8.shape[0]
    return (q8.reshape(2 * n, 4) @ _G_TENSOR).reshape(n, 2, 3, 4).transpose(
        0, 2, 1, 3).reshape(n, 3, 8)


#: The weights c_ab of each choice over the eight Euler-parameter slots.
_ROTARY_WEIGHTS8 = {k: np.kron(w, np.ones((4, 4))) for k, w in ROTARY_WEIGHTS.items()}


def _rotary_weights8(rotary: str) -> np.ndarray:
    """The weights c_ab of the choice ``rotary`` over the eight Euler-parameter slots."""
    rotary_weights(rotary)                                      # (the error of a bad choice)
    return _ROTARY_WEIGHTS8[rotary]


#: [2 H_k(e_j) | G]: the two maps linear in the Euler parameters that the inertia force
#: takes of each node's q and of its rate, in one product (:func:`beam_inertia_force`).
_TQ_G = np.concatenate([TQ_VEC, _G_TENSOR], axis=1)
#: The section inertia J (3x3, element axes) as a product with the EM values
#: ``[rho(Iy+Iz), rhoIy, rhoIz, rhoIyz]``: (4, 9).
_SECTION_FORMS = np.zeros((4, 3, 3))
_SECTION_FORMS[0, 0, 0] = _SECTION_FORMS[1, 1, 1] = _SECTION_FORMS[2, 2, 2] = 1.0
_SECTION_FORMS[3, 1, 2] = _SECTION_FORMS[3, 2, 1] = -1.0
_SECTION_FORMS = _SECTION_FORMS.reshape(4, 9)
#: Hermite weights of the position-tangent blocks per unit rho A l0^2: [node of the
#: position, node of the tangent] (``C_12, C_14; C_32, C_34``).
_W_RT = HERMITE_MASS[np.ix_([0, 2], [1, 3])]


def section_axes(axes: np.ndarray) -> np.ndarray:
    """The section inertia forms in initial global axes (n, 4, 9): ``E S_k E^T`` for the
    element axes ``E = [n_x n_y n_z]`` (given as rows, axes (n, 3, 3)) and the forms S_k of
    ``J = sum_k S_k [rho(Iy+Iz), rhoIy, rhoIz, rhoIyz]_k``, so that the tensor of EM values
    m is ``m[1:5] @ forms`` (one product per call; the forms are a model's constant)."""
    n = axes.shape[0]
    forms = _SECTION_FORMS.reshape(4, 3, 3) @ axes[:, None]
    return (axes.transpose(0, 2, 1)[:, None] @ forms).reshape(n, 4, 9)


def _section_global(nx, ny, nz, mass, section):
    """The section inertia tensors per unit length in initial global axes (n, 3, 3), from
    the forms of :func:`section_axes` (made here unless the caller keeps them)."""
    if section is None:
        section = section_axes(np.stack([nx, ny, nz], axis=1))
    return (mass[:, None, 1:5] @ section).reshape(-1, 3, 3)


def _tangent_jacobians(q: np.ndarray, nx: np.ndarray) -> np.ndarray:
    """``d(R(q_m) t_m)/dq_m`` (n, m, 3, 4) of the Hermite tangents of m nodes per element:
    ``t_m = n_x`` (nx (n, 3), the straight BEAM) or, for nx (n, 2, 3), the tangent of node
    p for the even m and of node q for the odd m (the curved BEAMC's arc end tangents)."""
    if nx.ndim == 2:
        return nodal_jacobians(q, nx[:, None])
    m = q.shape[1]
    both = nodal_jacobians(q, nx).reshape(q.shape[0], m, 2, 3, 4)
    return both[:, np.arange(m), np.arange(m) % 2]


def _has_rotary(mass: np.ndarray, section) -> bool:
    """Whether the rotary terms are evaluated: the caller's forms (it has checked the EM
    values), or any nonzero section inertia."""
    return section is not None or bool(np.count_nonzero(mass[:, 1:]))


def _rotary_force(g: np.ndarray, jg: np.ndarray, w: np.ndarray, c_ab: np.ndarray,
                  coef: np.ndarray) -> np.ndarray:
    """``coef sum_b c_ab G(q_a)^T J G(q_b) w_b``-type products of the rotary terms, for both
    nodes a: g (n, 2, 3, 4) the G matrices of the left factor, w (n, 2, 3, k) body
    vectors per node (angular velocities or accelerations), -> (n, 2, 4, k)."""
    n = g.shape[0]
    mixed = (c_ab @ w.reshape(n, 2, -1)).reshape(w.shape)         # sum_b c_ab w_b
    return coef[:, None, None, None] * (g.transpose(0, 1, 3, 2) @ (jg[:, None] @ mixed))


def beam_mass_matrix(x: np.ndarray, nx: np.ndarray, ny: np.ndarray, nz: np.ndarray,
                     l0: np.ndarray, mass: np.ndarray, rotary: str = "lumped",
                     section: np.ndarray | None = None) -> np.ndarray:
    """Mass matrices (n_elem, 14, 14) at configurations x (n_elem, 14): the consistent
    translational mass and the section rotary inertia of the choice ``rotary``.

    With ``N = [h1 I, l0 h2 B^p, h3 I, l0 h4 B^q]`` the translational mass ``rho A l0 N^T C
    N`` has constant position blocks ``C_ij I``, position-tangent blocks ``C_ij l0 B`` and
    tangent blocks ``C_ij l0^2 B_a^T B_b``: those are formed directly, the tangent ones and
    the rotary blocks ``4 l0 c_ab G_a^T J G_b`` as one 8x8 product over both nodes.

    Parameters
    ----------
    nx, ny, nz : (n_elem, 3)
        Reference triads; nx (n_elem, 2, 3): the Hermite tangents of nodes p and q apart
        (the curved BEAMC, :mod:`spacarpy.elements.beamc`; then l0 is the arc length).
    l0 : (n_elem,)
    mass : (n_elem, 5)
        EM data ``rhoA, rho(Iy+Iz), rhoIy, rhoIz, rhoIyz`` (kg/m, kg m).
    rotary : str
        ``"lumped"`` or ``"consistent"`` (:data:`ROTARY_WEIGHTS`).
    section : (n_elem, 4, 9), optional
        :func:`section_axes` of the element axes, when the caller keeps them (then the
        rotary terms are evaluated whatever the EM values).
    """
    wr = _rotary_weights8(rotary)
    n = x.shape[0]
    q2 = x.reshape(n, 2, 7)[:, :, 3:]
    ra = mass[:, 0] * l0                                        # rho A l0
    lb = _tangent_jacobians(q2, nx) * l0[:, None, None, None]   # l0 B (n, 2, 3, 4)
    m = ra[:, None, None] * _M_POS
    m4 = m.reshape(n, 2, 7, 2, 7)
    # position rows of node a, tangent columns of node b: C_(a, b) rho A l0 (l0 B_b)
    cross = _W_RT[:, None, :, None] * lb.transpose(0, 2, 1, 3)[:, None]    # (n, 2, 3, 2, 4)
    cross *= ra[:, None, None, None, None]
    m4[:, :, :3, :, 3:] = cross
    m4[:, :, 3:, :, :3] = cross.transpose(0, 3, 4, 1, 2)
    bt = lb.transpose(0, 1, 3, 2).reshape(n, 8, 3)
    qq = (bt @ bt.transpose(0, 2, 1)) * _W_TANGENT
    qq *= ra[:, None, None]
    if _has_rotary(mass, section):
        g = _g_pair(x[:, _Q8])
        jg = _section_global(nx, ny, nz, mass, section)
        qq += (4.0 * l0)[:, None, None] * wr * (g.transpose(0, 2, 1) @ (jg @ g))
    m4[:, :, 3:, :, 3:] = qq.reshape(n, 2, 4, 2, 4)
    return m


def beam_inertia_force(x: np.ndarray, v: np.ndarray, a: np.ndarray, nx: np.ndarray,
                       ny: np.ndarray, nz: np.ndarray, l0: np.ndarray, mass: np.ndarray,
                       rotary: str = "lumped", section: np.ndarray | None = None
                       ) -> np.ndarray:
    """The inertia force ``M a + h`` (n_elem, 14) of Eq. 60 at (x, v, a), without forming M.

    Translation: with ``N`` as in :func:`beam_mass_matrix`, ``dN/dt`` has the tangent rows
    ``l0 B(v_q)`` (B is linear in q), and Lagrange's equations of ``T = 1/2 rho A l0 (N
    v)^T C (N v)`` give ``rho A l0 N^T C (N a + (dN/dt) v)``: the gradient part of h cancels
    the ``(dN/dt)^T C N v`` of ``d/dt (dT/dv)`` (so the two parts of
    :func:`beam_convective` are not needed for the force). Rotation: with ``omega_b = G(q_b)
    v_b`` and ``G(q) dq = -G(dq) q``, node a receives ``4 l0 sum_b c_ab (G_a^T J G_b a_b +
    2 G(v_a)^T J omega_b)`` (for the lumped weights the rigid body's ``J alpha + omega x J
    omega`` mapped onto its Euler parameters). ``section`` as for :func:`beam_mass_matrix`."""
    n = x.shape[0]
    x2, v2, a2 = x.reshape(n, 2, 7), v.reshape(n, 2, 7), a.reshape(n, 2, 7)
    q4 = np.concatenate([x2[:, :, 3:], v2[:, :, 3:]], axis=1)  # q^p q^q v^p v^q (n, 4, 4)
    rotary_on = _has_rotary(mass, section)
    # the maps linear in q of all four: 2 H_k(e_j) q (for B) and, with rotary inertia, G
    lin = q4.reshape(4 * n, 4) @ (_TQ_G if rotary_on else TQ_VEC)
    t4 = nx[:, None, None] if nx.ndim == 2 else nx[:, [0, 1, 0, 1], None]
    b = (t4 @ lin[:, :36].reshape(n, 4, 3, 12)).reshape(n, 4, 3, 4)
    if rotary_on:
        # B(q), G(q) and B(v) applied to [v_q, a_q] of both nodes in one product
        g = lin[:, 36:].reshape(n, 4, 3, 4)
        mats = np.concatenate([b[:, :2], g[:, :2], b[:, 2:]], axis=2)   # (n, 2, 9, 4)
        prod = mats @ np.stack([v2[:, :, 3:], a2[:, :, 3:]], axis=3)   # (n, 2, 9, 2)
        t = prod[:, :, :3, 1] + prod[:, :, 6:, 0]
    else:
        t = (b[:, :2] @ a2[:, :, 3:, None] + b[:, 2:] @ v2[:, :, 3:, None])[..., 0]
    # N a + (dN/dt) v per Hermite function: [a_r^p, l0 t^p, a_r^q, l0 t^q] (n, 4, 3), with
    # t = B(q) a_q + B(v_q) v_q
    z = np.empty((n, 2, 2, 3))
    z[:, :, 0] = a2[:, :, :3]
    np.multiply(t, l0[:, None, None], out=z[:, :, 1])
    w = (z.reshape(n, 4, 3).transpose(0, 2, 1) @ HERMITE_MASS)      # C z (n, 3, 4)
    w *= (mass[:, 0] * l0)[:, None, None]
    w = w.transpose(0, 2, 1).reshape(n, 2, 2, 3)                # [node, (position, tangent)]
    f = np.empty((n, 14))
    f2 = f.reshape(n, 2, 7)
    f2[:, :, :3] = w[:, :, 0]
    if not rotary_on:
        fq = (b[:, :2].transpose(0, 1, 3, 2) @ w[:, :, 1, :, None])[..., 0]
        np.multiply(fq, l0[:, None, None], out=f2[:, :, 3:])
        return f
    c_ab = rotary_weights(rotary)
    jg = _section_global(nx, ny, nz, mass, section)
    # body angular velocity and acceleration of both nodes (G(q) [v_q, a_q]), mixed by
    # c_ab, times J; then l0 B^T (C z)_tangent + 4 l0 (G(q)^T J alpha + 2 G(v)^T J omega)
    # as one product of the stacked vectors with [B(q); G(q); G(v)]
    oa = prod[:, :, 3:6]                                          # (n, 2, 3, 2)
    joa = jg[:, None] @ (c_ab @ oa.reshape(n, 2, 6)).reshape(n, 2, 3, 2)
    l4 = (4.0 * l0)[:, None, None]
    rhs = np.concatenate([w[:, :, 1] * l0[:, None, None], joa[..., 1] * l4,
                          joa[..., 0] * (2.0 * l4)], axis=2)       # (n, 2, 9)
    left = np.concatenate([b[:, :2], g[:, :2], g[:, 2:]], axis=2)   # (n, 2, 9, 4)
    f2[:, :, 3:] = (rhs[:, :, None] @ left)[:, :, 0]
    return f


def beam_convective(x: np.ndarray, v: np.ndarray, nx: np.ndarray, ny: np.ndarray,
                    nz: np.ndarray, l0: np.ndarray, mass: np.ndarray, rotary: str = "lumped",
                    section: np.ndarray | None = None):
    """``(dM/dt v, d(v^T M v)/dx)``, both (n_elem, 14), of :func:`beam_mass_matrix` (with the
    same ``rotary``) at velocities v: the two parts of the convective term
    ``h = dM/dt v - grad/2`` of Eq. 60.

    Differencing M would cost 2 mass-matrix evaluations per Euler parameter. Analytically
    (M depends on the Euler parameters only):

    - translation: ``M_c = rho A l0 N^T C N`` with ``C`` the Hermite coefficients and the
      tangent rows of ``N`` equal to ``l0 B = l0 2 H_k(n_x) q``, linear in q. With
      ``u = N v``, ``w = C u``, ``u' = dN/dt v`` (tangent rows ``2 l0 v_q^T H_k v_q``) and
      ``w' = C u'``: ``v^T M v = rho A l0 u.w``, its q-gradient is
      ``2 rho A l0 (dN/dq v)^T w = 2 rho A l0^2 * 2 sum_k w_k H_k v_q``, and
      ``dM/dt v = rho A l0 ((dN/dt)^T w + N^T w')``;
    - rotation: ``omega_a = G(q_a) v_a``, ``G(q) p = -G(p) q`` and ``G(p) p = 0``, so the
      q-gradient of ``sum_ab 4 l0 c_ab omega_a^T J omega_b`` is
      ``-8 l0 sum_b c_ab G(v_a)^T J omega_b`` and ``dM/dt v`` is minus half of it. For the
      lumped weights that is, node by node, the gyroscopic term ``omega x (J omega)`` of a
      rigid body mapped onto the Euler parameters.

    ``section`` as for :func:`beam_mass_matrix`.
    """
    c_ab = rotary_weights(rotary)
    n = x.shape[0]
    v2 = v.reshape(n, 2, 7)
    vq2 = v2[:, :, 3:]
    q4 = np.concatenate([x.reshape(n, 2, 7)[:, :, 3:], vq2], axis=1)    # q^p q^q v^p v^q
    b = _tangent_jacobians(q4, nx)                              # B(q), dB/dt (n, 4, 3, 4)
    # u = N v and u' = dN/dt v per Hermite function, side by side: (n, 2 [u, u'], 4, 3)
    uu = np.zeros((n, 2, 2, 2, 3))
    uu[:, 0, :, 0] = v2[:, :, :3]
    tv = (b @ np.concatenate([vq2, vq2], axis=1)[..., None])[..., 0]   # (n, 4, 3)
    tv *= l0[:, None, None]
    uu[:, :, :, 1] = tv.reshape(n, 2, 2, 3)
    ra = mass[:, 0] * l0                                         # rho A l0
    ww = (uu.reshape(n, 2, 4, 3).transpose(0, 1, 3, 2) @ HERMITE_MASS)   # C u, C u' (n,2,3,4)
    ww *= ra[:, None, None, None]
    # (dN/dq v)^T w and N^T w' on the tangent rows: B(v)^T w_t, B(q)^T w'_t (times l0)
    wt = ww[:, ::-1, :, 1::2].transpose(0, 1, 3, 2).reshape(n, 4, 1, 3)   # w'_t p q, w_t p q
    bt = (wt @ b)[:, :, 0]                                       # B(q)^T w'_t, B(v)^T w_t
    bt *= l0[:, None, None]
    grad, mdot = np.zeros((n, 14)), np.empty((n, 14))
    g2, m2 = grad.reshape(n, 2, 7), mdot.reshape(n, 2, 7)
    np.multiply(bt[:, 2:], 2.0, out=g2[:, :, 3:])
    np.add(bt[:, 2:], bt[:, :2], out=m2[:, :, 3:])
    m2[:, :, :3] = ww[:, 1, :, 0::2].transpose(0, 2, 1)
    if _has_rotary(mass, section):
        jg = _section_global(nx, ny, nz, mass, section)
        g = (q4.reshape(4 * n, 4) @ _G_TENSOR).reshape(n, 4, 3, 4)
        om = g[:, :2] @ vq2[..., None]                           # (n, 2, 3, 1)
        rot = _rotary_force(g[:, 2:], jg, om, c_ab, 8.0 * l0)[..., 0]
        g2[:, :, 3:] -= rot
        m2[:, :, 3:] += 0.5 * rot
    return mdot, grad


def nodal_rotary_mass(q: np.ndarray, inertia: np.ndarray) -> np.ndarray:
    """4x4 mass blocks ``4 G^T J G`` of orientation nodes: q (n, 4), inertia (n, 3, 3)."""
    g = g_matrix(q)
    return 4.0 * g.transpose(0, 2, 1) @ inertia @ g


def tangent_gravity(q: np.ndarray, nx: np.ndarray, g: np.ndarray, coef: np.ndarray):
    """Force ``coef * B^T g`` on the Euler parameters of a node whose tangent ``n_x = R(q) n_x``
    carries mass, with ``B = d n_x / d q = 2 H(n_x) q``, and its derivative ``2 coef H.g``."""
    hg = np.einsum("nkab,k->nab", quadratic_form(nx), g)       # (n, 4, 4): sum_k g_k H_k
    return 2.0 * coef[:, None] * (hg @ q[..., None])[..., 0], 2.0 * coef[:, None, None] * hg
