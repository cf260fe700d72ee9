"""The fast path of the deck reader (spacarpy/deck/fastpath.py): plain lines (a keyword and
numbers) converted in batches with their locations made on demand, lines of words and
numbers lexed without Lark, and the short ways of the semantics for the usual element.

Every test compares against the general path (Lark lexing every line, the fast path switched
off): the statements, their locations and every error message must be the same, and a large
deck written out line by line must give the same model as its BEAMS generator form.
"""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import spacarpy.deck.fastpath as fastpath
import spacarpy.deck.fields as fields
import spacarpy.deck.lexer as lexer
import spacarpy.deck.parser as parser
from spacarpy.deck import job_from_text, parse_deck
from spacarpy.errors import DeckError

ROOT = Path(__file__).resolve().parents[1]
CORPUS = ROOT.parent / "shared" / "spacar-decks"

BASE = """\
X 1 0 0 0
X 3 1 0 0
BEAM 1 1 2 3 4 0 1 0
DYNE 1 1 2 3 4 5 6
FIX 1
FIX 2
END
HALT
ESTIFF 1 1e6 1e3 1e3 1e3
DELXF 3 0 1 0
END
END
"""


def _scanned(monkeypatch):
    """Read every text as a large one: its lines scanned with numpy (spacarpy/deck/linescan.py)
    and every run of simple lines appended to the batches at once."""
    monkeypatch.setattr(fastpath, "_SCAN_LINES", 0)
    monkeypatch.setattr(parser, "_RUN_LINES", 1)      # read by the parser's loop


def _general(monkeypatch):
    """Switch the fast path off: every line is lexed by Lark and checked field by field."""
    monkeypatch.setattr(fastpath, "_plain_kinds", lambda *args: None)
    monkeypatch.setattr(lexer, "_simple_tokens", lambda *args: None)


def _small_batch(monkeypatch, small: int) -> None:
    """Batches (and ranges) of fewer lines than ``small`` are converted line by line."""
    monkeypatch.setattr(fastpath, "_SMALL_BATCH", small)
    monkeypatch.setattr(fields, "_SMALL_BATCH", small)


def _outcome(text: str, name: str = "deck.dat", build: bool = False):
    """What reading the text gives: its statements (with their places) or the error text."""
    try:
        if build:
            job = job_from_text(text, name)
            return ("job", job.model.position_ids.tolist(), job.model.position_x0.tolist(),
                    {k: (es.ids.tolist(), es.nodes.tolist(), es.def_class.tolist(),
                         es.stiffness.tolist(), [loc.line for loc in es.locs])
                     for k, es in job.model.elements.items()})
        statements = parse_deck(text, name)
        return ("statements", [(st.keyword, st.fields, st.loc, st.field_locs, st.source_line,
                                st.module, st.origin) for st in statements])
    except DeckError as exc:
        return ("error", str(exc))


def _same_both_ways(monkeypatch, text: str, build: bool = False):
    fast = _outcome(text, build=build)
    with monkeypatch.context() as m:
        _general(m)
        general = _outcome(text, build=build)
    assert fast == general
    return fast


# lines the fast path must not take, or must take exactly as the general path does
ODD_LINES = [
    "X 5 0 0 1e999",                # not finite
    "X 5 0 0 inf",                  # a word, not a number
    "X 5 0 0 nan",
    "X 5 0 0 1_0",                  # float() reads it, the grammar does not
    "X 5 0 0 1.2.3",                # unreadable
    "X 5 0 0 1-2",
    "X 5 0 0 0x10",
    "X 5 0 0 .",
    "X 5 0 0 1e",
    "X 5 0 0 {1/0}",                # an expression that fails
    "X 5 0 0 {2*3}",                # an expression that works
    "X 5 0 0 1.0D-3",               # a Fortran exponent
    "X 5 0 0 \u0661",               # an Arabic-Indic digit: \\d in the grammar
    "X 5 0 0",                      # a missing field
    "X 5 0 0 0 0",                  # one too many
    "x 5 0 0 0",                    # lower case
    "X\t5\t0  0   0   # a comment",
    "X 5 0 0 0#glued comment",
    "X 5 0 0 0%glued comment",
    'X 5 0 0 "a#b"',
    "X 5.0 0 0 0",                  # a whole number written as a float
    "X 5.5 0 0 0",                  # not whole
    "X 0 0 0 0",                    # not positive
    "X 99999999999 0 0 0",          # out of range
    "X -3 0 0 0",
    "BEAM 2 3 4 5 6 0 1",           # a field missing at the end
    "BEAM 2 3 4",
    "5 0 0 0",                      # no keyword
    "X1 0 0 0",                     # keyword glued to a number
    "XX 5 0 0 0",                   # unknown keyword
    "DYNE 1:1 1 2",                 # a range
    "DYNE 1 7",                     # a mode the element does not have (semantics)
    "ESTIFF 1 -1 1 1 1",            # a negative stiffness (semantics)
    "GRAVITY 0 0 -9.81",
    "X 5 0 0 0 \x0c",
]


