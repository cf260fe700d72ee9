"""Deck semantics, the coordinate classes of the kinematics module: KINX, KINE and DYNX.

``KINX n c`` makes coordinate c of node n kinematic, ``KINE e k`` deformation mode k of
element e (SPACAR's class K, docs/rolling.md): free in the holonomic constraints, with a rate
that the slips held at zero fix. Checked here, each error at the field: nodes and elements
that do not exist, coordinate and mode numbers out of range, a coordinate that is also fixed
(FIX) or prescribed (INPUTX), a mode that is also flexible (DYNE), released (RLSE) or
prescribed (INPUTE), a slip mode (a velocity-level mode cannot be a coordinate), and a
coordinate or mode given twice. Whether their number matches the slips and whether the slips
determine their rates needs the model's Jacobians: :mod:`spacarpy.solvers.statics.nonholonomic`.

``DYNX n [c ...]`` makes coordinates c of node n (all of them without c) dynamic: degrees of
freedom (SPACAR's class m). Checked the same way (a coordinate also fixed, prescribed by
INPUTX/INPUTR or kinematic, or given twice, is an error at its field); whether the DYNX
coordinates and DYNE modes parameterize the model exactly needs its Jacobians:
:mod:`spacarpy.solvers.statics.dynamic_coords`.
"""
from __future__ import annotations

from spacarpy.deck.semantics.errors import DeckContext, ErrorCollector
from spacarpy.deck.semantics.topology import Topology, UsesTopology
from spacarpy.deck.statement import Statement
from spacarpy.elements.registry import KINDS
from spacarpy.model import FLEXIBLE, KINEMATIC, RIGID, DynamicCoordinate, Kinematic

__all__ = ["from_statements"]


