"""The second-order terms of the initially curved beam BEAMC (the arc's own Eq. 48b).

The modified deformations of the DDM beam are a quadratic map of the basic ones,
``e_i = e_hat_i + e_hat^T Q_i e_hat / (2 l0)`` (Jonker & Meijaard 2013, Eq. 48b). The paper
obtains Q by integrating the quadratic parts of Reissner's strains (Eq. 30) with the moment-
area weights of each mode (Eq. 45-47) over the linear displacement and rotation fields of
the element (Eq. 39-40, shear-free), and by the second-order relation between the basic
deformations and the end rotations (Eq. 43). This module does the same for a circular arc,
numerically and exactly to round-off, per element (docs/curved-beam.md, "Second-order
terms"):

- the weights are the arc's section resultants per unit stress resultant, ``B(s)`` of
  :func:`spacarpy.elements.beamc.section_forms` (the virtual-work identity that makes the
  linear part of every ``int B_i^T strain ds`` the basic deformation holds for any arc);
- the fields are the linear arc's under its end loads, shear-free as in the paper: section
  strains ``C0 B(s) sigma`` (C0 without the shear compliances), rotations and displacements
  integrated along the arc from p and turned rigidly into the co-rotational chord frame
  (q on the chord, no twist at p), expressed through the basic deformations by the inverse
  of their flexibility;
- the quadratic strains, in chord-frame components with the Tait-Bryan angles of Eq. (29):
  axial ``|u'_perp|^2 / 2`` (u' the displacement's derivative along the arc without its
  tangential part: the paper's ``(v'^2 + w'^2) / 2``), curvature ``(-phi_y phi_z',
  phi_x phi_z', -phi_x phi_y')``;
- the nodal part (Eq. 43) is the straight beam's: the deformations are the same functions
  of the nodal triads in the chord frame.

At zero angle this is Eq. (48b) (tests/test_beamc.py checks it to round-off). The integrals
use the Gauss-Legendre points of the flexibility and a Legendre integration matrix for the
fields' running integrals: spectral, round-off for these analytic integrands.
"""
from __future__ import annotations

import functools
from collections import namedtuple

import numpy as np

from spacarpy.elements.beam import BeamState, beam_deformations, beam_state
from spacarpy.elements.beam import _second_derivatives as second_derivatives
from spacarpy.elements.beamc import (
    arc_length,
    arc_stiffness,
    quadrature,
    section_axes_along,
    section_compliances,
    section_forms,
)


@functools.cache
def _running_integral() -> np.ndarray:
    """M (g, g): ``int_{-1/2}^{tau_i} f dtau = sum_j M[i, j] f(tau_j)`` on the quadrature
    points, exact for polynomials of degree below g (Legendre basis)."""
    from numpy.polynomial import legendre as leg

    tau = quadrature()[0]
    x = 2.0 * tau
    g = x.size
    vander = leg.legvander(x, g - 1)
    prim = np.empty((g, g))
    for k in range(g):
        c = np.zeros(g)
        c[k] = 1.0
        prim[:, k] = leg.legval(x, leg.legint(c, lbnd=-1))
    return 0.5 * prim @ np.linalg.inv(vander)


def _nodal_forms() -> np.ndarray:
    """E (6, 6, 6): Eq. (43), ``e_hat_i = b_i + b^T E_i b / (2 l0)`` with b the end rotations
    and elongation of the co-rotational frame (the same for the arc and the straight beam)."""
    e = np.zeros((6, 6, 6))

    def sym(i, a, b, val):
        e[i, a, b] += val
        e[i, b, a] += val

    for a, b, v in ((2, 4, 0.5), (2, 5, 0.5), (3, 4, -0.5), (3, 5, -0.5)):
        sym(1, a, b, v)                             # e2: (e3 - e4)(e5 + e6) / (2 l0)
    sym(3, 1, 5, 1.0)                               # e4: + e2 e6 / l0
    sym(5, 1, 3, -1.0)                              # e6: - e2 e4 / l0
    return e


_NODAL = _nodal_forms()


def _cross(a, b):
    return np.cross(a, b, axisa=-2, axisb=-2, axisc=-2)


