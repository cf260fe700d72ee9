"""Registry of element kinds: one uniform interface over the vectorized kernels.

The solvers never call a kernel module directly; they loop over the (few) element *groups*
of a model and call the group's :class:`Kind`. Each kind says which node slots it has
(position or orientation nodes), how many deformation modes, and wraps its kernel's pure
functions:

reference(x0_slots, vector) -> (ref, scale)
    Reference data from the initial configuration (triads, lengths) and the per-mode scale
    (n, n_def) that makes deformations dimensionless (a length for length-like modes, 1 for
    angles); used to weigh residuals and the kinematic correction.
state(x_local, ref, variant, prev) -> state with ``.e`` (n, n_def) and ``.D`` (n, n_def, n_ldof)
deformations(x_local, ref, variant, prev) -> e (n, n_def), optional
    ``state(...).e`` without the derivatives, where that is much cheaper (the BEAM).
hessian(state, w) -> (n, n_ldof, n_ldof)
tangent(state, S, w) -> (n, n_ldof, n_ldof), optional
    The element tangent ``D^T S D + hessian(state, w)`` in one pass (the BEAM's, chunk by
    chunk while the chunk is in cache); without it the solver adds the two.
stiffness(props, ref) -> (n, n_def, n_def)
mass(x_local, ref, mass) -> (n, n_ldof, n_ldof) or None
convective(x_local, v_local, ref, mass) -> (dM/dt v, d(v^T M v)/dx), each (n, n_ldof), optional
    The two parts of the convective terms; without it the transient solver differences the
    mass matrix (exact, since M is at most quadratic in the Euler parameters, but 2
    evaluations per Euler parameter plus 2 along v).
commit(state, prev) -> None
    Update the kind's persistent state after a converged step (the hinge's turn count).
check(state, ref) -> (element row, message) or None
    A validity check of a converged state (the BEAM's saturation of Eq. 7).
gravity(x_local, ref, mass, g) -> (f (n, n_ldof), df/dx (n, n_ldof, n_ldof))
    Generalized gravity forces of the element's own mass (consistent with its mass
    interpolation) and their derivative.
"""
from __future__ import annotations

from dataclasses import dataclass, replace
from functools import cached_property
from typing import Callable

import numpy as np

from spacarpy.elements import beam, beam_mass, hinge, rbeam, truss
from spacarpy.elements.chunks import in_chunks
from spacarpy.rotation import quadratic_form

#: Largest |e_hat_k| / l0 (torsion, bending) accepted in a converged BEAM state: the basic
#: deformations of Eq. (7) are sines of relative rotations, near 1 (90 degrees) they
#: saturate, the Jacobian loses rank and Newton can land on a spurious equilibrium.
MAX_BEAM_ROTATION = 0.95


@dataclass(frozen=True)
class Kind:
    keyword: str
    slots: tuple
    n_def: int
    length_modes: tuple          # per mode: True when the deformation is a length (m)
    reference: Callable
    state: Callable
    hessian: Callable
    stiffness: Callable
    tangent: Callable | None = None
    mass: Callable | None = None
    deformations: Callable | None = None
    convective: Callable | None = None
    commit: Callable | None = None
    check: Callable | None = None
    gravity: Callable | None = None

    @property
    def n_ldof(self) -> int:
        return sum(3 if s == "pos" else 4 for s in self.slots)

    @cached_property
    def position_starts(self) -> np.ndarray:
        """Local slots where the position triples (x, y, z of each position node) start
        (cached: the element-wise products of every CG iteration ask for it)."""
        width = [3 if s == "pos" else 4 for s in self.slots]
        starts = np.cumsum([0] + width[:-1])
        return np.array([a for a, s in zip(starts, self.slots) if s == "pos"], dtype=np.int64)


