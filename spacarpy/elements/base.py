"""The element-kind base class: what every element kind declares and which kernels it offers.

An element kind is one subclass of :class:`ElementKind` in its own module
(``spacarpy/elements/<kind>.py``), listed once in :mod:`spacarpy.elements.registry`. The class
*declares* the facts the rest of the program needs (deck keyword, node slots, deformation modes
with names and units, the ESTIFF and EM field layouts, the meaning of the element line's
trailing vector) and *wraps* the kind's pure array kernels in a uniform interface that the
solvers call element group by element group (element index first everywhere):

reference(x0_slots, vector) -> (ref, scale)
    Reference data from the initial configuration (a record of the kind's
    ``reference_type``, a :class:`Reference`: triads, lengths, axes) and the per-mode scale
    (n, n_def) that makes deformations dimensionless (a length for length-like modes, 1 for
    angles); used to weigh residuals and the kinematic correction.
state(x_local, ref, variant, prev) -> state with ``.e`` (n, n_def) and ``.D`` (n, n_def, n_ldof)
    The deformations and their Jacobian (first derivatives) at x.
deformations(x_local, ref, variant, prev) -> e (n, n_def), optional
    ``state(...).e`` without the derivatives, where that is much cheaper (the BEAM).
hessian(state, w) -> (n, n_ldof, n_ldof)
    The weighted second derivatives ``sum_i w_i d2e_i/dx2`` (the geometric stiffness for w = σ).
tangent(state, S, w) -> (n, n_ldof, n_ldof), optional
    The element tangent ``D^T S D + hessian(state, w)`` in one pass; without it the solver
    adds the two.
stiffness(props, ref) -> (n, n_def, n_def)
    From the ESTIFF values (n, len(estiff.names)).
mass(x_local, ref, mass, rotary="lumped") -> (n, n_ldof, n_ldof), optional
    From the EM values (n, len(em.names)); ``rotary`` (``"lumped"`` or ``"consistent"``,
    :mod:`spacarpy.elements.beam_mass`) is how a beam distributes its section rotary inertia
    (a kind without one ignores it).
convective(x_local, v_local, ref, mass, rotary="lumped") -> (dM/dt v, d(v^T M v)/dx), each
    (n, n_ldof), optional
    The two parts of the convective terms; without it the transient solver differences the
    mass matrix.
inertia_force(x_local, v_local, a_local, ref, mass, rotary="lumped") -> (n, n_ldof), optional
    The whole inertia force ``M a + h`` without forming M (the BEAM's and the RBEAM's are
    much cheaper than the mass matrix times a plus the convective terms); the transient
    solver differences it for its tangent where the kind has no ``convective``.
commit(state, prev) -> None, optional
    Update the kind's persistent state after a converged step (the hinge's turn count).
check(state, ref) -> (element row, message) or None, optional
    A validity check of a converged state (the BEAM's saturation of Eq. 7).
gravity(x_local, ref, mass, g) -> (f (n, n_ldof), df/dx (n, n_ldof, n_ldof)), optional
    Generalized gravity forces of the element's own mass and their derivative.
reference_problems(x0_slots, vector) -> [(element row, message), ...], optional
    Checks of the reference configuration beyond the generic ones (the WHEEL's: contact
    point in the wheel plane, ...); the deck semantics report each as an error at the
    element's line.

Velocity-level (non-holonomic) modes, declared as ``velocity_modes`` (0-based), are no
functions of x: ``state`` gives them zero deformations and zero Jacobian rows, and the kind
offers the slip kernels instead (the WHEEL, :mod:`spacarpy.elements.wheel`):

slip(x_local, ref) -> S (n, len(velocity_modes), n_ldof)
    The modes' rates ``s = S(x) v``.
slip_dx(x_local, v_local, ref) -> d(S v)/dx (n, len(velocity_modes), n_ldof)
    The derivative of the slip rates at fixed velocities.
slip_force_dx(x_local, nu, ref) -> d(S^T nu)/dx (n, n_ldof, n_ldof)
    The derivative of the slip constraints' forces at fixed multipliers.

An optional kernel a kind does not have is ``None`` (the solvers test ``kind.mass is None``).
The deformation classes of a mode (RIGID, FLEXIBLE, RELEASED) live here too, so that the model,
the deck writer and the kernels' users share them without importing one another.
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, fields
from functools import cached_property
from typing import NamedTuple

import numpy as np

#: Deformation classes of an element deformation mode.
RIGID = 0      # not listed in DYNE/RLSE: kept at its initial value (a constraint)
FLEXIBLE = 1   # listed in DYNE: carries stiffness (ESTIFF required)
RELEASED = 2   # listed in RLSE: free; carries ESTIFF stiffness if given, else none
KINEMATIC = 3  # listed in KINE: free, its rate fixed by the non-holonomic constraints (slips)


class Fields(NamedTuple):
    """The layout of an element's ESTIFF or EM values.

    names, units : tuple of str
        The stored values, in deck order (the model keeps ``len(names)`` columns; missing
        trailing values are 0).
    required : int
        How many values a line must give at least.
    allowed : int or None
        How many values a line may give at most (values past ``names`` are accepted and
        ignored); None: no limit is checked.
    usage : str
        The values as a usage text, e.g. ``"EA GJ EIy EIz [cy cz]"``.
    """

    names: tuple
    units: tuple
    required: int
    allowed: int | None
    usage: str

    @property
    def width(self) -> int:
        return len(self.names)


#: Coordinates per node of each slot type: a position node (x, y, z), an orientation node
#: (four Euler parameters), a warping node (the rate of twist, BEAMW).
SLOT_SIZE = {"pos": 3, "rot": 4, "warp": 1}

#: Node fields of the element lines, by role.
POS_P, POS_Q = ("position node p", "p"), ("position node q", "q")
ROT_AT_P, ROT_AT_Q = ("orientation node at p", "r"), ("orientation node at q", "s")
ROT_P, ROT_Q = ("orientation node p", "r"), ("orientation node q", "s")
#: The trailing initial local y-axis of BEAM and RBEAM lines.
Y_AXIS_FIELDS = (("x component of the initial local y-axis", "ox"),
                 ("y component of the initial local y-axis", "oy"),
                 ("z component of the initial local y-axis", "oz"))

#: The EM layout of the kinds with a mass per unit length and a cross-section inertia.
SECTION_MASS = Fields(("rhoA", "rho(Iy+Iz)", "rhoIy", "rhoIz", "rhoIyz"),
                      ("kg/m", "kg m", "kg m", "kg m", "kg m"), 1, None,
                      "rhoA [rho(Iy+Iz) rhoIy rhoIz rhoIyz]")


@dataclass(frozen=True, slots=True, eq=False, weakref_slot=True)
class Reference:
    """The base of the kinds' reference records: one element group's data from its initial
    configuration, as read by the kind's kernels.

    A kind declares its record (``reference_type``) beside its kernels: a subclass, itself a
    ``@dataclass(frozen=True, slots=True, eq=False)``, whose fields are arrays with the
    element index first (documented with units and shapes), or None where a field is
    optional. Records compare and hash by identity (a kernel may key a cache on one)."""

    def _map(self, op) -> Reference:
        return type(self)(*(None if v is None else op(v)
                            for v in (getattr(self, f.name) for f in fields(self))))

    def take(self, rows) -> Reference:
        """The record of the elements ``rows`` (an index array, a mask or a slice)."""
        return self._map(lambda v: v[rows])

    def tile(self, reps: int) -> Reference:
        """The record of ``reps`` stacked copies of the elements (itself for 1)."""
        if reps == 1:
            return self
        return self._map(lambda v: np.concatenate([v] * reps))


class ElementKind:
    """Base class of the element kinds; one instance per kind lives in the registry.

    Class attributes (declared by every kind)
    -----------------------------------------
    keyword : str
        The deck keyword.
    slots : tuple of str
        Per node of the element line: ``"pos"`` (3 coordinates), ``"rot"`` (4 Euler
        parameters) or ``"warp"`` (1: a BEAMW's rate of twist), in deck order.
    node_roles : tuple of str
        A name per node for messages and docs, e.g. ``("p", "r", "q", "s")``.
    modes, mode_units : tuple of str
        Name and unit of each deformation mode (1-based in the deck: ``DYNE e 1 2``).
    stress_units : tuple of str
        Unit of each mode's stress resultant (the dual of the deformation: N for a length,
        N m for an angle).
    deformation_meaning, stress_meaning : str
        What the deformations and stress resultants of the kind are, in words (the
        ``long_name`` of its result datasets).
    length_modes : tuple of bool
        Per mode: True when the deformation is a length (m); it sets the mode's scale.
    estiff, em : Fields or None
        The ESTIFF and EM layouts; ``em = None``: the element has no mass of its own;
        ``estiff = None``: no mode can be flexible (DYNE and ESTIFF are refused, saying
        ``no_stiffness_why`` is not supported yet).
    no_stiffness_why : str
        What a stiffness of a kind without ESTIFF would model (the WHEEL's "tyre
        compliance").
    mode_stiffness : tuple of int
        Per mode: the ESTIFF value (index into ``estiff.names``) that carries its stiffness.
    vector : str or None
        What the element line's trailing three numbers mean (``"local y-axis"``, ``"axis"``),
        None when the line has none.
    summary : str
        One line on what the element is (the deck keyword's summary in messages and docs).
    node_fields : tuple of (str, str)
        Per node of the element line: its name in error messages and its short name in the
        usage line, e.g. ``("position node p", "p")``.
    vector_fields : tuple of (str, str)
        The same for the three optional trailing numbers (empty when ``vector`` is None).
    planar : bool
        A planar kind (a model with one is planar and may have planar kinds only).
    zero_length : bool
        The element's two position nodes may coincide (the PINBODY); otherwise a zero length
        is a deck error.
    vector_required : bool
        The trailing vector must be given by the deck line (the WHEEL's axle; a HINGE without
        its axis gets a message of its own).
    vector_point : bool
        The trailing three numbers are a point, not a direction (the BEAMC's arc centre):
        no zero or parallel check; the kind's ``reference_problems`` checks it.
    velocity_modes : tuple of int
        The 0-based velocity-level (non-holonomic) modes (the WHEEL's slips); empty for a
        purely holonomic kind.
    rate_units : tuple of str
        Unit of each mode's rate; empty: the mode's unit per second.
    stress_sign : tuple of float
        Factor per mode from the multiplier (or ``S e``) to the stored stress resultant;
        empty: 1 for every mode. The WHEEL stores the ground's force on the wheel (its
        multipliers are the wheel's force on the ground).
    reference_type : type
        The kind's :class:`Reference` record, what ``reference`` returns and the kernels
        read.
    always_free : tuple of int
        0-based modes that are never rigid (the BEAMW's warping modes): released when no
        DYNE/RLSE lists them, carrying their ESTIFF stiffness when ESTIFF is given.
    """

    keyword: str = ""
    slots: tuple = ()
    node_roles: tuple = ()
    modes: tuple = ()
    mode_units: tuple = ()
    stress_units: tuple = ()
    deformation_meaning: str = ""
    stress_meaning: str = ""
    length_modes: tuple = ()
    estiff: Fields | None = None
    em: Fields | None = None
    mode_stiffness: tuple = ()
    no_stiffness_why: str = ""
    vector: str | None = None
    summary: str = ""
    node_fields: tuple = ()
    vector_fields: tuple = ()
    planar: bool = False
    zero_length: bool = False
    vector_required: bool = False
    vector_point: bool = False
    velocity_modes: tuple = ()
    rate_units: tuple = ()
    stress_sign: tuple = ()
    reference_type: type = Reference
    always_free: tuple = ()

    # optional kernels: None where the kind has none
    tangent: Callable | None = None
    deformations: Callable | None = None
    mass: Callable | None = None
    convective: Callable | None = None
    inertia_force: Callable | None = None
    commit: Callable | None = None
    check: Callable | None = None
    gravity: Callable | None = None
    reference_problems: Callable | None = None
    slip: Callable | None = None
    slip_dx: Callable | None = None
    slip_force_dx: Callable | None = None

    @property
    def n_def(self) -> int:
        return len(self.modes)

    @property
    def n_ldof(self) -> int:
        return sum(SLOT_SIZE[s] for s in self.slots)

    @property
    def n_estiff(self) -> int:
        return self.estiff.width if self.estiff is not None else 0

    @property
    def n_em(self) -> int:
        return self.em.width if self.em is not None else 0

    @cached_property
    def position_starts(self) -> np.ndarray:
        """Local slots where the position triples (x, y, z of each position node) start
        (cached: the element-wise products of every CG iteration ask for it)."""
        width = [SLOT_SIZE[s] for s in self.slots]
        starts = np.cumsum([0] + width[:-1])
        return np.array([a for a, s in zip(starts, self.slots) if s == "pos"], dtype=np.int64)

    def reference(self, x0_slots, vector):
        raise NotImplementedError

    def state(self, x, ref, variant, prev):
        raise NotImplementedError

    def hessian(self, st, w):
        raise NotImplementedError

    def stiffness(self, props, ref):
        raise NotImplementedError

    def __repr__(self) -> str:
        return f"<element kind {self.keyword}>"


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


# ------------------------------------------------------------------------------ restricted kinds
# A kind may be another kind's kernel restricted to some of its modes (the planar kinds: the
# spatial kernels in the x-y plane, where the out-of-plane deformations vanish identically).
@dataclass
class Selected:
    """A kernel state restricted to some of its modes (``full`` is the kernel's own)."""

    full: object
    modes: np.ndarray

    @property
    def e(self):
        return self.full.e[:, self.modes]

    @property
    def D(self):
        return self.full.D[:, self.modes]


def expand(w: np.ndarray, modes: np.ndarray, n_full: int) -> np.ndarray:
    """Weights (n, len(modes)) of the kept modes as weights (n, n_full) of all modes."""
    out = np.zeros((w.shape[0], n_full))
    out[:, modes] = w
    return out
