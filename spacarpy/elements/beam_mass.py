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
from spacarpy.rotation import quadratic_form, vector_jacobians

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
    """G(q) = [-lambda, lambda0 I - [lambda~]], shape (..., 3, 4): omega_body = 2 G q_dot."""
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
_G_TENSOR = np.stack([g_matrix(e).ravel() for e in np.eye(4)])


def _twice_h_times(hx: np.ndarray, q: np.ndarray) -> np.ndarray:
    """``2 H_k(n_x) q`` (n, 3, 4) for the quadratic forms hx (n, 3, 4, 4): the derivative
    ``d n_x / d q`` at q, or ``d/dt`` of it for q a velocity."""
    return 2.0 * (hx @ q[:, None, :, None])[..., 0]


def _global_section_inertia(nx, ny, nz, mass) -> np.ndarray:
    """The section inertia tensors per unit length (n, 3, 3) in initial global axes."""
    e = np.stack([nx, ny, nz], axis=2)                          # columns n_x n_y n_z
    return e @ section_inertia(mass) @ e.transpose(0, 2, 1)


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


def _tangent_jacobians(q8: np.ndarray, nx: np.ndarray) -> np.ndarray:
    """``B = d n_x / d q = 2 H(n_x) q`` of both nodes side by side, (n, 3, 8), for the
    Euler parameters q8 = [q^p, q^q] (n, 8): B is linear in q, so at a velocity it is
    ``dB/dt``."""
    n = q8.shape[0]
    b = vector_jacobians(q8.reshape(2 * n, 4), np.repeat(nx, 2, axis=0)[:, None, :])
    return b.reshape(n, 2, 3, 4).transpose(0, 2, 1, 3).reshape(n, 3, 8)


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


def beam_mass_matrix(x: np.ndarray, nx: np.ndarray, ny: np.ndarray, nz: np.ndarray,
                     l0: np.ndarray, mass: np.ndarray, rotary: str = "lumped") -> np.ndarray:
    """Mass matrices (n_elem, 14, 14) at configurations x (n_elem, 14): the consistent
    translational mass and the section rotary inertia of the choice ``rotary``.

    With ``N = [h1 I, l0 h2 B^p, h3 I, l0 h4 B^q]`` the translational mass ``rho A l0 N^T C
    N`` has constant position blocks ``C_ij I``, position-tangent blocks ``C_ij l0 B`` and
    tangent blocks ``C_ij l0^2 B_a^T B_b``: those are formed directly, the tangent ones and
    the rotary blocks ``4 l0 c_ab G_a^T J G_b`` as one 8x8 product over both nodes.

    Parameters
    ----------
    nx, ny, nz : (n_elem, 3)
        Reference triads.
    l0 : (n_elem,)
    mass : (n_elem, 5)
        EM data ``rhoA, rho(Iy+Iz), rhoIy, rhoIz, rhoIyz`` (kg/m, kg m).
    rotary : str
        ``"lumped"`` or ``"consistent"`` (:data:`ROTARY_WEIGHTS`).
    """
    wr = _rotary_weights8(rotary)
    q8 = x[:, _Q8]
    ra = mass[:, 0] * l0                                        # rho A l0
    lb = _tangent_jacobians(q8, nx) * l0[:, None, None]         # (n, 3, 8): l0 B
    m = ra[:, None, None] * _M_POS
    cross = ra[:, None, None, None] * (_W_CROSS[:, None, :] * lb[:, None])   # (n, 2, 3, 8)
    m[:, RP, _Q8] = cross[:, 0]
    m[:, RQ, _Q8] = cross[:, 1]
    m[:, _Q8, RP] = cross[:, 0].transpose(0, 2, 1)
    m[:, _Q8, RQ] = cross[:, 1].transpose(0, 2, 1)
    qq = ra[:, None, None] * _W_TANGENT * (lb.transpose(0, 2, 1) @ lb)
    if np.any(mass[:, 1:]):
        g = _g_pair(q8)
        jg = _global_section_inertia(nx, ny, nz, mass)
        qq += (4.0 * l0)[:, None, None] * wr * (g.transpose(0, 2, 1) @ (jg @ g))
    m[:, _Q8[:, None], _Q8] = qq
    return m