def relative_positions(ze: np.ndarray, starts: np.ndarray) -> np.ndarray:
    """Element vectors ``ze`` (n, n_ldof[, k]) with every position triple (starting at the
    local slots ``starts``) taken relative to the first one, in place.

    An element's deformations depend on its positions through differences only, so
    ``D z_e``, ``K_e z_e`` and ``z_e^T K_e z_e`` do not change; but they are then computed
    from quantities of the size of the element's own motion. With the nodal displacements
    of a long, finely meshed structure the products of stiffnesses ``EA/l0`` with
    displacements of the size of the whole structure cancel to many digits, and the soft
    (bending) part is lost in their round-off."""
    if starts.size:
        first = starts[0]
        for a in starts[:0:-1]:
            ze[:, a:a + 3] -= ze[:, first:first + 3]
        ze[:, first:first + 3] = 0.0
    return ze


# ------------------------------------------------------------------------------ BEAM
def _beam_reference(x0, vector):
    nx, ny, nz, l0 = beam.reference_triads(x0[0], x0[2], vector)
    return dict(nx=nx, ny=ny, nz=nz, l0=l0), np.repeat(l0[:, None], 6, axis=1)


def _beam_check(st, ref):
    rel = np.abs(st.e_hat[:, 1:]) / ref["l0"][:, None]
    if rel.size and rel.max() > MAX_BEAM_ROTATION:
        i, k = np.unravel_index(np.argmax(rel), rel.shape)
        return int(i), (
            f"deformation mode {k + 2} reached |e/l0| = {rel[i, k]:.3f}, a relative rotation "
            f"of about {np.degrees(np.arcsin(min(rel[i, k], 1.0))):.0f} degrees inside one "
            f"element. The deformation measures of Eq. (7) saturate at 90 degrees, so this "
            f"state is not a valid beam solution; use more elements.")
    return None


def _tangent_gravity(q, nx, g, coef):
    """Force ``coef * B^T g`` on the Euler parameters of a node whose tangent ``n_x = R(q) n_x``
    carries mass, with ``B = d n_x / d q = 2 H(n_x) q``, and its derivative ``2 coef H.g``."""
    hg = np.einsum("nkab,k->nab", quadratic_form(nx), g)       # (n, 4, 4): sum_k g_k H_k
    return 2.0 * coef[:, None] * (hg @ q[..., None])[..., 0], 2.0 * coef[:, None, None] * hg


def _beam_gravity(x, ref, mass, g):
    """Hermite centre line (Eq. 57): int r = l0 [r^p/2 + l0 n_x^p/12 + r^q/2 - l0 n_x^q/12]."""
    n = x.shape[0]
    m = mass[:, 0] * ref["l0"]
    f = np.zeros((n, 14))
    k = np.zeros((n, 14, 14))
    f[:, 0:3] = f[:, 7:10] = 0.5 * m[:, None] * g
    for qs, sign in ((slice(3, 7), 1.0), (slice(10, 14), -1.0)):
        fq, kq = _tangent_gravity(x[:, qs], ref["nx"], g, sign * m * ref["l0"] / 12.0)
        f[:, qs] = fq
        k[:, qs, qs] = kq
    return f, k


def _truss_gravity(x, ref, mass, g):
    n = x.shape[0]
    f = np.zeros((n, 6))
    f[:, 0:3] = f[:, 3:6] = 0.5 * (mass[:, 0] * ref["l0"])[:, None] * g
    return f, np.zeros((n, 6, 6))


def _rbeam_gravity(x, ref, mass, g):
    """Rigid rod: its mass at the centre r^p + R(q^p) n_x l0 / 2."""
    n = x.shape[0]
    m = mass[:, 0] * ref["l0"]
    f = np.zeros((n, 10))
    k = np.zeros((n, 10, 10))
    f[:, 0:3] = m[:, None] * g
    fq, kq = _tangent_gravity(x[:, 3:7], ref["nx"], g, m * ref["l0"] / 2.0)
    f[:, 3:7] = fq
    k[:, 3:7, 3:7] = kq
    return f, k


