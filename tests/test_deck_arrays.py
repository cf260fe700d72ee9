"""The deck semantics on arrays (spacarpy/deck/semantics/arrays.py) against the per-statement
semantics (spacarpy/deck/semantics/build.py), the reference.

The array path reads the X, element, DYNE and ESTIFF lines of a large deck as arrays (the
parser's tables, spacarpy/deck/fastpath.py) and builds the model only for a deck without
problems; for anything else it gives up and the per-statement semantics run. Every test here
compares the two: the same model and settings, or the same error text; and checks that the
array path was taken where it should be, so that the comparison is not between one path and
itself.
"""
from __future__ import annotations

import logging
from pathlib import Path

import numpy as np
import pytest

import spacarpy.deck.fastpath as fastpath
import spacarpy.deck.fields as fields
import spacarpy.deck.parser as parser
import spacarpy.deck.semantics.arrays as arrays
from spacarpy.deck import build_job, job_from_text, parse_deck
from spacarpy.errors import DeckError

ROOT = Path(__file__).resolve().parents[1]
CORPUS = ROOT.parent / "shared" / "spacar-decks"


def _state(job, locs: bool = True):
    """Everything a job holds, comparable with ==: arrays as lists (NaN as None)."""
    def plain(a):
        a = np.asarray(a)
        if a.dtype.kind == "f":
            return [None if np.isnan(v) else v for v in a.ravel().tolist()], a.shape
        return a.tolist(), a.shape

    m = job.model
    out = {"position_ids": plain(m.position_ids), "position_x0": plain(m.position_x0),
           "orientation_ids": plain(m.orientation_ids), "settings": job.settings}
    for name in ("fixes", "loads", "line_loads", "nodal_masses", "prescribed",
                 "prescribed_rotations",
                 "prescribed_deformations", "gravity", "cross_sections", "planar", "damping",
                 "element_damping", "element_prestress", "initial_rates", "source_path",
                 "source_text"):
        out[name] = getattr(m, name)
    for kind, es in m.elements.items():
        for name in ("ids", "nodes", "vector", "def_class", "stiffness", "has_stiffness",
                     "mass"):
            out[f"{kind}.{name}"] = plain(getattr(es, name))
        if locs:
            out[f"{kind}.locs"] = [str(loc) for loc in es.locs]
    if not locs:
        for name in ("fixes", "loads", "source_text", "source_path"):
            out.pop(name)
    return out


def _per_statement(text: str, name: str):
    """The reference: every line a statement, the per-statement semantics."""
    try:
        return ("job", _state(build_job(parse_deck(text, name), text=text, path=name)))
    except DeckError as exc:
        return ("error", str(exc))


class _Spy:
    """Counts the decks the array path built (it returns None when it gives up)."""

    def __init__(self, monkeypatch):
        self.built = self.gave_up = 0
        real = arrays.build_arrays

        def spy(*args, **kw):
            job = real(*args, **kw)
            if job is None:
                self.gave_up += 1
            else:
                self.built += 1
            return job
        monkeypatch.setattr(arrays, "build_arrays", spy)


def _arrays(text: str, name: str):
    try:
        return ("job", _state(job_from_text(text, name)))
    except DeckError as exc:
        return ("error", str(exc))


def _corpus():
    decks = sorted((ROOT / "decks").glob("*.dat"))
    if CORPUS.is_dir():
        decks += sorted(CORPUS.glob("*.dat"))
    return decks


def _check_corpus(monkeypatch, decks):
    # every batch of plain lines a table: the array path for every deck it can take; the
    # lines read one by one, and scanned as in a large deck
    monkeypatch.setattr(fastpath, "_SMALL_BATCH", 0)
    monkeypatch.setattr(fields, "_SMALL_BATCH", 0)
    monkeypatch.setattr(arrays, "MIN_LINES", 0)
    spy = _Spy(monkeypatch)
    for path in decks:
        text = path.read_text(encoding="utf-8", errors="replace")
        reference = _per_statement(text, str(path))
        assert _arrays(text, str(path)) == reference, path.name
        with monkeypatch.context() as m:
            m.setattr(fastpath, "_SCAN_LINES", 0)
            m.setattr(parser, "_RUN_LINES", 1)
            assert _arrays(text, str(path)) == reference, path.name
    spy.built //= 2
    spy.gave_up //= 2
    return spy


def test_the_repository_cantilever_decks_build_the_same_on_arrays(monkeypatch):
    decks = sorted((ROOT / "decks").glob("table1_cantilever_*.dat"))
    assert decks
    spy = _check_corpus(monkeypatch, decks)
    assert spy.built == len(decks)


