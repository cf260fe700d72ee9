"""The initially curved DDM beam BEAMC: a circular-arc element in the deformation-mode frame.

``BEAMC e p r q s cx cy cz``: a beam whose reference axis is the circular arc from position
node p to position node q about the centre (cx, cy, cz) (the shorter arc, less than 180
degrees). The derivation is in docs/curved-beam.md; in short:

Deformations
    The six deformation modes of the straight BEAM (Eq. 7) in the element's chord frame:
    elongation of the chord, relative twist about it, and the end rotations relative to the
    chord; torsion and bending are measured as angles, ``l0 arcsin(e_hat / l0)`` of the
    BEAM's sines (the same to second order; a linear law in the sines makes the element's
    moment ``2 sin(t/2)/t`` of the rotation's, the DDM's large-deflection error), then the
    modified deformations of Eq. (48b) on top. They are functions of the nodal coordinates
    alone, invariant under any rigid motion, and zero in the initial (curved, unloaded)
    state because the nodal rotations are measured from it; the kinematic kernels, their
    exact derivatives and the saturation check are the BEAM's
    (:mod:`spacarpy.elements.beam`) with the chain rule of the arcsine
    (:func:`arc_state`, :func:`arc_tangent`).
Stiffness
    What the curvature changes is the constitutive relation between these deformations
    and their dual stress resultants: ``S = F^-1`` with the flexibility of the circular arc
    segment by Castigliano's theorem, ``F = int B(s)^T C B(s) ds`` (B maps the stress
    resultants to the section forces and moments along the arc by statics, C the section
    compliances ``1/EA, 1/kGA, 1/GJ, 1/EI``), so elongation couples with in-plane bending
    and torsion with out-of-plane bending. The integral is evaluated by Gauss-Legendre
    quadrature (:data:`GAUSS_POINTS`, exact to round-off for these smooth integrands);
    for a zero angle it is the BEAM's S to round-off.
Inertia
    The BEAM's consistent mass with the centre line the cubic Hermite interpolation of the
    arc: nodal positions and the arc's end tangents ``R(q^p) t^p``, ``R(q^q) t^q`` scaled by
    the arc length L (:mod:`spacarpy.elements.beam_mass`), total mass ``rho A L``; the
    section rotary inertia in the chord axes.

Element axes: x along the chord p -> q, z in the plane of the arc towards its centre, y =
z x x normal to the plane (``(q - c) x (p - c)`` direction). Bending modes 3, 4 (about y,
EIy, cy) are in the plane of the arc, 5, 6 (about z, EIz, cz) out of it.
"""
from __future__ import annotations

import functools
from collections import namedtuple
from dataclasses import dataclass

import numpy as np

from spacarpy.elements.base import Fields
from spacarpy.elements.beam import (
    DENSE_MAX,
    Q_MODIFIED,
    Beam,
    BeamReference,
    BeamState,
    beam_deformations,
    beam_state,
)
from spacarpy.elements.beam import _second_derivatives as second_derivatives
from spacarpy.elements.beam_mass import tangent_gravity
from spacarpy.elements.chunks import in_chunks

#: Gauss-Legendre points of the flexibility integral over the arc. The integrands are
#: polynomials of degree <= 4 in sin, cos of the angle along the arc (< pi): 24 points
#: integrate them to round-off (the truncation error is below 1e-20 for any arc).
GAUSS_POINTS = 24


@functools.cache
def quadrature() -> tuple[np.ndarray, np.ndarray]:
    """Points and weights on tau in [-1/2, 1/2] (tau = 0 the middle of the arc); made on
    first use (numpy.polynomial is not loaded by a run without BEAMC)."""
    from numpy.polynomial.legendre import leggauss

    x, w = leggauss(GAUSS_POINTS)
    return 0.5 * x, 0.5 * w


#: Relative tolerance on the two radii ``|p - c|`` and ``|q - c|`` of a BEAMC line.
RADIUS_RTOL = 1e-6
#: Smallest and largest arc angle (rad) of a BEAMC: nearly straight arcs have an undefined
#: plane (use BEAM), half circles an undefined centre side.
MIN_ANGLE, MAX_ANGLE = 1e-9, np.pi - 1e-9


def _sinc(x):
    """sin(x) / x, 1 at 0."""
    return np.sinc(x / np.pi)