class _KinematicPass(UsesTopology):
    def __init__(self, ctx: DeckContext, errors: ErrorCollector, topology: Topology,
                 constraints):
        self.ctx, self.errors, self.topology = ctx, errors, topology
        self.constraints = constraints
        self.seen: dict[tuple, Statement] = {}
        self.out: list[Kinematic] = []
        self.dynamic: list[DynamicCoordinate] = []

    def _once(self, key: tuple, st: Statement, loc, what: str) -> bool:
        first = self.seen.get(key)
        if first is not None:
            self.error(loc, f"{st.keyword}: {what} is declared kinematic twice (lines "
                            f"{first.loc.line} and {st.loc.line})", st)
            return False
        self.seen[key] = st
        return True

    def kinx(self, st: Statement) -> None:
        """``KINX n c ...``: kinematic nodal coordinates."""
        node = self.coordinate_node(st)
        if node is None:
            return
        n, kind, size = node
        if len(st.fields) == 1:
            self.error(st.loc, f"KINX {n}: expected coordinate numbers after the node number "
                               f"(1 to {size} for a {kind} node)", st)
            return
        for i, c in enumerate(st.fields[1:], start=1):
            loc = st.field_locs[i]
            if not 1 <= c <= size:
                article = "an" if kind[0] in "aeiou" else "a"
                self.error(loc, f"KINX: node {n} is {article} {kind} node with coordinates 1 "
                                f"to {size}, got {c}", st)
                continue
            fix = self.constraints.fix_lines.get((n, c))
            if fix is not None:
                self.error(loc, f"KINX: coordinate {c} of node {n} is also fixed (FIX at line "
                                f"{fix.loc.line}); a kinematic coordinate moves", st)
                continue
            presc = self.constraints.prescribed.get((n, c))
            if presc is not None:
                self.error(loc, f"KINX: coordinate {c} of node {n} is also prescribed (INPUTX "
                                f"at line {presc['loc'].line}); a coordinate is either "
                                "prescribed or kinematic", st)
                continue
            if self._once(("KINX", n, c), st, loc, f"coordinate {c} of node {n}"):
                self.out.append(Kinematic("KINX", int(n), int(c), loc=st.loc))

    def dynx(self, st: Statement, kinx: set) -> None:
        """``DYNX n [c ...]``: dynamic nodal coordinates (all of the node's without c)."""
        node = self.coordinate_node(st)
        if node is None:
            return
        n, kind, size = node
        coords = st.fields[1:] or tuple(range(1, size + 1))
        for i, c in enumerate(coords, start=1):
            loc = st.field_locs[i] if i < len(st.field_locs) else st.loc
            if not 1 <= c <= size:
                article = "an" if kind[0] in "aeiou" else "a"
                plane = "planar " if self.planar else ""
                self.error(loc, f"DYNX: node {n} is {article} {plane}{kind} node with "
                                f"coordinates 1 to {size}, got {c}", st)
                continue
            fix = self.constraints.fix_lines.get((n, c))
            if fix is not None:
                self.error(loc, f"DYNX: coordinate {c} of node {n} is also fixed (FIX at line "
                                f"{fix.loc.line}); a coordinate is either fixed or a degree "
                                "of freedom", st)
                continue
            presc = self.constraints.prescribed.get((n, c))
            rot = self.constraints.rotations.get(n)
            if presc is not None or rot is not None:
                what = "INPUTX" if presc is not None else "INPUTR/INPUTX"
                line = (presc or rot)["loc"].line
                self.error(loc, f"DYNX: coordinate {c} of node {n} is also prescribed ({what} "
                                f"at line {line}); a coordinate is either prescribed or a "
                                "degree of freedom", st)
                continue
            if (n, c) in kinx:
                self.error(loc, f"DYNX: coordinate {c} of node {n} is also kinematic (KINX); "
                                "a coordinate is either kinematic or a degree of freedom", st)
                continue
            first = self.seen.get(("DYNX", n, c))
            if first is not None:
                self.error(loc, f"DYNX: coordinate {c} of node {n} is declared dynamic twice "
                                f"(lines {first.loc.line} and {st.loc.line})", st)
                continue
            self.seen[("DYNX", n, c)] = st
            self.dynamic.append(DynamicCoordinate(int(n), int(c), loc=st.loc))

    def kine(self, st: Statement) -> None:
        """``KINE e k ...``: kinematic deformation modes."""
        el = self.element_for(st)
        if el is None:
            return
        n_def = el.info["n_def"]
        if len(st.fields) == 1:
            self.error(st.loc, f"KINE {el.id}: expected deformation mode numbers after the "
                               f"element number (1 to {n_def} for a {el.keyword})", st)
            return
        slips = getattr(KINDS[el.keyword], "velocity_modes", ())
        for i, k in enumerate(st.fields[1:], start=1):
            loc = st.field_locs[i]
            if not 1 <= k <= n_def:
                modes = f"modes 1 to {n_def}" if n_def > 1 else "mode 1 only"
                self.error(loc, f"KINE: element {el.id} is a {el.keyword} with deformation "
                                f"{modes}, got {k}", st)
                continue
            if k - 1 in slips:
                self.error(loc, f"KINE: mode {k} of {el.keyword} {el.id} is a slip (a "
                                "velocity-level constraint), not a coordinate; declare the "
                                "coordinates whose rates the slips fix kinematic", st)
                continue
            cls = el.def_class[k - 1]
            if cls not in (RIGID, KINEMATIC):
                what = "DYNE" if cls == FLEXIBLE else "RLSE"
                self.error(loc, f"KINE: deformation {k} of element {el.id} is also listed in "
                                f"{what} (line {el.class_line[k - 1]}); a mode is either "
                                f"{'dynamic' if cls == FLEXIBLE else 'calculable'} or "
                                "kinematic", st)
                continue
            presc = self.constraints.input_deformations.get((el.id, k))
            if presc is not None:
                self.error(loc, f"KINE: deformation {k} of element {el.id} is also prescribed "
                                f"(INPUTE at line {presc['loc'].line}); a mode is either "
                                "prescribed or kinematic", st)
                continue
            if self._once(("KINE", el.id, k), st, loc, f"deformation {k} of element {el.id}"):
                el.def_class[k - 1] = KINEMATIC
                el.class_line[k - 1] = st.line
                self.out.append(Kinematic("KINE", int(el.id), int(k), loc=st.loc))


def from_statements(by_kw: dict, ctx: DeckContext, errors: ErrorCollector,
                    topology: Topology, constraints) -> tuple[list, list]:
    """The :class:`~spacarpy.model.Kinematic` entries of the KINX and KINE lines and the
    :class:`~spacarpy.model.DynamicCoordinate` entries of the DYNX lines (deck order), after
    the element data and the constraints (``constraints``: the
    :class:`~spacarpy.deck.semantics.constraints.Constraints`); problems go to ``errors``."""
    part = _KinematicPass(ctx, errors, topology, constraints)
    for st in ctx.in_deck_order("KINX", "KINE"):
        if st.module != 0:
            errors.error(st.loc, f"{st.keyword} belongs in the kinematics module (before the "
                                 "first END)", st)
        elif st.keyword == "KINX":
            part.kinx(st)
        else:
            part.kine(st)
    kinx = {(k.target, k.number) for k in part.out if k.keyword == "KINX"}
    for st in ctx.in_deck_order("DYNX"):
        if st.module != 0:
            errors.error(st.loc, "DYNX belongs in the kinematics module (before the first "
                                 "END)", st)
        else:
            part.dynx(st, kinx)
    return part.out, part.dynamic