@pytest.mark.slow
def test_every_deck_builds_the_same_on_arrays(monkeypatch):
    """Every deck of the repository and of the SPACAR corpus (when it is there): the same
    job or the same errors, whichever path built it."""
    decks = _corpus()
    spy = _check_corpus(monkeypatch, decks)
    assert spy.built >= 30 and spy.gave_up >= 5, (spy.built, spy.gave_up)


def _cantilever(n: int, compact: bool = False, extra=(), data_extra=()) -> str:
    """A straight cantilever of n BEAMs along x with tip load: one line per node and element
    (position node 2i+1, orientation node 2i+2), or the BEAMS generator and ranges."""
    length = 2.0
    if compact:
        body = [f"BEAMS 1 1 2 {2 * n + 1} {2 * n + 2} {n} 0 1 0", f"DYNE 1:{n} 1:6"]
        x = ["X 1 0 0 0", f"X {2 * n + 1} {length!r} 0 0"]
        data = [f"ESTIFF 1:{n} 2.07e9 1.1e6 1.725e6 1.725e6", f"EM 1:{n} 78.5 0.13 0.065"]
    else:
        x = [f"X {2 * i + 1} {length * i / n!r} 0 0" for i in range(n + 1)]
        body = [f"BEAM {i + 1} {2 * i + 1} {2 * i + 2} {2 * i + 3} {2 * i + 4} 0 1 0"
                for i in range(n)]
        body += [f"DYNE {i + 1} 1 2 3 4 5 6" for i in range(n)]
        data = [f"ESTIFF {i + 1} 2.07e9 1.1e6 1.725e6 1.725e6" for i in range(n)]
        data += [f"EM {i + 1} 78.5 0.13 0.065" for i in range(n)]
    return "\n".join(x + body + list(extra) + ["FIX 1", "FIX 2", "END", "HALT"] + data +
                     list(data_extra) + [f"DELXF {2 * n + 1} 0 100 0", "END", "END", ""])


def test_a_large_explicit_deck_on_arrays_equals_its_generator_form(monkeypatch):
    spy = _Spy(monkeypatch)
    n = 1000
    explicit = job_from_text(_cantilever(n), "<explicit>")
    assert (spy.built, spy.gave_up) == (1, 0)
    generated = job_from_text(_cantilever(n, compact=True), "<beams>")
    assert spy.built == 1                   # BEAMS: the per-statement semantics
    a, b = _state(explicit, locs=False), _state(generated, locs=False)
    # the generator numbers its intermediate nodes its own way: compare by position
    ids_a, ids_b = explicit.model.position_ids, generated.model.position_ids
    order_a = np.argsort(explicit.model.position_x0[:, 0])
    order_b = np.argsort(generated.model.position_x0[:, 0])
    assert np.array_equal(explicit.model.position_x0[order_a],
                          generated.model.position_x0[order_b])
    rename = dict(zip(ids_b[order_b].tolist(), ids_a[order_a].tolist()))
    es_a, es_b = explicit.model.elements["BEAM"], generated.model.elements["BEAM"]
    assert es_a.nodes[:, [0, 2]].tolist() == \
        [[rename[p] for p in row] for row in es_b.nodes[:, [0, 2]].tolist()]
    for name in ("ids", "vector", "def_class", "stiffness", "has_stiffness", "mass"):
        assert a[f"BEAM.{name}"] == b[f"BEAM.{name}"], name
    assert a["settings"] == b["settings"]
    assert len(explicit.model.orientation_ids) == len(generated.model.orientation_ids) == n + 1
    # and both equal what the per-statement semantics make of the explicit deck
    text = _cantilever(n)
    assert ("job", _state(explicit)) == _per_statement(text, "<explicit>")


def test_line_loads_and_load_functions_build_the_same_on_arrays(monkeypatch):
    """QE/DELQE lines (one per element), a named TIMEFUNCTION and LOADTF lines in a large
    deck: the array path keeps them as the per-statement semantics do."""
    spy = _Spy(monkeypatch)
    n = 1000
    data = [f"DELQE {i + 1} 0 -1 0" for i in range(n)]
    data += ["QE 1:4 1 2 3 4 5 6", "TIMEFUNCTION gust sine 2", f"LOADTF gust DELXF {2 * n + 1}",
             "LOADTF gust DELQE 7"]
    text = _cantilever(n, data_extra=data)
    job = job_from_text(text, "<lines>")
    assert (spy.built, spy.gave_up) == (1, 0)
    assert len(job.model.line_loads) == n + 4
    assert [ld.element for ld in job.model.line_loads if ld.tf == "gust"] == [7]
    assert [ld.tf for ld in job.model.loads] == ["gust"]
    assert ("job", _state(job)) == _per_statement(text, "<lines>")