BEAM = Kind(
    keyword="BEAM", slots=("pos", "rot", "pos", "rot"), n_def=6, length_modes=(True,) * 6,
    reference=_beam_reference,
    state=lambda x, ref, variant, prev: in_chunks(beam.beam_state, len(x), x, ref["ny"],
                                                  ref["nz"], ref["l0"], variant),
    deformations=lambda x, ref, variant, prev: in_chunks(
        beam.beam_deformations, len(x), x, ref["ny"], ref["nz"], ref["l0"], variant),
    hessian=lambda st, w: in_chunks(beam.beam_weighted_hessian, len(w), st, w),
    tangent=lambda st, S, w: in_chunks(beam.beam_tangent, len(w), st, S, w),
    stiffness=lambda props, ref: beam.stiffness_matrix(props, ref["l0"]),
    mass=lambda x, ref, m: in_chunks(beam_mass.beam_mass_matrix, len(x), x, ref["nx"],
                                     ref["ny"], ref["nz"], ref["l0"], m),
    convective=lambda x, v, ref, m: in_chunks(beam_mass.beam_convective, len(x), x, v,
                                              ref["nx"], ref["ny"], ref["nz"], ref["l0"], m),
    check=_beam_check, gravity=_beam_gravity)


# ------------------------------------------------------------------------------ TRUSS
def _truss_reference(x0, vector):
    l0 = truss.truss_reference(x0[0], x0[1])
    return dict(l0=l0), l0[:, None].copy()


TRUSS = Kind(
    keyword="TRUSS", slots=("pos", "pos"), n_def=1, length_modes=(True,),
    reference=_truss_reference,
    state=lambda x, ref, variant, prev: truss.truss_state(x, ref["l0"]),
    hessian=lambda st, w: truss.truss_weighted_hessian(st, w),
    stiffness=lambda props, ref: truss.truss_stiffness(props[:, :1], ref["l0"]),
    mass=lambda x, ref, m: truss.truss_mass_matrix(m[:, :1], ref["l0"]),
    gravity=_truss_gravity)


# ------------------------------------------------------------------------------ HINGE
def _hinge_reference(x0, vector):
    a, b, c = hinge.hinge_reference(vector)
    return dict(a=a, b=b, c=c), np.ones((a.shape[0], 3))


def _hinge_state(x, ref, variant, prev):
    return hinge.hinge_state(x, ref["a"], ref["b"], ref["c"], e1_previous=prev.get("e1"))


def _hinge_commit(st, prev):
    prev["e1"] = st.e[:, 0].copy()


HINGE = Kind(
    keyword="HINGE", slots=("rot", "rot"), n_def=3, length_modes=(False,) * 3,
    reference=_hinge_reference, state=_hinge_state,
    hessian=lambda st, w: hinge.hinge_weighted_hessian(st, w),
    stiffness=lambda props, ref: hinge.hinge_stiffness(props[:, :3]),
    commit=_hinge_commit)


# ------------------------------------------------------------------------------ RBEAM
def _rbeam_reference(x0, vector):
    nx, ny, nz, l0 = rbeam.rbeam_reference(x0[0], x0[2], vector)
    return dict(nx=nx, ny=ny, nz=nz, l0=l0), np.repeat(l0[:, None], 3, axis=1)


RBEAM = Kind(
    keyword="RBEAM", slots=("pos", "rot", "pos"), n_def=3, length_modes=(True,) * 3,
    reference=_rbeam_reference,
    state=lambda x, ref, variant, prev: rbeam.rbeam_state(x, ref["nx"], ref["ny"], ref["nz"],
                                                          ref["l0"]),
    hessian=lambda st, w: rbeam.rbeam_weighted_hessian(st, w),
    stiffness=lambda props, ref: rbeam.rbeam_stiffness(props[:, :3]),
    mass=lambda x, ref, m: rbeam.rbeam_mass_matrix(x, ref["nx"], ref["ny"], ref["nz"],
                                                   ref["l0"], m),
    gravity=_rbeam_gravity)

# ------------------------------------------------------------------------------ planar kinds
# PLBEAM, PLTRUSS and PLHINGE are the spatial kernels restricted to the x-y plane: a planar
# model holds z and the Euler parameters lambda1, lambda2 of every node at 0 (numbering.py),
# so the out-of-plane deformations vanish identically and only the in-plane modes are kept.

