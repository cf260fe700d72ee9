"""Beam section forces and the largest stresses at the surface of the cross-section.

This module's one job is to turn the generalized stress resultants of the DDM beam into what an
engineer checks: the normal force, torque and bending moments at the element ends, and, for a
beam whose cross-section is known (a rectangle or a solid circle, from the deck's VISUALIZATION
data), the largest normal stress and the largest von Mises stress in the element, as SPAVISUAL
shows them. The formulas are documented in ``docs/results.md`` ("Stresses").

Section forces (Eq. 17 of Jonker & Meijaard 2013)
--------------------------------------------------
The generalized stress resultants ``sigma`` all have the dimension of a force. Identified in the
undeformed configuration, with the nodal forces ``F`` and moments ``T`` that act *on* the
element at its nodes p and q, in the element axes x (p to q), y, z::

    sigma_1 = -F_x^p = F_x^q          normal force N (tension positive)
    sigma_2 = -T_x^p/l0 = T_x^q/l0    torque T = sigma_2 l0
    sigma_3 = -T_y^p/l0               bending moment about y at p: M_y(p) = sigma_3 l0
    sigma_4 =  T_y^q/l0               bending moment about y at q: M_y(q) = sigma_4 l0
    sigma_5 = -T_z^p/l0               bending moment about z at p: M_z(p) = sigma_5 l0
    sigma_6 =  T_z^q/l0               bending moment about z at q: M_z(q) = sigma_6 l0

The moments are internal moments in the usual beam sign convention: the moment acting on the
cut face whose outward normal is the element's +x axis (``M(p) = -T^p``, ``M(q) = T^q``).

Surface stresses
----------------
With A, I_y, I_z the area and second moments, c_y, c_z the extreme-fibre distances and W_t
the torsion modulus (``tau_max = |T| / W_t``), at each element end::

    sigma_max = |N|/A + |M_y| c_z/I_y + |M_z| c_y/I_z         rectangle (a corner)
    sigma_max = |N|/A + sqrt(M_y^2 + M_z^2) r/I               circle (r = d/2, I = pi d^4/64)
    tau_max   = |T| k / (k1 b c^2)                            rectangle, b >= c its sides
    tau_max   = 16 |T| / (pi d^3)                             circle
    von Mises = sqrt(sigma_max^2 + 3 tau_max^2)

Without distributed loads the moments vary linearly along the element, and the expressions
above are convex in them, so the maximum over the element is the larger of the two end values.
For the rectangle, k1 (torsion constant J = k1 b c^3) and k (tau_max = k c T/J) are Saint-Venant's
series solution (Timoshenko & Goodier, Theory of Elasticity, 3rd ed., Sec. 109), with a = b/c::

    k1 = (1 - 192/(pi^5 a) sum_{n odd} tanh(n pi a/2)/n^5) / 3
    k  = 1 - 8/pi^2 sum_{n odd} 1/(n^2 cosh(n pi a/2))

(for a square, tau_max = T/(0.208 b^3); for a thin strip, 3T/(b c^2)).
For the circle the von Mises value is exact at the critical point; for the rectangle it
combines the corner's normal stress with the largest torsional shear stress (at the middle of
the long side), which bounds the true maximum from above. Transverse shear from shear forces
is not included (it vanishes at the extreme fibres).
"""
from __future__ import annotations

import numpy as np

__all__ = ["SectionProperties", "section_properties", "section_forces", "surface_stress",
           "SECTION_FORCE_NAMES"]

#: Names of the six columns returned by :func:`section_forces`.
SECTION_FORCE_NAMES = ("N", "T", "My_p", "My_q", "Mz_p", "Mz_q")
#: Units of the six columns returned by :func:`section_forces`.
SECTION_FORCE_UNITS = ("N", "N m", "N m", "N m", "N m", "N m")


class SectionProperties:
    """Cross-section properties needed for surface stresses, one row per element.

    Elements without a known cross-section have NaN everywhere.

    Attributes
    ----------
    area : (n_elem,) float
        A (m^2).
    second_moment : (n_elem, 2) float
        ``(I_y, I_z)`` (m^4): second moments about the element's y- and z-axes.
    extreme_fibre : (n_elem, 2) float
        ``(c_y, c_z)`` (m): largest distances from the centroid along y and z.
    torsion_modulus : (n_elem,) float
        W_t (m^3) with ``tau_max = |T| / W_t``.
    circular : (n_elem,) bool
        Solid circle (the bending moments combine as a vector).
    known : (n_elem,) bool
        Whether the element has a cross-section.
    """

    def __init__(self, area, second_moment, extreme_fibre, torsion_modulus, circular):
        self.area = np.asarray(area, dtype=float)
        self.second_moment = np.asarray(second_moment, dtype=float)
        self.extreme_fibre = np.asarray(extreme_fibre, dtype=float)
        self.torsion_modulus = np.asarray(torsion_modulus, dtype=float)
        self.circular = np.asarray(circular, dtype=bool)

    @property
    def known(self) -> np.ndarray:
        return np.isfinite(self.area)