@pytest.mark.parametrize("line", ODD_LINES)
@pytest.mark.parametrize("where", ["kinematics", "data", "after the end", "continued"])
@pytest.mark.parametrize("batch", ["numpy", "line by line", "scanned"])
def test_odd_lines_read_as_the_general_path_reads_them(monkeypatch, line, where, batch):
    # a batch of this small deck is converted line by line unless told otherwise
    _small_batch(monkeypatch, 10**9 if batch == "line by line" else 0)
    if batch == "scanned":              # as a large deck: lines scanned and taken in runs
        _scanned(monkeypatch)
    lines = BASE.splitlines()
    if where == "kinematics":
        lines.insert(2, line)
    elif where == "data":
        lines.insert(9, line)
    elif where == "after the end":
        lines.append(line)
    else:                                   # a record split over two lines
        lines.insert(2, "BEAM 7 1 2 3")
        lines.insert(3, line.split(" ", 1)[-1])
    text = "\n".join(lines) + "\n"
    _same_both_ways(monkeypatch, text)
    _same_both_ways(monkeypatch, text, build=True)


def test_a_bad_number_is_reported_with_its_place():
    text = BASE.replace("X 3 1 0 0", "X 3 1 0 1e999")
    with pytest.raises(DeckError) as exc:
        parse_deck(text, "deck.dat")
    assert str(exc.value).splitlines()[0] == \
        "deck.dat:2:9: error: X: the z coordinate (m) '1e999' is out of range"
    with pytest.raises(DeckError) as exc:
        parse_deck(BASE.replace("BEAM 1 1 2 3 4", "BEAM 1.5 1 2 3 4"), "deck.dat")
    assert str(exc.value).splitlines()[0] == ("deck.dat:3:6: error: BEAM: expected the element "
                                              "number (a whole number), found '1.5'")


def test_a_missing_end_after_plain_lines(monkeypatch):
    _same_both_ways(monkeypatch, BASE.replace("END\nEND\n", "END\n"))
    _same_both_ways(monkeypatch, BASE.replace("HALT\n", "HALT\nX 9 0 0 0\n").replace(
        "DELXF 3 0 1 0\nEND\nEND\n", "DELXF 3 0 1 0\n"))


def test_fields_locations_and_lines_of_plain_statements():
    text = "  X   1 0.5   0 0   # start\r\nBEAM 1 1 2 3 4 0 1 0\n"
    x, beam = parse_deck(text, "d.dat")
    assert x.fields == (1, 0.5, 0.0, 0.0) and type(x.fields[0]) is int
    assert type(x.fields[2]) is float
    assert (x.file, x.line) == ("d.dat", 1)
    assert str(x.loc) == "d.dat:1:3"
    assert [loc.column for loc in x.field_locs] == [7, 9, 15, 17]
    assert x.source_line == "  X   1 0.5   0 0   # start"
    assert beam.fields == (1, 1, 2, 3, 4, 0.0, 1.0, 0.0)
    assert beam.replace(module=3).module == 3 and beam.replace(module=3).loc == beam.loc
    assert beam == beam.replace() and hash(beam) == hash(beam.replace())


def _shipped():
    return sorted((ROOT / "decks").rglob("*.dat"))


