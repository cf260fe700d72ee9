"""Checked deck statements -> a validated :class:`spacarpy.model.Model`.

This module gives the records their meaning (nodes, BEAM elements, deformation classes, fixes,
stiffness, mass, nodal masses, loads, load stepping, analysis choice) and checks everything that
needs more than one record: undefined or doubly defined nodes and elements, position versus
orientation nodes, zero-length elements, orientation vectors, deformation modes an element does
not have, modes both flexible and released, flexible modes without stiffness, coordinates that
do not exist, loads on fixed coordinates, unconnected nodes. Generator lines (BEAMS, BEAMARC)
are expanded first (:mod:`spacarpy.deck.generators`). Every problem is collected and they are
raised together in one :class:`spacarpy.errors.DeckError`, in deck order. Keywords spacarpy
recognises but does not implement yet are refused with "not supported yet: KEYWORD", one error
per occurrence.
"""
from __future__ import annotations

import logging
import re

import numpy as np

from spacarpy.deck.generators import expand_generators
from spacarpy.deck.keywords import KEYWORDS, UNSUPPORTED, UNSUPPORTED_ELEMENTS
from spacarpy.deck.parser import Statement, gc_paused
from spacarpy.deck.visualization import collect_cross_sections
from spacarpy.elements.registry import KINDS, PLANAR_KINDS
from spacarpy.errors import DeckError, SourceLoc
from spacarpy.expressions import ExpressionError, evaluate
from spacarpy.job import Job
from spacarpy.model import (
    FLEXIBLE,
    RELEASED,
    RIGID,
    ElementSet,
    Fix,
    Load,
    Model,
    NodalMass,
    Prescribed,
    PrescribedDeformation,
    PrescribedRotation,
)
from spacarpy.settings import (
    BIFURCATION_CHOICES,
    DEFORMATION_VARIANTS,
    AnalysisSettings,
    IterStep,
    LinearizedSettings,
    StaticSettings,
    TransientSettings,
    resolve_analysis,
    resolve_deformations,
    valid_modes,
)
from spacarpy.time_functions import KINDS as TIME_FUNCTION_KINDS
from spacarpy.time_functions import TIME_FUNCTIONS

__all__ = ["build_job", "build_model"]

logger = logging.getLogger(__name__)

_STIFFNESS_NAMES = ("EA", "GJ", "EIy", "EIz", "cy", "cz")
_MASS_NAMES = ("rhoA", "rho(Iy+Iz)", "rhoIy", "rhoIz")
_COORD_NAMES = {"position": ("x", "y", "z"),
                "orientation": ("lambda0", "lambda1", "lambda2", "lambda3")}

_DIGITS = re.compile(r"\d+")

#: Relative length below which an element counts as zero-length (times the model size).
ZERO_LENGTH_RTOL = 1e-12
#: Orientation vectors shorter than this, or with |n_x x o| < this * |o|, are rejected
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


def _kind_info(kind) -> dict:
    """What the builder checks of an element kind, from its declaration: number of deformation
    modes, index of the first vector field (orientation / hinge axis) or None, allowed ESTIFF
    value counts, the stiffness names, which ESTIFF value carries each mode's stiffness, and
    whether (and how much) EM applies."""
    est, em = kind.estiff, kind.em
    info = dict(n_def=kind.n_def, vector_at=1 + len(kind.slots) if kind.vector else None,
                n_estiff=(est.required, est.allowed), stiff_names=est.names,
                mode_stiffness=kind.mode_stiffness, has_mass=em is not None,
                estiff_usage=est.usage)
    if em is not None and em.allowed is not None:
        info.update(n_em=em.allowed, em_usage=em.usage)
    return info


_KIND_INFO = {keyword: _kind_info(kind) for keyword, kind in KINDS.items()}
#: The element keywords the model builder supports, in the order the model keeps them.
ELEMENT_KEYWORDS = tuple(_KIND_INFO)


class _Element:
    """One element record (BEAM, TRUSS, HINGE or RBEAM) while the model is being built."""

    def __init__(self, st: Statement):
        self.st = st
        self.keyword = st.keyword
        info = _KIND_INFO[st.keyword]
        self.info = info
        self.roles = KEYWORDS[st.keyword].node_roles
        self.id = st.fields[0]
        self.nodes = list(st.fields[1:1 + len(self.roles)])
        self.position_nodes = [n for n, r in zip(self.nodes, self.roles) if r == "p"]
        at = info["vector_at"]
        self.vector_given = at is not None and len(st.fields) >= at + 3
        self.orientation = (tuple(st.fields[at:at + 3]) if self.vector_given
                            else (np.nan, np.nan, np.nan))
        n_def = info["n_def"]
        self.def_class = [RIGID] * n_def
        self.class_line = [0] * n_def      # line of the DYNE/RLSE that set each mode
        self.flex_locs: dict[int, SourceLoc] = {}   # mode -> where it was made flexible
        self.stiffness = (0.0,) * (6 if st.keyword == "BEAM" else 3)
        self.estiff: Statement | None = None
        self.mass = (0.0,) * 5
        self.em: Statement | None = None


