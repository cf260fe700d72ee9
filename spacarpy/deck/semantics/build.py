"""Deck semantics, the driver: checked statements -> a validated :class:`spacarpy.job.Job`.

Runs the parts in order, each ``from_statements(by_kw, ctx, errors, ...)``: the generators
(BEAMS, BEAMARC) are expanded first (:mod:`spacarpy.deck.generators`) and the cross-sections
read once (:mod:`spacarpy.deck.visualization`); then :mod:`.topology`,
:mod:`.element_data`, :mod:`.constraints`, :mod:`.kinematic`, :mod:`.loads`,
:mod:`.settings` and
:mod:`.signals`, and the checks
that need several of them (unconnected nodes, cross-sections of missing elements). Keywords
spacarpy recognises but does not implement yet are refused with "SPACAR keyword KEYWORD is not
supported yet", one error per occurrence. Every problem is collected (:mod:`.errors`) and
they are raised together in one :class:`spacarpy.errors.DeckError`, in deck order; if there
are none, the warnings are logged and the parts are assembled into the model and its settings.
"""
from __future__ import annotations

import logging
from collections.abc import Callable
from contextvars import ContextVar
from dataclasses import replace
from itertools import chain

import numpy as np

from spacarpy.deck.generators import count_elements, expand_generators
from spacarpy.deck.keywords import KEYWORDS, UNSUPPORTED, unsupported_message
from spacarpy.deck.parser import gc_paused, parse_deck
from spacarpy.deck.semantics import arrays as _arrays
from spacarpy.deck.semantics import constraints as _constraints
from spacarpy.deck.semantics import element_data as _element_data
from spacarpy.deck.semantics import kinematic as _kinematic
from spacarpy.deck.semantics import loads as _loads
from spacarpy.deck.semantics import settings as _settings
from spacarpy.deck.semantics import signals as _signals
from spacarpy.deck.semantics import topology as _topology
from spacarpy.deck.semantics.errors import DeckContext, ErrorCollector
from spacarpy.deck.statement import Statement
from spacarpy.deck.visualization import collect_cross_sections
from spacarpy.elements.registry import PLANAR_KINDS
from spacarpy.errors import DeckError
from spacarpy.job import Job
from spacarpy.model import ElementSet, Model

__all__ = ["BEFORE_BUILD", "build_job", "build_job_parsed", "build_model"]

logger = logging.getLogger(__name__)

#: Called, when set, with the number of elements the deck defines (generators counted)
#: right after parsing and before any element is made: ``spacarpy run`` refuses a model too
#: large for the machine's memory there (:func:`spacarpy.memory.check_memory`) instead of
#: after building it (report N11: a million generated elements took 32 s to refuse).
BEFORE_BUILD: ContextVar[Callable[[int], None] | None] = ContextVar("before_build",
                                                                    default=None)


def _table(rows, dtype) -> np.ndarray:
    """Rows of numbers as an array (n, width): one pass over the values when every row has
    the same length (np.array's nested-list conversion is several times slower); otherwise
    the rows as they are (ElementSet converts them)."""
    rows = list(rows)
    widths = set(map(len, rows))
    if len(widths) != 1:
        return rows
    width = widths.pop()
    return np.fromiter(chain.from_iterable(rows), dtype=dtype,
                       count=len(rows) * width).reshape(len(rows), width)


def _element_sets(topology: _topology.Topology) -> dict:
    """The element records as one :class:`ElementSet` per kind, in the registry's order."""
    by_kind: dict[str, list] = {}
    for b in topology.elements.values():
        by_kind.setdefault(b.keyword, []).append(b)
    sets = {}
    for kw in _topology.ELEMENT_KEYWORDS:
        els = by_kind.get(kw)
        if els:
            sets[kw] = ElementSet(
                kind=kw, ids=[b.id for b in els],
                nodes=_table(map(_topology.KIND_INFO[kw]["nodes"], [b.st.fields for b in els]),
                             np.int64),
                vector=_topology.vectors_of(els),
                def_class=_table([b.def_class for b in els], np.int8),
                stiffness=_table([b.stiffness for b in els], float),
                has_stiffness=[b.estiff is not None for b in els],
                mass=_table([b.mass for b in els], float),
                locs=_arrays.StatementLocs(len(els), lambda i, els=els: els[i].st))
    return sets