#: BEAM modes a PLBEAM keeps: 1 elongation, 2 and 3 bending in the x-y plane at p and q
#: (BEAM modes 1, 5 and 6; rigidity EIz, shear flexibility cz).
PLBEAM_MODES = np.array([0, 4, 5])


@dataclass
class _Selected:
    """A kernel state restricted to some of its modes (``full`` is the kernel's own)."""

    full: object
    modes: np.ndarray

    @property
    def e(self):
        return self.full.e[:, self.modes]

    @property
    def D(self):
        return self.full.D[:, self.modes]


def _expand(w, modes, n_full):
    out = np.zeros((w.shape[0], n_full))
    out[:, modes] = w
    return out


def _plbeam_reference(x0, vector):
    # the local y-axis lies in the plane: z x (element axis)
    axis = x0[2] - x0[0]
    ref, scale = _beam_reference(x0, np.stack([-axis[:, 1], axis[:, 0],
                                               np.zeros(len(axis))], axis=1))
    return ref, scale[:, PLBEAM_MODES]


def _plbeam_props(props):
    """(EA, EI, c) -> BEAM's (EA, GJ, EIy, EIz, cy, cz) with only the in-plane values."""
    out = np.zeros((props.shape[0], 6))
    out[:, 0], out[:, 3], out[:, 5] = props[:, 0], props[:, 1], props[:, 2]
    return out


def _plbeam_mass(m):
    """(rhoA, rhoIz) -> BEAM's (rhoA, rhoIp, rhoIy, rhoIz, rhoIyz)."""
    out = np.zeros((m.shape[0], 5))
    out[:, 0], out[:, 3] = m[:, 0], m[:, 1]
    return out


PLBEAM = Kind(
    keyword="PLBEAM", slots=BEAM.slots, n_def=3, length_modes=(True,) * 3,
    reference=_plbeam_reference,
    state=lambda x, ref, variant, prev: _Selected(BEAM.state(x, ref, variant, prev),
                                                  PLBEAM_MODES),
    deformations=lambda x, ref, variant, prev: BEAM.deformations(x, ref, variant, prev)[
        :, PLBEAM_MODES],
    hessian=lambda st, w: BEAM.hessian(st.full, _expand(w, PLBEAM_MODES, 6)),
    stiffness=lambda props, ref: BEAM.stiffness(_plbeam_props(props), ref)[
        :, PLBEAM_MODES[:, None], PLBEAM_MODES],
    mass=lambda x, ref, m: BEAM.mass(x, ref, _plbeam_mass(m)),
    convective=lambda x, v, ref, m: BEAM.convective(x, v, ref, _plbeam_mass(m)),
    check=lambda st, ref: _beam_check(st.full, ref),
    gravity=lambda x, ref, m, g: _beam_gravity(x, ref, _plbeam_mass(m), g))

PLTRUSS = replace(TRUSS, keyword="PLTRUSS")


def _plhinge_reference(x0, vector):
    n = len(vector)
    ref, scale = _hinge_reference(x0, np.tile([0.0, 0.0, 1.0], (n, 1)))
    return ref, scale[:, :1]


PLHINGE = Kind(
    keyword="PLHINGE", slots=HINGE.slots, n_def=1, length_modes=(False,),
    reference=_plhinge_reference,
    state=lambda x, ref, variant, prev: _Selected(_hinge_state(x, ref, variant, prev),
                                                  np.array([0])),
    hessian=lambda st, w: HINGE.hessian(st.full, _expand(w, np.array([0]), 3)),
    stiffness=lambda props, ref: hinge.hinge_stiffness(props[:, :3])[:, :1, :1],
    commit=lambda st, prev: _hinge_commit(st.full, prev))

#: Keyword -> kind, in the order the solver assembles them.
KINDS = {k.keyword: k for k in (BEAM, TRUSS, HINGE, RBEAM, PLBEAM, PLTRUSS, PLHINGE)}
#: The planar kinds (a model with them is planar and may not have the others).
PLANAR_KINDS = ("PLBEAM", "PLTRUSS", "PLHINGE")