class _DeckSemantics:
    """Collects the meaning of the statements pass by pass, and every error on the way."""

    def __init__(self, path: str):
        self.path = path
        self.by_line: dict = {}            # (file, line) -> first statement on it
        self.rank: dict = {}               # (file, line) -> position in deck order
        self.errors: list = []
        self.warnings: list[str] = []
        self.positions: dict[int, tuple[tuple, Statement]] = {}
        self.beams: dict[int, _Element] = {}   # all elements, by number
        self.orientation_use: dict[int, Statement] = {}   # node -> first BEAM using it as r/s
        self.foreign_elements: set[int] = set()   # elements of unsupported keywords
        self.foreign_nodes: set[int] = set()      # nodes of unsupported element keywords
        self.quiet_elements: set[int] = set()     # elements of failed generator lines
        self.quiet_nodes: set[int] = set()        # end nodes of failed generator lines
        self.fixes: dict[int, tuple[set, SourceLoc]] = {}
        self.fix_lines: dict[tuple[int, int], Statement] = {}   # (node, coord) -> FIX line
        self.loads: list[Load] = []
        self.load_sts: list[Statement] = []
        self.nodal_masses: list[NodalMass] = []
        self.prescribed: dict = {}          # (node, coord) -> initial, delta, loc
        self.bifurcation = "off"
        self.planar = False
        self.timestep = None
        self.rho_inf = 0.9
        self.substeps = 1
        self.error_tol = None
        self.initial_velocities: dict = {}
        self.damping = (0.0, 0.0)
        self.element_damping: dict = {}
        self.start = "deck"
        self.time_function = ("constant", ())
        self.n_modes: int | None = None
        self.modes_each_step = False
        self.input_deformations: dict = {}  # (element, mode) -> initial, delta, loc (INPUTE)
        self.rotations: dict = {}           # node -> axis, angle, loc (INPUTR/DELINPR)
        self.gravity = (0.0, 0.0, 0.0)
        self.iterstep: IterStep | None = None
        self.analysis: str | None = None
        self.deformations: str | None = None
        self.singletons: dict[str, Statement] = {}

    # ---------------------------------------------------------------- helpers
    def error(self, loc: SourceLoc | None, message: str, st: Statement | None = None) -> None:
        self.errors.append((loc, message, st.source_line if st is not None else None))

    def node_kind(self, n: int) -> str | None:
        if n in self.positions:
            return "position"
        if n in self.orientation_use:
            return "orientation"
        return None

    def once(self, st: Statement) -> bool:
        """Record a keyword that may appear only once; report a repeat."""
        first = self.singletons.get(st.keyword)
        if first is not None:
            self.error(st.loc, f"{st.keyword} is given twice (lines {first.loc.line} and "
                               f"{st.loc.line})", st)
            return False
        self.singletons[st.keyword] = st
        return True

    def _line_at(self, loc: SourceLoc) -> Statement | None:
        return self.by_line.get((loc.file, loc.line))

    def sorted_errors(self) -> list:
        """The errors in deck order. Errors that a range or generator line repeats for each of
        its elements (same place, same message up to the numbers) are reported once."""
        def key(item):
            loc = item[0]
            if loc is None:
                return (0, 0, 0)
            return (1, self.rank.get((loc.file, loc.line), len(self.rank)), loc.column)

        out: list = []
        repeats: dict = {}
        for loc, msg, src in sorted(self.errors, key=key):
            same = (loc, _DIGITS.sub("#", msg)) if loc is not None else None
            if same is not None and same in repeats:
                repeats[same][1] += 1
                continue
            if same is not None:
                repeats[same] = [len(out), 0]
            out.append((loc, msg, src))
        for index, count in repeats.values():
            if count:
                loc, msg, src = out[index]
                out[index] = (loc, f"{msg} (and {count} more like it from this line)", src)
        return out

    # ---------------------------------------------------------------- passes
    def build(self, statements, deformations, analysis, text) -> Job:
        for st in statements:
            key = (st.loc.file, st.loc.line)
            if key not in self.rank:
                self.by_line[key] = st
                self.rank[key] = len(self.rank)
        statements, gen_errors, self.quiet_elements, self.quiet_nodes = \
            expand_generators(statements)
        self.errors.extend(gen_errors)
        sections, vis_errors, vis_warnings = collect_cross_sections(statements)
        self.errors.extend(vis_errors)
        self.warnings.extend(vis_warnings)

        statements = [st for st in statements if st.module >= 0]
        by_kw: dict[str, list[Statement]] = {}
        for st in statements:
            by_kw.setdefault(st.keyword, []).append(st)
            if st.keyword in UNSUPPORTED:
                self.error(st.loc, f"not supported yet: {st.keyword}", st)
                if st.keyword in UNSUPPORTED_ELEMENTS:
                    self.note_foreign(st)

        # a planar model: PLBEAM/PLTRUSS/PLHINGE only, nodes in the x-y plane
        self.planar = any(kw in by_kw for kw in PLANAR_KINDS)
        for st in by_kw.get("X", []):
            self.node(st)
        element_sts = [st for kw in ELEMENT_KEYWORDS for st in by_kw.get(kw, [])]
        element_sts.sort(key=lambda st: self.rank[(st.loc.file, st.loc.line)])
        for st in element_sts:
            for i, role in enumerate(KEYWORDS[st.keyword].node_roles, start=1):
                if role == "r":
                    self.orientation_use.setdefault(st.fields[i], st)
        elements = [_Element(st) for st in element_sts]
        for b, geometry in zip(elements, self.element_geometry(elements)):
            self.beam(b, *geometry)
        if self.planar:
            self.check_planar(element_sts)
        for st in sorted(by_kw.get("DYNE", []) + by_kw.get("RLSE", []),
                         key=lambda s: self.rank[(s.loc.file, s.loc.line)]):
            self.deformation_class(st)
        for st in by_kw.get("ESTIFF", []):
            self.estiff(st)
        for st in by_kw.get("EM", []):
            self.em(st)
        self.check_flexible_stiffness()
        for st in by_kw.get("FIX", []):
            self.fix(st)
        for st in by_kw.get("INPUTX", []):
            if st.module == 0:
                self.inputx_declare(st)
        for st in by_kw.get("INPUTX", []) + by_kw.get("DELINPX", []):
            if st.keyword == "DELINPX" or st.module > 0:
                self.inputx_value(st)
        for st in by_kw.get("INPUTE", []):
            if st.module == 0:
                self.inpute_declare(st)
        for st in by_kw.get("INPUTE", []) + by_kw.get("DELINPE", []):
            if st.keyword == "DELINPE" or st.module > 0:
                self.inpute_value(st)
        for st in by_kw.get("INPUTR", []):
            self.inputr_declare(st)
        for st in by_kw.get("DELINPR", []):
            self.inputr_value(st)
        for st in statements:          # loads in deck order
            if st.keyword in ("XF", "DELXF"):
                self.load(st)
        self.check_loads_on_fixed_coordinates()
        for st in by_kw.get("XM", []):
            self.nodal_mass(st)
        for st in by_kw.get("OUTLEVEL", []):
            self.warnings.append(f"{st.loc}: OUTLEVEL has no effect in spacarpy: the result "
                                 "file always holds every quantity")
        for st in by_kw.get("GRAVITY", []):
            if self.once(st):
                self.gravity = tuple(float(v) for v in st.fields[:3])
        for st in by_kw.get("ITERSTEP", []):
            self.iterstep_line(st)
        for st in by_kw.get("MODE", []):
            self.mode_line(st)
        for st in by_kw.get("DEFORMATIONS", []):
            self.deformations_line(st)
        for st in by_kw.get("BIFURCATION", []):
            self.bifurcation_line(st)
        for st in by_kw.get("MODES", []):
            self.modes_line(st)
        for st in by_kw.get("TIMESTEP", []):
            if self.once(st):
                if not (st.fields[0] > 0 and st.fields[1] >= 1):
                    self.error(st.loc, "TIMESTEP: expected a positive end time and at least "
                                       f"one step, got {st.fields[0]:g} {st.fields[1]}", st)
                else:
                    self.timestep = (float(st.fields[0]), int(st.fields[1]))
        for st in by_kw.get("EDAMP", []):
            self.edamp(st)
        for st in by_kw.get("DAMPING", []):
            if self.once(st):
                if st.fields[0] < 0 or st.fields[1] < 0:
                    self.error(st.loc, "DAMPING: alpha and beta must not be negative, got "
                                       f"{st.fields[0]:g} {st.fields[1]:g}", st)
                else:
                    self.damping = (float(st.fields[0]), float(st.fields[1]))
        for st in by_kw.get("VELOCITY", []):
            n = st.fields[0]
            if self.node_kind(n) is None:
                self.error(st.field_locs[0], f"VELOCITY: node {n} is not defined (no X line and "
                                             "not used by any element)", st)
            elif n in self.initial_velocities:
                self.error(st.loc, f"VELOCITY: node {n} is given twice", st)
            else:
                self.initial_velocities[n] = tuple(float(v) for v in st.fields[1:4])
        for st in by_kw.get("ERROR", []):
            if self.once(st):
                if st.fields[0] < 0 or st.fields[1] < 0 or st.fields[0] + st.fields[1] <= 0:
                    self.error(st.loc, "ERROR: expected non-negative tolerances abs rel, not both "
                                       f"zero, got {st.fields[0]:g} {st.fields[1]:g}", st)
                else:
                    self.error_tol = (float(st.fields[0]), float(st.fields[1]))
        for st in by_kw.get("SUBSTEPS", []):
            if self.once(st):
                self.substeps = int(st.fields[0])
        for st in by_kw.get("RHOINF", []):
            if self.once(st):
                if not 0.0 <= st.fields[0] <= 1.0:
                    self.error(st.field_locs[0], "RHOINF: the spectral radius lies in [0, 1], "
                                                 f"got {st.fields[0]:g}", st)
                else:
                    self.rho_inf = float(st.fields[0])
        for st in by_kw.get("START", []):
            if self.once(st):
                value = str(st.fields[0]).lower()
                if value not in ("deck", "static"):
                    self.error(st.field_locs[0], "START: expected 'deck' (at rest in the deck's "
                                                 "configuration) or 'static' (the static "
                                                 f"equilibrium), got '{st.fields[0]}'", st)
                else:
                    self.start = value
        for st in by_kw.get("TIMEFUNCTION", []):
            if self.once(st):
                self.time_function_line(st)
        self.overrides(deformations, analysis)
        self.check_unconnected()
        self.check_cross_section_elements(sections)

        if self.errors:
            raise DeckError(self.sorted_errors())
        for msg in self.warnings:
            logger.warning(msg)
        return self.job(text)

    def note_foreign(self, st: Statement) -> None:
        roles = KEYWORDS[st.keyword].node_roles
        self.foreign_elements.add(st.fields[0])
        self.foreign_nodes.update(st.fields[1:1 + len(roles)])

    def check_planar(self, element_sts) -> None:
        """A planar model has only planar elements (their nodes have planar coordinates)."""
        first = next(st for st in element_sts if st.keyword in PLANAR_KINDS)
        for st in element_sts:
            if st.keyword not in PLANAR_KINDS:
                what = f"the {st.origin} line" if st.origin else st.keyword
                self.error(st.loc, f"{what}: a planar model ({first.keyword} at line "
                                   f"{first.loc.line}) has planar elements only (PLBEAM, "
                                   "PLTRUSS, PLHINGE); model it in space instead", st)

    def node(self, st: Statement) -> None:
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

    def model_size(self) -> float:
        if not self.positions:
            return 1.0
        x = np.array([xyz for xyz, _ in self.positions.values()], dtype=float)
        with np.errstate(over="ignore", invalid="ignore"):
            size = max(float(np.ptp(x, axis=0).max()), float(np.abs(x).max()))
        return size if 0 < size < np.inf else 1.0

    def element_geometry(self, elements: list[_Element]):
        """Geometry checks of all elements at once: for each, whether it has zero length and
        whether its orientation vector (hinge axis) is (nearly) zero or parallel to the element
        axis (SPACAR's getLocalframe rule). Meaningless for an element with an undefined
        position node: :meth:`beam` reports that and looks no further.

        Returns
        -------
        iterator of (zero_length, zero_vector, parallel), one per element
        """
        n = len(elements)
        ids = np.fromiter(self.positions, dtype=np.int64, count=len(self.positions))
        x = np.array([xyz for xyz, _ in self.positions.values()], dtype=float).reshape(-1, 3)
        # rows of x of each element's two position nodes (HINGEs have none)
        two = np.array([len(b.position_nodes) == 2 for b in elements], dtype=bool)
        ends = np.array([b.position_nodes if len(b.position_nodes) == 2 else (0, 0)
                         for b in elements], dtype=np.int64).reshape(n, 2)
        rows, found = _lookup(ids, ends)
        has_axis = two & found.all(axis=1)
        d = x[rows[:, 1]] - x[rows[:, 0]] if len(ids) else np.zeros((n, 3))
        length = _row_norms(d)
        zero_length = has_axis & (length <= ZERO_LENGTH_RTOL * self.model_size())
        axis = np.divide(d, length[:, None], out=np.full_like(d, np.nan),
                         where=(has_axis & ~zero_length)[:, None])
        vector = np.array([b.orientation for b in elements], dtype=float).reshape(n, 3)
        vector_norm = _row_norms(vector)                   # NaN where no vector is given
        zero_vector = vector_norm < ORIENTATION_TOL
        parallel = _row_norms(np.cross(axis, vector)) < ORIENTATION_TOL * vector_norm
        return zip(zero_length.tolist(), zero_vector.tolist(), parallel.tolist())

    def beam(self, b: _Element, zero_length: bool, zero_vector: bool, parallel: bool) -> None:
        """An element record of any supported kind (the name is historical); the geometry
        flags come from :meth:`element_geometry`."""
        st = b.st
        ok = True
        if b.id in self.beams:
            first = self.beams[b.id].st
            self.error(st.field_locs[0], f"element {b.id} is defined twice (lines "
                                         f"{first.loc.line} and {st.loc.line})", st)
            return
        if b.id in self.foreign_elements:
            self.error(st.field_locs[0], f"element number {b.id} is also used by an "
                                         "unsupported element", st)
        name = _element_name(st, b.id)
        slots = {0: "p", 1: "q"}
        pos_k = rot_k = 0
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
            else:
                slot = slots.get(rot_k, "?")
                rot_k += 1
                if n in self.positions:
                    ok = False
                    self.error(st.field_locs[i],
                               f"{name}: node {n} is a position node (X at line "
                               f"{self.positions[n][1].loc.line}) and cannot be the "
                               f"orientation node at {slot}", st)
        self.beams[b.id] = b
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
            what = "hinge axis" if b.keyword == "HINGE" else "orientation vector"
            if zero_vector:
                self.error(st.field_locs[at], f"{name}: the {what} {shown} is (nearly) zero",
                           st)
            else:
                self.error(st.field_locs[at],
                           f"{name}: the orientation vector {shown} is parallel to the element "
                           f"axis (node {b.position_nodes[0]} to node {b.position_nodes[1]}); "
                           "give the local y-axis, perpendicular to the element", st)

    def element_for(self, st: Statement) -> _Element | None:
        """The BEAM an element-data record refers to; reports unknown elements."""
        e = st.fields[0]
        beam = self.beams.get(e)
        if beam is None and e not in self.foreign_elements and e not in self.quiet_elements:
            self.error(st.field_locs[0], f"{st.keyword}: element {e} is not defined "
                                         "(no element line)", st)
        return beam

    def deformation_class(self, st: Statement) -> None:
        beam = self.element_for(st)
        if beam is None:
            return
        e = beam.id
        n_def = beam.info["n_def"]
        if len(st.fields) == 1:
            self.error(st.loc, f"{st.keyword} {e}: expected deformation mode numbers after the "
                               f"element number (1 to {n_def} for a {beam.keyword})", st)
            return
        cls, other = (FLEXIBLE, "RLSE") if st.keyword == "DYNE" else (RELEASED, "DYNE")
        for i, k in enumerate(st.fields[1:], start=1):
            if not 1 <= k <= n_def:
                modes = f"modes 1 to {n_def}" if n_def > 1 else "mode 1 only"
                self.error(st.field_locs[i], f"{st.keyword}: element {e} is a {beam.keyword} "
                                             f"with deformation {modes}, got {k}", st)
                continue
            current = beam.def_class[k - 1]
            if current not in (RIGID, cls):
                self.error(st.field_locs[i],
                           f"element {e} mode {k} is listed in both {other} (line "
                           f"{beam.class_line[k - 1]}) and {st.keyword} (line {st.loc.line})",
                           st)
                continue
            beam.def_class[k - 1] = cls
            beam.class_line[k - 1] = st.loc.line
            if cls == FLEXIBLE:
                beam.flex_locs.setdefault(k, st.field_locs[i])

    def _repeated(self, st: Statement, first: Statement | None) -> bool:
        if first is not None:
            self.error(st.loc, f"{st.keyword} for element {st.fields[0]} is given twice "
                               f"(lines {first.loc.line} and {st.loc.line})", st)
            return True
        return False

    def estiff(self, st: Statement) -> None:
        beam = self.element_for(st)
        if beam is None or self._repeated(st, beam.estiff):
            return
        beam.estiff = st
        values = st.fields[1:]
        if beam.keyword != "BEAM":
            self._estiff_other(beam, st, values)
            return
        if len(values) < 4:
            self.error(st.loc, f"ESTIFF {beam.id}: a BEAM needs EA GJ EIy EIz [cy cz] "
                               f"(4 to 6 values), got {len(values)}", st)
            return
        if len(values) == 7:
            self.warnings.append(f"{st.loc}: ESTIFF {beam.id}: the 7th value ({values[6]:g}) "
                                 "is ignored for a BEAM (it is the warping stiffness of BEAMW)")
        for i, v in enumerate(values[:6]):
            if v < 0:
                self.error(st.field_locs[i + 1], f"ESTIFF {beam.id}: {_STIFFNESS_NAMES[i]} must "
                                                 f"not be negative, got {v:g}", st)
        beam.stiffness = tuple(values[:6]) + (0.0,) * (6 - len(values[:6]))

    def _estiff_other(self, el: _Element, st: Statement, values) -> None:
        info = el.info
        lo, hi = info["n_estiff"]
        if not lo <= len(values) <= hi:
            count = f"{lo} value" if lo == hi == 1 else (f"{lo} values" if lo == hi
                                                          else f"{lo} to {hi} values")
            self.error(st.loc, f"ESTIFF {el.id}: a {el.keyword} takes {info['estiff_usage']} "
                               f"({count}), got {len(values)}", st)
            return
        for i, v in enumerate(values):
            if v < 0:
                self.error(st.field_locs[i + 1], f"ESTIFF {el.id}: {info['stiff_names'][i]} "
                                                 f"must not be negative, got {v:g}", st)
        el.stiffness = tuple(float(v) for v in values) + (0.0,) * (3 - len(values))

    def em(self, st: Statement) -> None:
        beam = self.element_for(st)
        if beam is None or self._repeated(st, beam.em):
            return
        beam.em = st
        values = st.fields[1:]
        if not beam.info["has_mass"]:
            if any(v != 0 for v in values):       # 'EM e' without values is harmless
                self.error(st.loc, f"EM {beam.id}: a {beam.keyword} has no mass of its own; "
                                   "put masses and inertias on its nodes with XM", st)
            return
        if not values:
            self.error(st.loc, f"EM {beam.id}: a {beam.keyword} needs at least the mass per "
                               "unit length rhoA", st)
            return
        if "n_em" in beam.info and len(values) > beam.info["n_em"]:
            self.error(st.loc, f"EM {beam.id}: a {beam.keyword} takes {beam.info['em_usage']}, "
                               f"got {len(values)} values", st)
            return
        for i, v in enumerate(values[:4]):
            if v < 0:
                self.error(st.field_locs[i + 1], f"EM {beam.id}: {_MASS_NAMES[i]} must not be "
                                                 f"negative, got {v:g}", st)
        beam.mass = tuple(values[:5]) + (0.0,) * (5 - len(values[:5]))

    def check_flexible_stiffness(self) -> None:
        for beam in self.beams.values():
            modes = sorted(beam.flex_locs)
            if not modes or beam.keyword == "HINGE":
                # a HINGE mode listed in DYNE is a degree of freedom of the joint; without
                # ESTIFF (or with k = 0) it simply turns freely, as in SPACAR
                continue
            info = beam.info
            if beam.estiff is None:
                loc = beam.flex_locs[modes[0]]
                what = (f"mode {modes[0]} is" if len(modes) == 1
                        else "modes " + " ".join(map(str, modes)) + " are")
                self.error(loc, f"element {beam.id} {what} flexible (DYNE) but "
                                f"{'has' if len(modes) == 1 else 'have'} no stiffness: add "
                                f"ESTIFF {beam.id} {info['estiff_usage']}", self._line_at(loc))
                continue
            lo, hi = info["n_estiff"]
            if not lo <= len(beam.estiff.fields) - 1 <= hi:
                continue   # already reported: wrong number of ESTIFF values
            names_all, mode_k = info["stiff_names"], info["mode_stiffness"]
            zero = [k for k in modes if beam.stiffness[mode_k[k - 1]] == 0]
            if zero:
                k = zero[0]
                names = sorted({names_all[mode_k[m - 1]] for m in zero}, key=names_all.index)
                what = (f"mode {k} is" if len(zero) == 1
                        else "modes " + " ".join(map(str, zero)) + " are")
                self.error(beam.flex_locs[k],
                           f"element {beam.id} {what} flexible (DYNE) but the stiffness "
                           f"{' '.join(names)} is zero in ESTIFF (line "
                           f"{beam.estiff.loc.line})", self._line_at(beam.flex_locs[k]))

    def fix(self, st: Statement) -> None:
        n = st.fields[0]
        kind = self.node_kind(n)
        if kind is None:
            if n not in self.foreign_nodes:
                self.error(st.field_locs[0], f"FIX: node {n} is not defined (no X line and not "
                                             "used by any element)", st)
            return
        size = 3 if kind == "position" else 4
        if self.planar:                 # planar: x y, or the angle (held: the whole node)
            size = 2 if kind == "position" else 1
        coords = set()
        for i, c in enumerate(st.fields[1:], start=1):
            if not 1 <= c <= size:
                what = (f"coordinates 1 to {size}" if size > 1 else "coordinate 1 (its angle)")
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
        n = st.fields[0]
        kind = self.node_kind(n)
        if kind is None:
            if n not in self.foreign_nodes:
                self.error(st.field_locs[0], f"INPUTX: node {n} is not defined (no X line and "
                                             "not used by any element)", st)
            return
        size = 3 if kind == "position" else 4
        if self.planar:
            size = 2 if kind == "position" else 1
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
        if entry is None:
            if e not in self.foreign_elements:
                self.error(st.field_locs[1], f"{st.keyword}: deformation {k} of element {e} is "
                                             f"not prescribed: declare it with 'INPUTE {e} {k}' "
                                             "in the kinematics module", st)
            return
        self._input_value(entry, "delta" if st.keyword == "DELINPE" else "initial", value, st,
                          f"deformation {k} of element {e}")

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

    def _input_value(self, entry: dict, key: str, value: float, st: Statement,
                     what: str) -> None:
        """Set the initial value or the increment of a prescribed input once."""
        if key in entry["set"]:
            self.error(st.loc, f"{st.keyword}: {what} is given twice", st)
            return
        entry["set"].add(key)
        entry[key] = value

    def load(self, st: Statement) -> None:
        n = st.fields[0]
        if self.node_kind(n) is None:
            if n not in self.foreign_nodes:
                self.error(st.field_locs[0], f"{st.keyword}: node {n} is not defined (no X line "
                                             "and not used by any element)", st)
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
        self.loads.append(Load(node=n, kind=st.keyword, value=values, loc=st.loc))
        self.load_sts.append(st)

    def check_loads_on_fixed_coordinates(self) -> None:
        """A load component on a fixed coordinate goes straight into the support: an error.

        Force component i acts on coordinate i of a position node; the moment about global
        axis i acts (in the initial configuration) on the Euler parameter lambda_i, coordinate
        i + 1 of an orientation node.
        """
        for st, load in zip(self.load_sts, self.loads):
            n = st.fields[0]
            kind = self.node_kind(n)
            for i in range(3):
                if load.value[i] == 0:
                    continue
                coord = i + 1 if kind == "position" else i + 2
                fix = self.fix_lines.get((n, coord))
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
        n = st.fields[0]
        kind = self.node_kind(n)
        values = tuple(float(v) for v in st.fields[1:])
        if kind is None:
            if n not in self.foreign_nodes:
                self.error(st.field_locs[0], f"XM: node {n} is not defined (no X line and not "
                                             "used by any element)", st)
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
        self.nodal_masses.append(NodalMass(node=n, values=values, loc=st.loc))

    def iterstep_line(self, st: Statement) -> None:
        if not self.once(st):
            return
        f = st.fields
        max_iter, n_steps = f[0], f[1]
        ok = True
        if max_iter < 1:
            self.error(st.field_locs[0], f"ITERSTEP: the maximum number of iterations must be "
                                         f"at least 1, got {max_iter}", st)
            ok = False
        if n_steps < 0:
            self.error(st.field_locs[1], f"ITERSTEP: the number of load steps must not be "
                                         f"negative, got {n_steps}", st)
            ok = False
        tol = f[2] if len(f) > 2 else IterStep.tol
        if tol <= 0:
            self.error(st.field_locs[2], f"ITERSTEP: the tolerance must be positive, got {tol:g}",
                       st)
            ok = False
        n_init = f[5] if len(f) > 5 else 1
        if n_init < 0:
            self.error(st.field_locs[5], f"ITERSTEP: the number of initial-load steps must not "
                                         f"be negative, got {n_init}", st)
            ok = False
        if ok:
            self.iterstep = IterStep(max_iter=max_iter, n_steps=max(n_steps, 1), tol=float(tol),
                                     n_init=max(n_init, 1), extra=tuple(f[3:5]), loc=st.loc)

    def mode_line(self, st: Statement) -> None:
        if not self.once(st):
            return
        value = resolve_analysis(st.fields[0])
        if value is None:
            self.error(st.field_locs[0], f"MODE: unknown analysis '{st.fields[0]}'; expected "
                                         f"{valid_modes()}", st)
        self.analysis = value

    def deformations_line(self, st: Statement) -> None:
        if not self.once(st):
            return
        value = resolve_deformations(st.fields[0])
        if value is None:
            self.error(st.field_locs[0], f"DEFORMATIONS: unknown variant '{st.fields[0]}'; "
                                         f"expected {' or '.join(DEFORMATION_VARIANTS)}", st)
        self.deformations = value

    def edamp(self, st: Statement) -> None:
        """``EDAMP e d1 [d2 ...]``: viscous damping coefficients of the deformation modes
        1, 2, ... of element e (stress resultant ``d_k de_k/dt`` added in transient runs)."""
        el = self.element_for(st)
        if el is None:
            return
        values = tuple(float(v) for v in st.fields[1:])
        n_def = el.info["n_def"]
        if not 1 <= len(values) <= n_def:
            self.error(st.loc, f"EDAMP {el.id}: a {el.keyword} has {n_def} deformation mode(s), "
                               f"so 1 to {n_def} damping values, got {len(values)}", st)
            return
        if any(v < 0 for v in values):
            self.error(st.loc, f"EDAMP {el.id}: damping coefficients must not be negative", st)
            return
        if el.id in self.element_damping:
            self.error(st.loc, f"EDAMP for element {el.id} is given twice", st)
            return
        self.element_damping[el.id] = values + (0.0,) * (n_def - len(values))

    def time_function_line(self, st: Statement) -> None:
        kind = str(st.fields[0]).lower()
        spec = TIME_FUNCTION_KINDS.get(kind)
        if spec is None:
            self.error(st.field_locs[0], f"TIMEFUNCTION: unknown kind '{st.fields[0]}'; "
                                         f"expected {', '.join(TIME_FUNCTIONS)}", st)
            return
        if kind == "expr":
            if len(st.fields) != 2 or not isinstance(st.fields[1], str):
                self.error(st.loc, 'TIMEFUNCTION expr takes one expression in t, in double '
                                   'quotes: TIMEFUNCTION expr "1 - exp(-t/0.1)"', st)
                return
            try:
                evaluate(st.fields[1], {"t": 0.0})
            except (ExpressionError, ValueError, ZeroDivisionError) as exc:
                self.error(st.field_locs[1], f"TIMEFUNCTION expr: {exc} (the expression may use "
                                             "t, pi and the functions of {expressions})", st)
                return
            self.time_function = ("expr", (st.fields[1],))
            return
        if any(isinstance(v, str) for v in st.fields[1:]):
            self.error(st.loc, f"TIMEFUNCTION {kind}: expected numbers after the kind", st)
            return
        params = tuple(float(v) for v in st.fields[1:])
        if kind == "table":
            ok = len(params) >= 4 and len(params) % 2 == 0 and np.all(np.diff(params[0::2]) > 0)
            if not ok:
                self.error(st.loc, "TIMEFUNCTION table: expected pairs t1 phi1 t2 phi2 ... (at "
                                   "least two, times increasing)", st)
                return
        elif len(params) != spec.n_params:
            self.error(st.loc, f"TIMEFUNCTION {kind} takes {spec.n_params} parameter(s) "
                               f"({spec.description}), got {len(params)}", st)
            return
        elif spec.positive_first and params[0] <= 0:
            self.error(st.field_locs[1], f"TIMEFUNCTION {kind}: the parameter must be "
                                         f"positive, got {params[0]:g}", st)
            return
        self.time_function = (kind, params)

    def modes_line(self, st: Statement) -> None:
        if not self.once(st):
            return
        self.n_modes = int(st.fields[0])
        if len(st.fields) > 1:
            where = str(st.fields[1]).lower()
            if where not in ("each", "last"):
                self.error(st.field_locs[1], f"MODES: expected 'each' (linearize at every load "
                                             f"step) or 'last', got '{st.fields[1]}'", st)
                return
            self.modes_each_step = where == "each"

    def bifurcation_line(self, st: Statement) -> None:
        if not self.once(st):
            return
        value = str(st.fields[0]).lower()
        if value not in BIFURCATION_CHOICES:
            self.error(st.field_locs[0], f"BIFURCATION: unknown setting '{st.fields[0]}'; "
                                         f"expected {', '.join(BIFURCATION_CHOICES)}", st)
            return
        self.bifurcation = value

    def overrides(self, deformations, analysis) -> None:
        if analysis is not None:
            value = resolve_analysis(analysis)
            if value is None:
                self.error(None, f"unknown analysis '{analysis}'; expected {valid_modes()}")
            self.analysis = value
        if deformations is not None:
            value = resolve_deformations(deformations)
            if value is None:
                self.error(None, f"unknown deformation variant '{deformations}'; expected "
                                 f"{' or '.join(DEFORMATION_VARIANTS)}")
            self.deformations = value

    def check_unconnected(self) -> None:
        """A position node no element uses floats free (a mechanism): an error, unless all
        its coordinates are fixed (then it is merely useless: a warning)."""
        used = ({n for b in self.beams.values() for n in b.position_nodes}
                | self.foreign_nodes | self.quiet_nodes)
        for n, (_, st) in self.positions.items():
            if n in used:
                continue
            if self.fixes.get(n, (set(),))[0] >= {1, 2, 3}:
                self.warnings.append(f"{st.loc}: position node {n} is not connected to any "
                                     "element (it is fixed, so it does nothing)")
            else:
                self.error(st.field_locs[0], f"position node {n} is not connected to any "
                                             "element: it would float free (a mechanism); "
                                             "connect it, FIX it, or remove its X line", st)

    def check_cross_section_elements(self, sections) -> None:
        for e, cs in sections.by_element.items():
            if e not in self.beams and e not in self.foreign_elements \
                    and e not in self.quiet_elements:
                self.warnings.append(f"{cs.loc}: a cross-section is given for element {e}, "
                                     "which is not defined")

    def job(self, text: str) -> Job:
        by_kind: dict[str, list[_Element]] = {}
        for b in self.beams.values():
            by_kind.setdefault(b.keyword, []).append(b)
        sets = {}
        for kw in ELEMENT_KEYWORDS:
            els = by_kind.get(kw)
            if els:
                sets[kw] = ElementSet(
                    kind=kw, ids=[b.id for b in els], nodes=[b.nodes for b in els],
                    vector=[b.orientation for b in els], def_class=[b.def_class for b in els],
                    stiffness=[b.stiffness for b in els],
                    has_stiffness=[b.estiff is not None for b in els],
                    mass=[b.mass for b in els], locs=[b.st.loc for b in els])
        ids = list(self.positions)
        x0 = [self.positions[k][0] for k in ids] if ids else np.zeros((0, 3))
        model = Model(
            position_ids=ids,
            position_x0=x0,
            orientation_ids=sorted(self.orientation_use),
            elements=sets,
            fixes=[Fix(node=k, coords=tuple(sorted(c)), loc=loc)
                   for k, (c, loc) in self.fixes.items()],
            loads=self.loads,
            nodal_masses=self.nodal_masses,
            prescribed=[Prescribed(node=n, coord=c, initial=v["initial"], delta=v["delta"],
                                   loc=v["loc"]) for (n, c), v in self.prescribed.items()],
            prescribed_deformations=[
                PrescribedDeformation(element=e, mode=k, initial=v["initial"], delta=v["delta"],
                                      loc=v["loc"])
                for (e, k), v in self.input_deformations.items()],
            prescribed_rotations=[PrescribedRotation(node=n, axis=v["axis"], angle=v["angle"],
                                                     loc=v["loc"],
                                                     initial=v.get("initial", 0.0))
                                  for n, v in self.rotations.items()],
            gravity=self.gravity,
            planar=self.planar,
            damping=self.damping,
            element_damping=self.element_damping,
            source_path=self.path,
            source_text=text,
        )
        settings = AnalysisSettings(
            analysis=self.analysis or "static",
            deformations=self.deformations or "modified",
            bifurcation=self.bifurcation,
            static=StaticSettings(iterstep=self.iterstep or IterStep()),
            linearized=LinearizedSettings(n_modes=self.n_modes,
                                          modes_each_step=self.modes_each_step),
            transient=TransientSettings(
                timestep=self.timestep, rho_inf=self.rho_inf, substeps=self.substeps,
                error_tol=self.error_tol, start=self.start, time_function=self.time_function,
                initial_velocities=self.initial_velocities))
        return Job(model, settings)


