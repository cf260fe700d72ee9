"""Tests of deck parsing (spacarpy.deck.parser) and deck -> Model building (spacarpy.deck.build)."""
from __future__ import annotations

import logging
import math
import re
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from spacarpy.deck import build_model, load_deck, parse_deck
from spacarpy.errors import DeckError
from spacarpy.model import FLEXIBLE, RELEASED, RIGID, Fix, IterStep, Load

CORPUS = Path(__file__).resolve().parents[1].parent / "shared" / "spacar-decks"

VALID = """\
# small test deck
X 1 0 0 0
X 3 1 0 0
X 5 2 0 0
BEAM 1 1 2 3 4 0 0 1
BEAM 2 3 4 5 6
DYNE 1 1 2 3 4 5 6
DYNE 2 1 3 4
RLSE 2 2
FIX 1
FIX 2
FIX 5 2
FIX 5 3 2
END
HALT
ESTIFF 1 1e7 1e3 2e3 3e3
ESTIFF 2 1e7 1e3 2e3 3e3 1e-4 2e-4
EM 1 2.0 0.1
XF 5 0 -1 0
DELXF 6 0 0 0.5
ITERSTEP 10 5 1e-8 1 3 2
END
END
VISUALIZATION
BEAMPROPS 1 2
CROSSTYPE RECT
"""


def build(text: str, **kw):
    return build_model(parse_deck(text, "t.dat"), text=text, path="t.dat", **kw)


def deck_error(text: str, **kw) -> DeckError:
    with pytest.raises(DeckError) as info:
        build(text, **kw)
    return info.value


def only_item(err: DeckError):
    assert len(err.items) == 1, str(err)
    loc, msg, _ = err.items[0]
    return loc.line, loc.column, msg


# A kinematically complete one-beam deck to which error tests add lines.
BASE = "X 1 0 0 0\nX 3 1 0 0\nBEAM 1 1 2 3 4\n"


# ------------------------------------------------------------------ valid decks

def test_valid_deck_builds_expected_model():
    m = build(VALID)
    np.testing.assert_array_equal(m.position_ids, [1, 3, 5])
    np.testing.assert_array_equal(m.position_x0, [[0, 0, 0], [1, 0, 0], [2, 0, 0]])
    np.testing.assert_array_equal(m.orientation_ids, [2, 4, 6])
    b = m.beams
    np.testing.assert_array_equal(b.ids, [1, 2])
    np.testing.assert_array_equal(b.nodes, [[1, 2, 3, 4], [3, 4, 5, 6]])
    np.testing.assert_array_equal(b.orientation[0], [0, 0, 1])
    assert np.isnan(b.orientation[1]).all()
    np.testing.assert_array_equal(b.def_class, [[FLEXIBLE] * 6,
                                                [FLEXIBLE, RELEASED, FLEXIBLE, FLEXIBLE,
                                                 RIGID, RIGID]])
    np.testing.assert_allclose(b.stiffness, [[1e7, 1e3, 2e3, 3e3, 0, 0],
                                             [1e7, 1e3, 2e3, 3e3, 1e-4, 2e-4]])
    np.testing.assert_array_equal(b.has_stiffness, [True, True])
    np.testing.assert_allclose(b.mass, [[2.0, 0.1, 0, 0, 0], [0, 0, 0, 0, 0]])
    assert [loc.line for loc in b.locs] == [5, 6]
    assert [(f.node, f.coords) for f in m.fixes] == [(1, (1, 2, 3)), (2, (1, 2, 3, 4)),
                                                     (5, (2, 3))]
    assert all(isinstance(f, Fix) for f in m.fixes)
    assert [(ld.node, ld.kind, ld.value) for ld in m.loads] == [
        (5, "XF", (0.0, -1.0, 0.0)), (6, "DELXF", (0.0, 0.0, 0.5))]
    assert all(isinstance(ld, Load) for ld in m.loads)
    it = m.iterstep
    assert (it.max_iter, it.n_steps, it.tol, it.n_init, it.extra) == (10, 5, 1e-8, 2, (1.0, 3.0))
    assert it.loc.line == 21
    assert m.analysis == "static" and m.deformations == "modified"
    assert m.source_path == "t.dat" and m.source_text == VALID