# lines that are not plain (an expression, a comment, a range), lines of other keywords
# and kinds, and element data the arrays leave to the per-statement part
MIXED_BODY = ["X 1001 {2.5*2} 0 0   # an expression", "X 1002 5 1 0",
              "TRUSS 5001 1001 1002", "BEAM 5002 1001 1003 1002 1004 1 0 0",
              "RLSE 5001 1", "DYNE 5002 6 5 4 3 2 1"]
MIXED_DATA = ["ESTIFF 5001 1e5", "ESTIFF 5002 {2e9} 1e6 1e6 1e6", "EM 5001 2.0",
              "EM 5002 1 0 0 0", "EDAMP 3 1 1", "ESIG 4 10", "XM 1001 2.5",
              "XF 1002 0 0 1", "DAMPING 0.1 0.001"]


def test_a_mixed_deck_builds_the_same_on_arrays(monkeypatch):
    monkeypatch.setattr(fastpath, "_SCAN_LINES", 0)
    spy = _Spy(monkeypatch)
    n = 400
    text = _cantilever(n, extra=MIXED_BODY, data_extra=MIXED_DATA)
    text = text.replace(f"X {2 * n + 1} ", f"X {2 * n + 1}   ").replace(
        "BEAM 7 13 14 15 16 0 1 0", "BEAM 7 13 14 15 16 0 1 0  # a comment").replace(
        f"DYNE {n} 1 2 3 4 5 6", f"DYNE {n}:{n} 1:6")
    got = _arrays(text, "mixed.dat")
    assert (spy.built, spy.gave_up) == (1, 0)
    assert got == _per_statement(text, "mixed.dat")
    assert got[0] == "job"


def _cut(text: str, old: str, new: str) -> str:
    assert old in text, old
    return text.replace(old, new, 1)


