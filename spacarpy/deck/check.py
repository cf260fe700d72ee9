"""``spacarpy check``: parse and validate a deck without solving, and summarise it.

:func:`check_deck` reads a deck, builds the model if it can, and returns a
:class:`DeckSummary`: nodes, elements by type (also types spacarpy cannot analyse yet),
deformation classes, coordinates, constraints and degrees of freedom, loads, analysis, and
every problem found. For a deck with features that are not supported yet the summary holds
what can be counted from the deck lines alone, and the list of those features.

The degrees of freedom are counted as in docs/solver.md: free coordinates minus constraints,
the constraints being the rigid deformation modes and the normalisation of every orientation
node that is not completely fixed. A redundant constraint or a mechanism is found by
``spacarpy run`` (exit code 3), not by counting.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from spacarpy.deck.generators import expand_generators
from spacarpy.deck.keywords import GENERATORS, KEYWORDS, UNSUPPORTED_PATTERN
from spacarpy.deck.parser import parse_deck
from spacarpy.deck.semantics import build_job
from spacarpy.deck.statement import Statement
from spacarpy.deck.textfile import read_deck_text
from spacarpy.deck.visualization import collect_cross_sections
from spacarpy.elements.registry import KINDS
from spacarpy.errors import DeckError
from spacarpy.model import FLEXIBLE, RELEASED, RIGID, Model
from spacarpy.settings import AnalysisSettings, resolve_analysis, resolve_deformations

__all__ = ["DeckSummary", "check_deck", "summarize"]



@dataclass
class DeckSummary:
    """What a deck contains, as counted by ``spacarpy check``.

    Counts that need a complete model (rigid modes, coordinates, constraints, DOF) are None
    when the model cannot be built.
    """

    path: str
    position_nodes: int = 0
    orientation_nodes: int = 0
    warping_nodes: int = 0
    elements: dict = field(default_factory=dict)        # keyword -> count
    generated_elements: int = 0
    parameters: dict = field(default_factory=dict)      # SET name -> value
    flexible: int = 0
    released: int = 0
    rigid: int | None = None
    n_coord: int | None = None
    n_position_coord: int | None = None
    n_fixed: int | None = None
    n_rigid_constraints: int | None = None
    n_euler_constraints: int | None = None
    dof: int | None = None
    loads: dict = field(default_factory=dict)   # XF, DELXF and the other load lines present
    kinematic: int = 0                                  # KINE and KINX coordinates
    dynamic: list = field(default_factory=list)         # DYNX (node, coordinate), deck order
    slips_held: int = 0                                 # velocity-level modes not released
    forces: int | None = None
    moments: int | None = None
    nodal_masses: int = 0
    analysis: str = "static"
    deformations: str = "modified"
    iterstep: tuple | None = None
    cross_sections: dict = field(default_factory=dict)  # shape -> number of elements
    unsupported: list = field(default_factory=list)     # (keyword, SourceLoc)
    errors: list = field(default_factory=list)          # DeckError items (other problems)
    model: Model | None = None

    @property
    def ok(self) -> bool:
        """True if the deck is valid and can be analysed."""
        return self.model is not None and not self.errors and not self.unsupported

    def format(self) -> str:
        """The summary as printed by ``spacarpy check``."""
        rows = []
        nodes = f"{self.position_nodes} position, {self.orientation_nodes} orientation"
        if self.warping_nodes:
            nodes += f", {self.warping_nodes} warping"
        rows.append(("nodes", nodes))
        total = sum(self.elements.values())
        by_type = ", ".join(f"{n} {kw}" for kw, n in self.elements.items())
        text = f"{total}" + (f" ({by_type})" if by_type else "")
        if self.generated_elements:
            text += f"; {self.generated_elements} made by generator lines"
        rows.append(("elements", text))
        if self.parameters:
            rows.append(("parameters", ", ".join(f"{k} = {v:.10g}"
                                                 for k, v in self.parameters.items())))
        if self.rigid is not None:
            modes = self.flexible + self.released + self.rigid
            rows.append(("deformation modes", f"{modes}: {self.flexible} flexible, "
                                              f"{self.released} released, {self.rigid} rigid"))
        else:
            rows.append(("deformation modes", f"{self.flexible} flexible and {self.released} "
                                              "released listed (rigid: n/a)"))
        if self.n_coord is not None:
            n_euler = self.n_coord - self.n_position_coord - self.warping_nodes
            warp = f" + {self.warping_nodes} warping" if self.warping_nodes else ""
            rows.append(("coordinates", f"{self.n_coord} ({self.n_position_coord} position + "
                                        f"{n_euler} Euler parameters{warp}), "
                                        f"{self.n_fixed} fixed"))
            n_con = self.n_rigid_constraints + self.n_euler_constraints
            rows.append(("constraints", f"{n_con} ({self.n_rigid_constraints} rigid modes + "
                                        f"{self.n_euler_constraints} Euler normalisations)"))
            rows.append(("degrees of freedom", f"{self.dof} ({self.n_coord - self.n_fixed} "
                                               f"free coordinates - {n_con} constraints)"))
            if self.kinematic or self.slips_held:
                rows.append(("slips held", f"{self.slips_held} (non-holonomic constraints)"))
                rows.append(("kinematic", f"{self.kinematic} coordinates (KINE/KINX)"))
        else:
            rows.append(("coordinates", "n/a"))
            rows.append(("degrees of freedom", "n/a"))
        if self.dynamic:
            rows.append(("dynamic (DYNX)", dynamic_text(self.dynamic, self.flexible)))
        loads = ", ".join(f"{n} {kw}" for kw, n in self.loads.items() if n) or "none"
        if self.forces is not None and (self.forces or self.moments):
            loads += f" ({self.forces} force{'s' * (self.forces != 1)}, {self.moments} " \
                     f"moment{'s' * (self.moments != 1)})"
        rows.append(("loads", loads))
        if self.nodal_masses:
            rows.append(("nodal masses", str(self.nodal_masses)))
        analysis = f"{self.analysis}, {self.deformations} deformations"
        if self.iterstep is not None:
            max_iter, n_steps, tol = self.iterstep
            analysis += f"; {n_steps} load step{'s' * (n_steps != 1)}, at most {max_iter} " \
                        f"iterations each, tolerance {tol:g}"
        rows.append(("analysis", analysis))
        if self.cross_sections:
            rows.append(("cross-sections", ", ".join(f"{n} {shape}" for shape, n in
                                                     self.cross_sections.items())))
        width = max(len(k) for k, _ in rows)
        out = [f"{self.path}"] + [f"  {k:<{width}}  {v}" for k, v in rows]
        if self.unsupported:
            out.append(f"not supported yet ({len(self.unsupported)} "
                       f"line{'s' * (len(self.unsupported) != 1)}):")
            out += _unsupported_lines(self.unsupported, self.path)
        if self.errors:
            out.append(str(DeckError(self.errors)))
        if self.ok:
            out.append(f"{self.path}: OK, {self.dof} degrees of freedom")
        else:
            parts = []
            if self.errors:
                parts.append(f"{len(self.errors)} error{'s' * (len(self.errors) != 1)}")
            if self.unsupported:
                n = len(self.unsupported)
                parts.append(f"{n} line{'s' * (n != 1)} not supported yet")
            out.append(f"{self.path}: {', '.join(parts)}")
        return "\n".join(out)


def _line_ranges(lines: list[int]) -> str:
    """'5, 9-12, 40' for the lines [5, 9, 10, 11, 12, 40]."""
    runs: list[list[int]] = []
    for n in sorted(set(lines)):
        if runs and n == runs[-1][1] + 1:
            runs[-1][1] = n
        else:
            runs.append([n, n])
    return ", ".join(str(a) if a == b else f"{a}-{b}" for a, b in runs)


def _unsupported_lines(items, main: str) -> list[str]:
    """One line per keyword and file: 'DYNX   48 x  lines 60-107' (the file is named when
    it is not the main deck)."""
    groups: dict = {}
    for kw, loc in items:
        groups.setdefault((kw, loc.file), []).append(loc.line)
    width = max(len(kw) for kw, _ in groups)
    out = []
    for (kw, file), lines in groups.items():
        where = f"line {lines[0]}" if len(lines) == 1 else f"lines {_line_ranges(lines)}"
        out.append(f"  {kw:<{width}}  {len(lines):>3} x  {'' if file == main else file + ' '}"
                   f"{where}")
    return out


def summarize(statements: list[Statement], model: Model | None = None, *,
              path: str = "<deck>", problems=(),
              settings: AnalysisSettings | None = None) -> DeckSummary:
    """Count what a deck contains.

    Parameters
    ----------
    statements : list of Statement
        The parsed deck (generator lines are expanded here).
    model : Model, optional
        The built model, if it could be built; gives the counts that need a complete model.
    path : str
        Shown in the summary.
    problems : list of DeckError items
        From building the model; split into "not supported yet" items and other errors.
    settings : AnalysisSettings, optional
        The deck's analysis settings (with the model; default: the defaults).

    Returns
    -------
    DeckSummary
    """
    expanded = expand_generators(statements)[0]
    kin = [st for st in expanded if st.module >= 0]
    s = DeckSummary(path=path, model=model)
    for loc, msg, src in problems:
        refused = UNSUPPORTED_PATTERN.match(msg)
        if refused and loc is not None:
            s.unsupported.append((refused.group(1), loc))
        else:
            s.errors.append((loc, msg, src))

    positions = {st.fields[0] for st in kin if st.keyword == "X"}
    rot, warp = set(), set()
    elements: dict[str, set] = {}
    for st in kin:
        spec = KEYWORDS.get(st.keyword)
        if spec is None or not spec.is_element or st.keyword in GENERATORS:
            continue
        elements.setdefault(st.keyword, set()).add(st.fields[0])
        for role, n in zip(spec.node_roles, st.fields[1:]):
            if role == "r":
                rot.add(n)
            elif role == "w":
                warp.add(n)
        if st.origin is not None:
            s.generated_elements += 1
    s.position_nodes = len(positions)
    s.orientation_nodes = len(rot - positions)
    s.warping_nodes = len(warp - positions)
    s.elements = {kw: len(ids) for kw, ids in elements.items()}
    s.parameters = {st.fields[0]: st.fields[1] for st in statements if st.keyword == "SET"}
    s.loads = {kw: n for kw in ("XF", "DELXF", "QE", "DELQE", "XFL", "DELXFL", "QEL", "DELQEL")
               if (n := sum(st.keyword == kw for st in kin)) or kw in ("XF", "DELXF")}
    s.nodal_masses = sum(st.keyword == "XM" for st in kin)
    sections, _, _ = collect_cross_sections(expanded)
    for cs in sections.by_element.values():
        s.cross_sections[cs.shape] = s.cross_sections.get(cs.shape, 0) + 1

    if model is not None:
        _from_model(s, model, settings or AnalysisSettings())
        return s
    listed = {"DYNE": set(), "RLSE": set()}
    for st in kin:
        if st.keyword in listed:
            listed[st.keyword].update((st.fields[0], k) for k in st.fields[1:])
    s.flexible, s.released = len(listed["DYNE"]), len(listed["RLSE"])
    for st in kin:
        if st.keyword == "MODE":
            s.analysis = resolve_analysis(st.fields[0]) or s.analysis
        elif st.keyword == "DEFORMATIONS":
            s.deformations = resolve_deformations(st.fields[0]) or s.deformations
        elif st.keyword == "ITERSTEP":
            s.iterstep = (st.fields[0], max(st.fields[1], 1),
                          st.fields[2] if len(st.fields) > 2 else 5e-7)
    return s


def dynamic_text(dynamic, n_dyne: int, limit: int = 8) -> str:
    """The DYNX coordinates in one line: ``3 coordinates: node 2 (1 2), node 4 (3); with 1
    DYNE mode, 4 degrees of freedom`` (the first ``limit`` nodes named)."""
    by_node: dict = {}
    for n, c in dynamic:
        by_node.setdefault(n, []).append(c)
    named = [f"node {n} ({' '.join(map(str, cs))})" for n, cs in list(by_node.items())[:limit]]
    more = len(by_node) - limit
    text = (f"{len(dynamic)} coordinate{'s' * (len(dynamic) != 1)}: " + ", ".join(named)
            + (f" and {more} more node{'s' * (more != 1)}" if more > 0 else ""))
    return (text + f"; with {n_dyne} DYNE mode{'s' * (n_dyne != 1)}, "
            f"{len(dynamic) + n_dyne} degrees of freedom (SPACAR's)")


def _from_model(s: DeckSummary, model: Model, settings: AnalysisSettings) -> None:
    from spacarpy.numbering import number_model

    # the deformation modes of every element kind (the registry sets each kind's count)
    dcs = [es.def_class.ravel() for es in model.elements.values()]
    dc = np.concatenate(dcs) if dcs else np.zeros(0, np.int8)
    s.flexible = int(np.count_nonzero(dc == FLEXIBLE))
    s.released = int(np.count_nonzero(dc == RELEASED))
    s.rigid = int(np.count_nonzero(dc == RIGID))
    num = number_model(model)
    s.n_coord = num.n_coord
    s.n_position_coord = 3 * int(model.position_ids.size)
    s.n_fixed = int(num.fixed_mask.sum())
    s.n_rigid_constraints = num.n_rigid
    s.n_euler_constraints = int(num.euler_nodes.size)
    s.dof = num.n_unknown - num.n_constraint
    s.kinematic = len(model.kinematic)
    s.dynamic = [(d.node, d.coord) for d in model.dynamic_coords]
    s.slips_held = sum(int(np.count_nonzero(es.def_class[:, m] == RIGID))
                       for kw, es in model.elements.items()
                       for m in getattr(KINDS[kw], "velocity_modes", ()))
    positions = set(model.position_ids.tolist())
    every = list(model.loads) + list(model.follower_loads)
    s.forces = sum(ld.node in positions for ld in every)
    s.moments = len(every) - s.forces
    s.analysis, s.deformations = settings.analysis, settings.deformations
    it = settings.static.iterstep
    s.iterstep = (it.max_iter, it.n_steps, it.tol)


def check_deck(path, *, overrides=None, deformations: str | None = None,
               analysis: str | None = None) -> DeckSummary:
    """Read, parse and validate a deck file without solving it.

    Parameters
    ----------
    path : str or path-like
    overrides : dict, optional
        ``--set`` values for the deck's SET parameters.
    deformations, analysis : str, optional
        Command-line overrides of DEFORMATIONS / MODE.

    Returns
    -------
    DeckSummary
        With ``model`` set if the model could be built, and every problem found.

    Raises
    ------
    DeckError
        If the file cannot be read or has syntax errors (then nothing can be counted).
    """
    text = read_deck_text(path)
    statements = parse_deck(text, str(path), overrides=overrides)
    model, settings, problems = None, None, []
    try:
        model, settings = build_job(statements, text=text, path=str(path),
                                    deformations=deformations, analysis=analysis)
    except DeckError as exc:
        problems = exc.items
    return summarize(statements, model, path=str(path), problems=problems, settings=settings)