def section_properties(shape, dims) -> SectionProperties:
    """Properties of rectangular and circular cross-sections, vectorized over elements.

    Parameters
    ----------
    shape : array_like of str, shape (n_elem,)
        ``"RECT"``, ``"CIRC"`` or ``""`` (no cross-section known).
    dims : array_like of float, shape (n_elem, 2)
        RECT: ``(w, t)`` (m), w along the element's y-axis, t along its z-axis.
        CIRC: ``(d, NaN)`` (m), the diameter.

    Returns
    -------
    SectionProperties
    """
    shape = np.asarray(shape).astype(str).reshape(-1)
    dims = np.asarray(dims, dtype=float).reshape(shape.size, 2)
    rect = shape == "RECT"
    circ = shape == "CIRC"
    unknown = ~(rect | circ)
    w, t = dims[:, 0], dims[:, 1]
    d = dims[:, 0]
    with np.errstate(invalid="ignore", divide="ignore"):
        b, c = np.maximum(w, t), np.minimum(w, t)
        area = np.where(circ, np.pi * d**2 / 4, w * t)
        i_circ = np.pi * d**4 / 64
        second = np.column_stack([np.where(circ, i_circ, w * t**3 / 12),
                                  np.where(circ, i_circ, t * w**3 / 12)])
        fibre = np.column_stack([np.where(circ, d / 2, w / 2), np.where(circ, d / 2, t / 2)])
        torsion = np.where(circ, np.pi * d**3 / 16, _rect_torsion_modulus(b, c))
    area[unknown] = np.nan
    second[unknown] = np.nan
    fibre[unknown] = np.nan
    torsion[unknown] = np.nan
    return SectionProperties(area, second, fibre, torsion, circ)


def section_forces(stress_resultant, l0) -> np.ndarray:
    """Normal force, torque and end bending moments from the generalized stress resultants.

    Parameters
    ----------
    stress_resultant : array_like, shape (..., n_elem, 6)
        Generalized stress resultants sigma_1..sigma_6 (N), e.g. ``/static/stress_resultant``.
    l0 : array_like, shape (n_elem,)
        Reference lengths of the elements (m).

    Returns
    -------
    numpy.ndarray, shape (..., n_elem, 6)
        Columns :data:`SECTION_FORCE_NAMES`: ``N`` (N), ``T`` (N m), ``My_p``, ``My_q``,
        ``Mz_p``, ``Mz_q`` (N m), in element axes, beam sign convention (see the module
        docstring).
    """
    s = np.asarray(stress_resultant, dtype=float)
    scale = np.ones(s.shape[-2:])
    scale[:, 1:] = np.asarray(l0, dtype=float).reshape(-1, 1)
    return s * scale


def surface_stress(stress_resultant, l0, props: SectionProperties):
    """Largest normal stress and largest von Mises stress in each element.

    Parameters
    ----------
    stress_resultant : array_like, shape (..., n_elem, 6)
        Generalized stress resultants (N).
    l0 : array_like, shape (n_elem,)
        Reference lengths (m).
    props : SectionProperties
        From :func:`section_properties`, aligned with the elements.

    Returns
    -------
    max_normal : numpy.ndarray, shape (..., n_elem)
        Largest magnitude of the normal stress over the element's surface (Pa); NaN for
        elements without a cross-section.
    max_von_mises : numpy.ndarray, shape (..., n_elem)
        Largest von Mises stress (Pa), NaN likewise.
    """
    f = section_forces(stress_resultant, l0)
    n, torque = f[..., 0], f[..., 1]
    my = f[..., [2, 3]]                       # (..., n_elem, 2 ends)
    mz = f[..., [4, 5]]
    iy, iz = props.second_moment[:, 0, None], props.second_moment[:, 1, None]
    cy, cz = props.extreme_fibre[:, 0, None], props.extreme_fibre[:, 1, None]
    with np.errstate(invalid="ignore"):
        bending = np.where(props.circular[:, None], np.hypot(my, mz) * cz / iy,
                           np.abs(my) * cz / iy + np.abs(mz) * cy / iz)
        normal = np.abs(n)[..., None] / props.area[:, None] + bending    # (..., n_elem, 2)
        tau = np.abs(torque)[..., None] / props.torsion_modulus[:, None]
        mises = np.sqrt(normal**2 + 3 * tau**2)
    return normal.max(axis=-1), mises.max(axis=-1)


# Odd terms of Saint-Venant's series; the terms fall off as 1/n^5 and exp(-n pi a/2), a >= 1.
_ODD = np.arange(1, 60, 2, dtype=float)[:, None]


def _rect_torsion_modulus(b, c):
    """Torsion modulus ``W_t = k1 b c^2 / k`` of b x c rectangles (b >= c), vectorized."""
    a = b / c
    x = _ODD * np.pi * a / 2                                        # (n_term, n_elem)
    k1 = (1 - 192 / (np.pi**5 * a) * np.sum(np.tanh(x) / _ODD**5, axis=0)) / 3
    sech = 2 * np.exp(-x) / (1 + np.exp(-2 * x))
    k = 1 - 8 / np.pi**2 * np.sum(sech / _ODD**2, axis=0)
    return k1 * b * c**2 / k


class SurfaceStress:
    """The largest surface stresses of the BEAM elements of one model, step by step.

    Built from the writer's ``/model`` arrays (:func:`spacarpy.results.model_data.model_datasets`);
    calling it with a step's BEAM stress resultants gives the keyword arguments
    ``max_normal_stress`` and ``max_von_mises_stress`` of
    :meth:`spacarpy.results.writer.ResultsWriter.static_step`, or ``{}`` when no element has a
    known cross-section (the file then has no stress datasets).
    """

    def __init__(self, model_data: dict):
        b = "model/elements/BEAM"
        self.l0 = np.asarray(model_data[f"{b}/length"], dtype=np.float64)
        self.props = section_properties(np.char.decode(model_data[f"{b}/cross_section_type"],
                                                       "ascii"),
                                         model_data[f"{b}/cross_section_dims"])
        self.any = bool(self.props.known.any())

    def __call__(self, stress_resultant) -> dict:
        if not self.any:
            return {}
        normal, mises = surface_stress(np.asarray(stress_resultant, dtype=np.float64), self.l0,
                                       self.props)
        return {"max_normal_stress": normal, "max_von_mises_stress": mises}