def _semantics(statements: list[Statement], path: str, text: str, deformations, analysis) -> Job:
    hook = BEFORE_BUILD.get()
    if hook is not None:
        hook(count_elements(statements))
    errors = ErrorCollector(statements)
    statements, gen_errors, quiet_elements, quiet_nodes = expand_generators(statements)
    errors.extend(gen_errors)
    sections, vis_errors, vis_warnings = collect_cross_sections(statements)
    errors.extend(vis_errors)
    for msg in vis_warnings:
        errors.warn(msg)

    statements = [st for st in statements if st.module >= 0]
    by_kw: dict[str, list[Statement]] = {}
    for st in statements:
        sts = by_kw.get(st.keyword)
        if sts is None:
            sts = by_kw[st.keyword] = []
        sts.append(st)
    for keyword in UNSUPPORTED:
        for st in by_kw.get(keyword, ()):
            errors.error(st.loc, unsupported_message(st.keyword), st)
    # a planar model: PLBEAM/PLTRUSS/PLHINGE only, nodes in the x-y plane
    ctx = DeckContext(path, statements, planar=any(kw in by_kw for kw in PLANAR_KINDS),
                      quiet_elements=quiet_elements, quiet_nodes=quiet_nodes)
    ctx.by_keyword = by_kw

    topology = _topology.from_statements(by_kw, ctx, errors)
    element_data = _element_data.from_statements(by_kw, ctx, errors, topology)
    constraints = _constraints.from_statements(by_kw, ctx, errors, topology)
    kinematic, dynamic = _kinematic.from_statements(by_kw, ctx, errors, topology, constraints)
    loads = _loads.from_statements(by_kw, ctx, errors, topology, constraints)
    settings = _settings.from_statements(by_kw, ctx, errors, topology,
                                         deformations=deformations, analysis=analysis)
    inputs, outputs = _signals.from_statements(by_kw, ctx, errors, topology,
                                               constraints.fix_lines)
    if inputs or outputs:
        settings = replace(settings, linearized=replace(settings.linearized, inputs=inputs,
                                                        outputs=outputs))
    topology.check_unconnected(constraints.fixes)
    topology.check_cross_section_elements(sections)

    if errors:
        raise DeckError(errors.sorted())
    for msg in errors.warnings:
        logger.warning(msg)
    ids = list(topology.positions)
    prescribed, deformations_in, rotations = constraints.model_prescribed(
        loads.motion_tf)
    model = Model(
        position_ids=ids,
        position_x0=[topology.positions[k][0] for k in ids] if ids else [],
        orientation_ids=sorted(topology.orientation_use),
        warping_ids=sorted(topology.warping_use),
        elements=_element_sets(topology),
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
        planar=ctx.planar,
        damping=element_data.damping,
        element_damping=element_data.element_damping,
        element_prestress=element_data.prestress,
        initial_rates=element_data.initial_rates,
        kinematic=kinematic,
        user_routines=loads.user_routines,
        dynamic_coords=dynamic,
        source_path=path,
        source_text=text,
    )
    _warn_massless_gravity(model, by_kw.get("GRAVITY", ()))
    return Job(model, settings)


def _warn_massless_gravity(model, gravity_lines) -> None:
    """GRAVITY acts on masses: in a model without EM or XM masses it does nothing, which
    the deck's author did not mean (a warning naming the line)."""
    if not gravity_lines or not any(model.gravity):
        return
    if model.nodal_masses or any(np.any(es.mass != 0) for es in model.elements.values()):
        return
    st = gravity_lines[0]
    logger.warning("%s: warning: GRAVITY has no effect: the model has no mass (no EM or XM "
                   "lines)", st.loc)


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
        statements = parse_deck(text, path, overrides=overrides)
    with gc_paused():
        return _semantics(list(statements), path, text, deformations, analysis)


def build_job_parsed(parsed, *, text: str, path: str, deformations: str | None = None,
                     analysis: str | None = None) -> Job:
    """:func:`build_job` for a :class:`~spacarpy.deck.fastpath.ParsedDeck` of
    :func:`~spacarpy.deck.parser.parse_deck_tables` (with the keywords of
    :data:`.arrays.TABLE_KEYWORDS`): a deck with tables (many plain lines of one keyword) is
    built on arrays (:mod:`.arrays`) unless that path gives up; then, and for every other
    deck, by the per-statement semantics, with the same result and the same errors."""
    with gc_paused():
        if parsed.tables:
            hook = BEFORE_BUILD.get()
            if hook is not None:
                hook(count_elements(st for st in parsed.statements if st is not None)
                     + sum(len(tab) for tab in parsed.tables
                           if tab.keyword in KEYWORDS and KEYWORDS[tab.keyword].is_element))
            job = _arrays.build_arrays(parsed, path, text, deformations, analysis)
            if job is not None:
                return job
            statements = parsed.materialize()
        else:
            statements = parsed.statements
        return _semantics(list(statements), path, text, deformations, analysis)


def build_model(statements, **kw) -> Model:
    """The structural model of parsed deck statements: ``build_job(...).model`` (the analysis
    settings are checked too, then dropped). Arguments as :func:`build_job`."""
    return build_job(statements, **kw).model
