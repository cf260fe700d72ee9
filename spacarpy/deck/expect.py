"""Expectations carried by a deck (spacarpy extension): read ``EXPECT`` lines, check a result file.

An ``EXPECT`` line names a quantity of the result file, selects one value of it by step, deck
node/element number and component, and gives the expected value and a tolerance::

    EXPECT static.displacement -1 17 y 1.211296            # tolerance from the digits: 5e-7
    EXPECT static.position -1 3 x 46.94                     # 2 decimals: +-0.005
    EXPECT buckling.critical_load_multiplier -1 {1.495290*Fth} abs {5e-7*Fth}
    EXPECT eigen.frequency -1 1 1.5708 rel 1e-3

This module has one job: turn the parsed ``EXPECT`` statements into :class:`Expect` records
(:func:`expectations`, with file:line:column errors) and check them against an HDF5 result
file (:func:`check_expectations`). The syntax is documented in docs/deck.md ("EXPECT"); the
model builder ignores the lines, so they never change the analysis.
"""
from __future__ import annotations

import difflib
import logging
import math
import re
from dataclasses import dataclass

import numpy as np

from spacarpy.errors import DeckError, SourceLoc

log = logging.getLogger(__name__)

__all__ = ["EXIT_EXPECTATION", "QUANTITIES", "Expect", "ExpectResult", "check_expectations",
           "check_model_references",
           "expectations", "format_results", "load_with_expectations"]

#: Exit code of ``spacarpy run`` when the analysis finished but an EXPECT line failed.
EXIT_EXPECTATION = 4

# Axis kinds of the selectors, in the order they are written after the quantity:
#   step   static step, 0 = initial state, negative counts from the end (-1 = last)
#   lstep  the same static step, looked up in the group's `step` dataset (linearized groups)
#   pos / rot / elem   deck number of a position node / orientation node / element
#   xyz    component x, y, z (or 1..3);  euler 1..4 (lambda0..lambda3);  dmode 1..6
#   mode   mode number, 1 = the first;  c6  row or column 1..6 of a 6x6 compliance
#   reac   deck node number and a component word Fx Fy Fz Mx My Mz (two fields)
_AXIS_HELP = {
    "step": "the static step (0 = initial state, -1 = the last)",
    "lstep": "the static step that was linearized (-1 = the last)",
    "pos": "a position node number", "rot": "an orientation node number",
    "elem": "an element number", "xyz": "a component x, y or z (or 1, 2, 3)",
    "euler": "an Euler parameter 1..4", "dmode": "a deformation mode 1..6",
    "mode": "a mode number (1 = the first)", "c6": "a row/column 1..6",
    "reac": "a node number and a component Fx, Fy, Fz, Mx, My or Mz",
}

#: Quantities an EXPECT line may name: name -> (HDF5 path, axis kinds).
#: ``static.displacement`` is derived: ``/static/position`` minus ``/model/position_x0``.
#: ``run.exit_code`` is the exit code of ``spacarpy run``: ``EXPECT run.exit_code 1`` marks a
#: deck that must fail (checked by ``spacarpy batch``; ``spacarpy run`` skips it).
QUANTITIES: dict[str, tuple[str, tuple[str, ...]]] = {
    "run.exit_code": ("", ()),
    "static.load_factor": ("/static/load_factor", ("step",)),
    "static.position": ("/static/position", ("step", "pos", "xyz")),
    "static.displacement": ("/static/position", ("step", "pos", "xyz")),
    "static.euler": ("/static/euler", ("step", "rot", "euler")),
    "static.deformation": ("/static/deformation", ("step", "elem", "dmode")),
    "static.stress_resultant": ("/static/stress_resultant", ("step", "elem", "dmode")),
    "static.reaction": ("/static/reaction", ("step", "reac")),
    "static.iterations": ("/static/iterations", ("step",)),
    "static.max_normal_stress": ("/static/max_normal_stress", ("step", "elem")),
    "static.max_von_mises_stress": ("/static/max_von_mises_stress", ("step", "elem")),
    "eigen.frequency": ("/eigen/frequency", ("lstep", "mode")),
    "eigen.eigenvalue_real": ("/eigen/eigenvalue_real", ("lstep", "mode")),
    "buckling.load_multiplier": ("/buckling/load_multiplier", ("lstep", "mode")),
    "buckling.critical_load_multiplier": ("/buckling/critical_load_multiplier", ("lstep",)),
    "compliance.global": ("/compliance/global", ("lstep", "c6", "c6")),
    "compliance.local": ("/compliance/local", ("lstep", "c6", "c6")),
}

