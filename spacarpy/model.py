"""The typed, validated model: what a deck means, independent of how it was written.

A :class:`Model` is produced from a parsed deck by :mod:`spacarpy.deck.semantics` (or built directly
from Python). It is the structure only; what to compute on it (MODE, ITERSTEP, TIMESTEP, ...)
is a :class:`spacarpy.settings.AnalysisSettings` kept beside it (:class:`spacarpy.job.Job`).
It holds deck numbers (the user's node and element numbers) and SI values only; turning it
into coordinate and degree-of-freedom numbering is the job of :mod:`spacarpy.numbering`.

Conventions (see docs/conventions.md)
-------------------------------------
- Position nodes have 3 coordinates (x, y, z); orientation nodes have 4 Euler parameters
  (lambda0, lambda1, lambda2, lambda3), all orientation nodes start at the identity (1, 0, 0, 0).
- Warping nodes (BEAMW) have 1 coordinate, the rate of twist, starting at 0.
- Coordinate numbers inside a node are 1-based as in SPACAR (``FIX 7 2`` fixes y of node 7).
- Deformation-mode numbers inside an element are 1-based as in SPACAR (``DYNE 3 1 2``).
- Arrays have the entity index first: ``(n_elem, 6)``, ``(n_pos, 3)``.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from spacarpy.elements.base import FLEXIBLE, KINEMATIC, RELEASED, RIGID
from spacarpy.elements.registry import KINDS, kind_of
from spacarpy.errors import SourceLoc

__all__ = ["FLEXIBLE", "KINEMATIC", "RELEASED", "RIGID", "DynamicCoordinate", "ElementSet", "Fix",
           "FollowerLineLoad", "FollowerLoad", "Kinematic",
           "LineLoad", "Load", "Model", "NodalMass", "Prescribed", "PrescribedDeformation",
           "PrescribedRotation", "UserRoutine"]

# The deformation classes of a mode (RIGID, FLEXIBLE, RELEASED, KINEMATIC) are declared with
# the element kinds and re-exported here.

def _columns(values, n: int, width: int) -> np.ndarray:
    """``values`` as (n, width) floats: missing trailing columns are 0, extra ones dropped."""
    a = np.asarray(values, dtype=float)
    a = a.reshape(n, -1) if a.size else np.zeros((n, 0))
    return np.pad(a, ((0, 0), (0, max(0, width - a.shape[1]))))[:, :width]


@dataclass
class ElementSet:
    """All elements of one kind, vectorized (element index first).

    The array widths are the kind's declared ones (:mod:`spacarpy.elements.registry`): for a
    BEAM ``nodes`` (n, 4), ``def_class`` (n, 6), ``stiffness`` (n, 6), ``mass`` (n, 5).

    Attributes
    ----------
    kind : str
        The deck keyword (a key of :data:`spacarpy.elements.registry.KINDS`).
    ids : (n_elem,) int
        Deck element numbers.
    nodes : (n_elem, n_slots) int
        Deck node numbers in the keyword's order (the kind's ``node_roles``): BEAM
        ``[p, r, q, s]``, TRUSS ``[p, q]``, HINGE ``[r, s]``, RBEAM ``[p, r, q]``.
    vector : (n_elem, 3) float
        The element line's trailing vector (the kind's ``vector``: BEAM and RBEAM the initial
        local y-axis, not yet orthogonalized; HINGE the axis). Rows of NaN mean "not given"
        (the kind's default rule applies); always NaN for kinds without one.
    def_class : (n_elem, n_def) int8
        RIGID, FLEXIBLE, RELEASED or KINEMATIC per deformation mode.
    stiffness : (n_elem, n_estiff) float
        ESTIFF values in the kind's layout (BEAM ``EA, GJ, EIy, EIz, cy, cz``; TRUSS ``EA``;
        HINGE ``k k2 k3``; ...), missing trailing values 0; zero rows where no ESTIFF was
        given.
    has_stiffness : (n_elem,) bool
        Whether an ESTIFF line was given.
    mass : (n_elem, n_em) float
        EM values in the kind's layout (BEAM, RBEAM ``rhoA, rho(Iy+Iz), rhoIy, rhoIz,
        rhoIyz``; TRUSS ``rhoA``; none for hinges), zero rows where no EM was given.
    locs : list of SourceLoc
        Where each element was defined.
    """

    kind: str
    ids: np.ndarray
    nodes: np.ndarray
    vector: np.ndarray | None = None
    def_class: np.ndarray | None = None
    stiffness: np.ndarray | None = None
    has_stiffness: np.ndarray | None = None
    mass: np.ndarray | None = None
    locs: list = field(default_factory=list)

    def __post_init__(self):
        k = kind_of(self.kind)
        self.ids = np.asarray(self.ids, dtype=np.int64).reshape(-1)
        n = self.ids.size
        self.nodes = np.asarray(self.nodes, dtype=np.int64).reshape(n, len(k.slots))
        self.vector = (np.full((n, 3), np.nan) if self.vector is None
                       else np.asarray(self.vector, dtype=float).reshape(n, 3))
        self.def_class = (np.full((n, k.n_def), RIGID, np.int8) if self.def_class is None
                          else np.asarray(self.def_class, dtype=np.int8).reshape(n, k.n_def))
        self.stiffness = _columns(np.zeros((n, 0)) if self.stiffness is None else self.stiffness,
                                  n, k.n_estiff)
        self.has_stiffness = (np.zeros(n, bool) if self.has_stiffness is None
                              else np.asarray(self.has_stiffness, dtype=bool).reshape(n))
        self.mass = _columns(np.zeros((n, 0)) if self.mass is None else self.mass, n, k.n_em)
        if not self.locs:
            self.locs = [None] * n

    @property
    def n_elem(self) -> int:
        return int(self.ids.size)

    @classmethod
    def empty(cls, kind: str) -> ElementSet:
        """A set of no elements of a kind (arrays of the kind's widths)."""
        return cls(kind=kind, ids=np.zeros(0, np.int64), nodes=np.zeros(0, np.int64))


@dataclass(frozen=True)
class Fix:
    """``FIX node [c ...]``: coordinates (1-based) of a node held at their initial value."""

    node: int
    coords: tuple[int, ...]
    loc: SourceLoc | None = None


@dataclass(frozen=True)
class DynamicCoordinate:
    """``DYNX node coord``: a nodal coordinate that is a degree of freedom (SPACAR's dynamic
    class, docs/deck.md). Free like any coordinate that is not fixed; it names the degrees of
    freedom of the linearized equations (mode 3, 9, 10) beside the DYNE modes, and a model
    with DYNX lines must be parameterized by its DYNX coordinates and DYNE modes exactly."""

    node: int
    coord: int
    loc: SourceLoc | None = None

    @property
    def name(self) -> str:
        """The deck line, ``DYNX 2 1``."""
        return f"DYNX {self.node} {self.coord}"


@dataclass(frozen=True)
class Kinematic:
    """A kinematic coordinate (SPACAR's class K, docs/rolling.md): ``KINX node coord`` (a
    nodal coordinate, ``keyword == "KINX"``, ``target`` the node) or ``KINE element mode``
    (a deformation mode, ``target`` the element; that mode's ``def_class`` is KINEMATIC).
    Free in the holonomic constraints; its rate follows from the slips held at zero."""

    keyword: str
    target: int
    number: int
    loc: SourceLoc | None = None

    @property
    def name(self) -> str:
        """The deck line, ``KINX 2 1``."""
        return f"{self.keyword} {self.target} {self.number}"


@dataclass(frozen=True)
class Prescribed:
    """A prescribed (input) nodal coordinate: ``INPUTX node coord`` in the kinematics module.

    Its value follows the load path like the loads do: ``initial`` (the data module's
    ``INPUTX node coord value``; None = the initial configuration's value) is reached at
    step 0, then ``delta`` (``DELINPX node coord delta``) is added in the load steps, so the
    value at load factor s is ``initial + s * delta``. Euler parameters are prescribed like
    any coordinate; the normalization of their node still holds. In a transient run the
    5-field form's ``velocity`` and ``acceleration`` add ``velocity t + acceleration t^2 / 2``
    (SPACAR's value, rate and second derivative at t = 0, continued at constant
    acceleration).
    """

    node: int
    coord: int
    initial: float | None = None
    delta: float = 0.0
    loc: SourceLoc | None = None
    velocity: float = 0.0          # INPUTX n c value velocity acceleration: the rate at t = 0
    acceleration: float = 0.0      # and its constant second derivative (transient runs)
    tf: str | None = None          # LOADTF: the named time function of its DELINPX


@dataclass(frozen=True)
class PrescribedDeformation:
    """A prescribed (input) element deformation: ``INPUTE element mode`` in the kinematics
    module, e.g. the angle of a HINGE that drives a mechanism or sets a misalignment.

    Like :class:`Prescribed`: ``initial`` (the data module's ``INPUTE element mode value``;
    None = 0, the reference configuration's deformation) is reached at step 0 and ``delta``
    (``DELINPE element mode delta``) is added over the load steps; a transient run adds
    ``velocity t + acceleration t^2 / 2`` of the 5-field form. The mode is a constraint
    ``e_k(x) = initial + s * delta`` whose multiplier is the stress resultant that holds it
    (the driving torque of a hinge).
    """

    element: int
    mode: int
    initial: float | None = None
    delta: float = 0.0
    loc: SourceLoc | None = None
    velocity: float = 0.0          # INPUTE e k value velocity acceleration (transient runs)
    acceleration: float = 0.0
    tf: str | None = None          # LOADTF: the named time function of its DELINPE


@dataclass(frozen=True)
class PrescribedRotation:
    """spacarpy extension ``INPUTR node ax ay az`` / ``DELINPR node angle``: the orientation
    node turns about the fixed axis by ``s * angle`` (rad) at load factor s; all four Euler
    parameters follow, so nobody has to type quaternion components."""

    node: int
    axis: tuple
    angle: float = 0.0
    loc: SourceLoc | None = None
    initial: float = 0.0          # angle reached at step 0 (a planar deck's INPUTX n 1 value)
    tf: str | None = None         # LOADTF: the named time function of its DELINPR


@dataclass(frozen=True)
class Load:
    """A dead nodal load: force (position node) or moment (orientation node), global axes.

    ``kind`` is ``"XF"`` (present from the start) or ``"DELXF"`` (increment applied over the
    load steps). Loads on the same node and kind add up.
    """

    node: int
    kind: str
    value: tuple[float, float, float]
    loc: SourceLoc | None = None
    tf: str | None = None          # LOADTF: the named time function of a DELXF (transient)


@dataclass(frozen=True)
class LineLoad:
    """A dead line load on a beam element (``QE``/``DELQE e q1 q2 q3 [q1 q2 q3]``): force per
    unit reference length in global axes, ``q_p`` at the element's end p and ``q_q`` at its
    end q, linear in between (uniform where they are equal). ``kind`` is ``"QE"`` (present
    from the start, like XF) or ``"DELQE"`` (applied over the load steps, like DELXF); ``tf``
    names its time function (LOADTF) or is None. The solvers lump it at the element's nodes
    from the beam's interpolation (:mod:`spacarpy.elements.line_load`)."""

    element: int
    kind: str
    q_p: tuple[float, float, float]
    q_q: tuple[float, float, float]
    loc: SourceLoc | None = None
    tf: str | None = None


@dataclass(frozen=True)
class FollowerLoad:
    """A follower nodal load (``XFL n r f1 f2 f3``, ``DELXFL``): a force on position node
    ``node`` or a moment on orientation node ``node``, with components ``value`` in the
    current axes of orientation node ``axes`` (they turn with it; not conservative).

    ``kind`` is ``"XFL"`` (present from the start) or ``"DELXFL"`` (increment applied over
    the load steps, scaled by the time function in a transient)."""

    node: int
    axes: int
    kind: str
    value: tuple[float, float, float]
    loc: SourceLoc | None = None
    tf: str | None = None          # LOADTF: the named time function of a DELXFL (transient)


@dataclass(frozen=True)
class FollowerLineLoad(LineLoad):
    """A follower line load on a beam (``QEL``/``DELQEL e q1 q2 q3 [q1 q2 q3]``): the fields
    of a :class:`LineLoad`, but the components are force per current length in the element's
    **current axes** (x along the deformed chord p -> q, y its current local y-axis, z = x
    x y; docs/follower.md), so the load turns with the element (not conservative). A planar
    deck's ``qx qy`` are stored with a zero z component. ``tf`` names the time function of a
    DELQEL (LOADTF) or is None."""


@dataclass(frozen=True)
class NodalMass:
    """``XM`` line: a point mass on a position node (``values = (m,)``, kg) or an inertia
    tensor on an orientation node (``values = (Ixx, Ixy, Ixz, Iyy, Iyz, Izz)``, kg m^2,
    tensor components in the node's body frame, which coincides with the global axes in
    the initial configuration)."""

    node: int
    values: tuple
    loc: SourceLoc | None = None


@dataclass(frozen=True)
class UserRoutine:
    """A ``USERSIG name`` (nodal loads) or ``USERINP name`` (prescribed motion) line: a user
    routine the run calls (docs/user-routines.md). The model only names it; the code is
    found and loaded at the edge (``spacarpy run --allow-user-code``)."""

    keyword: str
    name: str
    loc: SourceLoc | None = None


@dataclass
class Model:
    """A complete, validated spacarpy model.

    Attributes
    ----------
    position_ids : (n_pos,) int
        Deck numbers of the position nodes, in the order of ``position_x0``.
    position_x0 : (n_pos, 3) float
        Initial positions (m).
    orientation_ids : (n_rot,) int
        Deck numbers of the orientation nodes (all start at the identity).
    elements : dict of str -> ElementSet
        The elements by kind (deck keyword), in the registry's order
        (:data:`spacarpy.elements.registry.KINDS`), only kinds the model has.
    fixes : list of Fix
    loads : list of Load
    line_loads : list of LineLoad
        The line loads on beams (QE/DELQE), in deck order.
    follower_loads : list of FollowerLoad
        The XFL/DELXFL lines (follower loads in the current axes of an orientation node).
    follower_line_loads : list of FollowerLineLoad
        The QEL/DELQEL lines (follower line loads in the element's current axes).
    nodal_masses : list of NodalMass
    prescribed : list of Prescribed
        Prescribed (input) coordinates with their initial values and increments.
    prescribed_rotations : list of PrescribedRotation
        Orientation nodes turned about a fixed axis (spacarpy extension).
    prescribed_deformations : list of PrescribedDeformation
        Element deformation modes driven along the load path (INPUTE/DELINPE).
    gravity : (3,) float
        Gravitational acceleration (m/s^2) acting on element and nodal masses; applied with
        the initial load (XF) and constant over the load steps.
    cross_sections : spacarpy.deck.visualization.CrossSections or None
        Cross-section shapes and dimensions per element from the deck's VISUALIZATION
        section (BEAMPROPS/CROSSTYPE/CROSSDIM), for stresses and plots.
    planar : bool
        A planar model (PLBEAM, PLTRUSS, PLHINGE): every node stays in the x-y plane (z and
        the Euler parameters lambda1, lambda2 are held at 0; only rotations about z).
    damping, element_damping
        Rayleigh damping ``(alpha, beta)`` (DAMPING: ``alpha M + beta K0``) and the viscous
        damping of deformation modes per element (EDAMP), used by the transient analysis.
    element_prestress : dict
        Element -> initial stress resultants per deformation mode (ESIG): the stress
        resultant of a flexible or released mode is ``sigma0 + S e``.
    initial_rates : dict
        (element, mode) -> initial deformation rate of a transient run (STARTDE).
    kinematic : list of Kinematic
        The kinematic coordinates (KINX) and deformations (KINE), in deck order; a KINE
        entry marks its mode KINEMATIC in the element set's ``def_class``.
    dynamic_coords : list of DynamicCoordinate
        The DYNX coordinates (nodal coordinates as degrees of freedom), in deck order.
    user_routines : list of UserRoutine
        The USERSIG and USERINP lines (at most one of each).
    source_path, source_text : str
        Where the deck came from and its text verbatim (stored in the results file).
    warping_ids : (n_warp,) int
        Deck numbers of the warping nodes (a BEAMW's; one coordinate each, the rate of
        twist, starting at 0).
    """

    position_ids: np.ndarray
    position_x0: np.ndarray
    orientation_ids: np.ndarray
    elements: dict = field(default_factory=dict)
    fixes: list = field(default_factory=list)
    loads: list = field(default_factory=list)
    line_loads: list = field(default_factory=list)
    nodal_masses: list = field(default_factory=list)
    prescribed: list = field(default_factory=list)
    prescribed_rotations: list = field(default_factory=list)
    prescribed_deformations: list = field(default_factory=list)
    gravity: tuple = (0.0, 0.0, 0.0)
    cross_sections: object | None = None
    planar: bool = False
    damping: tuple = (0.0, 0.0)             # Rayleigh (alpha, beta) of DAMPING
    element_damping: dict = field(default_factory=dict)   # element -> EDAMP values per mode
    element_prestress: dict = field(default_factory=dict)  # element -> ESIG values per mode
    initial_rates: dict = field(default_factory=dict)      # (element, mode) -> STARTDE rate
    kinematic: list = field(default_factory=list)          # KINX / KINE lines (Kinematic)
    dynamic_coords: list = field(default_factory=list)     # DYNX lines (DynamicCoordinate)
    user_routines: list = field(default_factory=list)      # USERSIG / USERINP (UserRoutine)
    source_path: str = "<model>"
    source_text: str = ""
    warping_ids: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    follower_loads: list = field(default_factory=list)     # XFL / DELXFL (FollowerLoad)
    follower_line_loads: list = field(default_factory=list)  # QEL / DELQEL

    def __post_init__(self):
        self.position_ids = np.asarray(self.position_ids, dtype=np.int64).reshape(-1)
        self.position_x0 = np.asarray(self.position_x0, dtype=float).reshape(-1, 3)
        self.orientation_ids = np.asarray(self.orientation_ids, dtype=np.int64).reshape(-1)
        self.warping_ids = np.asarray(self.warping_ids, dtype=np.int64).reshape(-1)
        for keyword, es in self.elements.items():
            if es.kind != keyword:
                raise ValueError(f"elements[{keyword!r}] holds {es.kind} elements")
        self.elements = {k: self.elements[k] for k in KINDS
                         if k in self.elements and self.elements[k].n_elem}
        for kin in self.kinematic:
            if kin.keyword != "KINE":
                continue
            for es in self.elements.values():
                hit = np.flatnonzero(es.ids == kin.target)
                if hit.size and 1 <= kin.number <= es.def_class.shape[1]:
                    es.def_class[hit[0], kin.number - 1] = KINEMATIC

    @property
    def n_elem(self) -> int:
        """The number of elements of all kinds."""
        return sum(es.n_elem for es in self.elements.values())

    def __repr__(self) -> str:
        return (f"Model({self.position_ids.size} position nodes, {self.orientation_ids.size} "
                f"orientation nodes, {self.n_elem} elements, {len(self.fixes)} fixes, "
                f"{len(self.loads)} loads)")
