"""Deck semantics, topology: nodes, elements and their geometry.

X lines become position nodes; the element lines of every supported kind (facts from
:mod:`spacarpy.elements.registry`) become :class:`ElementRecord` s with their nodes and
orientation vector. Checked here: doubly defined nodes and elements, position versus
orientation nodes, zero-length elements and orientation vectors (nearly) zero or parallel to
the element (all elements at once), a planar model with non-planar elements or z != 0, and,
once the fixes are known, position nodes no element uses.
"""
from __future__ import annotations

import operator

import numpy as np

from spacarpy.deck.keywords import KEYWORDS, UNKNOWN_LAYOUT_ELEMENTS, UNSUPPORTED_ELEMENTS
from spacarpy.deck.semantics.errors import DeckContext, ErrorCollector, Part
from spacarpy.deck.statement import Statement
from spacarpy.elements.registry import KINDS, PLANAR_KINDS
from spacarpy.errors import SourceLoc
from spacarpy.model import RIGID

__all__ = ["ELEMENT_KEYWORDS", "NODE_SIZE", "ORIENTATION_TOL", "ZERO_LENGTH_RTOL", "ElementRecord",
           "Topology", "UsesTopology", "from_statements"]

#: Relative length below which an element counts as zero-length (times the largest
#: coordinate magnitude of its two end nodes).
ZERO_LENGTH_RTOL = 1e-12
#: Coordinates of each node kind (a warping node, a BEAMW's, has one: the rate of twist).
NODE_SIZE = {"position": 3, "orientation": 4, "warping": 1}
#: Orientation vectors shorter than this, or with ``|n_x x o| < this * |o|``, are rejected
#: (SPACAR's getLocalframe rule).
ORIENTATION_TOL = 1e-5


def _row_norms(v: np.ndarray) -> np.ndarray:
    """The length of each row of v (n, 3), computed as np.linalg.norm computes the length of
    one vector (the square root of a dot product), so that checks made for all elements at
    once give exactly the results they gave element by element."""
    return np.sqrt(np.matmul(v[:, None, :], v[:, :, None])[:, 0, 0])


def _lookup(ids: np.ndarray, values: np.ndarray):
    """Where each of ``values`` is in ``ids`` (distinct numbers): ``(index, found)``, arrays of
    the shape of values; index means nothing where found is False."""
    if len(ids) == 0:
        return np.zeros(values.shape, dtype=np.intp), np.zeros(values.shape, dtype=bool)
    order = np.argsort(ids)
    k = np.minimum(np.searchsorted(ids, values, sorter=order), len(ids) - 1)
    index = order[k]
    return index, ids[index] == values


def _element_name(st: Statement, e: int) -> str:
    """'element 7', or 'element 7 (made by the BEAMARC line)' for generated elements."""
    return f"element {e}" + (f" (made by the {st.origin} line)" if st.origin else "")


def _picker(indices):
    """A function giving the tuple of the items at ``indices`` of a sequence."""
    if len(indices) > 1:
        return operator.itemgetter(*indices)
    return lambda values: tuple(values[i] for i in indices)


def _kind_info(kind) -> dict:
    """What the semantics check of an element kind, from its declaration: number of
    deformation modes, index of the first vector field (orientation / hinge axis) or None,
    allowed ESTIFF value counts, the stiffness names, which ESTIFF value carries each mode's
    stiffness, whether (and how much) EM applies, whether a zero length is allowed and the
    kind's own reference checks. A kind without ESTIFF (the WHEEL) takes no stiffness."""
    est, em = kind.estiff, kind.em
    roles = KEYWORDS[kind.keyword].node_roles
    info = dict(n_def=kind.n_def, vector_at=1 + len(kind.slots) if kind.vector else None,
                roles=roles, mode_stiffnesses=_picker(sorted(set(kind.mode_stiffness))),
                nodes=_picker(range(1, 1 + len(roles))),
                no_stiffness=(0.0,) * (6 if kind.keyword in ("BEAM", "BEAMC") else est.width
                                       if kind.keyword == "BEAMW" else 3 if est else 0),
                position_nodes=_picker([i for i, r in enumerate(roles, start=1) if r == "p"]),
                orientation_nodes=_picker([i for i, r in enumerate(roles, start=1)
                                           if r == "r"]),
                position_fields=[i for i, r in enumerate(roles, start=1) if r == "p"],
                orientation_fields=[i for i, r in enumerate(roles, start=1) if r == "r"],
                warping_fields=[i for i, r in enumerate(roles, start=1) if r == "w"],
                n_estiff=(est.required, est.allowed) if est is not None else (0, 0),
                stiff_names=est.names if est is not None else (),
                mode_stiffness=kind.mode_stiffness, has_mass=em is not None,
                estiff_usage=est.usage if est is not None else "",
                zero_length_ok=kind.zero_length, reference_problems=kind.reference_problems,
                vector_point=kind.vector_point,
                flexible_ok=est is not None, no_stiffness_why=kind.no_stiffness_why,
                always_free=kind.always_free, em_width=max(5, em.width) if em else 5)
    if em is not None and em.allowed is not None:
        info.update(n_em=em.allowed, em_usage=em.usage)
    return info