def build_job(statements, *, text: str, path: str, deformations: str | None = None,
              analysis: str | None = None, overrides: dict | None = None) -> Job:
    """Build and validate the model and the analysis settings of parsed deck statements.

    Parameters
    ----------
    statements : list of Statement
        From :func:`spacarpy.deck.parse_deck`.
    text, path : str
        The deck text and where it came from (stored in the model).
    deformations, analysis : str, optional
        Command-line choices; they override the deck's DEFORMATIONS / MODE lines. ``analysis``
        takes a name or a SPACAR mode number as text.
    overrides : dict, optional
        ``--set`` values for the deck's SET parameters. The values of the statements are
        already evaluated, so with overrides ``text`` is parsed again with them (and
        ``statements`` is not used).

    Returns
    -------
    Job
        The structure (``job.model``) and the settings (``job.settings``).

    Raises
    ------
    DeckError
        With every problem found, in deck order (problems without a location first).
    """
    if overrides:
        from spacarpy.deck.parser import parse_deck
        statements = parse_deck(text, path, overrides=overrides)
    from spacarpy.deck.visualization import cross_sections
    statements = list(statements)
    with gc_paused():
        job = _DeckSemantics(path).build(statements, deformations, analysis, text)
    sections = cross_sections(statements)
    job.model.cross_sections = sections if len(sections) else None
    return job


def build_model(statements, **kw) -> Model:
    """The structural model of parsed deck statements: ``build_job(...).model`` (the analysis
    settings are checked too, then dropped). Arguments as :func:`build_job`."""
    return build_job(statements, **kw).model