def test_statements_modules_and_locations():
    sts = parse_deck(VALID, "t.dat")
    kw = [s.keyword for s in sts]
    assert kw[:2] == ["X", "X"] and kw[-3:] == ["VISUALIZATION", "BEAMPROPS", "CROSSTYPE"]
    modules = {s.keyword: s.module for s in sts}
    assert modules["BEAM"] == 0 and modules["ESTIFF"] == 1 and modules["CROSSTYPE"] == -1
    beam = sts[3]
    assert beam.fields == (1, 1, 2, 3, 4, 0.0, 0.0, 1.0)
    assert isinstance(beam.fields[1], int) and isinstance(beam.fields[5], float)
    assert (beam.loc.line, beam.loc.column) == (5, 1)
    assert [fl.column for fl in beam.field_locs] == [6, 8, 10, 12, 14, 16, 18, 20]
    assert beam.source_line == "BEAM 1 1 2 3 4 0 0 1"
    assert sts[-1].fields == ("RECT",)


def test_keywords_case_insensitive():
    m = build(VALID.lower())
    assert m.beams.n_elem == 2 and m.iterstep.n_steps == 5
    assert parse_deck("beam 1 1 2 3 4\n")[0].keyword == "BEAM"


def test_comments_both_styles_and_trailing():
    text = ("% header\n# another\n\nX 1 0 0 0   % trailing\nX 3 1 0 0# no space\n"
            "   # indented comment\nBEAM 1 1 2 3 4  # beam\n")
    m = build(text)
    np.testing.assert_array_equal(m.position_ids, [1, 3])
    assert m.beams.n_elem == 1


def test_crlf_tabs_and_missing_final_newline():
    text = VALID.replace("\n", "\r\n").replace(" ", "\t").rstrip("\r\n")
    m = build(text)
    assert m.beams.n_elem == 2
    sts = parse_deck(text)
    assert not sts[0].source_line.endswith("\r")


def test_numbers_in_many_forms_and_int_from_float():
    text = "X 1.000000 1. .5 -1.5E+06\nX 2 1e-3 +2 1.0D-3\nITERSTEP 5.000000 1000.000000\n"
    sts = parse_deck(text)
    assert sts[0].fields == (1, 1.0, 0.5, -1.5e6)
    assert isinstance(sts[0].fields[0], int)
    assert sts[1].fields == (2, 1e-3, 2.0, 1e-3)
    assert sts[2].fields == (5, 1000)


def test_no_end_is_accepted_and_iterstep_defaults():
    m = build(BASE)
    assert m.beams.n_elem == 1
    assert m.iterstep == IterStep()


def test_iterstep_zero_steps_and_two_fields():
    m = build(BASE + "ITERSTEP 10 0 5e-7 1 3 0\n")
    assert (m.iterstep.n_steps, m.iterstep.n_init) == (1, 1)
    m = build(BASE + "ITERSTEP 5.0 1000.0\n")
    assert (m.iterstep.max_iter, m.iterstep.n_steps, m.iterstep.tol) == (5, 1000, 5e-7)


@pytest.mark.parametrize("value, expected", [
    ("static", "static"), ("EIGEN", "eigen"), ("10", "static"), ("-10", "static"),
    ("0", "check"), ("1", "transient"), ("8", "buckling"), ("4", "eigen"), ("7.0", "eigen"),
    ("-4", "eigen"), ('"buckling"', "buckling")])
def test_mode_extension(value, expected):
    assert build(BASE + f"MODE {value}\n").analysis == expected


def test_mode_invalid_lists_valid_values():
    line, col, msg = only_item(deck_error(BASE + "MODE 9\n"))
    assert (line, col) == (4, 6)
    assert "unknown analysis '9'" in msg and "static" in msg and "10=static" in msg


def test_deformations_extension_and_command_line_overrides():
    m = build(BASE + "DEFORMATIONS basic\nMODE eigen\n")
    assert (m.deformations, m.analysis) == ("basic", "eigen")
    m = build(BASE + "DEFORMATIONS basic\nMODE eigen\n", deformations="modified",
              analysis="buckling")
    assert (m.deformations, m.analysis) == ("modified", "buckling")
    line, col, msg = only_item(deck_error(BASE + "DEFORMATIONS fancy\n"))
    assert (line, col) == (4, 14) and "expected modified or basic" in msg
    err = deck_error(BASE, analysis="nonsense")
    assert err.items[0][0] is None and "unknown analysis" in err.items[0][1]