N = 300                       # elements of the deck of the error cases: tables, not lines
BAD = {
    "a node defined twice": ("X 301 ", "X 299 "),
    "an undefined position node": ("BEAM 150 299 300 301 302 0 1 0",
                                   "BEAM 150 299 300 9999 302 0 1 0"),
    "a position node as orientation node": ("BEAM 150 299 300 301 302 0 1 0",
                                            "BEAM 150 299 300 301 303 0 1 0"),
    "an element defined twice": ("BEAM 150 ", "BEAM 149 "),
    "a zero-length element": ("X 301 1.0 0 0", f"X 301 {2.0 * 149 / 300!r} 0 0"),
    "an orientation vector along the element": ("BEAM 150 299 300 301 302 0 1 0",
                                                "BEAM 150 299 300 301 302 1 0 0"),
    "a zero orientation vector": ("BEAM 150 299 300 301 302 0 1 0",
                                  "BEAM 150 299 300 301 302 0 0 0"),
    "DYNE of an undefined element": ("DYNE 150 1 2 3 4 5 6", "DYNE 9150 1 2 3 4 5 6"),
    "DYNE of a mode the element lacks": ("DYNE 150 1 2 3 4 5 6", "DYNE 150 1 2 3 4 5 7"),
    "DYNE and RLSE of one mode": ("DYNE 150 1 2 3 4 5 6", "DYNE 150 1 2 3 4 5 6\nRLSE 150 3"),
    "a negative stiffness": ("ESTIFF 150 2.07e9", "ESTIFF 150 -2.07e9"),
    "ESTIFF twice": ("ESTIFF 150 2.07e9", "ESTIFF 149 2.07e9"),
    "ESTIFF of an undefined element": ("ESTIFF 150 2.07e9", "ESTIFF 9150 2.07e9"),
    "a flexible mode without stiffness": ("ESTIFF 150 2.07e9 1.1e6 1.725e6 1.725e6\n", ""),
    "a flexible mode of zero stiffness": ("ESTIFF 150 2.07e9 1.1e6", "ESTIFF 150 2.07e9 0"),
    "an unconnected node": ("X 301 ", "X 9001 5 5 5\nX 301 "),
    "an unreadable number": ("X 301 1.0 ", "X 301 1.0.0 "),
    "a whole number expected": ("BEAM 150 299", "BEAM 150.5 299"),
    "a FIX of an undefined node": ("FIX 2", "FIX 2\nFIX 9999"),
    "a planar element in a spatial model": ("BEAM 150 299 300 301 302 0 1 0",
                                            "BEAM 150 299 300 301 302 0 1 0\nPLBEAM 9 1 2 3 4"),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_a_bad_line_in_a_large_deck_gives_the_per_statement_error(monkeypatch, case):
    monkeypatch.setattr(fastpath, "_SCAN_LINES", 0)      # read as the large deck it stands for
    text = _cut(_cantilever(N), *BAD[case])
    spy = _Spy(monkeypatch)
    got = _arrays(text, "big.dat")
    assert got[0] == "error", case
    assert got == _per_statement(text, "big.dat")
    assert spy.built == 0


def test_the_errors_name_their_lines():
    text = _cut(_cantilever(N), "X 301 ", "X 299 ")
    with pytest.raises(DeckError) as exc:
        job_from_text(text, "big.dat")
    assert str(exc.value).splitlines()[0] == \
        "big.dat:151:3: error: node 299 has two X lines (lines 150 and 151)"
    text = _cut(_cantilever(N), "BEAM 150 299 300 301 302 0 1 0",
                "BEAM 150 299 300 9999 302 0 1 0")
    with pytest.raises(DeckError) as exc:
        job_from_text(text, "big.dat")
    assert str(exc.value).splitlines()[0] == \
        "big.dat:451:18: error: element 150: position node 9999 (at q) has no X line"


def test_a_warning_is_given_as_the_per_statement_semantics_give_it(monkeypatch, caplog):
    text = _cut(_cantilever(N), "FIX 2", "FIX 2\nFIX 9001\nX 9001 5 5 5")
    spy = _Spy(monkeypatch)
    with caplog.at_level(logging.WARNING):
        got = _arrays(text, "big.dat")
    assert spy.gave_up == 1 and got[0] == "job"
    assert [r.getMessage() for r in caplog.records] == [
        "big.dat:905:1: position node 9001 is not connected to any element (it is fixed, "
        "so it does nothing)"]
    assert got == _per_statement(text, "big.dat")


def test_tables_give_the_statements_of_parse_deck(monkeypatch):
    text = _cantilever(200, extra=MIXED_BODY, data_extra=MIXED_DATA).replace(
        "DYNE 200 1 2 3 4 5 6", "DYNE 100:200 1:6")
    parsed = parser.parse_deck_tables(text, "d.dat", keywords=arrays.TABLE_KEYWORDS)
    assert {t.keyword for t in parsed.tables} == {"X", "BEAM", "DYNE", "ESTIFF", "EM"}
    assert parsed.materialize() == parse_deck(text, "d.dat")


def test_the_scan_finds_the_tokens_and_numbers_of_split_and_float():
    from spacarpy.deck.linescan import LineScan
    rng = np.random.default_rng(7)
    words = ["X", "BEAM", "x", "DYNE", "ESTIFF", "E_1", "LONGWORDS", "-", "1e5", "007", "+3",
             "2.5e-3", "1.", ".5", "123456789012345", "1234567890123456", "1.0D-3", "1-2"]
    lines = []
    for _ in range(400):
        tokens = rng.choice(words, size=rng.integers(0, 6)).tolist()
        gaps = rng.choice(["", " ", "  ", "\t", " \r"], size=len(tokens) + 1).tolist()
        lines.append(gaps[0] + "".join(t + (g or " ") for t, g in zip(tokens, gaps[1:])))
    lines += ["X 1 2 # comment", "BEAM {1} 2", "a:b", "\x0c", ""]
    text = "\n".join(lines)
    scan = LineScan(text)
    assert len(scan.n_tokens) == len(lines)
    for i, line in enumerate(lines):
        simple = not any(c in line for c in "#:{\x0c") and \
            (not line.split() or len(line.split()[0]) <= 8)
        assert bool(scan.simple[i]) == simple, line
        if not simple:
            continue
        assert scan.n_tokens[i] == len(line.split()), line
        if line.split():
            assert scan.combos[scan.combo[i]] == (line.split()[0], len(line.split()))
            tokens = scan.first_tok[i] + np.arange(len(line.split()))
            values, digits, texts = scan.numbers(tokens)
            parts = line.split()
            assert [p for p, d in zip(parts, digits) if not d] == texts
            for part, value, digit in zip(parts, values.tolist(), digits.tolist()):
                assert digit == (part.isdigit() and len(part) <= 15)
                if digit:
                    assert value == float(part)


def test_many_lines_left_to_the_per_statement_part_give_up(monkeypatch):
    """RLSE lines for every element (left to the per-statement part, one record each): past
    MAX_LEFT the per-statement semantics build the deck, with the same result."""
    monkeypatch.setattr(arrays, "MAX_LEFT", 100)
    text = _cantilever(N, data_extra=[f"RLSE {i} 4" for i in range(1, N + 1)]).replace(
        "DYNE", "DYNE").replace(" 1 2 3 4 5 6\n", " 1 2 3 5 6\n")
    spy = _Spy(monkeypatch)
    got = _arrays(text, "big.dat")
    assert (spy.built, spy.gave_up) == (0, 1) and got[0] == "job"
    assert got == _per_statement(text, "big.dat")