def _corpus():
    if not CORPUS.is_dir():
        return [pytest.param(None, marks=pytest.mark.skip(
            reason=f"the SPACAR deck corpus {CORPUS} is absent (../shared not beside the repo)"))]
    return sorted(CORPUS.rglob("*.dat"))


def test_there_are_shipped_decks_to_compare():
    assert len(_shipped()) >= 40        # decks/*.dat: the comparison below is not vacuous


def test_the_general_path_switch_takes_effect(monkeypatch):
    """_general really switches the fast path off (else the comparisons could not fail)."""
    assert any(type(st).__name__ == "_PlainStatement" for st in parse_deck(BASE, "d.dat"))
    with monkeypatch.context() as m:
        _general(m)
        statements = parse_deck(BASE, "d.dat")
    assert statements and all(type(st).__name__ == "Statement" for st in statements)


def _reads_the_same_both_ways(monkeypatch, path: Path) -> None:
    """The same statements with the same places, or the same errors, with and without the
    fast path: its batches converted with numpy, line by line, and scanned as a large deck."""
    text = path.read_text(encoding="utf-8", errors="replace")
    with monkeypatch.context() as m:
        _general(m)
        general = _outcome(text, str(path))
    for small in (0, 10**9):        # batches converted with numpy, and line by line
        with monkeypatch.context() as m:
            _small_batch(m, small)
            assert _outcome(text, str(path)) == general, path.name
    with monkeypatch.context() as m:  # scanned as a large deck
        _scanned(m)
        _small_batch(m, 0)
        assert _outcome(text, str(path)) == general, path.name


@pytest.mark.parametrize("path", _shipped(), ids=lambda p: p.name)
def test_every_shipped_deck_reads_the_same_both_ways(monkeypatch, path):
    _reads_the_same_both_ways(monkeypatch, path)


@pytest.mark.parametrize("path", _corpus(), ids=lambda p: getattr(p, "name", "corpus"))
def test_every_corpus_deck_reads_the_same_both_ways(monkeypatch, path):
    _reads_the_same_both_ways(monkeypatch, path)


def test_terminals_read_from_the_grammar_are_larks():
    from lark import Lark
    lark = Lark(lexer._GRAMMAR.read_text(encoding="utf-8"), parser="lalr", lexer="basic")
    compiled = {t.name: t.pattern.to_regexp() for t in lark.terminals}
    for name, pattern in lexer._TERMINALS.items():     # Lark writes \n as a line end
        assert compiled[name] == pattern.replace("\\n", "\n"), name


@pytest.mark.parametrize("line", [
    "", "END", "  DEFORMATIONS modified  # the paper's", 'TIMEFUNCTION expr "1 - t"#c',
    "EXPECT run.exit_code 1", "X 1 -2.5e3 .5 +3. 1D-3", "X 1 {2} 3", "X 1:3", "X 1abc",
    '"open', "A_b.c-d 1", "\t% only a comment", "X \u0661", "DYNE 1:10 1 2 3#c",
    "X 1:2:47 {n}:1", "X 1:{n} {a # b}", "X 1:2:3:4", "X 1: 2", "X {a}b", "X {a}:b",
    "X 1::2", "X {a}:{b}:{c}%c", 'X "a # b" 1:2'])
def test_lines_of_readable_fields_are_lexed_as_lark_lexes_them(line):
    _same_tokens_as_lark(line)


@settings(max_examples=300, deadline=None)
@given(st.lists(st.sampled_from(["1", "12", ":", "{", "}", "a", "X", ".", "-", "e", " ", "\t",
                                 "#", "%", '"', "n", "+"]), max_size=14).map("".join))
def test_any_line_is_lexed_as_lark_lexes_it_or_left_to_lark(line):
    _same_tokens_as_lark(line)


def _same_tokens_as_lark(line: str) -> None:
    """The tokens of lexer._simple_tokens are Lark's; a line it leaves to Lark has a BAD one."""
    mine = lexer._simple_tokens(line, 7)
    theirs = list(lexer._lark().lex(line))
    if mine is None:                        # not such a line: Lark's
        assert any(t.type == "BAD" for t in theirs), line
        return
    assert [(t.type, str(t), t.line, t.column, t.end_column) for t in mine] == \
        [(t.type, str(t), 7, t.column, t.end_column) for t in theirs], line


