"""Deck semantics, constraints: fixed and prescribed coordinates and deformations.

FIX holds coordinates; INPUTX/DELINPX prescribe coordinates along the load path, INPUTE/
DELINPE element deformation modes (the data module's ``INPUTX n c value [velocity
[acceleration]]`` and ``INPUTE e k ...`` give the value and, for a transient run, the rate and
second derivative at t = 0), INPUTR/DELINPR turn an orientation node about a fixed axis
(spacarpy extension; a planar deck's INPUTX on an orientation node means the same). Checked
here: nodes and elements that do not exist, coordinate and mode numbers out of range, a
coordinate both fixed and prescribed, a deformation both prescribed and flexible or released,
values given twice or for inputs never declared. A data-module INPUTE on a free mode (DYNE,
RLSE, KINE) draws a warning and is ignored, as SPACAR 2019 does.
"""
from __future__ import annotations

import numpy as np

from spacarpy.deck.semantics.errors import DeckContext, ErrorCollector
from spacarpy.deck.semantics.topology import ORIENTATION_TOL, Topology, UsesTopology
from spacarpy.deck.statement import Statement
from spacarpy.elements.registry import KINDS
from spacarpy.model import (
    FLEXIBLE,
    RIGID,
    Fix,
    Prescribed,
    PrescribedDeformation,
    PrescribedRotation,
)

__all__ = ["Constraints", "from_statements"]