def arc_frame(xp: np.ndarray, xq: np.ndarray, centre: np.ndarray):
    """The chord frame and the arc angle of BEAMC elements.

    Parameters
    ----------
    xp, xq, centre : (n, 3)

    Returns
    -------
    nx, ny, nz : (n, 3)
        x along the chord, y normal to the arc's plane (``(q - c) x (p - c)``), z = x x y
        (in the plane, towards the centre).
    l0 : (n,)
        Chord length.
    alpha : (n,)
        Angle of the arc (rad), ``2 arcsin(l0 / 2R)`` with R from the chord and the angle.
    """
    d = xq - xp
    l0 = np.linalg.norm(d, axis=1)
    nx = d / l0[:, None]
    u, v = xp - centre, xq - centre
    normal = np.cross(v, u)
    sin_a = np.linalg.norm(normal, axis=1)
    alpha = np.arctan2(sin_a, np.sum(u * v, axis=1))
    ny = normal - np.sum(normal * nx, axis=1)[:, None] * nx
    with np.errstate(invalid="ignore", divide="ignore"):      # (a straight "arc": NaN,
        ny /= np.linalg.norm(ny, axis=1)[:, None]             # refused by arc_problems)
    nz = np.cross(nx, ny)
    return nx, ny, nz, l0, alpha


def arc_length(l0, alpha):
    """Arc length ``L = R alpha = l0 / sinc(alpha / 2)``."""
    return l0 / _sinc(0.5 * alpha)


def arc_end_tangents(nx, nz, alpha) -> np.ndarray:
    """The unit tangents of the arc at p and q (n, 2, 3): ``cos(a/2) n_x -+ sin(a/2) n_z``."""
    c, s = np.cos(0.5 * alpha)[:, None], np.sin(0.5 * alpha)[:, None]
    return np.stack([c * nx - s * nz, c * nx + s * nz], axis=1)


def _section_forms(l0, alpha, tau):
    """B(tau) (n, g, 6, 6): the section resultants ``[N, Qy, Qz, T, My, Mz]`` at the points
    tau of the arc per unit generalized stress resultant, in the chord frame.

    With the chord frame as basis, the arc is ``X(tau) = (R sin(a tau), 0, -R (cos(a tau) -
    cos(a/2)))`` from the middle of the chord, its tangent ``t = (cos a tau, 0, sin a tau)``,
    the section axes ``[t, e_y, t x e_y]``. The end loads at q of the stress resultants
    sigma (Eq. 17) are ``F^q = (s1, s5 - s6, s4 - s3)``, ``T^q = l0 (s2, s4, s6)``; the
    section of the arc at tau carries ``F = F^q`` and ``M = T^q + (X_q - X) x F^q``.
    """
    n, g = l0.size, tau.size
    a = alpha[:, None]
    at = a * tau[None, :]
    half = 0.5 * a
    # chord coordinate and offset of the arc, written with sinc so that a = 0 is exact
    xc = l0[:, None] * tau * _sinc(at) / _sinc(half)
    h = (l0[:, None] * a * (0.25 - tau**2) * 0.5 * _sinc(0.5 * a * (0.5 + tau))
         * _sinc(0.5 * a * (0.5 - tau)) / _sinc(half))
    a1, a3 = 0.5 * l0[:, None] - xc, h                          # X_q - X = (a1, 0, a3)
    ct, st = np.cos(at), np.sin(at)
    fm = np.zeros((3, 6))                                       # F^q per sigma
    fm[0, 0] = 1.0
    fm[1, 4], fm[1, 5] = 1.0, -1.0
    fm[2, 2], fm[2, 3] = -1.0, 1.0
    tm = np.zeros((n, g, 3, 6))                                 # T^q per sigma
    tm[..., 0, 1] = tm[..., 1, 3] = tm[..., 2, 5] = l0[:, None]
    cross = np.zeros((n, g, 3, 3))                              # [X_q - X]x
    cross[..., 0, 1], cross[..., 1, 0] = -a3, a3
    cross[..., 1, 2], cross[..., 2, 1] = -a1, a1
    mm = tm + cross @ fm
    axes = np.zeros((n, g, 3, 3))                               # rows t, e_y, t x e_y
    axes[..., 0, 0], axes[..., 0, 2] = ct, st
    axes[..., 1, 1] = 1.0
    axes[..., 2, 0], axes[..., 2, 2] = -st, ct
    b = np.empty((n, g, 6, 6))
    b[..., :3, :] = axes @ fm
    b[..., 3:, :] = axes @ mm
    return b