def test_estiff_seventh_value_warns(caplog):
    text = BASE + "DYNE 1 1\nESTIFF 1 1 2 3 4 5 6 7\n"
    with caplog.at_level(logging.WARNING, logger="spacarpy.deck.build"):
        m = build(text)
    np.testing.assert_allclose(m.beams.stiffness[0], [1, 2, 3, 4, 5, 6])
    assert any("7th value" in r.getMessage() for r in caplog.records)


def test_unconnected_position_node_warns(caplog):
    with caplog.at_level(logging.WARNING, logger="spacarpy.deck.build"):
        m = build(BASE + "X 9 5 5 5\n")
    assert 9 in m.position_ids
    assert any("node 9 is not connected" in r.getMessage() for r in caplog.records)


def test_load_deck_reads_file_and_reports_missing(tmp_path):
    p = tmp_path / "d.dat"
    p.write_bytes(("# caf\u00e9\n" + BASE).encode("latin-1"))
    m = load_deck(p, analysis="eigen")
    assert m.analysis == "eigen" and m.source_path == str(p)
    with pytest.raises(DeckError, match="no such file"):
        load_deck(tmp_path / "missing.dat")


# ------------------------------------------------------------------ the corpus of real decks

def corpus_decks():
    if not CORPUS.is_dir():
        return [pytest.param(None, marks=pytest.mark.skip(
            reason=f"corpus directory {CORPUS} is absent (shared/spacar-decks not checked out)"))]
    return sorted(CORPUS.glob("*.dat"))


@pytest.mark.parametrize("path", corpus_decks(), ids=lambda p: getattr(p, "name", "none"))
def test_corpus_deck_parses(path):
    text = path.read_text(encoding="latin-1")
    sts = parse_deck(text, str(path))
    assert sts and any(s.keyword == "END" for s in sts)


def corpus_path(name: str) -> Path:
    path = CORPUS / name
    if not path.is_file():
        pytest.skip(f"corpus deck {path} is absent")
    return path


def test_corpus_spatools_cantilever_builds():
    m = load_deck(corpus_path("spatools_cantilever.dat"))
    np.testing.assert_array_equal(m.position_ids, [1, 3, 5, 7, 9])
    np.testing.assert_array_equal(m.orientation_ids, [2, 4, 6, 8, 10])
    np.testing.assert_array_equal(m.beams.ids, [1, 2, 3, 4])
    assert (m.beams.def_class == FLEXIBLE).all()
    np.testing.assert_allclose(m.beams.stiffness[0], [525e6, 63082.154762, 109375, 109375,
                                                      0.000729, 0.000729])
    np.testing.assert_allclose(m.beams.orientation, [[0, 0, 1]] * 4)
    assert [(f.node, f.coords) for f in m.fixes] == [(1, (1, 2, 3)), (2, (1, 2, 3, 4))]
    assert [(ld.node, ld.kind) for ld in m.loads] == [(3, "DELXF"), (3, "XF")]
    assert (m.iterstep.max_iter, m.iterstep.n_steps, m.iterstep.n_init) == (10, 9, 9)
    assert m.iterstep.extra == (1.0, 3.0)


def test_corpus_dynastatflex_builds():
    m = load_deck(corpus_path("dynastatflex_simple_beam.dat"))
    np.testing.assert_array_equal(m.position_ids, np.arange(1, 50, 2))
    np.testing.assert_array_equal(m.orientation_ids, np.arange(2, 51, 2))
    assert m.beams.n_elem == 24
    # the deck makes only the bending modes 3 and 4 flexible (DYNE e 3 4)
    np.testing.assert_array_equal(m.beams.def_class,
                                  [[RIGID, RIGID, FLEXIBLE, FLEXIBLE, RIGID, RIGID]] * 24)
    assert [(ld.node, ld.kind, ld.value) for ld in m.loads] == [(26, "DELXF", (0.0, 0.0, 0.3))]
    assert (m.iterstep.n_steps, m.iterstep.n_init) == (4, 1)


def test_corpus_slidercrank_refuses_hinge():
    path = corpus_path("oopspa_slidercrank.dat")
    with pytest.raises(DeckError) as info:
        load_deck(path)
    items = info.value.items
    assert all(msg.startswith("not supported yet: ") for _, msg, _ in items), str(info.value)
    hinges = [(loc.line, loc.column) for loc, msg, _ in items if msg == "not supported yet: HINGE"]
    assert hinges == [(16, 1), (18, 1)]
    assert f"{path}:16:1: error: not supported yet: HINGE" in str(info.value)


