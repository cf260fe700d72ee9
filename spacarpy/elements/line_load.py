"""Consistent lumping of a line load on beam elements into nodal forces and moments.

A beam (BEAM, PLBEAM, BEAMW) interpolates its axial displacement linearly and its
transverse displacement with the cubic Hermite functions of its end displacements and end
rotations. The work of a line load ``q(xi) = (1 - xi) q_p + xi q_q`` (force per unit length,
global axes, ``xi = s / L``) on a virtual displacement so interpolated gives, with the unit
chord ``t`` and the length ``L`` (docs/deck.md, "Line loads", derives it):

- forces: the axial part ``qa = (q . t) t`` lumps with the linear functions,
  ``F_p = L (2 qa_p + qa_q) / 6``, ``F_q = L (qa_p + 2 qa_q) / 6``; the transverse part
  ``qt = q - qa`` with the cubic ones, ``F_p = L (7 qt_p + 3 qt_q) / 20``,
  ``F_q = L (3 qt_p + 7 qt_q) / 20``;
- moments: ``M_p = L^2 / 60 t x (3 q_p + 2 q_q)``, ``M_q = -L^2 / 60 t x (2 q_p + 3 q_q)``
  (only the transverse part has a moment about the chord's perpendicular).

A uniform load gives ``q L / 2`` and ``+-q L^2 / 12`` (about ``t x q``). All elements at
once, no loop over elements.
"""
from __future__ import annotations

import numpy as np

__all__ = ["lump_line_load"]


def lump_line_load(x_p, x_q, q_p, q_q):
    """The nodal forces and moments of linear line loads on straight beam elements.

    Parameters
    ----------
    x_p, x_q : (n, 3)
        The element ends (the chord from p to q; its length is the element's length).
    q_p, q_q : (n, 3)
        The line load (force per unit length, global axes) at p and at q.

    Returns
    -------
    f_p, f_q, m_p, m_q : (n, 3) each
        The forces on the position nodes p and q and the moments on the orientation nodes
        at p and at q, global axes.
    """
    x_p, x_q, q_p, q_q = (np.asarray(a, dtype=float).reshape(-1, 3)
                          for a in (x_p, x_q, q_p, q_q))
    chord = x_q - x_p
    length = np.sqrt(np.einsum("ij,ij->i", chord, chord))[:, None]
    t = chord / length
    ax_p = np.einsum("ij,ij->i", q_p, t)[:, None] * t
    ax_q = np.einsum("ij,ij->i", q_q, t)[:, None] * t
    tr_p, tr_q = q_p - ax_p, q_q - ax_q
    f_p = length * ((2.0 * ax_p + ax_q) / 6.0 + (7.0 * tr_p + 3.0 * tr_q) / 20.0)
    f_q = length * ((ax_p + 2.0 * ax_q) / 6.0 + (3.0 * tr_p + 7.0 * tr_q) / 20.0)
    l2 = length * length / 60.0
    m_p = l2 * np.cross(t, 3.0 * q_p + 2.0 * q_q)
    m_q = -l2 * np.cross(t, 2.0 * q_p + 3.0 * q_q)
    return f_p, f_q, m_p, m_q