KIND_INFO = {keyword: _kind_info(kind) for keyword, kind in KINDS.items()}
#: The element keywords the semantics support, in the order the model keeps them.
ELEMENT_KEYWORDS = tuple(KIND_INFO)


def vectors_of(elements) -> np.ndarray:
    """The orientation vector (hinge axis) of each element, (n, 3), NaN rows where none is
    given."""
    out = np.full((len(elements), 3), np.nan)
    given = [i for i, b in enumerate(elements) if b.info["vector_at"] is not None
             and len(b.st.fields) >= b.info["vector_at"] + 3]
    if given:
        out[given] = [b.st.fields[b.info["vector_at"]:b.info["vector_at"] + 3]
                      for b in (elements[i] for i in given)]
    return out


class ElementRecord:
    """One element line (of any supported kind) while the model is being built; the element
    data (:mod:`spacarpy.deck.semantics.element_data`) fill in its classes, stiffness and
    mass."""

    # not yet given: the element data replace these (class-wide, immutable) defaults
    estiff: Statement | None = None
    mass = (0.0,) * 5
    em: Statement | None = None

    def __init__(self, st: Statement):
        self.st = st
        keyword = self.keyword = st.keyword
        info = self.info = KIND_INFO[keyword]
        self.id = st.fields[0]
        n_def = info["n_def"]
        self.def_class = [RIGID] * n_def
        self.class_line = [0] * n_def      # line of the DYNE/RLSE that set each mode
        self.flex_locs: dict[int, tuple] = {}   # mode -> (DYNE statement, field index)
        self.stiffness = info["no_stiffness"]
        if info["em_width"] != 5:
            self.mass = (0.0,) * info["em_width"]

    # made from the element line when asked for (all elements at once: the info's getters)
    @property
    def roles(self) -> str:
        return self.info["roles"]

    @property
    def nodes(self) -> list:
        return list(self.info["nodes"](self.st.fields))

    @property
    def position_nodes(self) -> list:
        return list(self.info["position_nodes"](self.st.fields))

    @property
    def vector_given(self) -> bool:
        at = self.info["vector_at"]
        return at is not None and len(self.st.fields) >= at + 3

    @property
    def orientation(self) -> tuple:
        at = self.info["vector_at"]
        return (tuple(self.st.fields[at:at + 3]) if self.vector_given
                else (np.nan, np.nan, np.nan))


    def flex_loc(self, mode: int) -> SourceLoc:
        """Where mode (1-based) was made flexible: the field of its first DYNE line."""
        st, i = self.flex_locs[mode]
        return st.field_locs[i]