# ------------------------------------------------------------------ syntax errors

def test_unknown_keyword_did_you_mean():
    with pytest.raises(DeckError) as info:
        parse_deck("X 1 0 0 0\n  BEEM 1 1 2 3 4\n", "d.dat")
    assert only_item(info.value) == (2, 3, "unknown keyword 'BEEM' (did you mean BEAM?)")
    text = str(info.value)
    assert text.startswith("d.dat:2:3: error: unknown keyword 'BEEM'")
    assert text.splitlines()[2] == "    " + "  ^"


def test_unknown_keyword_without_close_match():
    with pytest.raises(DeckError) as info:
        parse_deck("QQQQQQ 1\n")
    assert only_item(info.value)[2] == "unknown keyword 'QQQQQQ'"


def test_visualization_keyword_before_final_end():
    with pytest.raises(DeckError) as info:
        parse_deck("COLOR 0 0 0\n")
    assert "VISUALIZATION section" in only_item(info.value)[2]


def test_wrong_field_count_too_few_and_too_many():
    with pytest.raises(DeckError) as info:
        parse_deck("X 1 0 0 0\nBEAM 1 1 2 3\n")
    line, col, msg = only_item(info.value)
    assert (line, col) == (2, 13)
    assert msg.startswith("BEAM takes 5 or 8 fields, got 4")
    with pytest.raises(DeckError) as info:
        parse_deck("X 1 0 0 0 7\n")
    assert only_item(info.value)[:2] == (1, 11)
    assert "X takes exactly 4 fields, got 5" in only_item(info.value)[2]
    with pytest.raises(DeckError) as info:
        parse_deck("END 1\n")
    assert "END takes no fields, got 1" in only_item(info.value)[2]


def test_word_where_number_expected():
    with pytest.raises(DeckError) as info:
        parse_deck("X 1 zero 0 0\n")
    assert only_item(info.value) == (
        1, 5, "X: expected the x coordinate (m) (a number), found 'zero'")


def test_fraction_where_whole_number_expected():
    with pytest.raises(DeckError) as info:
        parse_deck("BEAM 1 1 2.5 3 4\n", "deck.dat")
    assert only_item(info.value) == (
        1, 10, "BEAM: expected the orientation node at p (a whole number), found '2.5'")


def test_non_positive_node_number():
    with pytest.raises(DeckError) as info:
        parse_deck("X 0 0 0 0\n")
    assert "must be a positive whole number" in only_item(info.value)[2]


def test_bad_character():
    with pytest.raises(DeckError) as info:
        parse_deck("X 1 0 0 0\nX 2 0 @ 0\n", "d.dat")
    assert only_item(info.value)[:2] == (2, 7)
    assert "unexpected character '@'" in only_item(info.value)[2]


def test_malformed_number_and_unterminated_string():
    with pytest.raises(DeckError) as info:
        parse_deck("X 1 0 1abc 0\n")
    assert only_item(info.value)[:2] == (1, 7)
    assert "cannot read '1abc'" in only_item(info.value)[2]
    with pytest.raises(DeckError) as info:
        parse_deck('USERSIG "name\n')
    assert only_item(info.value)[:2] == (1, 9)
    assert "unterminated string" in only_item(info.value)[2]


def test_line_starting_with_number():
    with pytest.raises(DeckError) as info:
        parse_deck("X 1 0 0 0\n1 2 3\n")
    line, col, msg = only_item(info.value)
    assert (line, col) == (2, 1) and "expected a keyword" in msg


def test_text_after_final_end():
    with pytest.raises(DeckError) as info:
        parse_deck(BASE + "END\nEND\nX 9 0 0 0\n")
    assert only_item(info.value)[:2] == (6, 1)
    assert "text after the final END" in only_item(info.value)[2]


def test_halt_must_follow_end():
    with pytest.raises(DeckError) as info:
        parse_deck(BASE + "HALT\n")
    assert only_item(info.value)[:2] == (4, 1)


# ------------------------------------------------------------------ semantic errors