@pytest.mark.parametrize("ranges", [False, True])
def test_a_deck_of_plain_lines_or_ranges_is_read_without_lark(ranges, tmp_path):
    deck = ROOT / "decks" / "table1_cantilever_8el_modified.dat"
    if ranges:                          # properties given to elements 1:8 (a compact deck)
        from spacarpy.bench.cases import cantilever_deck
        deck = tmp_path / "compact.dat"
        deck.write_text(cantilever_deck(8, n_steps=2, compact=True))
        assert ":" in deck.read_text().split("ESTIFF", 1)[1].split("\n", 1)[0]
    code = ("import sys; from spacarpy.deck import load; load(sys.argv[1]); "
            "print(sorted(m for m in sys.modules if m == 'lark' or m.startswith('lark.')))")
    out = subprocess.run([sys.executable, "-c", code, str(deck)], capture_output=True,
                         text=True, check=True, cwd=ROOT)
    assert out.stdout.strip() == "[]"


def _cantilever(n: int, explicit: bool) -> str:
    """A straight cantilever of n BEAMs: the BEAMS generator line, or the same nodes and
    elements written out one line each (the generator's numbering: intermediate node k has
    position node 2k+3 and orientation node 2k+4)."""
    head = ["X 1 0 0 0"]
    if explicit:
        x = _generated_x(n)
        head += [f"X {2 * k + 3} {x[k - 1]!r} 0 0" for k in range(1, n)]
        pos = [1] + [2 * k + 3 for k in range(1, n)] + [3]
        rot = [2] + [2 * k + 4 for k in range(1, n)] + [4]
        body = [f"BEAM {i + 1} {pos[i]} {rot[i]} {pos[i + 1]} {rot[i + 1]} 0 1 0"
                for i in range(n)]
        body += [f"DYNE {i + 1} 1 2 3 4 5 6" for i in range(n)]
        data = [f"ESTIFF {i + 1} 2.07e9 1.1e6 1.725e6 1.725e6" for i in range(n)]
        data += [f"EM {i + 1} 78.5 0.13 0.065 0.065" for i in range(n)]
    else:
        body = [f"BEAMS 1 1 2 3 4 {n} 0 1 0", f"DYNE 1:{n} 1:6"]
        data = [f"ESTIFF 1:{n} 2.07e9 1.1e6 1.725e6 1.725e6",
                f"EM 1:{n} 78.5 0.13 0.065 0.065"]
    return "\n".join(head + body[:n] + ["X 3 2 0 0"] + body[n:] + [
        "FIX 1", "FIX 2", "END", "HALT"] + data + ["DELXF 3 0 100 0", "END", "END", ""])


def _generated_x(n: int) -> list[float]:
    job = job_from_text(_cantilever(n, explicit=False), "<beams>")
    ids = job.model.position_ids
    return [float(job.model.position_x0[ids.tolist().index(2 * k + 3), 0])
            for k in range(1, n)]


def test_a_large_deck_written_out_gives_the_model_of_its_generator_form():
    n = 2000
    explicit = job_from_text(_cantilever(n, explicit=True), "<explicit>").model
    generated = job_from_text(_cantilever(n, explicit=False), "<beams>").model
    assert explicit.position_ids.tolist() == generated.position_ids.tolist()
    assert np.array_equal(explicit.position_x0, generated.position_x0)
    assert explicit.orientation_ids.tolist() == generated.orientation_ids.tolist()
    a, b = explicit.elements["BEAM"], generated.elements["BEAM"]
    assert a.ids.tolist() == b.ids.tolist() == list(range(1, n + 1))
    for name in ("nodes", "vector", "def_class", "stiffness", "has_stiffness", "mass"):
        assert np.array_equal(getattr(a, name), getattr(b, name)), name
    assert [f.node for f in explicit.fixes] == [f.node for f in generated.fixes]
    # the explicit deck's element lines are where its BEAM lines are
    assert [loc.line for loc in a.locs[:3]] == [n + 1, n + 2, n + 3]
