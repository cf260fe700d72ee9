"""Deck semantics, analysis settings: what to compute, not what the structure is.

MODE, DEFORMATIONS, ROTARYINERTIA, BIFURCATION, ITERSTEP, ARCLENGTH, MODES, TIMESTEP, ERROR,
SUBSTEPS, RHOINF, START, TIMEFUNCTION and VELOCITY become one
:class:`spacarpy.settings.AnalysisSettings`; OUTLEVEL is read and has no effect (a warning).
Checked here: values out of their range or not among the choices, keywords given twice, time
functions against :mod:`spacarpy.time_functions`, initial velocities of nodes that do not
exist.
"""
from __future__ import annotations

import numpy as np

from spacarpy.deck.semantics.errors import DeckContext, ErrorCollector
from spacarpy.deck.semantics.topology import Topology, UsesTopology
from spacarpy.deck.statement import Statement
from spacarpy.settings import (
    DEFORMATION_VARIANTS,
    AnalysisSettings,
    ArcLength,
    IterStep,
    LinearizedSettings,
    StaticSettings,
    TransientSettings,
    resolve_analysis,
    resolve_deformations,
    spacar_mode_refusal,
    valid_modes,
)
from spacarpy.time_functions import KINDS as TIME_FUNCTION_KINDS
from spacarpy.time_functions import TIME_FUNCTIONS

__all__ = ["from_statements"]


def named_time_function(st: Statement) -> str | None:
    """The name of a named ``TIMEFUNCTION name kind p...`` line (its first field is not a
    kind and its second is a word), None for the deck's ``TIMEFUNCTION kind p...``."""
    first = st.fields[0]
    if str(first).lower() in TIME_FUNCTION_KINDS or len(st.fields) < 2:
        return None
    return str(first) if isinstance(st.fields[1], str) else None