def arc_quadratic_forms(props: np.ndarray, l0: np.ndarray, alpha: np.ndarray) -> np.ndarray:
    """Q (n, 6, 6, 6), symmetric in its last two indices: the modified deformations of BEAMC
    elements are ``e_i = e_hat_i + e_hat^T Q[:, i] e_hat / (2 l0)`` (module docstring).

    Parameters
    ----------
    props : (n, 6)
        ``[EA, GJ, EIy, EIz, cy, cz]`` (the shear flexibilities are not used: shear-free
        fields, as the paper's).
    l0, alpha : (n,)
        Chord length and arc angle.
    """
    tau, wt = quadrature()
    length = arc_length(l0, alpha)[:, None, None, None]
    plain = np.array(props, dtype=float, copy=True)
    plain[:, 4:] = 0.0
    b = section_forms(l0, alpha, tau)                            # (n, g, 6, sigma)
    strain = section_compliances(plain)[:, None, :, None] * b
    axes = section_axes_along(alpha, tau)                       # rows t, e_y, t x e_y
    at = axes.transpose(0, 1, 3, 2)
    t = axes[..., 0, :, None]                                   # (n, g, 3, 1)
    gamma = at @ strain[..., :3, :]                             # chord frame, per sigma
    dphi = at @ strain[..., 3:, :]                              # d phi / ds
    phi = np.einsum("ij,njks->niks", _running_integral(), length * dphi)
    du = gamma + _cross(phi, t)
    uq = np.einsum("g,ngks->nks", wt, length * du)
    # the rigid rotation into the co-rotational frame: q on the chord, no twist at p
    psi = np.zeros_like(uq)
    psi[:, 1], psi[:, 2] = uq[:, 2] / l0[:, None], -uq[:, 1] / l0[:, None]
    phi += psi[:, None]
    du += _cross(psi[:, None], t)
    # quadratic strains per pair of unit stress resultants (a, b)
    perp = du - np.sum(t * du, axis=2, keepdims=True) * t
    axial = np.einsum("ngka,ngkb->ngab", perp, perp)

    def both(p, d):
        o = p[..., :, None] * d[..., None, :]
        return o + o.transpose(0, 1, 3, 2)

    px, py = phi[:, :, 0], phi[:, :, 1]
    dy, dz = dphi[:, :, 1], dphi[:, :, 2]
    curv = np.stack([-both(py, dz), both(px, dz), -both(px, dy)], axis=2)
    moments = at @ b[..., 3:, :]                                # chord frame, per mode
    quad = (np.einsum("g,ngi,ngab->niab", wt, b[..., 0, :], axial)
            + np.einsum("g,ngci,ngcab->niab", wt, moments, curv))
    quad *= length
    # in the end rotations b = F0 sigma, then Eq. (43) back to the basic deformations
    g0 = arc_stiffness(plain, l0, alpha)
    quad = np.einsum("nai,njab,nbk->njik", g0, quad, g0)
    quad *= l0[:, None, None, None]
    quad -= _NODAL
    return 0.5 * (quad + quad.transpose(0, 1, 3, 2))


# ------------------------------------------------------------- kernels with per-element Q
#: A BEAMC state: the BEAM's (:class:`~spacarpy.elements.beam.BeamState`, same fields and
#: meaning) and the elements' quadratic forms ``quad`` (n, 6, 6, 6), which the second
#: derivatives need (None for the basic deformations).
ArcState = namedtuple("ArcState", BeamState._fields + ("quad",))


def arc_state(x, ny, nz, l0, u, quad, variant: str, dense: bool) -> ArcState:
    """The deformations and their Jacobian (:func:`~spacarpy.elements.beam.beam_state`, same
    arguments) with the arc's modified deformations ``e = e_hat + e_hat^T Q e_hat / (2 l0)``
    for the quadratic forms ``quad`` (n, 6, 6, 6)."""
    st = beam_state(x, ny, nz, l0, "basic", u, dense)
    if variant == "basic":
        return ArcState(*st, None)
    qe = np.einsum("nijk,nk->nij", quad, st.e_hat)
    qe /= st.l0[:, None, None]
    e = st.e_hat + 0.5 * (qe @ st.e_hat[:, :, None])[:, :, 0]
    jac = qe + np.eye(6)
    return ArcState(*st._replace(e=e, D=jac @ st.D_hat, J=jac), quad)


def arc_deformations(x, ny, nz, l0, u, quad, variant: str) -> np.ndarray:
    """The deformations of :func:`arc_state` alone (the kinematic correction's iterations)."""
    e_hat = beam_deformations(x, ny, nz, l0, "basic", u)
    if variant == "basic":
        return e_hat
    qe = np.einsum("nijk,nk->nij", quad, e_hat)
    return e_hat + (0.5 / l0)[:, None] * (qe @ e_hat[:, :, None])[:, :, 0]


def _weights(st: ArcState, w: np.ndarray) -> np.ndarray:
    """``sum_i w_i Q_i / l0`` (n, 6, 6)."""
    return np.einsum("ni,nijk->njk", w, st.quad) / st.l0[:, None, None]


def arc_weighted_hessian(st: ArcState, w: np.ndarray, dense: bool) -> np.ndarray:
    """``sum_i w_i d^2 e_i / dx^2`` (as :func:`~spacarpy.elements.beam.beam_weighted_hessian`
    with the element's own Q)."""
    if st.J is None:
        return second_derivatives(st, w, None, dense)
    return second_derivatives(st, (w[:, None, :] @ st.J)[:, 0], _weights(st, w), dense)


def arc_tangent(st: ArcState, stiff: np.ndarray, w: np.ndarray, dense: bool) -> np.ndarray:
    """``D^T S D + sum_i w_i d^2 e_i / dx^2`` (as :func:`~spacarpy.elements.beam.beam_tangent`
    with the element's own Q)."""
    if st.J is None:
        return second_derivatives(st, w, stiff, dense)
    inner = st.J.transpose(0, 2, 1) @ (stiff @ st.J)
    inner += _weights(st, w)
    return second_derivatives(st, (w[:, None, :] @ st.J)[:, 0], inner, dense)