def section_compliances(props: np.ndarray) -> np.ndarray:
    """C (n, 6) of ``[N, Qy, Qz, T, My, Mz]`` from ``[EA, GJ, EIy, EIz, cy, cz]``:
    ``1/EA, cz/EIz, cy/EIy, 1/GJ, 1/EIy, 1/EIz`` (cy = EIy / kGA pairs with the shear
    force along z, as in the BEAM's shear factors). A zero rigidity is rigid (compliance 0):
    the arc couples the modes, so it has no meaning as a zero stiffness."""
    ea, gj, eiy, eiz, cy, cz = props.T

    def inv(v):
        return np.divide(1.0, v, out=np.zeros_like(v), where=v != 0)

    return np.stack([inv(ea), cz * inv(eiz), cy * inv(eiy), inv(gj), inv(eiy), inv(eiz)],
                    axis=1)


def arc_flexibility(props: np.ndarray, l0: np.ndarray, alpha: np.ndarray) -> np.ndarray:
    """The flexibility F (n, 6, 6) of circular arc segments, ``e = F sigma`` in the linear
    theory: ``F = L int B^T C B dtau`` (Castigliano), by :data:`GAUSS_POINTS`-point
    Gauss-Legendre quadrature."""
    tau, weights = quadrature()
    b = _section_forms(l0, alpha, tau)
    c = section_compliances(props)
    cb = c[:, None, :, None] * b
    f = np.einsum("g,ngki,ngkj->nij", weights, b, cb)
    f *= arc_length(l0, alpha)[:, None, None]
    return 0.5 * (f + f.transpose(0, 2, 1))


def arc_stiffness(props: np.ndarray, l0: np.ndarray, alpha: np.ndarray) -> np.ndarray:
    """``S = F^-1`` (n, 6, 6) of :func:`arc_flexibility`, inverted in the scaled form
    ``D (D F D)^-1 D`` (D = diag F^-1/2) so that the axial and bending compliances, many
    orders apart, keep their digits. A mode with no compliance at all gets no stiffness."""
    f = arc_flexibility(props, l0, alpha)
    diag = np.einsum("nii->ni", f)
    # a mode without any compliance (all its rigidities zero: a rigid element without
    # ESTIFF) gets no stiffness; it is rigid (a constraint) and S is not used for it
    rigid = ~(diag > 0)
    d = np.where(rigid, 0.0, 1.0 / np.sqrt(np.where(rigid, 1.0, diag)))
    scaled = d[:, :, None] * f * d[:, None, :]
    scaled += rigid[:, :, None] * np.eye(6)
    s = np.linalg.inv(scaled)
    s *= d[:, :, None] * d[:, None, :]
    return 0.5 * (s + s.transpose(0, 2, 1))


def arc_problems(xp0: np.ndarray, xq0: np.ndarray, centre: np.ndarray) -> list:
    """``[(row, message), ...]`` for BEAMC lines whose arc is undefined: unequal radii
    (relative tolerance :data:`RADIUS_RTOL`), a centre at an end node, on the chord line or
    beyond it (an arc of 180 degrees or more)."""
    out = []
    for i in range(xp0.shape[0]):
        c = centre[i]
        ra, rb = float(np.linalg.norm(xp0[i] - c)), float(np.linalg.norm(xq0[i] - c))
        shown = "(" + ", ".join(f"{v:g}" for v in c) + ")"
        if np.isnan(c).any():
            out.append((i, "a BEAMC needs the centre of its arc: cx cy cz"))
        elif min(ra, rb) == 0.0:
            out.append((i, f"the centre {shown} coincides with an end node"))
        elif abs(ra - rb) > RADIUS_RTOL * max(ra, rb):
            out.append((i, f"the end nodes are not on one circle about the centre {shown}: "
                           f"|p - c| = {ra:.10g}, |q - c| = {rb:.10g}"))
        else:
            alpha = float(arc_frame(xp0[i:i + 1], xq0[i:i + 1], c[None])[4][0])
            if not MIN_ANGLE < alpha < MAX_ANGLE:
                out.append((i, f"the centre {shown} lies on the line through the end nodes: "
                               "the arc is straight or a half circle; use BEAM for a straight "
                               "element and split a half circle"))
    return out


@dataclass(frozen=True, slots=True, eq=False)
class BeamCReference(BeamReference):
    """A BEAMC group's reference data: the BEAM's (chord frame, chord length l0, see
    :class:`~spacarpy.elements.beam.BeamReference`) and the arc's.

    alpha : (n_elem,)
        Angle of the arc (rad).
    arc : (n_elem,)
        Arc length L (m).
    tangents : (n_elem, 2, 3)
        Unit tangents of the arc at p and q (the mass kernels' Hermite tangents).
    """

    alpha: np.ndarray | None = None
    arc: np.ndarray | None = None
    tangents: np.ndarray | None = None