_COMPONENTS = {"x": 1, "y": 2, "z": 3}
_REACTIONS = ("Fx", "Fy", "Fz", "Mx", "My", "Mz")
_SPECIAL = {"inf": math.inf, "+inf": math.inf, "-inf": -math.inf, "nan": math.nan}
_LITERAL = re.compile(r"[+-]?(\d+)(?:\.(\d*))?(?:[eEdD]([+-]?\d+))?"
                      r"|[+-]?\.(\d+)(?:[eEdD]([+-]?\d+))?")


@dataclass(frozen=True)
class Expect:
    """One ``EXPECT`` line.

    Attributes
    ----------
    quantity : str
        A key of :data:`QUANTITIES`, e.g. ``"static.position"``.
    selectors : tuple
        One entry per axis (see :data:`QUANTITIES`): ints, and for ``reac`` a ``(node,
        component)`` pair.
    value : float
        The expected value (may be ``inf`` or ``nan``, which must then match exactly).
    abs_tol, rel_tol : float
        Pass when ``|actual - value| <= abs_tol + rel_tol * |value|``.
    loc : SourceLoc
        The EXPECT keyword.
    text : str
        The line as written (for reports).
    selector_locs : tuple of SourceLoc
        Where each selector was written (one per entry of ``selectors``; for ``reac`` the
        node number), for errors found against the model (:func:`check_model_references`).
    """

    quantity: str
    selectors: tuple
    value: float
    abs_tol: float
    rel_tol: float
    loc: SourceLoc
    text: str = ""
    selector_locs: tuple = ()

    @property
    def label(self) -> str:
        """``quantity[selectors]`` as a short readable name."""
        sel = " ".join(" ".join(map(str, s)) if isinstance(s, tuple) else str(s)
                       for s in self.selectors)
        return f"{self.quantity}[{sel}]"

    @property
    def tolerance(self) -> float:
        """The allowed absolute difference."""
        return self.abs_tol + self.rel_tol * abs(self.value) if math.isfinite(self.value) \
            else 0.0


@dataclass(frozen=True)
class ExpectResult:
    """The outcome of one expectation: ``actual`` is NaN when it could not be read, and
    ``message`` then says why."""

    expect: Expect
    actual: float
    passed: bool
    message: str = ""


def _literal_tolerance(text: str) -> float | None:
    """Half a unit in the last written digit of a number literal (``1.491462`` -> 5e-7)."""
    m = _LITERAL.fullmatch(text)
    if m is None:
        return None
    if m.group(4) is not None:
        decimals, exp = len(m.group(4)), int(m.group(5) or 0)
    else:
        decimals, exp = len(m.group(2) or ""), int(m.group(3) or 0)
    return 0.5 * 10.0 ** (exp - decimals)


def _field_text(st, i: int) -> str:
    """The i-th field of a statement as written in its source line."""
    loc = st.field_locs[i]
    line = st.source_line
    m = re.compile(r"\{[^}]*\}|\S+").match(line, max(loc.column - 1, 0))
    return m.group(0) if m else ""


def _whole(value) -> int | None:
    if isinstance(value, bool):
        return None
    if isinstance(value, int):
        return value
    if isinstance(value, float) and value.is_integer():
        return int(value)
    return None


def _selector(kind: str, value, value2=None):
    """Convert one selector field (or two for ``reac``); raise ValueError with the reason."""
    if kind == "xyz":
        if isinstance(value, str) and value.lower() in _COMPONENTS:
            return _COMPONENTS[value.lower()]
        n = _whole(value)
        if n in (1, 2, 3):
            return n
        raise ValueError(f"expected {_AXIS_HELP[kind]}, found '{value}'")
    n = _whole(value)
    if n is None:
        raise ValueError(f"expected {_AXIS_HELP[kind]}, found '{value}'")
    limits = {"euler": 4, "dmode": 6, "c6": 6}
    if kind in limits and not 1 <= n <= limits[kind]:
        raise ValueError(f"expected {_AXIS_HELP[kind]}, found '{value}'")
    if kind in ("pos", "rot", "elem", "mode", "reac") and n < 1:
        raise ValueError(f"expected {_AXIS_HELP[kind]}, found '{value}'")
    if kind == "reac":
        comp = str(value2)
        match = [c for c in _REACTIONS if c.lower() == comp.lower()]
        if not match:
            raise ValueError(f"expected a reaction component Fx, Fy, Fz, Mx, My or Mz after "
                             f"the node number, found '{value2}'")
        return (n, match[0])
    return n