def test_unknown_position_node():
    line, col, msg = only_item(deck_error("X 1 0 0 0\nBEAM 1 1 2 3 4\n"))
    assert (line, col) == (2, 12)
    assert msg == "element 1: position node 3 (at q) has no X line"


def test_position_node_used_as_orientation_node():
    line, col, msg = only_item(deck_error("X 1 0 0 0\nX 3 1 0 0\nBEAM 1 1 3 3 4\n"))
    assert (line, col) == (3, 10)
    assert "node 3 is a position node (X at line 2)" in msg


def test_duplicate_x_names_both_lines():
    line, col, msg = only_item(deck_error(BASE + "X 3 2 0 0\n"))
    assert (line, col) == (4, 3) and "lines 2 and 4" in msg


def test_duplicate_element():
    line, col, msg = only_item(deck_error(BASE + "BEAM 1 3 4 1 2\n"))
    assert (line, col) == (4, 6)
    assert msg == "element 1 is defined twice (lines 3 and 4)"


def test_zero_length_element():
    line, col, msg = only_item(deck_error("X 1 0 0 0\nX 3 0 0 0\nBEAM 7 1 2 3 4\n"))
    assert (line, col) == (3, 1)
    assert "element 7 has zero length" in msg and "nodes 1 and 3" in msg


def test_parallel_orientation_vector():
    line, col, msg = only_item(deck_error("X 1 0 0 0\nX 3 1 0 0\nBEAM 1 1 2 3 4 2 0 0\n"))
    assert (line, col) == (3, 16)
    assert "parallel to the element axis" in msg


def test_zero_orientation_vector():
    line, col, msg = only_item(deck_error("X 1 0 0 0\nX 3 1 0 0\nBEAM 1 1 2 3 4 0 0 0\n"))
    assert (line, col) == (3, 16) and "(nearly) zero" in msg


def test_dyne_mode_seven():
    line, col, msg = only_item(deck_error(BASE + "DYNE 1 1 7\nESTIFF 1 1 1 1 1\n"))
    assert (line, col) == (4, 10)
    assert "deformation modes 1 to 6, got 7" in msg


def test_dyne_without_estiff():
    line, col, msg = only_item(deck_error(BASE + "DYNE 1 2\n"))
    assert (line, col) == (4, 8)
    assert msg == ("element 1 mode 2 is flexible (DYNE) but has no stiffness: "
                   "add ESTIFF 1 EA GJ EIy EIz")


def test_dyne_with_zero_stiffness():
    line, col, msg = only_item(deck_error(BASE + "DYNE 1 1 2\nESTIFF 1 1 0 1 1\n"))
    assert (line, col) == (4, 10)
    assert "mode 2 is flexible (DYNE) but the stiffness GJ is zero" in msg


def test_dyne_without_modes_and_both_dyne_and_rlse():
    err = deck_error(BASE + "DYNE 1\nDYNE 1 3\nRLSE 1 3\nESTIFF 1 1 1 1 1\n")
    msgs = [(loc.line, msg) for loc, msg, _ in err.items]
    assert msgs[0][0] == 4 and "expected deformation mode numbers" in msgs[0][1]
    assert msgs[1][0] == 6 and "listed in both DYNE (line 5) and RLSE (line 6)" in msgs[1][1]


def test_element_data_for_unknown_element():
    err = deck_error(BASE + "DYNE 5 1\nESTIFF 5 1 1 1 1\nEM 5 1\n")
    assert [(loc.line, loc.column) for loc, _, _ in err.items] == [(4, 6), (5, 8), (6, 4)]
    assert all("element 5 is not defined" in msg for _, msg, _ in err.items)


def test_estiff_too_few_and_negative():
    err = deck_error(BASE + "ESTIFF 1 1 2\nEM 1 -1\n")
    assert "needs EA GJ EIy EIz" in err.items[0][1]
    assert err.items[1][0].line == 5 and "rhoA must not be negative" in err.items[1][1]
    line, col, msg = only_item(deck_error(BASE + "ESTIFF 1 1 -2 3 4\n"))
    assert (line, col) == (4, 12) and "GJ must not be negative" in msg