def arc_gravity(x: np.ndarray, ref: BeamCReference, mass: np.ndarray, g: np.ndarray):
    """Gravity on the Hermite centre line of the arc: ``int r = L [r^p/2 + L t^p/12 +
    r^q/2 - L t^q/12]`` with the rotated end tangents ``t = R(q) t_0``."""
    n = x.shape[0]
    m = mass[:, 0] * ref.arc
    f = np.zeros((n, 14))
    k = np.zeros((n, 14, 14))
    f[:, 0:3] = f[:, 7:10] = 0.5 * m[:, None] * g
    for node, qs, sign in ((0, slice(3, 7), 1.0), (1, slice(10, 14), -1.0)):
        fq, kq = tangent_gravity(x[:, qs], ref.tangents[:, node], g, sign * m * ref.arc / 12.0)
        f[:, qs] = fq
        k[:, qs, qs] = kq
    return f, k


# ----------------------------------------------------------------- deformations as angles
#: The modes measured as angles: torsion and the four bending modes (not the elongation).
ANGLE_MODES = np.array([False, True, True, True, True, True])
_QM = np.ascontiguousarray(Q_MODIFIED.reshape(36, 6).T)      # as in beam.py
_QW = Q_MODIFIED.reshape(6, 36)

#: A BEAMC state: the BEAM's (:class:`~spacarpy.elements.beam.BeamState`, its fields with
#: e_hat, D_hat, J those of the BEAM's basic deformations: the sines) and the first and
#: second derivatives gp, gpp (n, 6) of the angles ``l0 arcsin(e_hat / l0)`` in e_hat.
ArcState = namedtuple("ArcState", BeamState._fields + ("gp", "gpp"))


def _angles(e_hat: np.ndarray, l0: np.ndarray):
    """``l0 arcsin(e_hat / l0)`` for the :data:`ANGLE_MODES` (the elongation as it is), and
    its first and second derivatives in e_hat."""
    s = np.where(ANGLE_MODES, e_hat / l0[:, None], 0.0)
    c = 1.0 - s * s
    g = np.where(ANGLE_MODES, l0[:, None] * np.arcsin(s), e_hat)
    gp = np.where(ANGLE_MODES, 1.0 / np.sqrt(c), 1.0)
    gpp = s / (c * np.sqrt(c) * l0[:, None])
    return g, gp, gpp


def _modified_map(g: np.ndarray, l0: np.ndarray):
    """Eq. (48b) on the angles g: ``e = g + g^T Q g / (2 l0)`` and ``J = de/dg``."""
    qe = (g @ _QM).reshape(-1, 6, 6)
    qe /= l0[:, None, None]
    e = g + 0.5 * (qe @ g[:, :, None])[:, :, 0]
    qe += np.eye(6)
    return e, qe


def arc_state(x, ny, nz, l0, u, variant: str, dense: bool) -> ArcState:
    """BEAMC deformations and their exact Jacobian: the BEAM's basic deformations
    (:func:`~spacarpy.elements.beam.beam_state`, same arguments), turned into angles, then
    Eq. (48b) for ``variant == "modified"``."""
    st = beam_state(x, ny, nz, l0, "basic", u, dense)
    g, gp, gpp = _angles(st.e_hat, l0)
    dg = gp[:, :, None] * st.D_hat
    if variant == "basic":
        return ArcState(*st._replace(e=g, D=dg, J=None), gp, gpp)
    if variant != "modified":
        raise ValueError(f"unknown deformation variant {variant!r}")
    e, jac = _modified_map(g, l0)
    return ArcState(*st._replace(e=e, D=jac @ dg, J=jac), gp, gpp)


def arc_deformations(x, ny, nz, l0, u, variant: str) -> np.ndarray:
    """The deformations of :func:`arc_state` alone (the kinematic correction's iterations)."""
    g = _angles(beam_deformations(x, ny, nz, l0, "basic", u), l0)[0]
    return g if variant == "basic" else _modified_map(g, l0)[0]