def _parse_one(st) -> Expect:
    """One EXPECT statement -> Expect; raise DeckError (file:line:col) when it is wrong."""
    def fail(i, msg):
        loc = st.field_locs[i] if i < len(st.field_locs) else st.loc
        raise DeckError([(loc, f"EXPECT: {msg}", st.source_line)])

    fields = list(st.fields)
    name = str(fields[0]).lower()
    if name not in QUANTITIES:
        close = difflib.get_close_matches(name, list(QUANTITIES), n=1, cutoff=0.6)
        hint = f" (did you mean {close[0]}?)" if close else \
            f"; known quantities: {', '.join(QUANTITIES)}"
        fail(0, f"unknown quantity '{fields[0]}'{hint}")
    _, axes = QUANTITIES[name]
    n_sel = sum(2 if a == "reac" else 1 for a in axes)
    usage = (f"usage: EXPECT {name} " + " ".join(f"<{a}>" for a in axes)
             + " value [abs A] [rel R]")
    # trailing tolerances: pairs 'abs A' / 'rel R'
    end = len(fields)
    tol: dict = {}
    while end - 2 >= 1 + n_sel + 1 and isinstance(fields[end - 2], str) \
            and fields[end - 2].lower() in ("abs", "rel"):
        kind = fields[end - 2].lower()
        if kind in tol:
            fail(end - 2, f"'{kind}' is given twice")
        t = fields[end - 1]
        if isinstance(t, str) or not t >= 0 or not math.isfinite(float(t)):
            fail(end - 1, f"the {kind} tolerance must be a finite number >= 0, found '{t}'")
        tol[kind] = float(t)
        end -= 2
    if end != 1 + n_sel + 1:
        fail(min(end, len(fields) - 1) if end > 1 + n_sel + 1 else len(fields) - 1,
             f"{name} takes {n_sel} selector{'s' * (n_sel != 1)} "
             f"({', '.join(_AXIS_HELP[a] for a in axes)}), then the value and an optional "
             f"tolerance; got {len(fields) - 1} fields after the quantity ({usage})")
    selectors, selector_locs = [], []
    i = 1
    for a in axes:
        selector_locs.append(st.field_locs[i] if i < len(st.field_locs) else st.loc)
        try:
            if a == "reac":
                _selector("pos", fields[i])
                i += 1
                selectors.append(_selector(a, fields[i - 1], fields[i]))
                i += 1
            else:
                selectors.append(_selector(a, fields[i]))
                i += 1
        except ValueError as exc:
            fail(i, str(exc))
    raw = fields[i]
    if isinstance(raw, str):
        if raw.lower() not in _SPECIAL:
            fail(i, f"expected the value (a number, an {{expression}}, inf or nan), found "
                    f"'{raw}'")
        value = _SPECIAL[raw.lower()]
    else:
        value = float(raw)
    if not tol:
        if not math.isfinite(value):
            abs_tol = 0.0
        else:
            lit = _literal_tolerance(_field_text(st, i))
            if lit is None:
                fail(i, "give a tolerance ('abs A' or 'rel R') for a value written as an "
                        "expression; a plain number gets half a unit of its last digit")
            abs_tol = lit
        tol = {"abs": abs_tol}
    return Expect(quantity=name, selectors=tuple(selectors), value=value,
                  abs_tol=tol.get("abs", 0.0), rel_tol=tol.get("rel", 0.0), loc=st.loc,
                  text=st.source_line.strip(), selector_locs=tuple(selector_locs))


def expectations(statements) -> list[Expect]:
    """The EXPECT lines of a parsed deck.

    Parameters
    ----------
    statements : list of Statement
        From :func:`spacarpy.deck.parse_deck`.

    Returns
    -------
    list of Expect
        In deck order.

    Raises
    ------
    DeckError
        With every wrong EXPECT line (unknown quantity, wrong selectors, missing tolerance).
    """
    out, errors = [], []
    for st in statements:
        if st.keyword != "EXPECT":
            continue
        try:
            out.append(_parse_one(st))
        except DeckError as exc:
            errors.extend(exc.items)
    if errors:
        raise DeckError(errors)
    return out