def test_fix_coordinate_five_on_position_node():
    line, col, msg = only_item(deck_error(BASE + "FIX 1 5\n"))
    assert (line, col) == (4, 7)
    assert msg == "FIX: node 1 is a position node with coordinates 1 to 3, got 5"
    # coordinate 4 is fine on an orientation node, 5 is not
    assert build(BASE + "FIX 2 4\n").fixes[0].coords == (4,)
    assert "orientation node with coordinates 1 to 4" in only_item(
        deck_error(BASE + "FIX 2 5\n"))[2]


def test_fix_and_load_on_unknown_node():
    err = deck_error(BASE + "FIX 8\nXF 9 1 0 0\n")
    assert [(loc.line, loc.column) for loc, _, _ in err.items] == [(4, 5), (5, 4)]
    assert "node 8 is not defined" in err.items[0][1]


def test_unsupported_keyword_one_error_each():
    err = deck_error(BASE + "GRAVITY 0 0 -9.81\nXM 1 0.1\nXM 3 0.1\n")
    assert [(loc.line, msg) for loc, msg, _ in err.items] == [
        (4, "not supported yet: GRAVITY"), (5, "not supported yet: XM"),
        (6, "not supported yet: XM")]


def test_several_errors_reported_at_once_ordered_by_line():
    text = ("X 1 0 0 0\nX 3 0 0 0\nBEAM 1 1 2 3 4\nBEAM 2 1 2 9 4\n"
            "DYNE 1 7\nFIX 3 5\nHINGE 3 2 4 0 0 1\n")
    err = deck_error(text)
    lines = [loc.line for loc, _, _ in err.items]
    assert lines == sorted(lines) and lines == [3, 4, 5, 6, 7]
    assert str(err).endswith("5 errors")
    assert "t.dat:4:12: error: element 2: position node 9 (at q) has no X line" in str(err)


def test_several_syntax_errors_reported_at_once():
    with pytest.raises(DeckError) as info:
        parse_deck("X 1 a 0 0\nBEEM 1\nFIX x\n")
    assert [loc.line for loc, _, _ in info.value.items] == [1, 2, 3]


# ------------------------------------------------------------------ robustness

_TOKENS = ["BEAM", "END", "X", "HALT", "FIX", "DYNE", "RLSE", "ESTIFF", "XF", "ITERSTEP", "MODE",
           "HINGE", "VISUALIZATION", "1", "2", "7", "0", "-3", "2.5", "1e400", "-1e-3", ".", "abc",
           '"s"', "#", "%", "\n", "\t", "1abc"]
_CHARS = list("0123456789 .-+eE#%\"\n\r\tXxBEAMENDé@,;") + ["\x00", "\x0c", "\u2028"]


@st.composite
def mutated_decks(draw):
    text = VALID
    for _ in range(draw(st.integers(1, 4))):
        if draw(st.booleans()):                       # character level
            i = draw(st.integers(0, len(text)))
            op = draw(st.sampled_from(["delete", "duplicate", "insert"]))
            if op == "delete":
                text = text[:i] + text[i + 1:]
            elif op == "duplicate":
                text = text[:i] + text[i:i + 1] + text[i:]
            else:
                text = text[:i] + draw(st.sampled_from(_CHARS)) + text[i:]
        else:                                         # token level
            parts = re.split(r"(\s+)", text)
            words = [k for k, p in enumerate(parts) if p and not p.isspace()]
            k = draw(st.sampled_from(words)) if words else 0
            op = draw(st.sampled_from(["delete", "duplicate", "insert", "replace"]))
            if op == "delete":
                parts[k] = ""
            elif op == "duplicate":
                parts[k] = parts[k] + " " + parts[k]
            elif op == "insert":
                parts[k] = draw(st.sampled_from(_TOKENS)) + " " + parts[k]
            else:
                parts[k] = draw(st.sampled_from(_TOKENS))
            text = "".join(parts)
    return text


@settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(mutated_decks())
def test_mutated_decks_only_raise_deck_errors(text):
    n_lines = text.count("\n") + 1
    try:
        build(text)
    except DeckError as exc:
        assert exc.loc is not None
        assert 1 <= exc.loc.line <= n_lines + 1
        assert exc.loc.column >= 1
        for loc, msg, _ in exc.items:
            assert loc is not None and 1 <= loc.line <= n_lines + 1 and msg
        assert str(exc)
    # warnings are allowed; anything but DeckError propagates and fails the test


def test_nan_never_leaks_into_coordinates():
    m = build(VALID)
    assert all(math.isfinite(v) for v in m.position_x0.ravel())