class _SettingsPass(UsesTopology):
    def __init__(self, ctx: DeckContext, errors: ErrorCollector, topology: Topology):
        self.ctx, self.errors, self.topology = ctx, errors, topology
        self.analysis: str | None = None
        self.deformations: str | None = None
        self.rotary_inertia = "lumped"
        self.bifurcation = "off"
        self.iterstep: IterStep | None = None
        self.arclength: ArcLength | None = None
        self.n_modes: int | None = None
        self.modes_each_step = False
        self.timestep = None
        self.rho_inf = 0.9
        self.substeps = 1
        self.error_tol = None
        self.start = "deck"
        self.time_function = ("constant", ())
        self.named_time_functions: dict = {}      # name (lower case) -> (kind, params)
        self.named_lines: dict = {}               # name (lower case) -> its TIMEFUNCTION line
        self.initial_velocities: dict = {}

    def settings(self) -> AnalysisSettings:
        return AnalysisSettings(
            analysis=self.analysis or "static",
            deformations=self.deformations or "modified",
            rotary_inertia=self.rotary_inertia,
            bifurcation=self.bifurcation,
            static=StaticSettings(iterstep=self.iterstep or IterStep(),
                                  arclength=self.arclength),
            linearized=LinearizedSettings(n_modes=self.n_modes,
                                          modes_each_step=self.modes_each_step),
            transient=TransientSettings(
                timestep=self.timestep, rho_inf=self.rho_inf, substeps=self.substeps,
                error_tol=self.error_tol, start=self.start, time_function=self.time_function,
                named_time_functions=tuple(sorted(self.named_time_functions.items())),
                initial_velocities=self.initial_velocities))

    def timestep_line(self, st: Statement) -> None:
        """``TIMESTEP t_end n_steps``; ``TIMESTEP 0 0`` (a spacarpy extension) asks mode 3
        for the linearization about the initial state only."""
        t_end, n_steps = st["t_end"], st["n_steps"]
        if t_end == 0 and n_steps == 0:
            self.timestep = (0.0, 0)
        elif not (t_end > 0 and n_steps >= 1):
            self.error(st.loc, "TIMESTEP: expected a positive end time and at least one step, "
                               f"got {t_end:g} {n_steps}", st)
        else:
            self.timestep = (float(t_end), int(n_steps))

    def velocity_line(self, st: Statement) -> None:
        """``VELOCITY n vx vy vz``: an initial velocity."""
        n = st["n"]
        if self.node_kind(n) is None:
            self.error(st.loc_of("n"), f"VELOCITY: node {n} is not defined (no X line and not "
                                       "used by any element)", st)
        elif n in self.initial_velocities:
            self.error(st.loc, f"VELOCITY: node {n} is given twice", st)
        else:
            self.initial_velocities[n] = tuple(float(st[c]) for c in ("vx", "vy", "vz"))

    def error_line(self, st: Statement) -> None:
        """``ERROR abs rel``: adaptive time steps."""
        tol_abs, tol_rel = st["abs"], st["rel"]
        if tol_abs < 0 or tol_rel < 0 or tol_abs + tol_rel <= 0:
            self.error(st.loc, "ERROR: expected non-negative tolerances abs rel, not both zero, "
                               f"got {tol_abs:g} {tol_rel:g}", st)
        else:
            self.error_tol = (float(tol_abs), float(tol_rel))

    def substeps_line(self, st: Statement) -> None:
        """``SUBSTEPS k``: integration steps per stored step."""
        self.substeps = int(st["k"])

    def rho_inf_line(self, st: Statement) -> None:
        """``RHOINF rho_inf``, in the range its field declares."""
        rho, spec = st["rho_inf"], st.field_spec("rho_inf")
        if not spec.accepts(rho):
            self.error(st.loc_of("rho_inf"), f"RHOINF: the spectral radius lies in "
                                             f"{spec.range_text}, got {rho:g}", st)
        else:
            self.rho_inf = float(rho)

    def start_line(self, st: Statement) -> None:
        """``START deck|static`` (the choices of its field)."""
        if not st.field_spec("start").accepts(st["start"]):
            self.error(st.loc_of("start"), "START: expected 'deck' (at rest in the deck's "
                                           "configuration) or 'static' (the static "
                                           f"equilibrium), got '{st['start']}'", st)
        else:
            self.start = str(st["start"]).lower()

    def iterstep_line(self, st: Statement) -> None:
        """``ITERSTEP max_iter n_steps [tol [f4 [f5 [n_init]]]]``."""
        if not self.ctx.once(st, self.errors):
            return
        max_iter, n_steps = st["max_iter"], st["n_steps"]
        ok = True
        if max_iter < 1:
            self.error(st.loc_of("max_iter"), "ITERSTEP: the maximum number of iterations must "
                                              f"be at least 1, got {max_iter}", st)
            ok = False
        if n_steps < 0:
            self.error(st.loc_of("n_steps"), "ITERSTEP: the number of load steps must not be "
                                             f"negative, got {n_steps}", st)
            ok = False
        tol = st.value("tol", IterStep.tol)
        if tol <= 0:
            self.error(st.loc_of("tol"), f"ITERSTEP: the tolerance must be positive, got {tol:g}",
                       st)
            ok = False
        n_init = st.value("n_init", 1)
        if n_init < 0:
            self.error(st.loc_of("n_init"), "ITERSTEP: the number of initial-load steps must not "
                                            f"be negative, got {n_init}", st)
            ok = False
        extra = tuple(v for v in (st.value("f4"), st.value("f5")) if v is not None)
        if ok:
            self.iterstep = IterStep(max_iter=max_iter, n_steps=max(n_steps, 1), tol=float(tol),
                                     n_init=max(n_init, 1), extra=extra, loc=st.loc)

    def arclength_line(self, st: Statement) -> None:
        """``ARCLENGTH n_max ds0 [ds_min [ds_max]]``: arc-length continuation."""
        if not self.ctx.once(st, self.errors):
            return
        n_max, ds0 = int(st["n_max"]), float(st["ds0"])
        ds_min, ds_max = st.value("ds_min"), st.value("ds_max")
        for name in ("ds0", "ds_min", "ds_max"):
            value = st.value(name)
            if value is not None and not value > 0:
                self.error(st.loc_of(name), f"ARCLENGTH: {name} must be positive, got "
                                            f"{value:g}", st)
                return
        lo = float(ds_min) if ds_min is not None else ds0 / 1000.0
        hi = float(ds_max) if ds_max is not None else 10.0 * ds0
        if not lo <= ds0 <= hi:
            self.error(st.loc, f"ARCLENGTH: expected ds_min <= ds0 <= ds_max, got "
                               f"{lo:g} <= {ds0:g} <= {hi:g}", st)
            return
        self.arclength = ArcLength(n_max=n_max, ds0=ds0,
                                   ds_min=None if ds_min is None else float(ds_min),
                                   ds_max=None if ds_max is None else float(ds_max),
                                   loc=st.loc)

    def mode_line(self, st: Statement) -> None:
        """``MODE analysis``."""
        if not self.ctx.once(st, self.errors):
            return
        value = resolve_analysis(st["analysis"])
        refusal = spacar_mode_refusal(st["analysis"])
        if refusal is not None:
            self.error(st.loc_of("analysis"), f"MODE: {refusal}", st)
        elif value is None:
            self.error(st.loc_of("analysis"), f"MODE: unknown analysis '{st['analysis']}'; "
                                              f"expected {valid_modes()}", st)
        self.analysis = value

    def deformations_line(self, st: Statement) -> None:
        """``DEFORMATIONS variant``."""
        if not self.ctx.once(st, self.errors):
            return
        value = resolve_deformations(st["variant"])
        if value is None:
            self.error(st.loc_of("variant"), f"DEFORMATIONS: unknown variant '{st['variant']}'; "
                                             f"expected {' or '.join(DEFORMATION_VARIANTS)}", st)
        self.deformations = value

    def _choice(self, st: Statement, field: str, joiner: str) -> str | None:
        """The lower-cased value of a keyword whose one field is a choice, given once; None
        (with the error reported) otherwise."""
        if not self.ctx.once(st, self.errors):
            return None
        value, spec = st[field], st.field_spec(field)
        if not spec.accepts(value):
            self.error(st.loc_of(field), f"{st.keyword}: unknown {field} '{value}'; "
                                         f"expected {joiner.join(spec.choices)}", st)
            return None
        return str(value).lower()

    def rotary_inertia_line(self, st: Statement) -> None:
        """``ROTARYINERTIA lumped|consistent`` (the choices of its field)."""
        value = self._choice(st, "choice", " or ")
        if value is not None:
            self.rotary_inertia = value

    def time_function_line(self, st: Statement) -> None:
        """``TIMEFUNCTION kind p...`` (the deck's function) or ``TIMEFUNCTION name kind p...``
        (a named one, for the loads LOADTF gives it), checked against
        :mod:`spacarpy.time_functions`."""
        name = named_time_function(st)
        if name is None:
            if self.ctx.once(st, self.errors):
                parsed = self._time_function(st, str(st["kind"]), st.values("p"),
                                             st.loc_of("kind"), st.loc_of("p"))
                if parsed is not None:
                    self.time_function = parsed
            return
        if not name.isidentifier():
            self.error(st.loc_of("kind"), f"TIMEFUNCTION: the name {name!r} must be a word of "
                                          "letters, digits and _ (TIMEFUNCTION name kind "
                                          "p...)", st)
            return
        first = self.named_lines.get(name.lower())
        if first is not None:
            self.error(st.loc_of("kind"), f"TIMEFUNCTION {name} is given twice (lines "
                                          f"{first.loc.line} and {st.loc.line})", st)
            return
        self.named_lines[name.lower()] = st
        given = st.values("p")
        p_loc = st.field_locs[2] if len(st.field_locs) > 2 else st.loc
        parsed = self._time_function(st, str(given[0]), given[1:], st.field_locs[1], p_loc)
        if parsed is not None:
            self.named_time_functions[name.lower()] = parsed

    def _time_function(self, st: Statement, kind: str, given: tuple, kind_loc,
                       p_loc) -> tuple | None:
        """(kind, params) of a TIMEFUNCTION line's kind and parameters, or None after an
        error."""
        written, kind = kind, kind.lower()
        spec = TIME_FUNCTION_KINDS.get(kind)
        if spec is None:
            self.error(kind_loc, f"TIMEFUNCTION: unknown kind '{written}'; expected "
                                 f"{', '.join(TIME_FUNCTIONS)} (or a name, then the kind)",
                       st)
            return None
        if kind == "expr":
            if len(given) != 1 or not isinstance(given[0], str):
                self.error(st.loc, 'TIMEFUNCTION expr takes one expression in t, in double '
                                   'quotes: TIMEFUNCTION expr "1 - exp(-t/0.1)"', st)
                return None
            from spacarpy.expressions import ExpressionError, evaluate  # Lark: only here
            try:
                evaluate(given[0], {"t": 0.0})
            except (ExpressionError, ValueError, ZeroDivisionError) as exc:
                self.error(p_loc, f"TIMEFUNCTION expr: {exc} (the expression may use "
                                  "t, pi and the functions of {expressions})", st)
                return None
            return ("expr", tuple(given))
        if any(isinstance(v, str) for v in given):
            self.error(st.loc, f"TIMEFUNCTION {kind}: expected numbers after the kind", st)
            return None
        params = tuple(float(v) for v in given)
        if kind == "table":
            ok = len(params) >= 4 and len(params) % 2 == 0 and np.all(np.diff(params[0::2]) > 0)
            if not ok:
                self.error(st.loc, "TIMEFUNCTION table: expected pairs t1 phi1 t2 phi2 ... (at "
                                   "least two, times increasing)", st)
                return None
        elif len(params) != spec.n_params:
            self.error(st.loc, f"TIMEFUNCTION {kind} takes {spec.n_params} parameter(s) "
                               f"({spec.description}), got {len(params)}", st)
            return None
        elif spec.positive_first and params[0] <= 0:
            self.error(p_loc, f"TIMEFUNCTION {kind}: the parameter must be positive, "
                              f"got {params[0]:g}", st)
            return None
        return (kind, params)

    def modes_line(self, st: Statement) -> None:
        """``MODES count [each|last]`` (the choices of its ``where`` field)."""
        if not self.ctx.once(st, self.errors):
            return
        self.n_modes = int(st["count"])
        where = st.value("where")
        if where is not None:
            if not st.field_spec("where").accepts(where):
                self.error(st.loc_of("where"), "MODES: expected 'each' (linearize at every load "
                                               f"step) or 'last', got '{where}'", st)
                return
            self.modes_each_step = str(where).lower() == "each"

    def bifurcation_line(self, st: Statement) -> None:
        """``BIFURCATION off|warn|switch`` (the choices of its field)."""
        value = self._choice(st, "setting", ", ")
        if value is not None:
            self.bifurcation = value

    def overrides(self, deformations, analysis) -> None:
        """The command line's choices replace the deck's MODE / DEFORMATIONS."""
        if analysis is not None:
            value = resolve_analysis(analysis)
            if spacar_mode_refusal(analysis) is not None:
                self.error(None, spacar_mode_refusal(analysis))
            elif value is None:
                self.error(None, f"unknown analysis '{analysis}'; expected {valid_modes()}")
            self.analysis = value
        if deformations is not None:
            value = resolve_deformations(deformations)
            if value is None:
                self.error(None, f"unknown deformation variant '{deformations}'; expected "
                                 f"{' or '.join(DEFORMATION_VARIANTS)}")
            self.deformations = value