def load_with_expectations(path, *, deformations: str | None = None,
                           analysis: str | None = None, overrides: dict | None = None,
                           input_files: list | None = None):
    """Like :func:`spacarpy.deck.load`, and also return the deck's expectations.

    ``input_files``, a list, gets the files the deck was read from (the deck and its
    INCLUDEs), so that a caller can refuse to overwrite one.

    Returns
    -------
    job : Job
        The model and the analysis settings.
    expects : list of Expect
    """
    from spacarpy.deck.parser import parse_deck
    from spacarpy.deck.semantics import build_job
    from spacarpy.deck.textfile import read_deck_text

    text = read_deck_text(path)
    try:
        statements = parse_deck(text, str(path), overrides=overrides)
    except DeckError as exc:
        skipped = _unevaluable_expects(exc, str(path)) if overrides else None
        if skipped is None:
            raise
        # --set changed the deck; its EXPECT lines belong to the deck as written: one that
        # cannot be evaluated now (sqrt of a negative ...) is skipped with a warning
        for loc, msg, _ in exc.items:
            log.warning("%s: warning: EXPECT line skipped under --set: %s", loc, msg)
        lines = text.split("\n")
        for n in skipped:
            lines[n - 1] = "%" + lines[n - 1]            # a comment: line numbers stay
        statements = parse_deck("\n".join(lines), str(path), overrides=overrides)
    if input_files is not None:
        input_files.append(str(path))
        # (``file``, not ``loc.file``: a fast-path statement makes its locations when asked)
        input_files.extend(dict.fromkeys(st.file for st in statements
                                         if st.file is not None and st.file != str(path)))
    job = build_job(statements, text=text, path=str(path), deformations=deformations,
                    analysis=analysis)
    expects = expectations(statements)
    check_model_references(expects, job.model, statements)
    return job, expects


def check_model_references(expects, model, statements=()) -> None:
    """Refuse, before any run, an EXPECT line whose node or element is not in ``model``.

    Parameters
    ----------
    expects : list of Expect
    model : Model
        The model the deck builds.
    statements : list of Statement, optional
        The parsed deck, for the source line of each error.

    Raises
    ------
    DeckError
        With file:line:column of every selector naming a node or element the model lacks.
    """
    sources = {id(st.loc): st.source_line for st in statements if st.keyword == "EXPECT"}
    element_ids = set()
    for es in model.elements.values():
        element_ids.update(int(i) for i in es.ids)
    known = {"pos": (set(model.position_ids.tolist()), "position node"),
             "rot": (set(model.orientation_ids.tolist()), "orientation node"),
             "elem": (element_ids, "element")}
    errors = []
    for ex in expects:
        _, axes = QUANTITIES[ex.quantity]
        for k, (axis, sel) in enumerate(zip(axes, ex.selectors)):
            if axis == "reac":        # a force at a position node, a moment at an orientation node
                axis, sel = ("pos" if sel[1].startswith("F") else "rot"), sel[0]
            if axis not in known:
                continue
            ids, what = known[axis]
            if sel not in ids:
                loc = ex.selector_locs[k] if k < len(ex.selector_locs) else ex.loc
                shown = sorted(ids)
                listed = ", ".join(map(str, shown[:20])) + (", ..." if len(shown) > 20 else "")
                errors.append((loc, f"EXPECT {ex.quantity}: {what} {sel} is not in the model "
                                    f"(its {what}s: {listed or 'none'})",
                               sources.get(id(ex.loc), ex.text)))
    if errors:
        raise DeckError(errors)


def _unevaluable_expects(exc: DeckError, path: str) -> set | None:
    """The line numbers of ``exc``'s errors if every one is on an EXPECT line of the deck
    file ``path`` itself, else None."""
    lines = set()
    for loc, _, src in exc.items:
        if loc is None or loc.file != path or src is None or \
                not src.lstrip().upper().startswith("EXPECT"):
            return None
        lines.add(loc.line)
    return lines or None


def _row(ids, number, what):
    hit = np.flatnonzero(np.asarray(ids) == number)
    if not hit.size:
        raise LookupError(f"{what} {number} is not in the model")
    return int(hit[0])