class Topology(Part):
    """The nodes and elements of a deck.

    Attributes
    ----------
    positions : dict
        Position node -> ((x, y, z), its X statement), in deck order.
    orientation_use : dict
        Orientation node -> the first element line using it.
    warping_use : dict
        Warping node (a BEAMW's) -> the first element line using it.
    elements : dict
        Element number -> :class:`ElementRecord`, all kinds, in deck order.
    """

    def __init__(self, ctx: DeckContext, errors: ErrorCollector):
        self.ctx, self.errors = ctx, errors
        self.positions: dict[int, tuple[tuple, Statement]] = {}
        self.orientation_use: dict[int, Statement] = {}
        self.warping_use: dict[int, Statement] = {}
        self.elements: dict[int, ElementRecord] = {}

    def node_kind(self, n: int) -> str | None:
        """``"position"``, ``"orientation"``, ``"warping"`` or None (not defined)."""
        if n in self.positions:
            return "position"
        if n in self.orientation_use:
            return "orientation"
        if n in self.warping_use:
            return "warping"
        return None

    def node(self, st: Statement) -> None:
        """An X line."""
        n = st.fields[0]
        if len(st.fields) == 3:
            if not self.planar:
                self.error(st.loc, f"X {n}: expected x y z (3 coordinates), got 2; only a planar "
                                   "model (PLBEAM, PLTRUSS, PLHINGE) may leave out z", st)
                return
        elif self.planar and st.fields[3] != 0:
            self.error(st.field_locs[3], f"X {n}: a planar model lies in the x-y plane, but "
                                         f"z = {st.fields[3]:g}", st)
            return
        if n in self.positions:
            first = self.positions[n][1]
            self.error(st.field_locs[0], f"node {n} has two X lines (lines {first.loc.line} and "
                                         f"{st.loc.line})", st)
            return
        self.positions[n] = ((tuple(st.fields[1:4]) + (0.0,))[:3], st)

    def check_planar(self, element_sts) -> None:
        """A planar model has only planar elements (their nodes have planar coordinates)."""
        first = next(st for st in element_sts if st.keyword in PLANAR_KINDS)
        for st in element_sts:
            if st.keyword not in PLANAR_KINDS:
                what = f"the {st.origin} line" if st.origin else st.keyword
                self.error(st.loc, f"{what}: a planar model ({first.keyword} at line "
                                   f"{first.loc.line}) has planar elements only (PLBEAM, "
                                   "PLTRUSS, PLHINGE); model it in space instead", st)

    def element_geometry(self, elements: list[ElementRecord]):
        """Geometry checks of all elements at once: for each, whether it has zero length and
        whether its orientation vector (hinge axis) is (nearly) zero or parallel to the element
        axis (SPACAR's getLocalframe rule). Meaningless for an element with an undefined
        position node: :meth:`element` reports that and looks no further.

        Returns
        -------
        iterator of (zero_length, zero_vector, parallel), one per element
        """
        n = len(elements)
        ids = np.fromiter(self.positions, dtype=np.int64, count=len(self.positions))
        x = np.array([xyz for xyz, _ in self.positions.values()], dtype=float).reshape(-1, 3)
        # rows of x of each element's two position nodes (HINGEs have none)
        two = np.array([len(b.info["position_fields"]) == 2 for b in elements], dtype=bool)
        ends = np.array([b.info["position_nodes"](b.st.fields) if len(b.info["position_fields"])
                         == 2 else (0, 0) for b in elements], dtype=np.int64).reshape(n, 2)
        rows, found = _lookup(ids, ends)
        has_axis = two & found.all(axis=1)
        d = x[rows[:, 1]] - x[rows[:, 0]] if len(ids) else np.zeros((n, 3))
        length = _row_norms(d)
        # an element is zero-length when its length is below the round-off of its own end
        # coordinates (not of the whole model: a far node must not shorten a near element)
        with np.errstate(over="ignore", invalid="ignore"):
            scale = (np.maximum(np.abs(x[rows[:, 0]]).max(axis=1),
                                np.abs(x[rows[:, 1]]).max(axis=1)) if len(ids) else np.zeros(n))
        may_coincide = np.array([b.info["zero_length_ok"] for b in elements], dtype=bool)
        short = has_axis & (length <= ZERO_LENGTH_RTOL * scale)
        zero_length = short & ~may_coincide
        axis = np.divide(d, length[:, None], out=np.full_like(d, np.nan),
                         where=(has_axis & ~short)[:, None])
        vector = vectors_of(elements)
        vector_norm = _row_norms(vector)                   # NaN where no vector is given
        zero_vector = vector_norm < ORIENTATION_TOL
        parallel = _row_norms(np.cross(axis, vector)) < ORIENTATION_TOL * vector_norm
        # a kind with reference checks of its own (the WHEEL's axle) is not a local y-axis
        own = np.array([b.info["reference_problems"] is not None for b in elements], dtype=bool)
        parallel &= ~own
        # a point (the BEAMC's arc centre) may be anywhere, the origin too
        zero_vector &= ~np.array([b.info["vector_point"] for b in elements], dtype=bool)
        return zip(zero_length.tolist(), zero_vector.tolist(), parallel.tolist())

    def element(self, b: ElementRecord, zero_length: bool, zero_vector: bool,
                parallel: bool) -> None:
        """An element record of any supported kind; the geometry flags come from
        :meth:`element_geometry`."""
        positions = self.positions
        if not (zero_length or b.id in self.elements or b.id in self.foreign_elements
                or (b.vector_given and (zero_vector or parallel))
                or (b.keyword == "HINGE" and not b.vector_given)
                or b.info["reference_problems"] is not None):
            fields = b.st.fields
            info = b.info
            has = positions.__contains__
            if all(map(has, info["position_nodes"](fields))) and \
                    not any(map(has, info["orientation_nodes"](fields))) and \
                    not info["warping_fields"]:
                self.elements[b.id] = b         # nothing to report
                return
        st = b.st
        ok = True
        if b.id in self.elements:
            first = self.elements[b.id].st
            self.error(st.field_locs[0], f"element {b.id} is defined twice (lines "
                                         f"{first.loc.line} and {st.loc.line})", st)
            return
        if b.id in self.foreign_elements:
            self.error(st.field_locs[0], f"element number {b.id} is also used by an "
                                         "unsupported element", st)
        name = _element_name(st, b.id)
        slots = {0: "p", 1: "q"}
        pos_k = rot_k = warp_k = 0
        for i, role in enumerate(b.roles, start=1):
            n = st.fields[i]
            if role == "p":
                slot = slots.get(pos_k, "?")
                pos_k += 1
                if n not in self.positions:
                    ok = False
                    msg = f"{name}: position node {n} (at {slot}) has no X line"
                    use = self.orientation_use.get(n)
                    if use is not None:
                        msg += f"; node {n} is used as an orientation node (line {use.loc.line})"
                    self.error(st.field_locs[i], msg, st)
            elif role == "w":
                slot = slots.get(warp_k, "?")
                warp_k += 1
                clash = ("a position node (X at line "
                         f"{self.positions[n][1].loc.line})" if n in self.positions else
                         "an orientation node (line "
                         f"{self.orientation_use[n].loc.line})" if n in self.orientation_use
                         else None)
                if clash:
                    ok = False
                    self.error(st.field_locs[i], f"{name}: node {n} is {clash} and cannot be "
                                                 f"the warping node at {slot}", st)
            else:
                slot = slots.get(rot_k, "?")
                rot_k += 1
                if n in self.positions:
                    ok = False
                    self.error(st.field_locs[i],
                               f"{name}: node {n} is a position node (X at line "
                               f"{self.positions[n][1].loc.line}) and cannot be the "
                               f"orientation node at {slot}", st)
        self.elements[b.id] = b
        if not ok:
            return
        at = b.info["vector_at"]
        if zero_length:
            self.error(st.loc, f"{name} has zero length: nodes {b.position_nodes[0]} and "
                               f"{b.position_nodes[1]} are at the same position", st)
            return
        if b.keyword == "HINGE" and not b.vector_given:
            self.error(st.loc, f"{name}: a HINGE needs its axis: HINGE {b.id} {b.nodes[0]} "
                               f"{b.nodes[1]} ax ay az", st)
            return
        if b.vector_given and (zero_vector or parallel):
            shown = "(" + ", ".join(f"{v:g}" for v in b.orientation) + ")"
            what = {"HINGE": "hinge axis", "WHEEL": "axle"}.get(b.keyword,
                                                                "orientation vector")
            if zero_vector:
                self.error(st.field_locs[at], f"{name}: the {what} {shown} is (nearly) zero",
                           st)
            else:
                self.error(st.field_locs[at],
                           f"{name}: the orientation vector {shown} is parallel to the element "
                           f"axis (node {b.position_nodes[0]} to node {b.position_nodes[1]}); "
                           "give the local y-axis, perpendicular to the element", st)
            return
        if b.info["reference_problems"] is not None:
            self.reference_problems(b)

    def reference_problems(self, b: ElementRecord) -> None:
        """The kind's own checks of the reference configuration (the WHEEL's), each an error
        at the element line."""
        x0 = [np.array([self.positions[n][0]], dtype=float) if role == "p" else None
              for role, n in zip(b.roles, b.nodes)]
        vector = np.array([b.orientation], dtype=float)
        for _, msg in b.info["reference_problems"](x0, vector):
            self.error(b.st.loc, f"{b.keyword} {b.id}: {msg}", b.st)

    def element_for(self, st: Statement) -> ElementRecord | None:
        """The element an element-data record refers to; reports unknown elements."""
        e = st.fields[0]
        beam = self.elements.get(e)
        if beam is None and e not in self.foreign_elements and e not in self.quiet_elements:
            self.error(st.field_locs[0], f"{st.keyword}: element {e} is not defined "
                                         "(no element line)", st)
        return beam

    def check_unconnected(self, fixes: dict) -> None:
        """A position node no element uses floats free (a mechanism): an error, unless all
        its coordinates are fixed (then it is merely useless: a warning)."""
        used = ({n for b in self.elements.values() for n in b.info["position_nodes"](b.st.fields)}
                | self.foreign_nodes | self.quiet_nodes)
        for n, (_, st) in self.positions.items():
            if n in used:
                continue
            if fixes.get(n, (set(),))[0] >= {1, 2, 3}:
                self.errors.warn(f"{st.loc}: position node {n} is not connected to any "
                                     "element (it is fixed, so it does nothing)")
            else:
                self.error(st.field_locs[0], f"position node {n} is not connected to any "
                                             "element: it would float free (a mechanism); "
                                             "connect it, FIX it, or remove its X line", st)

    def check_cross_section_elements(self, sections) -> None:
        """Warn about cross-sections given for elements that do not exist."""
        for e, cs in sections.by_element.items():
            if e not in self.elements and e not in self.foreign_elements \
                    and e not in self.quiet_elements:
                self.errors.warn(f"{cs.loc}: a cross-section is given for element {e}, "
                                     "which is not defined")

    def note_foreign(self, st: Statement) -> None:
        """Remember the element and nodes of an unsupported element keyword."""
        roles = KEYWORDS[st.keyword].node_roles
        if not st.fields:
            return
        if not roles:            # layout unknown (PINBODY, WHEEL, ...): whole numbers only
            numbers = [f for f in st.fields if isinstance(f, (int, float))
                       and not isinstance(f, bool) and float(f).is_integer() and f >= 1]
            self.foreign_elements.update(int(f) for f in numbers[:1])
            self.foreign_nodes.update(int(f) for f in numbers[1:])
            return
        self.foreign_elements.add(st.fields[0])
        self.foreign_nodes.update(st.fields[1:1 + len(roles)])


