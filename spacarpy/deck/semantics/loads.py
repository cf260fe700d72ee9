"""Deck semantics, loads and masses: XF/DELXF, the follower loads XFL/DELXFL and QEL/DELQEL,
QE/DELQE, LOADTF, XM, GRAVITY, and the user routines USERSIG (loads) and USERINP (prescribed
motion), which the model only names.

Dead nodal loads (forces on position nodes, moments on orientation nodes, a planar deck's
fx fy or m), follower loads, dead line loads on beams, the named time functions of load
increments and prescribed motions (LOADTF), point masses and inertia tensors on nodes, and
the gravitational acceleration. Checked here: nodes and elements that do not exist, value
counts for the node's kind, line loads on elements that are not beams, LOADTF lines naming
no TIMEFUNCTION or no load, negative masses, inertia tensors that are not positive
semi-definite, and load components on fixed coordinates (they would go straight into the
support). A follower load's axes node must be an orientation node.
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from spacarpy.deck.semantics.constraints import Constraints
from spacarpy.deck.semantics.errors import DeckContext, ErrorCollector
from spacarpy.deck.semantics.settings import named_time_function
from spacarpy.deck.semantics.topology import Topology, UsesTopology
from spacarpy.deck.statement import Statement
from spacarpy.model import FollowerLineLoad, FollowerLoad, LineLoad, Load, NodalMass, UserRoutine

__all__ = ["LINE_LOAD_KINDS", "Loads", "from_statements"]

#: The element kinds a line load (QE/DELQE) acts on: the beams, whose bending is cubic.
LINE_LOAD_KINDS = ("BEAM", "PLBEAM", "BEAMW")
#: What LOADTF gives a time function: the load increments and the prescribed motions.
_TF_TARGETS = ("DELXF", "DELXFL", "DELQE", "DELQEL", "DELINPX", "DELINPE", "DELINPR")


@dataclass
class Loads:
    """The loads (in deck order), line loads, nodal masses and gravity of a deck, and the
    LOADTF names of the prescribed motions (``("DELINPX", n, c)``, ``("DELINPE", e, k)``,
    ``("DELINPR", n)`` -> name)."""

    loads: list = field(default_factory=list)
    line_loads: list = field(default_factory=list)
    motion_tf: dict = field(default_factory=dict)
    follower_loads: list = field(default_factory=list)
    follower_line_loads: list = field(default_factory=list)
    nodal_masses: list = field(default_factory=list)
    gravity: tuple = (0.0, 0.0, 0.0)
    user_routines: list = field(default_factory=list)


class _LoadsPass(UsesTopology):
    def __init__(self, ctx: DeckContext, errors: ErrorCollector, topology: Topology,
                 constraints: Constraints):
        self.ctx, self.errors = ctx, errors
        self.topology, self.constraints = topology, constraints
        self.result = Loads()
        self.load_sts: list[Statement] = []

    def load(self, st: Statement) -> None:
        """An XF or DELXF line."""
        values = self._load_values(st, st.fields[0], st.fields[1:4])
        if values is not None:
            self.result.loads.append(Load(node=st.fields[0], kind=st.keyword, value=values,
                                          loc=st.loc))
            self.load_sts.append(st)

    def follower(self, st: Statement) -> None:
        """An XFL or DELXFL line: ``n r f1 f2 f3``, components in the axes of node r."""
        n, r = st.fields[0], st.fields[1]
        values = self._load_values(st, n, st.fields[2:5])
        if values is None:
            return
        kind = self.node_kind(r)
        if kind != "orientation":
            what = ("is not defined (no element uses it)" if kind is None
                    else f"is a {kind} node")
            if kind is None and r in self.foreign_nodes:
                return
            self.error(st.field_locs[1], f"{st.keyword}: node {r} {what}: the load's axes "
                                         "are those of an orientation node (the r of a BEAM "
                                         "line)", st)
            return
        self.result.follower_loads.append(FollowerLoad(node=n, axes=r, kind=st.keyword,
                                                       value=values, loc=st.loc))

    def follower_line(self, st: Statement) -> None:
        """A QEL or DELQEL line: ``e q1 q2 q3 [q1 q2 q3 at q]`` on a beam, components in
        its current axes (a planar deck: ``e qx qy [qx qy at q]`` on a PLBEAM)."""
        self.line_load(st, follower=True)

    def _load_values(self, st: Statement, n, fields):
        """The three components of a load line on node n (a planar deck's fx fy or m
        completed), None after an error."""
        usage = f"{st.keyword} {n}" + (f" {st.fields[1]}" if st.keyword.endswith("XFL")
                                        else "")
        if self.node_kind(n) is None:
            if n not in self.foreign_nodes:
                self.error(st.field_locs[0], f"{st.keyword}: node {n} is not defined (no X line "
                                             "and not used by any element)", st)
            return None
        if self.node_kind(n) == "warping":
            self.error(st.field_locs[0], f"{st.keyword}: node {n} is a warping node (BEAMW); "
                                         "a load on it (a bimoment) is not supported", st)
            return None
        values = tuple(float(v) for v in fields)
        if self.planar:
            want, usage = ((2, f"{usage} fx fy") if self.node_kind(n) == "position"
                           else (1, f"{usage} m (the moment about z)"))
            if len(values) != want:
                self.error(st.loc, f"{st.keyword}: node {n} is a planar {self.node_kind(n)} node: "
                                   f"expected {usage}, got {len(values)} value(s)", st)
                return None
            return (values + (0.0,)) if want == 2 else (0.0, 0.0, values[0])
        if len(values) != 3:
            self.error(st.loc, f"{st.keyword}: expected three components ({usage} f1 f2 f3), "
                               f"got {len(values)}", st)
            return None
        return values

    def line_load(self, st: Statement, follower: bool = False) -> None:
        """A QE or DELQE line (or a follower QEL/DELQEL, ``follower``): a line load on a
        beam, uniform or linear."""
        e = st.fields[0]
        b = self.element_for(st)
        if b is None:
            return
        if b.keyword not in LINE_LOAD_KINDS:
            what = "follower line" if follower else "line"
            self.error(st.field_locs[0], f"{st.keyword}: element {e} is a {b.keyword}; a "
                                         f"{what} load acts on a beam "
                                         f"({', '.join(LINE_LOAD_KINDS)})", st)
            return
        values = tuple(float(v) for v in st.fields[1:])
        width = 2 if self.planar else 3
        usage = (f"{st.keyword} {e} qx qy [qx qy at q]" if self.planar
                 else f"{st.keyword} {e} q1 q2 q3 [q1 q2 q3 at q]")
        if len(values) not in (width, 2 * width):
            plane = "a planar deck: " if self.planar else ""
            self.error(st.loc, f"{st.keyword}: expected {width} or {2 * width} components "
                               f"({plane}{usage}), got {len(values)}", st)
            return
        if self.planar:
            values = tuple(v for pair in zip(values[0::2], values[1::2]) for v in (*pair, 0.0))
        q_p = values[:3]
        q_q = values[3:6] if len(values) == 6 else q_p
        cls, where = ((FollowerLineLoad, self.result.follower_line_loads) if follower
                      else (LineLoad, self.result.line_loads))
        where.append(cls(element=e, kind=st.keyword, q_p=q_p, q_q=q_q, loc=st.loc))

    def load_tf(self, st: Statement, names: dict, by_kw: dict, given: dict) -> None:
        """A LOADTF line: the named time function of the load increments (DELXF, DELQE,
        DELXFL, DELQEL) on a node or element, or of a prescribed motion (DELINPX n c, DELINPE e k,
        DELINPR n)."""
        name, what, target = str(st.fields[0]), str(st.fields[1]).upper(), st.fields[2]
        number = st.fields[3] if len(st.fields) > 3 else None
        if name.lower() not in names:
            known = ", ".join(sorted(names)) or "none"
            self.error(st.field_locs[0], f"LOADTF: no TIMEFUNCTION is named {name!r} (named "
                                         f"ones: {known}; write TIMEFUNCTION {name} kind "
                                         "p...)", st)
            return
        if what not in _TF_TARGETS:
            self.error(st.field_locs[1], f"LOADTF: {st.fields[1]} has no time function; "
                                         f"expected one of {', '.join(_TF_TARGETS)}", st)
            return
        wants_number = what in ("DELINPX", "DELINPE")
        if wants_number != (number is not None):
            usage = (f"LOADTF {name} {what} {'n c' if what == 'DELINPX' else 'e k'}"
                     if wants_number else f"LOADTF {name} {what} "
                     f"{'e' if what in ('DELQE', 'DELQEL') else 'n'}")
            self.error(st.loc, f"LOADTF: expected {usage}", st)
            return
        key = (what, target) if number is None else (what, target, number)
        lines = by_kw.get(what, ())
        if what in ("DELQE", "DELQEL"):
            lines = (self.result.line_loads if what == "DELQE"
                     else self.result.follower_line_loads)
            hit = any(ld.element == target for ld in lines if ld.kind == what)
        elif what == "DELXF":
            hit = any(ld.node == target for ld in self.result.loads if ld.kind == "DELXF")
        else:
            hit = any(tuple(x.fields[:len(key) - 1]) == key[1:] for x in lines)
        if not hit:
            thing = "element" if what in ("DELQE", "DELQEL", "DELINPE") else "node"
            extra = f" {number}" if number is not None else ""
            self.error(st.field_locs[2], f"LOADTF: no {what} line on {thing} "
                                         f"{target}{extra}", st)
            return
        first = given.get(key)
        if first is not None:
            self.error(st.loc, f"LOADTF: {what} {target}"
                               f"{'' if number is None else f' {number}'} is given a time "
                               f"function twice (lines {first.loc.line} and {st.loc.line})", st)
            return
        given[key] = st
        self.result.motion_tf[key] = name.lower()

    def check_loads_on_fixed_coordinates(self) -> None:
        """A load component on a fixed coordinate goes straight into the support: an error.

        Force component i acts on coordinate i of a position node; the moment about global
        axis i acts (in the initial configuration) on the Euler parameter lambda_i, coordinate
        i + 1 of an orientation node.
        """
        for st, load in zip(self.load_sts, self.result.loads):
            n = st.fields[0]
            kind = self.node_kind(n)
            for i in range(3):
                if load.value[i] == 0:
                    continue
                coord = i + 1 if kind == "position" else i + 2
                fix = self.constraints.fix_lines.get((n, coord))
                if fix is None:
                    continue
                axis = "xyz"[i]
                if kind == "position":
                    what = (f"the force along {axis} acts on the fixed coordinate {axis} of node "
                            f"{n}")
                else:
                    what = (f"the moment about {axis} acts on the fixed Euler parameter "
                            f"lambda{i + 1} of node {n}, which cannot turn about {axis}")
                self.error(st.field_locs[1 + i], f"{st.keyword} {n}: {what} (FIX at line "
                                                 f"{fix.loc.line}); it would go straight into "
                                                 "the support: remove the load component or "
                                                 "the FIX", st)

    def nodal_mass(self, st: Statement) -> None:
        """An XM line: a point mass or an inertia tensor."""
        n = st.fields[0]
        kind = self.node_kind(n)
        values = tuple(float(v) for v in st.fields[1:])
        if kind is None:
            if n not in self.foreign_nodes:
                self.error(st.field_locs[0], f"XM: node {n} is not defined (no X line and not "
                                             "used by any element)", st)
            return
        if kind == "warping":
            self.error(st.field_locs[0], f"XM: node {n} is a warping node (BEAMW): give its "
                                         "warping inertia as the sixth EM value instead", st)
            return
        if self.planar and kind == "orientation" and len(values) == 1:
            values = (0.0, 0.0, 0.0, 0.0, 0.0, values[0])     # planar: J about z
        if kind == "position" and len(values) != 1:
            self.error(st.field_locs[2], f"XM: node {n} is a position node: give its mass only "
                                         f"(XM {n} m)", st)
            return
        if kind == "orientation" and len(values) != 6:
            self.error(st.field_locs[1], f"XM: node {n} is an orientation node: give its "
                                         f"inertia tensor (XM {n} Ixx Ixy Ixz Iyy Iyz Izz)", st)
            return
        if kind == "position":
            if values[0] < 0:
                self.error(st.field_locs[1], f"XM: the mass must not be negative, got "
                                             f"{values[0]:g}", st)
                return
        else:
            ixx, ixy, ixz, iyy, iyz, izz = values
            tensor = np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]])
            eig = np.linalg.eigvalsh(tensor)
            if eig[0] < -1e-12 * max(abs(eig[-1]), 1e-300):
                self.error(st.field_locs[1], f"XM: the inertia tensor of node {n} is not "
                                             "positive semi-definite (a negative principal "
                                             f"inertia {eig[0]:g})", st)
                return
        self.result.nodal_masses.append(NodalMass(node=n, values=values, loc=st.loc))


def from_statements(by_kw: dict, ctx: DeckContext, errors: ErrorCollector, topology: Topology,
                    constraints: Constraints) -> Loads:
    """The XF/DELXF and XFL/DELXFL (in deck order), XM and GRAVITY lines; problems go to
    ``errors``."""
    part = _LoadsPass(ctx, errors, topology, constraints)
    for st in ctx.in_deck_order("XF", "DELXF"):
        part.load(st)
    for st in ctx.in_deck_order("XFL", "DELXFL"):
        part.follower(st)
    for st in ctx.in_deck_order("QEL", "DELQEL"):
        part.follower_line(st)
    part.check_loads_on_fixed_coordinates()
    for st in ctx.in_deck_order("QE", "DELQE"):
        part.line_load(st)
    names = {named_time_function(st).lower() for st in by_kw.get("TIMEFUNCTION", ())
             if named_time_function(st) is not None}
    given: dict = {}
    for st in by_kw.get("LOADTF", ()):
        part.load_tf(st, names, by_kw, given)
    tf_of = part.result.motion_tf
    if tf_of:
        res = part.result
        res.loads = [replace(ld, tf=tf_of.get(("DELXF", ld.node))) if ld.kind == "DELXF"
                     else ld for ld in res.loads]
        res.line_loads = [replace(ld, tf=tf_of.get(("DELQE", ld.element)))
                          if ld.kind == "DELQE" else ld for ld in res.line_loads]
        res.follower_loads = [replace(ld, tf=tf_of.get(("DELXFL", ld.node)))
                              if ld.kind == "DELXFL" else ld for ld in res.follower_loads]
        res.follower_line_loads = [replace(ld, tf=tf_of.get(("DELQEL", ld.element)))
                                   if ld.kind == "DELQEL" else ld
                                   for ld in res.follower_line_loads]
    for st in by_kw.get("XM", []):
        part.nodal_mass(st)
    for st in by_kw.get("GRAVITY", []):
        if ctx.once(st, errors):
            part.result.gravity = tuple(float(v) for v in st.fields[:3])
    for keyword in ("USERSIG", "USERINP"):
        for st in by_kw.get(keyword, []):
            if ctx.once(st, errors):
                routine = _user_routine(st, by_kw, errors)
                if routine is not None:
                    part.result.user_routines.append(routine)
    return part.result


def _user_routine(st: Statement, by_kw: dict, errors: ErrorCollector) -> UserRoutine | None:
    """A USERSIG/USERINP line: its name must be a Python function name; USERINP drives
    input coordinates or prescribed deformations, so the deck must declare some (INPUTX,
    INPUTE)."""
    name = str(st.fields[0])
    if not name.isidentifier():
        errors.error(st.field_locs[0], f"{st.keyword}: {name!r} cannot name a Python function "
                                       "(letters, digits and _, not starting with a digit)", st)
        return None
    if st.keyword == "USERINP" and not (by_kw.get("INPUTX") or by_kw.get("INPUTE")):
        errors.error(st.loc, "USERINP: the routine gives the motion of input coordinates or "
                             "prescribed deformations, and the deck declares none: add INPUTX "
                             "or INPUTE lines for those it drives", st)
        return None
    return UserRoutine(keyword=st.keyword, name=name, loc=st.loc)