def _read_value(f, ex: Expect) -> float:
    """Read the selected value of ``ex`` from the open h5py file ``f``."""
    path, axes = QUANTITIES[ex.quantity]
    if path not in f:
        raise LookupError(f"{path} is not in the result file (was that analysis run?)")
    ds = f[path]
    n_step = len(f["/static/load_factor"]) if "/static/load_factor" in f else 0
    index = []
    for kind, sel in zip(axes, ex.selectors):
        if kind in ("step", "lstep"):
            step = sel + n_step if sel < 0 else sel
            if not 0 <= step < n_step:
                raise LookupError(f"step {sel} does not exist (the run has {n_step} steps, "
                                  f"0..{n_step - 1})")
            if kind == "lstep":
                group = path.rsplit("/", 1)[0]
                rows = np.flatnonzero(f[group + "/step"][()] == step)
                if not rows.size:
                    raise LookupError(f"step {sel} was not linearized ({group}/step holds "
                                      f"{list(f[group + '/step'][()])})")
                index.append(int(rows[0]))
            else:
                index.append(step)
        elif kind == "pos":
            index.append(_row(f["/model/position_nodes"][()], sel, "position node"))
        elif kind == "rot":
            index.append(_row(f["/model/orientation_nodes"][()], sel, "orientation node"))
        elif kind == "elem":
            index.append(_row(f["/model/elements"][()], sel, "element"))
        elif kind == "reac":
            nodes = f["/static/reaction_node"][()]
            comps = [c.decode() if isinstance(c, bytes) else str(c)
                     for c in f["/static/reaction_component"][()]]
            hit = [k for k, (n, c) in enumerate(zip(nodes, comps)) if n == sel[0] and c == sel[1]]
            if not hit:
                raise LookupError(f"no reaction {sel[1]} at node {sel[0]} (not a supported "
                                  "coordinate)")
            index.append(hit[0])
        elif kind == "mode":
            n_mode = ds.shape[-1]
            if sel > n_mode:
                raise LookupError(f"mode {sel} is not stored ({n_mode} modes; see --modes)")
            index.append(sel - 1)
        else:                             # xyz, euler, dmode, c6: 1-based components
            index.append(sel - 1)
    value = float(ds[tuple(index)])
    if ex.quantity == "static.displacement":
        value -= float(f["/model/position_x0"][index[1], index[2]])
    return value


def check_expectations(expects, result_path) -> list[ExpectResult]:
    """Check expectations against a result file.

    Parameters
    ----------
    expects : list of Expect
    result_path : path-like or file-like
        An HDF5 result file written by ``spacarpy run`` (a path, or a file-like object).

    Returns
    -------
    list of ExpectResult
        One per expectation; a value that cannot be read (missing dataset, unknown node, step
        not linearized) fails with the reason in ``message``.
    """
    import h5py

    out = []
    with h5py.File(result_path, "r") as f:
        for ex in expects:
            if ex.quantity == "run.exit_code":
                continue
            try:
                actual = _read_value(f, ex)
            except LookupError as exc:
                out.append(ExpectResult(ex, math.nan, False, str(exc)))
                continue
            if math.isfinite(ex.value):
                passed = abs(actual - ex.value) <= ex.tolerance
            elif math.isnan(ex.value):
                passed = math.isnan(actual)
            else:
                passed = actual == ex.value
            out.append(ExpectResult(ex, actual, bool(passed)))
    return out


def format_results(results) -> str:
    """A PASS/FAIL table of :func:`check_expectations` results, one line each."""
    lines = []
    width = max((len(r.expect.label) for r in results), default=0)
    for r in results:
        ex = r.expect
        head = f"{'PASS' if r.passed else 'FAIL'}  {ex.label:<{width}}"
        if r.message:
            lines.append(f"{head}  {r.message}  ({ex.loc})")
            continue
        diff = r.actual - ex.value if math.isfinite(ex.value) else math.nan
        lines.append(f"{head}  expected {ex.value:.10g} +- {ex.tolerance:.3g}, got "
                     f"{r.actual:.10g} (difference {diff:.3g})  ({ex.loc})")
    n_fail = sum(not r.passed for r in results)
    lines.append(f"expectations: {len(results) - n_fail} passed, {n_fail} failed")
    return "\n".join(lines) + "\n"