def from_statements(by_kw: dict, ctx: DeckContext, errors: ErrorCollector) -> Topology:
    """The nodes and elements of the statements (by keyword), every problem reported to
    ``errors``. Unsupported element keywords are reported here too ("not supported yet"
    comes from the build), their elements and nodes noted in ``ctx``."""
    topology = Topology(ctx, errors)
    for keyword in UNSUPPORTED_ELEMENTS + UNKNOWN_LAYOUT_ELEMENTS:
        for st in by_kw.get(keyword, []):
            topology.note_foreign(st)
    x_sts = by_kw.get("X", [])
    ids = [st.fields[0] for st in x_sts]
    if not ctx.planar and len(set(ids)) == len(ids) and all(len(st.fields) == 4 for st in x_sts):
        topology.positions = dict(zip(ids, zip([st.fields[1:4] for st in x_sts], x_sts)))
    else:
        for st in x_sts:
            topology.node(st)
    kinds = [kw for kw in ELEMENT_KEYWORDS if kw in by_kw]
    element_sts = [st for kw in kinds for st in by_kw[kw]]
    if len(kinds) > 1:
        element_sts.sort(key=errors.order)
    use = topology.orientation_use
    for st in element_sts:
        fields = st.fields
        for i in KIND_INFO[st.keyword]["orientation_fields"]:
            if fields[i] not in use:
                use[fields[i]] = st
        for i in KIND_INFO[st.keyword]["warping_fields"]:
            topology.warping_use.setdefault(fields[i], st)
    elements = [ElementRecord(st) for st in element_sts]
    for b, geometry in zip(elements, topology.element_geometry(elements)):
        topology.element(b, *geometry)
    if ctx.planar:
        topology.check_planar(element_sts)
    return topology


class UsesTopology(Part):
    """Base of the parts that refer to nodes and elements: ``self.topology``, with short
    names for what they look up in it."""

    topology: Topology

    def node_kind(self, n: int) -> str | None:
        return self.topology.node_kind(n)

    def coordinate_node(self, st: Statement) -> tuple[int, str, int] | None:
        """The node of a line about node coordinates (FIX, INPUTX, KINX, DYNX: the first
        field), its kind and its number of coordinates (planar: x, y or the angle); None,
        with the error reported (unless the node belongs to a refused element), where the
        node is not defined."""
        n = st.fields[0]
        kind = self.node_kind(n)
        if kind is None:
            if n not in self.foreign_nodes:
                self.error(st.field_locs[0], f"{st.keyword}: node {n} is not defined (no X line "
                                             "and not used by any element)", st)
            return None
        if self.planar:
            return n, kind, 2 if kind == "position" else 1
        return n, kind, NODE_SIZE[kind]

    def element_for(self, st: Statement) -> ElementRecord | None:
        return self.topology.element_for(st)

    @property
    def positions(self) -> dict:
        return self.topology.positions

    @property
    def beams(self) -> dict:
        """All element records, by number (of every kind; the name is SPACAR's habit)."""
        return self.topology.elements
