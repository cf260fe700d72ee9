"""Deck semantics, element data: deformation classes, stiffness, mass and damping.

DYNE/RLSE set the class of deformation modes, ESTIFF and EM the stiffness and mass of the
elements of :mod:`spacarpy.deck.semantics.topology` (filled into their records), EDAMP and
DAMPING the viscous damping (a property of the structure, used by transient runs), ESIG the
initial stress resultants (pre-stress) and STARTDE the initial deformation rates of a
transient run. Checked
here: modes an element does not have, modes both flexible and released, value counts and
signs as the element kind declares them, repeated lines, and flexible modes without
stiffness.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from itertools import repeat

from spacarpy.deck.semantics.errors import DeckContext, ErrorCollector
from spacarpy.deck.semantics.topology import ElementRecord, Topology, UsesTopology
from spacarpy.deck.statement import Statement
from spacarpy.model import FLEXIBLE, RELEASED, RIGID

__all__ = ["ElementData", "from_statements"]

_ALL_MODES = {n: tuple(range(1, n + 1)) for n in range(1, 16)}
_STIFFNESS_NAMES = ("EA", "GJ", "EIy", "EIz", "cy", "cz")
_MASS_NAMES = ("rhoA", "rho(Iy+Iz)", "rhoIy", "rhoIz")


@dataclass
class ElementData:
    """What the element data give beyond the element records: the Rayleigh damping
    ``(alpha, beta)`` of DAMPING and the EDAMP coefficients per element."""

    damping: tuple = (0.0, 0.0)
    element_damping: dict = field(default_factory=dict)
    prestress: dict = field(default_factory=dict)        # element -> ESIG values per mode
    initial_rates: dict = field(default_factory=dict)    # (element, mode) -> STARTDE rate


class _ElementDataPass(UsesTopology):
    def __init__(self, ctx: DeckContext, errors: ErrorCollector, topology: Topology):
        self.ctx, self.errors, self.topology = ctx, errors, topology
        self.result = ElementData()

    def deformation_class(self, st: Statement) -> None:
        """A DYNE (flexible) or RLSE (released) line."""
        fields = st.fields
        beam = self.beams.get(fields[0])
        if beam is not None and st.keyword == "DYNE" and not beam.info["flexible_ok"]:
            self.error(st.loc, f"DYNE {beam.id}: a {beam.keyword} mode cannot be flexible: "
                               f"{beam.info['no_stiffness_why']} is not supported yet "
                               f"({beam.keyword} modes are rigid, or released with RLSE)", st)
            return
        if beam is not None and len(fields) > 1:
            # the usual line: known modes, none of them set the other way
            cls = FLEXIBLE if st.keyword == "DYNE" else RELEASED
            modes = fields[1:]
            current = beam.def_class
            if min(modes) >= 1 and max(modes) <= len(current) and \
                    (RELEASED if cls == FLEXIBLE else FLEXIBLE) not in current:
                line = st.line
                flex = beam.flex_locs
                if len(modes) == len(current) and not flex and modes == _ALL_MODES[len(modes)]:
                    beam.def_class = [cls] * len(modes)        # DYNE e 1 2 ... n_def
                    beam.class_line = [line] * len(modes)
                    if cls == FLEXIBLE:
                        beam.flex_locs = dict(zip(modes, zip(repeat(st), modes)))
                    return
                for k in modes:
                    current[k - 1] = cls
                    beam.class_line[k - 1] = line
                if cls == FLEXIBLE:
                    for i, k in enumerate(modes, start=1):
                        if k not in flex:
                            flex[k] = (st, i)
                return
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
            beam.class_line[k - 1] = st.line
            if cls == FLEXIBLE:
                beam.flex_locs.setdefault(k, (st, i))

    def _repeated(self, st: Statement, first: Statement | None) -> bool:
        if first is not None:
            self.error(st.loc, f"{st.keyword} for element {st.fields[0]} is given twice "
                               f"(lines {first.loc.line} and {st.loc.line})", st)
            return True
        return False

    def estiff(self, st: Statement) -> None:
        """An ESTIFF line."""
        beam = self.beams.get(st.fields[0])
        if beam is None or beam.estiff is not None:
            beam = self.element_for(st)
            if beam is None or self._repeated(st, beam.estiff):
                return
        beam.estiff = st
        values = st.fields[1:]
        if not beam.info["flexible_ok"]:
            self.error(st.loc, f"ESTIFF {beam.id}: a {beam.keyword} takes no stiffness: "
                               f"{beam.info['no_stiffness_why']} is not supported yet", st)
            return
        if beam.keyword == "BEAM" and 4 <= len(values) <= 6 and min(values) >= 0:
            beam.stiffness = values + (0.0,) * (6 - len(values))   # nothing to report
            return
        if beam.keyword != "BEAM":
            self._estiff_other(beam, st, values)
            return
        if len(values) < 4:
            self.error(st.loc, f"ESTIFF {beam.id}: a BEAM needs EA GJ EIy EIz [cy cz] "
                               f"(4 to 6 values), got {len(values)}", st)
            return
        if len(values) == 7:
            self.errors.warn(f"{st.loc}: ESTIFF {beam.id}: the 7th value ({values[6]:g}) "
                                 "is ignored for a BEAM (it is the warping stiffness of BEAMW)")
        for i, v in enumerate(values[:6]):
            if v < 0:
                self.error(st.field_locs[i + 1], f"ESTIFF {beam.id}: {_STIFFNESS_NAMES[i]} must "
                                                 f"not be negative, got {v:g}", st)
        beam.stiffness = tuple(values[:6]) + (0.0,) * (6 - len(values[:6]))

    def _estiff_other(self, el: ElementRecord, st: Statement, values) -> None:
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
        width = max(3, len(info["stiff_names"]))
        el.stiffness = tuple(float(v) for v in values) + (0.0,) * (width - len(values))

    def em(self, st: Statement) -> None:
        """An EM line."""
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
        width = beam.info["em_width"]
        beam.mass = tuple(values[:width]) + (0.0,) * (width - len(values[:width]))

    def check_flexible_stiffness(self) -> None:
        """Every flexible mode (DYNE) of an element but a hinge has a stiffness."""
        for beam in self.beams.values():
            flex = beam.flex_locs
            if not flex:
                continue
            if beam.estiff is not None:         # the usual element: nothing to report
                lo, hi = beam.info["n_estiff"]
                if lo <= len(beam.estiff.fields) - 1 <= hi and \
                        0 not in beam.info["mode_stiffnesses"](beam.stiffness):
                    continue
            modes = sorted(flex)
            if beam.keyword == "HINGE":
                # a HINGE mode listed in DYNE is a degree of freedom of the joint; without
                # ESTIFF (or with k = 0) it simply turns freely, as in SPACAR
                continue
            info = beam.info
            if beam.estiff is None:
                loc = beam.flex_loc(modes[0])
                what = (f"mode {modes[0]} is" if len(modes) == 1
                        else "modes " + " ".join(map(str, modes)) + " are")
                self.error(loc, f"element {beam.id} {what} flexible (DYNE) but "
                                f"{'has' if len(modes) == 1 else 'have'} no stiffness: add "
                                f"ESTIFF {beam.id} {info['estiff_usage']}",
                           self.errors.line_at(loc))
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
                self.error(beam.flex_loc(k),
                           f"element {beam.id} {what} flexible (DYNE) but the stiffness "
                           f"{' '.join(names)} is zero in ESTIFF (line "
                           f"{beam.estiff.loc.line})", self.errors.line_at(beam.flex_loc(k)))

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
        if el.id in self.result.element_damping:
            self.error(st.loc, f"EDAMP for element {el.id} is given twice", st)
            return
        self.result.element_damping[el.id] = values + (0.0,) * (n_def - len(values))

    def esig(self, st: Statement) -> None:
        """``ESIG e s1 [s2 ...]``: initial stress resultants (pre-stress) of the deformation
        modes 1, 2, ... of element e; a flexible or released mode then carries ``s_k + S e``.
        On a rigid mode the constraint takes any stress, so a value there has no effect and
        is refused unless it is zero."""
        el = self.element_for(st)
        if el is None:
            return
        values = tuple(float(v) for v in st.fields[1:])
        n_def = el.info["n_def"]
        if len(values) > n_def:
            self.error(st.loc, f"ESIG {el.id}: a {el.keyword} has {n_def} deformation mode(s), "
                               f"so 1 to {n_def} initial stress resultants, got {len(values)}",
                       st)
            return
        for k, v in enumerate(values):
            if v != 0 and el.def_class[k] == RIGID:
                self.error(st.field_locs[k + 1],
                           f"ESIG {el.id}: mode {k + 1} is rigid (neither DYNE nor RLSE), so "
                           "its stress resultant is the constraint's reaction and a pre-stress "
                           "has no meaning; list the mode in DYNE or RLSE", st)
                return
        if el.id in self.result.prestress:
            self.error(st.loc, f"ESIG for element {el.id} is given twice", st)
            return
        self.result.prestress[el.id] = values + (0.0,) * (n_def - len(values))

    def startde(self, st: Statement) -> None:
        """``STARTDE e k rate``: the rate of deformation mode k of element e at t = 0 of a
        transient run (a flexible or released mode)."""
        el = self.element_for(st)
        if el is None:
            return
        k, rate = st.fields[1], float(st.fields[2])
        n_def = el.info["n_def"]
        if not 1 <= k <= n_def:
            modes = f"modes 1 to {n_def}" if n_def > 1 else "mode 1 only"
            self.error(st.field_locs[1], f"STARTDE: element {el.id} is a {el.keyword} with "
                                         f"deformation {modes}, got {k}", st)
            return
        if el.def_class[k - 1] == RIGID:
            self.error(st.field_locs[1], f"STARTDE: mode {k} of element {el.id} is rigid (its "
                                         "rate is zero, or set by INPUTE); STARTDE gives the "
                                         "rate of a DYNE or RLSE mode", st)
            return
        if (el.id, k) in self.result.initial_rates:
            self.error(st.loc, f"STARTDE for mode {k} of element {el.id} is given twice", st)
            return
        self.result.initial_rates[(el.id, k)] = rate

    def damping(self, st: Statement) -> None:
        """``DAMPING alpha beta``: Rayleigh damping alpha M + beta K0."""
        if self.ctx.once(st, self.errors):
            alpha, beta = st["alpha"], st["beta"]
            if not (st.field_spec("alpha").accepts(alpha)
                    and st.field_spec("beta").accepts(beta)):
                self.error(st.loc, "DAMPING: alpha and beta must not be negative, got "
                                   f"{alpha:g} {beta:g}", st)
            else:
                self.result.damping = (float(alpha), float(beta))


def from_statements(by_kw: dict, ctx: DeckContext, errors: ErrorCollector,
                    topology: Topology) -> ElementData:
    """Fill the element records of ``topology`` with the DYNE/RLSE, ESTIFF and EM lines;
    return the damping. Every problem goes to ``errors``."""
    part = _ElementDataPass(ctx, errors, topology)
    classes = by_kw.get("DYNE", []) + by_kw.get("RLSE", [])
    if "DYNE" in by_kw and "RLSE" in by_kw:
        classes.sort(key=errors.order)
    elements = topology.elements
    for st in classes:
        # the usual line, DYNE e 1 2 ... n_def on an element no DYNE/RLSE has touched, here;
        # everything else in deformation_class
        fields = st.fields
        beam = elements.get(fields[0])
        if beam is not None and not beam.flex_locs and st.keyword == "DYNE" and \
                RELEASED not in beam.def_class and fields[1:] == _ALL_MODES[len(beam.def_class)]:
            modes = fields[1:]
            beam.def_class = [FLEXIBLE] * len(modes)
            beam.class_line = [st.line] * len(modes)
            beam.flex_locs = dict(zip(modes, zip(repeat(st), modes)))
            continue
        part.deformation_class(st)
    for beam in elements.values():
        # modes that are never rigid (a BEAMW's warping modes: "ep_7 and ep_8 are always
        # calculable"): released unless DYNE made them flexible; ESTIFF gives them stiffness
        for k in beam.info["always_free"]:
            if beam.def_class[k] == RIGID:
                beam.def_class[k] = RELEASED
    for st in by_kw.get("ESTIFF", []):
        # the usual BEAM line (4 to 6 values, none negative, given once), here
        fields = st.fields
        beam = elements.get(fields[0])
        if beam is not None and beam.estiff is None and beam.keyword == "BEAM" and \
                5 <= len(fields) <= 7 and min(fields[1:]) >= 0:
            beam.estiff = st
            beam.stiffness = fields[1:] + (0.0,) * (7 - len(fields))
            continue
        part.estiff(st)
    for st in by_kw.get("EM", []):
        part.em(st)
    part.check_flexible_stiffness()
    for st in by_kw.get("EDAMP", []):
        part.edamp(st)
    for st in by_kw.get("DAMPING", []):
        part.damping(st)
    for st in by_kw.get("ESIG", []):
        part.esig(st)
    for st in by_kw.get("STARTDE", []):
        part.startde(st)
    return part.result
