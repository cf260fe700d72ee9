"""The rigid beam RBEAM (SPACAR ``RBEAM e Xp Rp Xq [ox oy oz]``), vectorized.

A rigid beam attaches the position node q to the body of node p: p's position node and
orientation node carry a rigid body, and q is a point of that body. Pure functions on arrays
with the element index first, mirroring :mod:`spacarpy.elements.beam`.

Local coordinates
-----------------
x : (n_elem, 10)
    ``[r^p (3), q^p (4), r^q (3)]``: position of p, Euler parameters of p's orientation node,
    position of q.

Reference triad
---------------
As for a BEAM (:func:`spacarpy.elements.beam.reference_triads`, reused): ``n_x`` along the
chord p->q in the initial configuration, ``n_y`` the deck's orientation vector ``(ox, oy, oz)``
made orthogonal to n_x (default when omitted: the global axis with the smallest component
along n_x), ``n_z = n_x x n_y``; ``l0`` the initial length (must be > 0). The body triad is
``n_x^p = R(q^p) n_x`` etc.

Deformations (1-based, as SPACAR's DYNE/RLSE number them), all in m
-------------------------------------------------------------------
With ``d = r^q - r^p``:

1. ``e1 = n_x^p . d - l0`` (elongation along the body's x-axis),
2. ``e2 = n_y^p . d`` (displacement of q along the body's y-axis),
3. ``e3 = n_z^p . d`` (displacement of q along the body's z-axis).

All zero in the initial configuration and normally all rigid (not in DYNE/RLSE); their dual
stress resultants are the forces (N) on node q along the body axes. For unnormalized Euler
parameters the nodal vectors scale with ``|q^p|^2`` (as in the BEAM kernel).

Derivatives (exact)
-------------------
``D = [-n_j^p, d^T (2 H(n_j) q^p), n_j^p]`` per mode j. For weights w, the weighted sum is
``d . R(q^p) v`` with ``v = sum_j w_j n_j``, so the Hessian has the blocks
``d^2/dq^p^2 = 2 sum_k d_k H_k(v)``, ``d^2/(dq^p dr^q) = -d^2/(dq^p dr^p) = (2 H(v) q^p)^T`` and
zero position-position blocks.

Properties
----------
ESTIFF: none needed (S = 0, the modes are rigid); ``ESTIFF e k1 [k2 k3]`` (N/m) gives
S = diag(k1, k2, k3) if a mode is made flexible with DYNE.
EM: ``EM e rhoA [rho(Iy+Iz) rhoIy rhoIz rhoIyz]`` (kg/m, kg m; the layout of the BEAM's EM
line, trailing values optional): the rigid rod of mass ``m = rhoA l0`` with its centre at
``r_c = r^p + R(q^p) n_x l0/2`` and the inertia tensor about the centre, in the element axes
``(n_x, n_y, n_z)``,

    J_c = l0 J_section + m l0^2 / 12 diag(0, 1, 1),

with ``J_section`` the per-unit-length rotary inertia of the cross-section as in
:func:`spacarpy.elements.beam_mass.section_inertia`. The kinetic energy
``T = m/2 |r_c_dot|^2 + 1/2 omega^T J_c omega`` with the body angular velocity
``omega = 2 G(q^p) q^p_dot`` gives the 10x10 mass matrix (configuration dependent)

    M = m N^T N + 4 G^T J_c G (q^p block),   N = [I, (l0/2) dn_x^p/dq^p, 0],

whose r^q rows and columns are zero (q is a dependent point). It equals the kinetic energy of
a rigid BEAM with the same EM data, and is exact for unit Euler parameters. The section
rotary inertia ``l0 J_section`` is that of the one rigid body of node p: the BEAM's choice
of lumped or consistent rotary inertia (which differ only where the two end nodes rotate
differently) does not apply, and both give this matrix for a rigid motion.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from spacarpy.elements.base import (
    POS_P,
    POS_Q,
    ROT_AT_P,
    SECTION_MASS,
    Y_AXIS_FIELDS,
    ElementKind,
    Fields,
    Reference,
)
from spacarpy.elements.beam import reference_triads
from spacarpy.elements.beam_mass import g_matrix, section_inertia, tangent_gravity
from spacarpy.elements.nodal import TQ_H2, nodal_jacobians
from spacarpy.linalg import batch_matvec, property_columns
from spacarpy.rotation import vector_jacobians

N_LDOF = 10
N_DEF = 3

# Local coordinate slices.
RP, QP, RQ = slice(0, 3), slice(3, 7), slice(7, 10)







def rbeam_reference(xp: np.ndarray, xq: np.ndarray, orientation: np.ndarray):
    """Reference triads and lengths ``(nx, ny, nz, l0)`` as
    :func:`spacarpy.elements.beam.reference_triads` (a NaN row of ``orientation`` selects the
    default y-axis). Raises ValueError for a rigid beam of zero length."""
    xp = np.asarray(xp, dtype=float)
    xq = np.asarray(xq, dtype=float)
    if np.any(np.linalg.norm(xq - xp, axis=1) <= 0.0):
        raise ValueError("RBEAM of zero length: nodes p and q coincide")
    return reference_triads(xp, xq, orientation)


class RBeamState(NamedTuple):
    """Deformations and Jacobian at one configuration, plus what the Hessian reuses."""

    e: np.ndarray          # (n, 3)
    D: np.ndarray          # (n, 3, 10)
    d: np.ndarray          # (n, 3) r^q - r^p
    triad: np.ndarray      # (n, 3, 3) rows n_x^p, n_y^p, n_z^p (current)
    dtriad: np.ndarray     # (n, 3, 3, 4) d n_j^p / d q^p
    u: np.ndarray          # (n, 3, 3) rows n_x, n_y, n_z (reference triad)


def rbeam_state(x: np.ndarray, nx: np.ndarray, ny: np.ndarray, nz: np.ndarray,
                l0: np.ndarray, u: np.ndarray | None = None) -> RBeamState:
    """Deformations e (n_elem, 3) and their exact Jacobian D (n_elem, 3, 10) at x (n_elem, 10).

    nx, ny, nz (n_elem, 3) and l0 (n_elem,) from :func:`rbeam_reference`; u (n_elem, 3, 3)
    is ``[nx, ny, nz]`` stacked, when the caller keeps it (the kind's reference data).
    """
    n = x.shape[0]
    if u is None:
        u = np.stack([nx, ny, nz], axis=1)
    qp = x[:, QP]
    y = np.empty((n, 4, 3))                                       # [d, n_x^p, n_y^p, n_z^p]
    np.subtract(x[:, RQ], x[:, RP], out=y[:, 0])
    dtr = nodal_jacobians(qp[:, None], u).reshape(n, 3, 3, 4)     # d n_j^p / d q^p
    y[:, 1:] = (dtr.reshape(n, 9, 4) @ qp[:, :, None]).reshape(n, 3, 3)
    y[:, 1:] *= 0.5
    d, triad = y[:, 0], y[:, 1:]
    e = (triad @ d[:, :, None])[:, :, 0]
    e[:, 0] -= l0
    D = np.empty((n, N_DEF, N_LDOF))
    np.negative(triad, out=D[:, :, RP])
    D[:, :, RQ] = triad
    D[:, :, QP] = (d[:, None, None, :] @ dtr)[:, :, 0, :]          # d^T dn_j/dq
    return RBeamState(e=e, D=D, d=d, triad=triad, dtriad=dtr, u=u)


def rbeam_weighted_hessian(st: RBeamState, w: np.ndarray) -> np.ndarray:
    """``sum_i w_i d^2 e_i / dx^2`` at the state ``st``; w (n_elem, 3) -> (n_elem, 10, 10)."""
    n = w.shape[0]
    v = (w[:, None, :] @ st.u)                                     # sum_j w_j n_j (n, 1, 3)
    mkj = st.d[:, :, None] * v                                     # d_k v_j
    hx = np.zeros((n, N_LDOF, N_LDOF))
    hx[:, QP, QP] = (mkj.reshape(n, 9) @ TQ_H2).reshape(n, 4, 4)   # 2 sum_k d_k H_k(v)
    dm = (w[:, None, :] @ st.dtriad.reshape(n, 3, 12)).reshape(n, 3, 4)   # d(R v)/dq
    dmt = dm.transpose(0, 2, 1)
    hx[:, QP, RQ], hx[:, QP, RP] = dmt, -dmt
    hx[:, RQ, QP], hx[:, RP, QP] = dm, -dm
    return hx


def rbeam_deformations(x, nx, ny, nz, l0) -> np.ndarray:
    """Deformations only, (n_elem, 3): a convenience wrapper of :func:`rbeam_state`."""
    return rbeam_state(x, nx, ny, nz, l0).e


def rbeam_stiffness(props: np.ndarray) -> np.ndarray:
    """S = diag(k1, k2, k3) (n_elem, 3, 3) from the optional ESTIFF values ``k1 [k2 k3]``
    (N/m), given as (n_elem,) or (n_elem, 0..3); missing values (and no ESTIFF line: pass
    ``np.zeros((n_elem, 0))``) are 0."""
    k = property_columns(props, N_DEF, "RBEAM ESTIFF")
    return k[:, :, None] * np.eye(N_DEF)


def rbeam_mass_matrix(x: np.ndarray, nx: np.ndarray, ny: np.ndarray, nz: np.ndarray,
                      l0: np.ndarray, mass: np.ndarray) -> np.ndarray:
    """Rigid-body mass matrices (n_elem, 10, 10) at configurations x (n_elem, 10).

    Parameters
    ----------
    nx, ny, nz : (n_elem, 3)
        Reference triads.
    l0 : (n_elem,)
    mass : (n_elem,) or (n_elem, 1..5)
        EM data ``rhoA [rho(Iy+Iz) rhoIy rhoIz rhoIyz]`` (kg/m, kg m); missing values are 0.
    """
    n = x.shape[0]
    em = property_columns(mass, 5, "RBEAM EM")
    qp = x[:, QP]
    m = em[:, 0] * l0
    half = 0.5 * l0
    b = vector_jacobians(qp, nx[:, None, :])[:, 0]               # (n, 3, 4) d n_x^p / d q^p
    out = np.zeros((n, N_LDOF, N_LDOF))
    out[:, RP, RP] = m[:, None, None] * np.eye(3)
    mb = (m * half)[:, None, None] * b
    out[:, RP, QP] = mb
    out[:, QP, RP] = mb.transpose(0, 2, 1)
    out[:, QP, QP] = (m * half * half)[:, None, None] * (b.transpose(0, 2, 1) @ b)
    # inertia about the centre, element axes -> initial global axes
    jg = _centre_inertia(em, l0, m, nx, ny, nz)
    g = g_matrix(qp)
    out[:, QP, QP] += 4.0 * (g.transpose(0, 2, 1) @ jg @ g)
    return out


def rbeam_inertia_force(x: np.ndarray, v: np.ndarray, a: np.ndarray, nx: np.ndarray,
                        ny: np.ndarray, nz: np.ndarray, l0: np.ndarray,
                        mass: np.ndarray) -> np.ndarray:
    """The inertia force ``M a + h`` (n_elem, 10) of :func:`rbeam_mass_matrix`'s rigid body
    at (x, v, a), without forming M.

    Lagrange's equations of ``T = 1/2 m |c'|^2 + 2 q'^T G^T J G q'`` (centre ``c = r^p + h
    n_x(q)``, ``h = l0 / 2``, J the inertia about the centre in initial global axes):
    ``n_x`` is quadratic in q with the linear Jacobian ``B(q)``, so ``c'' = r^p'' + h (B(q)
    q'' + B(q') q')`` and the translation gives ``m c''`` on r^p and ``m h B(q)^T c''`` on q
    (the gradient part cancels); the rotation gives ``4 G^T J G q'' + 8 G(q')^T J G q'``
    (``G(q) p = -G(p) q``, ``G(p) p = 0``; the BEAM's :func:`~spacarpy.elements.beam_mass.
    beam_inertia_force` for one node). Node q carries no mass."""
    n = x.shape[0]
    em = property_columns(mass, 5, "RBEAM EM")
    m = em[:, 0] * l0
    half = 0.5 * l0
    qv = np.stack([x[:, QP], v[:, QP]], axis=1)                    # q, q' (n, 2, 4)
    b = vector_jacobians(qv.reshape(2 * n, 4), np.repeat(nx, 2, axis=0)[:, None, :])
    b = b.reshape(n, 2, 3, 4)                                      # B(q), B(q')
    aq = a[:, QP]
    cdd = a[:, RP] + half[:, None] * (batch_matvec(b[:, 0], aq) + batch_matvec(b[:, 1],
                                                                               v[:, QP]))
    f = np.zeros((n, N_LDOF))
    f[:, RP] = m[:, None] * cdd
    jg = _centre_inertia(em, l0, m, nx, ny, nz)
    g = g_matrix(qv)                                               # G(q), G(q') (n, 2, 3, 4)
    omega = batch_matvec(g[:, 0], v[:, QP])                        # G q' (half the rate)
    alpha = batch_matvec(g[:, 0], aq)
    f[:, QP] = ((m * half)[:, None] * batch_matvec(b[:, 0].transpose(0, 2, 1), cdd)
                + 4.0 * batch_matvec(g[:, 0].transpose(0, 2, 1), batch_matvec(jg, alpha))
                + 8.0 * batch_matvec(g[:, 1].transpose(0, 2, 1), batch_matvec(jg, omega)))
    return f


def _centre_inertia(em, l0, m, nx, ny, nz) -> np.ndarray:
    """The rigid rod's inertia about its centre in initial global axes (n, 3, 3): the
    section's ``l0 J`` plus ``m l0^2 / 12`` about the two cross axes."""
    jc = l0[:, None, None] * section_inertia(em)
    jc[:, 1, 1] += m * l0 * l0 / 12.0
    jc[:, 2, 2] += m * l0 * l0 / 12.0
    e = np.stack([nx, ny, nz], axis=2)                             # columns n_x n_y n_z
    return e @ jc @ e.transpose(0, 2, 1)


# ------------------------------------------------------------------------------ the kind
@dataclass(frozen=True, slots=True, eq=False)
class RBeamReference(Reference):
    """An RBEAM group's reference data, from :meth:`RBeam.reference`.

    nx, ny, nz : (n_elem, 3)
        The reference triad (unit vectors, see :func:`rbeam_reference`).
    l0 : (n_elem,)
        Lengths (m).
    u : (n_elem, 3, 3) or None
        ``[nx, ny, nz]`` stacked (the kernels' nodal vectors); None: stacked at each call.
    """

    nx: np.ndarray
    ny: np.ndarray
    nz: np.ndarray
    l0: np.ndarray
    u: np.ndarray | None = None


def rbeam_gravity(x: np.ndarray, ref: RBeamReference, mass: np.ndarray, g: np.ndarray):
    """Rigid rod: its mass at the centre r^p + R(q^p) n_x l0 / 2."""
    n = x.shape[0]
    m = mass[:, 0] * ref.l0
    f = np.zeros((n, 10))
    k = np.zeros((n, 10, 10))
    f[:, 0:3] = m[:, None] * g
    fq, kq = tangent_gravity(x[:, 3:7], ref.nx, g, m * ref.l0 / 2.0)
    f[:, 3:7] = fq
    k[:, 3:7, 3:7] = kq
    return f, k


class RBeam(ElementKind):
    """``RBEAM e p r q [oy_x oy_y oy_z]``: node q carried rigidly by the body of p (kernels
    above)."""

    keyword = "RBEAM"
    slots = ("pos", "rot", "pos")
    node_roles = ("p", "r", "q")
    modes = ("elongation along x", "displacement along y", "displacement along z")
    mode_units = ("m",) * 3
    stress_units = ("N",) * 3
    deformation_meaning = "RBEAM deformations (position of q in the body of p)"
    stress_meaning = "RBEAM constraint forces"
    length_modes = (True,) * 3
    estiff = Fields(("k1", "k2", "k3"), ("N/m",) * 3, 0, 3, "[k1 k2 k3]")
    mode_stiffness = (0, 1, 2)
    em = SECTION_MASS
    vector = "local y-axis"
    summary = "rigid beam carried by the orientation node of p"
    node_fields = (POS_P, ROT_AT_P, POS_Q)
    vector_fields = Y_AXIS_FIELDS
    reference_type = RBeamReference

    def reference(self, x0, vector):
        nx, ny, nz, l0 = rbeam_reference(x0[0], x0[2], vector)
        # u = [n_x, n_y, n_z] stacked once here rather than at every kernel call
        return (RBeamReference(nx, ny, nz, l0, np.stack([nx, ny, nz], axis=1)),
                np.repeat(l0[:, None], 3, axis=1))

    def state(self, x, ref, variant, prev):
        return rbeam_state(x, ref.nx, ref.ny, ref.nz, ref.l0, ref.u)

    def hessian(self, st, w):
        return rbeam_weighted_hessian(st, w)

    def stiffness(self, props, ref):
        return rbeam_stiffness(props[:, :3])

    def mass(self, x, ref, m, rotary="lumped"):    # one rigid body: exact for either choice
        return rbeam_mass_matrix(x, ref.nx, ref.ny, ref.nz, ref.l0, m)

    def inertia_force(self, x, v, a, ref, m, rotary="lumped"):
        return rbeam_inertia_force(x, v, a, ref.nx, ref.ny, ref.nz, ref.l0, m)

    def gravity(self, x, ref, mass, g):
        return rbeam_gravity(x, ref, mass, g)
