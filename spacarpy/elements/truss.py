"""The spatial TRUSS element (SPACAR ``TRUSS e p q``), vectorized.

Pure functions on arrays with the element index first, mirroring
:mod:`spacarpy.elements.beam`. Nothing here knows about decks, nodes or global numbering.

Local coordinates
-----------------
x : (n_elem, 6)
    ``[r^p (3), r^q (3)]``: the positions of the two end nodes (position nodes only; a truss
    has no orientation nodes).

Deformation (1-based, as SPACAR's DYNE/RLSE number it)
------------------------------------------------------
1. elongation ``e1 = l - l0`` with ``l = |r^q - r^p|`` and ``l0`` the length in the initial
   configuration (m). It is zero in the initial configuration. The dual stress resultant is
   the axial force (N, positive in tension).

Derivatives (exact)
-------------------
With the unit chord ``n1 = (r^q - r^p) / l``: ``D = [-n1, n1]`` (n_elem, 1, 6) and
``d^2 e1/dx^2 = (I - n1 n1^T) / l`` in the blocks ``[[P, -P], [-P, P]]``.

Properties
----------
ESTIFF: ``ESTIFF e EA`` (N) -> ``S = EA / l0`` (N/m), shape (n_elem, 1, 1).
EM: ``EM e rhoA`` (kg/m) -> consistent mass with linear interpolation of the positions,
``rhoA l0 / 6 [[2 I, I], [I, 2 I]]`` (6x6, configuration independent). It is exact for the
kinetic energy of any velocity field that is linear along the truss (rigid motions included).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from spacarpy.elements.base import POS_P, POS_Q, ElementKind, Fields, Reference
from spacarpy.linalg import property_columns

N_LDOF = 6
N_DEF = 1

# Local coordinate slices.
RP, RQ = slice(0, 3), slice(3, 6)




def truss_reference(xp: np.ndarray, xq: np.ndarray) -> np.ndarray:
    """Reference lengths ``l0 = |x^q - x^p|`` (n_elem,) from the initial positions (n_elem, 3).

    Raises ValueError for a truss of zero length.
    """
    l0 = np.linalg.norm(np.asarray(xq, float) - np.asarray(xp, float), axis=1)
    if np.any(l0 <= 0.0):
        raise ValueError("TRUSS of zero length: its end nodes coincide")
    return l0


@dataclass(frozen=True, slots=True, eq=False)
class TrussReference(Reference):
    """A TRUSS group's reference data (also the PLTRUSS's and the worked example's SPRING's).

    l0 : (n_elem,)
        Initial lengths (m), from :func:`truss_reference`.
    """

    l0: np.ndarray


class TrussState(NamedTuple):
    """Deformation and Jacobian at one configuration, plus what the Hessian reuses."""

    e: np.ndarray          # (n, 1) elongation
    D: np.ndarray          # (n, 1, 6)
    n1: np.ndarray         # (n, 3) current unit chord
    length: np.ndarray     # (n,) current length
    l0: np.ndarray         # (n,)


def truss_state(x: np.ndarray, l0: np.ndarray) -> TrussState:
    """Elongation e (n_elem, 1) and its exact Jacobian D (n_elem, 1, 6) at x (n_elem, 6)."""
    d = x[:, RQ] - x[:, RP]
    length = np.linalg.norm(d, axis=1)
    n1 = d / length[:, None]
    e = (length - l0)[:, None]
    D = np.concatenate([-n1, n1], axis=1)[:, None, :]
    return TrussState(e=e, D=D, n1=n1, length=length, l0=l0)


def truss_weighted_hessian(st: TrussState, w: np.ndarray) -> np.ndarray:
    """``w_1 d^2 e_1 / dx^2`` at the state ``st``; w (n_elem, 1) -> (n_elem, 6, 6)."""
    w1 = np.asarray(w, dtype=float).reshape(st.length.shape[0], -1)[:, 0]
    p = (w1 / st.length)[:, None, None] * (np.eye(3) - st.n1[:, :, None] * st.n1[:, None, :])
    h = np.empty((p.shape[0], N_LDOF, N_LDOF))
    h[:, RP, RP] = h[:, RQ, RQ] = p
    h[:, RP, RQ] = h[:, RQ, RP] = -p
    return h


def truss_deformations(x: np.ndarray, l0: np.ndarray) -> np.ndarray:
    """Deformations only, (n_elem, 1): a convenience wrapper of :func:`truss_state`."""
    return truss_state(x, l0).e


def truss_stiffness(props: np.ndarray, l0: np.ndarray) -> np.ndarray:
    """S (n_elem, 1, 1) = EA / l0 from the ESTIFF values ``EA`` (n_elem,) or (n_elem, 1)."""
    ea = property_columns(props, 1, "TRUSS ESTIFF")[:, 0]
    return (ea / l0)[:, None, None]


def truss_mass_matrix(mass: np.ndarray, l0: np.ndarray) -> np.ndarray:
    """Consistent mass (n_elem, 6, 6) from the EM values ``rhoA`` (n_elem,) or (n_elem, 1).

    ``M = rhoA l0 / 6 [[2 I, I], [I, 2 I]]`` (linear interpolation of the positions).
    """
    rho_a = property_columns(mass, 1, "TRUSS EM")[:, 0]
    block = np.kron(np.array([[2.0, 1.0], [1.0, 2.0]]) / 6.0, np.eye(3))
    return (rho_a * l0)[:, None, None] * block


# ------------------------------------------------------------------------------ the kind
def truss_gravity(x: np.ndarray, ref: TrussReference, mass: np.ndarray, g: np.ndarray):
    """Half the truss's mass ``rhoA l0`` on each end node; the forces are constant."""
    n = x.shape[0]
    f = np.zeros((n, 6))
    f[:, 0:3] = f[:, 3:6] = 0.5 * (mass[:, 0] * ref.l0)[:, None] * g
    return f, np.zeros((n, 6, 6))


class Truss(ElementKind):
    """``TRUSS e p q``: a rod between two position nodes (kernels above)."""

    keyword = "TRUSS"
    slots = ("pos", "pos")
    node_roles = ("p", "q")
    modes = ("elongation",)
    mode_units = ("m",)
    stress_units = ("N",)
    deformation_meaning = "elongation of each TRUSS element"
    stress_meaning = "axial force of each TRUSS element"
    length_modes = (True,)
    estiff = Fields(("EA",), ("N",), 1, 1, "EA")
    mode_stiffness = (0,)
    #: values after rhoA are accepted and ignored (the BEAM's EM layout)
    em = Fields(("rhoA",), ("kg/m",), 1, None, "rhoA")
    summary = "truss (rod) element between two position nodes"
    node_fields = (POS_P, POS_Q)
    reference_type = TrussReference

    def reference(self, x0, vector):
        l0 = truss_reference(x0[0], x0[1])
        return TrussReference(l0), l0[:, None].copy()

    def state(self, x, ref, variant, prev):
        return truss_state(x, ref.l0)

    def hessian(self, st, w):
        return truss_weighted_hessian(st, w)

    def stiffness(self, props, ref):
        return truss_stiffness(props[:, :1], ref.l0)

    def mass(self, x, ref, m, rotary="lumped"):       # rotary: no section inertia
        return truss_mass_matrix(m[:, :1], ref.l0)

    def gravity(self, x, ref, mass, g):
        return truss_gravity(x, ref, mass, g)