class Constraints(UsesTopology):
    """The fixes and prescribed inputs of a deck.

    Attributes
    ----------
    fixes : dict
        Node -> (set of fixed coordinates, location of its first FIX).
    fix_lines : dict
        (node, coordinate) -> the FIX line that fixed it.
    prescribed, input_deformations, rotations : dict
        (node, coordinate), (element, mode) and node -> the initial value, increment and
        location of INPUTX, INPUTE and INPUTR inputs.
    """

    def __init__(self, ctx: DeckContext, errors: ErrorCollector, topology: Topology):
        self.ctx, self.errors, self.topology = ctx, errors, topology
        self.fixes: dict[int, tuple[set, object]] = {}
        self.fix_lines: dict[tuple[int, int], Statement] = {}
        self.prescribed: dict = {}
        self.input_deformations: dict = {}
        self.rotations: dict = {}

    def model_fixes(self) -> list:
        """The :class:`spacarpy.model.Fix` list."""
        return [Fix(node=k, coords=tuple(sorted(c)), loc=loc)
                for k, (c, loc) in self.fixes.items()]

    def model_prescribed(self, tf_of: dict | None = None) -> tuple[list, list, list]:
        """The prescribed coordinates, deformations and rotations of the model; ``tf_of``
        (LOADTF: ``("DELINPX", n, c)``, ``("DELINPE", e, k)``, ``("DELINPR", n)`` -> name)
        names their time functions."""
        tf = (tf_of or {}).get
        return ([Prescribed(node=n, coord=c, initial=v["initial"], delta=v["delta"],
                            loc=v["loc"], velocity=v.get("velocity", 0.0),
                            acceleration=v.get("acceleration", 0.0),
                            tf=tf(("DELINPX", n, c)))
                 for (n, c), v in self.prescribed.items()],
                [PrescribedDeformation(element=e, mode=k, initial=v["initial"],
                                       delta=v["delta"], loc=v["loc"],
                                       velocity=v.get("velocity", 0.0),
                                       acceleration=v.get("acceleration", 0.0),
                                       tf=tf(("DELINPE", e, k)))
                 for (e, k), v in self.input_deformations.items()],
                [PrescribedRotation(node=n, axis=v["axis"], angle=v["angle"], loc=v["loc"],
                                    initial=v.get("initial", 0.0),
                                    tf=tf(("DELINPR", n)) or tf(("DELINPX", n, 1)))
                 for n, v in self.rotations.items()])

    def fix(self, st: Statement) -> None:
        """A FIX line: the coordinates given, or all of the node."""
        node = self.coordinate_node(st)
        if node is None:
            return
        n, kind, size = node
        coords = set()
        for i, c in enumerate(st.fields[1:], start=1):
            if not 1 <= c <= size:
                what = (f"coordinates 1 to {size}" if size > 1 else "coordinate 1 (its angle)"
                        if kind == "orientation" else "coordinate 1 (its rate of twist)")
                plane = "planar " if self.planar else ""
                self.error(st.field_locs[i], f"FIX: node {n} is a {plane}{kind} node with "
                                             f"{what}, got {c}", st)
            else:
                coords.add(c)
        if len(st.fields) == 1:
            coords = set(range(1, size + 1))
        if self.planar and kind == "orientation" and coords:
            coords = {1, 2, 3, 4}
        for c in coords:
            self.fix_lines.setdefault((n, c), st)
        if n in self.fixes:
            self.fixes[n][0].update(coords)
        else:
            self.fixes[n] = (coords, st.loc)

    def inputx_declare(self, st: Statement) -> None:
        """``INPUTX n c ...`` (kinematics module): coordinates c of node n are prescribed."""
        node = self.coordinate_node(st)
        if node is None:
            return
        n, kind, size = node
        coords = st.fields[1:] or tuple(range(1, size + 1))
        for i, c in enumerate(coords, start=1):
            loc = st.field_locs[i] if i < len(st.field_locs) else st.loc
            if not 1 <= c <= size:
                plane = "planar " if self.planar else ""
                self.error(loc, f"INPUTX: node {n} is a {plane}{kind} node with coordinates 1 "
                                f"to {size}, got {c}", st)
                continue
            if self.planar and kind == "orientation":
                # the angle of a planar orientation node: a rotation about z (as INPUTR)
                if (n, 1) in self.fix_lines:
                    self.error(loc, f"INPUTX: node {n} is also fixed (FIX at line "
                                    f"{self.fix_lines[(n, 1)].loc.line})", st)
                elif n in self.rotations:
                    self.error(loc, f"INPUTX: coordinate 1 of node {n} is prescribed twice", st)
                else:
                    self.rotations[n] = {"axis": (0.0, 0.0, 1.0), "angle": 0.0, "initial": 0.0,
                                         "loc": st.loc, "set": False, "planar": set()}
                continue
            fix = self.fix_lines.get((n, c))
            if fix is not None:
                self.error(loc, f"INPUTX: coordinate {c} of node {n} is also fixed (FIX at "
                                f"line {fix.loc.line}); a coordinate is either fixed or "
                                "prescribed", st)
                continue
            if (n, c) in self.prescribed:
                self.error(loc, f"INPUTX: coordinate {c} of node {n} is prescribed twice", st)
                continue
            self.prescribed[(n, c)] = {"initial": None, "delta": 0.0, "loc": st.loc,
                                       "set": set()}

    def inpute_declare(self, st: Statement) -> None:
        """``INPUTE e k ...`` (kinematics module): deformation modes k of element e are
        prescribed (driven) instead of being rigid."""
        el = self.element_for(st)
        if el is None:
            return
        n_def = el.info["n_def"]
        if len(st.fields) == 1:
            self.error(st.loc, f"INPUTE {el.id}: expected deformation mode numbers after the "
                               f"element number (1 to {n_def} for a {el.keyword})", st)
            return
        for i, k in enumerate(st.fields[1:], start=1):
            loc = st.field_locs[i]
            if not 1 <= k <= n_def:
                modes = f"modes 1 to {n_def}" if n_def > 1 else "mode 1 only"
                self.error(loc, f"INPUTE: element {el.id} is a {el.keyword} with deformation "
                                f"{modes}, got {k}", st)
                continue
            if k - 1 in KINDS[el.keyword].velocity_modes:
                self.error(loc, f"INPUTE: deformation {k} of {el.keyword} {el.id} is a slip "
                                "(a velocity-level constraint): prescribing it is not "
                                "supported yet", st)
                continue
            if el.def_class[k - 1] != RIGID:
                what = "DYNE" if el.def_class[k - 1] == FLEXIBLE else "RLSE"
                self.error(loc, f"INPUTE: deformation {k} of element {el.id} is also listed in "
                                f"{what} (line {el.class_line[k - 1]}); a prescribed "
                                "deformation is neither flexible nor released", st)
                continue
            if (el.id, k) in self.input_deformations:
                self.error(loc, f"INPUTE: deformation {k} of element {el.id} is prescribed "
                                "twice", st)
                continue
            self.input_deformations[(el.id, k)] = {"initial": None, "delta": 0.0,
                                                   "loc": st.loc, "set": set()}

    def inpute_value(self, st: Statement) -> None:
        """``INPUTE e k value`` (data module) or ``DELINPE e k delta``."""
        e, k, value = st.fields[0], st.fields[1], float(st.fields[2])
        entry = self.input_deformations.get((e, k))
        if entry is None and st.keyword == "INPUTE" and self._stray(e, k):
            # SPACAR 2019 prints "* Invalid deformation parameter k" for such a line and
            # goes on (a dynamics-module INPUTE on a DYNE mode, docs/deck.md)
            self.errors.warn(f"{st.loc}: INPUTE {e} {k}: deformation {k} of element "
                             f"{e} is not prescribed (it is not INPUTE in the kinematics "
                             "module); the line is ignored, as SPACAR does")
            return
        if entry is None:
            el = self.beams.get(e)
            if el is not None and k - 1 in KINDS[el.keyword].velocity_modes:
                return                  # a slip: its INPUTE declaration was reported
            if e not in self.foreign_elements:
                self.error(st.field_locs[1], f"{st.keyword}: deformation {k} of element {e} is "
                                             f"not prescribed: declare it with 'INPUTE {e} {k}' "
                                             "in the kinematics module", st)
            return
        self._input_value(entry, "delta" if st.keyword == "DELINPE" else "initial", value, st,
                          f"deformation {k} of element {e}")
        self._rates(entry, st)

    def _stray(self, e: int, k: int) -> bool:
        """Whether deformation k of element e is a free mode (DYNE, RLSE or KINE): a
        data-module INPUTE there is SPACAR's "invalid deformation parameter", ignored."""
        el = self.beams.get(e)
        if el is None or not 1 <= k <= len(el.def_class):
            return False
        if el.def_class[k - 1] != RIGID:
            return True
        return any(kin.fields[0] == e and k in kin.fields[1:]
                   for kin in self.ctx.by_keyword.get("KINE", ()))

    def inputr_declare(self, st: Statement) -> None:
        """``INPUTR n ax ay az``: orientation node n turns about the axis (all of its Euler
        parameters are prescribed)."""
        n = st.fields[0]
        if self.node_kind(n) != "orientation":
            what = "a position node" if n in self.positions else "not defined"
            self.error(st.field_locs[0], f"INPUTR: node {n} is {what}; INPUTR turns an "
                                         "orientation node", st)
            return
        axis = np.array(st.fields[1:4], dtype=float)
        if np.linalg.norm(axis) < ORIENTATION_TOL:
            self.error(st.field_locs[1], "INPUTR: the rotation axis is (nearly) zero", st)
            return
        for c in range(1, 5):
            fix = self.fix_lines.get((n, c))
            if fix is not None or (n, c) in self.prescribed:
                self.error(st.loc, f"INPUTR: node {n} is already fixed or prescribed (coordinate "
                                   f"{c}); a turned node cannot be fixed too", st)
                return
        if n in self.rotations:
            self.error(st.loc, f"INPUTR: node {n} is given twice", st)
            return
        self.rotations[n] = {"axis": tuple(axis / np.linalg.norm(axis)), "angle": 0.0,
                             "loc": st.loc, "set": False}

    def inputr_value(self, st: Statement) -> None:
        """``DELINPR n angle``."""
        n, angle = st.fields[0], float(st.fields[1])
        entry = self.rotations.get(n)
        if entry is None:
            self.error(st.field_locs[0], f"DELINPR: node {n} has no INPUTR line (declare its "
                                         f"axis with 'INPUTR {n} ax ay az')", st)
            return
        if entry["set"]:
            self.error(st.loc, f"DELINPR: node {n} is given twice", st)
            return
        entry["set"] = True
        entry["angle"] = angle

    def inputx_value(self, st: Statement) -> None:
        """``INPUTX n c value`` (data module) or ``DELINPX n c delta``."""
        n, c, value = st.fields[0], st.fields[1], float(st.fields[2])
        rotation = self.rotations.get(n)
        if self.planar and rotation is not None and "planar" in rotation and c == 1:
            key = "angle" if st.keyword == "DELINPX" else "initial"
            if key in rotation["planar"]:
                self.error(st.loc, f"{st.keyword}: coordinate {c} of node {n} is given twice",
                           st)
                return
            rotation["planar"].add(key)
            rotation[key] = value
            if any(st.fields[3:]):
                self.error(st.field_locs[3], f"INPUTX: the velocity and acceleration of the "
                                             f"angle of planar node {n} are not supported yet; "
                                             "drive it with INPUTE on a PLHINGE, or DELINPX "
                                             "and a TIMEFUNCTION", st)
            return
        entry = self.prescribed.get((n, c))
        if entry is None:
            if n not in self.foreign_nodes:
                self.error(st.field_locs[1], f"{st.keyword}: coordinate {c} of node {n} is not "
                                             f"prescribed: declare it with 'INPUTX {n} {c}' in "
                                             "the kinematics module", st)
            return
        self._input_value(entry, "delta" if st.keyword == "DELINPX" else "initial", value, st,
                          f"coordinate {c} of node {n}")
        self._rates(entry, st)

    @staticmethod
    def _rates(entry: dict, st: Statement) -> None:
        """The velocity and acceleration of the 5-field INPUTX/INPUTE (data module): the
        motion ``value + velocity t + acceleration t^2 / 2`` of a transient run."""
        if st.keyword in ("INPUTX", "INPUTE") and len(st.fields) > 3:
            entry["velocity"] = float(st.fields[3])
            if len(st.fields) > 4:
                entry["acceleration"] = float(st.fields[4])

    def _input_value(self, entry: dict, key: str, value: float, st: Statement,
                     what: str) -> None:
        """Set the initial value or the increment of a prescribed input once."""
        if key in entry["set"]:
            self.error(st.loc, f"{st.keyword}: {what} is given twice", st)
            return
        entry["set"].add(key)
        entry[key] = value


def from_statements(by_kw: dict, ctx: DeckContext, errors: ErrorCollector,
                    topology: Topology) -> Constraints:
    """The FIX and INPUT* lines of the statements (by keyword); problems go to ``errors``."""
    part = Constraints(ctx, errors, topology)
    for st in by_kw.get("FIX", []):
        part.fix(st)
    for st in by_kw.get("INPUTX", []):
        if st.module == 0:
            part.inputx_declare(st)
    for st in by_kw.get("INPUTX", []) + by_kw.get("DELINPX", []):
        if st.keyword == "DELINPX" or st.module > 0:
            part.inputx_value(st)
    for st in by_kw.get("INPUTE", []):
        if st.module == 0:
            part.inpute_declare(st)
    for st in by_kw.get("INPUTE", []) + by_kw.get("DELINPE", []):
        if st.keyword == "DELINPE" or st.module > 0:
            part.inpute_value(st)
    for st in by_kw.get("INPUTR", []):
        part.inputr_declare(st)
    for st in by_kw.get("DELINPR", []):
        part.inputr_value(st)
    return part
