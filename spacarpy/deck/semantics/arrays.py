"""Deck semantics on arrays: the nodes, elements, DYNE, ESTIFF and EM lines of a valid deck,
all at once.

A deck of 10^5 elements has one X line per node and one BEAM line per element; turning each
line into records and checking them one by one took most of the time of reading it. Here
those lines come as arrays (the parser's :class:`~spacarpy.deck.fastpath.PlainTable` s, and
rows made from the statements of the lines that are not plain), and the checks of
:mod:`.topology` and :mod:`.element_data` are made for all of them at once: doubly defined
nodes and elements, undefined nodes, position versus orientation nodes, zero lengths,
orientation vectors, the usual DYNE, ESTIFF and EM lines, flexible modes without stiffness,
unconnected nodes. The other keywords (FIX, loads, settings, ...) and the unusual element
data lines go through the parts of the per-statement semantics, which see the elements
through mappings that make an element's record when one is asked for.

This path builds models only. At the first thing that is not the usual case (a planar
model, generator lines, an unsupported keyword) or that the per-statement semantics would
report (any error or warning), :func:`build_arrays` returns None and
:mod:`.build` runs the per-statement semantics on the same statements, which give every
message exactly as before; a deck with a problem is therefore read twice. The model built
here equals the per-statement one (tests/test_deck_arrays.py).

The arrays themselves, and the mappings through which the per-statement parts see them, are
in :mod:`.array_views`; this module checks them and builds the model.
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from spacarpy.deck.keywords import GENERATORS, UNSUPPORTED
from spacarpy.deck.semantics import constraints as _constraints
from spacarpy.deck.semantics import element_data as _element_data
from spacarpy.deck.semantics import loads as _loads
from spacarpy.deck.semantics import settings as _settings
from spacarpy.deck.semantics import signals as _signals
from spacarpy.deck.semantics.array_views import (
    StatementLocs,
    _ArrayTopology,
    _Elements,
    _FirstUse,
    _GiveUp,
    _Kind,
    _Lines,
    _Positions,
)
from spacarpy.deck.semantics.errors import DeckContext, ErrorCollector
from spacarpy.deck.semantics.topology import (
    ELEMENT_KEYWORDS,
    ORIENTATION_TOL,
    ZERO_LENGTH_RTOL,
    _row_norms,
)
from spacarpy.deck.visualization import collect_cross_sections
from spacarpy.elements.registry import KINDS, PLANAR_KINDS
from spacarpy.job import Job
from spacarpy.model import FLEXIBLE, ElementSet, Model

__all__ = ["MAX_LEFT", "MIN_LINES", "TABLE_KEYWORDS", "build_arrays"]

#: The keywords whose plain lines the parser gives as tables for this module.
TABLE_KEYWORDS = frozenset(("X", "DYNE", "ESTIFF", "EM") + ELEMENT_KEYWORDS)
#: Decks of fewer lines are read the per-statement way (``spacarpy.deck.job_from_text``):
#: for them the arrays' fixed costs outweigh what they save.
MIN_LINES = 1024
#: Element data lines left to the per-statement part beyond this many: the per-statement
#: semantics build the deck (a record per element would cost more than they do).
MAX_LEFT = 4096




def _unique(ids: np.ndarray) -> bool:
    """Whether no number is there twice."""
    ids = np.sort(ids)
    return bool((ids[1:] != ids[:-1]).all())


def _positions(lines: _Lines) -> _Positions:
    """The X lines: three coordinates each (a model in space), every node once."""
    if len(lines) and not (lines.width == 4).all():
        raise _GiveUp
    ids = lines.ints(0)
    if not _unique(ids):
        raise _GiveUp
    return _Positions(lines, ids, lines.values[:, 1:4].reshape(len(lines), 3))


def _check_elements(kinds: list[_Kind], positions: _Positions) -> None:
    """Every element: known position nodes, orientation nodes that are none, a length, an
    orientation vector (hinge axis) neither zero nor parallel to the element (as
    :meth:`.topology.Topology.element_geometry` computes them)."""
    x, search = positions.xyz, positions.search
    for kind in kinds:
        info, n = kind.info, len(kind.ids)
        ends = kind.field_columns(info["position_fields"])
        rows, found = search.find(ends)
        if not found.all():
            raise _GiveUp
        if search.find(kind.field_columns(info["orientation_fields"]))[1].any():
            raise _GiveUp
        if kind.keyword == "HINGE" and not kind.vector_given.all():
            raise _GiveUp
        if len(info["position_fields"]) == 2:
            d = x[rows[:, 1]] - x[rows[:, 0]]
            length = _row_norms(d)
            with np.errstate(over="ignore", invalid="ignore"):
                scale = np.maximum(np.abs(x[rows[:, 0]]).max(axis=1),
                                   np.abs(x[rows[:, 1]]).max(axis=1))
            if (length <= ZERO_LENGTH_RTOL * scale).any():
                raise _GiveUp
            axis = d / length[:, None]
        else:
            axis = np.full((n, 3), np.nan)
        given = kind.vector_given
        if given.any():
            vector = kind.vector[given]
            vector_norm = _row_norms(vector)
            parallel = _row_norms(np.cross(axis[given], vector)) < ORIENTATION_TOL * vector_norm
            if (vector_norm < ORIENTATION_TOL).any() or parallel.any():
                raise _GiveUp


def _orientation_use(kinds: list[_Kind]) -> _FirstUse:
    """The orientation nodes, each with the first element line using it."""
    nodes, pos, owner = [], [], []
    for k, kind in enumerate(kinds):
        cols = kind.field_columns(kind.info["orientation_fields"])
        nodes.append(cols.ravel())
        pos.append(np.repeat(kind.lines.pos, cols.shape[1]))
        owner.append(np.stack([np.full(cols.size, k), np.repeat(np.arange(len(kind.ids)),
                                                                cols.shape[1])], axis=1))
    nodes = np.concatenate(nodes) if nodes else np.zeros(0, np.int64)
    pos = np.concatenate(pos) if pos else np.zeros(0, np.int64)
    owner = np.concatenate(owner) if owner else np.zeros((0, 2), np.int64)
    order = np.argsort(pos, kind="stable")
    unique, first = np.unique(nodes[order], return_index=True)
    first_owner = owner[order][first]

    def statement(i):
        k, row = first_owner[i]
        return kinds[k].lines.statement(int(row))
    return _FirstUse(unique, statement)


def _element_data_rows(kinds: list[_Kind], elements: _Elements, dyne: _Lines | None,
                       estiff: _Lines | None, rlse: list):
    """Apply the usual DYNE and ESTIFF lines (an element's only line of that keyword, all
    its modes flexible; a BEAM's 4 to 6 stiffnesses, none negative) to the arrays; return
    the statements of the other lines, for the per-statement part."""
    rest_dyne, rest_estiff = [], []
    lookup = elements.search
    if dyne is not None and len(dyne):
        e = dyne.ints(0)
        i, found = lookup.find(e)
        ids, counts = np.unique(e, return_counts=True)
        once = counts[np.searchsorted(ids, e)] == 1
        if rlse:
            once &= ~np.isin(e, [st.fields[0] for _, st in rlse])
        usual = found & once
        which, row = elements.which[i], elements.row[i]
        handled = np.zeros(len(dyne), dtype=bool)
        for k, kind in enumerate(kinds):
            n_def = kind.def_class.shape[1]
            if n_def + 1 > dyne.values.shape[1]:
                continue
            mine = usual & (which == k) & (dyne.width == 1 + n_def) & \
                (dyne.values[:, 1:1 + n_def] == np.arange(1, n_def + 1)).all(axis=1)
            kind.def_class[row[mine]] = FLEXIBLE
            kind.dyne_row[row[mine]] = np.flatnonzero(mine)
            handled |= mine
        rest_dyne = [(int(p), dyne.statement(j)) for j, p in zip(np.flatnonzero(~handled),
                                                                  dyne.pos[~handled])]
    if estiff is not None and len(estiff):
        e = estiff.ints(0)
        i, found = lookup.find(e)
        ids, counts = np.unique(e, return_counts=True)
        usual = found & (counts[np.searchsorted(ids, e)] == 1) & \
            (estiff.width >= 5) & (estiff.width <= 7)
        with np.errstate(invalid="ignore"):
            usual &= ~(estiff.values[:, 1:] < 0).any(axis=1)
        which, row = elements.which[i], elements.row[i]
        beam = [k for k, kind in enumerate(kinds) if kind.keyword == "BEAM"]
        usual &= (which == beam[0]) if beam else False
        if usual.any():
            kind = kinds[beam[0]]
            values = np.nan_to_num(estiff.values[usual, 1:7], nan=0.0)
            kind.stiffness[row[usual]] = np.pad(values, ((0, 0), (0, 6 - values.shape[1])))
            kind.has_stiffness[row[usual]] = True
            kind.estiff_row[row[usual]] = np.flatnonzero(usual)
        rest_estiff = [(int(p), estiff.statement(j)) for j, p in zip(np.flatnonzero(~usual),
                                                                     estiff.pos[~usual])]
    rest_dyne += [(pos, st) for pos, st in rlse]
    rest_dyne.sort(key=lambda item: item[0])
    return [st for _, st in rest_dyne], [st for _, st in rest_estiff]


def _em_rows(kinds: list[_Kind], elements: _Elements, em: _Lines | None) -> list:
    """Apply the usual EM lines (an element's only one, of a kind with mass, as many values
    as the kind takes, the first four not negative) to the arrays; return the statements
    of the others, in deck order."""
    if em is None or not len(em):
        return []
    e = em.ints(0)
    i, found = elements.search.find(e)
    ids, counts = np.unique(e, return_counts=True)
    usual = found & (counts[np.searchsorted(ids, e)] == 1) & (em.width >= 2)
    with np.errstate(invalid="ignore"):
        usual &= ~(em.values[:, 1:5] < 0).any(axis=1)
    which, row = elements.which[i], elements.row[i]
    handled = np.zeros(len(em), dtype=bool)
    for k, kind in enumerate(kinds):
        info = kind.info
        if not info["has_mass"]:
            continue
        mine = usual & (which == k)
        if "n_em" in info:
            mine &= em.width - 1 <= info["n_em"]
        if not mine.any():
            continue
        values = np.nan_to_num(em.values[mine, 1:6], nan=0.0)
        values = np.pad(values, ((0, 0), (0, 5 - values.shape[1])))
        kind.mass[row[mine]] = values[:, :kind.mass.shape[1]]
        kind.em_row[row[mine]] = np.flatnonzero(mine)
        handled |= mine
    return [em.statement(j) for j in np.flatnonzero(~handled).tolist()]


def _check_flexible_stiffness(kinds: list[_Kind]) -> None:
    """Every flexible mode of an element but a hinge has an ESTIFF line and a stiffness that
    is not zero (:meth:`.element_data._ElementDataPass.check_flexible_stiffness`)."""
    for kind in kinds:
        if kind.keyword == "HINGE":
            continue
        flexible = kind.def_class == FLEXIBLE
        k = kind.stiffness[:, list(kind.info["mode_stiffness"])] if len(kind.ids) else \
            np.zeros(flexible.shape)
        if (flexible & (~kind.has_stiffness[:, None] | (k == 0))).any():
            raise _GiveUp


def _unconnected(kinds: list[_Kind], positions: _Positions, ctx: DeckContext) -> None:
    """Every position node is used by an element (else an error or a warning)."""
    used = [kind.field_columns(kind.info["position_fields"]).ravel() for kind in kinds]
    used.append(np.array(sorted(ctx.foreign_nodes | ctx.quiet_nodes), dtype=np.int64))
    if not np.isin(positions.ids, np.concatenate(used)).all():
        raise _GiveUp


def build_arrays(parsed, path: str, text: str, deformations, analysis) -> Job | None:
    """The job of a parsed deck (:class:`~spacarpy.deck.fastpath.ParsedDeck` with the tables
    of :data:`TABLE_KEYWORDS`), or None if the per-statement semantics must build it (see the
    module docstring)."""
    try:
        return _build(parsed, path, text, deformations, analysis)
    except _GiveUp:
        return None


def _build(parsed, path, text, deformations, analysis) -> Job | None:
    general = parsed.general()
    keywords = {st.keyword for _, st in general} | {t.keyword for t in parsed.tables}
    if keywords & (set(GENERATORS) | set(UNSUPPORTED) | set(PLANAR_KINDS)
                   | {"KINE", "KINX", "DYNX", "USERSIG", "USERINP"}
                   | {kw for kw, k in KINDS.items() if "warp" in k.slots}):
        raise _GiveUp
    statements = [st for _, st in general]
    errors = ErrorCollector(statements)
    sections, vis_errors, vis_warnings = collect_cross_sections(statements)
    if vis_errors or vis_warnings:
        raise _GiveUp
    lines: dict = {}
    by_kw: dict = {}
    for pos, st in general:
        if st.module < 0:
            continue
        if st.keyword in TABLE_KEYWORDS:
            lines.setdefault(st.keyword, ([], []))[1].append((pos, st))
        else:
            by_kw.setdefault(st.keyword, []).append(st)
    for table in parsed.tables:
        lines.setdefault(table.keyword, ([], []))[0].append(table)
    lines = {kw: _Lines(*parts) for kw, parts in lines.items()}
    ctx = DeckContext(path, [st for st in statements if st.module >= 0])
    ctx.by_keyword = by_kw

    positions = _positions(lines.get("X", _Lines([], [])))
    kinds = [_Kind(kw, lines[kw]) for kw in ELEMENT_KEYWORDS if kw in lines]
    if any(kind.info["zero_length_ok"] or kind.info["reference_problems"] is not None
           for kind in kinds):
        raise _GiveUp                       # kinds with checks of their own: line by line
    elements = _Elements(kinds, lines.get("DYNE"), lines.get("ESTIFF"), lines.get("EM"))
    if not _unique(elements.ids):
        raise _GiveUp
    _check_elements(kinds, positions)
    topology = _ArrayTopology(ctx, errors, positions, _orientation_use(kinds), elements)

    rlse = [(pos, st) for pos, st in general if st.keyword == "RLSE" and st.module >= 0]
    by_kw.pop("RLSE", None)
    rest_dyne, rest_estiff = _element_data_rows(kinds, elements, lines.get("DYNE"),
                                                lines.get("ESTIFF"), rlse)
    if rest_dyne:
        by_kw["DYNE"] = rest_dyne           # in deck order, RLSE among them
    if rest_estiff:
        by_kw["ESTIFF"] = rest_estiff
    rest_em = _em_rows(kinds, elements, lines.get("EM"))
    if rest_em:
        by_kw["EM"] = rest_em
    left = len(rest_dyne) + len(rest_estiff) + len(rest_em) + \
        sum(len(by_kw.get(kw, ())) for kw in ("EDAMP", "ESIG", "STARTDE"))
    if left > MAX_LEFT:
        raise _GiveUp
    element_data = _element_data_pass(by_kw, ctx, errors, topology)
    constraints = _constraints.from_statements(by_kw, ctx, errors, topology)
    loads = _loads.from_statements(by_kw, ctx, errors, topology, constraints)
    settings = _settings.from_statements(by_kw, ctx, errors, topology,
                                         deformations=deformations, analysis=analysis)
    inputs, outputs = _signals.from_statements(by_kw, ctx, errors, topology)
    if inputs or outputs:
        settings = replace(settings, linearized=replace(settings.linearized, inputs=inputs,
                                                        outputs=outputs))
    topology.check_cross_section_elements(sections)
    if errors or errors.warnings:
        raise _GiveUp
    elements.write_back()
    _check_flexible_stiffness(kinds)
    _unconnected(kinds, positions, ctx)

    prescribed, deformations_in, rotations = constraints.model_prescribed(loads.motion_tf)
    sets = {kind.keyword: ElementSet(
        kind=kind.keyword, ids=kind.ids, nodes=kind.nodes, vector=kind.vector,
        def_class=kind.def_class, stiffness=kind.stiffness, has_stiffness=kind.has_stiffness,
        mass=kind.mass, locs=StatementLocs(len(kind.lines), kind.lines.statement))
        for kind in kinds if len(kind.ids)}
    model = Model(
        position_ids=positions.ids,
        position_x0=positions.xyz,
        orientation_ids=topology.orientation_use.nodes,
        elements=sets,
        fixes=constraints.model_fixes(),
        loads=loads.loads,
        line_loads=loads.line_loads,
        follower_loads=loads.follower_loads,
        follower_line_loads=loads.follower_line_loads,
        nodal_masses=loads.nodal_masses,
        prescribed=prescribed,
        prescribed_deformations=deformations_in,
        prescribed_rotations=rotations,
        gravity=loads.gravity,
        cross_sections=sections if len(sections) else None,
        planar=False,
        damping=element_data.damping,
        element_damping=element_data.element_damping,
        element_prestress=element_data.prestress,
        initial_rates=element_data.initial_rates,
        source_path=path,
        source_text=text,
    )
    return Job(model, settings)


def _element_data_pass(by_kw: dict, ctx, errors, topology) -> _element_data.ElementData:
    """The element data lines the arrays left (unusual DYNE/RLSE and ESTIFF lines, EM, EDAMP,
    DAMPING, ESIG, STARTDE), line by line; the flexible modes' stiffness is checked on the
    arrays afterwards (:func:`_check_flexible_stiffness`)."""
    part = _element_data._ElementDataPass(ctx, errors, topology)
    for st in by_kw.get("DYNE", []):
        part.deformation_class(st)
    for st in by_kw.get("ESTIFF", []):
        part.estiff(st)
    for keyword, apply in (("EM", part.em), ("EDAMP", part.edamp), ("DAMPING", part.damping),
                           ("ESIG", part.esig), ("STARTDE", part.startde)):
        for st in by_kw.get(keyword, []):
            apply(st)
    return part.result