def beam_inertia_force(x: np.ndarray, v: np.ndarray, a: np.ndarray, nx: np.ndarray,
                       ny: np.ndarray, nz: np.ndarray, l0: np.ndarray, mass: np.ndarray,
                       rotary: str = "lumped") -> np.ndarray:
    """The inertia force ``M a + h`` (n_elem, 14) of Eq. 60 at (x, v, a), without forming M.

    Translation: with ``N`` as in :func:`beam_mass_matrix`, ``dN/dt`` has the tangent rows
    ``l0 B(v_q)`` (B is linear in q), and Lagrange's equations of ``T = 1/2 rho A l0 (N
    v)^T C (N v)`` give ``rho A l0 N^T C (N a + (dN/dt) v)``: the gradient part of h cancels
    the ``(dN/dt)^T C N v`` of ``d/dt (dT/dv)`` (so the two parts of
    :func:`beam_convective` are not needed for the force). Rotation: with ``omega_b = G(q_b)
    v_b`` and ``G(q) dq = -G(dq) q``, node a receives ``4 l0 sum_b c_ab (G_a^T J G_b a_b +
    2 G(v_a)^T J omega_b)`` (for the lumped weights the rigid body's ``J alpha + omega x J
    omega`` mapped onto its Euler parameters)."""
    n = x.shape[0]
    q8, v8, a8 = x[:, _Q8], v[:, _Q8], a[:, _Q8]
    ra = mass[:, 0] * l0
    lc = l0[:, None]
    b = _tangent_jacobians(np.concatenate([q8, v8]), np.concatenate([nx, nx]))
    bq, bv = b[:n], b[n:]                                       # B, dB/dt (n, 3, 8)
    # N a + (dN/dt) v per Hermite function (n, 3, 4), then C times it
    tang = (bq * a8[:, None, :] + bv * v8[:, None, :]).reshape(n, 3, 2, 4).sum(axis=3)
    z = np.stack([a[:, RP], lc * tang[:, :, 0], a[:, RQ], lc * tang[:, :, 1]], axis=2)
    w = (z @ HERMITE_MASS) * ra[:, None, None]
    f = np.empty((n, 14))
    f[:, RP] = w[:, :, 0]
    f[:, RQ] = w[:, :, 2]
    f[:, _Q8] = lc * np.einsum("nkj,nkj->nj", bq,
                               np.repeat(w[:, :, [1, 3]], 4, axis=2))
    if np.any(mass[:, 1:]):
        c_ab = rotary_weights(rotary)
        jg = _global_section_inertia(nx, ny, nz, mass)
        g = _g_pair(np.concatenate([q8, v8]))
        gq, gv = g[:n].reshape(n, 3, 2, 4), g[n:].reshape(n, 3, 2, 4)
        # body angular velocity and acceleration of both nodes (n, 3, 2)
        om = np.einsum("nkbj,nbj->nkb", gq, v8.reshape(n, 2, 4))
        al = np.einsum("nkbj,nbj->nkb", gq, a8.reshape(n, 2, 4))
        jom, jal = jg @ (om @ c_ab.T), jg @ (al @ c_ab.T)       # sum_b c_ab J (.)_b
        f[:, _Q8] += (4.0 * lc) * (np.einsum("nkaj,nka->naj", gq, jal)
                                   + 2.0 * np.einsum("nkaj,nka->naj", gv, jom)).reshape(n, 8)
    return f


def beam_convective(x: np.ndarray, v: np.ndarray, nx: np.ndarray, ny: np.ndarray,
                    nz: np.ndarray, l0: np.ndarray, mass: np.ndarray, rotary: str = "lumped"):
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
    """
    c_ab = rotary_weights(rotary)
    n = x.shape[0]
    qp, qq = x[:, QP], x[:, QQ]
    vqp, vqq = v[:, QP], v[:, QQ]
    hx = quadratic_form(nx)                                     # (n, 3, 4, 4)
    # B q-columns (n, 3, 4) and the tangent velocities l0 B v_q, l0 (dB/dt) v_q
    bp, bq = _twice_h_times(hx, qp), _twice_h_times(hx, qq)
    hvp, hvq = _twice_h_times(hx, vqp), _twice_h_times(hx, vqq)
    lc = l0[:, None]
    u = np.stack([v[:, RP], lc * (bp @ vqp[:, :, None])[..., 0], v[:, RQ],
                  lc * (bq @ vqq[:, :, None])[..., 0]], axis=2)          # (n, 3, 4)
    du = np.zeros_like(u)
    du[:, :, 1] = lc * (hvp @ vqp[:, :, None])[..., 0]
    du[:, :, 3] = lc * (hvq @ vqq[:, :, None])[..., 0]
    w, dw = u @ HERMITE_MASS, du @ HERMITE_MASS                  # C u, C u' per component
    ra = (mass[:, 0] * l0)[:, None]                              # rho A l0
    grad, mdot = np.zeros((n, 14)), np.zeros((n, 14))
    for sl, i, hv, b in ((QP, 1, hvp, bp), (QQ, 3, hvq, bq)):
        dn_w = lc * (hv.transpose(0, 2, 1) @ w[:, :, i, None])[..., 0]   # (dN/dq v)^T w
        grad[:, sl] = 2.0 * ra * dn_w
        mdot[:, sl] = ra * (dn_w + lc * (b.transpose(0, 2, 1) @ dw[:, :, i, None])[..., 0])
    mdot[:, RP] = ra * dw[:, :, 0]
    mdot[:, RQ] = ra * dw[:, :, 2]
    if np.any(mass[:, 1:]):
        jg = _global_section_inertia(nx, ny, nz, mass)
        om = [(g_matrix(q) @ vq[:, :, None])[..., 0] for q, vq in ((qp, vqp), (qq, vqq))]
        for a, (sl, vq) in enumerate(((QP, vqp), (QQ, vqq))):
            jw = sum(c_ab[a, b] * (jg @ om[b][:, :, None])[..., 0] for b in range(2)
                     if c_ab[a, b] != 0.0)
            rot = (8.0 * l0)[:, None] * (
                g_matrix(vq).transpose(0, 2, 1) @ jw[:, :, None])[..., 0]
            grad[:, sl] -= rot
            mdot[:, sl] += 0.5 * rot
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