def from_statements(by_kw: dict, ctx: DeckContext, errors: ErrorCollector, topology: Topology,
                    deformations: str | None = None,
                    analysis: str | None = None) -> AnalysisSettings:
    """The analysis settings of the statements (by keyword), with the command line's
    ``deformations`` and ``analysis`` (None: the deck's); problems go to ``errors``."""
    part = _SettingsPass(ctx, errors, topology)
    for st in by_kw.get("OUTLEVEL", []):
        errors.warn(f"{st.loc}: OUTLEVEL has no effect in spacarpy: the result file always "
                    "holds every quantity")
    for keyword, line in (("ITERSTEP", part.iterstep_line), ("MODE", part.mode_line),
                          ("ARCLENGTH", part.arclength_line),
                          ("DEFORMATIONS", part.deformations_line),
                          ("ROTARYINERTIA", part.rotary_inertia_line),
                          ("BIFURCATION", part.bifurcation_line), ("MODES", part.modes_line)):
        for st in by_kw.get(keyword, []):
            line(st)
    for st in by_kw.get("TIMESTEP", []):
        if ctx.once(st, errors):
            part.timestep_line(st)
    for st in by_kw.get("VELOCITY", []):
        part.velocity_line(st)
    for keyword, line in (("ERROR", part.error_line), ("SUBSTEPS", part.substeps_line),
                          ("RHOINF", part.rho_inf_line), ("START", part.start_line)):
        for st in by_kw.get(keyword, []):
            if ctx.once(st, errors):
                line(st)
    for st in by_kw.get("TIMEFUNCTION", []):
        part.time_function_line(st)
    part.overrides(deformations, analysis)
    return part.settings()