def _chain(st: ArcState, w: np.ndarray, stiff: np.ndarray | None):
    """The weights on the BEAM's basic deformations and the inner matrix (on D_hat) of
    ``sum_i w_i d^2 e_i/dx^2 [+ D^T S D]``: with ``e = h(g(e_hat))``, ``d^2 e_i = sum_k
    (dh_i/dg_k) (g'_k d^2 e_hat_k + g''_k de_hat_k de_hat_k^T) + D_g^T d^2 h_i D_g``."""
    wj = w if st.J is None else (w[:, None, :] @ st.J)[:, 0]
    n = w.shape[0]
    inner = np.zeros((n, 6, 6))
    diag = np.arange(6)
    inner[:, diag, diag] = wj * st.gpp
    if st.J is not None:
        qw = (w @ _QW).reshape(n, 6, 6)
        qw /= st.l0[:, None, None]
        inner += st.gp[:, :, None] * qw * st.gp[:, None, :]
    if stiff is not None:
        jg = st.gp[:, None, :] * (np.eye(6) if st.J is None else st.J)
        inner += jg.transpose(0, 2, 1) @ (stiff @ jg)
    return wj * st.gp, inner


def arc_weighted_hessian(st: ArcState, w: np.ndarray, dense: bool) -> np.ndarray:
    """``sum_i w_i d^2 e_i / dx^2`` (n, 14, 14), exact, by the BEAM's kernels."""
    return second_derivatives(st, *_chain(st, w, None), dense)


def arc_tangent(st: ArcState, stiff: np.ndarray, w: np.ndarray, dense: bool) -> np.ndarray:
    """``D^T S D + sum_i w_i d^2 e_i / dx^2`` (n, 14, 14), exact, by the BEAM's kernels."""
    return second_derivatives(st, *_chain(st, w, stiff), dense)


class BeamC(Beam):
    """``BEAMC e p r q s cx cy cz``: the initially curved beam (module docstring): the BEAM's
    kernels in the chord frame, with the arc's reference, stiffness, end tangents, length
    and weight."""

    keyword = "BEAMC"
    modes = ("elongation", "torsion", "bending y (in-plane) at p", "bending y (in-plane) at q",
             "bending z (out-of-plane) at p", "bending z (out-of-plane) at q")
    deformation_meaning = ("generalized deformations of each BEAMC element (chord frame: "
                           "elongation, torsion, bending in and out of the arc's plane)")
    stress_meaning = ("generalized stress resultants (dual to the deformations) of each "
                      "BEAMC element")
    estiff = Fields(("EA", "GJ", "EIy", "EIz", "cy", "cz"),
                    ("N", "N m^2", "N m^2", "N m^2", "m^2", "m^2"), 4, 6,
                    "EA GJ EIy EIz [cy cz]")
    vector = "arc centre"
    vector_required = True
    vector_point = True
    summary = "initially curved beam: a circular arc between two position nodes"
    vector_fields = (("x coordinate of the arc centre (m)", "cx"),
                     ("y coordinate of the arc centre (m)", "cy"),
                     ("z coordinate of the arc centre (m)", "cz"))
    reference_type = BeamCReference

    def reference(self, x0, vector):
        nx, ny, nz, l0, alpha = arc_frame(np.asarray(x0[0], float), np.asarray(x0[2], float),
                                          np.asarray(vector, float))
        axes = np.stack([nx, ny, nz], axis=1)
        ref = BeamCReference(nx, ny, nz, l0, axes, axes[:, 1:], alpha, arc_length(l0, alpha),
                             arc_end_tangents(nx, nz, alpha))
        return ref, np.repeat(l0[:, None], 6, axis=1)

    def reference_problems(self, x0, vector):
        return arc_problems(np.asarray(x0[0], float), np.asarray(x0[2], float),
                            np.asarray(vector, float))

    def stiffness(self, props, ref):
        return arc_stiffness(props, ref.l0, ref.alpha)

    def state(self, x, ref, variant, prev):
        return in_chunks(arc_state, len(x), x, ref.ny, ref.nz, ref.l0, ref.u, variant,
                         len(x) <= DENSE_MAX)

    def deformations(self, x, ref, variant, prev):
        return in_chunks(arc_deformations, len(x), x, ref.ny, ref.nz, ref.l0, ref.u, variant)

    def hessian(self, st, w):
        return in_chunks(arc_weighted_hessian, len(w), st, w, len(w) <= DENSE_MAX)

    def tangent(self, st, S, w):
        return in_chunks(arc_tangent, len(w), st, S, w, len(w) <= DENSE_MAX)

    def inertia_geometry(self, ref) -> tuple:
        """The arc's own end tangents and its length (the chord's are the BEAM's)."""
        return ref.tangents, ref.ny, ref.nz, ref.arc

    def gravity(self, x, ref, mass, g):
        return arc_gravity(x, ref, mass, g)
