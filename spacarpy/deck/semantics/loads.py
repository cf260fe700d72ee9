"""Deck semantics, loads and masses: XF/DELXF, XM, GRAVITY, and the user routines USERSIG
(loads) and USERINP (prescribed motion), which the model only names.

Dead nodal loads (forces on position nodes, moments on orientation nodes, a planar deck's
fx fy or m), point masses and inertia tensors on nodes, and the gravitational acceleration.
Checked here: nodes that do not exist, value counts for the node's kind, negative masses,
inertia tensors that are not positive semi-definite, and load components on fixed
coordinates (they would go straight into the support).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from spacarpy.deck.semantics.constraints import Constraints
from spacarpy.deck.semantics.errors import DeckContext, ErrorCollector
from spacarpy.deck.semantics.topology import Topology, UsesTopology
from spacarpy.deck.statement import Statement
from spacarpy.model import Load, NodalMass, UserRoutine

__all__ = ["Loads", "from_statements"]


@dataclass
class Loads:
    """The loads (in deck order), nodal masses and gravity of a deck."""

    loads: list = field(default_factory=list)
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
        n = st.fields[0]
        if self.node_kind(n) is None:
            if n not in self.foreign_nodes:
                self.error(st.field_locs[0], f"{st.keyword}: node {n} is not defined (no X line "
                                             "and not used by any element)", st)
            return
        if self.node_kind(n) == "warping":
            self.error(st.field_locs[0], f"{st.keyword}: node {n} is a warping node (BEAMW); "
                                         "a load on it (a bimoment) is not supported", st)
            return
        values = tuple(float(v) for v in st.fields[1:4])
        if self.planar:
            want, usage = ((2, f"{st.keyword} {n} fx fy") if self.node_kind(n) == "position"
                           else (1, f"{st.keyword} {n} m (the moment about z)"))
            if len(values) != want:
                self.error(st.loc, f"{st.keyword}: node {n} is a planar {self.node_kind(n)} node: "
                                   f"expected {usage}, got {len(values)} value(s)", st)
                return
            values = (values + (0.0,)) if want == 2 else (0.0, 0.0, values[0])
        elif len(values) != 3:
            self.error(st.loc, f"{st.keyword}: expected three components ({st.keyword} {n} f1 "
                               f"f2 f3), got {len(values)}", st)
            return
        self.result.loads.append(Load(node=n, kind=st.keyword, value=values, loc=st.loc))
        self.load_sts.append(st)

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
    """The XF/DELXF (in deck order), XM and GRAVITY lines; problems go to ``errors``."""
    part = _LoadsPass(ctx, errors, topology, constraints)
    for st in ctx.in_deck_order("XF", "DELXF"):
        part.load(st)
    part.check_loads_on_fixed_coordinates()
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
